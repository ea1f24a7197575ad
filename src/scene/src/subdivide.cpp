// A model split to a longest edge, for the building's per-vertex light (see site.hpp,
// subdivide and load_site_model).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "skylit/scene/site.hpp"

namespace skylit::scene {
namespace {

// The midpoint of edge (a, b), made once and shared by both triangles on the edge.
class Midpoints {
 public:
  explicit Midpoints(Mesh& mesh) : mesh_(mesh) {}
  std::uint32_t of(std::uint32_t a, std::uint32_t b) {
    const std::pair<std::uint32_t, std::uint32_t> key = std::minmax(a, b);
    if (const auto found = made_.find(key); found != made_.end()) return found->second;
    const auto index = static_cast<std::uint32_t>(mesh_.positions.size());
    mesh_.positions.push_back(0.5f * (mesh_.positions[a] + mesh_.positions[b]));
    const Eigen::Vector3f n = mesh_.normals[a] + mesh_.normals[b];
    mesh_.normals.push_back(n.norm() > 0.0f ? Eigen::Vector3f(n.normalized()) : mesh_.normals[a]);
    if (!mesh_.texcoords.empty()) mesh_.texcoords.push_back(0.5f * (mesh_.texcoords[a] + mesh_.texcoords[b]));
    made_.emplace(key, index);
    return index;
  }

 private:
  Mesh& mesh_;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> made_;
};

}  // namespace

void subdivide(Mesh& mesh, double max_edge) {
  if (!std::isfinite(max_edge) || max_edge <= 0.0) return;
  const float limit = static_cast<float>(max_edge);
  if (mesh.texcoords.size() != mesh.positions.size()) mesh.texcoords.clear();
  // Rounds of one-into-four splits of the triangles still too long, until none is.
  for (bool split = true; split;) {
    split = false;
    Midpoints midpoints(mesh);
    std::vector<std::uint32_t> indices;
    std::vector<std::uint32_t> materials;
    indices.reserve(mesh.indices.size());
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      const std::uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
      const std::uint32_t material = t / 3 < mesh.triangle_material.size() ? mesh.triangle_material[t / 3] : 0u;
      const float longest = std::max({(mesh.positions[a] - mesh.positions[b]).norm(), (mesh.positions[b] - mesh.positions[c]).norm(),
                                      (mesh.positions[c] - mesh.positions[a]).norm()});
      if (!(longest > limit)) {
        indices.insert(indices.end(), {a, b, c});
        materials.push_back(material);
        continue;
      }
      split = true;
      const std::uint32_t ab = midpoints.of(a, b), bc = midpoints.of(b, c), ca = midpoints.of(c, a);
      indices.insert(indices.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
      materials.insert(materials.end(), {material, material, material, material});
    }
    mesh.indices = std::move(indices);
    if (!mesh.triangle_material.empty()) mesh.triangle_material = std::move(materials);
  }
}

Mesh load_site_model(const Site& site) {
  Mesh mesh = load_model(site.model, site.up, site.scale);
  subdivide(mesh, site.max_edge);
  return mesh;
}

}  // namespace skylit::scene
