#include "skylit/geom/dome.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <set>
#include <stdexcept>

namespace skylit::geom {
namespace {

constexpr double kPi = std::numbers::pi;

// Whether the spherical triangle holds `d`: on the inner side of all three great circles, within
// `tolerance` (radians of distance from the edge circle, roughly).
bool contains(const SphericalTriangle& t, const Vec3& d, double tolerance) {
  const Vec3 u = d.normalized();
  return t.a.cross(t.b).normalized().dot(u) >= -tolerance &&
         t.b.cross(t.c).normalized().dot(u) >= -tolerance &&
         t.c.cross(t.a).normalized().dot(u) >= -tolerance;
}

Vec3 slerp(const Vec3& a, const Vec3& b, double s) {
  const double angle = std::atan2(a.cross(b).norm(), a.dot(b));
  return (std::sin((1 - s) * angle) * a + std::sin(s * angle) * b) / std::sin(angle);
}

TEST(Dome, RejectsOddSmallAndHugeFrequencies) {
  for (const int nu : {-2, 0, 1, 3, 5, 7, 66, 128}) {
    EXPECT_THROW(Dome{nu}, std::invalid_argument) << nu;
  }
  EXPECT_NO_THROW(Dome{64});
}

TEST(Dome, FaceCountsAreTenNuSquared) {
  EXPECT_EQ(Dome(2).face_count(), 40);
  EXPECT_EQ(Dome(4).face_count(), 160);
  EXPECT_EQ(Dome(6).face_count(), 360);
  EXPECT_EQ(Dome(8).face_count(), 640);
  EXPECT_EQ(Dome(64).face_count(), 10 * 64 * 64);
}

TEST(Dome, SolidAnglesSumToTwoPi) {
  for (int nu = 2; nu <= 16; nu += 2) {
    const Dome dome(nu);
    double sum = 0.0;
    for (const DomeFace& f : dome.faces()) {
      EXPECT_GT(f.solid_angle, 0.0);
      sum += f.solid_angle;
    }
    EXPECT_NEAR(sum, 2.0 * kPi, 1e-9) << "nu=" << nu;
  }
}

TEST(Dome, VerticesAreUnitAndNotBelowTheHorizon) {
  for (const int nu : {2, 4, 8, 16}) {
    const Dome dome(nu);
    int on_horizon = 0;
    for (const Vec3& v : dome.vertices()) {
      EXPECT_GE(v.z(), 0.0);
      EXPECT_NEAR(v.norm(), 1.0, 1e-15);
      on_horizon += v.z() == 0.0;
    }
    // The horizon carries 10·ν/2 edges, hence as many vertices (a closed ring).
    EXPECT_EQ(on_horizon, 5 * nu) << nu;
    // Euler on the hemisphere (a disc): V − E + F = 1 with E = (3F + horizon edges) / 2.
    const int edges = (3 * dome.face_count() + 5 * nu) / 2;
    EXPECT_EQ(static_cast<int>(dome.vertices().size()) - edges + dome.face_count(), 1);
  }
}

TEST(Dome, FacesAreCounterClockwiseWithCentresAndExactSolidAngles) {
  const Dome dome(8);
  for (int i = 0; i < dome.face_count(); ++i) {
    const SphericalTriangle t = dome.triangle(i);
    EXPECT_GT(t.a.cross(t.b).dot(t.c), 0.0);
    const Vec3 mean = (t.a + t.b + t.c).normalized();
    EXPECT_LT((dome.face(i).centre - mean).norm(), 1e-15);
    EXPECT_EQ(dome.face(i).solid_angle, solid_angle(t));
    // Girard's theorem as an independent check of the solid angle.
    const auto angle = [](const Vec3& at, const Vec3& p, const Vec3& q) {
      const Vec3 tp = p - p.dot(at) * at, tq = q - q.dot(at) * at;
      return std::atan2(tp.cross(tq).norm(), tp.dot(tq));
    };
    const double excess = angle(t.a, t.b, t.c) + angle(t.b, t.c, t.a) + angle(t.c, t.a, t.b) - kPi;
    EXPECT_NEAR(dome.face(i).solid_angle, excess, 1e-12);
  }
}

TEST(Dome, FacesOrderedByZenithThenAzimuth) {
  const Dome dome(6);
  // The first five faces surround the zenith vertex, in azimuth order from east.
  for (int i = 0; i < 5; ++i) {
    const auto& v = dome.face(i).vertex;
    EXPECT_TRUE(dome.vertices()[static_cast<std::size_t>(v[0])].z() == 1.0 ||
                dome.vertices()[static_cast<std::size_t>(v[1])].z() == 1.0 ||
                dome.vertices()[static_cast<std::size_t>(v[2])].z() == 1.0);
  }
  double previous_zenith = -1.0, previous_azimuth = -1.0;
  for (const DomeFace& f : dome.faces()) {
    const double zenith = std::atan2(std::hypot(f.centre.x(), f.centre.y()), f.centre.z());
    double azimuth = std::atan2(f.centre.y(), f.centre.x());
    if (azimuth < -1e-12) azimuth += 2 * kPi;
    if (zenith > previous_zenith + 1e-9) {
      previous_azimuth = -1.0;
    } else {
      EXPECT_NEAR(zenith, previous_zenith, 1e-9);
      EXPECT_GT(azimuth, previous_azimuth);
    }
    previous_zenith = std::max(previous_zenith, zenith);
    previous_azimuth = azimuth;
  }
  // Deterministic: a second dome is identical.
  const Dome again(6);
  for (int i = 0; i < dome.face_count(); ++i) {
    EXPECT_EQ(dome.face(i).vertex, again.face(i).vertex);
    EXPECT_EQ(dome.face(i).centre, again.face(i).centre);
  }
}

TEST(Dome, NeighboursAreSymmetricAndShareTheEdge) {
  for (const int nu : {2, 4, 8}) {
    const Dome dome(nu);
    int horizon_edges = 0;
    for (int i = 0; i < dome.face_count(); ++i) {
      const DomeFace& f = dome.face(i);
      for (std::size_t k = 0; k < 3; ++k) {
        const int a = f.vertex[k], b = f.vertex[(k + 1) % 3];
        const int n = f.neighbour[k];
        if (n < 0) {
          ++horizon_edges;
          EXPECT_EQ(dome.vertices()[static_cast<std::size_t>(a)].z(), 0.0);
          EXPECT_EQ(dome.vertices()[static_cast<std::size_t>(b)].z(), 0.0);
          continue;
        }
        const DomeFace& g = dome.face(n);
        bool back = false;
        for (std::size_t m = 0; m < 3; ++m) {
          if (g.neighbour[m] == i) {
            back = true;
            // The same edge, traversed the other way (both faces counter-clockwise).
            EXPECT_EQ(g.vertex[m], b);
            EXPECT_EQ(g.vertex[(m + 1) % 3], a);
          }
        }
        EXPECT_TRUE(back) << "face " << i << " edge " << k;
      }
    }
    EXPECT_EQ(horizon_edges, 5 * nu);
  }
}

TEST(Dome, MillionRandomDirectionsLandInAFaceThatContainsThem) {
  std::mt19937_64 generator(20240611);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const int nu : {2, 8, 16}) {
    const Dome dome(nu);
    const int count = nu == 8 ? 1000000 : 200000;
    std::vector<int> hits(static_cast<std::size_t>(dome.face_count()), 0);
    int failures = 0;
    for (int s = 0; s < count; ++s) {
      const double z = unit(generator), phi = 2 * kPi * unit(generator);
      const double r = std::sqrt(std::max(0.0, 1 - z * z));
      const Vec3 d(r * std::cos(phi), r * std::sin(phi), z);
      const int f = dome.face_of(3.7 * d);  // length does not matter
      if (f < 0 || !contains(dome.triangle(f), d, 1e-12)) ++failures;
      if (f >= 0) ++hits[static_cast<std::size_t>(f)];
    }
    EXPECT_EQ(failures, 0) << "nu=" << nu;
    // Uniform directions: hits per face follow the solid angles (binomial, 5σ).
    for (int i = 0; i < dome.face_count(); ++i) {
      const double p = dome.face(i).solid_angle / (2 * kPi);
      EXPECT_NEAR(hits[static_cast<std::size_t>(i)], count * p, 5 * std::sqrt(count * p * (1 - p)) + 1);
    }
  }
}

TEST(Dome, PointsJustInsideAFaceLandInIt) {
  for (const int nu : {2, 4, 8, 16}) {
    const Dome dome(nu);
    for (int i = 0; i < dome.face_count(); ++i) {
      const DomeFace& f = dome.face(i);
      ASSERT_EQ(dome.face_of(f.centre), i);
      const SphericalTriangle t = dome.triangle(i);
      // Near each vertex and each edge midpoint, pulled 1e-7 of the way towards the centre.
      for (const Vec3& corner : {t.a, t.b, t.c, (t.a + t.b).normalized().eval(),
                                 (t.b + t.c).normalized().eval(), (t.c + t.a).normalized().eval()}) {
        const Vec3 nudged = (corner + 1e-7 * (f.centre - corner)).normalized();
        EXPECT_EQ(dome.face_of(nudged), i) << "nu=" << nu << " face " << i;
      }
    }
  }
}

TEST(Dome, VerticesEdgesAndHorizonGetAContainingFace) {
  for (const int nu : {2, 4, 8, 16, 64}) {
    const Dome dome(nu);
    const auto check = [&](const Vec3& d) {
      const int f = dome.face_of(d);
      ASSERT_GE(f, 0) << d.transpose();
      EXPECT_TRUE(contains(dome.triangle(f), d, 1e-12)) << "nu=" << nu << " d=" << d.transpose();
      EXPECT_EQ(dome.face_of(d), f);  // the same answer every time
    };
    for (const Vec3& v : dome.vertices()) check(v);
    for (int i = 0; i < dome.face_count(); ++i) {
      const SphericalTriangle t = dome.triangle(i);
      for (const double s : {0.0, 1e-13, 0.25, 0.5, 1.0 / 3.0, 0.75, 1.0 - 1e-13}) {
        check(slerp(t.a, t.b, s));
        check(slerp(t.b, t.c, s));
        check(slerp(t.c, t.a, s));
      }
    }
    for (int k = 0; k < 3600; ++k) {
      const double phi = 2 * kPi * k / 3600.0;
      const Vec3 d(std::cos(phi), std::sin(phi), 0.0);
      check(d);
      const int f = dome.face_of(d);
      // A horizon direction between vertices belongs to a face with a horizon edge.
      bool at_vertex = false;
      for (const Vec3& v : dome.vertices()) at_vertex = at_vertex || (v - d).norm() < 1e-12;
      const auto& n = dome.face(f).neighbour;
      EXPECT_TRUE(at_vertex || n[0] < 0 || n[1] < 0 || n[2] < 0) << "nu=" << nu << " k=" << k;
    }
    check(Vec3(0, 0, 1e-300));
    check(Vec3(1, 0, 0));
    check(Vec3(-1, 0, 0));
    check(Vec3(1e-300, 1e-300, 0.0));
  }
}

TEST(Dome, BelowHorizonZeroAndNonFiniteGiveMinusOne) {
  const Dome dome(4);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(dome.face_of(Vec3(0, 0, -1)), -1);
  EXPECT_EQ(dome.face_of(Vec3(1, 0, -1e-300)), -1);
  EXPECT_EQ(dome.face_of(Vec3(0.3, 0.2, -0.1)), -1);
  EXPECT_EQ(dome.face_of(Vec3::Zero()), -1);
  EXPECT_EQ(dome.face_of(Vec3(nan, 0, 1)), -1);
  EXPECT_EQ(dome.face_of(Vec3(0, 0, nan)), -1);
  EXPECT_EQ(dome.face_of(Vec3(inf, 0, 1)), -1);
  EXPECT_EQ(dome.face_of(Vec3(0, 0, inf)), -1);
  EXPECT_EQ(dome.face_of(Vec3(0, 0, 1)), dome.face_of(Vec3(0, 0, 1)));
  EXPECT_GE(dome.face_of(Vec3(0, 0, 1)), 0);
}

TEST(Dome, CosineIntegralsOverAllFacesMatchTheHemisphere) {
  for (const int nu : {2, 8}) {
    const Dome dome(nu);
    double up = 0.0, east = 0.0, down = 0.0, tilted = 0.0;
    for (int i = 0; i < dome.face_count(); ++i) {
      up += cosine_integral(dome.triangle(i), Vec3(0, 0, 1));
      east += cosine_integral(dome.triangle(i), Vec3(1, 0, 0));
      down += cosine_integral(dome.triangle(i), Vec3(0, 0, -1));
      tilted += cosine_integral(dome.triangle(i), Vec3(std::sin(0.6), 0, std::cos(0.6)));
    }
    EXPECT_NEAR(up, kPi, 1e-9);
    // ∫ over the upper hemisphere of max(0, x) dω is half of the full-sphere lobe π.
    EXPECT_NEAR(east, kPi / 2, 1e-9);
    EXPECT_EQ(down, 0.0);
    // A plane tilted by θ sees π(1 + cos θ)/2 of the sky (the classic sky view factor).
    EXPECT_NEAR(tilted, kPi * (1 + std::cos(0.6)) / 2, 1e-9);
  }
}

}  // namespace
}  // namespace skylit::geom
