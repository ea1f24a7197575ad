// The window context: an OpenGL ES 3.1 context through EGL in a GLFW window, on a virtual X
// display (Xvfb, started by the test) so that it runs on machines without a screen. A texture is
// shown upright and scaled to fit with its aspect ratio kept; no display is a clear error.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "skylit/gpu/gl.hpp"
#include "skylit/gpu/window_context.hpp"

namespace skylit::gpu {
namespace {

// An environment variable set (or unset) for a scope, restored after.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) {
      ::setenv(name, value, 1);
    } else {
      ::unsetenv(name);
    }
  }
  ~ScopedEnv() {
    if (old_) {
      ::setenv(name_.c_str(), old_->c_str(), 1);
    } else {
      ::unsetenv(name_.c_str());
    }
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_;
  std::optional<std::string> old_;
};

// Xvfb on a free display number (it writes the number to a pipe: -displayfd); stopped on
// destruction. display() is empty when Xvfb is not installed or does not start.
class VirtualDisplay {
 public:
  VirtualDisplay() {
    int fds[2];
    if (::pipe(fds) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      ::close(fds[0]);
      const int null = ::open("/dev/null", O_WRONLY);
      if (null >= 0) {
        ::dup2(null, 1);
        ::dup2(null, 2);
      }
      const std::string fd = std::to_string(fds[1]);
      ::execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", "640x480x24", "-nolisten", "tcp",
               static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(fds[1]);
    std::string number;
    char c = 0;
    while (::read(fds[0], &c, 1) == 1 && c != '\n') number += c;
    ::close(fds[0]);
    if (!number.empty()) display_ = ":" + number;
  }
  ~VirtualDisplay() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  VirtualDisplay(const VirtualDisplay&) = delete;
  VirtualDisplay& operator=(const VirtualDisplay&) = delete;
  const std::string& display() const { return display_; }

 private:
  pid_t pid_ = -1;
  std::string display_;
};

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
