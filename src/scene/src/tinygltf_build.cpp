// tinygltf, Debian's header, compiled here with its decoder of KHR_draco_mesh_compression on
// (Debian's libtinygltf is built without it): Draco meshes decode into plain buffers and
// accessors, which the model loader then reads as any other. Images decode through Debian's stb.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_ENABLE_DRACO
#include <tiny_gltf.h>
