// GpuBlender against blend_cpu: random planes (40 and 640 faces), a real small bake, both basis
// storages and both output formats, skies without light, and the two savings. Tolerances are
// derived, the measured differences printed ("measured:" lines).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "blend_fixtures.hpp"
#include "gpu_test_support.hpp"
#include "../support/gl_suite.hpp"
#include "../support/box_site.hpp"
#include "../support/fixture_cache.hpp"
#include "../support/quiet_bake.hpp"
#include "../support/suite_setup.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/blend/half.hpp"

namespace skylit::blend {
namespace gpu_blend_test {  // named, not anonymous: the test program is one unity build

namespace fs = std::filesystem;
using test::make_basis;
using test::random_scene;
using test::RandomScene;

constexpr double kUnitRoundoff = 0x1p-24;  // float, round to nearest
constexpr double kHalfUlpBelowOne = 0x1p-11;  // RGBA16F output: one unit in the last place in [0.5, 1)

// One context for the whole program (the blenders' names die before it).
class GpuBlend : public skylit::test::GlSuite {};

struct Case {
  BasisStorage storage;
  ShadowRatioFormat output;
  bool packed;
  std::string name() const {
    const bool half = storage == BasisStorage::Half;
    return std::string(packed ? (half ? "RGBA16F" : "RGBA8") : (half ? "R16F" : "R8")) + " basis, " +
           (output == ShadowRatioFormat::Float ? "RGBA32F" : "RGBA16F") + " T";
  }
  GpuBlendOptions options() const {
    GpuBlendOptions o = test::blend_options(storage, output);
    o.pack_layers = packed;
    return o;
  }
};

const Case kCases[] = {{BasisStorage::Half, ShadowRatioFormat::Float, false},
                       {BasisStorage::Half, ShadowRatioFormat::Half, false},
                       {BasisStorage::Unorm8, ShadowRatioFormat::Float, false},
                       {BasisStorage::Unorm8, ShadowRatioFormat::Half, false},
                       {BasisStorage::Half, ShadowRatioFormat::Float, true},
                       {BasisStorage::Half, ShadowRatioFormat::Half, true},
                       {BasisStorage::Unorm8, ShadowRatioFormat::Float, true},
                       {BasisStorage::Unorm8, ShadowRatioFormat::Half, true}};

// The largest |T_gpu - T_cpu| the formats allow at a texel whose terms add up to `magnitude`
// (Σ|w_i| B_i + |w_sun| V) over n layers: two fp32 sums of the same terms in the same order,
// each within n·u·magnitude (with or without fused multiply-adds), plus R8 quantisation
// (Σ|w_i| max_i / 510, half a step of each layer) and the rounding of an RGBA16F output.
struct Tolerance {
  double summation = 0;
  double quantisation = 0;
  double output = 0;
  double total() const { return summation + quantisation + output; }
};

Tolerance tolerance_of(const BasisImages& basis, const BlendWeights& w, std::span<const float> visibility,
                       const Case& c) {
  const std::size_t texels = basis.texel_count();
  std::vector<float> b(texels);
  std::vector<double> magnitude(3 * texels, 0.0);
  Eigen::Vector3d quantisation = Eigen::Vector3d::Zero();
  for (const int i : w.active) {
    halves_to_floats(std::span<const std::uint16_t>(basis.half.data() + static_cast<std::size_t>(i) * texels, texels), b);
    const Eigen::Vector3d wi = w.face[static_cast<std::size_t>(i)].cast<double>().cwiseAbs();
    const double top = *std::max_element(b.begin(), b.end());
    quantisation += wi * std::max(top, 0.0) / 510.0;
    for (std::size_t k = 0; k < texels; ++k) {
      for (int ch = 0; ch < 3; ++ch) magnitude[3 * k + static_cast<std::size_t>(ch)] += wi[ch] * std::abs(b[k]);
    }
  }
  double largest = 0;
  for (std::size_t k = 0; k < texels; ++k) {
    for (int ch = 0; ch < 3; ++ch) {
      const double v = visibility.empty() ? 0.0 : visibility[k];
      largest = std::max(largest, magnitude[3 * k + static_cast<std::size_t>(ch)] + std::abs(w.sun[ch]) * v);
    }
  }
  Tolerance t;
  t.summation = 2.0 * static_cast<double>(w.active.size() + 2) * kUnitRoundoff * std::max(largest, 1.0);
  t.quantisation = c.storage == BasisStorage::Unorm8 ? quantisation.maxCoeff() : 0.0;
  t.output = c.output == ShadowRatioFormat::Half ? kHalfUlpBelowOne : 0.0;
  return t;
}

double max_abs_difference(std::span<const float> a, std::span<const float> b) {
  double worst = 0;
  for (std::size_t k = 0; k < a.size(); ++k) worst = std::max(worst, std::abs(static_cast<double>(a[k]) - b[k]));
  return worst;
}

double mean_abs_difference(std::span<const float> a, std::span<const float> b) {
  double sum = 0;
  for (std::size_t k = 0; k < a.size(); ++k) sum += std::abs(static_cast<double>(a[k]) - b[k]);
  return a.empty() ? 0.0 : sum / static_cast<double>(a.size());
}

std::vector<float> cpu_blend(const BasisImages& basis, const BlendWeights& w, std::span<const float> visibility) {
  std::vector<float> T(3 * basis.texel_count());
  blend_cpu(basis, w, w.sun.isZero() ? std::span<const float>() : visibility, T);
  return T;
}

// Blends on the GPU in every case and checks against blend_cpu; returns the worst R8 error.
double expect_matches_cpu(const std::string& what, const BasisImages& basis, const BlendWeights& w,
                          std::span<const float> visibility) {
  const std::vector<float> expected = cpu_blend(basis, w, visibility);
  std::optional<test::VisibilityTexture> sun_texture;
  if (!w.sun.isZero()) sun_texture.emplace(basis.width, basis.height, visibility);
  double r8_error = 0;
  for (const Case& c : kCases) {
    SCOPED_TRACE(what + ", " + c.name());
    GpuBlender blender(basis, c.options());
    EXPECT_TRUE(blender.blend(w, sun_texture ? &sun_texture->texture : nullptr));
    const std::vector<float> T = blender.read_back();
    if (T.size() != expected.size()) {
      ADD_FAILURE() << T.size() << " values read back, " << expected.size() << " expected";
      continue;
    }
    EXPECT_EQ(std::count_if(T.begin(), T.end(), [](float t) { return !(t >= 0.0f && t <= 1.0f); }), 0)
        << "T outside [0, 1] or NaN";
    const double difference = max_abs_difference(T, expected);
    const Tolerance tolerance = tolerance_of(basis, w, visibility, c);
    std::printf("measured: %s, %s: max |T_gpu - T_cpu| = %.3g (mean %.3g; bound %.3g)\n", what.c_str(), c.name().c_str(),
                difference, mean_abs_difference(T, expected), tolerance.total());
    EXPECT_LE(difference, tolerance.total());
    if (c.storage == BasisStorage::Unorm8) r8_error = std::max(r8_error, difference);
  }
  return r8_error;
}

TEST_F(GpuBlend, RandomPlaneWith40FacesAndTheSunMatchesTheCpu) {
  const RandomScene scene = random_scene(40, 67, 45, 3);
  const BlendWeights w = blend_weights(scene.basis, scene.S, scene.sun);
  ASSERT_FALSE(w.sun.isZero());
  expect_matches_cpu("random 40 faces + sun", scene.basis, w, scene.visibility);
}

TEST_F(GpuBlend, RandomPlaneWithoutTheSunMatchesTheCpu) {
  const RandomScene scene = random_scene(40, 33, 70, 5);
  const BlendWeights w = blend_weights(scene.basis, scene.S, std::nullopt);
  expect_matches_cpu("random 40 faces", scene.basis, w, {});
}

TEST_F(GpuBlend, SixHundredFortyLayersMatchTheCpu) {
  GLint max_layers = 0;
  glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
  ASSERT_GE(max_layers, 640) << "this driver's texture arrays cannot hold a ν = 8 dome";
  const RandomScene scene = random_scene(640, 24, 20, 11);
  const BlendWeights w = blend_weights(scene.basis, scene.S, scene.sun);
  ASSERT_GT(w.active.size(), 400u);
  expect_matches_cpu("random 640 faces + sun", scene.basis, w, scene.visibility);
}

TEST_F(GpuBlend, BlackSkyGivesOneEverywhere) {
  const RandomScene scene = random_scene(40, 16, 16, 7);
  const std::vector<Eigen::Vector3d> black(40, Eigen::Vector3d::Zero());
  const BlendWeights w = blend_weights(scene.basis, black, std::nullopt);
  ASSERT_TRUE(w.no_light[0] && w.no_light[1] && w.no_light[2]);
  for (const Case& c : kCases) {
    GpuBlender blender(scene.basis, c.options());
    blender.blend(w);
    for (const float t : blender.read_back()) ASSERT_EQ(t, 1.0f) << c.name();
  }
}

TEST_F(GpuBlend, OneChannelWithoutLightIsOneTheOthersBlend) {
  RandomScene scene = random_scene(40, 16, 12, 9);
  for (Eigen::Vector3d& s : scene.S) s.z() = 0.0;
  const BlendWeights w = blend_weights(scene.basis, scene.S, std::nullopt);
  ASSERT_TRUE(w.no_light[2] && !w.no_light[0]);
  GpuBlender blender(scene.basis, test::blend_options(BasisStorage::Half, ShadowRatioFormat::Float));
  blender.blend(w);
  const std::vector<float> T = blender.read_back();
  const std::vector<float> expected = cpu_blend(scene.basis, w, {});
  for (std::size_t k = 0; k < T.size() / 3; ++k) EXPECT_EQ(T[3 * k + 2], 1.0f);
  EXPECT_LE(max_abs_difference(T, expected), 1e-5);
}

TEST_F(GpuBlend, SumsAboveOneAreClampedLikeTheCpu) {
  // B = 1.5 A everywhere (not a bake, but what half rounding does in small measure): T = 1.5.
  const std::vector<double> A(8, 0.25);
  const BasisImages basis = make_basis(9, 7, A, [](int, std::size_t) { return 0.375f; });
  const std::vector<Eigen::Vector3d> S(8, Eigen::Vector3d(1, 2, 3));
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  GpuBlender blender(basis, test::blend_options(BasisStorage::Half, ShadowRatioFormat::Float));
  blender.blend(w);
  for (const float t : blender.read_back()) ASSERT_EQ(t, 1.0f);
}

TEST_F(GpuBlend, R8StorageErrorStaysWithinHalfAStepPerLayer) {
  // Smooth basis images (a bake's are mostly smooth): the measured R8 error against the exact
  // blend, next to its bound Σ_i |w_i| max_i / 510.
  const int layers = 160;
  std::vector<double> A(layers);
  for (int i = 0; i < layers; ++i) A[static_cast<std::size_t>(i)] = 2.0 * std::numbers::pi / layers * (0.3 + 0.7 * ((i * 37) % 11) / 10.0);
  const int width = 48, height = 40;
  const BasisImages basis = make_basis(width, height, A, [&](int i, std::size_t t) {
    const double x = static_cast<double>(t % width) / width;
    const double y = static_cast<double>(t / width) / height;
    const double f = 0.5 + 0.5 * std::sin(6.0 * x + 0.1 * i) * std::cos(4.0 * y - 0.05 * i);
    return static_cast<float>(A[static_cast<std::size_t>(i)] * f);
  });
  std::vector<Eigen::Vector3d> S;
  for (int i = 0; i < layers; ++i) S.emplace_back(0.4 + 0.01 * (i % 13), 0.6, 1.0 + 0.02 * (i % 7));
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  const std::vector<float> exact = cpu_blend(basis, w, {});
  GpuBlender blender(basis, test::blend_options(BasisStorage::Unorm8, ShadowRatioFormat::Float));
  blender.blend(w);
  const std::vector<float> T = blender.read_back();
  const double bound = tolerance_of(basis, w, {}, {BasisStorage::Unorm8, ShadowRatioFormat::Float, true}).total();
  const double worst = max_abs_difference(T, exact);
  std::printf("measured: R8 storage, 160 smooth layers: max |T_R8 - T_R16F| = %.3g, mean %.3g (bound %.3g)\n", worst,
              mean_abs_difference(T, exact), bound);
  EXPECT_LE(worst, bound);
  EXPECT_GT(worst, 0.0);  // R8 is lossy: a zero here would mean the R16F path ran
}

// ---- the savings ---------------------------------------------------------------------------

TEST_F(GpuBlend, SkipThresholdBoundsTheErrorAndSkipsLayers) {
  // A sky whose faces span three decades: the dim ones can go.
  RandomScene scene = random_scene(160, 40, 30, 21);
  // Whole texture slices (four layers) dim together, so that packed storage can skip too.
  for (std::size_t i = 0; i < scene.S.size(); ++i) scene.S[i] *= std::pow(10.0, -static_cast<double>(i / 4 % 4));
  const BlendWeights w = blend_weights(scene.basis, scene.S, std::nullopt);
  GpuBlender exact(scene.basis, test::blend_options(BasisStorage::Half, ShadowRatioFormat::Float));
  exact.blend(w);
  const std::vector<float> reference = exact.read_back();
  EXPECT_EQ(exact.summed_layers(), static_cast<int>(w.active.size()));
  for (const bool packed : {false, true}) {
  for (const double threshold : {0.001, 0.01, 0.05}) {
    GpuBlendOptions options = test::blend_options(BasisStorage::Half, ShadowRatioFormat::Float);
    options.skip_threshold = threshold;
    options.pack_layers = packed;
    GpuBlender blender(scene.basis, options);
    blender.blend(w);
    const std::vector<float> T = blender.read_back();
    double worst = 0;
    for (std::size_t k = 0; k < T.size(); ++k) {
      // Skipping only removes light: T never gets brighter (up to fp32 summation).
      EXPECT_LE(T[k], reference[k] + 1e-6f);
      worst = std::max(worst, static_cast<double>(reference[k] - T[k]));
    }
    std::printf("measured: skip_threshold %.3g, %s: %d of %zu layers skipped (bound %.3g), max error %.3g\n", threshold,
                packed ? "packed" : "one layer per slice", blender.skipped_layers(), w.active.size(),
                blender.skipped_bound(), worst);
    EXPECT_GT(blender.skipped_layers(), 0);
    EXPECT_EQ(blender.summed_layers() + blender.skipped_layers(), static_cast<int>(w.active.size()));
    EXPECT_LE(blender.skipped_bound(), threshold);
    EXPECT_LE(worst, blender.skipped_bound() + 1e-5);
  }
  }
}

TEST_F(GpuBlend, LayersThatAddNothingAreSkippedEvenAtThresholdZero) {
  // Layers 1 and 4 … 7 are zero everywhere (fully shadowed faces): no cost, same T. Packed, the
  // slice of layers 0 … 3 is read whole, the slice of 4 … 7 not at all.
  const std::vector<double> A{0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8};
  const BasisImages basis = make_basis(10, 6, A, [&](int i, std::size_t t) {
    return (i == 1 || i >= 4) ? 0.0f : static_cast<float>(A[static_cast<std::size_t>(i)] * static_cast<double>(t % 3) / 2.0);
  });
  const std::vector<Eigen::Vector3d> S(8, Eigen::Vector3d(1, 1, 1));
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  ASSERT_EQ(w.active.size(), 8u);
  for (const bool packed : {false, true}) {
    GpuBlendOptions options = test::blend_options(BasisStorage::Half, ShadowRatioFormat::Float);
    options.pack_layers = packed;
    GpuBlender blender(basis, options);
    blender.blend(w);
    EXPECT_EQ(blender.summed_slices(), packed ? 1 : 3);
    EXPECT_EQ(blender.summed_layers(), packed ? 4 : 3);
    EXPECT_EQ(blender.skipped_layers(), packed ? 4 : 5);
    EXPECT_EQ(blender.skipped_bound(), 0.0);
    EXPECT_LE(max_abs_difference(blender.read_back(), cpu_blend(basis, w, {})), 1e-6);
  }
}

TEST_F(GpuBlend, ChangeThresholdSkipsBlendsWhileTheSkyHoldsStill) {
  const RandomScene scene = random_scene(40, 20, 16, 31);
  GpuBlendOptions options = test::blend_options(BasisStorage::Half, ShadowRatioFormat::Float);
  options.change_threshold = 0.01;
  GpuBlender blender(scene.basis, options);
  const BlendWeights first = blend_weights(scene.basis, scene.S, std::nullopt);
  EXPECT_TRUE(blender.blend(first));
  const std::vector<float> T0 = blender.read_back();
  EXPECT_FALSE(blender.blend(first)) << "same weights: nothing to do";

  // One S up by 0.1 %: T changes by far less than 0.01, the blend is skipped and T stays.
  std::vector<Eigen::Vector3d> S = scene.S;
  S[4] *= 1.001;
  EXPECT_FALSE(blender.blend(blend_weights(scene.basis, S, std::nullopt)));
  EXPECT_EQ(blender.read_back(), T0);

  // Small steps add up against the last blend that ran, not the last call: after enough of
  // them the blend runs, and then the result is the fresh one.
  int skipped = 0;
  bool ran = false;
  for (int step = 0; step < 200 && !ran; ++step) {
    S[4] *= 1.01;
    ran = blender.blend(blend_weights(scene.basis, S, std::nullopt));
    skipped += ran ? 0 : 1;
  }
  EXPECT_TRUE(ran);
  EXPECT_GT(skipped, 0);
  const BlendWeights now = blend_weights(scene.basis, S, std::nullopt);
  EXPECT_LE(max_abs_difference(blender.read_back(), cpu_blend(scene.basis, now, {})), 1e-5);

  // Whatever was skipped, the T on show is within the threshold of the exact T of the sky.
  std::vector<Eigen::Vector3d> S2 = S;
  for (Eigen::Vector3d& s : S2) s *= 1.0004;
  S2[7] *= 1.02;
  const BlendWeights drifted = blend_weights(scene.basis, S2, std::nullopt);
  blender.blend(drifted);
  EXPECT_LE(max_abs_difference(blender.read_back(), cpu_blend(scene.basis, drifted, {})), 0.01 + 1e-5);

  // invalidate() forces the next one.
  blender.invalidate();
  EXPECT_TRUE(blender.blend(drifted));
}

TEST_F(GpuBlend, ChangeOfSunVisibilityOrLightFlagsAlwaysBlends) {
  const RandomScene scene = random_scene(40, 12, 10, 41);
  GpuBlendOptions options = test::blend_options(BasisStorage::Half, ShadowRatioFormat::Float);
  options.change_threshold = 0.5;  // generous: only the rules below force a blend
  GpuBlender blender(scene.basis, options);
  test::VisibilityTexture sun(12, 10, scene.visibility);
  const BlendWeights w = blend_weights(scene.basis, scene.S, scene.sun);
  EXPECT_TRUE(blender.blend(w, &sun.texture));
  EXPECT_FALSE(blender.blend(w, &sun.texture));
  sun.texture.revision += 1;  // the shadow map was redrawn
  EXPECT_TRUE(blender.blend(w, &sun.texture));
  EXPECT_FALSE(blender.blend(w, &sun.texture));
  // Night: every channel loses its light.
  const std::vector<Eigen::Vector3d> black(40, Eigen::Vector3d::Zero());
  EXPECT_TRUE(blender.blend(blend_weights(scene.basis, black, std::nullopt)));
  for (const float t : blender.read_back()) ASSERT_EQ(t, 1.0f);
}

TEST_F(GpuBlend, BadInputsAreInputErrors) {
  const RandomScene scene = random_scene(8, 6, 5, 51);
  GpuBlendOptions negative;
  negative.skip_threshold = -0.1;
  EXPECT_THROW(GpuBlender(scene.basis, negative), InputError);
  negative = {};
  negative.change_threshold = std::nan("");
  EXPECT_THROW(GpuBlender(scene.basis, negative), InputError);
  BasisImages broken = scene.basis;
  broken.half.pop_back();
  EXPECT_THROW(GpuBlender{broken}, InputError);

  GpuBlender blender(scene.basis);
  BlendWeights w = blend_weights(scene.basis, scene.S, scene.sun);
  EXPECT_THROW(blender.blend(w), InputError) << "the sun lights the plane: V is needed";
  test::VisibilityTexture small(5, 5, std::vector<float>(25, 1.0f));
  EXPECT_THROW(blender.blend(w, &small.texture), InputError) << "V of another plane";
  w.face.pop_back();
  EXPECT_THROW(blender.blend(w), InputError);
  w = blend_weights(scene.basis, scene.S, std::nullopt);
  w.active = {3, 2};
  EXPECT_THROW(blender.blend(w), InputError);
}

// ---- a real bake -----------------------------------------------------------------------------

// A box 2 m tall on the ground, a ground plane around it and a wall plane beside it, baked by
// the ray tracer at ν = 2 with 4 samples per face.
class GpuBlendRealBake : public GpuBlend {
 protected:
  static void SetUpTestSuite() {
    GpuBlend::SetUpTestSuite();
    // Made once per build of the test program and shared by its processes (read only).
    setup_.run([&] {
      dir_ = new fs::path(skylit::test::cached_fixture("gpu_blend_box", [](const fs::path& out) {
        skylit::test::write_box_site(out, "dome:\n  frequency: 2\n"
                                          "planes:\n"
                                          "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                          "    v: [0, 12, 0]\n    resolution: [40, 40]\n"
                                          "  - name: north_wall\n    origin: [1, 1.01, 0]\n    u: [-2, 0, 0]\n"
                                          "    v: [0, 0, 2]\n    resolution: [8, 8]\n");
        skylit::test::quiet_bake(out / "site.yaml", out / "bake");
      }));
      manifest_ = new bake_format::Manifest(bake_format::read_manifest(*dir_ / "bake"));
    });
  }
  void SetUp() override { setup_.require(); }
  static void TearDownTestSuite() {
    delete dir_;
    delete manifest_;
    GpuBlend::TearDownTestSuite();
  }
  static fs::path* dir_;
  static bake_format::Manifest* manifest_;
  static inline skylit::test::SuiteSetup setup_;
};
fs::path* GpuBlendRealBake::dir_ = nullptr;
bake_format::Manifest* GpuBlendRealBake::manifest_ = nullptr;

TEST_F(GpuBlendRealBake, MatchesTheCpuOnEveryPlaneUnderASunnySky) {
  // A blue sky, brighter around a sun in the south-east at 40°, plus the sun as a light.
  const geom::Vec3 sun_direction = geom::Vec3(0.54, -0.54, 0.643).normalized();
  std::vector<Eigen::Vector3d> S;
  for (const bake_format::FaceRecord& face : manifest_->faces) {
    const double closeness = std::exp(-std::acos(std::clamp(face.direction.dot(sun_direction), -1.0, 1.0)) / 0.4);
    S.push_back(Eigen::Vector3d(0.4, 0.6, 1.0) * (1.0 + 4.0 * closeness));
  }
  const SunLight sun{sun_direction, Eigen::Vector3d(60, 55, 50)};
  double r8_error = 0;
  for (std::size_t j = 0; j < manifest_->planes.size(); ++j) {
    const BasisImages basis = load_basis(*dir_ / "bake", *manifest_, static_cast<int>(j));
    // A stand-in V (half the plane in the sun's shadow); the shadow map's own V is tested in
    // sun_shadow_map_test.cpp.
    std::vector<float> visibility(basis.texel_count());
    const auto width = static_cast<std::size_t>(basis.width);
    for (std::size_t k = 0; k < visibility.size(); ++k) visibility[k] = k % width < width / 2 ? 0.0f : 1.0f;
    const BlendWeights w = blend_weights(basis, S, sun);
    r8_error = std::max(r8_error, expect_matches_cpu("real bake, plane " + basis.name, basis, w, visibility));
  }
  std::printf("measured: real bake (ν = 2, 4 samples): worst R8 error %.3g\n", r8_error);
}

TEST_F(GpuBlendRealBake, EacLayersStayWithinTheErrorMeasuredOnUpload) {
  // The same sky; EAC R11 blocks against the exact CPU blend. A bake's layers are mostly flat
  // (open sky or full shadow) with edges between: the case block compression keeps best.
  const geom::Vec3 sun_direction = geom::Vec3(0.54, -0.54, 0.643).normalized();
  std::vector<Eigen::Vector3d> S;
  for (const bake_format::FaceRecord& face : manifest_->faces) {
    const double closeness = std::exp(-std::acos(std::clamp(face.direction.dot(sun_direction), -1.0, 1.0)) / 0.4);
    S.push_back(Eigen::Vector3d(0.4, 0.6, 1.0) * (1.0 + 4.0 * closeness));
  }
  for (std::size_t j = 0; j < manifest_->planes.size(); ++j) {
    const BasisImages basis = load_basis(*dir_ / "bake", *manifest_, static_cast<int>(j));
    const BlendWeights w = blend_weights(basis, S, std::nullopt);
    const std::vector<float> expected = cpu_blend(basis, w, {});
    for (const bool packed : {false, true}) {
      GpuBlendOptions options = test::blend_options(BasisStorage::Eac11, ShadowRatioFormat::Float);
      options.pack_layers = packed;
      GpuBlender blender(basis, options);
      ASSERT_TRUE(blender.blend(w));
      const std::vector<float> T = blender.read_back();
      double bound = 0.0, worst_layer = 0.0;
      for (int c = 0; c < 3; ++c) {
        double channel = 0.0;
        for (const int i : w.active) {
          const auto k = static_cast<std::size_t>(i);
          channel += std::abs(w.face[k][c]) * blender.eac_error()[k];
          worst_layer = std::max(worst_layer, static_cast<double>(blender.eac_error()[k] / std::max(blender.layer_max()[k], 1e-30f)));
        }
        bound = std::max(bound, channel);
      }
      const double difference = max_abs_difference(T, expected);
      std::printf("measured: real bake, plane %s, EAC %s: max |T_eac - T_cpu| = %.3g (mean %.3g; bound %.3g; worst layer "
                  "%.3g of its maximum)\n",
                  basis.name.c_str(), packed ? "RG11" : "R11", difference, mean_abs_difference(T, expected), bound, worst_layer);
      EXPECT_LE(difference, bound + 1e-5);
      EXPECT_LE(difference, 0.02);  // a bake's layers, unlike noise, compress well
    }
  }
}

}  // namespace
}  // namespace skylit::blend
