// The model's flat regions (flat_regions.hpp).
#include "flat_regions.hpp"

#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <numeric>

namespace skylit::baker {
namespace flat_regions_detail {

struct UnionFind {
  std::vector<std::size_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), std::size_t{0}); }
  std::size_t find(std::size_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void join(std::size_t a, std::size_t b) { parent[find(a)] = find(b); }
};

// A vertex position welded to the millimetre, so that faces joined in space join here even where
// the model repeats a vertex for each face.
std::array<long, 3> weld(const Eigen::Vector3f& p) {
  return {std::lround(p.x() * 1000.0f), std::lround(p.y() * 1000.0f), std::lround(p.z() * 1000.0f)};
}

}  // namespace flat_regions_detail

FlatFaces flat_faces(const scene::Mesh& mesh) {
  const std::size_t triangles = mesh.triangle_count();
  FlatFaces f;
  f.normal.resize(triangles);
  f.area.resize(triangles);
  for (std::size_t t = 0; t < triangles; ++t) {
    const Eigen::Vector3d a = mesh.positions[mesh.indices[3 * t]].cast<double>();
    const Eigen::Vector3d cross =
        (mesh.positions[mesh.indices[3 * t + 1]].cast<double>() - a).cross(mesh.positions[mesh.indices[3 * t + 2]].cast<double>() - a);
    f.area[t] = 0.5 * cross.norm();
    f.normal[t] = f.area[t] > 0.0 ? Eigen::Vector3d(cross.normalized()) : Eigen::Vector3d::Zero();
  }
  return f;
}

std::vector<FlatRegion> flat_regions(const scene::Mesh& mesh, const FlatFaces& faces) {
  using flat_regions_detail::UnionFind, flat_regions_detail::weld;
  const std::size_t triangles = mesh.triangle_count();
  const auto corner = [&](std::size_t t, std::size_t k) { return mesh.positions[mesh.indices[3 * t + k]].cast<double>(); };
  UnionFind sets(triangles);
  std::map<std::pair<std::array<long, 3>, std::array<long, 3>>, std::size_t> first_on_edge;
  const double cos_flat = std::cos(std::numbers::pi / 180.0);
  for (std::size_t t = 0; t < triangles; ++t) {
    if (faces.area[t] <= 0.0) continue;
    for (std::size_t e = 0; e < 3; ++e) {
      auto a = weld(mesh.positions[mesh.indices[3 * t + e]]), b = weld(mesh.positions[mesh.indices[3 * t + (e + 1) % 3]]);
      if (b < a) std::swap(a, b);
      const auto [it, inserted] = first_on_edge.try_emplace({a, b}, t);
      if (inserted) continue;
      const std::size_t u = it->second;
      if (faces.normal[u].dot(faces.normal[t]) >= cos_flat && std::abs(faces.normal[u].dot(corner(t, 0) - corner(u, 0))) <= 0.01) {
        sets.join(u, t);
      }
    }
  }
  std::map<std::size_t, std::size_t> region_of_root;
  std::vector<FlatRegion> regions;
  for (std::size_t t = 0; t < triangles; ++t) {
    if (faces.area[t] <= 0.0) continue;
    const auto [it, inserted] = region_of_root.try_emplace(sets.find(t), regions.size());
    if (inserted) regions.emplace_back();
    FlatRegion& r = regions[it->second];
    r.triangles.push_back(t);
    r.normal += faces.area[t] * faces.normal[t];
    r.area += faces.area[t];
  }
  for (FlatRegion& r : regions) {
    if (r.normal.norm() > 0.0) r.normal.normalize();
  }
  return regions;
}

}  // namespace skylit::baker
