// The raster engine (shadow maps on OpenGL ES) against the ray-traced reference (Embree) on one
// small scene: a box-shaped building under an overhanging roof slab, a tessellated ground patch,
// a ground plane and a vertical plane in front of the building's south wall.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

// geom::Plane::normal() uses cross(), which lives in Eigen/Geometry.
#include <Eigen/Geometry>

#include "skylit/baker/visibility.hpp"
#include "box_scene.hpp"
#include "skylit/geom/dome.hpp"

namespace skylit::baker {
namespace {

using test::direction;

// Tolerances. A shadow map answers "lit or not" per shadow-map texel, so the two engines can
// only disagree where a plane texel (or vertex) lies within about one shadow-map texel of a
// shadow edge; there a single direction flips V from 0 to 1. Away from edges both are exact.
// So: the mean |Δf| over a plane stays small (edges are a thin set) and large differences
// (|Δf| > 0.5, i.e. the majority of a texel's rays flipped) are confined to a few per cent.
constexpr double kMaxMeanAbsDifference = 0.01;
constexpr double kLargeDifference = 0.5;
constexpr double kMaxLargeDifferenceShare = 0.02;

// A flat, upward-facing grid of (n+1)² vertices at height z: vertices that lie inside lit areas,
// shadowed areas and across shadow edges, unlike box corners.
void add_ground_grid(scene::Mesh& mesh, double half_size, double z, int n) {
  const auto first = static_cast<std::uint32_t>(mesh.positions.size());
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      mesh.positions.emplace_back(static_cast<float>(-half_size + 2.0 * half_size * i / n),
                                  static_cast<float>(-half_size + 2.0 * half_size * j / n),
                                  static_cast<float>(z));
      mesh.normals.emplace_back(0.0f, 0.0f, 1.0f);
    }
  }
  const auto at = [&](int i, int j) { return first + static_cast<std::uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      for (std::uint32_t index : {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)}) {
        mesh.indices.push_back(index);
      }
      mesh.triangle_material.insert(mesh.triangle_material.end(), {0u, 0u});
    }
  }
}

scene::Mesh small_site() {
  scene::Mesh mesh;
  mesh.materials.push_back({});
  test::add_box(mesh, {{-1.0, -0.75, 0.0}, {1.0, 0.75, 2.0}});        // the building
  test::add_box(mesh, {{-1.4, -1.5, 2.3}, {1.3, 1.1, 2.45}});         // a roof slab overhanging south
  add_ground_grid(mesh, 3.0, -0.02, 24);                      // 2 cm below the building's foot
  return mesh;
}

std::vector<geom::Plane> small_site_planes() {
  geom::Plane ground;
  ground.name = "ground";
  ground.origin = {-4.0, -4.0, 0.01};
  ground.u = {8.0, 0.0, 0.0};
  ground.v = {0.0, 8.0, 0.0};
  ground.width = 128;
  ground.height = 128;
  geom::Plane wall;  // 1 cm in front of the building's south face, facing south (-y)
  wall.name = "south wall";
  wall.origin = {-1.0, -0.76, 0.0};
  wall.u = {2.0, 0.0, 0.0};
  wall.v = {0.0, 0.0, 2.0};
  wall.width = 64;
  wall.height = 64;
  return {ground, wall};
}

struct DirectionSet {
  std::string label;
  std::vector<Vec3> directions;
};

// Faces of the ν=2 dome chosen for what they stress, each sampled as the baker does, plus two
// single suns (binary visibility: the sharpest test of shadow edges).
std::vector<DirectionSet> direction_sets(const Vec3& wall_normal) {
  const geom::Dome dome(2);
  const auto samples = [&](int i) {
    return geom::stratified_samples(dome.triangle(i), 4, static_cast<std::uint64_t>(i));
  };
  int lowest_south = -1;
  int highest = -1;
  int straddling = -1;
  int behind_wall = -1;
  for (int i = 0; i < dome.face_count(); ++i) {
    const Vec3& centre = dome.face(i).centre;
    if (centre.y() < 0.0 && (lowest_south < 0 || centre.z() < dome.face(lowest_south).centre.z())) {
      lowest_south = i;
    }
    if (highest < 0 || centre.z() > dome.face(highest).centre.z()) highest = i;
    double min_c = 1.0;
    double max_c = -1.0;
    for (const Vec3& w : samples(i)) {
      min_c = std::min(min_c, wall_normal.dot(w));
      max_c = std::max(max_c, wall_normal.dot(w));
    }
    if (straddling < 0 && min_c < 0.0 && max_c > 0.0) straddling = i;
    if (behind_wall < 0 && max_c < 0.0 && centre.z() > 0.3 && centre.z() < 0.8) behind_wall = i;
  }
  EXPECT_GE(lowest_south, 0);
  EXPECT_GE(straddling, 0);
  EXPECT_GE(behind_wall, 0);
  return {
      {"lowest southern face", samples(lowest_south)},
      {"zenith face", samples(highest)},
      {"face straddling the wall's horizon", samples(straddling)},
      {"face behind the wall", samples(behind_wall)},
      {"low sun (5°)", {direction(5.0, 200.0)}},
      {"high sun (65°)", {direction(65.0, 150.0)}},
  };
}

struct Disagreement {
  double mean_abs = 0.0;
  double large_share = 0.0;
};

Disagreement compare(const std::vector<float>& raster, const std::vector<float>& raytrace) {
  Disagreement d;
  std::size_t large = 0;
  for (std::size_t i = 0; i < raster.size(); ++i) {
    const double diff = std::abs(static_cast<double>(raster[i]) - raytrace[i]);
    d.mean_abs += diff;
    if (diff > kLargeDifference) ++large;
  }
  d.mean_abs /= static_cast<double>(raster.size());
  d.large_share = static_cast<double>(large) / static_cast<double>(raster.size());
  return d;
}

TEST(EngineAgreement, RasterMatchesRaytraceUpToShadowEdges) {
  const scene::Mesh mesh = small_site();
  const std::vector<geom::Plane> planes = small_site_planes();
  RasterOptions raster_options;
  raster_options.shadow_map_resolution = 2048;
  raster_options.shader_dir = std::filesystem::path(SKYLIT_SOURCE_DIR) / "shaders";
  auto raster = make_raster_engine(mesh, planes, raster_options);
  auto raytrace = make_raytrace_engine(mesh, planes, {});

  for (const DirectionSet& set : direction_sets(planes[1].normal())) {
    SCOPED_TRACE(set.label);
    raster->set_directions(set.directions);
    raytrace->set_directions(set.directions);
    for (int j = 0; j < static_cast<int>(planes.size()); ++j) {
      SCOPED_TRACE(planes[static_cast<std::size_t>(j)].name);
      const std::size_t texels = static_cast<std::size_t>(planes[static_cast<std::size_t>(j)].width) *
                                 static_cast<std::size_t>(planes[static_cast<std::size_t>(j)].height);
      std::vector<float> f_raster(texels, -1.0f);
      std::vector<float> f_raytrace(texels, -1.0f);
      raster->plane_fractions(j, f_raster);
      raytrace->plane_fractions(j, f_raytrace);
      const Disagreement d = compare(f_raster, f_raytrace);
      EXPECT_LE(d.mean_abs, kMaxMeanAbsDifference);
      EXPECT_LT(d.large_share, kMaxLargeDifferenceShare);
    }
    std::vector<float> v_raster(mesh.vertex_count(), -1.0f);
    std::vector<float> v_raytrace(mesh.vertex_count(), -1.0f);
    raster->vertex_fractions(v_raster);
    raytrace->vertex_fractions(v_raytrace);
    const Disagreement d = compare(v_raster, v_raytrace);
    EXPECT_LE(d.mean_abs, kMaxMeanAbsDifference) << "vertex fractions";
    EXPECT_LT(d.large_share, kMaxLargeDifferenceShare) << "vertex fractions";
  }
}

// The comparison above is only meaningful if the scene has shadows to disagree about.
TEST(EngineAgreement, SceneCastsShadowsOnBothPlanes) {
  const scene::Mesh mesh = small_site();
  const std::vector<geom::Plane> planes = small_site_planes();
  auto raytrace = make_raytrace_engine(mesh, planes, {});
  const std::vector<Vec3> sun{direction(40.0, 170.0)};
  raytrace->set_directions(sun);
  for (int j = 0; j < 2; ++j) {
    const auto& plane = planes[static_cast<std::size_t>(j)];
    std::vector<float> f(static_cast<std::size_t>(plane.width) * static_cast<std::size_t>(plane.height));
    raytrace->plane_fractions(j, f);
    const auto shadowed = std::count(f.begin(), f.end(), 0.0f);
    EXPECT_GT(shadowed, static_cast<long>(f.size() / 20)) << plane.name;
    EXPECT_LT(shadowed, static_cast<long>(f.size())) << plane.name;
  }
}

}  // namespace
}  // namespace skylit::baker
