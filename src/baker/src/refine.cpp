// The bake's refinement of the model where the light changes (refine.hpp).
#include "skylit/baker/refine.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <string>

#include "skylit/base/error.hpp"

namespace skylit::baker {
namespace {

// A point probed beside the mesh's own vertices: the midpoint of an edge or a triangle's centroid.
struct Probe {
  std::vector<std::uint32_t> corners;  // 2 (an edge) or 3 (a triangle)
};

Eigen::Vector3f mean_normal(const scene::Mesh& mesh, const std::vector<std::uint32_t>& corners) {
  Eigen::Vector3f n = Eigen::Vector3f::Zero();
  for (std::uint32_t c : corners) n += mesh.normals[c];
  return n.norm() > 0.0f ? Eigen::Vector3f(n.normalized()) : mesh.normals[corners.front()];
}

}  // namespace

void validate_refine_options(const RefineOptions& o) {
  const auto fail = [](const std::string& option, const std::string& problem, const std::string& fix) {
    return InputError(option + ": " + problem + ". Fix: " + fix);
  };
  if (!std::isfinite(o.tolerance) || o.tolerance < 0.0) {
    throw fail("--refine", "must be a share ≥ 0", "give e.g. --refine 0.02 (a fiftieth of a uniform sky's light), or 0 for none");
  }
  if (o.rounds < 1 || o.rounds > 12) throw fail("--refine-rounds", "must be 1 to 12", "give e.g. --refine-rounds 4");
  if (!std::isfinite(o.min_edge) || o.min_edge <= 0.0) {
    throw fail("--refine-min-edge", "must be a length > 0 in metres", "give e.g. --refine-min-edge 0.25");
  }
  if (o.directions < 16 || o.directions > 16384) {
    throw fail("refine directions", "must be 16 to 16384", "give e.g. 256");
  }
  if (!std::isfinite(o.ground_albedo) || o.ground_albedo < 0.0 || o.ground_albedo > 1.0) {
    throw fail("refine ground albedo", "must lie in [0, 1]", "give e.g. 0.2");
  }
}

std::vector<Vec3> sphere_directions(int count) {
  std::vector<Vec3> out;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < count; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * k;
    out.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return out;
}

scene::Refinement refine_where_light_changes(scene::Mesh& mesh, std::span<const geom::Plane> planes,
                                             const RefineOptions& options, std::FILE* log) {
  scene::Refinement refinement;
  if (options.tolerance <= 0.0) return refinement;
  validate_refine_options(options);
  const std::vector<Vec3> directions = sphere_directions(options.directions);
  const std::size_t count = directions.size();
  // Σ_k |Δ| · (4π / K) / π: the difference's share of a uniform unit sky's horizontal irradiance.
  const double scale = 4.0 / static_cast<double>(count);
  const float long_enough = static_cast<float>(2.0 * options.min_edge);
  RaytraceOptions trace;
  trace.threads = options.threads;

  for (int round = 1; round <= options.rounds; ++round) {
    // The probes: every long enough edge's midpoint, and the centroid of every triangle with one.
    std::set<scene::Edge> long_edges;
    std::vector<Probe> probes;
    std::vector<bool> triangle_probed(mesh.triangle_count(), false);
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
      for (std::size_t e = 0; e < 3; ++e) {
        const std::uint32_t a = mesh.indices[3 * t + e], b = mesh.indices[3 * t + (e + 1) % 3];
        if ((mesh.positions[a] - mesh.positions[b]).norm() < long_enough) continue;
        triangle_probed[t] = true;
        long_edges.insert({std::min(a, b), std::max(a, b)});
      }
    }
    for (const scene::Edge& e : long_edges) probes.push_back({{e.first, e.second}});
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
      if (triangle_probed[t]) probes.push_back({{mesh.indices[3 * t], mesh.indices[3 * t + 1], mesh.indices[3 * t + 2]}});
    }
    if (probes.empty()) break;

    // The mesh with each probe as one more vertex that no triangle uses: seen like a vertex.
    scene::Mesh probed = mesh;
    for (const Probe& p : probes) {
      Eigen::Vector3f at = Eigen::Vector3f::Zero();
      for (std::uint32_t c : p.corners) at += mesh.positions[c];
      probed.positions.push_back(at / static_cast<float>(p.corners.size()));
      probed.normals.push_back(mean_normal(mesh, p.corners));
    }
    std::vector<float> views(probed.vertex_count() * count);
    vertex_views(probed, planes, directions, options.ground_albedo, views, trace);

    std::vector<scene::Edge> marked;
    const std::size_t first_probe = mesh.vertex_count();
    for (std::size_t p = 0; p < probes.size(); ++p) {
      const float* at = views.data() + (first_probe + p) * count;
      double seen = 0.0, differs = 0.0;
      const auto& corners = probes[p].corners;
      for (std::size_t k = 0; k < count; ++k) {
        double interpolated = 0.0;
        for (std::uint32_t c : corners) interpolated += views[c * count + k];
        interpolated /= static_cast<double>(corners.size());
        seen += at[k];
        differs += std::abs(at[k] - interpolated);
      }
      if (seen == 0.0 || differs * scale <= options.tolerance) continue;
      for (std::size_t i = 0; i < corners.size(); ++i) {
        const std::uint32_t a = corners[i], b = corners[(i + 1) % corners.size()];
        const scene::Edge e{std::min(a, b), std::max(a, b)};
        if (long_edges.count(e)) marked.push_back(e);
        if (corners.size() == 2) break;
      }
    }
    if (marked.empty()) break;
    const std::size_t vertices_before = mesh.vertex_count();
    refinement.rounds.push_back(scene::split_edges(mesh, marked));
    if (log) {
      std::fprintf(log, "refine: round %d: %zu of %zu edges split where the light changes (%zu probes), %zu → %zu vertices\n",
                   round, refinement.rounds.back().size(), long_edges.size(), probes.size(), vertices_before,
                   mesh.vertex_count());
    }
  }
  return refinement;
}

}  // namespace skylit::baker
