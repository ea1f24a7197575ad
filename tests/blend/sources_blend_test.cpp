// Several separated sources in the CPU blend (issue 3): Σ_k E_k c_k V_k in numerator and
// denominator; one source is the single-sun blend bit for bit; both kernels agree with the
// double-precision reference; bad counts and visibilities are input errors.
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "blend_fixtures.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/base/error.hpp"

namespace skylit::blend {
namespace sources_blend_test {  // named, not anonymous: the test program is one unity build

using test::random_scene;

template <class F>
std::string input_error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

std::vector<BlendOptions> kernels() {
  BlendOptions simd;
  simd.threads = 2;
  BlendOptions portable = simd;
  portable.use_simd = false;
  return {simd, portable};
}

// Three lamps around the plane's normal (one behind it: no light on the plane) and their V.
struct Lamps {
  std::vector<SunLight> lights;
  std::vector<std::vector<float>> visibility;
  std::vector<std::span<const float>> views() const {
    std::vector<std::span<const float>> v;
    for (const auto& x : visibility) v.emplace_back(x);
    return v;
  }
};

Lamps lamps(std::size_t texels, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Lamps l;
  l.lights = {SunLight{Vec3(0.3, 0.2, 0.9).normalized(), Eigen::Vector3d(2.0, 1.0, 0.5)},
              SunLight{Vec3(-0.5, 0.1, 0.6).normalized(), Eigen::Vector3d(0.2, 0.9, 3.0)},
              SunLight{Vec3(0.0, 0.3, -0.8).normalized(), Eigen::Vector3d(5.0, 5.0, 5.0)}};  // below the plane
  for (std::size_t k = 0; k < l.lights.size(); ++k) {
    std::vector<float> v(texels);
    for (float& x : v) {
      const double pick = uniform(rng);
      x = pick < 0.4 ? 0.0f : (pick < 0.8 ? 1.0f : static_cast<float>(uniform(rng)));
    }
    l.visibility.push_back(std::move(v));
  }
  return l;
}

TEST(SourcesBlend, WeightsSumEveryTermIntoTheDenominator) {
  const auto scene = random_scene(40, 16, 8, 7);
  const Lamps l = lamps(scene.basis.texel_count(), 1);
  const BlendWeights w = blend_weights_sources(scene.basis, scene.S, l.lights);
  ASSERT_EQ(w.sources.size(), 3u);
  EXPECT_EQ(w.sun, w.sources[0]);
  EXPECT_TRUE(w.sources[2].isZero());  // behind the plane
  Eigen::Vector3d expected = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < scene.S.size(); ++i) expected += scene.S[i] * scene.basis.unoccluded[i];
  for (const SunLight& s : l.lights) expected += s.energy * std::max(0.0, s.direction.dot(Vec3::UnitZ()));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(w.denominator[c], expected[c], 1e-12 * expected[c]);
}

TEST(SourcesBlend, BothKernelsMatchTheReference) {
  const auto scene = random_scene(40, 37, 23, 11);  // odd sizes: the kernels' scalar tails
  const Lamps l = lamps(scene.basis.texel_count(), 2);
  std::vector<double> reference(3 * scene.basis.texel_count());
  blend_reference_sources(scene.basis, scene.S, l.lights, l.views(), reference);
  for (const BlendOptions& options : kernels()) {
    const BlendWeights w = blend_weights_sources(scene.basis, scene.S, l.lights, options);
    std::vector<float> T(reference.size(), std::numeric_limits<float>::quiet_NaN());
    blend_cpu_sources(scene.basis, w, l.views(), T, options);
    for (std::size_t k = 0; k < T.size(); ++k) {
      ASSERT_TRUE(std::isfinite(T[k]) && T[k] >= 0.0f && T[k] <= 1.0f);
      EXPECT_NEAR(T[k], reference[k], 2e-3) << "value " << k;  // half-float basis, float sums
    }
  }
  // The reference itself: T = (Σ S B + Σ E c V) / D at one texel, by hand.
  const std::size_t texel = 5;
  const BlendWeights w = blend_weights_sources(scene.basis, scene.S, l.lights);
  for (int c = 0; c < 3; ++c) {
    if (w.no_light[static_cast<std::size_t>(c)]) continue;
    double numerator = 0.0;
    for (std::size_t i = 0; i < scene.S.size(); ++i) {
      numerator += scene.S[i][c] * half_to_float(scene.basis.half[i * scene.basis.texel_count() + texel]);
    }
    for (std::size_t k = 0; k < l.lights.size(); ++k) {
      numerator += l.lights[k].energy[c] * std::max(0.0, l.lights[k].direction.z()) * l.visibility[k][texel];
    }
    EXPECT_NEAR(reference[3 * texel + static_cast<std::size_t>(c)], std::clamp(numerator / w.denominator[c], 0.0, 1.0),
                1e-12);
  }
}

TEST(SourcesBlend, OneSourceIsTheSingleSunBlendBitForBit) {
  const auto scene = random_scene(40, 33, 17, 5);
  for (const BlendOptions& options : kernels()) {
    const BlendWeights single = blend_weights(scene.basis, scene.S, scene.sun, options);
    const BlendWeights multi = blend_weights_sources(scene.basis, scene.S, std::span<const SunLight>(&scene.sun, 1), options);
    EXPECT_EQ(single.sun, multi.sun);
    EXPECT_EQ(single.denominator, multi.denominator);
    std::vector<float> a(3 * scene.basis.texel_count()), b(a.size());
    blend_cpu(scene.basis, single, scene.visibility, a, options);
    const std::vector<std::span<const float>> views{scene.visibility};
    blend_cpu_sources(scene.basis, multi, views, b, options);
    EXPECT_EQ(a, b);
  }
  // No source at all: the dome alone, as blend_weights without a sun.
  const BlendWeights none = blend_weights_sources(scene.basis, scene.S, {});
  const BlendWeights no_sun = blend_weights(scene.basis, scene.S, std::nullopt);
  EXPECT_TRUE(none.sources.empty());
  EXPECT_EQ(none.denominator, no_sun.denominator);
  std::vector<float> a(3 * scene.basis.texel_count()), b(a.size());
  blend_cpu_sources(scene.basis, none, {}, a);
  blend_cpu(scene.basis, no_sun, {}, b);
  EXPECT_EQ(a, b);
}

TEST(SourcesBlend, BlackDomeAndNoLightStayFinite) {
  // S = 0 everywhere, every lamp behind the plane: no light in any channel, T = 1 and flagged.
  auto scene = random_scene(40, 8, 8, 3);
  for (auto& s : scene.S) s.setZero();
  const std::vector<SunLight> behind{SunLight{Vec3(0, 0, -1), Eigen::Vector3d(1, 1, 1)},
                                     SunLight{Vec3(1, 0, -0.1).normalized(), Eigen::Vector3d(2, 2, 2)}};
  const BlendWeights w = blend_weights_sources(scene.basis, scene.S, behind);
  EXPECT_TRUE(w.no_light[0] && w.no_light[1] && w.no_light[2]);
  std::vector<float> T(3 * scene.basis.texel_count(), -1.0f);
  blend_cpu_sources(scene.basis, w, {}, T);  // zero weights: no V needed
  for (float t : T) EXPECT_EQ(t, 1.0f);
  // Lamps alone light the plane (black dome): T is the lamps' visible share, in [0, 1].
  const Lamps l = lamps(scene.basis.texel_count(), 4);
  const BlendWeights lit = blend_weights_sources(scene.basis, scene.S, l.lights);
  blend_cpu_sources(scene.basis, lit, l.views(), T);
  for (std::size_t k = 0; k < scene.basis.texel_count(); ++k) {
    const double e0 = l.lights[0].energy[1] * l.lights[0].direction.z(), e1 = l.lights[1].energy[1] * l.lights[1].direction.z();
    EXPECT_NEAR(T[3 * k + 1], (e0 * l.visibility[0][k] + e1 * l.visibility[1][k]) / (e0 + e1), 1e-5);
  }
}

TEST(SourcesBlend, BadInputsAreInputErrors) {
  const auto scene = random_scene(40, 8, 8, 9);
  const Lamps l = lamps(scene.basis.texel_count(), 5);
  const BlendWeights w = blend_weights_sources(scene.basis, scene.S, l.lights);
  std::vector<float> T(3 * scene.basis.texel_count());
  // One visibility image for several sources.
  EXPECT_NE(input_error_of([&] { blend_cpu(scene.basis, w, l.visibility[0], T); }).find("weights.sources"),
            std::string::npos);
  // Too few visibility images, a lit source without one, a NaN V.
  std::vector<std::span<const float>> views = l.views();
  views.pop_back();
  EXPECT_NE(input_error_of([&] { blend_cpu_sources(scene.basis, w, views, T); }).find("source_visibility"),
            std::string::npos);
  views = l.views();
  views[1] = {};
  EXPECT_NE(input_error_of([&] { blend_cpu_sources(scene.basis, w, views, T); }).find("source_visibility[1]"),
            std::string::npos);
  std::vector<float> nan_v = l.visibility[0];
  nan_v[3] = std::numeric_limits<float>::quiet_NaN();
  views = l.views();
  views[0] = nan_v;
  EXPECT_NE(input_error_of([&] { blend_cpu_sources(scene.basis, w, views, T); }).find("outside [0, 1]"),
            std::string::npos);
  // A source with a bad energy or direction is named.
  std::vector<SunLight> bad = l.lights;
  bad[1].energy.x() = std::numeric_limits<double>::infinity();
  EXPECT_NE(input_error_of([&] { blend_weights_sources(scene.basis, scene.S, bad); }).find("sources[1].energy"),
            std::string::npos);
  bad = l.lights;
  bad[2].direction = Vec3::Zero();
  EXPECT_NE(input_error_of([&] { blend_weights_sources(scene.basis, scene.S, bad); }).find("sources[2].direction"),
            std::string::npos);
}

}  // namespace
}  // namespace skylit::blend
