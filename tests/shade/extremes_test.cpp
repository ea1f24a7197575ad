// The sky stage and the CPU blend at the numerical extremes, end to end: a real (small) bake of a
// box beside a wall, sky frames rendered into a sky camera, luminance parameters, the sun, and
// the shadow ratios. In every case T is finite and in [0, 1], and the flag says what happened.
// Every case runs on a faces bake and on a corners bake (three layers per face, corner
// coefficients that may be negative), and on the bake of every preset of config/presets.yaml
// (its dome frequency, basis, samples and PCA components), each in its full, lean and PCA forms,
// blended on the CPU and on the GPU (llvmpipe) in every storage the form can take: half, 8-bit
// and EAC blocks.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>
#include <limits>
#include <numbers>
#include <optional>
#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "../blend/gpu_test_support.hpp"
#include "../support/box_site.hpp"
#include "../support/fixture_cache.hpp"
#include "../support/quiet_bake.hpp"
#include "../support/sky_paint.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/base/presets.hpp"
#include "skylit/baker/preset.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit {
namespace {

namespace fs = std::filesystem;
using geom::Vec3;
constexpr double kDeg = std::numbers::pi / 180.0;

using skylit::test::angle;
using skylit::test::from_angles;

// What a case is run on: a bake's settings.
struct BakeVariant {
  std::string name;
  int frequency = 2;
  geom::DomeBasis basis = geom::DomeBasis::Faces;
  int samples = 4;
  int pca_components = 4;  // the PCA form stored beside the full one
  int pca_tile = 0;        // clustered PCA: tiles of this many texels (0: the whole plane)
};

std::vector<BakeVariant> bake_variants() {
  // Compressed hard (4 components) so that the clamp and the bound are exercised.
  std::vector<BakeVariant> variants{{"faces", 2, geom::DomeBasis::Faces, 4, 4},
                                    {"corners", 2, geom::DomeBasis::Corners, 4, 4},
                                    {"quadratics", 2, geom::DomeBasis::Quadratics, 6, 4},
                                    // Tiles of 6 texels: 4 × 4 on the ground, 2 × 2 (the last narrower) on the wall.
                                    {"faces_tiled_pca", 2, geom::DomeBasis::Faces, 4, 4, 6}};
  const PresetsFile presets(default_presets_file());
  for (const std::string& name : presets.names()) {
    const baker::BakePreset p = baker::load_bake_preset(presets, name);
    variants.push_back({"preset_" + name, p.frequency, p.basis, p.samples, p.pca_components > 0 ? p.pca_components : 4,
                        p.pca_tile});
  }
  return variants;
}

// A box 2 m tall on the ground, a ground plane around it, and a wall plane on the box's north
// face that faces north (away from a southern sky).
class ExtremesTest : public ::testing::TestWithParam<BakeVariant> {
 protected:
  static void SetUpTestSuite() {
    dir_ = new skylit::test::TempDir("skylit-extremes-");
    skylit::test::write_box_site(dir_->path(), "dome:\n  frequency: 2\n"
                                        "planes:\n"
                                        "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                        "    v: [0, 12, 0]\n    resolution: [24, 24]\n"
                                        "  - name: north_wall\n    origin: [1, 1.01, 0]\n    u: [-2, 0, 0]\n"
                                        "    v: [0, 0, 2]\n    resolution: [8, 8]\n");
    const scene::Site site = scene::load_site(*dir_ / "site.yaml");
    mesh_ = new scene::Mesh(scene::load_site_model(site));
    context_ = new gpu::HeadlessContext();
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete mesh_;
    delete context_;
  }

  // The GPU blend of `basis` in every storage that can hold it (half; 8-bit and EAC blocks when
  // no layer is negative, i.e. not a PCA form): T finite and in [0, 1], and within the storage's
  // bound of the CPU blend `expected` (8-bit: Σ_i |w_i| max_i / 510; EAC: Σ_i |w_i| e_i with e_i
  // the error measured on upload), plus fp32 summation in another order.
  static void expect_gpu_blends(const blend::BasisImages& basis, const blend::BlendWeights& w,
                                std::span<const float> visibility, std::span<const float> expected, std::size_t plane) {
    std::optional<blend::test::VisibilityTexture> sun;
    if (!w.sun.isZero(0)) sun.emplace(basis.width, basis.height, visibility);
    const bool negative = std::any_of(basis.half.begin(), basis.half.end(), [](std::uint16_t h) { return (h & 0x8000u) && (h & 0x7FFFu); });
    std::vector<blend::BasisStorage> storages{blend::BasisStorage::Half};
    if (!negative) storages.insert(storages.end(), {blend::BasisStorage::Unorm8, blend::BasisStorage::Eac11});
    for (const blend::BasisStorage storage : storages) {
      blend::GpuBlender blender(basis, blend::test::blend_options(storage, blend::ShadowRatioFormat::Float));
      blender.blend(w, sun ? &sun->texture : nullptr);
      const std::vector<float> T = blender.read_back();
      ASSERT_EQ(T.size(), expected.size());
      Eigen::Vector3d magnitude = w.sun.cwiseAbs().cast<double>(), quantisation = Eigen::Vector3d::Zero();
      for (const int i : w.active) {
        // A tiled basis has a weight per tile and layer; the layer's bounds are per layer.
        const auto k = static_cast<std::size_t>(i) % static_cast<std::size_t>(basis.layers);
        const Eigen::Vector3d wi = w.face[static_cast<std::size_t>(i)].cwiseAbs().cast<double>();
        magnitude += wi * blender.layer_max()[k];
        if (storage == blend::BasisStorage::Unorm8) quantisation += wi * blender.layer_max()[k] / 510.0;
        if (storage == blend::BasisStorage::Eac11) quantisation += wi * blender.eac_error()[k];
      }
      const double bound = quantisation.maxCoeff() + 4.0 * static_cast<double>(w.active.size() + 2) * 0x1p-24 * std::max(magnitude.maxCoeff(), 1.0);
      double worst = 0.0;
      for (std::size_t k = 0; k < T.size(); ++k) {
        ASSERT_TRUE(std::isfinite(T[k]) && T[k] >= 0.0f && T[k] <= 1.0f) << "plane " << plane << " value " << k;
        worst = std::max(worst, std::abs(static_cast<double>(T[k]) - expected[k]));
      }
      EXPECT_LE(worst, bound + 1e-6) << "plane " << plane << ", storage " << static_cast<int>(storage) << ", "
                                     << basis.layers << " layers";
    }
  }

  // The case's bake, beside the site it was made from: made once per build of the test program
  // (ctest runs each case in its own process) and shared by the processes that need it.
  static fs::path bake_dir() {
    const BakeVariant& v = GetParam();
    return skylit::test::cached_fixture("extremes_" + v.name, [&v](const fs::path& out) {
      for (const char* file : {"site.yaml", "box.obj"}) fs::copy_file(*dir_ / file, out / file);
      skylit::test::quiet_bake(out / "site.yaml", out / "bake", v.samples, [&v](baker::BakeOptions& options) {
        options.frequency = v.frequency;
        options.basis = v.basis;
      });
      // The PCA form beside the full one: every case checks it too.
      bake_format::PcaOptions pca;
      pca.components = v.pca_components;
      pca.tile = v.pca_tile;
      baker::compress_bake(out / "bake", pca, std::nullopt, nullptr);
    }) / "bake";
  }
  static const bake_format::Manifest& manifest() {
    const BakeVariant& v = GetParam();
    if (auto found = manifests_.find(v.name); found != manifests_.end()) return found->second;
    return manifests_.emplace(v.name, bake_format::read_manifest(bake_dir())).first->second;
  }

  static camera::CameraCalibration camera(double edge_angle_deg = 90.0) {
    camera::CameraCalibration c;
    c.image_width = c.image_height = 400;
    c.fx = c.fy = 200.0 / (edge_angle_deg * kDeg);
    c.cx = c.cy = 199.5;
    c.D = {0, 0, 0, 0};
    return c;
  }

  struct Outcome {
    sky::SkyEstimate estimate;
    std::vector<blend::BlendWeights> weights;
    std::vector<std::vector<float>> T;
    std::vector<std::vector<float>> T_pca;  // the same from the bake's PCA form
    std::vector<int> lean_layers;           // layers of the lean form, per plane
  };

  // Sky frame → S (and sun) → T for every plane, as skylit-shade does it, on the bake of the
  // test's basis.
  static Outcome shade(const sky::RadianceFrame& frame, const camera::CameraCalibration& calibration,
                       sky::SunMode sun_mode) {
    const bake_format::Manifest& m = manifest();
    const geom::Dome dome(GetParam().frequency);
    sky::SkyEstimateOptions options;
    options.sun_mode = sun_mode;
    options.table.basis = GetParam().basis;
    const sky::SkyEstimator estimator(calibration, dome, options);
    Outcome o;
    o.estimate = estimator.estimate(frame);
    const std::vector<Eigen::Vector3d> S = sky::layer_radiances(o.estimate.luminance);
    std::optional<blend::SunLight> sun;
    if (o.estimate.sun) sun = blend::SunLight{o.estimate.sun->direction, o.estimate.sun->energy};
    for (std::size_t j = 0; j < m.planes.size(); ++j) {
      const blend::BasisImages basis = blend::load_basis(bake_dir(), m, static_cast<int>(j));
      std::vector<float> visibility;
      if (sun) {
        visibility.resize(basis.texel_count());
        baker::area_light_visibility(*mesh_, m.planes[j].plane, o.estimate.sun->disc_directions,
                                     o.estimate.sun->disc_weights, visibility);
      }
      o.weights.push_back(blend::blend_weights(basis, S, sun));
      std::vector<float> T(basis.texel_count() * 3);
      blend::blend_cpu(basis, o.weights.back(),
                        o.weights.back().sun.isZero(0) ? std::span<const float>() : std::span<const float>(visibility), T);
      // The PCA form: within its bound of the full blend, max |F − F̂| times Σ_l |α_l|
      // (α_l = S_l A_l / D: at most 1 for faces, more where corner coefficients are negative).
      const blend::BasisImages pca =
          blend::load_basis(bake_dir(), m, static_cast<int>(j), blend::BasisForm::Pca);
      const blend::BlendWeights pca_weights = blend::blend_weights(pca, S, sun);
      std::vector<float> T_pca(T.size());
      blend::blend_cpu(pca, pca_weights,
                        pca_weights.sun.isZero(0) ? std::span<const float>() : std::span<const float>(visibility), T_pca);
      for (int c = 0; c < 3; ++c) {
        if (o.weights.back().no_light[static_cast<std::size_t>(c)]) continue;
        double alpha = 0.0;
        for (std::size_t l = 0; l < S.size(); ++l) alpha += std::abs(S[l][c] * m.planes[j].unoccluded[l]);
        const double bound = m.planes[j].pca->max_error * alpha / o.weights.back().denominator[c] + 1e-4;
        for (std::size_t k = 0; k < basis.texel_count(); ++k) {
          EXPECT_LE(std::abs(T_pca[3 * k + static_cast<std::size_t>(c)] - T[3 * k + static_cast<std::size_t>(c)]), bound)
              << "plane " << j << " texel " << k << " channel " << c;
        }
      }
      // A form within the footprint's tolerance (1e-3) of the full one: blended, finite, in
      // [0, 1] and within the tolerance times Σ|α| (1 for faces; corners' negative coefficients
      // raise it) of T.
      const auto blend_within_tolerance = [&](const blend::BasisImages& form, blend::BlendWeights& weights) {
        weights = blend::blend_weights(form, S, sun);
        std::vector<float> T_form(T.size());
        blend::blend_cpu(form, weights, weights.sun.isZero(0) ? std::span<const float>() : std::span<const float>(visibility),
                          T_form);
        for (std::size_t k = 0; k < T.size(); ++k) {
          EXPECT_TRUE(std::isfinite(T_form[k]) && T_form[k] >= 0.0f && T_form[k] <= 1.0f) << "plane " << j;
          const auto c = k % 3;
          double alpha = 1.0;
          if (!o.weights.back().no_light[c]) {
            alpha = 0.0;
            for (std::size_t l = 0; l < S.size(); ++l) alpha += std::abs(S[l][static_cast<Eigen::Index>(c)] * m.planes[j].unoccluded[l]);
            alpha /= o.weights.back().denominator[static_cast<Eigen::Index>(c)];
          }
          EXPECT_LE(std::abs(T_form[k] - T[k]), 1e-3 * alpha + 1e-5) << "plane " << j << " value " << k;
        }
        return T_form;
      };
      // The lean form: only the layers that hold a shadow.
      const blend::BasisImages lean =
          blend::load_basis(bake_dir(), m, static_cast<int>(j), blend::BasisForm::Lean);
      EXPECT_LE(lean.layers, basis.layers);
      blend::BlendWeights lean_weights;
      const std::vector<float> T_lean = blend_within_tolerance(lean, lean_weights);
      // The cropped form: the lean one with each shadowed layer cropped to its rectangle. Outside
      // it B is within the tolerance of A, so the same bound holds against the full form.
      const blend::BasisImages cropped =
          blend::load_basis(bake_dir(), m, static_cast<int>(j), blend::BasisForm::Cropped);
      EXPECT_LE(cropped.half.size(), lean.half.size());
      blend::BlendWeights cropped_weights;
      const std::vector<float> T_cropped = blend_within_tolerance(cropped, cropped_weights);
      // The same forms blended on the GPU, in every storage each can take.
      expect_gpu_blends(basis, o.weights.back(), visibility, T, j);
      expect_gpu_blends(lean, lean_weights, visibility, T_lean, j);
      expect_gpu_blends(cropped, cropped_weights, visibility, T_cropped, j);
      expect_gpu_blends(pca, pca_weights, visibility, T_pca, j);
      o.lean_layers.push_back(lean.layers);
      o.T.push_back(std::move(T));
      o.T_pca.push_back(std::move(T_pca));
    }
    return o;
  }

  static sky::RadianceFrame paint(const camera::CameraCalibration& calibration,
                                  const std::function<Eigen::Vector3d(const Vec3&)>& radiance) {
    return {skylit::test::paint_sky(camera::Lens(calibration), radiance), cv::Mat()};
  }

  static void expect_finite_unit(const Outcome& o) {
    for (const auto& T : o.T_pca) {
      for (float t : T) {
        ASSERT_TRUE(std::isfinite(t));
        ASSERT_GE(t, 0.0f);
        ASSERT_LE(t, 1.0f);
      }
    }
    for (const auto& T : o.T) {
      for (float t : T) {
        ASSERT_TRUE(std::isfinite(t));
        ASSERT_GE(t, 0.0f);
        ASSERT_LE(t, 1.0f);
      }
    }
  }

  static bool any_no_light(const blend::BlendWeights& w) { return w.no_light[0] || w.no_light[1] || w.no_light[2]; }

  static skylit::test::TempDir* dir_;
  static std::map<std::string, bake_format::Manifest> manifests_;  // by variant name
  static scene::Mesh* mesh_;
  static gpu::HeadlessContext* context_;  // the GPU blends' (their GL objects die before it)
};

skylit::test::TempDir* ExtremesTest::dir_ = nullptr;
std::map<std::string, bake_format::Manifest> ExtremesTest::manifests_;
scene::Mesh* ExtremesTest::mesh_ = nullptr;
gpu::HeadlessContext* ExtremesTest::context_ = nullptr;

// A blue sky with a sun of the given radiance and radius.
std::function<Eigen::Vector3d(const Vec3&)> sunny(const Vec3& sun, double sun_radiance, double sky_level = 1.0,
                                                  double radius_deg = 0.6) {
  return [=](const Vec3& d) -> Eigen::Vector3d {
    if (d.z() < 0) return Eigen::Vector3d::Zero();
    if (angle(d, sun) <= radius_deg * kDeg) return Eigen::Vector3d::Constant(sun_radiance);
    return sky_level * Eigen::Vector3d(0.4, 0.6, 1.0);
  };
}

TEST_P(ExtremesTest, BlackSkyGivesOneAndTheNoLightFlag) {
  for (sky::SunMode mode : {sky::SunMode::Off, sky::SunMode::Auto}) {
    const Outcome o = shade(paint(camera(), [](const Vec3&) { return Eigen::Vector3d::Zero(); }), camera(), mode);
    expect_finite_unit(o);
    EXPECT_FALSE(o.estimate.sun);
    for (std::size_t j = 0; j < o.T.size(); ++j) {
      EXPECT_TRUE(o.weights[j].no_light[0] && o.weights[j].no_light[1] && o.weights[j].no_light[2]);
      for (float t : o.T[j]) EXPECT_EQ(t, 1.0f);
    }
  }
}

TEST_P(ExtremesTest, OnlyTheSunCastsAHardShadow) {
  const Vec3 sun = from_angles(180.0, 45.0);
  const Outcome o = shade(paint(camera(), [&](const Vec3& d) {
                            return Eigen::Vector3d::Constant(angle(d, sun) <= 0.6 * kDeg ? 1e4 : 0.0);
                          }),
                          camera(), sky::SunMode::Auto);
  expect_finite_unit(o);
  ASSERT_TRUE(o.estimate.sun) << o.estimate.sun_reason;
  // The ground north of the box is in full shadow, the ground far south fully lit.
  const auto& ground = manifest().planes[0].plane;
  const auto texel = [&](double x, double y) {
    const int col = static_cast<int>((x - ground.origin.x()) / ground.u.x() * ground.width);
    const int row = static_cast<int>((y - ground.origin.y()) / ground.v.y() * ground.height);
    return o.T[0][(static_cast<std::size_t>(row) * ground.width + col) * 3 + 1];
  };
  EXPECT_LT(texel(0.0, 1.8), 0.02f);
  EXPECT_GT(texel(0.0, -4.0), 0.98f);
}

TEST_P(ExtremesTest, SunOnADomeVertexAnEdgeTheHorizonAndBelow) {
  const geom::Dome dome(GetParam().frequency);
  const auto& f = dome.face(12);
  const Vec3 vertex = dome.vertices()[static_cast<std::size_t>(f.vertex[1])];
  const Vec3 edge = (dome.vertices()[static_cast<std::size_t>(f.vertex[0])] +
                     dome.vertices()[static_cast<std::size_t>(f.vertex[1])]).normalized();
  struct Case {
    const char* name;
    Vec3 sun;
    bool visible;
  };
  const std::vector<Case> cases{{"zenith vertex", Vec3::UnitZ(), true},
                                {"vertex", vertex, vertex.z() > 0.05},
                                {"edge", edge, edge.z() > 0.05},
                                {"horizon", from_angles(200.0, 0.0), true},
                                {"below", from_angles(200.0, -2.0), false}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    for (sky::SunMode mode : {sky::SunMode::Off, sky::SunMode::Auto}) {
      const Outcome o = shade(paint(camera(), sunny(c.sun, 1e4)), camera(), mode);
      expect_finite_unit(o);
      if (mode == sky::SunMode::Off) {
        EXPECT_FALSE(o.estimate.sun);
        if (GetParam().basis != geom::DomeBasis::Faces && c.visible) {
          // A 1e4 sun in a linear or quadratic fit: the coefficients away from it go negative, T
          // stays in [0, 1].
          double lowest = 0;
          for (const auto& face : o.estimate.luminance.faces) {
            for (const Eigen::Vector3d& corner : face.coefficients) lowest = std::min(lowest, corner.minCoeff());
          }
          EXPECT_LT(lowest, -1.0);
        }
        continue;
      }
      EXPECT_EQ(o.estimate.sun.has_value(), c.visible) << o.estimate.sun_reason;
      if (o.estimate.sun) {
        EXPECT_LT(angle(o.estimate.sun->direction, c.sun), 1.0 * kDeg);
        bool flagged = false;
        for (const auto& face : o.estimate.luminance.faces) flagged |= (face.flags & sky::kFaceSunRemoved) != 0;
        EXPECT_TRUE(flagged);
      }
    }
  }
}

TEST_P(ExtremesTest, DynamicRangeOfAMillion) {
  const Outcome o = shade(paint(camera(), sunny(from_angles(90.0, 30.0), 1e3, 1e-3)), camera(), sky::SunMode::Auto);
  expect_finite_unit(o);
  ASSERT_TRUE(o.estimate.sun) << o.estimate.sun_reason;
  EXPECT_GT(o.estimate.sun->contrast, 1e5);
}

TEST_P(ExtremesTest, NegativeNanAndInfPixelsAreCountedNeverPropagated) {
  sky::RadianceFrame frame = paint(camera(), sunny(from_angles(90.0, 50.0), 1e4));
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  for (int k = 0; k < 50; ++k) {
    frame.radiance.at<cv::Vec3f>(100 + k, 150) = cv::Vec3f(nan, 1, 1);
    frame.radiance.at<cv::Vec3f>(150, 100 + k) = cv::Vec3f(inf, inf, inf);
    frame.radiance.at<cv::Vec3f>(250, 200 + k) = cv::Vec3f(-5, -5, -5);
  }
  for (sky::SunMode mode : {sky::SunMode::Off, sky::SunMode::Auto}) {
    const Outcome o = shade(frame, camera(), mode);
    expect_finite_unit(o);
    EXPECT_EQ(o.estimate.luminance.nan_pixels, 50);
    EXPECT_EQ(o.estimate.luminance.inf_pixels, 50);
    EXPECT_EQ(o.estimate.luminance.negative_pixels, 50);
    for (const auto& face : o.estimate.luminance.faces) EXPECT_TRUE(face.rgb.allFinite());
  }
}

TEST_P(ExtremesTest, EightBitFrameWithAClippedSun) {
  const sky::RadianceFrame hdr = paint(camera(), sunny(from_angles(135.0, 40.0), 1e4));
  // Exposed for the sky: the sun clips, as it does on every real 8-bit sky camera.
  const cv::Mat frame8 = sky::to_8bit(hdr.radiance, 0.5);
  const sky::RadianceFrame frame = sky::linearise(frame8, sky::ResponseCurve::srgb(8), {});
  ASSERT_GT(cv::countNonZero(frame.clipped), 0);
  // Separated: the sun says it is clipped (its energy is a lower bound).
  const Outcome separated = shade(frame, camera(), sky::SunMode::Auto);
  expect_finite_unit(separated);
  ASSERT_TRUE(separated.estimate.sun) << separated.estimate.sun_reason;
  EXPECT_TRUE(separated.estimate.sun->clipped);
  // In the dome: the face that holds it is flagged clipped.
  const Outcome in_dome = shade(frame, camera(), sky::SunMode::Off);
  expect_finite_unit(in_dome);
  EXPECT_GT(in_dome.estimate.luminance.clipped_pixels, 0);
  int clipped_faces = 0;
  for (const auto& face : in_dome.estimate.luminance.faces) clipped_faces += (face.flags & sky::kFaceClipped) != 0;
  EXPECT_GE(clipped_faces, 1);
}

TEST_P(ExtremesTest, NarrowLensesSeeLessOfTheHorizon) {
  // A real lens sees nothing outside its image circle: a mask at the circle's edge.
  const auto lens_of = [&](double half_fov_deg) {
    camera::CameraCalibration c = camera(half_fov_deg);
    cv::Mat mask(c.image_height, c.image_width, CV_8UC1, cv::Scalar(0));
    cv::circle(mask, cv::Point(200, 200), 200, cv::Scalar(255), -1);
    c.mask = *dir_ / ("mask_" + std::to_string(static_cast<int>(half_fov_deg)) + ".png");
    cv::imwrite(c.mask.string(), mask);
    return c;
  };
  // 160°: the horizon faces are seen only in part (S from what is seen, coverage says how much).
  const camera::CameraCalibration wide = lens_of(80.0);
  const Outcome o160 = shade(paint(wide, sunny(from_angles(30.0, 60.0), 1e4)), wide, sky::SunMode::Auto);
  expect_finite_unit(o160);
  int partial = 0;
  for (const auto& face : o160.estimate.luminance.faces) partial += face.coverage < 0.95;
  EXPECT_GE(partial, 10);
  // 100°: the horizon band is not seen at all; those faces are filled from their neighbours.
  const camera::CameraCalibration narrow = lens_of(50.0);
  const Outcome o100 = shade(paint(narrow, sunny(from_angles(30.0, 60.0), 1e4)), narrow, sky::SunMode::Auto);
  expect_finite_unit(o100);
  EXPECT_GT(o100.estimate.luminance.unseen_faces, 0);
  int flagged = 0;
  for (const auto& face : o100.estimate.luminance.faces) {
    if (face.flags & sky::kFaceUnseen) {
      ++flagged;
      EXPECT_GT(face.rgb.minCoeff(), 0.0);  // filled from the seen neighbours
      if (GetParam().basis != geom::DomeBasis::Faces) {
        ASSERT_EQ(face.coefficients.size(), static_cast<std::size_t>(geom::layers_per_face(GetParam().basis)));
        for (const Eigen::Vector3d& c : face.coefficients) EXPECT_EQ(c, face.rgb);  // in every function
      }
    }
  }
  EXPECT_EQ(flagged, o100.estimate.luminance.unseen_faces);
}

TEST_P(ExtremesTest, PlaneFacingAwayFromEveryLitFace) {
  // Light only from deep in the south: the north-facing wall sees none of it.
  const Outcome o = shade(paint(camera(), [](const Vec3& d) {
                            return Eigen::Vector3d::Constant(d.z() >= 0 && d.y() < -0.75 ? 1.0 : 0.0);
                          }),
                          camera(), sky::SunMode::Auto);
  expect_finite_unit(o);
  ASSERT_EQ(manifest().planes[1].plane.name, "north_wall");
  EXPECT_TRUE(any_no_light(o.weights[1]));
  for (float t : o.T[1]) EXPECT_EQ(t, 1.0f);
  EXPECT_FALSE(any_no_light(o.weights[0]));  // the ground is lit
  // The wall sees half the dome, and the box it stands on shadows none of it: the lean form
  // keeps a layer of ones and nothing else at ν = 2. (The box shadows the ground from every
  // direction.) At ν = 4 (the presets) a few layers of faces on the wall's horizon are kept too
  // (4 of 480): their B differs from A there by more than the footprint's tolerance.
  if (GetParam().frequency == 2) {
    EXPECT_EQ(o.lean_layers[1], 1);
  } else {
    EXPECT_LE(static_cast<std::size_t>(o.lean_layers[1]), 1 + manifest().layer_count() / 100);
  }
  std::printf("measured: lean form, %s basis: ground %d of %zu layers, north wall %d\n",
              GetParam().name.c_str(), o.lean_layers[0], manifest().layer_count(),
              o.lean_layers[1]);
}

INSTANTIATE_TEST_SUITE_P(Basis, ExtremesTest, ::testing::ValuesIn(bake_variants()),
                         [](const ::testing::TestParamInfo<BakeVariant>& param) { return param.param.name; });

}  // namespace
}  // namespace skylit
