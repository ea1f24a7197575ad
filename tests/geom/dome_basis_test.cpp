// The corners basis over the dome: barycentric hats, the face quadrature and the corner cosine
// integrals A_{f,k}.
#include "skylit/geom/dome_basis.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <random>

namespace skylit::geom {
namespace {

Vec3 vertex(const Dome& d, int face, int k) {
  return d.vertices()[static_cast<std::size_t>(d.face(face).vertex[static_cast<std::size_t>(k)])];
}

TEST(DomeBasis, NamesAndLayers) {
  EXPECT_EQ(basis_name(DomeBasis::Faces), "faces");
  EXPECT_EQ(basis_name(DomeBasis::Corners), "corners");
  EXPECT_EQ(parse_basis("corners"), DomeBasis::Corners);
  EXPECT_EQ(parse_basis("faces"), DomeBasis::Faces);
  EXPECT_FALSE(parse_basis("Corners"));
  EXPECT_FALSE(parse_basis(""));
  EXPECT_EQ(layers_per_face(DomeBasis::Faces), 1);
  EXPECT_EQ(layers_per_face(DomeBasis::Corners), 3);
  EXPECT_EQ(basis_name(DomeBasis::Quadratics), "quadratics");
  EXPECT_EQ(parse_basis("quadratics"), DomeBasis::Quadratics);
  EXPECT_EQ(layers_per_face(DomeBasis::Quadratics), 6);
}

TEST(QuadraticValues, AreBernsteinPolynomialsThatHoldEveryLinearFunction) {
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int s = 0; s < 100; ++s) {
    double u = unit(random), v = unit(random);
    if (u + v > 1.0) {
      u = 1.0 - u;
      v = 1.0 - v;
    }
    const std::array<double, 3> l{1.0 - u - v, u, v};
    const LayerValues q = layer_values(DomeBasis::Quadratics, l);
    double sum = 0;
    for (const double x : q) {
      EXPECT_GE(x, 0.0);
      sum += x;
    }
    EXPECT_NEAR(sum, 1.0, 1e-15);
    // P maps the six functions onto the three hats; a linear function written with
    // corner_to_quadratic takes the same value.
    const Eigen::Matrix<double, 6, 1> phi = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(q.data());
    const Eigen::Vector3d hats = quadratic_to_corner() * phi;
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(hats[k], l[static_cast<std::size_t>(k)], 1e-15);
    const Eigen::Vector3d c(2.0, -1.0, 0.5);
    EXPECT_NEAR(phi.dot(corner_to_quadratic() * c), c.dot(Eigen::Vector3d(l[0], l[1], l[2])), 1e-14);
    const LayerValues corners = layer_values(DomeBasis::Corners, l);
    EXPECT_EQ(corners[0], l[0]);
    EXPECT_EQ(corners[3], 0.0);
    EXPECT_EQ(layer_values(DomeBasis::Faces, l)[0], 1.0);
  }
  // At a vertex only its own square is 1; at an edge midpoint the edge's function is 1/2.
  EXPECT_EQ(layer_values(DomeBasis::Quadratics, {0.0, 1.0, 0.0}), (LayerValues{0, 1, 0, 0, 0, 0}));
  EXPECT_EQ(layer_values(DomeBasis::Quadratics, {0.0, 0.5, 0.5}), (LayerValues{0, 0.25, 0.25, 0, 0.5, 0}));
}

TEST(QuadraticCosineIntegrals, SumToTheExactIntegralAndSplitIntoTheCorners) {
  const Dome dome(2);
  std::mt19937_64 random(13);
  std::normal_distribution<double> gauss;
  const Eigen::Matrix<double, 3, 6> to_corner = quadratic_to_corner();
  for (int f = 0; f < dome.face_count(); f += 3) {
    const FaceQuadrature corners = face_quadrature(dome, f);
    const FaceQuadrature quadratics = face_quadrature(dome, f, kDefaultQuadratureSubdivisions, DomeBasis::Quadratics);
    EXPECT_EQ(quadratics.layers, 6);
    ASSERT_EQ(quadratics.mass.rows(), 6);
    EXPECT_LT((to_corner * quadratics.mass * to_corner.transpose() - corners.mass).norm(), 1e-14);
    for (int s = 0; s < 16; ++s) {
      const Vec3 n = Vec3(gauss(random), gauss(random), gauss(random)).normalized();
      const double exact = cosine_integral(dome.triangle(f), n);
      const std::vector<double> q = layer_cosine_integrals(dome, f, quadratics, n);
      const std::vector<double> c = layer_cosine_integrals(dome, f, corners, n);
      ASSERT_EQ(q.size(), 6U);
      double sum = 0;
      for (const double x : q) {
        EXPECT_GE(x, 0.0);
        sum += x;
      }
      EXPECT_NEAR(sum, exact, 1e-14);
      // The same nodes: P maps the six shares onto the three corners' exactly.
      const Eigen::Vector3d mapped = to_corner * Eigen::Map<const Eigen::Matrix<double, 6, 1>>(q.data());
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(mapped[k], c[static_cast<std::size_t>(k)], 1e-15 + 1e-12 * exact);
    }
  }
}

TEST(CornerWeights, AreBarycentricOnTheFlatTriangle) {
  const Dome dome(4);
  const CornerWeights weights(dome);
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int f = 0; f < dome.face_count(); f += 5) {
    const Vec3 a = vertex(dome, f, 0), b = vertex(dome, f, 1), c = vertex(dome, f, 2);
    // A vertex is 1 at itself; an edge midpoint splits evenly between its two vertices.
    for (int k = 0; k < 3; ++k) {
      const auto l = weights(f, vertex(dome, f, k));
      for (int m = 0; m < 3; ++m) EXPECT_NEAR(l[static_cast<std::size_t>(m)], m == k ? 1.0 : 0.0, 1e-12);
    }
    const auto mid = weights(f, (a + b).normalized());
    EXPECT_NEAR(mid[0], 0.5, 1e-12);
    EXPECT_NEAR(mid[1], 0.5, 1e-12);
    EXPECT_NEAR(mid[2], 0.0, 1e-12);
    // Any point of the flat triangle, seen along its ray, gives back its barycentric coordinates.
    for (int s = 0; s < 20; ++s) {
      double u = unit(random), v = unit(random);
      if (u + v > 1.0) {
        u = 1.0 - u;
        v = 1.0 - v;
      }
      const Vec3 p = (1.0 - u - v) * a + u * b + v * c;
      const auto l = weights(f, 3.0 * p.normalized());  // the length does not matter
      EXPECT_NEAR(l[0], 1.0 - u - v, 1e-12);
      EXPECT_NEAR(l[1], u, 1e-12);
      EXPECT_NEAR(l[2], v, 1e-12);
    }
  }
}

TEST(FaceQuadrature, TilesTheFaceAndItsMomentsConverge) {
  const Dome dome(2);
  for (int f : {0, 17, 39}) {
    const FaceQuadrature q = face_quadrature(dome, f);
    ASSERT_EQ(q.directions.size(), static_cast<std::size_t>(kDefaultQuadratureSubdivisions * kDefaultQuadratureSubdivisions));
    double total = 0;
    for (double w : q.weights) total += w;
    EXPECT_NEAR(total, dome.face(f).solid_angle, 1e-12);
    for (std::size_t k = 0; k < q.directions.size(); ++k) {
      EXPECT_EQ(dome.face_of(q.directions[k]), f);
      EXPECT_NEAR(q.hats[k][0] + q.hats[k][1] + q.hats[k][2], 1.0, 1e-12);
    }
    // Σ_k ∫ λ_k ω dω = ∫ ω dω: the hats partition the face.
    const Vec3 moment = q.moment[0] + q.moment[1] + q.moment[2];
    Vec3 direct = Vec3::Zero();
    for (std::size_t k = 0; k < q.directions.size(); ++k) direct += q.weights[k] * q.directions[k];
    EXPECT_LT((moment - direct).norm(), 1e-14);
    // Quadrature error: m = 32 against m = 256, relative to the face's moment.
    const FaceQuadrature fine = face_quadrature(dome, f, 256);
    for (std::size_t k = 0; k < 3; ++k) {
      EXPECT_LT((q.moment[k] - fine.moment[k]).norm(), 1.5e-4 * fine.moment[k].norm()) << f;  // measured 7.6e-5
    }
  }
}

TEST(CornerCosineIntegrals, SumToTheExactIntegralAndConverge) {
  const Dome dome(2);
  std::mt19937_64 random(11);
  std::normal_distribution<double> gauss;
  double worst = 0;
  int clipped = 0;
  for (int f = 0; f < dome.face_count(); f += 3) {  // every third face: the zenith cap, the band, the horizon
    const FaceQuadrature q = face_quadrature(dome, f);
    const FaceQuadrature fine = face_quadrature(dome, f, 256);
    for (int s = 0; s < 16; ++s) {
      const Vec3 n = Vec3(gauss(random), gauss(random), gauss(random)).normalized();
      const double exact = cosine_integral(dome.triangle(f), n);
      const auto a = layer_cosine_integrals(dome, f, q, n);
      EXPECT_NEAR(a[0] + a[1] + a[2], exact, 1e-14);
      for (double x : a) EXPECT_GE(x, 0.0);
      const auto b = layer_cosine_integrals(dome, f, fine, n);
      for (std::size_t k = 0; k < 3; ++k) worst = std::max(worst, std::abs(a[k] - b[k]) / dome.face(f).solid_angle);
      bool cut = false;
      for (int k = 0; k < 3; ++k) cut = cut || n.dot(vertex(dome, f, k)) < 0.0;
      clipped += cut && exact > 0.0;
    }
  }
  EXPECT_GT(clipped, 10);  // faces the normal's horizon cuts took the node loop
  // The error of one corner's share, as a fraction of the face's solid angle (docs/method.md).
  EXPECT_LT(worst, 5e-5);  // measured 2.5e-5
  // A face behind the surface gives nothing, one in front of it at normal incidence about Ω/3
  // per corner.
  const auto behind = layer_cosine_integrals(dome, 0, face_quadrature(dome, 0), -Vec3::UnitZ());
  EXPECT_EQ(behind, (std::vector<double>{0.0, 0.0, 0.0}));
  const Vec3 centre = dome.face(0).centre;
  const auto facing = layer_cosine_integrals(dome, 0, face_quadrature(dome, 0), centre);
  for (double x : facing) EXPECT_NEAR(x, cosine_integral(dome.triangle(0), centre) / 3.0, 0.05 * x);
}

}  // namespace
}  // namespace skylit::geom
