// The HMD display in a window (on Xvfb, started by the test): a stereo panel shows the left eye's
// image on the left half and the right eye's on the right, read back from the window.
#include <array>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "../support/virtual_display.hpp"
#include "skylit/gpu/window_context.hpp"
#include "skylit/render/hmd_distortion.hpp"
#include "skylit/render/hmd_profile.hpp"

namespace skylit::render {
namespace {

TEST(HmdWindow, StereoShowsTwoEyeImagesSideBySide) {
  const gpu::test::VirtualDisplay xvfb;
  if (xvfb.display().empty()) GTEST_SKIP() << "Xvfb is not installed (apt install xvfb)";
  const gpu::test::ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const gpu::test::ScopedEnv wayland("WAYLAND_DISPLAY", nullptr);

  HmdProfile hmd;
  hmd.panel_width = 400;
  hmd.panel_height = 160;
  hmd.layout = PanelLayout::side_by_side;
  hmd.lens_center = {Eigen::Vector2d(100, 80), Eigen::Vector2d(100, 80)};
  hmd.lens_radius = 100;
  hmd.distortion = {RadialDistortion{0.2, 0.2, 0}, RadialDistortion{0.22, 0.24, 0}, RadialDistortion{0.24, 0.28, 0}};

  gpu::WindowOptions options;
  options.width = hmd.panel_width;
  options.height = hmd.panel_height;
  options.vsync = false;
  gpu::WindowContext window(options);
  ASSERT_EQ(window.framebuffer_width(), 400);
  ASSERT_EQ(window.framebuffer_height(), 160);

  // The left eye sees green, the right eye white (every channel lit, so each lens shows it).
  const cv::Mat green(120, 160, CV_8UC3, cv::Scalar(0, 255, 0)), white(120, 160, CV_8UC3, cv::Scalar::all(255));
  const gpu::Texture left = upload_eye_image(green), right = upload_eye_image(white);
  HmdDistortion pass(hmd);
  const std::vector<GLuint> eyes = {left.get(), right.get()};
  pass.draw(eyes, 160, 120);
  window.draw(pass.panel_texture(), hmd.panel_width, hmd.panel_height);

  std::vector<std::uint8_t> pixels(400 * 160 * 4);
  glReadPixels(0, 0, 400, 160, GL_RGBA, GL_UNSIGNED_BYTE, pixels.data());
  auto at = [&](int x, int y_from_top) {
    const std::uint8_t* p = &pixels[4 * (static_cast<std::size_t>(159 - y_from_top) * 400 + x)];
    return std::array<int, 3>{p[0], p[1], p[2]};
  };
  EXPECT_EQ(at(100, 80), (std::array<int, 3>{0, 255, 0}));       // left lens centre: the left image
  EXPECT_EQ(at(300, 80), (std::array<int, 3>{255, 255, 255}));   // right lens centre: the right image
  EXPECT_EQ(at(2, 2), (std::array<int, 3>{0, 0, 0}));            // the barrel leaves the corners black
  EXPECT_EQ(at(202, 157), (std::array<int, 3>{0, 0, 0}));
  // Near the edge of the white image, the channels part: blue reaches less far out than red.
  int coloured_fringe = 0;
  for (int x = 200; x < 400; ++x) {
    const auto c = at(x, 80);
    if (c[0] != c[2]) ++coloured_fringe;
  }
  EXPECT_GT(coloured_fringe, 0);
  window.swap_buffers();
}

}  // namespace
}  // namespace skylit::render
