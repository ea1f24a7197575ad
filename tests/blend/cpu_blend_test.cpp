// blend_cpu (both kernels) and blend_reference: analytic planes, agreement within a derived
// float bound, thread independence, skies without light, clamping, and every bad input.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "blend_fixtures.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/workers.hpp"
#include "skylit/blend/half.hpp"

namespace skylit::blend {
namespace cpu_blend_test {  // named, not anonymous: the test program is one unity build

using test::make_basis;
using test::random_scene;

constexpr double kUnitRoundoff = 0x1p-24;  // float, round to nearest

// Both kernels: the AVX2/F16C one (where the CPU has it) and the portable one.
std::vector<BlendOptions> kernels(int threads = 2) {
  BlendOptions simd;
  simd.threads = threads;
  BlendOptions portable = simd;
  portable.use_simd = false;
  return {simd, portable};
}

std::string name_of(const BlendOptions& o) {
  return std::string(o.use_simd && blend_simd_available() ? "avx2" : "portable") + ", " +
         std::to_string(o.threads) + " threads";
}

struct Result {
  std::vector<float> T;
  BlendStats stats;
};

Result blend(const BasisImages& basis, std::span<const Eigen::Vector3d> S, const std::optional<SunLight>& sun,
             std::span<const float> visibility, const BlendOptions& options) {
  const BlendWeights w = blend_weights(basis, S, sun, options);
  Result r;
  r.T.assign(3 * basis.texel_count(), std::numeric_limits<float>::quiet_NaN());
  r.stats = blend_cpu(basis, w, visibility, r.T, options);
  return r;
}

template <class F>
std::string input_error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

// Half values of A, so that B = A is stored exactly and T = 1 is exact up to float summation.
std::vector<double> half_exact_unoccluded(int layers) {
  std::vector<double> A;
  for (int i = 0; i < layers; ++i) A.push_back(i % 5 == 0 ? 0.0 : (1 + (i * 37) % 200) / 2048.0);
  return A;
}

std::vector<Eigen::Vector3d> varied_sky(int layers) {
  std::vector<Eigen::Vector3d> S;
  for (int i = 0; i < layers; ++i) S.emplace_back(0.5 + (i % 7), 0.1 * (i % 3), 2.0 + std::sin(i));
  return S;
}

TEST(BlendCpu, UnshadowedPlaneGivesOne) {
  const int layers = 40;
  const std::vector<double> A = half_exact_unoccluded(layers);
  // 37 × 61 = 2257 texels: one full block of 2048 and a tail that is not a multiple of 8.
  const BasisImages basis =
      make_basis(37, 61, A, [&](int i, std::size_t) { return static_cast<float>(A[static_cast<std::size_t>(i)]); });
  const std::vector<Eigen::Vector3d> S = varied_sky(layers);
  SunLight sun;
  sun.direction = Vec3(0.2, 0.1, 0.9);
  sun.energy = Eigen::Vector3d(2, 2, 1);
  const std::vector<float> visible(basis.texel_count(), 1.0f);
  for (const BlendOptions& options : kernels()) {
    SCOPED_TRACE(name_of(options));
    for (const bool with_sun : {false, true}) {
      const Result r = blend(basis, S, with_sun ? std::optional<SunLight>(sun) : std::nullopt,
                             with_sun ? std::span<const float>(visible) : std::span<const float>(), options);
      // Σ w_i A_i = 1 exactly in real numbers; float weights and summation stay within 1e-6.
      for (const float t : r.T) ASSERT_NEAR(t, 1.0f, 1e-6f);
      EXPECT_LE(r.stats.max_above_one, 1e-6f);
      EXPECT_EQ(r.stats.max_below_zero, 0.0f);
    }
  }
}

TEST(BlendCpu, UnshadowedPlaneWithRealAStaysWithinHalfRounding) {
  // A from Lambert's formula is no half: B = half(A) is off by up to 2^-11 relative, so T is
  // within 2^-11 of 1 and anything above 1 is clamped and reported.
  const int layers = 40;
  std::vector<double> A;
  for (int i = 0; i < layers; ++i) A.push_back(2.0 * std::numbers::pi / layers * (0.3 + 0.017 * i));
  const BasisImages basis =
      make_basis(16, 9, A, [&](int i, std::size_t) { return static_cast<float>(A[static_cast<std::size_t>(i)]); });
  const std::vector<Eigen::Vector3d> S = varied_sky(layers);
  for (const BlendOptions& options : kernels()) {
    SCOPED_TRACE(name_of(options));
    const Result r = blend(basis, S, std::nullopt, {}, options);
    for (const float t : r.T) {
      ASSERT_LE(t, 1.0f);
      ASSERT_GE(t, 1.0f - 0x1p-11f);
    }
    EXPECT_LE(r.stats.max_above_one, 0x1p-11f);
  }
}

TEST(BlendCpu, FullShadowGivesZeroOrTheSunsShare) {
  const int layers = 40;
  const std::vector<double> A = half_exact_unoccluded(layers);
  const BasisImages basis = make_basis(19, 7, A, [](int, std::size_t) { return 0.0f; });
  const std::vector<Eigen::Vector3d> S = varied_sky(layers);
  SunLight sun;
  sun.direction = Vec3(0.0, -0.6, 0.8);  // c = 0.8
  sun.energy = Eigen::Vector3d(1.0, 2.0, 4.0);
  const BlendWeights w = blend_weights(basis, S, sun);
  // V = 1 on even texels, 0.5 on odd ones, except the last, which is 0.
  std::vector<float> visibility(basis.texel_count());
  for (std::size_t t = 0; t < visibility.size(); ++t) visibility[t] = t % 2 ? 0.5f : 1.0f;
  visibility.back() = 0.0f;
  for (const BlendOptions& options : kernels()) {
    SCOPED_TRACE(name_of(options));
    const Result dark = blend(basis, S, std::nullopt, {}, options);
    for (const float t : dark.T) ASSERT_EQ(t, 0.0f);
    const Result sunny = blend(basis, S, sun, visibility, options);
    for (std::size_t t = 0; t < basis.texel_count(); ++t) {
      for (int c = 0; c < 3; ++c) {
        const double share = sun.energy[c] * 0.8 / w.denominator[c];  // E c / D
        ASSERT_NEAR(sunny.T[3 * t + static_cast<std::size_t>(c)], share * visibility[t], 1e-7) << t;
      }
    }
  }
}

TEST(BlendCpu, CheckerboardMatchesHandComputedRatios) {
  // Two faces, A = (0.5, 0.25), S0 = (1, 2, 3), S1 = (3, 2, 1): D = (1.25, 1.5, 1.75).
  // Face 0 is half shadowed (B = A/2) on even squares, face 1 on odd squares:
  //   even: T = (S0·A0/2 + S1·A1) / D = (0.8, 2/3, 4/7)
  //   odd:  T = (S0·A0 + S1·A1/2) / D = (0.7, 5/6, 13/14)
  const std::vector<double> A{0.5, 0.25};
  const int width = 13;
  const auto even = [](std::size_t t) { return (t % width + t / width) % 2 == 0; };
  const BasisImages basis = make_basis(width, 11, A, [&](int i, std::size_t t) {
    const bool shadowed = (i == 0) == even(t);
    return static_cast<float>(A[static_cast<std::size_t>(i)] * (shadowed ? 0.5 : 1.0));
  });
  const std::vector<Eigen::Vector3d> S{{1, 2, 3}, {3, 2, 1}};
  const Eigen::Vector3d t_even(0.8, 2.0 / 3.0, 4.0 / 7.0);
  const Eigen::Vector3d t_odd(0.7, 5.0 / 6.0, 13.0 / 14.0);
  // With a sun of E c = (1, 1, 1) (E = 2, 30° elevation), visible on even rows only:
  //   D' = D + 1 and T' = (T·D + V) / D'.
  SunLight sun;
  sun.direction = Vec3(0.0, std::sqrt(3.0) / 2.0, 0.5);
  sun.energy = Eigen::Vector3d(2, 2, 2);
  const Eigen::Vector3d D(1.25, 1.5, 1.75);
  std::vector<float> visibility(basis.texel_count());
  for (std::size_t t = 0; t < visibility.size(); ++t) visibility[t] = (t / width) % 2 == 0 ? 1.0f : 0.0f;

  for (const BlendOptions& options : kernels()) {
    SCOPED_TRACE(name_of(options));
    const Result plain = blend(basis, S, std::nullopt, {}, options);
    const Result lit = blend(basis, S, sun, visibility, options);
    std::vector<double> reference(3 * basis.texel_count());
    blend_reference(basis, S, sun, visibility, reference, options);
    for (std::size_t t = 0; t < basis.texel_count(); ++t) {
      const Eigen::Vector3d expected = even(t) ? t_even : t_odd;
      for (int c = 0; c < 3; ++c) {
        const std::size_t at = 3 * t + static_cast<std::size_t>(c);
        ASSERT_NEAR(plain.T[at], expected[c], 1e-6) << t;
        const double with_sun = (expected[c] * D[c] + visibility[t]) / (D[c] + 1.0);
        ASSERT_NEAR(lit.T[at], with_sun, 1e-6) << t;
        ASSERT_NEAR(reference[at], with_sun, 1e-12) << t;
      }
    }
  }
}

// blend_cpu against blend_reference on random planes. Both read the same half values (exact
// input). blend_cpu rounds each weight S_i/D to float (relative error ≤ u = 2^-24) and sums n
// non-negative products in float (error ≤ γ_n·Σ terms, γ_n = n·u/(1 − n·u), Higham 3.1; an FMA
// only lowers it); so |T_cpu − T_ref| ≤ (n + 2)·u·Σ_i w_i B_i, n = active layers + the sun.
// Σ w_i B_i ≲ 1 (B ≤ A), so the bound is ≈ 2.5e-6 for 40 faces and ≈ 3.8e-5 for 640; it is
// checked per texel, clamping to [0, 1] can only shrink a difference.
void expect_agreement(int layers, int width, int height, std::uint32_t seed) {
  const test::RandomScene scene = random_scene(layers, width, height, seed);
  std::vector<double> reference(3 * scene.basis.texel_count());
  blend_reference(scene.basis, scene.S, scene.sun, scene.visibility, reference);
  // The unclamped sums Σ w_i B_i + w_sun V from the reference's own inputs, for the bound.
  const BlendWeights w = blend_weights(scene.basis, scene.S, scene.sun);
  const double terms = static_cast<double>(w.active.size()) + 1.0;
  std::vector<double> sums(reference.size(), 0.0);
  for (int i = 0; i < layers; ++i) {
    for (std::size_t t = 0; t < scene.basis.texel_count(); ++t) {
      const double b = half_to_float(scene.basis.half[static_cast<std::size_t>(i) * scene.basis.texel_count() + t]);
      for (int c = 0; c < 3; ++c) sums[3 * t + static_cast<std::size_t>(c)] += scene.S[static_cast<std::size_t>(i)][c] * b;
    }
  }
  const Eigen::Vector3d sun_term =
      scene.sun.energy * std::max(0.0, scene.basis.normal.dot(scene.sun.direction.normalized()));
  double bound_max = 0.0;
  for (const BlendOptions& options : kernels(3)) {
    SCOPED_TRACE(name_of(options));
    const Result r = blend(scene.basis, scene.S, scene.sun, scene.visibility, options);
    double worst = 0.0;
    for (std::size_t t = 0; t < scene.basis.texel_count(); ++t) {
      for (int c = 0; c < 3; ++c) {
        const std::size_t at = 3 * t + static_cast<std::size_t>(c);
        const double sum = (sums[at] + sun_term[c] * scene.visibility[t]) / w.denominator[c];
        const double bound = (terms + 2.0) * kUnitRoundoff * sum;
        bound_max = std::max(bound_max, bound);
        ASSERT_TRUE(std::isfinite(r.T[at]));
        ASSERT_LE(std::abs(r.T[at] - reference[at]), bound) << "texel " << t << " channel " << c;
        worst = std::max(worst, std::abs(r.T[at] - reference[at]));
      }
    }
    std::printf("[ info ] %d faces (%zu active), %s: max |T_cpu - T_ref| = %.3g, bound up to %.3g\n", layers,
                w.active.size(), name_of(options).c_str(), worst, bound_max);
  }
}

TEST(BlendCpu, AgreesWithReferenceFor40Faces) { expect_agreement(40, 67, 53, 7); }
TEST(BlendCpu, AgreesWithReferenceFor640Faces) { expect_agreement(640, 45, 51, 11); }

TEST(BlendCpu, ResultsAreIdenticalForAnyThreadCount) {
  // 50 100 texels: 3 whole chunks of 8 blocks of 2048 texels and a partial one with a partial
  // block, taken by 1, 2, 3, 4 or 16 threads in whatever order they come.
  const test::RandomScene scene = random_scene(40, 334, 150, 3);
  for (const bool simd : {true, false}) {
    BlendOptions options;
    options.use_simd = simd;
    options.threads = 1;
    const Result one = blend(scene.basis, scene.S, scene.sun, scene.visibility, options);
    const auto expect_same = [&](const Result& many) {
      EXPECT_EQ(std::memcmp(one.T.data(), many.T.data(), one.T.size() * sizeof(float)), 0);
      EXPECT_EQ(one.stats.max_above_one, many.stats.max_above_one);
      EXPECT_EQ(one.stats.max_below_zero, many.stats.max_below_zero);
      EXPECT_EQ(one.stats.clamped, many.stats.clamped);
    };
    for (const int threads : {2, 3, 4, 16}) {
      options.threads = threads;
      SCOPED_TRACE(name_of(options));
      expect_same(blend(scene.basis, scene.S, scene.sun, scene.visibility, options));
    }
    // The same through a pool kept between calls, used again and again.
    BlendWorkers workers(3);
    options.workers = &workers;
    for (int call = 0; call < 5; ++call) {
      SCOPED_TRACE("pool of 3, call " + std::to_string(call));
      expect_same(blend(scene.basis, scene.S, scene.sun, scene.visibility, options));
    }
  }
}

TEST(BlendCpu, NightSkyGivesOneAndTheFlag) {
  const test::RandomScene scene = random_scene(40, 21, 17, 5);
  const std::vector<Eigen::Vector3d> night(40, Eigen::Vector3d::Zero());
  for (const BlendOptions& options : kernels()) {
    SCOPED_TRACE(name_of(options));
    const BlendWeights w = blend_weights(scene.basis, night, std::nullopt, options);
    EXPECT_EQ(w.no_light, (std::array<bool, 3>{true, true, true}));
    std::vector<float> T(3 * scene.basis.texel_count(), -7.0f);
    const BlendStats stats = blend_cpu(scene.basis, w, {}, T, options);
    for (const float t : T) ASSERT_EQ(t, 1.0f);
    EXPECT_EQ(stats.clamped, 0);
    EXPECT_EQ(stats.max_above_one, 0.0f);
    std::vector<double> reference(T.size());
    blend_reference(scene.basis, night, std::nullopt, {}, reference, options);
    for (const double t : reference) ASSERT_EQ(t, 1.0);
  }
}

TEST(BlendCpu, PlaneFacingAwayGivesOneAndTheFlagNeverNaN) {
  // A = 0 for every face (a plane looking at the ground), B = 0; the sun is behind it too.
  const BasisImages basis = make_basis(9, 9, std::vector<double>(40, 0.0), [](int, std::size_t) { return 0.0f; });
  const std::vector<Eigen::Vector3d> S = varied_sky(40);
  SunLight sun;
  sun.direction = Vec3(0, 0.5, -1);
  sun.energy = Eigen::Vector3d(5, 5, 5);
  for (const BlendOptions& options : kernels()) {
    SCOPED_TRACE(name_of(options));
    const BlendWeights w = blend_weights(basis, S, sun, options);
    EXPECT_EQ(w.no_light, (std::array<bool, 3>{true, true, true}));
    const Result r = blend(basis, S, sun, {}, options);
    for (const float t : r.T) ASSERT_EQ(t, 1.0f);
    std::vector<double> reference(r.T.size());
    blend_reference(basis, S, sun, {}, reference, options);
    for (const double t : reference) ASSERT_EQ(t, 1.0);
  }
}

TEST(BlendCpu, OneDarkChannelIsOneTheOthersBlend) {
  const std::vector<double> A{0.5, 0.25};
  const BasisImages basis = make_basis(5, 3, A, [&](int i, std::size_t) {
    return static_cast<float>(A[static_cast<std::size_t>(i)] * (i == 0 ? 0.5 : 0.0));
  });
  const std::vector<Eigen::Vector3d> S{{1, 0, 2}, {1, 0, 2}};  // T = 0.25/0.75 in r and b
  for (const BlendOptions& options : kernels()) {
    const Result r = blend(basis, S, std::nullopt, {}, options);
    for (std::size_t t = 0; t < basis.texel_count(); ++t) {
      EXPECT_NEAR(r.T[3 * t], 1.0 / 3.0, 1e-7);
      EXPECT_EQ(r.T[3 * t + 1], 1.0f);
      EXPECT_NEAR(r.T[3 * t + 2], 1.0 / 3.0, 1e-7);
    }
  }
}

TEST(BlendCpu, HalfRoundingAboveOneIsClampedAndReported) {
  // Find an A whose nearest half lies above it: B = half(A) > A, so T = half(A)/A > 1.
  double a = 0.1;
  while (half_to_float(float_to_half(static_cast<float>(a))) <= a) a += 1e-4;
  const double b = half_to_float(float_to_half(static_cast<float>(a)));
  ASSERT_GT(b / a - 1.0, 0.0);
  ASSERT_LT(b / a - 1.0, 0x1p-11);
  const BasisImages basis = make_basis(35, 3, {a}, [&](int, std::size_t) { return static_cast<float>(a); });
  const std::vector<Eigen::Vector3d> S{{1, 2, 3}};
  for (const BlendOptions& options : kernels()) {
    SCOPED_TRACE(name_of(options));
    const Result r = blend(basis, S, std::nullopt, {}, options);
    for (const float t : r.T) ASSERT_EQ(t, 1.0f);
    EXPECT_NEAR(r.stats.max_above_one, b / a - 1.0, 1e-7);
    EXPECT_EQ(r.stats.max_below_zero, 0.0f);
    EXPECT_EQ(r.stats.clamped, static_cast<std::int64_t>(3 * basis.texel_count()));
    std::vector<double> reference(r.T.size());
    blend_reference(basis, S, std::nullopt, {}, reference, options);
    for (const double t : reference) ASSERT_EQ(t, 1.0);
  }
}

TEST(BlendCpu, NegativeOrNaNBasisValuesClampToZeroNeverNaN) {
  // load_basis refuses such files; a basis built in memory may still hold them.
  const BasisImages basis = make_basis(11, 3, {0.5}, [](int, std::size_t t) {
    return t % 3 == 0 ? -0.25f : (t % 3 == 1 ? std::numeric_limits<float>::quiet_NaN() : 0.25f);
  });
  const std::vector<Eigen::Vector3d> S{{1, 1, 1}};
  for (const BlendOptions& options : kernels()) {
    SCOPED_TRACE(name_of(options));
    const Result r = blend(basis, S, std::nullopt, {}, options);
    for (std::size_t t = 0; t < basis.texel_count(); ++t) {
      for (int c = 0; c < 3; ++c) ASSERT_EQ(r.T[3 * t + static_cast<std::size_t>(c)], t % 3 == 2 ? 0.5f : 0.0f) << t;
    }
    EXPECT_FLOAT_EQ(r.stats.max_below_zero, 0.5f);
    EXPECT_EQ(r.stats.clamped, static_cast<std::int64_t>(3 * 2 * 11));  // 22 texels, 3 channels
  }
}

TEST(BlendCpu, BadInputsAreInputErrors) {
  const test::RandomScene scene = random_scene(40, 10, 6, 9);
  const BlendWeights w = blend_weights(scene.basis, scene.S, scene.sun);
  ASSERT_FALSE(w.sun.isZero());
  std::vector<float> T(3 * scene.basis.texel_count());
  const auto message = [&](std::span<const float> visibility, std::span<float> out, const BlendWeights& weights) {
    return input_error_of([&] { blend_cpu(scene.basis, weights, visibility, out, {}); });
  };
  EXPECT_NE(message(scene.visibility, std::span<float>(T).first(T.size() - 3), w).find("'out'"), std::string::npos);
  EXPECT_NE(message(std::span<const float>(scene.visibility).first(5), T, w).find("sun_visibility"),
            std::string::npos);
  EXPECT_NE(message({}, T, w).find("the sun lights plane"), std::string::npos);
  for (const float bad : {std::numeric_limits<float>::quiet_NaN(), 1.5f, -0.1f}) {
    for (const std::size_t at : {std::size_t{0}, scene.visibility.size() - 1}) {  // vector part and tail
      std::vector<float> visibility = scene.visibility;
      visibility[at] = bad;
      for (const BlendOptions& options : kernels()) {
        EXPECT_NE(input_error_of([&] { blend_cpu(scene.basis, w, visibility, T, options); }).find("outside [0, 1]"),
                  std::string::npos)
            << bad << " at " << at << ", " << name_of(options);
      }
      std::vector<double> reference(T.size());
      EXPECT_NE(input_error_of([&] { blend_reference(scene.basis, scene.S, scene.sun, visibility, reference); })
                    .find("sun_visibility"),
                std::string::npos);
    }
  }
  BlendWeights other = w;
  other.face.pop_back();
  EXPECT_NE(message(scene.visibility, T, other).find("weights.face"), std::string::npos);
  other = w;
  other.active.push_back(40);
  EXPECT_NE(message(scene.visibility, T, other).find("weights.active"), std::string::npos);
  other = w;
  other.active = {3, 2};
  EXPECT_NE(message(scene.visibility, T, other).find("weights.active"), std::string::npos);

  std::vector<double> reference(T.size());
  EXPECT_NE(input_error_of([&] { blend_reference(scene.basis, scene.S, scene.sun, {}, reference); })
                .find("the sun lights plane"),
            std::string::npos);
  std::vector<double> short_reference(T.size() - 1);
  EXPECT_NE(input_error_of([&] { blend_reference(scene.basis, scene.S, scene.sun, scene.visibility, short_reference); })
                .find("'out'"),
            std::string::npos);
  std::vector<Eigen::Vector3d> bad_sky = scene.S;
  bad_sky[7].x() = -1.0;
  EXPECT_NE(input_error_of([&] { blend_reference(scene.basis, bad_sky, scene.sun, scene.visibility, reference); })
                .find("S[7].r"),
            std::string::npos);
}

TEST(BlendCpu, EmptyPlaneIsNothingToDo) {
  const BasisImages basis = make_basis(0, 0, {0.5, 0.5}, [](int, std::size_t) { return 0.0f; });
  const std::vector<Eigen::Vector3d> S(2, Eigen::Vector3d(1, 1, 1));
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  const BlendStats stats = blend_cpu(basis, w, {}, {}, {});
  EXPECT_EQ(stats.clamped, 0);
}

}  // namespace
}  // namespace skylit::blend
