// load_basis on small bakes written with the bake library's own writers: the half values come
// back bit for bit in face order, and every broken plane image is an InputError naming the file.
#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "../bake_format/bake_fixtures.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/bake_format/arrays.hpp"

namespace skylit::blend {
namespace load_basis_test {  // named, not anonymous: the test program is one unity build

namespace fs = std::filesystem;
using bake_format::test::TempDir;

template <class F>
std::string input_error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

// Overwrites plane `plane`'s image with `layers` layers of width × height (B = 0.01 everywhere,
// `poison` at layer 3, texel 5 when given), named face_000 … except `skip`.
void rewrite_image(const fs::path& dir, const bake_format::Manifest& m, std::size_t plane, int layers, int width,
                   int height, int skip = -1, std::optional<float> poison = std::nullopt) {
  bake_format::ImageStack stack;
  stack.width = width;
  stack.height = height;
  stack.layers = layers;
  stack.data.assign(static_cast<std::size_t>(width * height * layers), 0.01f);
  if (poison) stack.layer(3)[5] = *poison;
  std::vector<std::string> names;
  for (int i = 0, face = 0; i < layers; ++i, ++face) {
    if (face == skip) ++face;
    names.push_back(bake_format::face_layer_name(face));
  }
  bake_format::write_exr_stack(dir / m.planes[plane].file, stack, names);
}

TEST(LoadBasis, ReproducesTheBakedValuesInFaceOrder) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  const bake_format::Manifest m = bake_format::read_manifest(dir.path());
  for (std::size_t j = 0; j < m.planes.size(); ++j) {
    const BasisImages basis = load_basis(dir.path(), m, static_cast<int>(j));
    const geom::Plane& plane = m.planes[j].plane;
    EXPECT_EQ(basis.name, plane.name);
    ASSERT_EQ(basis.width, plane.width);
    ASSERT_EQ(basis.height, plane.height);
    ASSERT_EQ(basis.layers, 40);
    ASSERT_EQ(basis.half.size(), basis.texel_count() * 40);
    EXPECT_EQ(basis.unoccluded, m.planes[j].unoccluded);
    EXPECT_NEAR((basis.normal - plane.u.cross(plane.v).normalized()).norm(), 0.0, 1e-15);
    for (int i = 0; i < 40; ++i) {
      for (std::size_t t = 0; t < basis.texel_count(); ++t) {
        // The writer rounds float → half as float_to_half does: the bits must match exactly.
        ASSERT_EQ(basis.half[static_cast<std::size_t>(i) * basis.texel_count() + t],
                  float_to_half(bake_format::test::sample_basis(j, i, t)))
            << "plane " << j << " face " << i << " texel " << t;
      }
    }
  }
}

TEST(LoadBasis, ABlendOfALoadedPlaneEqualsTheReference) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  const bake_format::Manifest m = bake_format::read_manifest(dir.path());
  const BasisImages basis = load_basis(dir.path(), m, 0);
  std::vector<Eigen::Vector3d> S;
  for (int i = 0; i < 40; ++i) S.emplace_back(1.0 + i % 3, 2.0, 0.5 + 0.1 * i);
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  std::vector<float> T(3 * basis.texel_count());
  blend_cpu(basis, w, {}, T);
  std::vector<double> reference(T.size());
  blend_reference(basis, S, std::nullopt, {}, reference);
  // This synthetic bake has B ≤ 2A, so Σ w_i B_i ≤ 2 and the float bound (see cpu_blend_test)
  // is 42·2^-24·2 < 5e-6.
  for (std::size_t k = 0; k < T.size(); ++k) ASSERT_NEAR(T[k], reference[k], 5e-6);
  // By hand for texel 0: T = Σ S_i B_i(0) / Σ S_i A_i.
  Eigen::Vector3d numerator = Eigen::Vector3d::Zero();
  Eigen::Vector3d denominator = Eigen::Vector3d::Zero();
  for (int i = 0; i < 40; ++i) {
    numerator += S[static_cast<std::size_t>(i)] * half_to_float(float_to_half(bake_format::test::sample_basis(0, i, 0)));
    denominator += S[static_cast<std::size_t>(i)] * m.planes[0].unoccluded[static_cast<std::size_t>(i)];
  }
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(reference[static_cast<std::size_t>(c)], numerator[c] / denominator[c], 1e-12);
}

TEST(LoadBasis, PlaneIndexOutOfRangeNamesTheManifestAndThePlanes) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  const bake_format::Manifest m = bake_format::read_manifest(dir.path());
  for (const int bad : {-1, 2}) {
    const std::string message = input_error_of([&] { load_basis(dir.path(), m, bad); });
    EXPECT_NE(message.find("manifest.json"), std::string::npos) << message;
    EXPECT_NE(message.find("'ground', 'wall'"), std::string::npos) << message;
    EXPECT_NE(message.find("from 0 to 1"), std::string::npos) << message;
  }
}

TEST(LoadBasis, MissingLayerIsNamed) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  const bake_format::Manifest m = bake_format::read_manifest(dir.path());
  rewrite_image(dir.path(), m, 0, 39, 8, 6, 17);
  const std::string message = input_error_of([&] { load_basis(dir.path(), m, 0); });
  EXPECT_NE(message.find("ground.exr"), std::string::npos) << message;
  EXPECT_NE(message.find("face_017.Y"), std::string::npos) << message;
  EXPECT_NE(message.find("missing"), std::string::npos) << message;
  EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
  // The last one missing, too.
  rewrite_image(dir.path(), m, 0, 39, 8, 6);
  EXPECT_NE(input_error_of([&] { load_basis(dir.path(), m, 0); }).find("face_039.Y"), std::string::npos);
}

TEST(LoadBasis, ExtraLayerIsNamed) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  const bake_format::Manifest m = bake_format::read_manifest(dir.path());
  rewrite_image(dir.path(), m, 1, 41, 5, 4);
  const std::string message = input_error_of([&] { load_basis(dir.path(), m, 1); });
  EXPECT_NE(message.find("wall.exr"), std::string::npos) << message;
  EXPECT_NE(message.find("face_040.Y"), std::string::npos) << message;
}

TEST(LoadBasis, SizeOtherThanTheManifestsIsNamed) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  const bake_format::Manifest m = bake_format::read_manifest(dir.path());
  rewrite_image(dir.path(), m, 0, 40, 8, 5);
  const std::string message = input_error_of([&] { load_basis(dir.path(), m, 0); });
  EXPECT_NE(message.find("ground.exr"), std::string::npos) << message;
  EXPECT_NE(message.find("8x5"), std::string::npos) << message;
  EXPECT_NE(message.find("8x6"), std::string::npos) << message;
}

TEST(LoadBasis, MissingOrTruncatedFileIsNamed) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  const bake_format::Manifest m = bake_format::read_manifest(dir.path());
  const fs::path file = dir / m.planes[0].file;
  fs::resize_file(file, fs::file_size(file) / 2);
  EXPECT_NE(input_error_of([&] { load_basis(dir.path(), m, 0); }).find("ground.exr"), std::string::npos);
  fs::remove(file);
  EXPECT_NE(input_error_of([&] { load_basis(dir.path(), m, 0); }).find("ground.exr"), std::string::npos);
}

TEST(LoadBasis, NonFiniteOrNegativeValuesAreNamedWithTheirTexel) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  const bake_format::Manifest m = bake_format::read_manifest(dir.path());
  for (const float poison : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                             -0.5f, 1e6f /* overflows half */}) {
    rewrite_image(dir.path(), m, 0, 40, 8, 6, -1, poison);
    const std::string message = input_error_of([&] { load_basis(dir.path(), m, 0); });
    EXPECT_NE(message.find("ground.exr"), std::string::npos) << message;
    EXPECT_NE(message.find("face_003.Y"), std::string::npos) << message;
    EXPECT_NE(message.find("col 5, row 0"), std::string::npos) << message;
  }
  rewrite_image(dir.path(), m, 0, 40, 8, 6, -1, -0.0f);  // negative zero is a zero
  EXPECT_NO_THROW(load_basis(dir.path(), m, 0));
}

TEST(LoadBasis, ManifestInconsistenciesAreNamed) {
  TempDir dir;
  bake_format::test::write_synthetic_bake(dir.path());
  bake_format::Manifest m = bake_format::read_manifest(dir.path());
  m.planes[1].unoccluded.pop_back();
  std::string message = input_error_of([&] { load_basis(dir.path(), m, 1); });
  EXPECT_NE(message.find("planes[1].unoccluded"), std::string::npos) << message;
  m = bake_format::read_manifest(dir.path());
  m.planes[0].unoccluded[4] = std::numeric_limits<double>::quiet_NaN();
  message = input_error_of([&] { load_basis(dir.path(), m, 0); });
  EXPECT_NE(message.find("planes[0].unoccluded[4]"), std::string::npos) << message;
}

}  // namespace
}  // namespace skylit::blend
