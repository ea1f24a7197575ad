// The blend with a corners bake: three layers per face, whose S (corner coefficients of a linear
// fit) may be negative. T stays finite and in [0, 1], the fast blend equals the reference, and
// load_basis reads the face_NNN_k layers.
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "../bake_format/bake_fixtures.hpp"
#include "blend_fixtures.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/bake_format/arrays.hpp"

namespace skylit::blend {
namespace {

using bake_format::test::TempDir;

TEST(CornersBlend, LoadBasisReadsThreeLayersPerFace) {
  TempDir dir;
  const bake_format::Manifest m = bake_format::test::write_synthetic_bake(dir.path(), geom::DomeBasis::Corners);
  const BasisImages basis = load_basis(dir.path(), m, 1);
  EXPECT_EQ(basis.layers, 120);
  EXPECT_EQ(basis.layers_per_face, 3);
  EXPECT_EQ(basis.unoccluded.size(), 120U);
  EXPECT_EQ(basis.half[22 * basis.texel_count() + 9], float_to_half(bake_format::test::sample_basis(1, 22, 9)));
  // A faces bake loads with one layer per face.
  TempDir faces_dir;
  const bake_format::Manifest f = bake_format::test::write_synthetic_bake(faces_dir.path());
  EXPECT_EQ(load_basis(faces_dir.path(), f, 1).layers_per_face, 1);
  // A layer named for the other basis is missing, and named so.
  bake_format::ImageStack stack = bake_format::read_exr_stack(faces_dir / f.planes[0].file);
  bake_format::write_exr_stack(dir / m.planes[0].file, stack, bake_format::layer_names(geom::DomeBasis::Faces, 40));
  try {
    load_basis(dir.path(), m, 0);
    FAIL() << "a faces image was read as a corners plane";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("face_000_0.Y"), std::string::npos) << message;
    EXPECT_NE(message.find("120 layers (corners basis: 3 per face of 40 dome faces)"), std::string::npos) << message;
  }
}

TEST(CornersBlend, NegativeCornerCoefficientsKeepTInTheUnitInterval) {
  // 40 faces × 3 corners. Per face a linear fit with one corner below zero: S = (−1, 3, 0.2) per
  // channel (scaled), the face's integral positive. Texels where the bright corner is shadowed
  // (f = 0 in layer 3i+1) sum to below zero: T is clamped to 0 there; elsewhere f varies.
  const int layers = 120;
  const std::vector<double> A(layers, 2.0 * std::numbers::pi / layers);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<float> f(static_cast<std::size_t>(layers) * 37 * 23);
  for (float& x : f) x = static_cast<float>(uniform(rng));
  BasisImages basis = test::make_basis(37, 23, A, [&](int l, std::size_t t) {
    const float shade = l % 3 == 1 && t % 4 == 0 ? 0.0f : (t % 4 == 1 ? 1.0f : f[static_cast<std::size_t>(l) * 851 + t]);
    return static_cast<float>(A[static_cast<std::size_t>(l)] * shade);
  });
  basis.layers_per_face = 3;
  std::vector<Eigen::Vector3d> S;
  for (int i = 0; i < 40; ++i) {
    const Eigen::Vector3d scale(0.8 + 0.4 * uniform(rng), 1.0, 1.2);
    S.push_back(-1.0 * scale);
    S.push_back(3.0 * scale);
    S.push_back(0.2 * scale);
  }
  const test::RandomScene sunny = test::random_scene(3, 37, 23, 5);
  for (const bool with_sun : {false, true}) {
    const std::optional<SunLight> sun = with_sun ? std::optional(sunny.sun) : std::nullopt;
    const std::vector<float> visibility = with_sun ? sunny.visibility : std::vector<float>();
    const BlendWeights w = blend_weights(basis, S, sun);
    EXPECT_FALSE(w.no_light[0] || w.no_light[1] || w.no_light[2]);
    std::vector<float> fast(3 * basis.texel_count());
    const BlendStats stats = blend_cpu(basis, w, visibility, fast);
    std::vector<double> reference(fast.size());
    blend_reference(basis, S, sun, visibility, reference);
    for (std::size_t k = 0; k < fast.size(); ++k) {
      ASSERT_TRUE(std::isfinite(fast[k]));
      ASSERT_GE(fast[k], 0.0f);
      ASSERT_LE(fast[k], 1.0f);
      ASSERT_NEAR(fast[k], reference[k], 1e-5);
    }
    // Every fourth texel (bright corners shadowed) sums below zero without the sun: clamped to 0
    // and counted. Fully lit texels (t % 4 == 1) are 1.
    if (!with_sun) {
      EXPECT_GE(stats.clamped, static_cast<std::int64_t>(3 * (basis.texel_count() / 4)));
      EXPECT_GT(stats.max_below_zero, 0.1f);
      for (std::size_t t = 0; t < basis.texel_count(); t += 4) EXPECT_EQ(fast[3 * t], 0.0f);
    }
    for (std::size_t t = 1; t < basis.texel_count(); t += 4) {
      if (!with_sun || visibility[t] == 1.0f) {
        EXPECT_NEAR(fast[3 * t + 1], 1.0f, 2e-3);
      }
    }
  }
}

TEST(CornersBlend, TinyDenominatorsStillMeanNoLight) {
  // Corners that cancel: Σ S A = 0 in green, negative in blue. Those channels are T = 1, flagged.
  const BasisImages basis = [] {
    BasisImages b = test::make_basis(4, 3, {0.1, 0.1, 0.1}, [](int, std::size_t t) { return 0.02f * static_cast<float>(t % 5); });
    b.layers_per_face = 3;
    return b;
  }();
  const std::vector<Eigen::Vector3d> S{{1.0, 1.0, -1.0}, {1.0, -1.0, -1.0}, {1.0, 0.0, 0.5}};
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  EXPECT_FALSE(w.no_light[0]);
  EXPECT_TRUE(w.no_light[1]);
  EXPECT_TRUE(w.no_light[2]);
  std::vector<float> T(3 * basis.texel_count());
  blend_cpu(basis, w, {}, T);
  for (std::size_t t = 0; t < basis.texel_count(); ++t) {
    EXPECT_EQ(T[3 * t + 1], 1.0f);
    EXPECT_EQ(T[3 * t + 2], 1.0f);
    EXPECT_GE(T[3 * t], 0.0f);
    EXPECT_LE(T[3 * t], 1.0f);
  }
}

TEST(CornersBlend, FacesStillRefuseNegativeSAndCornersRefuseNonFinite) {
  test::RandomScene scene = test::random_scene(6, 4, 4, 3);
  scene.S[2] = Eigen::Vector3d(0.5, -0.1, 0.5);
  EXPECT_THROW(blend_weights(scene.basis, scene.S, std::nullopt), InputError);
  scene.basis.layers_per_face = 3;
  EXPECT_NO_THROW(blend_weights(scene.basis, scene.S, std::nullopt));
  scene.S[4] = Eigen::Vector3d(0.5, std::numeric_limits<double>::quiet_NaN(), 0.5);
  try {
    blend_weights(scene.basis, scene.S, std::nullopt);
    FAIL() << "a NaN corner coefficient was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("S[4]"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace skylit::blend
