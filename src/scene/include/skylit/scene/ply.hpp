#pragma once
// A model with values per vertex as a PLY file (binary, little-endian): what MeshLab, Blender,
// CloudCompare and Open3D open, for looking at the building's light and for any other tool.
#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "skylit/scene/mesh.hpp"

namespace skylit::scene {

// A float property of every vertex, e.g. "irradiance_r".
struct VertexProperty {
  std::string name;
  std::vector<float> values;  // one per vertex
};

// Writes the mesh's positions and normals, `colours` as the red, green and blue a viewer shows
// (one per vertex, or empty), each extra property, and the triangles; atomically.
// std::invalid_argument when a column's length is not the vertex count or a name is not a
// PLY word.
void write_ply(const std::filesystem::path& file, const Mesh& mesh, std::span<const std::array<std::uint8_t, 3>> colours,
               std::span<const VertexProperty> properties);

}  // namespace skylit::scene
