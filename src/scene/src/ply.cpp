// The PLY writer: a text header, then the vertices and faces as little-endian binary records.
#include "skylit/scene/ply.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <stdexcept>

#include "skylit/base/files.hpp"

namespace skylit::scene {
namespace {

static_assert(std::endian::native == std::endian::little, "the PLY writer writes the host's little-endian bytes");

template <typename T>
void append(std::vector<std::byte>& out, const T& value) {
  const auto* bytes = reinterpret_cast<const std::byte*>(&value);
  out.insert(out.end(), bytes, bytes + sizeof(T));
}

bool is_word(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  });
}

}  // namespace

void write_ply(const std::filesystem::path& file, const Mesh& mesh, std::span<const std::array<std::uint8_t, 3>> colours,
               std::span<const VertexProperty> properties) {
  const std::size_t n = mesh.vertex_count();
  if (!colours.empty() && colours.size() != n) throw std::invalid_argument("write_ply: one colour per vertex");
  if (mesh.normals.size() != n) throw std::invalid_argument("write_ply: one normal per vertex");
  for (const VertexProperty& p : properties) {
    if (p.values.size() != n) throw std::invalid_argument("write_ply: property '" + p.name + "' needs one value per vertex");
    if (!is_word(p.name)) throw std::invalid_argument("write_ply: '" + p.name + "' is not a PLY property name");
  }
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment skylit\nelement vertex " + std::to_string(n) +
                       "\nproperty float x\nproperty float y\nproperty float z\n"
                       "property float nx\nproperty float ny\nproperty float nz\n";
  if (!colours.empty()) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (const VertexProperty& p : properties) header += "property float " + p.name + "\n";
  header += "element face " + std::to_string(mesh.triangle_count()) + "\nproperty list uchar uint vertex_indices\nend_header\n";

  std::vector<std::byte> out(header.size());
  std::memcpy(out.data(), header.data(), header.size());
  for (std::size_t v = 0; v < n; ++v) {
    for (int k = 0; k < 3; ++k) append(out, mesh.positions[v][k]);
    for (int k = 0; k < 3; ++k) append(out, mesh.normals[v][k]);
    if (!colours.empty()) {
      for (std::uint8_t c : colours[v]) append(out, c);
    }
    for (const VertexProperty& p : properties) append(out, p.values[v]);
  }
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    append(out, std::uint8_t{3});
    for (int k = 0; k < 3; ++k) append(out, mesh.indices[3 * t + static_cast<std::size_t>(k)]);
  }
  write_file_atomic(file, out);
}

}  // namespace skylit::scene
