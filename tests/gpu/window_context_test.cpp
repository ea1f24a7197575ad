// The window context: an OpenGL ES 3.1 context through EGL in a GLFW window, on a virtual X
// display (Xvfb, started by the test) so that it runs on machines without a screen. A texture is
// shown upright and scaled to fit with its aspect ratio kept; no display is a clear error. A monitor is chosen by name; an
// unknown name is an error that lists the monitors present.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "skylit/base/error.hpp"
#include "skylit/gpu/gl.hpp"
#include "skylit/gpu/window_context.hpp"
#include "../support/virtual_display.hpp"

namespace skylit::gpu {
namespace {

using test::ScopedEnv;
using test::VirtualDisplay;

// A width × height RGBA8 texture: the top half (texel rows 0 .. height/2 − 1) red, the rest blue.
Texture red_over_blue(int width, int height) {
  std::vector<std::uint8_t> texels(static_cast<std::size_t>(width) * height * 4);
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      std::uint8_t* t = &texels[4 * (static_cast<std::size_t>(row) * width + col)];
      const bool top = row < height / 2;
      t[0] = top ? 255 : 0;
      t[1] = 0;
      t[2] = top ? 0 : 255;
      t[3] = 255;
    }
  }
  Texture texture = make_texture();
  glBindTexture(GL_TEXTURE_2D, texture.get());
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, width, height);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, texels.data());
  check_gl_error("red_over_blue");
  return texture;
}

TEST(WindowContext, ShowsATextureUprightScaledToFit) {
  const VirtualDisplay xvfb;
  if (xvfb.display().empty()) GTEST_SKIP() << "Xvfb is not installed (apt install xvfb)";
  const ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const ScopedEnv wayland("WAYLAND_DISPLAY", nullptr);

  WindowOptions options;
  options.width = 200;
  options.height = 96;
  options.vsync = false;
  WindowContext window(options);
  EXPECT_NE(window.description().find("OpenGL ES 3."), std::string::npos) << window.description();
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  EXPECT_TRUE(major > 3 || (major == 3 && minor >= 1)) << major << "." << minor;

  const int width = window.framebuffer_width(), height = window.framebuffer_height();
  ASSERT_EQ(width, 200);
  ASSERT_EQ(height, 96);
  const Texture texture = red_over_blue(64, 48);
  window.draw(texture.get(), 64, 48);
  // The back buffer, GL's row 0 at the bottom: a 128 × 96 image (scale 2) between black bars of
  // 36 pixels, red on top, blue below.
  std::vector<std::uint8_t> pixels(static_cast<std::size_t>(width) * height * 4);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, pixels.data());
  check_gl_error("read back");
  auto at = [&](int x, int y_from_top) {
    const std::uint8_t* p = &pixels[4 * (static_cast<std::size_t>(height - 1 - y_from_top) * width + x)];
    return std::array<int, 3>{p[0], p[1], p[2]};
  };
  EXPECT_EQ(at(100, 10), (std::array<int, 3>{255, 0, 0}));   // top: red
  EXPECT_EQ(at(100, 85), (std::array<int, 3>{0, 0, 255}));   // bottom: blue
  EXPECT_EQ(at(10, 48), (std::array<int, 3>{0, 0, 0}));      // left bar
  EXPECT_EQ(at(190, 48), (std::array<int, 3>{0, 0, 0}));     // right bar
  EXPECT_EQ(at(40, 10), (std::array<int, 3>{255, 0, 0}));    // just inside the image's left edge (x0 = 36)
  window.swap_buffers();
  EXPECT_FALSE(window.close_requested());
}

TEST(WindowContext, FullScreenOnAMonitorChosenByName) {
  const VirtualDisplay xvfb;
  if (xvfb.display().empty()) GTEST_SKIP() << "Xvfb is not installed (apt install xvfb)";
  const ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const ScopedEnv wayland("WAYLAND_DISPLAY", nullptr);
  const std::vector<std::string> names = monitor_names();
  ASSERT_FALSE(names.empty());
  std::printf("measured: Xvfb's monitors: '%s'%s\n", names.front().c_str(), names.size() > 1 ? " and more" : "");

  WindowOptions options;
  options.width = 200;
  options.height = 96;
  options.vsync = false;
  options.monitor = names.front();
  const WindowContext window(options);
  // Full screen at the monitor's mode: the screen Xvfb was started with.
  EXPECT_EQ(window.framebuffer_width(), 640);
  EXPECT_EQ(window.framebuffer_height(), 480);
}

TEST(WindowContext, AnUnknownMonitorIsAnErrorListingTheMonitorsPresent) {
  const VirtualDisplay xvfb;
  if (xvfb.display().empty()) GTEST_SKIP() << "Xvfb is not installed (apt install xvfb)";
  const ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const ScopedEnv wayland("WAYLAND_DISPLAY", nullptr);
  const std::vector<std::string> names = monitor_names();
  ASSERT_FALSE(names.empty());
  WindowOptions options;
  options.monitor = "No Such HMD";
  try {
    const WindowContext window(options);
    FAIL() << "a window opened on a monitor that does not exist";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("'No Such HMD'"), std::string::npos) << message;
    EXPECT_NE(message.find("monitors present: '" + names.front() + "'"), std::string::npos) << message;
    EXPECT_NE(message.find("display.monitor"), std::string::npos) << message;
    EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
  }
  // GLFW was left terminated: a window opens after the error.
  options.monitor.clear();
  options.width = 64;
  options.height = 48;
  options.vsync = false;
  const WindowContext window(options);
  EXPECT_EQ(window.framebuffer_width(), 64);
}

TEST(WindowContext, NoDisplayIsAClearError) {
  const ScopedEnv display("DISPLAY", nullptr);
  const ScopedEnv wayland("WAYLAND_DISPLAY", nullptr);
  try {
    const WindowContext window;
    FAIL() << "a window opened without a display";
  } catch (const ContextError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("$DISPLAY"), std::string::npos) << message;
    EXPECT_NE(message.find("--headless"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace skylit::gpu
