#include "skylit/geom/spherical.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

namespace skylit::geom {
namespace spherical_test {  // named, not anonymous: the test program is one unity build

constexpr double kPi = std::numbers::pi;

const SphericalTriangle kOctant{Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};

SphericalTriangle around_zenith(double zenith) {  // equilateral, centred on +z
  const auto at = [zenith](double azimuth) {
    return Vec3(std::sin(zenith) * std::cos(azimuth), std::sin(zenith) * std::sin(azimuth), std::cos(zenith));
  };
  return {at(0.0), at(2 * kPi / 3), at(4 * kPi / 3)};
}

bool contains(const SphericalTriangle& t, const Vec3& d, double tolerance) {
  return t.a.cross(t.b).normalized().dot(d) >= -tolerance &&
         t.b.cross(t.c).normalized().dot(d) >= -tolerance &&
         t.c.cross(t.a).normalized().dot(d) >= -tolerance;
}

// Lambert's formula without clipping, written independently (acos, normalized cross products).
double lambert_unclipped(const SphericalTriangle& t, const Vec3& n) {
  const std::array<Vec3, 3> v{t.a, t.b, t.c};
  double sum = 0.0;
  for (std::size_t k = 0; k < 3; ++k) {
    const Vec3& p = v[k];
    const Vec3& q = v[(k + 1) % 3];
    sum += std::acos(std::clamp(p.dot(q), -1.0, 1.0)) * n.dot(p.cross(q).normalized());
  }
  return 0.5 * sum;
}

TEST(SolidAngle, AnalyticCases) {
  EXPECT_NEAR(solid_angle(kOctant), kPi / 2, 1e-15);
  // A cap-like triangle: three points at zenith angle θ spaced 120° apart; Girard gives the
  // excess from the vertex angles, checked against a tiny and a large one.
  for (const double zenith : {1e-6, 0.1, 0.7, 1.2}) {
    const SphericalTriangle t = around_zenith(zenith);
    // Flat limit: area ≈ (3√3/4) sin²θ for small θ.
    if (zenith < 1e-3) {
      EXPECT_NEAR(solid_angle(t) / (0.75 * std::sqrt(3.0) * zenith * zenith), 1.0, 1e-9);
    }
    EXPECT_GT(solid_angle(t), 0.0);
  }
  // More than a hemisphere's worth of excess is still right (atan2 keeps the quadrant).
  const SphericalTriangle wide = around_zenith(1.5);
  const double cos_side = wide.a.dot(wide.b);
  const double side = std::acos(cos_side);
  const double angle = std::acos((cos_side - cos_side * cos_side) / (std::sin(side) * std::sin(side)));
  EXPECT_NEAR(solid_angle(wide), 3 * angle - kPi, 1e-12);
  EXPECT_GT(solid_angle(wide), kPi / 2);
  // Scale-invariant in its inputs; clockwise gives the negative.
  EXPECT_NEAR(solid_angle({2.0 * kOctant.a, kOctant.b, 5.0 * kOctant.c}), kPi / 2, 1e-15);
  EXPECT_NEAR(solid_angle({kOctant.a, kOctant.c, kOctant.b}), -kPi / 2, 1e-15);
}

TEST(CosineIntegral, OctantAnalytic) {
  EXPECT_NEAR(cosine_integral(kOctant, Vec3(0, 0, 1)), kPi / 4, 1e-14);
  EXPECT_NEAR(cosine_integral(kOctant, Vec3(1, 0, 0)), kPi / 4, 1e-14);
  EXPECT_NEAR(cosine_integral(kOctant, Vec3(1, 1, 1)), 3 * kPi / 4, 1e-14);  // scales with |n|
  EXPECT_EQ(cosine_integral(kOctant, Vec3(-1, -1, -1)), 0.0);
  EXPECT_EQ(cosine_integral(kOctant, Vec3(0, 0, -1)), 0.0);   // touches the plane along an edge
  EXPECT_EQ(cosine_integral(kOctant, Vec3::Zero()), 0.0);
  // Straddling: n = (1, −1, 0) sees the half x ≥ y of the octant, the triangle
  // (x̂, (x̂+ŷ)/√2, ẑ), which lies wholly in front, so the unclipped formula applies to it.
  const SphericalTriangle half{Vec3(1, 0, 0), Vec3(1, 1, 0).normalized(), Vec3(0, 0, 1)};
  EXPECT_NEAR(cosine_integral(kOctant, Vec3(1, -1, 0)), lambert_unclipped(half, Vec3(1, -1, 0)), 1e-14);
}

TEST(CosineIntegral, InFrontAgreesWithTheUnclippedFormula) {
  std::mt19937_64 generator(7);
  std::normal_distribution<double> gauss;
  int compared = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    SphericalTriangle t{Vec3(gauss(generator), gauss(generator), gauss(generator)).normalized(),
                        Vec3(gauss(generator), gauss(generator), gauss(generator)).normalized(),
                        Vec3(gauss(generator), gauss(generator), gauss(generator)).normalized()};
    if (t.a.cross(t.b).dot(t.c) < 0) std::swap(t.b, t.c);
    const Vec3 n(gauss(generator), gauss(generator), gauss(generator));
    if (n.dot(t.a) <= 0 || n.dot(t.b) <= 0 || n.dot(t.c) <= 0) continue;
    ++compared;
    EXPECT_NEAR(cosine_integral(t, n), lambert_unclipped(t, n), 1e-12 * n.norm());
  }
  EXPECT_GT(compared, 100);
}

TEST(CosineIntegral, AgreesWithMonteCarloForEveryCase) {
  // A large triangle around the zenith, sampled once, integrated against several normals.
  const SphericalTriangle t = around_zenith(1.0);
  const double area = solid_angle(t);
  std::mt19937_64 generator(42);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  constexpr int kSamples = 1000000;
  std::vector<Vec3> samples(kSamples);
  for (Vec3& s : samples) s = sample_uniform(t, unit(generator), unit(generator));
  const std::array<Vec3, 6> normals{Vec3(0, 0, 1),                                // up: all in front
                                    Vec3(std::sin(0.4), 0, std::cos(0.4)),        // tilted
                                    Vec3(1, 0, 0),                                // horizontal: straddles
                                    Vec3(0.3, -0.8, 0.2).normalized(),            // straddling, oblique
                                    Vec3(0, 0, -1),                               // facing away
                                    Vec3(-0.2, 0.1, -1).normalized()};            // away, tilted
  for (const Vec3& n : normals) {
    double sum = 0.0, sum_squares = 0.0;
    for (const Vec3& s : samples) {
      const double f = std::max(0.0, n.dot(s));
      sum += f;
      sum_squares += f * f;
    }
    const double mean = sum / kSamples;
    const double sigma = area * std::sqrt(std::max(0.0, sum_squares / kSamples - mean * mean) / kSamples);
    const double exact = cosine_integral(t, n);
    if (sum == 0.0) {
      EXPECT_EQ(exact, 0.0) << n.transpose();
    } else {
      EXPECT_NEAR(exact, area * mean, 4 * sigma + 1e-12) << n.transpose() << " sigma " << sigma;
      EXPECT_LT(sigma, 1e-3);
    }
  }
}

TEST(CosineIntegral, PolygonEqualsItsTriangles) {
  // A spherical quadrilateral around the zenith, counter-clockwise seen from outside.
  const double s = 0.5;
  const std::array<Vec3, 4> quad{Vec3(s, -s, 1).normalized(), Vec3(s, s, 1).normalized(),
                                 Vec3(-s, s, 1).normalized(), Vec3(-s, -s, 1).normalized()};
  for (const Vec3& n : {Vec3(0, 0, 1), Vec3(1, 0, 0.1), Vec3(0.2, -1, 0), Vec3(0, 0, -1)}) {
    const double whole = cosine_integral(std::span<const Vec3>(quad), n);
    const double parts = cosine_integral(SphericalTriangle{quad[0], quad[1], quad[2]}, n) +
                         cosine_integral(SphericalTriangle{quad[0], quad[2], quad[3]}, n);
    EXPECT_NEAR(whole, parts, 1e-14) << n.transpose();
  }
  // Fewer than three vertices: no area.
  const std::array<Vec3, 2> segment{quad[0], quad[1]};
  EXPECT_EQ(cosine_integral(std::span<const Vec3>(segment), Vec3(0, 0, 1)), 0.0);
}

TEST(CosineIntegral, TinyTrianglesKeepRelativeAccuracy) {
  // For a tiny triangle the integral is Ω (n·centre) to first order.
  for (const double zenith : {1e-3, 1e-5}) {
    SphericalTriangle t = around_zenith(zenith);
    const Eigen::AngleAxisd tilt(0.5, Vec3(0, 1, 0));
    t = {tilt * t.a, tilt * t.b, tilt * t.c};
    const Vec3 n(0, 0, 1);
    const Vec3 centre = (t.a + t.b + t.c).normalized();
    EXPECT_NEAR(cosine_integral(t, n) / (solid_angle(t) * n.dot(centre)), 1.0, 1e-6) << zenith;
  }
}

TEST(SampleUniform, LandsInsideAndIsAreaUniform) {
  const SphericalTriangle t{Vec3(0.2, 0.1, 1).normalized(), Vec3(1, 0.3, 0.4).normalized(),
                            Vec3(-0.1, 1, 0.5).normalized()};
  ASSERT_GT(t.a.cross(t.b).dot(t.c), 0.0);
  const Vec3 ab = (t.a + t.b).normalized(), bc = (t.b + t.c).normalized(), ca = (t.c + t.a).normalized();
  // Four sub-triangles through the edge midpoints (unequal areas on the sphere).
  const std::array<SphericalTriangle, 4> parts{SphericalTriangle{t.a, ab, ca}, SphericalTriangle{ab, t.b, bc},
                                               SphericalTriangle{ca, bc, t.c}, SphericalTriangle{ab, bc, ca}};
  const double area = solid_angle(t);
  std::array<int, 4> counts{};
  std::mt19937_64 generator(1995);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  constexpr int kSamples = 400000;
  Vec3 mean = Vec3::Zero();
  for (int i = 0; i < kSamples; ++i) {
    const Vec3 p = sample_uniform(t, unit(generator), unit(generator));
    ASSERT_NEAR(p.norm(), 1.0, 1e-12);
    ASSERT_TRUE(contains(t, p, 1e-12)) << p.transpose();
    mean += p;
    for (std::size_t k = 0; k < 4; ++k) {
      if (contains(parts[k], p, 0.0)) {
        ++counts[k];
        break;
      }
    }
  }
  double chi_square = 0.0;
  for (std::size_t k = 0; k < 4; ++k) {
    const double expected = kSamples * solid_angle(parts[k]) / area;
    chi_square += (counts[k] - expected) * (counts[k] - expected) / expected;
  }
  EXPECT_LT(chi_square, 16.27);  // 3 degrees of freedom, p = 0.001
  // Mean direction against ∫ ω dω / Ω = ½ Σ θ_e ĝ_e / Ω (the vector form of Lambert's formula).
  Vec3 exact = Vec3::Zero();
  for (const auto& [p, q] : {std::pair{t.a, t.b}, std::pair{t.b, t.c}, std::pair{t.c, t.a}}) {
    exact += 0.5 * std::atan2(p.cross(q).norm(), p.dot(q)) * p.cross(q).normalized();
  }
  exact /= area;
  mean /= kSamples;
  EXPECT_LT((mean - exact).norm(), 2e-3);  // σ per component ≈ 0.3/√N ≈ 5e-4
  // The corners of the unit square map to the vertices.
  EXPECT_LT((sample_uniform(t, 0.0, 0.0) - t.b).norm(), 1e-12);
  EXPECT_LT((sample_uniform(t, 1.0, 1.0) - t.c).norm(), 1e-9);
  // u2 = 1 puts the point on the arc AC.
  EXPECT_NEAR(t.a.cross(t.c).normalized().dot(sample_uniform(t, 0.5, 1.0)), 0.0, 1e-12);
}

// Inverse of Arvo's first coordinate: the area fraction of the sub-triangle A B Ĉ, Ĉ where the
// great circle through B and p meets the arc AC.
double arvo_u1(const SphericalTriangle& t, const Vec3& p) {
  Vec3 c_hat = t.b.cross(p).cross(t.a.cross(t.c)).normalized();
  if (c_hat.dot(t.a + t.c) < 0) c_hat = -c_hat;
  return solid_angle({t.a, t.b, c_hat}) / solid_angle(t);
}

TEST(StratifiedSamples, DeterministicCountedInsideAndStratified) {
  const SphericalTriangle t = around_zenith(0.3);
  for (const int count : {1, 2, 7, 12, 16, 64}) {
    const auto samples = stratified_samples(t, count, 99);
    ASSERT_EQ(samples.size(), static_cast<std::size_t>(count));
    EXPECT_EQ(samples, stratified_samples(t, count, 99));
    if (count > 1) {
      EXPECT_NE(samples, stratified_samples(t, count, 100));
    }
    int rows = 1;
    for (int r = 1; r * r <= count; ++r) rows = count % r == 0 ? r : rows;
    const int cols = count / rows;
    for (int k = 0; k < count; ++k) {
      const Vec3& p = samples[static_cast<std::size_t>(k)];
      EXPECT_TRUE(contains(t, p, 1e-12));
      // Row-major jittered grid: sample k lies in row k / cols of the u1 strata.
      const double u1 = arvo_u1(t, p);
      const int row = k / cols;
      EXPECT_GE(u1, static_cast<double>(row) / rows - 1e-9) << count << " " << k;
      EXPECT_LE(u1, static_cast<double>(row + 1) / rows + 1e-9) << count << " " << k;
    }
  }
  EXPECT_THROW(stratified_samples(t, 0, 1), std::invalid_argument);
}

}  // namespace
}  // namespace skylit::geom
