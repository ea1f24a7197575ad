#pragma once
// KHR_draco_mesh_compression: a glTF primitive's compressed vertices and triangles, decoded by
// Draco's library with every id and count checked (the model loader's only use of Draco).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace skylit::scene {

struct DracoPrimitive {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3d> normals;    // empty when the primitive has none
  std::vector<Eigen::Vector2f> texcoords;  // empty when none was asked for
  std::vector<std::uint32_t> indices;      // three per triangle, each below positions.size()
};

// Draco attribute unique ids, as the extension's `attributes` names them; -1 for none.
struct DracoAttributeIds {
  int position = -1;
  int normal = -1;
  int texcoord = -1;
};

// Decodes `data` (the extension's buffer view). Throws std::runtime_error with the problem (no
// mesh, an id it lacks, an attribute of the wrong size) for data that is not such a mesh.
DracoPrimitive decode_draco_primitive(std::span<const unsigned char> data, const DracoAttributeIds& ids);

}  // namespace skylit::scene
