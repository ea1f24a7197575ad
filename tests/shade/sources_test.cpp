// Several separated sources end to end (issue 3): a real small bake of a 2 m box on the ground,
// a sky frame with two compact lamps in an otherwise black (or dim) sky, the sky stage with
// max_sources, each lamp's disc ray-cast as an area light, the CPU blend with every source.
// T on the ground matches an independent reference (the lamps' true discs against the box,
// slab-tested ray by ray) and the double-precision blend; max_sources = 1 is today's path;
// black skies and bad pixels stay finite in [0, 1] with their flags.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "../support/box_site.hpp"
#include "../support/quiet_bake.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/camera/lens.hpp"
#include "../support/sky_paint.hpp"
#include "../support/suite_setup.hpp"

namespace skylit {
namespace sources_test {  // named, not anonymous: the test program is one unity build

namespace fs = std::filesystem;
using geom::Vec3;
constexpr double kDeg = std::numbers::pi / 180.0;

using skylit::test::angle;
using skylit::test::from_angles;

struct Lamp {
  Vec3 direction;
  double radius;             // radians
  Eigen::Vector3d radiance;  // RGB at the centre; L0 (1 − 0.3 (θ/r)²) across the disc
};

// The profile across a lamp's disc (brightest at the centre, where the detector's peak is).
double profile(double theta, double radius) { return 1.0 - 0.3 * (theta / radius) * (theta / radius); }

// Lamp A east at 45°, lamp B north at 60°, 3.5° in radius: cores wider than a sun's 3°, so only
// the lamp mode separates them.
const Lamp kLamps[2] = {{from_angles(90.0, 45.0), 3.5 * kDeg, Eigen::Vector3d(40.0, 30.0, 20.0)},
                        {from_angles(0.0, 60.0), 3.5 * kDeg, Eigen::Vector3d(15.0, 25.0, 45.0)}};

// Does the ray from p towards d hit the box [-1, 1]² × [0, 2]? (slab test)
bool hits_box(const Vec3& p, const Vec3& d) {
  double near = 0.0, far = std::numeric_limits<double>::infinity();
  const Vec3 lo(-1, -1, 0), hi(1, 1, 2);
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12) {
      if (p[a] < lo[a] || p[a] > hi[a]) return false;
      continue;
    }
    double t0 = (lo[a] - p[a]) / d[a], t1 = (hi[a] - p[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    near = std::max(near, t0);
    far = std::min(far, t1);
    if (near > far) return false;
  }
  return true;
}

// The visible fraction of a lamp's disc from p, by a polar grid of directions over the cap
// (each weighted by its solid angle).
double disc_visibility(const Vec3& p, const Lamp& lamp) {
  const Vec3 axis = lamp.direction;
  const Vec3 t1 = Vec3::UnitZ().cross(axis).normalized(), t2 = axis.cross(t1);
  double seen = 0.0, total = 0.0;
  const int rings = 12, spokes = 36;
  for (int r = 0; r < rings; ++r) {
    const double theta = (r + 0.5) / rings * lamp.radius;
    for (int s = 0; s < spokes; ++s) {
      const double phi = (s + 0.5) / spokes * 2.0 * std::numbers::pi;
      const Vec3 d = (std::cos(theta) * axis + std::sin(theta) * (std::cos(phi) * t1 + std::sin(phi) * t2)).normalized();
      const double w = std::sin(theta) * profile(theta, lamp.radius);
      total += w;
      if (!hits_box(p, d)) seen += w;
    }
  }
  return seen / total;
}

class SourcesShadeTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new skylit::test::TempDir("skylit-sources-");
    skylit::test::write_box_site(dir_->path(), "dome:\n  frequency: 2\n"
                                        "planes:\n"
                                        "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                        "    v: [0, 12, 0]\n    resolution: [24, 24]\n");
    setup_.run([&] {
      skylit::test::quiet_bake(*dir_ / "site.yaml", *dir_ / "bake");
      manifest_ = new bake_format::Manifest(bake_format::read_manifest(*dir_ / "bake"));
      const scene::Site site = scene::load_site(*dir_ / "site.yaml");
      mesh_ = new scene::Mesh(scene::load_site_model(site));
    });
  }
  void SetUp() override { setup_.require(); }
  static void TearDownTestSuite() {
    delete dir_;
    delete manifest_;
    delete mesh_;
  }

  static camera::CameraCalibration camera() {
    camera::CameraCalibration c;
    c.image_width = c.image_height = 400;
    c.fx = c.fy = 200.0 / (90.0 * kDeg);
    c.cx = c.cy = 199.5;
    c.D = {0, 0, 0, 0};
    return c;
  }

  static sky::RadianceFrame paint(const std::function<Eigen::Vector3d(const Vec3&)>& radiance) {
    return {skylit::test::paint_sky(camera::Lens(camera()), radiance), cv::Mat()};
  }

  static Eigen::Vector3d lamps_on(const Vec3& d, const Eigen::Vector3d& sky) {
    if (d.z() < 0) return Eigen::Vector3d::Zero();
    for (const Lamp& lamp : kLamps) {
      const double a = angle(d, lamp.direction);
      if (a <= lamp.radius) return lamp.radiance * profile(a, lamp.radius);
    }
    return sky;
  }

  struct Outcome {
    sky::SkyEstimate estimate;
    blend::BlendWeights weights;
    std::vector<float> T;                // the ground, RGB
    std::vector<double> T_reference;     // blend_reference_sources with the same inputs
  };

  // As skylit-shade --sources N does it.
  static Outcome shade(const sky::RadianceFrame& frame, int max_sources) {
    const geom::Dome dome(2);
    sky::SkyEstimateOptions options;
    options.max_sources = max_sources;
    const sky::SkyEstimator estimator(camera(), dome, options);
    Outcome o;
    o.estimate = estimator.estimate(frame);
    const std::vector<Eigen::Vector3d> S = sky::layer_radiances(o.estimate.luminance);
    const blend::BasisImages basis = blend::load_basis(*dir_ / "bake", *manifest_, 0);
    std::vector<blend::SunLight> lights;
    std::vector<std::vector<float>> visibility;
    for (const sky::Sun& s : o.estimate.sources) {
      lights.push_back({s.direction, s.energy});
      visibility.emplace_back(basis.texel_count());
      baker::area_light_visibility(*mesh_, manifest_->planes[0].plane, s.disc_directions, s.disc_weights,
                                   visibility.back());
    }
    const std::vector<std::span<const float>> views(visibility.begin(), visibility.end());
    o.weights = blend::blend_weights_sources(basis, S, lights);
    o.T.resize(3 * basis.texel_count());
    blend::blend_cpu_sources(basis, o.weights, views, o.T);
    o.T_reference.resize(o.T.size());
    blend::blend_reference_sources(basis, S, lights, views, o.T_reference);
    return o;
  }

  static void expect_finite_unit(const Outcome& o) {
    for (const float t : o.T) {
      ASSERT_TRUE(std::isfinite(t));
      ASSERT_GE(t, 0.0f);
      ASSERT_LE(t, 1.0f);
    }
  }

  static skylit::test::TempDir* dir_;
  static inline skylit::test::SuiteSetup setup_;
  static bake_format::Manifest* manifest_;
  static scene::Mesh* mesh_;
};

skylit::test::TempDir* SourcesShadeTest::dir_ = nullptr;
bake_format::Manifest* SourcesShadeTest::manifest_ = nullptr;
scene::Mesh* SourcesShadeTest::mesh_ = nullptr;

TEST_F(SourcesShadeTest, TwoLampsInABlackSkyCastBothShadows) {
  const Outcome o = shade(paint([](const Vec3& d) { return lamps_on(d, Eigen::Vector3d::Zero()); }), 4);
  expect_finite_unit(o);
  EXPECT_FALSE(o.estimate.sun) << o.estimate.sun_reason;  // 3.5° wide: no sun
  ASSERT_EQ(o.estimate.sources.size(), 2u) << o.estimate.sources_reason;
  EXPECT_NE(o.estimate.sources_reason.find("black"), std::string::npos) << o.estimate.sources_reason;
  for (int k = 0; k < 2; ++k) {
    EXPECT_LT(angle(o.estimate.sources[static_cast<std::size_t>(k)].direction, kLamps[k].direction), 0.3 * kDeg);
  }
  // Independent reference: the true lamps (energy ∫ L = 0.85 L0 Ω, disc against the box).
  const geom::Plane& plane = manifest_->planes[0].plane;
  double true_energy[2][3];
  for (int k = 0; k < 2; ++k) {
    const double omega = 2.0 * std::numbers::pi * (1.0 - std::cos(kLamps[k].radius));
    for (int c = 0; c < 3; ++c) true_energy[k][c] = 0.85 * kLamps[k].radiance[c] * omega * kLamps[k].direction.z();
  }
  double sum = 0.0, worst = 0.0;
  int count = 0, shadowed_by_one = 0;
  for (int row = 0; row < plane.height; ++row) {
    for (int col = 0; col < plane.width; ++col) {
      const Vec3 p = plane.texel_centre(col, row);
      if (std::abs(p.x()) < 1.0 && std::abs(p.y()) < 1.0) continue;  // under the box
      const double v0 = disc_visibility(p, kLamps[0]), v1 = disc_visibility(p, kLamps[1]);
      shadowed_by_one += (v0 < 0.01 && v1 > 0.99) || (v1 < 0.01 && v0 > 0.99);
      const std::size_t texel = static_cast<std::size_t>(row) * static_cast<std::size_t>(plane.width) +
                                static_cast<std::size_t>(col);
      for (int c = 0; c < 3; ++c) {
        const double expected =
            (true_energy[0][c] * v0 + true_energy[1][c] * v1) / (true_energy[0][c] + true_energy[1][c]);
        const double got = o.T[3 * texel + static_cast<std::size_t>(c)];
        const double error = std::abs(got - expected);
        sum += error;
        worst = std::max(worst, error);
        ++count;
        EXPECT_NEAR(got, o.T_reference[3 * texel + static_cast<std::size_t>(c)], 2e-3);
      }
    }
  }
  EXPECT_GT(shadowed_by_one, 4);  // both shadows fall on the ground, apart
  EXPECT_LT(sum / count, 0.01);
  EXPECT_LT(worst, 0.08);  // penumbra texels: the detected disc against the true one
}

TEST_F(SourcesShadeTest, OneSourceKeepsTheLampsInTheDome) {
  // max_sources = 1: no sun test passes, nothing separated; the lamps light the ground through
  // the dome's faces (blurred shadows), and the blend is the single-sun one without a sun.
  const sky::RadianceFrame frame = paint([](const Vec3& d) { return lamps_on(d, Eigen::Vector3d::Constant(0.05)); });
  const Outcome one = shade(frame, 1);
  expect_finite_unit(one);
  EXPECT_TRUE(one.estimate.sources.empty());
  EXPECT_FALSE(one.estimate.sun);
  const blend::BasisImages basis = blend::load_basis(*dir_ / "bake", *manifest_, 0);
  const std::vector<Eigen::Vector3d> S = sky::layer_radiances(one.estimate.luminance);
  const blend::BlendWeights w = blend::blend_weights(basis, S, std::nullopt);
  std::vector<float> T(one.T.size());
  blend::blend_cpu(basis, w, {}, T);
  EXPECT_EQ(T, one.T);
  // Separated, the lamps' shadows are where they belong: against the true T (the dim sky and
  // both lamps integrated against the box ray by ray, green channel) the mean error outside the
  // box's footprint is far below the dome's, which spreads each lamp over its 30° face.
  const Outcome several = shade(frame, 8);
  ASSERT_EQ(several.estimate.sources.size(), 2u) << several.estimate.sources_reason;
  expect_finite_unit(several);
  const geom::Plane& plane = manifest_->planes[0].plane;
  double error_one = 0.0, error_several = 0.0;
  int count = 0;
  for (int row = 0; row < plane.height; ++row) {
    for (int col = 0; col < plane.width; ++col) {
      const Vec3 p = plane.texel_centre(col, row);
      if (std::abs(p.x()) < 1.0 && std::abs(p.y()) < 1.0) continue;  // under the box
      // The sky: 0.05 over the hemisphere, cosine-weighted, on a 90 × 360 grid.
      double sky_lit = 0.0, sky_all = 0.0;
      for (int e = 0; e < 90; ++e) {
        const double el = (e + 0.5) * kDeg;
        for (int a = 0; a < 360; a += 2) {
          const Vec3 d = from_angles(a + 1.0, el * 180.0 / std::numbers::pi);
          const double weight = std::cos(el) * std::sin(el);  // dω ∝ cos(el); n·ω = sin(el)
          sky_all += weight;
          if (!hits_box(p, d)) sky_lit += weight;
        }
      }
      const double sky_irradiance = 0.05 * std::numbers::pi;  // L π over the hemisphere
      double numerator = sky_irradiance * sky_lit / sky_all, denominator = sky_irradiance;
      for (const Lamp& lamp : kLamps) {
        const double e = 0.85 * lamp.radiance[1] * 2.0 * std::numbers::pi * (1.0 - std::cos(lamp.radius)) *
                         lamp.direction.z();
        numerator += e * disc_visibility(p, lamp);
        denominator += e;
      }
      const double truth = numerator / denominator;
      const std::size_t k = 3 * (static_cast<std::size_t>(row) * static_cast<std::size_t>(plane.width) +
                                 static_cast<std::size_t>(col)) + 1;
      error_one += std::abs(one.T[k] - truth);
      error_several += std::abs(several.T[k] - truth);
      ++count;
    }
  }
  error_one /= count;
  error_several /= count;
  EXPECT_LT(error_several, 0.5 * error_one) << "dome only " << error_one << ", separated " << error_several;
  EXPECT_LT(error_several, 0.02);
}

TEST_F(SourcesShadeTest, ExtremesStayFiniteWithSeveralSources) {
  // A black sky: nothing separated, no light, T = 1 and flagged.
  const Outcome black = shade(paint([](const Vec3&) { return Eigen::Vector3d::Zero(); }), 8);
  expect_finite_unit(black);
  EXPECT_TRUE(black.estimate.sources.empty());
  EXPECT_TRUE(black.weights.no_light[0] && black.weights.no_light[1] && black.weights.no_light[2]);
  for (const float t : black.T) EXPECT_EQ(t, 1.0f);
  // NaN, Inf and negative pixels over the lamp sky, one inside each lamp: counted, never a
  // source of their own, T finite in [0, 1].
  sky::RadianceFrame frame = paint([](const Vec3& d) { return lamps_on(d, Eigen::Vector3d::Constant(0.05)); });
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -3.0f};
  for (int y = 3; y < frame.radiance.rows; y += 23) {
    for (int x = 5; x < frame.radiance.cols; x += 19) frame.radiance.at<cv::Vec3f>(y, x) = cv::Vec3f::all(bad[(x + y) % 3]);
  }
  const camera::Lens lens(camera());
  for (const Lamp& lamp : kLamps) {
    const auto p = lens.site_to_pixel(lamp.direction);
    ASSERT_TRUE(p);
    frame.radiance.at<cv::Vec3f>(static_cast<int>(std::lround(p->y())), static_cast<int>(std::lround(p->x()))) =
        cv::Vec3f::all(std::numeric_limits<float>::quiet_NaN());
  }
  const Outcome o = shade(frame, 8);
  expect_finite_unit(o);
  EXPECT_GT(o.estimate.luminance.nan_pixels, 0);
  EXPECT_GT(o.estimate.luminance.inf_pixels, 0);
  ASSERT_EQ(o.estimate.sources.size(), 2u) << o.estimate.sources_reason;
  for (const sky::Sun& s : o.estimate.sources) EXPECT_TRUE(s.energy.allFinite() && s.direction.allFinite());
  // Lamps only up: every lamp under the horizon (none), a very bright lamp over a dim sky — a
  // dynamic range of 1e8 between lamp and sky still gives T in [0, 1].
  const Outcome bright = shade(paint([](const Vec3& d) -> Eigen::Vector3d {
                                 if (d.z() < 0) return Eigen::Vector3d::Zero();
                                 const double a = angle(d, kLamps[0].direction);
                                 return a <= kLamps[0].radius ? Eigen::Vector3d::Constant(1e6 * profile(a, kLamps[0].radius))
                                                              : Eigen::Vector3d::Constant(1e-2);
                               }),
                               8);
  expect_finite_unit(bright);
  ASSERT_GE(bright.estimate.sources.size(), 1u);
}

}  // namespace
}  // namespace skylit
