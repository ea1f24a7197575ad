// The compositor against its CPU reference and against geometry: recorded sky and camera frames
// in, composites out; the shadow of the buildings on the real ground where the sun puts it; the
// real camera pixels untouched where nothing virtual is; the virtual planes' exact shading; no
// NaN from any input. Measured figures are printed ("measured:" lines).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "compose_fixture.hpp"
#include "skylit/bake_format/light_map.hpp"
#include "skylit/baker/light_map.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::compose_test {
namespace {

class CompositorTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { context_ = new gpu::HeadlessContext(); }
  static void TearDownTestSuite() {
    delete context_;
    context_ = nullptr;
  }

  static render::Compositor make(const render::CompositorOptions& options = {}) {
    const BakedSite& baked = BakedSite::get();
    return render::Compositor(baked.site, baked.mesh, baked.manifest, baked.transfer, hmd_camera(), options);
  }

  // Shadow-ratio textures for the compositor, and their names in plane order.
  struct RatioTextures {
    std::vector<gpu::Texture> textures;
    std::vector<GLuint> names;
  };
  static RatioTextures upload(const std::vector<PlaneRatios>& ratios) {
    RatioTextures out;
    for (const PlaneRatios& r : ratios) {
      out.textures.push_back(render::upload_shadow_ratio(r.rgb, r.width, r.height));
      out.names.push_back(out.textures.back().get());
    }
    return out;
  }

  static ReferenceInputs reference_inputs(const std::vector<PlaneRatios>& ratios, const std::vector<Vector3d>& sky,
                                          const std::optional<blend::SunLight>& sun,
                                          const Vector3d& photometric = Vector3d::Ones()) {
    const BakedSite& baked = BakedSite::get();
    ReferenceInputs in;
    in.site = &baked.site;
    in.mesh = &baked.mesh;
    in.manifest = &baked.manifest;
    in.transfer = baked.transfer;
    in.ratios = ratios;
    in.sky = sky;
    in.sun = sun;
    in.photometric = photometric;
    return in;
  }

  static gpu::HeadlessContext* context_;
};
gpu::HeadlessContext* CompositorTest::context_ = nullptr;

// A uniform sky of radiance `level` on every face.
std::vector<Vector3d> uniform_sky(double level) {
  return std::vector<Vector3d>(BakedSite::get().manifest.faces.size(), Vector3d::Constant(level));
}

bool finite_image(const cv::Mat& image) {
  const cv::Mat flat = image.reshape(1);
  for (int y = 0; y < flat.rows; ++y) {
    for (int x = 0; x < flat.cols; ++x) {
      const double v = flat.depth() == CV_32F ? static_cast<double>(flat.at<float>(y, x)) : flat.at<std::uint8_t>(y, x);
      if (!std::isfinite(v)) return false;
    }
  }
  return true;
}

TEST_F(CompositorTest, RecordedFramesMatchTheCpuReference) {
  const BakedSite& baked = BakedSite::get();
  // The recorded sky (a real HDR capture), turned so that its sun stands in the west-south-west,
  // seen by the sample sky camera; the HMD frame is the same capture seen by the HMD camera.
  const cv::Mat equirect = sky::read_sky_image(fs::path(SKYLIT_SOURCE_DIR) / "data/hdri/park.exr");
  const camera::CameraCalibration sky_camera = camera::load_calibration(fs::path(SKYLIT_SOURCE_DIR) / "config/sky_camera.yaml");
  sky::RenderOptions render_options;
  render_options.supersample = 2;
  const geom::Dome dome(2);
  const sky::SkyEstimator estimator(sky_camera, dome);
  sky::SkyEstimate estimate = estimator.estimate({sky::render_fisheye(estimator.lens(), equirect, render_options), cv::Mat()});
  ASSERT_TRUE(estimate.sun) << estimate.sun_reason;
  // Turn the capture about the zenith so that its sun lies at azimuth 250° (the tower then shades
  // the annex's roof and the ground east of it).
  const double sun_azimuth = std::atan2(estimate.sun->direction.x(), estimate.sun->direction.y());
  render_options.azimuth_offset = 250.0 * std::numbers::pi / 180.0 - sun_azimuth;
  estimate = estimator.estimate({sky::render_fisheye(estimator.lens(), equirect, render_options), cv::Mat()});
  ASSERT_TRUE(estimate.sun) << estimate.sun_reason;
  const sky::Sun& detected = *estimate.sun;
  std::vector<Vector3d> S;
  for (const sky::FaceLuminance& face : estimate.luminance.faces) S.push_back(face.rgb);
  const blend::SunLight sun{detected.direction, detected.energy};
  std::printf("measured: sun at azimuth %.1f°, elevation %.1f°, E_sun %.3g, Σ S_i Ω_i %.3g\n",
              std::atan2(sun.direction.x(), sun.direction.y()) * 180 / std::numbers::pi,
              std::asin(sun.direction.z()) * 180 / std::numbers::pi, sun.energy.mean(),
              [&] {
                double sum = 0;
                for (std::size_t i = 0; i < S.size(); ++i) sum += S[i].mean() * baked.manifest.faces[i].solid_angle;
                return sum;
              }());

  const std::vector<PlaneRatios> ratios = baked.shadow_ratios(S, sun, detected.disc_directions, detected.disc_weights);
  const RatioTextures textures = upload(ratios);
  render::SunShadowMap shadow_map(baked.mesh, baked.site.planes);
  shadow_map.update(detected.direction, detected.angular_radius);

  camera::CameraCalibration hmd = hmd_camera();
  const render::CameraPose pose = hmd_pose();
  hmd.R_site_from_camera = pose.R_site_from_camera;
  const cv::Mat camera = sky::render_fisheye(camera::Lens(hmd), equirect, render_options);

  render::Compositor compositor = make();
  // The photometric match from the grass south-west of the buildings (albedo taken as known),
  // which nothing shades with the sun in the west.
  const cv::Mat region = compositor.region_mask(0, 0.15, 0.45, 0.2, 0.4, pose);
  const Vector3d ground_irradiance = render::plane_irradiance(baked.manifest.planes[0], S, sun);
  const render::PhotometricEstimate match =
      render::estimate_photometric_match(camera, region, ground_irradiance, Vector3d(0.12, 0.14, 0.05));
  ASSERT_TRUE(match.ok) << match.problem;
  std::printf("measured: photometric scale k = (%.4g, %.4g, %.4g) from %lld pixels, spread %.3f\n",
              match.match.scale.x(), match.match.scale.y(), match.match.scale.z(),
              static_cast<long long>(match.pixels_used), match.spread.maxCoeff());

  render::CompositeInput input;
  input.camera = camera;
  input.pose = pose;
  input.sky = S;
  input.sun = sun;
  input.shadow_ratios = textures.names;
  input.sun_shadow = &shadow_map;
  input.photometric = match.match;
  const cv::Mat gpu = compositor.composite(input);
  EXPECT_FALSE(compositor.last_stats().sun_without_shadow_map);

  const RayCaster caster(baked.mesh);
  const ReferenceResult reference = reference_composite(reference_inputs(ratios, S, sun, match.match.scale),
                                                        camera::Lens(hmd_camera()), caster, camera, pose);
  ASSERT_TRUE(finite_image(gpu));
  // A pixel is off when a channel differs by more than 1% of the image's mean value plus 2% of
  // its own. Edges rasterise differently (the building's outline through the pinhole render,
  // the sun's penumbra on the building through the shadow map against the reference's one ray to
  // the disc's centre): the building is judged inside its outline (eroded by 2 px), where the
  // remaining differences lie on the kinks of the bilinearly magnified checker texture, smoothed
  // by the render's resampling (a render_scale of 2 halves them).
  const double scale = cv::mean(reference.linear)[1];
  const Difference all = compare(gpu, reference.linear, cv::Mat(), 0.01 * scale, 0.02);
  const cv::Mat building = reference.what == 2, ground = reference.what == 1;
  cv::Mat interior;
  cv::erode(building, interior, cv::Mat::ones(5, 5, CV_8U));
  const Difference on_building = compare(gpu, reference.linear, interior, 0.01 * scale, 0.02);
  const Difference on_ground = compare(gpu, reference.linear, ground, 0.01 * scale, 0.02);
  std::printf("measured: GPU vs CPU composite (mean value %.4g): all %lld px, mean |d| %.3g, max %.3g, off %.2f%%; "
              "building interior %lld px, mean %.3g, max %.3g, off %.2f%%; real ground %lld px, mean %.3g, max %.3g, "
              "off %.2f%%\n",
              scale, static_cast<long long>(all.pixels), all.mean, all.max, 100 * all.fraction_off,
              static_cast<long long>(on_building.pixels), on_building.mean, on_building.max,
              100 * on_building.fraction_off, static_cast<long long>(on_ground.pixels), on_ground.mean, on_ground.max,
              100 * on_ground.fraction_off);
  EXPECT_GT(on_building.pixels, 3000);
  EXPECT_GT(on_ground.pixels, 10000);
  EXPECT_LT(all.mean, 0.005 * scale);
  EXPECT_LT(all.fraction_off, 0.02);
  EXPECT_LT(on_ground.fraction_off, 0.001);
  // The ground's mean difference is its few penumbra pixels (the map's disc against the
  // reference's one ray): 3.6e-5 of a mean value of 0.27 under park's sun in its daylight colour,
  // whose edges lie in every channel (before the colour was corrected, in blue alone: 1e-5).
  EXPECT_LT(on_ground.mean, 2e-4 * scale);
  EXPECT_LT(on_building.mean, 0.01 * cv::mean(reference.linear, interior)[1]);
  EXPECT_LT(on_building.fraction_off, 0.05);

  // The building rendered smaller (CompositorOptions::lens.render_scale, a speed setting): what
  // it costs against the same reference. 0.75 keeps the full-size bounds; 0.5, which blurs the
  // checker over twice the texels, gets twice them. The real ground changes only where the
  // building's coarser outline covers it.
  for (const double render_scale : {0.75, 0.5}) {
    SCOPED_TRACE(render_scale);
    render::CompositorOptions options;
    options.lens.render_scale = render_scale;
    render::Compositor smaller = make(options);
    const cv::Mat out = smaller.composite(input);
    const Difference scaled_all = compare(out, reference.linear, cv::Mat(), 0.01 * scale, 0.02);
    const Difference scaled_building = compare(out, reference.linear, interior, 0.01 * scale, 0.02);
    const Difference scaled_ground = compare(out, reference.linear, ground, 0.01 * scale, 0.02);
    std::printf("measured: render scale %.2f (pinhole %d×%d): all mean |d| %.3g, off %.2f%%; building interior mean %.3g, "
                "off %.2f%%; real ground off %.2f%%\n",
                render_scale, smaller.lens_remap().pinhole.width, smaller.lens_remap().pinhole.height, scaled_all.mean,
                100 * scaled_all.fraction_off, scaled_building.mean, 100 * scaled_building.fraction_off,
                100 * scaled_ground.fraction_off);
    const bool full_bounds = render_scale >= 0.75;
    EXPECT_LT(scaled_all.mean, (full_bounds ? 0.005 : 0.01) * scale);
    EXPECT_LT(scaled_ground.fraction_off, 0.002);
    EXPECT_LT(scaled_building.mean, (full_bounds ? 0.01 : 0.02) * cv::mean(reference.linear, interior)[1]);
    EXPECT_LT(scaled_building.fraction_off, full_bounds ? 0.05 : 0.15);
  }

  save_picture("recorded_camera", camera);
  save_picture("recorded_composite_gpu", gpu);
  save_picture("recorded_composite_cpu", reference.linear);
  cv::Mat difference;
  cv::absdiff(gpu, reference.linear, difference);
  save_picture("recorded_difference_x10", difference * 10.0);
}

// Ground points in the shadow the buildings cast with the sun towards `sun`: the convex hull of
// each box's corners projected along the sun onto the ground plane; signed distance to the
// nearest hull edge (positive inside).
double shadow_depth(const Vector3d& sun, const Eigen::Vector2d& ground_point, double plane_height) {
  const std::array<Box, 2> boxes{Box{{-1, -1, 0}, {1, 1, 4}}, Box{{1, -1, 0}, {4, 1, 1.5}}};
  double best = -std::numeric_limits<double>::infinity();
  for (const Box& box : boxes) {
    std::vector<cv::Point2f> corners;
    for (int k = 0; k < 8; ++k) {
      const Vector3d p((k & 1) ? box.high.x() : box.low.x(), (k & 2) ? box.high.y() : box.low.y(),
                       (k & 4) ? box.high.z() : box.low.z());
      const Vector3d q = p - (p.z() - plane_height) / sun.z() * sun;
      corners.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()));
    }
    std::vector<cv::Point2f> hull;
    cv::convexHull(corners, hull);
    best = std::max(best, cv::pointPolygonTest(hull, cv::Point2f(static_cast<float>(ground_point.x()),
                                                                 static_cast<float>(ground_point.y())),
                                               true));
  }
  return best;
}

TEST_F(CompositorTest, ShadowOnTheGroundLandsWhereGeometryPutsIt) {
  const BakedSite& baked = BakedSite::get();
  for (const double azimuth : {250.0, 120.0}) {
    SCOPED_TRACE(azimuth);
    const Vector3d towards_sun = from_angles(azimuth, 35.0);
    const std::vector<Vector3d> S = uniform_sky(0.05);
    const blend::SunLight sun{towards_sun, Vector3d::Ones()};
    const std::vector<PlaneRatios> ratios = baked.shadow_ratios(S, sun);
    const RatioTextures textures = upload(ratios);
    render::SunShadowMap shadow_map(baked.mesh, baked.site.planes);
    shadow_map.update(towards_sun, 0.0047);

    // A grey real world: every camera pixel 0.5 (linear), so a ground pixel reads 0.5 T.
    const cv::Mat camera(240, 320, CV_32FC3, cv::Scalar::all(0.5));
    const render::CameraPose pose = hmd_pose(4.0, -8.0, 8.0, 40.0);
    render::Compositor compositor = make();
    render::CompositeInput input;
    input.camera = camera;
    input.pose = pose;
    input.sky = S;
    input.sun = sun;
    input.shadow_ratios = textures.names;
    input.sun_shadow = &shadow_map;
    const cv::Mat out = compositor.composite(input);

    // Every ground pixel clear of the building and more than 0.3 m from a shadow's edge: dark
    // (T < 0.6) exactly where the geometry puts the shadow.
    const camera::Lens lens(hmd_camera());
    const RayCaster caster(baked.mesh);
    const geom::Plane& ground = baked.manifest.planes[0].plane;
    int shadowed = 0, lit = 0, agree = 0;
    for (int y = 0; y < out.rows; ++y) {
      for (int x = 0; x < out.cols; ++x) {
        const auto ray = lens.unproject(Eigen::Vector2d(x, y));
        if (!ray) continue;
        const Vector3d d = pose.R_site_from_camera * ray->normalized();
        if (d.z() >= -1e-6) continue;
        const double t = (ground.origin.z() - pose.t_site_from_camera.z()) / d.z();
        const Vector3d g = pose.t_site_from_camera + t * d;
        const Eigen::Vector2d st = plane_st(ground, g);
        if (st.minCoeff() < 0.02 || st.maxCoeff() > 0.98) continue;
        // Clear of the building in a 2-pixel neighbourhood.
        bool clear = true;
        for (int dy = -2; dy <= 2 && clear; ++dy) {
          for (int dx = -2; dx <= 2 && clear; ++dx) {
            const auto r = lens.unproject(Eigen::Vector2d(x + dx, y + dy));
            if (r && caster.intersect(pose.t_site_from_camera, pose.R_site_from_camera * r->normalized())) clear = false;
          }
        }
        if (!clear) continue;
        const double depth = shadow_depth(towards_sun, g.head<2>(), ground.origin.z());
        if (std::abs(depth) < 0.3) continue;
        const bool geometry_says_shadow = depth > 0;
        const bool image_says_shadow = out.at<cv::Vec3f>(y, x)[1] / 0.5f < 0.6f;
        (geometry_says_shadow ? shadowed : lit) += 1;
        agree += geometry_says_shadow == image_says_shadow ? 1 : 0;
      }
    }
    // On the building, away from its outline: the sun's shadows through the shadow map agree
    // with rays to the sun (the tower shades the annex's roof).
    ReferenceInputs reference_in = reference_inputs(ratios, S, sun);
    const ReferenceResult reference = reference_composite(reference_in, lens, caster, camera, pose);
    reference_in.sun_shadows = false;
    const ReferenceResult unshadowed = reference_composite(reference_in, lens, caster, camera, pose);
    cv::Mat interior;
    cv::erode(reference.what == 2, interior, cv::Mat::ones(5, 5, CV_8U));
    cv::Mat in_sun_shadow(interior.size(), CV_8U, cv::Scalar(0));
    for (int y = 0; y < out.rows; ++y) {
      for (int x = 0; x < out.cols; ++x) {
        if (interior.at<std::uint8_t>(y, x) != 0 &&
            reference.linear.at<cv::Vec3f>(y, x)[1] < 0.7f * unshadowed.linear.at<cv::Vec3f>(y, x)[1]) {
          in_sun_shadow.at<std::uint8_t>(y, x) = 255;
        }
      }
    }
    // Pixels at the shadow's edge (2 px) are left out on both sides: a pixel there is part lit.
    cv::Mat edge, shadow_core;
    cv::morphologyEx(in_sun_shadow, edge, cv::MORPH_GRADIENT, cv::Mat::ones(5, 5, CV_8U));
    cv::erode(in_sun_shadow, shadow_core, cv::Mat::ones(5, 5, CV_8U));
    interior.setTo(0, edge);
    const Difference building = compare(out, reference.linear, interior, 0.005, 0.02);
    const Difference shadowed_building = compare(out, reference.linear, shadow_core, 0.005, 0.02);
    std::printf("measured: sun azimuth %.0f°: building interior %lld px, mean |d| %.3g, off %.2f%%; of them in the "
                "sun's shadow %lld px, off %.2f%%\n",
                azimuth, static_cast<long long>(building.pixels), building.mean, 100 * building.fraction_off,
                static_cast<long long>(shadowed_building.pixels), 100 * shadowed_building.fraction_off);
    EXPECT_LT(building.fraction_off, 0.05);  // the checker's kinks, as in RecordedFramesMatchTheCpuReference
    EXPECT_LT(shadowed_building.fraction_off, 0.03);

    const double agreement = static_cast<double>(agree) / std::max(1, shadowed + lit);
    std::printf("measured: sun azimuth %.0f°: %d shadowed and %d lit ground pixels, %.2f%% agree with the geometry\n",
                azimuth, shadowed, lit, 100 * agreement);
    EXPECT_GT(shadowed, 300);
    EXPECT_GT(lit, 3000);
    EXPECT_GE(agreement, 0.995);
    if (azimuth == 250.0) {
      EXPECT_GT(shadowed_building.pixels, 100);  // the tower's shadow on the annex's roof
    }
    save_picture("box_shadow_azimuth_" + std::to_string(static_cast<int>(azimuth)), out);
    save_picture("box_shadow_reference_azimuth_" + std::to_string(static_cast<int>(azimuth)), reference.linear);
    cv::Mat difference;
    cv::absdiff(out, reference.linear, difference);
    save_picture("box_shadow_difference_x10_azimuth_" + std::to_string(static_cast<int>(azimuth)), difference * 10.0);
  }
}

TEST_F(CompositorTest, RealPixelsPassUntouchedWhereNothingVirtualIs) {
  // A random 8-bit frame, T = 1 on the ground: wherever the building is not drawn the display
  // shows exactly the camera's codes (sRGB decoded, composited in linear, encoded again).
  cv::Mat camera(240, 320, CV_8UC3);
  cv::randu(camera, cv::Scalar::all(0), cv::Scalar::all(256));
  const render::CameraPose pose = hmd_pose();
  render::Compositor compositor = make();
  render::CompositeInput input;
  input.camera = camera;
  input.pose = pose;
  const std::vector<Vector3d> S = uniform_sky(1.0);
  input.sky = S;
  const cv::Mat out = compositor.composite(input);
  ASSERT_EQ(out.type(), CV_8UC3);

  const camera::Lens lens(hmd_camera());
  const RayCaster caster(BakedSite::get().mesh);
  cv::Mat building(camera.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < camera.rows; ++y) {
    for (int x = 0; x < camera.cols; ++x) {
      const auto ray = lens.unproject(Eigen::Vector2d(x, y));
      if (ray && caster.intersect(pose.t_site_from_camera, pose.R_site_from_camera * ray->normalized())) {
        building.at<std::uint8_t>(y, x) = 255;
      }
    }
  }
  cv::dilate(building, building, cv::Mat::ones(5, 5, CV_8U));
  std::int64_t compared = 0, equal = 0;
  for (int y = 0; y < camera.rows; ++y) {
    for (int x = 0; x < camera.cols; ++x) {
      if (building.at<std::uint8_t>(y, x) != 0) continue;
      ++compared;
      equal += out.at<cv::Vec3b>(y, x) == camera.at<cv::Vec3b>(y, x) ? 1 : 0;
    }
  }
  std::printf("measured: %lld of %lld real pixels identical to the camera's\n", static_cast<long long>(equal),
              static_cast<long long>(compared));
  EXPECT_GT(compared, 40000);
  EXPECT_EQ(equal, compared);
  EXPECT_GT(cv::countNonZero(building), 3000);  // the building is in view
}

TEST_F(CompositorTest, ANewSkyReachesTheBuildingOnTheNextFrame) {
  // The per-vertex sky irradiance is summed on the CPU when the sky changes, not per frame: a
  // compositor that drew one sky and then another draws exactly what a fresh one draws for the
  // second (and again for the first), and a change of one layer alone is seen.
  cv::Mat camera(240, 320, CV_8UC3, cv::Scalar(90, 110, 130));
  render::CompositeInput input;
  input.camera = camera;
  input.pose = hmd_pose();
  std::vector<Vector3d> bright = uniform_sky(1.0);
  std::vector<Vector3d> dim = uniform_sky(0.25);
  dim.front() = Vector3d(2.0, 0.5, 0.0);  // one layer differs from the rest
  auto linear = [&](render::Compositor& compositor, const std::vector<Vector3d>& sky) {
    input.sky = sky;
    compositor.draw(input);
    return compositor.read_linear();
  };
  render::Compositor reused = make();
  const cv::Mat first = linear(reused, bright);
  const cv::Mat second = linear(reused, dim);
  const cv::Mat again = linear(reused, bright);
  render::Compositor fresh_dim = make();
  const cv::Mat expected_dim = linear(fresh_dim, dim);
  EXPECT_EQ(cv::norm(second, expected_dim, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(again, first, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(first, second, cv::NORM_INF), 0.01);  // the building changed with the sky
}

TEST_F(CompositorTest, LampsLightTheBuildingPerVertexThroughTheirVisibility) {
  // A lamp (a separated source after the sun) lights the building per vertex: on the flat faces
  // of this model, with its visibility 1 at every vertex, exactly as an unshadowed sun of the
  // same light does per pixel; with visibility v, v times that. No virtual plane covers the
  // building here (cover_distance 0), and the sky is black, so the lamp is all the light.
  const BakedSite& baked = BakedSite::get();
  render::CompositorOptions options;
  options.cover_distance = 0.0;
  render::Compositor compositor = make(options);
  const cv::Mat camera(240, 320, CV_32FC3, cv::Scalar::all(0.0));
  const std::vector<Vector3d> black = uniform_sky(0.0);
  const blend::SunLight lamp{Vector3d(-0.5, -0.7, 0.5), Vector3d(3.0, 2.0, 1.0)};
  const std::size_t vertices = baked.mesh.vertex_count();
  auto draw = [&](const std::optional<blend::SunLight>& sun, std::span<const blend::SunLight> lamps,
                  std::span<const std::vector<float>> visibility) {
    render::CompositeInput input;
    input.camera = camera;
    input.pose = hmd_pose(4.0, -8.0, 8.0, 40.0);
    input.sky = black;
    input.sun = sun;
    input.lamps = lamps;
    input.lamp_vertex_visibility = visibility;
    return compositor.composite(input);
  };
  const cv::Mat as_sun = draw(lamp, {}, {});
  const std::vector<std::vector<float>> seen{std::vector<float>(vertices, 1.0f)};
  const cv::Mat lit = draw(std::nullopt, std::span(&lamp, 1), seen);
  const std::vector<std::vector<float>> quarter{std::vector<float>(vertices, 0.25f)};
  const cv::Mat dimmed = draw(std::nullopt, std::span(&lamp, 1), quarter);
  const std::vector<std::vector<float>> hidden{std::vector<float>(vertices, 0.0f)};
  const cv::Mat dark = draw(std::nullopt, std::span(&lamp, 1), hidden);
  double peak = 0;
  cv::minMaxLoc(as_sun.reshape(1), nullptr, &peak);
  ASSERT_GT(peak, 0.05) << "the lamp lights the building in view";
  EXPECT_LE(cv::norm(lit, as_sun, cv::NORM_INF), 1e-5 * peak);
  EXPECT_LE(cv::norm(dimmed, 0.25 * as_sun, cv::NORM_INF), 1e-5 * peak);
  EXPECT_EQ(cv::norm(dark, cv::NORM_INF), 0.0);
  // A visibility of the wrong size is refused, naming the field.
  const std::vector<std::vector<float>> short_one{std::vector<float>(vertices - 1, 1.0f)};
  EXPECT_THROW(draw(std::nullopt, std::span(&lamp, 1), short_one), InputError);
}

TEST_F(CompositorTest, TheGroundLightsTheBuildingThroughTheBakesGroundLayer) {
  // With a ground albedo ρ the building gets ρ Σ_l S^g_l t^g_{v,l} (blend::GroundLayers): the same
  // composite as a bake whose transfer vectors were ρ t^g, lit by S^g. A lamp that no vertex sees
  // adds nothing directly but lights the ground, through S^g. No virtual plane covers the building
  // (cover_distance 0).
  const BakedSite& baked = BakedSite::get();
  ASSERT_TRUE(baked.manifest.ground.has_value());
  std::vector<std::size_t> shape;
  const std::vector<float> ground = bake_format::read_npy(baked.dir / "bake" / baked.manifest.ground->file, &shape);
  constexpr float kAlbedo = 0.3f;
  std::vector<float> reflected(ground.size());
  for (std::size_t k = 0; k < ground.size(); ++k) reflected[k] = kAlbedo * ground[k];
  render::CompositorOptions with_ground;
  with_ground.cover_distance = 0.0;
  with_ground.ground_albedo = Vector3d::Constant(kAlbedo);
  with_ground.ground_transfer = ground;
  render::Compositor lit_by_ground(baked.site, baked.mesh, baked.manifest, std::vector<float>(baked.transfer.size(), 0.0f),
                                   hmd_camera(), with_ground);
  render::CompositorOptions plain;
  plain.cover_distance = 0.0;
  render::Compositor as_transfer(baked.site, baked.mesh, baked.manifest, reflected, hmd_camera(), plain);

  const blend::GroundLayers layers(baked.manifest.plan.frequency, baked.manifest.plan.basis,
                                   baked.manifest.ground->horizontal_unoccluded);
  const std::vector<Vector3d> S = uniform_sky(0.2);
  const blend::SunLight lamp{Vector3d(0.4, -0.6, 0.7).normalized(), Vector3d(3.0, 2.0, 1.0)};
  const std::vector<std::vector<float>> unseen{std::vector<float>(baked.mesh.vertex_count(), 0.0f)};
  const cv::Mat camera(240, 320, CV_32FC3, cv::Scalar::all(0.0));
  const auto draw = [&](render::Compositor& compositor, std::span<const Vector3d> sky, std::span<const blend::SunLight> lamps) {
    render::CompositeInput input;
    input.camera = camera;
    input.pose = hmd_pose(4.0, -8.0, 8.0, 40.0);
    input.sky = sky;
    input.lamps = lamps;
    if (!lamps.empty()) input.lamp_vertex_visibility = unseen;
    return compositor.composite(input);
  };
  const cv::Mat sky_only = draw(lit_by_ground, S, {});
  double peak = 0;
  cv::minMaxLoc(sky_only.reshape(1), nullptr, &peak);
  ASSERT_GT(peak, 0.005) << "the ground lights the building's sides in view";
  EXPECT_LE(cv::norm(sky_only, draw(as_transfer, S, {}), cv::NORM_INF), 1e-5 * peak);
  const std::vector<Vector3d> with_lamp = layers.coefficients(S, std::span(&lamp, 1));
  const cv::Mat lamp_lit = draw(lit_by_ground, S, std::span(&lamp, 1));
  EXPECT_GT(cv::norm(lamp_lit, sky_only, cv::NORM_INF), 0.1 * peak) << "the lamp lights the ground";
  EXPECT_LE(cv::norm(lamp_lit, draw(as_transfer, with_lamp, {}), cv::NORM_INF), 1e-5 * cv::norm(lamp_lit, cv::NORM_INF));
  // Where a virtual plane covers the building (the default cover distance: its wall and roof),
  // T_j D_j holds the sky and the ground's light is added from the vertices as elsewhere: the
  // ground adds the same light with or without the planes.
  render::CompositorOptions covered_plain;
  render::CompositorOptions covered_ground = covered_plain;
  covered_ground.ground_albedo = with_ground.ground_albedo;
  covered_ground.ground_transfer = ground;
  render::Compositor covered_off(baked.site, baked.mesh, baked.manifest, baked.transfer, hmd_camera(), covered_plain);
  render::Compositor covered_on(baked.site, baked.mesh, baked.manifest, baked.transfer, hmd_camera(), covered_ground);
  const cv::Mat added = draw(covered_on, S, {}) - draw(covered_off, S, {});
  EXPECT_LE(cv::norm(added, sky_only, cv::NORM_INF), 1e-4 * peak + 1e-6);
  // Bad settings are refused at construction.
  render::CompositorOptions bad = with_ground;
  bad.ground_albedo = Vector3d(0.2, 1.5, 0.2);
  EXPECT_THROW(render::Compositor(baked.site, baked.mesh, baked.manifest, baked.transfer, hmd_camera(), bad), InputError);
  bad = with_ground;
  bad.ground_transfer.pop_back();
  EXPECT_THROW(render::Compositor(baked.site, baked.mesh, baked.manifest, baked.transfer, hmd_camera(), bad), InputError);
}

TEST_F(CompositorTest, OpacityBlendsTheCompositeTowardsTheCameraImage) {
  // The building and its shadow on the ground (a low sun in the west-south-west), over a random
  // real world: opacity 0 must give the camera image exactly, 0.5 the midpoint of the camera
  // image and the full composite, and the CPU reference with the same opacity must agree.
  const BakedSite& baked = BakedSite::get();
  const Vector3d towards_sun = from_angles(250.0, 35.0);
  const std::vector<Vector3d> S = uniform_sky(0.05);
  const blend::SunLight sun{towards_sun, Vector3d::Ones()};
  const std::vector<PlaneRatios> ratios = baked.shadow_ratios(S, sun);
  const RatioTextures textures = upload(ratios);
  render::SunShadowMap shadow_map(baked.mesh, baked.site.planes);
  shadow_map.update(towards_sun, 0.0047);
  cv::Mat camera(240, 320, CV_32FC3);
  cv::randu(camera, cv::Scalar::all(0.05), cv::Scalar::all(0.9));
  const render::CameraPose pose = hmd_pose(4.0, -8.0, 8.0, 40.0);

  render::Compositor compositor = make();
  render::CompositeInput input;
  input.camera = camera;
  input.pose = pose;
  input.sky = S;
  input.sun = sun;
  input.shadow_ratios = textures.names;
  input.sun_shadow = &shadow_map;
  const auto composite_at = [&](double opacity) {
    input.opacity = opacity;
    return compositor.composite(input);
  };
  const cv::Mat full = composite_at(1.0);
  const cv::Mat half = composite_at(0.5);
  const cv::Mat none = composite_at(0.0);

  // Opacity 0: the camera's values, bit for bit (the building and the ground's shadow gone).
  cv::Mat changed;
  cv::compare(none, camera, changed, cv::CMP_NE);
  EXPECT_EQ(cv::countNonZero(changed.reshape(1)), 0);
  // The full composite does differ from the camera (the building and its shadow are in view).
  cv::compare(full, camera, changed, cv::CMP_NE);
  EXPECT_GT(cv::countNonZero(changed.reshape(1)), 3 * 3000);

  // Opacity 0.5: the midpoint, within float rounding (|d| ≤ 1e-6 + 1e-6 of the value).
  const cv::Mat midpoint = 0.5 * (camera + full);
  const Difference to_midpoint = compare(half, midpoint, cv::Mat(), 1e-6, 1e-6);
  std::printf("measured: opacity 0.5 against the midpoint of camera and composite: %lld px, max |d| %.3g, off %lld px\n",
              static_cast<long long>(to_midpoint.pixels), to_midpoint.max,
              static_cast<long long>(to_midpoint.fraction_off * static_cast<double>(to_midpoint.pixels)));
  EXPECT_EQ(to_midpoint.fraction_off, 0.0);
  EXPECT_LT(to_midpoint.max, 2e-6);

  // The CPU reference at opacity 0.5: the bounds of the full-opacity comparisons (RecordedFrames…).
  const camera::Lens lens(hmd_camera());
  const RayCaster caster(baked.mesh);
  ReferenceInputs reference_in = reference_inputs(ratios, S, sun);
  reference_in.opacity = 0.5;
  const ReferenceResult reference = reference_composite(reference_in, lens, caster, camera, pose);
  const double scale = cv::mean(reference.linear)[1];
  const Difference all = compare(half, reference.linear, cv::Mat(), 0.01 * scale, 0.02);
  std::printf("measured: opacity 0.5, GPU vs CPU reference: %lld px, mean |d| %.3g, off %.2f%%\n",
              static_cast<long long>(all.pixels), all.mean, 100 * all.fraction_off);
  EXPECT_LT(all.mean, 0.005 * scale);
  EXPECT_LT(all.fraction_off, 0.02);
  reference_in.opacity = 0.0;
  const ReferenceResult reference_none = reference_composite(reference_in, lens, caster, camera, pose);
  EXPECT_EQ(compare(none, reference_none.linear, cv::Mat(), 0.0, 0.0).max, 0.0);

  // Out of range: clamped; NaN shows nothing rather than a building that may be misplaced.
  EXPECT_EQ(compare(composite_at(1.5), full, cv::Mat(), 0.0, 0.0).max, 0.0);
  EXPECT_EQ(compare(composite_at(std::numeric_limits<double>::quiet_NaN()), camera, cv::Mat(), 0.0, 0.0).max, 0.0);

  // An 8-bit frame at opacity 0: the display shows exactly the camera's codes, every pixel.
  cv::Mat codes(240, 320, CV_8UC3);
  cv::randu(codes, cv::Scalar::all(0), cv::Scalar::all(256));
  input.camera = codes;
  const cv::Mat shown = composite_at(0.0);
  ASSERT_EQ(shown.type(), CV_8UC3);
  cv::compare(shown, codes, changed, cv::CMP_NE);
  EXPECT_EQ(cv::countNonZero(changed.reshape(1)), 0);
}

TEST_F(CompositorTest, VirtualPlaneShadesExactlyWithItsRatioInsteadOfTheTransfer) {
  const BakedSite& baked = BakedSite::get();
  const std::vector<Vector3d> S = uniform_sky(1.0);
  const cv::Mat camera(240, 320, CV_32FC3, cv::Scalar::all(0.2));
  // The wall plane (bake plane 2) with T = 1, then T = 0.5 everywhere: where it covers the
  // tower's south face the radiance halves exactly; with planes never covering (cover distance
  // 0) the wall's T does not matter.
  auto constant = [&](float value) {
    const blend::BasisImages& wall = baked.basis[2];
    return render::upload_shadow_ratio(std::vector<float>(wall.texel_count() * 3, value), wall.width, wall.height);
  };
  const gpu::Texture full = constant(1.0f);
  const gpu::Texture half = constant(0.5f);
  auto run = [&](GLuint wall_ratio, double cover_distance) {
    render::CompositorOptions options;
    options.cover_distance = cover_distance;
    render::Compositor compositor = make(options);
    render::CompositeInput input;
    input.camera = camera;
    input.pose = hmd_pose();
    input.sky = S;
    const std::array<GLuint, 3> names{0, 0, wall_ratio};
    input.shadow_ratios = names;
    return compositor.composite(input);
  };
  const cv::Mat lit = run(full.get(), 0.05);
  const cv::Mat shaded = run(half.get(), 0.05);
  const cv::Mat uncovered_full = run(full.get(), 0.0);
  const cv::Mat uncovered_half = run(half.get(), 0.0);

  // Pixels well inside the tower's south face (x in [−0.8, 0.8], z in [0.2, 3.8]).
  const camera::Lens lens(hmd_camera());
  const render::CameraPose pose = hmd_pose();
  int pixels = 0;
  double worst_ratio = 0, worst_uncovered = 0, transfer_vs_plane = 0;
  for (int y = 0; y < camera.rows; ++y) {
    for (int x = 0; x < camera.cols; ++x) {
      const auto ray = lens.unproject(Eigen::Vector2d(x, y));
      if (!ray) continue;
      const Vector3d d = pose.R_site_from_camera * ray->normalized();
      const double t = (-1.0 - pose.t_site_from_camera.y()) / d.y();
      const Vector3d p = pose.t_site_from_camera + t * d;
      if (std::abs(p.x()) > 0.8 || p.z() < 0.2 || p.z() > 3.8) continue;
      ++pixels;
      for (int c = 0; c < 3; ++c) {
        const double l = lit.at<cv::Vec3f>(y, x)[c];
        worst_ratio = std::max(worst_ratio, std::abs(shaded.at<cv::Vec3f>(y, x)[c] / l - 0.5));
        worst_uncovered = std::max(worst_uncovered, std::abs(static_cast<double>(uncovered_half.at<cv::Vec3f>(y, x)[c]) -
                                                             uncovered_full.at<cv::Vec3f>(y, x)[c]));
        // T = 1 on an unshadowed face: plane shading (D_j) and transfer shading agree within the
        // bake's sampling.
        transfer_vs_plane = std::max(transfer_vs_plane, std::abs(uncovered_full.at<cv::Vec3f>(y, x)[c] / l - 1.0));
      }
    }
  }
  std::printf("measured: %d south-face pixels: |ratio − 0.5| ≤ %.2g; uncovered change %.2g; transfer vs plane %.3f\n",
              pixels, worst_ratio, worst_uncovered, transfer_vs_plane);
  EXPECT_GT(pixels, 1000);
  EXPECT_LT(worst_ratio, 1e-5);
  EXPECT_EQ(worst_uncovered, 0.0);
  EXPECT_LT(transfer_vs_plane, 0.1);
}

TEST_F(CompositorTest, EachVirtualPlaneReadsItsOwnTexelsUpToItsEdges) {
  // The virtual planes' T share one texture array whose layers take the largest plane's size
  // (render/plane_ratio_array.hpp): the roof (16 × 16) lies in a 16 × 32 layer beside the wall's
  // (16 × 32). With the roof's T 0.5, each roof pixel is half what it is with T 1, up to the roof's
  // north edge, where a lookup that strayed past its last row would read the layer's padding (1);
  // the wall's T given as one texel (0.25) covers the whole wall. The camera image is black, so
  // that pixels on the building's silhouette keep the building's ratio.
  const BakedSite& baked = BakedSite::get();
  ASSERT_EQ(baked.manifest.planes[1].plane.name, "roof");
  ASSERT_EQ(baked.manifest.planes[2].plane.name, "wall");
  const blend::BasisImages& roof = baked.basis[1];
  const gpu::Texture roof_half = render::upload_shadow_ratio(std::vector<float>(roof.texel_count() * 3, 0.5f), roof.width, roof.height);
  const gpu::Texture wall_quarter = render::upload_shadow_ratio(std::vector<float>(3, 0.25f), 1, 1);
  const cv::Mat black(240, 320, CV_32FC3, cv::Scalar::all(0.0));
  render::Compositor compositor = make();
  const std::vector<Vector3d> sky = uniform_sky(1.0);  // input.sky is a view: the values must outlive it
  auto run = [&](const render::CameraPose& pose, std::array<GLuint, 3> names) {
    render::CompositeInput input;
    input.camera = black;
    input.pose = pose;
    input.sky = sky;
    input.shadow_ratios = names;
    return compositor.composite(input).clone();
  };
  const camera::Lens lens(hmd_camera());
  // Ratios of the pixels whose ray meets `inside` first (a point on the plane through `origin`
  // with normal `normal`), against the composite with every T 1.
  auto ratios = [&](const render::CameraPose& pose, const cv::Mat& shaded, const cv::Mat& lit, const Vector3d& origin,
                    const Vector3d& normal, auto inside, double expected, int* edge_pixels) {
    double worst = 0;
    int pixels = 0;
    for (int y = 0; y < lit.rows; ++y) {
      for (int x = 0; x < lit.cols; ++x) {
        const auto ray = lens.unproject(Eigen::Vector2d(x, y));
        if (!ray) continue;
        const Vector3d d = pose.R_site_from_camera * ray->normalized();
        const double t = (origin - pose.t_site_from_camera).dot(normal) / d.dot(normal);
        if (!(t > 0)) continue;
        const Vector3d p = pose.t_site_from_camera + t * d;
        if (!inside(p)) continue;
        ++pixels;
        if (edge_pixels != nullptr && p.y() > 0.95) ++*edge_pixels;
        for (int c = 0; c < 3; ++c) {
          worst = std::max(worst, std::abs(shaded.at<cv::Vec3f>(y, x)[c] / lit.at<cv::Vec3f>(y, x)[c] - expected));
        }
      }
    }
    EXPECT_GT(pixels, 500);
    return worst;
  };

  // The roof from above and south of the tower.
  const render::CameraPose above = hmd_pose(-0.3, -3.0, 9.0, 55.0);
  const cv::Mat roof_lit = run(above, {0, 0, 0});
  const cv::Mat roof_shaded = run(above, {0, roof_half.get(), 0});
  int edge_pixels = 0;
  const double roof_worst = ratios(above, roof_shaded, roof_lit, Vector3d(0, 0, 4), Vector3d::UnitZ(),
                                   [](const Vector3d& p) { return p.x() > -0.97 && p.x() < 0.9 && p.y() > -0.9 && p.y() < 0.995; },
                                   0.5, &edge_pixels);
  // The south face from the default pose.
  const cv::Mat wall_lit = run(hmd_pose(), {0, 0, 0});
  const cv::Mat wall_shaded = run(hmd_pose(), {0, 0, wall_quarter.get()});
  const double wall_worst = ratios(hmd_pose(), wall_shaded, wall_lit, Vector3d(0, -1, 0), Vector3d::UnitY(),
                                   [](const Vector3d& p) { return std::abs(p.x()) < 0.8 && p.z() > 0.2 && p.z() < 3.8; }, 0.25,
                                   nullptr);
  std::printf("measured: roof |ratio − 0.5| ≤ %.2g (%d pixels within 5 cm of its north edge); wall |ratio − 0.25| ≤ %.2g\n",
              roof_worst, edge_pixels, wall_worst);
  EXPECT_GT(edge_pixels, 20);
  EXPECT_LT(roof_worst, 1e-5);
  EXPECT_LT(wall_worst, 1e-5);
}

TEST_F(CompositorTest, ALightMapShowsItsTexelsBilinearlyOnItsCharts) {
  // A light map over the model's flat faces (0.25 m texels), its texels' light a pattern across
  // the annex's south face, f = 1 + 0.3 sin(2.5 x) + 0.2 z at each texel's point, against one of 1
  // everywhere: the ratio of the two composites is f as the CPU reads the atlas
  // (bake_format::sample_light_map), pixel by pixel, and not what the face's corners would give.
  const BakedSite& baked = BakedSite::get();
  const baker::LightMapPoints lm = baker::lay_out_light_map(baked.mesh, {0.25, 1.0, 0});
  const std::size_t layers = baked.manifest.layer_count();
  const auto pattern = [](const Eigen::Vector3f& p) { return 1.0 + 0.3 * std::sin(2.5 * p.x()) + 0.2 * p.z(); };
  std::vector<float> patterned(lm.layout.texels.size() * layers, 0.0f), flat(patterned.size(), 0.0f);
  for (std::size_t k = 0; k < lm.layout.texels.size(); ++k) {
    patterned[k * layers] = static_cast<float>(pattern(lm.positions[k]));
    flat[k * layers] = 1.0f;
  }
  const cv::Mat black(240, 320, CV_32FC3, cv::Scalar::all(0.0));
  const std::vector<Vector3d> uniform = uniform_sky(1.0);
  auto run = [&](const std::vector<float>& transfer, std::optional<bake_format::LightMapPca> pca = std::nullopt) {
    render::CompositorOptions options;
    options.light_map = {lm.layout, pca ? std::vector<float>() : transfer, {}, std::move(pca)};
    render::Compositor compositor = make(options);
    render::CompositeInput input;
    input.camera = black;
    input.pose = hmd_pose();
    input.sky = uniform;
    return compositor.composite(input).clone();
  };
  const cv::Mat shown = run(patterned), lit = run(flat);
  std::vector<Vector3d> sky(layers, Vector3d::Zero());
  sky[0] = Vector3d::Ones();
  const std::vector<Vector3d> atlas = bake_format::light_map_atlas(lm.layout, patterned, sky);
  // The annex's south face (y = −1, 1 < x < 4, 0 < z < 1.5), away from its edges.
  const camera::Lens lens(hmd_camera());
  const render::CameraPose pose = hmd_pose();
  int chart = -1;
  for (std::size_t t = 0; t < baked.mesh.triangle_count(); ++t) {
    const Eigen::Vector3f& a = baked.mesh.positions[baked.mesh.indices[3 * t]];
    if (baked.mesh.normals[baked.mesh.indices[3 * t]].y() < -0.99f && a.x() >= 1.0f) chart = lm.layout.triangle_chart[t];
  }
  ASSERT_GE(chart, 0);
  double worst = 0.0, spread = 0.0, squared = 0.0;
  int pixels = 0;
  for (int y = 0; y < lit.rows; ++y) {
    for (int x = 0; x < lit.cols; ++x) {
      const auto ray = lens.unproject(Eigen::Vector2d(x, y));
      if (!ray) continue;
      const Vector3d d = pose.R_site_from_camera * ray->normalized();
      const double t = (-1.0 - pose.t_site_from_camera.y()) / d.y();
      if (!(t > 0)) continue;
      const Vector3d p = pose.t_site_from_camera + t * d;
      if (p.x() < 1.2 || p.x() > 3.8 || p.z() < 0.2 || p.z() > 1.3) continue;
      const double expected = bake_format::sample_light_map(atlas, lm.layout.width, lm.layout.height, lm.layout.atlas_coordinates(chart, p)).x();
      const double ratio = shown.at<cv::Vec3f>(y, x)[1] / lit.at<cv::Vec3f>(y, x)[1];
      const double e = std::abs(ratio - expected);
      if (!(e <= worst)) worst = e;  // a NaN (nothing drawn) too
      squared += e * e;
      spread = std::max(spread, std::abs(expected - pattern(p.cast<float>())));
      ++pixels;
    }
  }
  const double rms = std::sqrt(squared / std::max(pixels, 1));
  std::printf("measured: %d pixels of the annex's south face within %.2g (RMS %.2g) of the CPU's bilinear light map, which is "
              "within %.2g of the pattern itself\n", pixels, worst, rms, spread);
  EXPECT_GT(pixels, 300);
  // The lens's resampling of the pinhole render blurs the map's kinks at texel centres a little; a
  // lookup half a texel off would be 0.09 off.
  EXPECT_LT(worst, 0.01);
  EXPECT_LT(rms, 1e-3);
  // Its PCA form: the pattern varies in one layer, so one component per chart holds it, and the
  // compositor's sum over the charts' components shows what the full form shows.
  const bake_format::LightMapPca pca{bake_format::compress_light_map(lm.layout, patterned, layers, {1, 0.0}), {}};
  EXPECT_LT(pca.sky.max_error, 1e-5);
  const cv::Mat compressed = run(patterned, pca);
  double pca_worst = 0.0;
  for (int y = 0; y < shown.rows; ++y) {
    for (int x = 0; x < shown.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        const float a = shown.at<cv::Vec3f>(y, x)[c], b = compressed.at<cv::Vec3f>(y, x)[c];
        const double e = std::abs(a - b) / std::max(1e-3f, std::abs(a));
        if (!(e <= pca_worst)) pca_worst = e;
      }
    }
  }
  std::printf("measured: the PCA form (K = 1) within %.2g (relative) of the full form, every pixel\n", pca_worst);
  EXPECT_LT(pca_worst, 1e-4);
  // The light map's sizes must fit the model and the bake.
  render::CompositorOptions wrong;
  wrong.light_map = {lm.layout, std::vector<float>(3), {}, std::nullopt};
  EXPECT_THROW(make(wrong), InputError);
  wrong.light_map = {lm.layout, {}, {}, bake_format::LightMapPca{bake_format::compress_light_map(lm.layout, patterned, layers, {1, 0.0}), {}}};
  wrong.light_map.pca->sky.weights.pop_back();
  EXPECT_THROW(make(wrong), InputError);
}

TEST_F(CompositorTest, NoNanFromNanOrBlackInputs) {
  const BakedSite& baked = BakedSite::get();
  const render::CameraPose pose = hmd_pose();
  // Float camera with NaN, ±Inf and negative pixels; a sky with NaN, Inf and negative faces; a
  // NaN sun; a shadow-ratio texture full of NaN; a NaN photometric scale.
  cv::Mat camera(240, 320, CV_32FC3, cv::Scalar::all(0.3));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  camera(cv::Rect(0, 0, 100, 240)).setTo(cv::Scalar(nan, nan, nan));
  camera(cv::Rect(100, 0, 50, 240)).setTo(cv::Scalar(inf, -inf, -1.0));
  std::vector<Vector3d> S = uniform_sky(1.0);
  S[0] = Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  S[1] = Vector3d(std::numeric_limits<double>::infinity(), -1.0, 0.5);
  const blend::BasisImages& ground = baked.basis[0];
  const gpu::Texture nan_ratio =
      render::upload_shadow_ratio(std::vector<float>(ground.texel_count() * 3, nan), ground.width, ground.height);
  const std::array<GLuint, 3> names{nan_ratio.get(), nan_ratio.get(), 0};

  render::Compositor compositor = make();
  render::CompositeInput input;
  input.camera = camera;
  input.pose = pose;
  input.sky = S;
  input.sun = blend::SunLight{from_angles(200, 40), Vector3d(std::nan(""), 1.0, 1.0)};
  input.shadow_ratios = names;
  input.photometric = render::PhotometricMatch{Vector3d(1.0, std::nan(""), 1.0)};
  const cv::Mat out = compositor.composite(input);
  EXPECT_TRUE(finite_image(out));
  EXPECT_TRUE(finite_image(compositor.read_linear()));
  EXPECT_EQ(compositor.last_stats().camera_values_replaced, 100 * 240 * 3 + 50 * 240 * 3);
  EXPECT_EQ(compositor.last_stats().sky_values_replaced, 3 + 2 + 1);
  EXPECT_TRUE(compositor.last_stats().sun_without_shadow_map);
  double low = 0, high = 0;
  cv::minMaxLoc(out.reshape(1), &low, &high);
  EXPECT_GE(low, 0.0);

  // A black sky and a black 8-bit frame: black everywhere, not NaN (0/0 nowhere).
  const std::vector<Vector3d> black = uniform_sky(0.0);
  std::vector<PlaneRatios> ratios = baked.shadow_ratios(black, std::nullopt);
  const RatioTextures textures = upload(ratios);
  render::CompositeInput dark;
  dark.camera = cv::Mat(240, 320, CV_8UC3, cv::Scalar::all(0));
  dark.pose = pose;
  dark.sky = black;
  dark.shadow_ratios = textures.names;
  const cv::Mat night = compositor.composite(dark);
  EXPECT_EQ(cv::countNonZero(night.reshape(1)), 0);
  EXPECT_TRUE(finite_image(compositor.read_linear()));
}

TEST_F(CompositorTest, RegionMaskAndPhotometricEstimateRecoverTheScale) {
  // A synthetic real ground of albedo 0.3 filmed with k = (2, 1.5, 1): the estimate from a
  // region of it recovers k, and the composite's building then has that scale too.
  const BakedSite& baked = BakedSite::get();
  const std::vector<Vector3d> S = uniform_sky(0.8);
  const render::CameraPose pose = hmd_pose();
  render::Compositor compositor = make();
  const cv::Mat region = compositor.region_mask(0, 0.3, 0.5, 0.1, 0.25, pose);
  ASSERT_GT(cv::countNonZero(region), 500);
  // Every pixel of the mask sees the rectangle.
  const camera::Lens lens(hmd_camera());
  const geom::Plane& ground = baked.manifest.planes[0].plane;
  for (int y = 0; y < region.rows; ++y) {
    for (int x = 0; x < region.cols; ++x) {
      if (region.at<std::uint8_t>(y, x) == 0) continue;
      const Vector3d d = pose.R_site_from_camera * lens.unproject(Eigen::Vector2d(x, y))->normalized();
      const Vector3d g = pose.t_site_from_camera + (ground.origin.z() - pose.t_site_from_camera.z()) / d.z() * d;
      const Eigen::Vector2d st = plane_st(ground, g);
      ASSERT_GE(st.x(), 0.3 - 1e-9);
      ASSERT_LE(st.x(), 0.5 + 1e-9);
      ASSERT_GE(st.y(), 0.1 - 1e-9);
      ASSERT_LE(st.y(), 0.25 + 1e-9);
    }
  }
  const Vector3d k(2.0, 1.5, 1.0);
  const Vector3d D = render::plane_irradiance(baked.manifest.planes[0], S, std::nullopt);
  const Vector3d value = k.cwiseProduct(0.3 / std::numbers::pi * D);
  cv::Mat camera(240, 320, CV_32FC3, cv::Scalar(value.z(), value.y(), value.x()));
  const render::PhotometricEstimate estimate = render::estimate_photometric_match(camera, region, D, Vector3d::Constant(0.3));
  ASSERT_TRUE(estimate.ok) << estimate.problem;
  EXPECT_LT((estimate.match.scale - k).cwiseAbs().maxCoeff(), 1e-5);
}

TEST_F(CompositorTest, MismatchedInputsAreInputErrors) {
  const BakedSite& baked = BakedSite::get();
  render::Compositor compositor = make();
  const std::vector<Vector3d> S = uniform_sky(1.0);
  render::CompositeInput input;
  input.camera = cv::Mat(200, 320, CV_8UC3, cv::Scalar::all(0));
  input.sky = S;
  EXPECT_THROW(compositor.composite(input), InputError);
  input.camera = cv::Mat(240, 320, CV_8UC4, cv::Scalar::all(0));
  EXPECT_THROW(compositor.composite(input), InputError);
  input.camera = cv::Mat(240, 320, CV_8UC3, cv::Scalar::all(0));
  const std::vector<Vector3d> short_sky(S.begin(), S.end() - 1);
  input.sky = short_sky;
  try {
    compositor.composite(input);
    ADD_FAILURE() << "no error for a sky of the wrong size";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("39 values"), std::string::npos) << e.what();
  }

  // A site without the bake's 'roof' plane, a model with other vertices.
  scene::Site other = baked.site;
  other.planes[1].name = "attic";
  try {
    render::Compositor bad(other, baked.mesh, baked.manifest, baked.transfer, hmd_camera());
    ADD_FAILURE() << "no error for a site without the bake's plane";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'roof'"), std::string::npos) << e.what();
  }
  render::CompositorOptions bad_options;
  bad_options.far = bad_options.near;
  EXPECT_THROW(make(bad_options), InputError);

  scene::Mesh fewer = baked.mesh;
  fewer.positions.pop_back();
  fewer.normals.pop_back();
  fewer.texcoords.pop_back();
  EXPECT_THROW(render::Compositor(baked.site, fewer, baked.manifest, baked.transfer, hmd_camera()), InputError);
}

}  // namespace
}  // namespace skylit::compose_test
