// blend_weights: w_i = S_i / D, w_sun = E_sun·c / D, D = Σ S_i A_i + E_sun·c per channel; faces
// that cannot matter are skipped; a sky without light is flagged, never divided by.
#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "blend_fixtures.hpp"
#include "skylit/base/error.hpp"

namespace skylit::blend {
namespace {

using test::make_basis;

BasisImages four_faces() {
  return make_basis(3, 2, {0.5, 0.25, 0.0, 1.0}, [](int, std::size_t) { return 0.0f; });
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

TEST(BlendWeights, FollowTheFormulaPerChannel) {
  const BasisImages basis = four_faces();
  const std::vector<Eigen::Vector3d> S{{1, 2, 3}, {4, 0, 2}, {9, 9, 9}, {0, 1, 0}};
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  // D = 0.5·S0 + 0.25·S1 + 0·S2 + 1·S3 = (1.5, 2, 2).
  EXPECT_DOUBLE_EQ(w.denominator.x(), 1.5);
  EXPECT_DOUBLE_EQ(w.denominator.y(), 2.0);
  EXPECT_DOUBLE_EQ(w.denominator.z(), 2.0);
  ASSERT_EQ(w.face.size(), 4u);
  EXPECT_FLOAT_EQ(w.face[0].x(), 1.0f / 1.5f);
  EXPECT_FLOAT_EQ(w.face[0].y(), 1.0f);
  EXPECT_FLOAT_EQ(w.face[0].z(), 1.5f);
  EXPECT_FLOAT_EQ(w.face[1].x(), 4.0f / 1.5f);
  EXPECT_FLOAT_EQ(w.face[1].y(), 0.0f);
  EXPECT_FLOAT_EQ(w.face[1].z(), 1.0f);
  EXPECT_TRUE(w.face[2].isZero());  // A = 0: the plane cannot see the face, whatever its S
  EXPECT_FLOAT_EQ(w.face[3].y(), 0.5f);
  EXPECT_EQ(w.active, (std::vector<int>{0, 1, 3}));
  EXPECT_TRUE(w.sun.isZero());
  EXPECT_EQ(w.no_light, (std::array<bool, 3>{false, false, false}));
  // Σ w_i A_i = 1 per channel: an unshadowed texel gets T = 1.
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < 4; ++i) sum += w.face[i].cast<double>() * basis.unoccluded[i];
  EXPECT_NEAR(sum.x(), 1.0, 1e-7);
  EXPECT_NEAR(sum.y(), 1.0, 1e-7);
  EXPECT_NEAR(sum.z(), 1.0, 1e-7);
}

TEST(BlendWeights, SunAddsItsCosineWeightedEnergy) {
  const BasisImages basis = four_faces();  // normal +z
  const std::vector<Eigen::Vector3d> S(4, Eigen::Vector3d(1, 1, 1));  // D_sky = 1.75
  SunLight sun;
  sun.direction = Vec3(std::sqrt(3.0), 0.0, 1.0);  // 30° elevation, not unit: normalised
  sun.energy = Eigen::Vector3d(2.5, 0.5, 0.0);     // c = sin 30° = 0.5
  const BlendWeights w = blend_weights(basis, S, sun);
  EXPECT_NEAR(w.denominator.x(), 1.75 + 1.25, 1e-12);
  EXPECT_NEAR(w.denominator.y(), 1.75 + 0.25, 1e-12);
  EXPECT_NEAR(w.denominator.z(), 1.75, 1e-12);
  EXPECT_FLOAT_EQ(w.sun.x(), static_cast<float>(1.25 / 3.0));
  EXPECT_FLOAT_EQ(w.sun.y(), static_cast<float>(0.25 / 2.0));
  EXPECT_FLOAT_EQ(w.sun.z(), 0.0f);
  EXPECT_FLOAT_EQ(w.face[0].x(), static_cast<float>(1.0 / 3.0));

  // A sun behind the plane (below its horizon) adds nothing.
  sun.direction = Vec3(0.3, 0.2, -0.5);
  const BlendWeights behind = blend_weights(basis, S, sun);
  EXPECT_TRUE(behind.sun.isZero());
  EXPECT_NEAR(behind.denominator.x(), 1.75, 1e-12);
}

TEST(BlendWeights, NightSkyIsNoLightInEveryChannel) {
  const BasisImages basis = four_faces();
  const std::vector<Eigen::Vector3d> S(4, Eigen::Vector3d::Zero());
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  EXPECT_EQ(w.no_light, (std::array<bool, 3>{true, true, true}));
  EXPECT_TRUE(w.active.empty());
  for (const Eigen::Vector3f& f : w.face) EXPECT_TRUE(f.isZero());
  EXPECT_TRUE(w.sun.isZero());
}

TEST(BlendWeights, PlaneFacingAwayFromEveryLitFaceIsNoLight) {
  // Only face 2 is lit, and the plane cannot see it (A = 0).
  const BasisImages basis = four_faces();
  std::vector<Eigen::Vector3d> S(4, Eigen::Vector3d::Zero());
  S[2] = Eigen::Vector3d(5, 5, 5);
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  EXPECT_EQ(w.no_light, (std::array<bool, 3>{true, true, true}));
  EXPECT_TRUE(w.active.empty());
}

TEST(BlendWeights, OneDarkChannelIsFlaggedAlone) {
  const BasisImages basis = four_faces();
  const std::vector<Eigen::Vector3d> S(4, Eigen::Vector3d(1, 0, 1));
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  EXPECT_EQ(w.no_light, (std::array<bool, 3>{false, true, false}));
  EXPECT_EQ(w.active, (std::vector<int>{0, 1, 3}));
  for (const Eigen::Vector3f& f : w.face) EXPECT_EQ(f.y(), 0.0f);
}

TEST(BlendWeights, MinDenominatorDecidesWhatCountsAsLight) {
  const BasisImages basis = four_faces();
  const std::vector<Eigen::Vector3d> S(4, Eigen::Vector3d(1e-9, 1e-9, 1e-9));  // D = 1.75e-9
  BlendOptions options;
  EXPECT_EQ(blend_weights(basis, S, std::nullopt, options).no_light[0], false);
  options.min_denominator = 1e-6;
  EXPECT_EQ(blend_weights(basis, S, std::nullopt, options).no_light[0], true);
}

TEST(BlendWeights, BadSkiesAreInputErrorsNamingTheValue) {
  const BasisImages basis = four_faces();
  std::vector<Eigen::Vector3d> S(4, Eigen::Vector3d(1, 1, 1));

  const std::vector<Eigen::Vector3d> three(3, Eigen::Vector3d(1, 1, 1));
  EXPECT_NE(input_error_of([&] { blend_weights(basis, three, std::nullopt); }).find("3 luminance values for the 4"),
            std::string::npos);

  S[2].y() = std::numeric_limits<double>::quiet_NaN();
  std::string message = input_error_of([&] { blend_weights(basis, S, std::nullopt); });
  EXPECT_NE(message.find("S[2].g"), std::string::npos) << message;
  EXPECT_NE(message.find("NaN"), std::string::npos) << message;
  EXPECT_NE(message.find("Fix:"), std::string::npos) << message;

  S[2] = Eigen::Vector3d(1, 1, -0.5);
  message = input_error_of([&] { blend_weights(basis, S, std::nullopt); });
  EXPECT_NE(message.find("S[2].b"), std::string::npos) << message;

  S[2] = Eigen::Vector3d(std::numeric_limits<double>::infinity(), 1, 1);
  message = input_error_of([&] { blend_weights(basis, S, std::nullopt); });
  EXPECT_NE(message.find("S[2].r"), std::string::npos) << message;
  EXPECT_NE(message.find("inf"), std::string::npos) << message;

  S[2] = Eigen::Vector3d(1, 1, 1);
  SunLight sun;
  sun.energy = Eigen::Vector3d(1, -1, 1);
  message = input_error_of([&] { blend_weights(basis, S, sun); });
  EXPECT_NE(message.find("sun.energy.g"), std::string::npos) << message;
  sun.energy = Eigen::Vector3d(1, 1, std::numeric_limits<double>::quiet_NaN());
  EXPECT_NE(input_error_of([&] { blend_weights(basis, S, sun); }).find("sun.energy.b"), std::string::npos);
  sun.energy = Eigen::Vector3d(1, 1, 1);
  sun.direction = Vec3::Zero();
  EXPECT_NE(input_error_of([&] { blend_weights(basis, S, sun); }).find("sun.direction"), std::string::npos);
  sun.direction = Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 1);
  EXPECT_NE(input_error_of([&] { blend_weights(basis, S, sun); }).find("sun.direction"), std::string::npos);

  BlendOptions options;
  options.min_denominator = -1;
  EXPECT_NE(input_error_of([&] { blend_weights(basis, S, std::nullopt, options); }).find("min_denominator"),
            std::string::npos);
  options.min_denominator = 1e-12;
  options.threads = -2;
  EXPECT_NE(input_error_of([&] { blend_weights(basis, S, std::nullopt, options); }).find("threads"),
            std::string::npos);
}

TEST(BlendWeights, InconsistentBasisIsAnInputError) {
  BasisImages basis = four_faces();
  const std::vector<Eigen::Vector3d> S(4, Eigen::Vector3d(1, 1, 1));
  basis.unoccluded.pop_back();
  EXPECT_NE(input_error_of([&] { blend_weights(basis, S, std::nullopt); }).find("unoccluded"), std::string::npos);
  basis = four_faces();
  basis.unoccluded[1] = -0.1;
  EXPECT_NE(input_error_of([&] { blend_weights(basis, S, std::nullopt); }).find("unoccluded[1]"), std::string::npos);
  basis = four_faces();
  basis.half.pop_back();
  EXPECT_NE(input_error_of([&] { blend_weights(basis, S, std::nullopt); }).find("holds 23 values"),
            std::string::npos);
}

}  // namespace
}  // namespace skylit::blend
