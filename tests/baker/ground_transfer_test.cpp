// The ground's light (baker/ground_transfer.hpp) against analytic answers: the equal-area
// directions integrate the cosine; a small box high above the ground sees it unshadowed
// (π below, π/2 at its sides, nothing on top); a vertex low on a long wall sees the ground the
// wall shadows, as a two-dimensional view-factor integral gives it; buried and enclosed vertices
// see none of it.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "box_scene.hpp"
#include "skylit/baker/ground_transfer.hpp"

namespace skylit::baker {
namespace ground_transfer_test {  // named, not anonymous: the test program is one unity build

using test::Box;
using test::mesh_of;
constexpr double kPi = std::numbers::pi;

// Σ_l t^g_{v,l}: the ground's light at vertex v under a sky of radiance 1 in every layer.
std::vector<double> uniform_sky_ground_light(const scene::Mesh& mesh, const GroundGrid& grid, int samples) {
  const std::vector<float> t = ground_transfer(mesh, {}, grid, samples);
  std::vector<double> out(mesh.vertex_count(), 0.0);
  for (std::size_t v = 0; v < out.size(); ++v) {
    for (std::size_t l = 0; l < grid.layers(); ++l) out[v] += t[v * grid.layers() + l];
  }
  return out;
}

TEST(GroundTransfer, TheDirectionsAreEqualAreaAndIntegrateTheCosine) {
  const std::vector<Vec3> d = ground_directions(1024);
  ASSERT_EQ(d.size(), 1024u);
  double mean_z = 0.0;
  for (const Vec3& w : d) {
    EXPECT_LT(w.z(), 0.0);
    EXPECT_NEAR(w.norm(), 1.0, 1e-12);
    mean_z += w.z() / 1024.0;
  }
  EXPECT_NEAR(mean_z, -0.5, 1e-9) << "equal areas in z: the lower hemisphere's mean";
  std::mt19937 random(3);
  std::normal_distribution<double> gauss;
  for (int trial = 0; trial < 20; ++trial) {
    const Vec3 n = Vec3(gauss(random), gauss(random), gauss(random)).normalized();
    double sum = 0.0;
    for (const Vec3& w : d) sum += std::max(0.0, n.dot(w)) * 2.0 * kPi / 1024.0;
    EXPECT_NEAR(sum, unoccluded_ground_transfer(n), 0.01 * kPi / 2) << n.transpose();
  }
  EXPECT_DOUBLE_EQ(unoccluded_ground_transfer(Vec3::UnitZ()), 0.0);
  EXPECT_DOUBLE_EQ(unoccluded_ground_transfer(-Vec3::UnitZ()), kPi);
  EXPECT_DOUBLE_EQ(unoccluded_ground_transfer(Vec3::UnitX()), kPi / 2);
  EXPECT_THROW(ground_directions(0), std::invalid_argument);
}

TEST(GroundTransfer, ABoxHighAboveSeesTheGroundUnshadowed) {
  const scene::Mesh mesh = mesh_of({Box{{-0.1, -0.1, 20.0}, {0.1, 0.1, 20.2}}});
  const geom::Dome dome(2);
  const GroundGrid grid = bake_ground_grid(mesh, dome, geom::DomeBasis::Faces, 16);
  double horizontal = 0.0;
  for (double a : grid.unoccluded) horizontal += a;
  EXPECT_NEAR(horizontal, kPi, 1e-9) << "Σ_l A_l(z): the horizontal's projected solid angle";
  const std::vector<double> light = uniform_sky_ground_light(mesh, grid, 256);
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    // A ground of albedo 1 under E_h = π has radiance 1: what the vertex sees of it is A_g(n).
    const double expected = unoccluded_ground_transfer(mesh.normals[v].cast<double>());
    EXPECT_NEAR(light[v], expected, 2e-3 * kPi) << "vertex " << v << " normal " << mesh.normals[v].transpose();
  }
}

// A wall 3 m tall and 40 m long along y, 0.2 m thick; a vertex on its east face 0.5 m up, in the
// middle. Across a long wall the ground's irradiance at distance d is π (1 + d / √(d² + H²)) / 2
// (the wall hides the sky below its top on one side), and the vertex sees the ground at depression
// θ at d = h / tan θ, with the view factor cos θ dθ / 2 of a long strip.
TEST(GroundTransfer, AVertexOnAWallSeesTheGroundTheWallShadows) {
  constexpr double kHeight = 3.0, kUp = 0.5;
  scene::Mesh mesh = mesh_of({Box{{-0.1, -20.0, 0.0}, {0.1, 20.0, kHeight}}});
  const auto probe = static_cast<std::uint32_t>(mesh.positions.size());
  mesh.positions.emplace_back(0.1f, 0.0f, static_cast<float>(kUp));
  mesh.normals.emplace_back(1.0f, 0.0f, 0.0f);
  const GroundGrid grid = bake_ground_grid(mesh, geom::Dome(2), geom::DomeBasis::Faces, 32, 0.2, 256);
  const double seen = uniform_sky_ground_light(mesh, grid, 4096)[probe];
  double expected = 0.0;
  constexpr int kSteps = 20000;
  for (int k = 0; k < kSteps; ++k) {
    const double theta = (k + 0.5) * (kPi / 2) / kSteps;
    const double d = kUp / std::tan(theta);
    const double ground = (1.0 + d / std::hypot(d, kHeight)) / 2.0;  // E(d) / π: the ground's radiance
    expected += kPi * ground * std::cos(theta) / 2.0 * (kPi / 2) / kSteps;
  }
  // Unshadowed it would be π/2; the wall takes about a fifth of that away.
  EXPECT_LT(expected, 0.85 * kPi / 2);
  EXPECT_NEAR(seen, expected, 0.01 * kPi / 2) << "the wall's own shadow on the ground, as the vertex sees it";
}

TEST(GroundTransfer, BuriedAndEnclosedVerticesSeeNoGround) {
  // A box below the ground, and a vertex inside a closed box standing on it.
  scene::Mesh mesh = mesh_of({Box{{-3, -3, -2}, {-1, -1, -1}}, Box{{1, 1, 0}, {3, 3, 2}}});
  const auto enclosed = static_cast<std::uint32_t>(mesh.positions.size());
  mesh.positions.emplace_back(2.0f, 2.0f, 1.0f);
  mesh.normals.emplace_back(0.0f, -0.6f, -0.8f);
  const GroundGrid grid = bake_ground_grid(mesh, geom::Dome(2), geom::DomeBasis::Corners, 16);
  const std::vector<float> t = ground_transfer(mesh, {}, grid, 256);
  const std::size_t layers = grid.layers();
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const bool buried = mesh.positions[v].z() < -0.5f;
    if (!buried && v != enclosed) continue;
    for (std::size_t l = 0; l < layers; ++l) ASSERT_EQ(t[v * layers + l], 0.0f) << "vertex " << v << " layer " << l;
  }
}

}  // namespace ground_transfer_test
}  // namespace skylit::baker
