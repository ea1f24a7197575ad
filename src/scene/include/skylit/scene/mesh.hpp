#pragma once
// A triangle mesh in the site frame (metres, x east, y north, z up), ready for baking and drawing.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace skylit::scene {

// A decoded texture image: 8-bit RGBA, rows from the top of the picture down, as stored in the
// file (glTF's texture coordinate (0, 0) is the top-left corner). A colour texture holds
// sRGB-encoded values, as glTF says of baseColorTexture.
struct TextureImage {
  std::string name;
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  // width × height × 4, row-major
};

struct Material {
  std::string name;
  Eigen::Vector4f base_colour{1.0f, 1.0f, 1.0f, 1.0f};  // linear RGBA (glTF baseColorFactor)
  // Into Mesh::textures, or -1: multiplies base_colour (glTF baseColorTexture), read at the
  // vertices' texcoords.
  int base_colour_texture = -1;
};

struct Mesh {
  std::vector<Eigen::Vector3f> positions;   // site frame, metres
  std::vector<Eigen::Vector3f> normals;     // unit, one per position (computed when absent)
  std::vector<std::uint32_t> indices;       // three per triangle, counter-clockwise outside
  std::vector<std::uint32_t> triangle_material;  // one per triangle, into materials
  std::vector<Material> materials;
  // One per position, or empty when the model has none (glTF TEXCOORD_n of the base-colour
  // texture). Reading them never changes the vertex order, which the baked transfer vectors
  // follow. OBJ texture coordinates are not read.
  std::vector<Eigen::Vector2f> texcoords;
  std::vector<TextureImage> textures;

  std::size_t vertex_count() const { return positions.size(); }
  std::size_t triangle_count() const { return indices.size() / 3; }
  Eigen::Vector3f bounds_min() const;
  Eigen::Vector3f bounds_max() const;
};

enum class UpAxis { Z, Y };

// Loads a glTF 2.0 (.gltf/.glb) or OBJ model and brings it into the site frame: node transforms
// applied, y-up models rotated to z-up (x stays east, model -z becomes north), scaled to metres.
// Vertex order is deterministic (scene nodes in order, primitives in order), so per-vertex data
// baked from one load matches another load of the same file. glTF base-colour textures are
// decoded (PNG, JPEG); one that cannot be decoded is left out (its material keeps its factor).
// Throws InputError (naming the file and the fix) for a missing, unreadable or empty model.
Mesh load_model(const std::filesystem::path& file, UpAxis up, double scale);

// Writes a mesh as binary glTF 2.0 (y-up, as the standard says), so it opens in Blender.
void write_glb(const Mesh& mesh, const std::filesystem::path& file);

}  // namespace skylit::scene
