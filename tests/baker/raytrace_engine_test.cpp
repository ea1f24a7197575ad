// The ray-traced visibility engine against analytic answers: boxes are axis-aligned, so the
// visibility of a point along a direction is a slab test, computed here independently of Embree.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

// geom::Plane::normal() uses cross(), which lives in Eigen/Geometry.
#include <Eigen/Geometry>

#include "skylit/baker/visibility.hpp"
#include "box_scene.hpp"

namespace skylit::baker {
namespace raytrace_engine_test {  // named, not anonymous: the test program is one unity build

using test::Box;
using test::direction;
using test::mesh_of;

// True when the ray p + tω, t > 0, meets the closed box (slab test).
bool ray_hits_box(const Vec3& p, const Vec3& w, const Box& box) {
  double t_enter = 0.0;
  double t_exit = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    if (w[axis] == 0.0) {
      if (p[axis] < box.min[axis] || p[axis] > box.max[axis]) return false;
      continue;
    }
    double t0 = (box.min[axis] - p[axis]) / w[axis];
    double t1 = (box.max[axis] - p[axis]) / w[axis];
    if (t0 > t1) std::swap(t0, t1);
    t_enter = std::max(t_enter, t0);
    t_exit = std::min(t_exit, t1);
  }
  return t_enter <= t_exit;
}

bool visible(const Vec3& p, const Vec3& w, const std::vector<Box>& boxes) {
  return std::none_of(boxes.begin(), boxes.end(), [&](const Box& b) { return ray_hits_box(p, w, b); });
}

// Far from the shadow boundary: the answer is the same on a ring of points 1.1 mm around p in
// the plane (the shadow of a box on a plane is convex, so a point within ~1 mm of its boundary
// has a ring point on the other side).
bool clear_of_boundary(const geom::Plane& plane, const Vec3& p, const Vec3& w,
                       const std::vector<Box>& boxes) {
  constexpr double kRadius = 1.1e-3;
  constexpr int kRingPoints = 32;
  const Vec3 e1 = plane.u.normalized();
  const Vec3 e2 = plane.normal().cross(e1);
  const bool centre = visible(p, w, boxes);
  for (int k = 0; k < kRingPoints; ++k) {
    const double angle = 2.0 * std::numbers::pi * k / kRingPoints;
    const Vec3 q = p + kRadius * (std::cos(angle) * e1 + std::sin(angle) * e2);
    if (visible(q, w, boxes) != centre) return false;
  }
  return true;
}

// A 4 m × 4 m ground plane 1 cm above z = 0, centred on the origin.
geom::Plane ground_plane(int width, int height) {
  geom::Plane plane;
  plane.name = "ground";
  plane.origin = {-2.0, -2.0, 0.01};
  plane.u = {4.0, 0.0, 0.0};
  plane.v = {0.0, 4.0, 0.0};
  plane.width = width;
  plane.height = height;
  return plane;
}

const Box kUnitBox{{-0.5, -0.5, 0.0}, {0.5, 0.5, 1.0}};

// Compares every texel clear of all shadow boundaries with the analytic c-weighted fraction
// (or Σ V/K when no direction faces the plane); returns how many texels were compared.
int expect_plane_matches_analytic(const geom::Plane& plane, const std::vector<Box>& boxes,
                                  const std::vector<Vec3>& directions, std::span<const float> f,
                                  double tolerance) {
  const Vec3 n = plane.normal();
  double weight_sum = 0.0;
  for (const Vec3& w : directions) weight_sum += std::max(0.0, n.dot(w));
  int compared = 0;
  for (int row = 0; row < plane.height; ++row) {
    for (int col = 0; col < plane.width; ++col) {
      const Vec3 p = plane.texel_centre(col, row);
      bool clear = true;
      double expected = 0.0;
      for (const Vec3& w : directions) {
        clear = clear && clear_of_boundary(plane, p, w, boxes);
        const double weight = weight_sum > 0.0 ? std::max(0.0, n.dot(w)) : 1.0;
        expected += weight * (visible(p, w, boxes) ? 1.0 : 0.0);
      }
      expected /= weight_sum > 0.0 ? weight_sum : static_cast<double>(directions.size());
      if (!clear) continue;
      ++compared;
      const float got = f[static_cast<std::size_t>(row) * static_cast<std::size_t>(plane.width) +
                          static_cast<std::size_t>(col)];
      EXPECT_NEAR(got, expected, tolerance) << "texel col " << col << " row " << row;
      if (std::abs(got - expected) > tolerance) return compared;  // one report is enough
    }
  }
  return compared;
}

TEST(RaytraceEngine, NothingInTheWayGivesOneEverywhere) {
  // The box stands beside the plane, below it: no ray from the plane towards the sky meets it.
  const scene::Mesh mesh = mesh_of({{{10, 10, -5}, {11, 11, -4}}});
  const std::vector<geom::Plane> planes{ground_plane(64, 48)};
  auto engine = make_raytrace_engine(mesh, planes, {});
  const std::vector<Vec3> directions{direction(5, 0), direction(45, 30), direction(89, 200)};
  engine->set_directions(directions);
  std::vector<float> f(64 * 48, -1.0f);
  engine->plane_fractions(0, f);
  for (float value : f) ASSERT_EQ(value, 1.0f);  // exactly: B = A for an unoccluded texel
  std::vector<float> vf(mesh.vertex_count(), -1.0f);
  engine->vertex_fractions(vf);
  // Faces with an upward or sideways normal weight only the rays leaving the box, which see
  // the open sky. (The bottom face's corners, which count every ray, sit on the shadow
  // boundary; the overhang test covers that rule.)
  for (std::size_t v = 0; v < vf.size(); ++v) {
    if (mesh.normals[v].z() >= 0.0f) {
      EXPECT_EQ(vf[v], 1.0f) << "vertex " << v;
    }
  }
}

TEST(RaytraceEngine, BoxOnGroundMatchesSlabTestForOneDirection) {
  const std::vector<Box> boxes{kUnitBox};
  const scene::Mesh mesh = mesh_of(boxes);
  const std::vector<geom::Plane> planes{ground_plane(200, 200)};
  auto engine = make_raytrace_engine(mesh, planes, {.threads = 2});
  const std::vector<Vec3> directions{direction(45, 30)};
  engine->set_directions(directions);
  std::vector<float> f(200 * 200);
  engine->plane_fractions(0, f);
  const int compared = expect_plane_matches_analytic(planes[0], boxes, directions, f, 0.0);
  // Nearly every texel is clear of the boundary; a vacuous comparison must not pass.
  EXPECT_GT(compared, 200 * 200 * 97 / 100);
  // The shadow is there at all: the part of the box above the plane (0.99 m tall) swept along
  // the sun's horizontal direction by 0.99 m / tan 45°, a unit square swept by a segment:
  // area 1 + L (|sin az| + |cos az|). Texel counting is good to about a texel row along the
  // 6 m outline (0.02 m × 6 m ≈ 0.1 m² worst case; far less on average).
  const auto shadowed = std::count(f.begin(), f.end(), 0.0f);
  const double texel_area = 16.0 / (200 * 200);
  const double sweep = 0.99 / std::tan(std::numbers::pi / 4);
  const double expected_area =
      1.0 + sweep * (std::sin(std::numbers::pi / 6) + std::cos(std::numbers::pi / 6));
  EXPECT_NEAR(static_cast<double>(shadowed) * texel_area, expected_area, 0.05);
}

TEST(RaytraceEngine, SeveralDirectionsGiveTheCosineWeightedAverage) {
  const std::vector<Box> boxes{kUnitBox, {{0.8, -1.5, 0.0}, {1.2, -0.2, 2.0}}};
  const scene::Mesh mesh = mesh_of(boxes);
  const std::vector<geom::Plane> planes{ground_plane(128, 128)};
  auto engine = make_raytrace_engine(mesh, planes, {});
  const std::vector<Vec3> directions{direction(45, 30), direction(20, 100), direction(70, 250),
                                     direction(8, 300), direction(60, 170)};
  engine->set_directions(directions);
  std::vector<float> f(128 * 128);
  engine->plane_fractions(0, f);
  const int compared = expect_plane_matches_analytic(planes[0], boxes, directions, f, 1e-6);
  EXPECT_GT(compared, 128 * 128 * 9 / 10);
  // Partial values exist, so the weights are actually exercised.
  EXPECT_TRUE(std::any_of(f.begin(), f.end(), [](float x) { return x > 0.05f && x < 0.95f; }));
}

TEST(RaytraceEngine, PlaneFacingAwayFromAllDirectionsCountsRaysEqually) {
  const std::vector<Box> boxes{kUnitBox};
  const scene::Mesh mesh = mesh_of(boxes);
  // A vertical plane at y = -1 whose normal u × v points to -y (south).
  geom::Plane wall;
  wall.name = "wall";
  wall.origin = {-2.0, -1.0, 0.0};
  wall.u = {4.0, 0.0, 0.0};
  wall.v = {0.0, 0.0, 2.0};
  wall.width = 80;
  wall.height = 40;
  ASSERT_NEAR(wall.normal().y(), -1.0, 1e-12);
  const std::vector<geom::Plane> planes{wall};
  auto engine = make_raytrace_engine(mesh, planes, {});
  // All point north (+y): behind the wall, towards the box.
  const std::vector<Vec3> directions{direction(10, 0), direction(30, 20), direction(20, -25),
                                     direction(25, 40)};
  engine->set_directions(directions);
  std::vector<float> f(80 * 40);
  engine->plane_fractions(0, f);
  const int compared = expect_plane_matches_analytic(planes[0], boxes, directions, f, 1e-6);
  EXPECT_GT(compared, 80 * 40 * 9 / 10);
  // Quarter steps only (four equally counted rays), and a fully blocked texel exists.
  for (float value : f) EXPECT_EQ(value * 4.0f, std::round(value * 4.0f));
  EXPECT_TRUE(std::find(f.begin(), f.end(), 0.0f) != f.end());
}

TEST(RaytraceEngine, NonSquarePlaneKeepsRowMajorTexelOrder) {
  // Columns run north (along u = +y), rows run east (along v = +x): a transposed or mirrored
  // layout would put the shadow in the wrong texels.
  const std::vector<Box> boxes{{{0.3, -0.9, 0.0}, {0.6, -0.4, 1.5}}};
  const scene::Mesh mesh = mesh_of(boxes);
  geom::Plane plane;
  plane.name = "strip";
  plane.origin = {-1.0, -2.0, 0.01};
  plane.u = {0.0, 4.0, 0.0};
  plane.v = {2.0, 0.0, 0.0};
  plane.width = 96;
  plane.height = 24;
  // u × v points down; flip so that the plane faces the sky.
  plane.origin += plane.v;
  plane.v = -plane.v;
  ASSERT_GT(plane.normal().z(), 0.99);
  const std::vector<geom::Plane> planes{plane};
  auto engine = make_raytrace_engine(mesh, planes, {});
  const std::vector<Vec3> directions{direction(40, 210)};
  engine->set_directions(directions);
  std::vector<float> f(96 * 24);
  engine->plane_fractions(0, f);
  const int compared = expect_plane_matches_analytic(plane, boxes, directions, f, 0.0);
  EXPECT_GT(compared, 96 * 24 * 9 / 10);
  EXPECT_TRUE(std::find(f.begin(), f.end(), 0.0f) != f.end());
}

TEST(RaytraceEngine, VertexFractionsUnderAnOverhangAndOnTop) {
  // A roof slab 2 m up over a small floor tile: floor vertices see the sky only at low angles
  // (the three steep directions meet the roof from every tile corner; the two low ones pass
  // beneath its edge).
  const Box roof{{-1.0, -1.0, 2.0}, {1.0, 1.0, 2.2}};
  const Box tile{{-0.5, -0.5, -0.1}, {0.5, 0.5, 0.0}};
  const std::vector<Box> boxes{roof, tile};
  const scene::Mesh mesh = mesh_of(boxes);
  const std::vector<geom::Plane> planes;
  auto engine = make_raytrace_engine(mesh, planes, {});
  const std::vector<Vec3> directions{direction(80, 10), direction(75, 140), direction(15, 45),
                                     direction(10, 260), direction(85, 300)};
  engine->set_directions(directions);
  std::vector<float> f(mesh.vertex_count(), -1.0f);
  engine->vertex_fractions(f);

  int under = 0;
  int on_top = 0;
  int facing_away = 0;  // bottom faces: no direction has c > 0, so the Σ V/K rule applies
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const Vec3 p = mesh.positions[v].cast<double>();
    const Vec3 n = mesh.normals[v].cast<double>();
    double weight_sum = 0.0;
    double visible_weight = 0.0;
    for (const Vec3& w : directions) weight_sum += std::max(0.0, n.dot(w));
    for (const Vec3& w : directions) {
      const double weight = weight_sum > 0.0 ? std::max(0.0, n.dot(w)) : 1.0;
      // The analytic ray leaves from a point 1 mm off the surface: the same side of every box
      // face as the engine's nudged origin, and far from any shadow boundary in this layout.
      visible_weight += weight * (visible(p + 1e-3 * n, w, boxes) ? 1.0 : 0.0);
    }
    if (weight_sum == 0.0) ++facing_away;
    const double expected = visible_weight / (weight_sum > 0.0 ? weight_sum : directions.size());
    EXPECT_NEAR(f[v], expected, 1e-6) << "vertex " << v << " at " << p.transpose();
    if (n.z() > 0.5 && p.z() == 0.0) {
      ++under;
      // Only the two low directions (15° and 10°) pass under the roof edge.
      double low = std::max(0.0, n.dot(directions[2])) + std::max(0.0, n.dot(directions[3]));
      EXPECT_NEAR(f[v], low / weight_sum, 1e-6);
    }
    if (n.z() > 0.5 && std::abs(p.z() - 2.2) < 1e-6) {
      ++on_top;
      EXPECT_EQ(f[v], 1.0f);
    }
  }
  EXPECT_EQ(under, 4);
  EXPECT_EQ(on_top, 4);
  EXPECT_EQ(facing_away, 8);
}

TEST(RaytraceEngine, PlaneOnASurfaceDoesNotShadowItself) {
  // The plane lies exactly on the box top (z = 1), and texel centres fall exactly on the box's
  // edges and on the diagonal that splits the top face into two triangles: the surface offset
  // (tnear) must keep the rays from hitting the surface they start on.
  const std::vector<Box> boxes{kUnitBox};
  const scene::Mesh mesh = mesh_of(boxes);
  geom::Plane plane;
  plane.name = "top";
  plane.origin = {-0.5 - 1.0 / 16, -0.5 - 1.0 / 16, 1.0};
  plane.u = {1.0 + 2.0 / 16, 0.0, 0.0};
  plane.v = {0.0, 1.0 + 2.0 / 16, 0.0};
  plane.width = 9;  // texel pitch 1/8: centres at -0.5, -0.375, …, 0.5
  plane.height = 9;
  ASSERT_DOUBLE_EQ(plane.texel_centre(0, 0).x(), -0.5);
  ASSERT_DOUBLE_EQ(plane.texel_centre(8, 8).y(), 0.5);
  const std::vector<geom::Plane> planes{plane};
  auto engine = make_raytrace_engine(mesh, planes, {});
  std::vector<Vec3> directions;
  for (double azimuth = 0; azimuth < 360; azimuth += 15) {
    directions.push_back(direction(3, azimuth));
    directions.push_back(direction(45, azimuth + 7));
  }
  directions.push_back({0.0, 0.0, 1.0});
  engine->set_directions(directions);
  std::vector<float> f(9 * 9);
  engine->plane_fractions(0, f);
  for (std::size_t i = 0; i < f.size(); ++i) EXPECT_EQ(f[i], 1.0f) << "texel " << i;
}

TEST(RaytraceEngine, SurfaceOffsetScalesWithTheScene) {
  const scene::Mesh mesh = mesh_of({kUnitBox});  // diagonal √3
  EXPECT_NEAR(surface_offset(mesh, {}), 1e-4 * std::sqrt(3.0), 1e-12);
  // A plane widens the box: corners (-2,-2,0.01)…(2,2,0.01) with the box → 4 × 4 × 1.
  const std::vector<geom::Plane> planes{ground_plane(4, 4)};
  EXPECT_NEAR(surface_offset(mesh, planes), 1e-4 * std::sqrt(33.0), 1e-12);
  // A tiny scene gets the floor.
  EXPECT_EQ(surface_offset(mesh_of({{{0, 0, 0}, {1e-3, 1e-3, 1e-3}}}), {}), 1e-5);
  EXPECT_EQ(surface_offset(scene::Mesh{}, {}), 1e-5);
}

TEST(RaytraceEngine, ResultsDoNotDependOnThreadCount) {
  const std::vector<Box> boxes{kUnitBox, {{0.8, -1.5, 0.0}, {1.2, -0.2, 2.0}}};
  const scene::Mesh mesh = mesh_of(boxes);
  const std::vector<geom::Plane> planes{ground_plane(97, 61)};
  const std::vector<Vec3> directions{direction(30, 10), direction(12, 190), direction(65, 95)};
  std::vector<std::vector<float>> results;
  for (int threads : {1, 3}) {
    auto engine = make_raytrace_engine(mesh, planes, {.threads = threads});
    engine->set_directions(directions);
    std::vector<float> f(97 * 61);
    engine->plane_fractions(0, f);
    results.push_back(f);
  }
  EXPECT_EQ(results[0], results[1]);
}

TEST(RaytraceEngine, RejectsMisuse) {
  const scene::Mesh mesh = mesh_of({kUnitBox});
  const std::vector<geom::Plane> planes{ground_plane(8, 8)};
  auto engine = make_raytrace_engine(mesh, planes, {});
  std::vector<float> f(64);
  EXPECT_THROW(engine->plane_fractions(0, f), std::logic_error);  // no directions yet
  const std::vector<Vec3> none;
  EXPECT_THROW(engine->set_directions(none), std::invalid_argument);
  const std::vector<Vec3> one{direction(45, 0)};
  engine->set_directions(one);
  EXPECT_THROW(engine->plane_fractions(1, f), std::out_of_range);
  std::vector<float> wrong_size(63);
  EXPECT_THROW(engine->plane_fractions(0, wrong_size), std::invalid_argument);
  scene::Mesh broken = mesh;
  broken.indices.back() = 1000;
  EXPECT_THROW(make_raytrace_engine(broken, planes, {}), std::invalid_argument);
}

}  // namespace
}  // namespace skylit::baker

namespace skylit::baker {
namespace raytrace_engine_test {

TEST(WeightedPlaneVisibility, SumsRadianceWeightedCosinesOfTheVisibleDirections) {
  const std::vector<Box> boxes{kUnitBox, {{0.8, -1.5, 0.0}, {1.2, -0.2, 2.0}}};
  const scene::Mesh mesh = mesh_of(boxes);
  const geom::Plane plane = ground_plane(64, 64);
  const std::vector<Vec3> directions{direction(45, 30), direction(20, 100), direction(70, 250),
                                     direction(-10, 0), direction(60, 170)};
  const std::vector<Eigen::Vector3d> weights{{1, 2, 3}, {0.5, 0.5, 0.5}, {4, 0, 1}, {9, 9, 9}, {0, 0, 0}};
  std::vector<Eigen::Vector3d> out(64 * 64);
  weighted_plane_visibility(mesh, plane, directions, weights, out, {.threads = 2});
  int compared = 0;
  for (int row = 0; row < 64; ++row) {
    for (int col = 0; col < 64; ++col) {
      const Vec3 p = plane.texel_centre(col, row);
      Eigen::Vector3d expected = Eigen::Vector3d::Zero();
      bool near_edge = false;
      for (std::size_t k = 0; k < directions.size(); ++k) {
        const double c = std::max(0.0, plane.normal().dot(directions[k]));
        if (c == 0.0) continue;  // below the plane's horizon: never counts
        // Texels whose answer flips within a millimetre are boundary cases for both tracers.
        const Vec3 side = directions[k].cross(plane.normal()).normalized() * 1e-3;
        near_edge |= visible(p + side, directions[k], boxes) != visible(p - side, directions[k], boxes);
        if (visible(p, directions[k], boxes)) expected += c * weights[k];
      }
      if (near_edge) continue;
      ++compared;
      EXPECT_LT((out[static_cast<std::size_t>(row * 64 + col)] - expected).norm(), 1e-9) << col << "," << row;
    }
  }
  EXPECT_GT(compared, 64 * 64 * 9 / 10);
}

}  // namespace
}  // namespace skylit::baker

namespace skylit::baker {
namespace raytrace_engine_test {

TEST(AreaLightVisibility, WeighsEachDirectionByItsShareAndCosine) {
  const std::vector<Box> boxes{kUnitBox};
  const scene::Mesh mesh = mesh_of(boxes);
  const geom::Plane plane = ground_plane(64, 64);
  // Two suns a few degrees apart: texels that see one and not the other get its share.
  const std::vector<Vec3> directions{direction(40, 20), direction(40, 35)};
  const std::vector<double> weights{0.25, 0.75};
  std::vector<float> v(64 * 64);
  area_light_visibility(mesh, plane, directions, weights, v);
  const double c0 = 0.25 * directions[0].z(), c1 = 0.75 * directions[1].z();
  int partial = 0;
  for (int row = 0; row < 64; ++row) {
    for (int col = 0; col < 64; ++col) {
      const Vec3 p = plane.texel_centre(col, row);
      const double expected = (c0 * visible(p, directions[0], boxes) + c1 * visible(p, directions[1], boxes)) / (c0 + c1);
      const float got = v[static_cast<std::size_t>(row * 64 + col)];
      // Texels on a shadow edge may go either way in either tracer.
      if (std::abs(got - expected) > 1e-5) {
        const Vec3 side(1e-3, 1e-3, 0);
        const bool edge = visible(p + side, directions[0], boxes) != visible(p - side, directions[0], boxes) ||
                          visible(p + side, directions[1], boxes) != visible(p - side, directions[1], boxes);
        EXPECT_TRUE(edge) << col << "," << row << ": " << got << " vs " << expected;
      }
      partial += expected > 0.1 && expected < 0.9;
    }
  }
  EXPECT_GT(partial, 10);  // the penumbra exists
  // A light wholly behind the plane: visibility 1 (it carries no weight there anyway).
  const std::vector<Vec3> below{direction(-30, 0)};
  const std::vector<double> one{1.0};
  area_light_visibility(mesh, plane, below, one, v);
  for (float x : v) EXPECT_EQ(x, 1.0f);
}

}  // namespace
}  // namespace skylit::baker

namespace skylit::baker {
namespace raytrace_engine_test {

TEST(WeightedVertexIrradiance, SumsTheLightEachVertexSeesUnderAnOverhang) {
  // The roof over a floor tile again: each vertex gets Σ w_k max(0, n·ω_k) over the directions
  // its own geometry leaves open, RGB weights kept apart.
  const Box roof{{-1.0, -1.0, 2.0}, {1.0, 1.0, 2.2}};
  const Box tile{{-0.5, -0.5, -0.1}, {0.5, 0.5, 0.0}};
  const std::vector<Box> boxes{roof, tile};
  const scene::Mesh mesh = mesh_of(boxes);
  const std::vector<Vec3> directions{direction(80, 10), direction(75, 140), direction(15, 45), direction(10, 260),
                                     direction(85, 300), direction(-20, 0)};
  const std::vector<Eigen::Vector3d> weights{{1, 2, 3}, {0.5, 0.5, 0.5}, {4, 0, 1}, {2, 2, 0}, {0, 0, 0}, {9, 9, 9}};
  std::vector<Eigen::Vector3d> out(mesh.vertex_count());
  weighted_vertex_irradiance(mesh, {}, directions, weights, out, {.threads = 2});
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const Vec3 p = mesh.positions[v].cast<double>();
    const Vec3 n = mesh.normals[v].cast<double>();
    Eigen::Vector3d expected = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < directions.size(); ++k) {
      if (visible(p + 1e-3 * n, directions[k], boxes)) expected += std::max(0.0, n.dot(directions[k])) * weights[k];
    }
    EXPECT_LT((out[v] - expected).norm(), 1e-9) << "vertex " << v << " at " << p.transpose();
  }
  // The tile's top vertices, under the roof: only the two low directions reach them.
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    if (mesh.normals[v].z() > 0.5 && mesh.positions[v].z() == 0.0f) {
      const Eigen::Vector3d low = directions[2].z() * weights[2] + directions[3].z() * weights[3];
      EXPECT_LT((out[v] - low).norm(), 1e-9);
    }
  }
  std::vector<Eigen::Vector3d> wrong(mesh.vertex_count() - 1);
  EXPECT_THROW(weighted_vertex_irradiance(mesh, {}, directions, weights, wrong), std::invalid_argument);
}

TEST(AreaLightVertexVisibility, IsTheShareOfTheDiscEachVertexSees) {
  const Box roof{{-1.0, -1.0, 2.0}, {1.0, 1.0, 2.2}};
  const Box tile{{-0.5, -0.5, -0.1}, {0.5, 0.5, 0.0}};
  const std::vector<Box> boxes{roof, tile};
  const scene::Mesh mesh = mesh_of(boxes);
  // A low sun (passes under the roof) and a high one (the roof blocks it over the tile).
  const std::vector<Vec3> disc{direction(12, 45), direction(70, 45)};
  const std::vector<double> weights{0.4, 0.6};
  std::vector<float> v(mesh.vertex_count());
  area_light_vertex_visibility(mesh, {}, disc, weights, v);
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    const Vec3 p = mesh.positions[i].cast<double>(), n = mesh.normals[i].cast<double>();
    const double c0 = weights[0] * std::max(0.0, n.dot(disc[0])), c1 = weights[1] * std::max(0.0, n.dot(disc[1]));
    const double expected = c0 + c1 > 0 ? (c0 * visible(p + 1e-3 * n, disc[0], boxes) + c1 * visible(p + 1e-3 * n, disc[1], boxes)) / (c0 + c1)
                                        : 1.0;
    EXPECT_NEAR(v[i], expected, 1e-6) << "vertex " << i << " at " << p.transpose();
  }
}

// A vertex that lies on a second face (a post standing on its plinth: the post's foot lies in
// the plinth's top) sees what lies above the plinth. Its rays start in that face's plane; a
// hit there at t = 0 must not shade them.
TEST(AreaLightVertexVisibility, AVertexOnAnotherFaceSeesOverIt) {
  const Box plinth{{-1.0, -1.0, 0.0}, {1.0, 1.0, 0.3}};
  const Box post{{-0.2, -0.2, 0.3}, {0.2, 0.2, 3.0}};
  const scene::Mesh mesh = mesh_of({plinth, post});
  const std::vector<Vec3> disc{direction(40, 90)};  // up and to the east
  const std::vector<double> weight{1.0};
  std::vector<float> v(mesh.vertex_count());
  area_light_vertex_visibility(mesh, {}, disc, weight, v);
  int feet = 0;
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    const Eigen::Vector3f& p = mesh.positions[i];
    // The post's east face at its foot, on the plinth's top.
    if (mesh.normals[i].x() > 0.5f && std::abs(p.x() - 0.2f) < 1e-6f && std::abs(p.z() - 0.3f) < 1e-6f) {
      EXPECT_FLOAT_EQ(v[i], 1.0f) << "vertex " << i << " at " << p.transpose();
      ++feet;
    }
  }
  EXPECT_EQ(feet, 2);
}

}  // namespace
}  // namespace skylit::baker
