// The ground's coefficients (blend::GroundLayers): each separated source joins the layers of the
// face it lies in without changing the horizontal irradiance Σ_l S^g_l A_l(z), in every basis;
// a source on or below the horizon lights no ground; bad sizes are refused.
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/geom/dome.hpp"

namespace skylit::blend {
namespace ground_layers_test {  // named, not anonymous: the test program is one unity build

using Eigen::Vector3d;

// A_l(z) for every layer, by the same quadrature the bake uses.
std::vector<double> horizontal(const geom::Dome& dome, geom::DomeBasis basis) {
  std::vector<double> out;
  for (int i = 0; i < dome.face_count(); ++i) {
    const geom::DomeBasis split = basis == geom::DomeBasis::Faces ? geom::DomeBasis::Corners : basis;
    const geom::FaceQuadrature q = geom::face_quadrature(dome, i, geom::kDefaultQuadratureSubdivisions, split);
    const std::vector<double> shares = geom::layer_cosine_integrals(dome, i, q, Vector3d::UnitZ());
    if (basis == geom::DomeBasis::Faces) {
      double a = 0.0;
      for (double x : shares) a += x;
      out.push_back(a);
    } else {
      out.insert(out.end(), shares.begin(), shares.end());
    }
  }
  return out;
}

Vector3d horizontal_irradiance(const std::vector<Vector3d>& coefficients, const std::vector<double>& a) {
  Vector3d sum = Vector3d::Zero();
  for (std::size_t l = 0; l < a.size(); ++l) sum += a[l] * coefficients[l];
  return sum;
}

TEST(GroundLayers, ASourceJoinsItsFacesLayersAndKeepsTheHorizontalIrradiance) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const geom::DomeBasis basis : {geom::DomeBasis::Faces, geom::DomeBasis::Corners, geom::DomeBasis::Quadratics}) {
    const geom::Dome dome(4);
    const std::vector<double> a = horizontal(dome, basis);
    const GroundLayers layers(4, basis, a);
    std::vector<Vector3d> S(a.size());
    for (Vector3d& s : S) s = Vector3d(unit(random), unit(random), unit(random));
    EXPECT_EQ(layers.coefficients(S, {}), S) << "no source: the sky's own coefficients";
    for (int trial = 0; trial < 20; ++trial) {
      const double elevation = 0.02 + 1.5 * unit(random), azimuth = 2 * std::numbers::pi * unit(random);
      const SunLight sun{Vector3d(std::cos(elevation) * std::sin(azimuth), std::cos(elevation) * std::cos(azimuth), std::sin(elevation)),
                         Vector3d(90, 80, 70)};
      const std::vector<Vector3d> g = layers.coefficients(S, std::vector{sun});
      const Vector3d expected = horizontal_irradiance(S, a) + std::sin(elevation) * sun.energy;
      EXPECT_LT((horizontal_irradiance(g, a) - expected).norm(), 1e-9 * expected.norm()) << geom::basis_name(basis);
      // Only the layers of the sun's face change.
      const int face = dome.face_of(sun.direction);
      const int per_face = geom::layers_per_face(basis);
      for (std::size_t l = 0; l < S.size(); ++l) {
        if (static_cast<int>(l) / per_face != face) {
          EXPECT_EQ(g[l], S[l]) << "layer " << l;
        }
      }
    }
  }
}

TEST(GroundLayers, ASourceOnOrBelowTheHorizonOrNotFiniteLightsNoGround) {
  const geom::Dome dome(2);
  const std::vector<double> a = horizontal(dome, geom::DomeBasis::Corners);
  const GroundLayers layers(2, geom::DomeBasis::Corners, a);
  const std::vector<Vector3d> S(a.size(), Vector3d(1, 1, 1));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<SunLight> none{{Vector3d(1, 0, 0), Vector3d(50, 50, 50)},
                                   {Vector3d(0.3, 0.2, -0.5), Vector3d(50, 50, 50)},
                                   {Vector3d::Zero(), Vector3d(50, 50, 50)},
                                   {Vector3d(nan, 0, 1), Vector3d(50, 50, 50)}};
  EXPECT_EQ(layers.coefficients(S, none), S);
  const std::vector<Vector3d> g = layers.coefficients(S, std::vector<SunLight>{{Vector3d(0, 0, 1), Vector3d(nan, 4, 4)}});
  EXPECT_NEAR(horizontal_irradiance(g, a).x(), horizontal_irradiance(S, a).x(), 1e-9) << "a NaN channel counts as 0";
  EXPECT_NEAR(horizontal_irradiance(g, a).y(), horizontal_irradiance(S, a).y() + 4, 1e-9);
  EXPECT_THROW(GroundLayers(2, geom::DomeBasis::Corners, std::vector<double>(a.size() - 1)), std::invalid_argument);
  EXPECT_THROW((void)layers.coefficients(std::vector<Vector3d>(3), {}), std::invalid_argument);
}

// The ground's term in vertex_irradiance: ρ ⊙ Σ_l S^g_l t^g_{v,l}, bad sizes refused.
TEST(GroundLayers, TheVertexIrradianceAddsTheReflectedLight) {
  const std::vector<float> transfer{1.0f, 2.0f, 0.5f, 0.0f};  // 2 vertices × 2 layers
  const std::vector<float> ground{0.25f, 0.5f, std::numeric_limits<float>::quiet_NaN(), -1.0f};
  const std::vector<Vector3d> S{Vector3d(1, 2, 3), Vector3d(4, 5, 6)};
  const std::vector<Eigen::Vector3f> normals{Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY()};
  GroundLight light{ground, {Vector3d(2, 2, 2), Vector3d(1, 1, 1)}, Vector3d(0.5, 0.25, 0)};
  const std::vector<Vector3d> E = vertex_irradiance(transfer, S, normals, {}, {}, light);
  EXPECT_LT((E[0] - (S[0] + 2 * S[1] + Vector3d(0.5, 0.25, 0).cwiseProduct(Vector3d(1, 1, 1)))).norm(), 1e-12);
  EXPECT_LT((E[1] - 0.5 * S[0]).norm(), 1e-12) << "non-finite and negative ground transfer counts as 0";
  light.coefficients.pop_back();
  EXPECT_THROW(vertex_irradiance(transfer, S, normals, {}, {}, light), std::invalid_argument);
}

}  // namespace ground_layers_test
}  // namespace skylit::blend
