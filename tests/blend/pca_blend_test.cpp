// The PCA form of a bake end to end: skylit-bake compress writes it, verify checks it, load_basis
// reads it, and a blend of its K + 1 layers stays within the bound the bake reports of the blend
// of the full basis, on the CPU and on the GPU, for random skies with and without a sun.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "../bake_format/bake_fixtures.hpp"
#include "gpu_test_support.hpp"
#include "../support/gl_suite.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/blend/gpu_blend.hpp"

namespace skylit::blend {
namespace pca_blend_test {  // named, not anonymous: the test program is one unity build

namespace fs = std::filesystem;
using bake_format::test::pca_components;
using bake_format::test::pca_max_error;
using bake_format::test::TempDir;

struct Sky {
  std::vector<Eigen::Vector3d> S;
  std::optional<SunLight> sun;
  std::vector<float> visibility;
};

// Radiances >= 0 over the layers, a third of them dark, and a sun half the time.
Sky random_sky(std::size_t layers, std::size_t texels, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Sky sky;
  for (std::size_t l = 0; l < layers; ++l) {
    const bool dark = unit(rng) < 0.33;
    const Eigen::Vector3d radiance = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 10.0;
    sky.S.push_back(dark ? Eigen::Vector3d::Zero().eval() : radiance);
  }
  if (unit(rng) < 0.5) {
    sky.sun = SunLight{Eigen::Vector3d(0.3, -0.2, 0.9).normalized(), Eigen::Vector3d::Constant(50.0 * unit(rng))};
    for (std::size_t k = 0; k < texels; ++k) sky.visibility.push_back(static_cast<float>(unit(rng) < 0.5 ? 0.0 : 1.0));
  }
  return sky;
}

std::vector<float> blend(const BasisImages& basis, const Sky& sky) {
  const BlendWeights w = blend_weights(basis, sky.S, sky.sun);
  std::vector<float> T(3 * basis.texel_count());
  blend_cpu(basis, w, w.sun.isZero(0) ? std::span<const float>() : std::span<const float>(sky.visibility), T);
  return T;
}

double max_abs_difference(std::span<const float> a, std::span<const float> b) {
  double worst = 0;
  for (std::size_t k = 0; k < a.size(); ++k) worst = std::max(worst, std::abs(static_cast<double>(a[k]) - b[k]));
  return worst;
}

// A synthetic bake, compressed with `options`; returns its manifest.
bake_format::Manifest compressed_bake(const fs::path& dir, const bake_format::PcaOptions& options) {
  bake_format::test::write_synthetic_bake(dir);
  std::FILE* quiet = std::fopen("/dev/null", "w");
  baker::compress_bake(dir, options, std::nullopt, quiet);
  std::fclose(quiet);
  return bake_format::read_manifest(dir);
}

bake_format::PcaOptions tiled(bake_format::PcaOptions options, int tile) {
  options.tile = tile;
  return options;
}

TEST(PcaBlend, StaysWithinTheReportedBoundOfTheFullBlend) {
  // Tiles of 3 texels cut both planes (8 × 6 and 5 × 4) with narrower tiles at the edges.
  for (const bake_format::PcaOptions& options :
       {pca_components(6), pca_max_error(0.01), tiled(pca_components(2), 3), tiled(pca_max_error(0.01), 3)}) {
    TempDir dir;
    const bake_format::Manifest m = compressed_bake(dir.path(), options);
    const bake_format::VerifyReport report = bake_format::verify(dir.path());
    ASSERT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems.front());
    std::mt19937 rng(5);
    for (std::size_t j = 0; j < m.planes.size(); ++j) {
      ASSERT_TRUE(m.planes[j].pca);
      const bake_format::PcaRecord& record = *m.planes[j].pca;
      if (options.max_error) {
        EXPECT_LE(record.max_error, *options.max_error);
      }
      if (options.components) {
        EXPECT_EQ(record.components, *options.components);
      }
      const BasisImages full = load_basis(dir.path(), m, static_cast<int>(j));
      const BasisImages pca = load_basis(dir.path(), m, static_cast<int>(j), BasisForm::Pca);
      ASSERT_TRUE(pca.compressed());
      EXPECT_EQ(pca.layers, record.components + 1);
      EXPECT_EQ(pca.tile, options.tile);
      EXPECT_EQ(record.tile, options.tile);
      EXPECT_EQ(pca.source_layers(), full.layers);
      double worst = 0.0;
      for (int trial = 0; trial < 20; ++trial) {
        const Sky sky = random_sky(static_cast<std::size_t>(full.layers), full.texel_count(), rng);
        const std::vector<float> expected = blend(full, sky);
        const std::vector<float> T = blend(pca, sky);
        for (const float t : T) ASSERT_TRUE(t >= 0.0f && t <= 1.0f);
        worst = std::max(worst, max_abs_difference(T, expected));
        // The double-precision reference of the same compressed form agrees with the fast path.
        std::vector<double> reference(T.size());
        blend_reference(pca, sky.S, sky.sun, sky.sun ? std::span<const float>(sky.visibility) : std::span<const float>(),
                        reference);
        // Tolerance: float rounding of the weights and of the sum, (K + 3) units of 2^-24 of the
        // sum of the terms' magnitudes (tiles of 3 × 3 texels have near-degenerate components
        // whose terms cancel), and at least 1e-5.
        const BlendWeights w = blend_weights(pca, sky.S, sky.sun);
        const double sun_bound = w.sun.cwiseAbs().maxCoeff();
        for (std::size_t k = 0; k < T.size(); ++k) {
          const std::size_t texel = k / 3;
          const int tile = pca.tile_of(static_cast<int>(texel % static_cast<std::size_t>(pca.width)),
                                       static_cast<int>(texel / static_cast<std::size_t>(pca.width)));
          double magnitude = sun_bound;
          for (int l = 0; l < pca.layers; ++l) {
            const float b = half_to_float(pca.half[static_cast<std::size_t>(l) * pca.texel_count() + texel]);
            magnitude += std::abs(static_cast<double>(w.face[static_cast<std::size_t>(tile * pca.layers + l)][static_cast<int>(k % 3)]) * b);
          }
          const double tolerance = std::max(1e-5, (pca.layers + 3) * std::ldexp(magnitude, -24));
          ASSERT_NEAR(T[k], reference[k], tolerance) << "sum of |terms| " << magnitude << ", texel " << texel << " of tile " << tile;
        }
      }
      std::printf("measured: plane '%s', K = %d of %d, tile %d: max |T_pca - T_full| = %.4f over 20 skies (bound %.4f)\n",
                  pca.name.c_str(), record.components, full.layers, options.tile, worst, record.max_error);
      // Float sums of K + 1 and n terms add a little rounding on top of the bound.
      EXPECT_LE(worst, record.max_error + 1e-5);
    }
  }
}

TEST(PcaBlend, CompressingAgainReplacesTheForm) {
  TempDir dir;
  compressed_bake(dir.path(), pca_components(3));
  std::FILE* quiet = std::fopen("/dev/null", "w");
  baker::compress_bake(dir.path(), pca_components(5), std::nullopt, quiet);
  std::fclose(quiet);
  const bake_format::VerifyReport report = bake_format::verify(dir.path());
  ASSERT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems.front());
  for (const bake_format::PlaneRecord& r : report.manifest.planes) {
    ASSERT_TRUE(r.pca);
    EXPECT_EQ(r.pca->components, 5);
  }
  const auto listed = std::count_if(report.manifest.files.begin(), report.manifest.files.end(),
                                    [](const bake_format::FileRecord& f) { return f.path.ends_with(".pca.npy"); });
  EXPECT_EQ(listed, static_cast<long>(report.manifest.planes.size()));
}

TEST(PcaBlend, MissingFormAndBrokenFilesAreNamed) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  const bake_format::Manifest plain = bake_format::read_manifest(dir.path());
  try {
    load_basis(dir.path(), plain, 0, BasisForm::Pca);
    FAIL() << "a bake without a PCA form was read as one";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("planes[0].pca"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("skylit-bake compress"), std::string::npos) << e.what();
  }

  const bake_format::Manifest m = compressed_bake(dir.path(), pca_components(2));
  const std::string npy = m.planes[1].pca->coefficients;
  fs::remove(dir.path() / npy);
  const bake_format::VerifyReport report = bake_format::verify(dir.path());
  EXPECT_FALSE(report.ok);
  ASSERT_FALSE(report.problems.empty());
  EXPECT_NE(report.problems.front().find(npy), std::string::npos) << report.problems.front();
  EXPECT_THROW(load_basis(dir.path(), m, 1, BasisForm::Pca), InputError);
  // The full form is untouched.
  EXPECT_NO_THROW(load_basis(dir.path(), m, 1));
}

TEST(PcaBlend, ATiledFormWhoseManifestLostItsTileIsRefusedByShape) {
  TempDir dir;
  const bake_format::Manifest m = compressed_bake(dir.path(), tiled(pca_components(2), 3));
  ASSERT_EQ(m.planes[0].pca->tile, 3);
  const std::string npy = m.planes[0].pca->coefficients;
  bake_format::Manifest untiled = m;
  untiled.planes[0].pca->tile = 0;
  bake_format::write_manifest(dir.path(), untiled);
  const bake_format::VerifyReport report = bake_format::verify(dir.path());
  EXPECT_FALSE(report.ok);
  ASSERT_FALSE(report.problems.empty());
  EXPECT_NE(report.problems.front().find(npy), std::string::npos) << report.problems.front();
  try {
    load_basis(dir.path(), untiled, 0, BasisForm::Pca);
    FAIL() << "coefficients of 6 tiles were read as one";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("(layers × components)"), std::string::npos) << e.what();
  }
}

TEST(PcaBlend, CompressRefusesBadOptionsAndForeignDirectories) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  EXPECT_THROW(baker::compress_bake(dir.path(), pca_components(0), std::nullopt, nullptr), InputError);
  EXPECT_THROW(baker::compress_bake(dir.path() / "nowhere", pca_components(2), std::nullopt, nullptr), InputError);
}

class PcaGpuBlend : public skylit::test::GlSuite {};

TEST_F(PcaGpuBlend, MatchesTheCpuBlendOfTheSameForm) {
  for (const int tile : {0, 3}) {
  SCOPED_TRACE("tile " + std::to_string(tile));
  TempDir dir;
  const bake_format::Manifest m = compressed_bake(dir.path(), tiled(pca_components(6), tile));
  const BasisImages pca = load_basis(dir.path(), m, 0, BasisForm::Pca);
  EXPECT_EQ(pca.tile, tile);
  std::mt19937 rng(9);
  const Sky sky = random_sky(static_cast<std::size_t>(pca.source_layers()), pca.texel_count(), rng);
  const BlendWeights w = blend_weights(pca, sky.S, sky.sun);
  const std::vector<float> expected = blend(pca, sky);
  std::optional<test::VisibilityTexture> sun_texture;
  if (!w.sun.isZero()) sun_texture.emplace(pca.width, pca.height, sky.visibility);
  for (const bool packed : {false, true}) {
    GpuBlendOptions options = test::blend_options(BasisStorage::Half, ShadowRatioFormat::Float);
    options.pack_layers = packed;
    GpuBlender blender(pca, options);
    ASSERT_TRUE(blender.blend(w, sun_texture ? &sun_texture->texture : nullptr));
    const std::vector<float> T = blender.read_back();
    ASSERT_EQ(T.size(), expected.size());
    EXPECT_LE(max_abs_difference(T, expected), 1e-5) << (packed ? "packed" : "one layer per slice");
  }
  // 8-bit layers cannot hold eigen-images of either sign: refused, naming the fix.
  try {
    GpuBlender blender(pca, test::blend_options(BasisStorage::Unorm8, ShadowRatioFormat::Float));
    FAIL() << "8-bit storage of a PCA basis was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("half"), std::string::npos) << e.what();
  }
  }
}

}  // namespace
}  // namespace skylit::blend
