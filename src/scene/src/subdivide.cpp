// A model split to a longest edge, or where a bake found the light changing, for the building's
// per-vertex light (see site.hpp: subdivide, split_edges, apply_refinement, load_site_model).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
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

// The marked edges of triangle t: bit e for its edge from corner e to corner e + 1.
unsigned marked_sides(const Mesh& mesh, std::size_t t, const std::set<Edge>& marked) {
  unsigned sides = 0;
  for (unsigned e = 0; e < 3; ++e) {
    const Edge key = std::minmax(mesh.indices[3 * t + e], mesh.indices[3 * t + (e + 1) % 3]);
    if (marked.count(key)) sides |= 1u << e;
  }
  return sides;
}

}  // namespace

std::size_t Refinement::split_count() const {
  std::size_t n = 0;
  for (const std::vector<Edge>& round : rounds) n += round.size();
  return n;
}

std::vector<Edge> split_edges(Mesh& mesh, std::span<const Edge> marked) {
  std::set<Edge> edges;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    for (std::size_t e = 0; e < 3; ++e) edges.insert(std::minmax(mesh.indices[3 * t + e], mesh.indices[3 * t + (e + 1) % 3]));
  }
  std::set<Edge> split;
  for (const Edge& edge : marked) {
    const Edge key = std::minmax(edge.first, edge.second);
    if (!edges.count(key)) {
      throw std::invalid_argument("split_edges: (" + std::to_string(edge.first) + ", " + std::to_string(edge.second) +
                                  ") is not an edge of the mesh");
    }
    split.insert(key);
  }
  // Edges with the same ends in space (a crease, where each face has its own vertices) split
  // together, so that no face keeps a vertex of its neighbour's hanging on its side.
  using Ends = std::pair<std::array<float, 3>, std::array<float, 3>>;
  const auto ends_of = [&](const Edge& e) {
    std::array<float, 3> p{mesh.positions[e.first].x(), mesh.positions[e.first].y(), mesh.positions[e.first].z()};
    std::array<float, 3> q{mesh.positions[e.second].x(), mesh.positions[e.second].y(), mesh.positions[e.second].z()};
    return p < q ? Ends{p, q} : Ends{q, p};
  };
  std::map<Ends, std::vector<Edge>> twins;
  for (const Edge& e : edges) twins[ends_of(e)].push_back(e);
  // Closure: a triangle with two of its edges split would keep a vertex hanging on its third.
  for (bool closed = false; !closed;) {
    closed = true;
    for (const Edge& e : std::vector<Edge>(split.begin(), split.end())) {
      for (const Edge& twin : twins[ends_of(e)]) closed = !split.insert(twin).second && closed;
    }
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
      const unsigned sides = marked_sides(mesh, t, split);
      if (sides == 3u || sides == 5u || sides == 6u) {
        const unsigned third = 7u & ~sides;
        const unsigned e = third == 1u ? 0u : third == 2u ? 1u : 2u;
        split.insert(std::minmax(mesh.indices[3 * t + e], mesh.indices[3 * t + (e + 1) % 3]));
        closed = false;
      }
    }
  }
  if (split.empty()) return {};
  if (mesh.texcoords.size() != mesh.positions.size()) mesh.texcoords.clear();
  Midpoints midpoints(mesh);
  for (const Edge& edge : split) midpoints.of(edge.first, edge.second);  // new vertices in edge order
  std::vector<std::uint32_t> indices;
  std::vector<std::uint32_t> materials;
  indices.reserve(mesh.indices.size() + 9 * split.size());
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const std::uint32_t material = t < mesh.triangle_material.size() ? mesh.triangle_material[t] : 0u;
    const unsigned sides = marked_sides(mesh, t, split);
    std::uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
    if (sides == 0u) {
      indices.insert(indices.end(), {a, b, c});
      materials.push_back(material);
    } else if (sides == 7u) {
      const std::uint32_t ab = midpoints.of(a, b), bc = midpoints.of(b, c), ca = midpoints.of(c, a);
      indices.insert(indices.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
      materials.insert(materials.end(), {material, material, material, material});
    } else {
      // One marked edge: turned to a→b (winding kept), halved through c.
      if (sides == 2u) std::tie(a, b, c) = std::make_tuple(b, c, a);
      if (sides == 4u) std::tie(a, b, c) = std::make_tuple(c, a, b);
      const std::uint32_t m = midpoints.of(a, b);
      indices.insert(indices.end(), {a, m, c, m, b, c});
      materials.insert(materials.end(), {material, material});
    }
  }
  mesh.indices = std::move(indices);
  if (!mesh.triangle_material.empty()) mesh.triangle_material = std::move(materials);
  return {split.begin(), split.end()};
}

void apply_refinement(Mesh& mesh, const Refinement& refinement) {
  for (std::size_t r = 0; r < refinement.rounds.size(); ++r) {
    std::vector<Edge> recorded = refinement.rounds[r];
    for (Edge& e : recorded) e = Edge(std::min(e.first, e.second), std::max(e.first, e.second));
    std::sort(recorded.begin(), recorded.end());
    if (split_edges(mesh, recorded) != recorded) {
      throw std::invalid_argument("refinement round " + std::to_string(r + 1) +
                                  ": its edges are not closed as a refinement of this model splits them");
    }
  }
}

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
