// The HMD's stereo frame: one camera, the building and its shadows drawn per eye from the head's
// pose shifted by ±IPD/2 along the camera's x axis, each eye's composite on its half of the panel;
// mono shows one composite to both eyes.
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "compose_fixture.hpp"
#include "../support/gl_suite.hpp"
#include "skylit/render/hmd_distortion.hpp"

namespace skylit::compose_test {
namespace {

// Side by side, one eye exactly the HMD camera's 320 × 240, no lens: each half is its eye's
// composite texel for texel.
render::HmdProfile plain_stereo_hmd() {
  render::HmdProfile hmd;
  hmd.panel_width = 640;
  hmd.panel_height = 240;
  hmd.layout = render::PanelLayout::side_by_side;
  hmd.lens_center = {Eigen::Vector2d(160, 120), Eigen::Vector2d(160, 120)};
  hmd.lens_radius = 160;
  hmd.ipd = 0.3;  // wide, so that the eyes' views of the tower differ clearly at 9 m
  return hmd;
}

TEST(EyePose, EyesSitHalfTheIpdEitherSideAlongTheCameraX) {
  const render::CameraPose head = hmd_pose();
  const render::CameraPose left = render::eye_pose(head, 0.064, 0), right = render::eye_pose(head, 0.064, 1);
  EXPECT_NEAR((right.t_site_from_camera - left.t_site_from_camera).norm(), 0.064, 1e-12);
  EXPECT_NEAR((0.5 * (left.t_site_from_camera + right.t_site_from_camera) - head.t_site_from_camera).norm(), 0, 1e-12);
  // The camera's x (right) is site east here: the right eye is east of the left.
  EXPECT_GT(right.t_site_from_camera.x(), left.t_site_from_camera.x());
  EXPECT_TRUE(right.R_site_from_camera.isApprox(head.R_site_from_camera));
}

class StereoFrame : public skylit::test::GlSuite {};

TEST_F(StereoFrame, EachHalfIsItsEyesCompositeAndTheEyesDiffer) {
  const BakedSite& baked = BakedSite::get();
  render::Compositor compositor(baked.site, baked.mesh, baked.manifest, baked.transfer, hmd_camera());
  const render::HmdProfile hmd = plain_stereo_hmd();
  render::HmdDistortion distortion(hmd);

  cv::Mat camera(240, 320, CV_8UC3, cv::Scalar(90, 120, 150));
  const std::vector<Vector3d> sky(baked.manifest.faces.size(), Vector3d(0.4, 0.5, 0.7));
  render::CompositeInput input;
  input.camera = camera;
  input.pose = hmd_pose();
  input.sky = sky;

  render::draw_hmd_frame(compositor, distortion, input, render::StereoMode::stereo);
  const cv::Mat panel = distortion.read_panel();
  std::array<cv::Mat, 2> expected;
  for (int eye = 0; eye < 2; ++eye) {
    render::CompositeInput eye_input = input;
    eye_input.pose = render::eye_pose(input.pose, hmd.ipd, eye);
    expected[static_cast<std::size_t>(eye)] = compositor.composite(eye_input);
    cv::Mat diff;
    cv::absdiff(panel(cv::Rect(eye * 320, 0, 320, 240)), expected[static_cast<std::size_t>(eye)], diff);
    double worst = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
    EXPECT_LE(worst, 1.0) << "eye " << eye;
  }
  // The tower stands at a different place in each eye: many pixels differ.
  cv::Mat eyes_differ;
  cv::absdiff(expected[0], expected[1], eyes_differ);
  const int differing = cv::countNonZero(eyes_differ.reshape(1) > 8);
  EXPECT_GT(differing, 500);

  // Mono: one composite from the head's pose, on both halves.
  render::draw_hmd_frame(compositor, distortion, input, render::StereoMode::mono);
  const cv::Mat mono_panel = distortion.read_panel();
  const cv::Mat centre = compositor.composite(input);
  for (int eye = 0; eye < 2; ++eye) {
    cv::Mat diff;
    cv::absdiff(mono_panel(cv::Rect(eye * 320, 0, 320, 240)), centre, diff);
    double worst = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
    EXPECT_LE(worst, 1.0) << "mono, eye " << eye;
  }
}

}  // namespace
}  // namespace skylit::compose_test
