// The raster engine (shadow maps on OpenGL ES) against analytic visibility: boxes as occluders,
// rays from texel centres and vertices tested against them with the slab method. Shadow maps
// resolve edges to one shadow-map texel, so exact agreement is required away from shadow
// edges, and near edges only a small share of texels may differ.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

// geom::Plane::normal() uses cross(), which lives in Eigen/Geometry.
#include <Eigen/Geometry>

#include "skylit/baker/visibility.hpp"
#include "box_scene.hpp"

namespace skylit::baker {
namespace {

using test::Box;
using test::direction;
using test::mesh_of;

constexpr int kShadowMapResolution = 1024;  // fast on llvmpipe

// A flat grid of n×n vertices with one normal (no triangles of its own: the vertices only sample).
void add_vertex_grid(scene::Mesh& mesh, const Vec3& corner, double size, int n, double z, const Vec3& normal) {
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      mesh.positions.emplace_back(static_cast<float>(corner.x() + size * i / (n - 1)),
                                  static_cast<float>(corner.y() + size * j / (n - 1)), static_cast<float>(z));
      mesh.normals.push_back(normal.cast<float>());
    }
  }
}

geom::Plane make_plane(const Vec3& origin, const Vec3& u, const Vec3& v, int width, int height) {
  geom::Plane plane;
  plane.name = "test plane";
  plane.origin = origin;
  plane.u = u;
  plane.v = v;
  plane.width = width;
  plane.height = height;
  return plane;
}

// Slab test: does the ray origin + t·dir, t ≥ 0, meet the closed box?
bool ray_hits_box(const Vec3& origin, const Vec3& dir, const Box& box) {
  double enter = 0.0;
  double leave = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(dir[axis]) < 1e-15) {
      if (origin[axis] < box.min[axis] || origin[axis] > box.max[axis]) return false;
      continue;
    }
    double t0 = (box.min[axis] - origin[axis]) / dir[axis];
    double t1 = (box.max[axis] - origin[axis]) / dir[axis];
    if (t0 > t1) std::swap(t0, t1);
    enter = std::max(enter, t0);
    leave = std::min(leave, t1);
    if (enter > leave) return false;
  }
  return true;
}

bool visible(const Vec3& point, const Vec3& dir, const std::vector<Box>& boxes) {
  return std::none_of(boxes.begin(), boxes.end(), [&](const Box& box) { return ray_hits_box(point, dir, box); });
}

// The contract's f at a point with normal n, from analytic visibility.
double analytic_fraction(const Vec3& point, const Vec3& normal, const std::vector<Vec3>& dirs,
                         const std::vector<Box>& boxes) {
  double weighted = 0.0;
  double weight = 0.0;
  double count = 0.0;
  for (const Vec3& w : dirs) {
    const Vec3 unit = w.normalized();
    const double c = std::max(0.0, normal.dot(unit));
    const double v = visible(point, unit, boxes) ? 1.0 : 0.0;
    weighted += c * v;
    weight += c;
    count += v;
  }
  return weight > 0.0 ? weighted / weight : count / static_cast<double>(dirs.size());
}

// Whether the analytic answer changes anywhere within `radius` of the point (in the two given
// directions and along the normal): such a point lies on a shadow edge, where a shadow map
// may resolve either way.
bool near_edge(const Vec3& point, const Vec3& normal, const Vec3& a, const Vec3& b, double radius,
               const std::vector<Vec3>& dirs, const std::vector<Box>& boxes) {
  const double centre = analytic_fraction(point, normal, dirs, boxes);
  constexpr int kSteps = 3;
  for (int i = -kSteps; i <= kSteps; ++i) {
    for (int j = -kSteps; j <= kSteps; ++j) {
      const Vec3 p = point + (radius * i / kSteps) * a + (radius * j / kSteps) * b;
      if (analytic_fraction(p, normal, dirs, boxes) != centre) return true;
    }
  }
  return false;
}

struct Comparison {
  int interior = 0;
  int interior_mismatches = 0;
  int edge = 0;
  int edge_mismatches = 0;
};

Comparison compare_plane(const geom::Plane& plane, const std::vector<float>& f, const std::vector<Vec3>& dirs,
                         const std::vector<Box>& boxes, double edge_texels) {
  Comparison result;
  const Vec3 n = plane.normal();
  const Vec3 du = plane.u / plane.width;
  const Vec3 dv = plane.v / plane.height;
  const double radius = edge_texels * std::max(du.norm(), dv.norm());
  for (int row = 0; row < plane.height; ++row) {
    for (int col = 0; col < plane.width; ++col) {
      const Vec3 p = plane.texel_centre(col, row);
      const double expected = analytic_fraction(p, n, dirs, boxes);
      const double got = f[static_cast<std::size_t>(row * plane.width + col)];
      const bool matches = std::abs(got - expected) < 1e-6;
      if (near_edge(p, n, du.normalized(), dv.normalized(), radius, dirs, boxes)) {
        ++result.edge;
        if (!matches) ++result.edge_mismatches;
      } else {
        ++result.interior;
        if (!matches) {
          ++result.interior_mismatches;
          ADD_FAILURE() << "texel (" << col << ", " << row << ") at " << p.transpose() << ": got " << got
                        << ", expected " << expected;
          if (result.interior_mismatches > 5) return result;
        }
      }
    }
  }
  return result;
}

std::unique_ptr<VisibilityEngine> raster(const scene::Mesh& mesh, std::span<const geom::Plane> planes) {
  RasterOptions options;
  options.shadow_map_resolution = kShadowMapResolution;
  options.shader_dir = std::filesystem::path(SKYLIT_SOURCE_DIR) / "shaders";
  return make_raster_engine(mesh, planes, options);
}

// (a) The only occluder lies far below the plane: every texel sees every direction.
TEST(RasterEngine, NothingInTheWayGivesOne) {
  const std::vector<Box> boxes{{{-1, -1, -10}, {1, 1, -9}}};
  const scene::Mesh mesh = mesh_of(boxes);
  const std::vector<geom::Plane> planes{make_plane({-4, -4, 0}, {8, 0, 0}, {0, 8, 0}, 64, 48)};
  auto engine = raster(mesh, planes);
  for (const std::vector<Vec3>& dirs : {std::vector<Vec3>{direction(90, 0)},
                                        std::vector<Vec3>{direction(5, 10), direction(30, 100), direction(60, 250)},
                                        std::vector<Vec3>{direction(1, 0), direction(1, 90), direction(1, 180),
                                                          direction(1, 270)}}) {
    engine->set_directions(dirs);
    std::vector<float> f(64 * 48, -1.0f);
    engine->plane_fractions(0, f);
    EXPECT_EQ(std::count(f.begin(), f.end(), 1.0f), static_cast<long>(f.size())) << dirs.size() << " directions";
  }
}

// (b) A unit box on the ground, one sun: binary shadow, exact away from the edge.
TEST(RasterEngine, BoxShadowOnGroundMatchesRays) {
  const std::vector<Box> boxes{{{0, 0, 0}, {1, 1, 1}}};
  const scene::Mesh mesh = mesh_of(boxes);
  const std::vector<geom::Plane> planes{make_plane({-1.5, -1.5, 0}, {4, 0, 0}, {0, 4, 0}, 128, 128)};
  auto engine = raster(mesh, planes);
  const std::vector<Vec3> sun{direction(45, 30)};
  engine->set_directions(sun);
  std::vector<float> f(128 * 128, -1.0f);
  engine->plane_fractions(0, f);
  const Comparison c = compare_plane(planes[0], f, sun, boxes, 1.5);
  EXPECT_EQ(c.interior_mismatches, 0);
  EXPECT_GT(c.edge, 100);  // the test is only meaningful with a shadow edge on the plane
  EXPECT_LT(c.edge_mismatches, std::max(1, c.edge / 50)) << c.edge_mismatches << " of " << c.edge;
  // The shadow is there: the box's footprint and the shadow beyond it (1 m tall, 45°).
  const auto shadowed = std::count(f.begin(), f.end(), 0.0f);
  EXPECT_GT(shadowed, 128 * 128 / 16);
  RecordProperty("edge_texels", c.edge);
  RecordProperty("edge_mismatches", c.edge_mismatches);
}

// (c) A wall facing away from every direction: f is the plain share of directions that get
// through (Σ V / K).
TEST(RasterEngine, PlaneFacingAwayUsesVisibleShare) {
  // The wall: x ∈ [0, 2], z ∈ [0, 2] at y = 0, normal u × v = −y. Directions come from the north
  // (+y), so n·ω < 0 for all; a box north of the wall covers half of it.
  const std::vector<Box> boxes{{{0, 0.5, 0}, {1, 1.5, 3}}};
  const scene::Mesh mesh = mesh_of(boxes);
  const std::vector<geom::Plane> planes{make_plane({0, 0, 0}, {2, 0, 0}, {0, 0, 2}, 64, 64)};
  ASSERT_LT(planes[0].normal().y(), -0.999);
  auto engine = raster(mesh, planes);
  const std::vector<Vec3> dirs{direction(10, 0), direction(20, 30), direction(40, -40)};
  for (const Vec3& w : dirs) ASSERT_LT(planes[0].normal().dot(w), 0.0);
  engine->set_directions(dirs);
  std::vector<float> f(64 * 64, -1.0f);
  engine->plane_fractions(0, f);
  const Comparison c = compare_plane(planes[0], f, dirs, boxes, 1.5);
  EXPECT_EQ(c.interior_mismatches, 0);
  EXPECT_LT(c.edge_mismatches, std::max(1, c.edge / 50)) << c.edge_mismatches << " of " << c.edge;
  // Partial values occur (some directions blocked, others not), and they are multiples of 1/3.
  const auto partial = std::count_if(f.begin(), f.end(), [](float x) { return x > 0.3f && x < 0.7f; });
  EXPECT_GT(partial, 64);
  for (float x : f) EXPECT_NEAR(x * 3.0f, std::round(x * 3.0f), 1e-5f);
}

// (d) Vertices: box tops see the sky, vertices under an overhang do not; vertices facing down
// (away from every direction) follow the Σ V / K rule.
TEST(RasterEngine, VertexFractionsSeeOverhangs) {
  const std::vector<Box> boxes{
      {{0, 0, 0}, {1, 1, 1}},            // A: open sky above
      {{3, 0, 1.0}, {5, 2, 1.2}},        // B: a floating slab (the overhang)
      {{3.5, 0.5, 0}, {4, 1, 0.3}},      // C: under B
  };
  scene::Mesh mesh = mesh_of(boxes);
  // 40×40 sample vertices around and under the slab: more than one row of the vertex target, so
  // the vertex → texel mapping is checked too.
  const std::size_t grid_first = mesh.positions.size();
  add_vertex_grid(mesh, {2.5, -0.5, 0}, 3.0, 40, 0.0, Vec3::UnitZ());
  // Downward-facing samples in the air between C and B: lit only outside B's footprint.
  add_vertex_grid(mesh, {2.5, -0.5, 0}, 3.0, 20, 0.5, -Vec3::UnitZ());
  const std::vector<geom::Plane> planes;
  auto engine = raster(mesh, planes);
  // Chosen so that no grid row runs parallel to a shadow edge at a sub-texel distance (at 62°
  // instead of 64°, the row y = 0.5 sees B's edge y = 0 at 1.7 mm, and all of it flips at once).
  const std::vector<Vec3> dirs{direction(90, 0), direction(70, 20), direction(64, 200), direction(75, 290)};
  engine->set_directions(dirs);
  std::vector<float> f(mesh.vertex_count(), -1.0f);
  engine->vertex_fractions(f);

  const double offset = surface_offset(mesh, planes);
  for (std::size_t face = 0; face < 18; ++face) {
    const std::size_t box = face / 6;
    const int side = static_cast<int>(face % 6);  // +x, −x, +y, −y, +z, −z
    for (std::size_t corner = 0; corner < 4; ++corner) {
      const std::size_t v = 4 * face + corner;
      SCOPED_TRACE("box " + std::to_string(box) + " face " + std::to_string(side) + " vertex " + std::to_string(v));
      if (side != 4) continue;
      // A's and B's tops see open sky; C's top lies under B.
      EXPECT_EQ(f[v], box == 2 ? 0.0f : 1.0f);
    }
  }
  // The grid against analytic rays from the nudged vertices.
  int interior = 0;
  int edge = 0;
  int edge_mismatches = 0;
  for (std::size_t v = grid_first; v < mesh.vertex_count(); ++v) {
    const Vec3 normal = mesh.normals[v].cast<double>();
    const Vec3 p = mesh.positions[v].cast<double>() + offset * normal;
    const double expected = analytic_fraction(p, normal, dirs, boxes);
    const bool matches = std::abs(f[v] - expected) < 1e-6;
    if (near_edge(p, normal, Vec3::UnitX(), Vec3::UnitY(), 0.02, dirs, boxes)) {
      ++edge;
      edge_mismatches += matches ? 0 : 1;
    } else {
      ++interior;
      EXPECT_NEAR(f[v], expected, 1e-6) << "grid vertex " << v - grid_first << " at " << p.transpose();
    }
  }
  EXPECT_GT(interior, 1300);
  EXPECT_LE(edge_mismatches, std::max(1, edge / 50)) << edge_mismatches << " of " << edge;
  const auto grid_end = f.begin() + static_cast<long>(grid_first + 40 * 40);
  EXPECT_GT(std::count(f.begin() + static_cast<long>(grid_first), grid_end, 0.0f), 100);
  EXPECT_GT(std::count(grid_end, f.end(), 0.0f), 50);  // under B, facing away: all blocked
  EXPECT_GT(std::count(grid_end, f.end(), 1.0f), 50);  // outside B's footprint: all through
}

// (e) Texel orientation on a W ≠ H plane: out[row * W + col], col along u, row along v, row 0
// at the origin.
TEST(RasterEngine, TexelOrientationFollowsThePlane) {
  // Plane 4 m (64 texels) along x, 2 m (32 texels) along y; the sun straight overhead. One slab
  // shades x < 1 (cols 0–15), another shades y < 0.5 (rows 0–7).
  const std::vector<Box> boxes{{{-0.5, -0.5, 0.5}, {1.0, 2.5, 0.6}}, {{-0.5, -0.5, 0.5}, {4.5, 0.5, 0.6}}};
  const scene::Mesh mesh = mesh_of(boxes);
  const std::vector<geom::Plane> planes{make_plane({0, 0, 0}, {4, 0, 0}, {0, 2, 0}, 64, 32)};
  auto engine = raster(mesh, planes);
  engine->set_directions(std::vector<Vec3>{direction(90, 0)});
  std::vector<float> f(64 * 32, -1.0f);
  engine->plane_fractions(0, f);
  int wrong = 0;
  for (int row = 0; row < 32; ++row) {
    for (int col = 0; col < 64; ++col) {
      const float expected = (col < 16 || row < 8) ? 0.0f : 1.0f;
      if (f[static_cast<std::size_t>(row * 64 + col)] != expected) ++wrong;
    }
  }
  EXPECT_EQ(wrong, 0);
  // A plane whose u runs along −x: the dark columns move to the end of each row.
  const std::vector<geom::Plane> flipped{make_plane({4, 0, 0}, {-4, 0, 0}, {0, 2, 0}, 64, 32)};
  auto flipped_engine = raster(mesh, flipped);
  flipped_engine->set_directions(std::vector<Vec3>{direction(90, 0)});
  // The flipped plane faces down (u × v = −z): Σ V / K applies and gives the same binary answer.
  flipped_engine->plane_fractions(0, f);
  wrong = 0;
  for (int row = 0; row < 32; ++row) {
    for (int col = 0; col < 64; ++col) {
      const float expected = (col >= 48 || row < 8) ? 0.0f : 1.0f;
      if (f[static_cast<std::size_t>(row * 64 + col)] != expected) ++wrong;
    }
  }
  EXPECT_EQ(wrong, 0);
}

// More directions than one batch of shadow maps holds (64 at 1024²), set again and again: the
// batches add up to the same answer as the analytic rays, and repeated calls agree bit for bit.
TEST(RasterEngine, ManyDirectionsInBatchesAndRepeatedCalls) {
  const std::vector<Box> boxes{{{0, 0, 0}, {1, 1, 1}}};
  const scene::Mesh mesh = mesh_of(boxes);
  const std::vector<geom::Plane> planes{make_plane({-1.5, -1.5, 0}, {4, 0, 0}, {0, 4, 0}, 32, 32)};
  auto engine = raster(mesh, planes);
  std::vector<Vec3> dirs;
  for (int k = 0; k < 70; ++k) dirs.push_back(direction(20.0 + 0.9 * k, 5.0 * k));
  engine->set_directions(dirs);
  std::vector<float> first(32 * 32, -1.0f);
  engine->plane_fractions(0, first);
  double mean_abs = 0.0;
  for (int row = 0; row < 32; ++row) {
    for (int col = 0; col < 32; ++col) {
      const double expected = analytic_fraction(planes[0].texel_centre(col, row), planes[0].normal(), dirs, boxes);
      mean_abs += std::abs(first[static_cast<std::size_t>(row * 32 + col)] - expected);
    }
  }
  mean_abs /= 32.0 * 32.0;
  EXPECT_LT(mean_abs, 0.005);
  // Other direction sets in between, then the first again.
  for (int round = 0; round < 10; ++round) {
    engine->set_directions(std::vector<Vec3>{direction(10.0 + 7.0 * round, 36.0 * round)});
    std::vector<float> scratch(32 * 32);
    engine->plane_fractions(0, scratch);
  }
  engine->set_directions(dirs);
  std::vector<float> again(32 * 32, -1.0f);
  engine->plane_fractions(0, again);
  EXPECT_EQ(first, again);
}

TEST(RasterEngine, RejectsMisuse) {
  const scene::Mesh mesh = mesh_of({{{0, 0, 0}, {1, 1, 1}}});
  const std::vector<geom::Plane> planes{make_plane({-1, -1, 0}, {3, 0, 0}, {0, 3, 0}, 8, 8)};
  auto engine = raster(mesh, planes);
  std::vector<float> f(64);
  EXPECT_THROW(engine->plane_fractions(0, f), std::logic_error);  // no directions yet
  EXPECT_THROW(engine->set_directions(std::vector<Vec3>{}), std::invalid_argument);
  EXPECT_THROW(engine->set_directions(std::vector<Vec3>{Vec3::Zero()}), std::invalid_argument);
  engine->set_directions(std::vector<Vec3>{direction(45, 0)});
  EXPECT_THROW(engine->plane_fractions(1, f), std::out_of_range);
  std::vector<float> wrong_size(63);
  EXPECT_THROW(engine->plane_fractions(0, wrong_size), std::invalid_argument);
  EXPECT_THROW(engine->vertex_fractions(wrong_size), std::invalid_argument);
  EXPECT_NE(engine->name().find("raster"), std::string::npos);
}

}  // namespace
}  // namespace skylit::baker
