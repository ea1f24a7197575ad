// A stereo camera on the HMD (a camera per eye): both cameras' poses from the stereo calibration;
// each eye's composite identical to a single-camera composite from that eye's camera; and the
// tower's shadow on the real ground at the ground's own disparity, where one shared camera image
// puts it off by f·IPD/Z. Measured figures are printed ("measured:" lines).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "compose_fixture.hpp"
#include "../support/gl_suite.hpp"
#include "skylit/render/hmd_distortion.hpp"
#include "skylit/render/stereo_camera.hpp"
#include "skylit/render/sun_shadow_map.hpp"

namespace skylit::compose_test {
namespace stereo_cameras_test {

// The right camera 64 mm to the left camera's right, toed in a little and slightly off level,
// as a real stereo calibration comes out.
camera::StereoCalibration toed_in_pair() {
  camera::StereoCalibration stereo;
  stereo.left = hmd_camera();
  stereo.right = hmd_camera();
  stereo.right.cx = 158.4;
  stereo.right.cy = 121.0;
  stereo.right.fx = stereo.right.fy = 204.0;
  stereo.right.D = {-0.25, 0.07, -0.0006, 0.0004, -0.008};
  stereo.R_right_from_left = Eigen::AngleAxisd(-0.02, Vector3d::UnitY()).toRotationMatrix() *
                             Eigen::AngleAxisd(0.004, Vector3d::UnitZ()).toRotationMatrix();
  stereo.t_right_from_left = Vector3d(-0.064, 0.0008, 0.0015);
  return stereo;
}

// A pinhole camera without distortion, as a rectified pair has (both eyes alike).
camera::CameraCalibration rectified_camera() {
  camera::CameraCalibration c;
  c.file = "rectified.yaml";
  c.image_width = 640;
  c.image_height = 480;
  c.model = camera::LensModel::Pinhole;
  c.fx = c.fy = 500.0;
  c.cx = 319.5;
  c.cy = 239.5;
  c.D = {0, 0, 0, 0, 0};
  return c;
}

// Side by side, each eye's viewport exactly one camera image, with or without a lens.
render::HmdProfile side_by_side_hmd(int eye_width, int eye_height, double ipd, bool lens) {
  render::HmdProfile hmd;
  hmd.panel_width = 2 * eye_width;
  hmd.panel_height = eye_height;
  hmd.layout = render::PanelLayout::side_by_side;
  hmd.lens_center = {Eigen::Vector2d(0.5 * eye_width, 0.5 * eye_height), Eigen::Vector2d(0.5 * eye_width, 0.5 * eye_height)};
  hmd.lens_radius = 0.5 * eye_width;
  hmd.ipd = ipd;
  if (lens) {
    hmd.lens_center = {Eigen::Vector2d(0.5 * eye_width + 4, 0.5 * eye_height - 2),
                       Eigen::Vector2d(0.5 * eye_width - 4, 0.5 * eye_height - 2)};
    hmd.distortion = {render::RadialDistortion{0.20, 0.20, 0.0}, render::RadialDistortion{0.22, 0.24, 0.0},
                      render::RadialDistortion{0.24, 0.28, 0.0}};
  }
  return hmd;
}

double max_abs_difference(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  double worst = 0;
  cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
  return worst;
}

// The camera's site point of pixel (x, y) on the horizontal plane at height z (a pinhole without
// distortion), and its depth along the camera axis; nullopt where the ray does not go down.
struct GroundHit {
  Vector3d point;
  double depth = 0;
};
std::optional<GroundHit> ground_hit(const camera::CameraCalibration& c, const render::CameraPose& pose, double x, double y,
                                    double z) {
  const Vector3d ray((x - c.cx) / c.fx, (y - c.cy) / c.fy, 1.0);
  const Vector3d d = pose.R_site_from_camera * ray;
  if (d.z() > -1e-9) return std::nullopt;
  const double depth = (z - pose.t_site_from_camera.z()) / d.z();
  return GroundHit{pose.t_site_from_camera + depth * d, depth};
}

Eigen::Vector2d project(const camera::CameraCalibration& c, const render::CameraPose& pose, const Vector3d& site_point) {
  const Vector3d p = pose.R_site_from_camera.transpose() * (site_point - pose.t_site_from_camera);
  return {c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy};
}

// The real world as this camera sees it (linear, CV_32FC3): a ground checker of 0.5 m cells
// (albedo 0.25 and 0.6, edges at x = 0.25 + k/2 and y = k/2) on the plane at height z, a grey
// sky above; 4 × 4 samples per pixel, so that edges fall between pixels where they lie.
constexpr double kDarkCell = 0.25, kLightCell = 0.6, kSky = 0.7;
cv::Mat real_ground_image(const camera::CameraCalibration& c, const render::CameraPose& pose, double z) {
  cv::Mat image(c.image_height, c.image_width, CV_32FC3);
  constexpr int kSamples = 4;
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      double sum = 0;
      for (int j = 0; j < kSamples; ++j) {
        for (int i = 0; i < kSamples; ++i) {
          const double sx = x - 0.5 + (i + 0.5) / kSamples, sy = y - 0.5 + (j + 0.5) / kSamples;
          const std::optional<GroundHit> hit = ground_hit(c, pose, sx, sy, z);
          if (!hit || hit->depth > 60.0) {
            sum += kSky;
            continue;
          }
          const auto cell_x = static_cast<long>(std::floor((hit->point.x() - 0.25) / 0.5));
          const auto cell_y = static_cast<long>(std::floor(hit->point.y() / 0.5));
          sum += (cell_x + cell_y) % 2 == 0 ? kLightCell : kDarkCell;
        }
      }
      const auto v = static_cast<float>(sum / (kSamples * kSamples));
      image.at<cv::Vec3f>(y, x) = cv::Vec3f(0.9f * v, v, 1.05f * v);
    }
  }
  return image;
}

// Where, near `predicted`, a row profile crosses `level` (linear between pixels): the crossing
// nearest to the prediction within ±half_window pixels, or nullopt.
std::optional<double> crossing_near(const std::vector<double>& profile, double predicted, int half_window, double level) {
  const int centre = static_cast<int>(std::lround(predicted));
  std::optional<double> best;
  for (int x = std::max(0, centre - half_window); x < std::min<int>(static_cast<int>(profile.size()) - 1, centre + half_window); ++x) {
    const double a = profile[static_cast<std::size_t>(x)] - level, b = profile[static_cast<std::size_t>(x + 1)] - level;
    if ((a < 0) == (b < 0) || a == b) continue;
    const double at = x + a / (a - b);
    if (!best || std::abs(at - predicted) < std::abs(*best - predicted)) best = at;
  }
  return best;
}

// The edge of a step in a profile near `predicted`: where it crosses halfway between its least
// and greatest values within ±half_window pixels.
std::optional<double> edge_near(const std::vector<double>& profile, double predicted, int half_window) {
  const int centre = static_cast<int>(std::lround(predicted));
  double low = 1e30, high = -1e30;
  for (int x = std::max(0, centre - half_window); x <= std::min<int>(static_cast<int>(profile.size()) - 1, centre + half_window); ++x) {
    low = std::min(low, profile[static_cast<std::size_t>(x)]);
    high = std::max(high, profile[static_cast<std::size_t>(x)]);
  }
  if (!(high > low)) return std::nullopt;
  return crossing_near(profile, predicted, half_window, 0.5 * (low + high));
}

// T along row `row` of one eye's half of the panel (8-bit sRGB): the composite over the camera
// image that eye was given (linear), green channel.
std::vector<double> shadow_ratio_row(const cv::Mat& panel_half, const cv::Mat& camera, int row) {
  std::vector<double> out(static_cast<std::size_t>(camera.cols));
  for (int x = 0; x < camera.cols; ++x) {
    const double shown = srgb_decode(panel_half.at<cv::Vec3b>(row, x)[1] / 255.0);
    out[static_cast<std::size_t>(x)] = shown / static_cast<double>(camera.at<cv::Vec3f>(row, x)[1]);
  }
  return out;
}

std::vector<double> green_row(const cv::Mat& camera, int row) {
  std::vector<double> out(static_cast<std::size_t>(camera.cols));
  for (int x = 0; x < camera.cols; ++x) out[static_cast<std::size_t>(x)] = camera.at<cv::Vec3f>(row, x)[1];
  return out;
}

// The shared inputs of one frame: sky, sun, the shadow ratios of the bake and the sun's map.
struct SharedLight {
  std::vector<Vector3d> sky;
  blend::SunLight sun;
  std::vector<gpu::Texture> ratio_textures;
  std::vector<GLuint> ratio_names;
  render::SunShadowMap shadow_map;

  explicit SharedLight(const Vector3d& towards_sun)
      : sky(BakedSite::get().manifest.faces.size(), Vector3d::Constant(0.05)),
        sun{towards_sun, Vector3d::Ones()},
        shadow_map(BakedSite::get().mesh, BakedSite::get().site.planes) {
    for (const PlaneRatios& r : BakedSite::get().shadow_ratios(sky, sun)) {
      ratio_textures.push_back(render::upload_shadow_ratio(r.rgb, r.width, r.height));
      ratio_names.push_back(ratio_textures.back().get());
    }
    shadow_map.update(towards_sun, 0.0047);
  }

  render::CompositeInput input(const cv::Mat& camera, const render::CameraPose& pose) const {
    render::CompositeInput in;
    in.camera = camera;
    in.pose = pose;
    in.sky = sky;
    in.sun = sun;
    in.shadow_ratios = ratio_names;
    in.sun_shadow = &shadow_map;
    return in;
  }
};

render::Compositor make_compositor(const camera::CameraCalibration& calibration) {
  const BakedSite& baked = BakedSite::get();
  return render::Compositor(baked.site, baked.mesh, baked.manifest, baked.transfer, calibration);
}

class StereoCameraFrame : public skylit::test::GlSuite {};

TEST(StereoCameraPoses, TheRightCameraSitsWhereTheCalibrationPutsIt) {
  const camera::StereoCalibration stereo = toed_in_pair();
  const render::CameraPose left = hmd_pose();
  const std::array<render::CameraPose, 2> poses = render::stereo_camera_poses(left, stereo);
  EXPECT_TRUE(poses[0].R_site_from_camera == left.R_site_from_camera);
  EXPECT_EQ(poses[0].t_site_from_camera, left.t_site_from_camera);
  // Any site point: its right-camera coordinates are R_right_from_left x_left + t_right_from_left.
  for (const Vector3d& site_point : {Vector3d(0, 0, 2), Vector3d(3, -4, 0.01), Vector3d(-20, 40, 7)}) {
    const Vector3d x_left = left.R_site_from_camera.transpose() * (site_point - left.t_site_from_camera);
    const Vector3d x_right = poses[1].R_site_from_camera.transpose() * (site_point - poses[1].t_site_from_camera);
    EXPECT_LT((x_right - (stereo.R_right_from_left * x_left + stereo.t_right_from_left)).norm(), 1e-12);
  }
  EXPECT_NEAR((poses[1].t_site_from_camera - left.t_site_from_camera).norm(), stereo.baseline_m(), 1e-12);
  // From the right camera's pose back to the left's.
  const std::array<render::CameraPose, 2> from_right = render::stereo_camera_poses(poses[1], stereo, 1);
  EXPECT_LT((from_right[0].R_site_from_camera - left.R_site_from_camera).norm(), 1e-12);
  EXPECT_LT((from_right[0].t_site_from_camera - left.t_site_from_camera).norm(), 1e-12);
  EXPECT_LT((from_right[1].t_site_from_camera - poses[1].t_site_from_camera).norm(), 1e-15);
  // A rectified pair (t = (−B, 0, 0)): the right camera B along the left camera's x (right).
  camera::StereoCalibration rectified = stereo;
  rectified.R_right_from_left.setIdentity();
  rectified.t_right_from_left = Vector3d(-0.064, 0, 0);
  const std::array<render::CameraPose, 2> pair = render::stereo_camera_poses(left, rectified);
  const Vector3d expected_right = left.t_site_from_camera + 0.064 * left.R_site_from_camera.col(0);
  EXPECT_LT((pair[1].t_site_from_camera - expected_right).norm(), 1e-12);
  EXPECT_TRUE(pair[1].R_site_from_camera == left.R_site_from_camera);
  EXPECT_THROW(render::stereo_camera_poses(left, stereo, 2), std::invalid_argument);
}

// Identical: each compositor owns its targets and sets the GL state it draws with, so drawing
// the other eye in between changes nothing, and the same GL program on the same inputs gives the
// same bits.
TEST_F(StereoCameraFrame, EachEyeIsTheSingleCameraCompositeOfItsOwnCamera) {
  const camera::StereoCalibration stereo = toed_in_pair();
  const SharedLight light(from_angles(200, 35));
  // One side-by-side frame of the stereo camera (as ZED-class cameras deliver it): each eye's
  // image is an ROI of it. Noise, so that any pixel moved or mixed shows.
  cv::Mat side_by_side(240, 640, CV_8UC3);
  cv::randu(side_by_side, cv::Scalar::all(20), cv::Scalar::all(235));
  const std::array<cv::Mat, 2> images{side_by_side(cv::Rect(0, 0, 320, 240)), side_by_side(cv::Rect(320, 0, 320, 240))};
  const std::array<render::CameraPose, 2> poses = render::stereo_camera_poses(hmd_pose(), stereo);
  const std::array<render::CompositeInput, 2> inputs{light.input(images[0], poses[0]), light.input(images[1], poses[1])};

  render::Compositor left = make_compositor(stereo.left);
  render::Compositor right = make_compositor(stereo.right);
  const std::array<render::Compositor*, 2> eyes{&left, &right};
  for (const bool lens : {false, true}) {
    SCOPED_TRACE(lens ? "HMD lens" : "no HMD lens");
    render::HmdDistortion hmd(side_by_side_hmd(320, 240, 0.064, lens));
    render::draw_hmd_frame(eyes, hmd, inputs);
    const cv::Mat panel = hmd.read_panel();
    const std::array<cv::Mat, 2> drawn{left.read_linear(), right.read_linear()};

    // The ordinary way: one Compositor per camera, each alone, each frame its own.
    for (int eye = 0; eye < 2; ++eye) {
      SCOPED_TRACE(eye);
      const auto e = static_cast<std::size_t>(eye);
      render::Compositor single = make_compositor(eye == 0 ? stereo.left : stereo.right);
      render::CompositeInput alone = inputs[e];
      alone.camera = images[e].clone();
      const cv::Mat composite = single.composite(alone);
      const double linear_difference = max_abs_difference(drawn[e], single.read_linear());
      EXPECT_EQ(linear_difference, 0.0);
      render::HmdDistortion single_hmd(side_by_side_hmd(320, 240, 0.064, lens));
      single_hmd.begin_frame();
      single_hmd.draw_eye(eye, single.display_texture(), 320, 240);
      const cv::Rect half(eye * 320, 0, 320, 240);
      const double panel_difference = max_abs_difference(panel(half), single_hmd.read_panel()(half));
      EXPECT_EQ(panel_difference, 0.0);
      std::printf("measured: stereo camera, %s, eye %d: linear composite max |diff| %g, panel max |diff| %g codes\n",
                  lens ? "HMD lens" : "no lens", eye, linear_difference, panel_difference);
      if (!lens) {
        // Without a lens the eye's viewport shows its composite texel for texel (the mesh's
        // interpolated texture coordinates may round a code).
        const double shown_difference = max_abs_difference(panel(half), composite);
        EXPECT_LE(shown_difference, 1.0);
        std::printf("measured: stereo camera, eye %d: panel half against the 8-bit composite max |diff| %g codes\n", eye,
                    shown_difference);
      }
    }
    // The two eyes see different images from different places.
    cv::Mat eyes_differ;
    cv::absdiff(drawn[0], drawn[1], eyes_differ);
    EXPECT_GT(cv::countNonZero(eyes_differ.reshape(1) > 0.05f), 10000);
  }
  // A single-layout display (a monitor) shows the left camera's composite.
  render::HmdProfile monitor = side_by_side_hmd(320, 240, 0.064, false);
  monitor.layout = render::PanelLayout::single;
  monitor.panel_width = 320;
  render::HmdDistortion single(monitor);
  render::draw_hmd_frame(eyes, single, inputs);
  render::Compositor alone = make_compositor(stereo.left);
  render::CompositeInput left_input = inputs[0];
  left_input.camera = images[0].clone();
  EXPECT_LE(max_abs_difference(single.read_panel(), alone.composite(left_input)), 1.0);

  render::HmdDistortion hmd(side_by_side_hmd(320, 240, 0.064, false));
  EXPECT_THROW(render::draw_hmd_frame(eyes, hmd, std::span<const render::CompositeInput>(inputs.data(), 1)),
               std::invalid_argument);
  const std::array<render::Compositor*, 2> one_missing{&left, nullptr};
  EXPECT_THROW(render::draw_hmd_frame(one_missing, hmd, inputs), std::invalid_argument);
}

// A rectified pair looking down at the tower's shadow (sun in the north, 35° up, so the shadow
// falls south, towards the cameras, 2.5 to 6 m away). Along a row at the shadow's west edge
// (the tower's west face, site x = −1), each eye's composite is its camera image times T, so
// T = composite / camera finds the shadow's edge; the checker's edge at x = −1.25 on the same
// row (the same depth) gives the real ground's disparity.
TEST_F(StereoCameraFrame, TheShadowOnTheGroundHasTheGroundsDisparity) {
  const BakedSite& baked = BakedSite::get();
  const double ground_z = baked.manifest.planes[0].plane.origin.z();
  constexpr double kBaseline = 0.064;
  camera::StereoCalibration stereo;
  stereo.left = stereo.right = rectified_camera();
  stereo.t_right_from_left = Vector3d(-kBaseline, 0, 0);
  const camera::CameraCalibration& cam = stereo.left;
  const double f = cam.fx;

  const render::CameraPose left_pose = hmd_pose(0.0, -9.0, 1.7, 30.0);
  const std::array<render::CameraPose, 2> poses = render::stereo_camera_poses(left_pose, stereo);
  // Today's single camera sits between the two, each eye ±IPD/2 from it (the same eye poses).
  render::CameraPose head = left_pose;
  head.t_site_from_camera += 0.5 * kBaseline * left_pose.R_site_from_camera.col(0);
  const SharedLight light(from_angles(0, 35));

  const std::array<cv::Mat, 2> images{real_ground_image(cam, poses[0], ground_z), real_ground_image(cam, poses[1], ground_z)};
  const cv::Mat head_image = real_ground_image(cam, head, ground_z);

  const render::HmdProfile profile = side_by_side_hmd(cam.image_width, cam.image_height, kBaseline, false);
  render::HmdDistortion hmd(profile);
  render::Compositor left = make_compositor(stereo.left);
  render::Compositor right = make_compositor(stereo.right);
  const std::array<render::Compositor*, 2> eyes{&left, &right};
  const std::array<render::CompositeInput, 2> inputs{light.input(images[0], poses[0]), light.input(images[1], poses[1])};
  render::draw_hmd_frame(eyes, hmd, inputs);
  const cv::Mat stereo_panel = hmd.read_panel();
  render::draw_hmd_frame(left, hmd, light.input(head_image, head), render::StereoMode::stereo);
  const cv::Mat shared_panel = hmd.read_panel();
  const cv::Rect halves[2] = {cv::Rect(0, 0, cam.image_width, cam.image_height),
                              cv::Rect(cam.image_width, 0, cam.image_width, cam.image_height)};
  save_picture("stereo_cameras_panel", stereo_panel);
  save_picture("stereo_cameras_shared_panel", shared_panel);

  double worst_stereo = 0, worst_ground = 0, least_shared_error = 1e30, worst_shared_prediction = 0;
  int rows = 0;
  for (double y_ground = -6.25; y_ground <= -2.75; y_ground += 0.5) {  // checker cell centres
    SCOPED_TRACE(y_ground);
    const int row = static_cast<int>(std::lround(project(cam, poses[0], Vector3d(-1, y_ground, ground_z)).y()));
    // The edges as each eye's geometry predicts them (search windows only).
    auto predicted = [&](const render::CameraPose& pose, double x_site) {
      const std::optional<GroundHit> on_row = ground_hit(cam, pose, cam.cx, row, ground_z);
      return project(cam, pose, Vector3d(x_site, on_row->point.y(), ground_z)).x();
    };

    std::array<double, 2> shadow_edge{}, ground_edge{}, shared_shadow_edge{};
    for (int eye = 0; eye < 2; ++eye) {
      const auto e = static_cast<std::size_t>(eye);
      const render::CameraPose& pose = poses[e];
      const std::optional<double> shadow =
          edge_near(shadow_ratio_row(stereo_panel(halves[e]), images[e], row), predicted(pose, -1.0), 30);
      const std::optional<double> ground =
          crossing_near(green_row(images[e], row), predicted(pose, -1.25), 10, 0.5 * (kDarkCell + kLightCell));
      const std::optional<double> shared =
          edge_near(shadow_ratio_row(shared_panel(halves[e]), head_image, row), predicted(pose, -1.0), 30);
      ASSERT_TRUE(shadow && ground && shared) << "eye " << eye << ", row " << row;
      shadow_edge[e] = *shadow;
      ground_edge[e] = *ground;
      shared_shadow_edge[e] = *shared;
    }
    // The ground's depth where the left eye sees the shadow's edge: f B / Z is its disparity.
    const std::optional<GroundHit> at_edge = ground_hit(cam, poses[0], shadow_edge[0], row, ground_z);
    ASSERT_TRUE(at_edge.has_value());
    EXPECT_NEAR(at_edge->point.x(), -1.0, 0.02);  // where the tower's west face puts it
    const double expected = f * kBaseline / at_edge->depth;
    const double shadow_disparity = shadow_edge[0] - shadow_edge[1];
    const double ground_disparity = ground_edge[0] - ground_edge[1];
    // One camera image for both eyes: the real ground has no disparity, the drawn shadow has its own.
    const double shared_disparity = shared_shadow_edge[0] - shared_shadow_edge[1];
    std::printf("measured: row %d, ground at Z = %.2f m (shadow edge at site x = %.3f): f·B/Z = %.2f px; stereo cameras: "
                "shadow %.2f px, real ground %.2f px; one shared camera: shadow %.2f px, real ground 0 px\n",
                row, at_edge->depth, at_edge->point.x(), expected, shadow_disparity, ground_disparity, shared_disparity);
    EXPECT_NEAR(shadow_disparity, expected, 1.0);
    EXPECT_NEAR(ground_disparity, expected, 1.0);
    EXPECT_NEAR(shadow_disparity, ground_disparity, 1.0);
    // The shared camera's shadow is off the real ground by the disparity the ground lacks.
    EXPECT_NEAR(shared_disparity, expected, 1.0);
    EXPECT_GT(shared_disparity, 3.0);
    worst_stereo = std::max(worst_stereo, std::abs(shadow_disparity - expected));
    worst_ground = std::max(worst_ground, std::abs(shadow_disparity - ground_disparity));
    least_shared_error = std::min(least_shared_error, shared_disparity);
    worst_shared_prediction = std::max(worst_shared_prediction, std::abs(shared_disparity - expected));
    ++rows;
  }
  EXPECT_GE(rows, 7);
  std::printf("measured: over %d rows, stereo cameras: shadow disparity − f·B/Z at most %.3f px, shadow − real ground "
              "at most %.3f px; one shared camera: the shadow %.2f px or more off the real ground (f·IPD/Z within %.3f px)\n",
              rows, worst_stereo, worst_ground, least_shared_error, worst_shared_prediction);
}

}  // namespace stereo_cameras_test
}  // namespace skylit::compose_test
