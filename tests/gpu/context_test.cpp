// The headless EGL context: it can be made here (Mesa llvmpipe or a GPU driver), says what it is,
// and releases cleanly.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>

#include "skylit/gpu/egl_context.hpp"
#include "skylit/gpu/gl.hpp"

namespace skylit::gpu {
namespace {

TEST(HeadlessContext, CreatesAnEs31ContextAndDescribesIt) {
  const HeadlessContext context;
  EXPECT_FALSE(context.renderer().empty());
  EXPECT_FALSE(context.vendor().empty());
  EXPECT_NE(context.version().find("OpenGL ES 3."), std::string::npos) << context.version();
  EXPECT_FALSE(context.platform().empty());
  const std::string description = context.description();
  EXPECT_NE(description.find(context.renderer()), std::string::npos) << description;
  EXPECT_NE(description.find(context.platform()), std::string::npos) << description;

  GLint major = 0;
  GLint minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  EXPECT_TRUE(major > 3 || (major == 3 && minor >= 1)) << major << "." << minor;
  check_gl_error("version query");
}

TEST(HeadlessContext, ReportsExtensions) {
  const HeadlessContext context;
  // Every ES 3.1 driver the project targets (Mesa, NVIDIA) offers float render targets; the
  // raster engine relies on it.
  EXPECT_TRUE(context.has_extension("GL_EXT_color_buffer_float"));
  EXPECT_FALSE(context.has_extension("GL_SKYLIT_no_such_extension"));
  EXPECT_FALSE(context.has_extension(""));
}

TEST(HeadlessContext, WorksWithSurfacelessPlatformEnvironment) {
  const char* previous = std::getenv("EGL_PLATFORM");
  const std::string saved = previous != nullptr ? previous : "";
  ::setenv("EGL_PLATFORM", "surfaceless", 1);
  try {
    const HeadlessContext context;
    EXPECT_FALSE(context.renderer().empty());
  } catch (...) {
    previous != nullptr ? ::setenv("EGL_PLATFORM", saved.c_str(), 1) : ::unsetenv("EGL_PLATFORM");
    throw;
  }
  previous != nullptr ? ::setenv("EGL_PLATFORM", saved.c_str(), 1) : ::unsetenv("EGL_PLATFORM");
}

TEST(HeadlessContext, TwoContextsCoexistAndOutliveEachOther) {
  auto first = std::make_unique<HeadlessContext>();
  {
    const HeadlessContext second;
    second.make_current();
    Texture texture = make_texture();
    glBindTexture(GL_TEXTURE_2D, texture.get());
    check_gl_error("second context");
  }
  // Destroying the second context must not have terminated the display under the first.
  first->make_current();
  Texture texture = make_texture();
  glBindTexture(GL_TEXTURE_2D, texture.get());
  EXPECT_EQ(glIsTexture(texture.get()), GL_TRUE);
  check_gl_error("first context after the second is gone");
}

// A context made in another's share group sees its textures (name and contents), on the same
// display, and outlives it; a thread with no context current has no share group to give.
TEST(HeadlessContext, ASharedContextSeesTheOtherContextsObjects) {
  auto first = std::make_unique<HeadlessContext>();
  GLuint name = 0;  // deleted in the shared context, after the first is gone
  glGenTextures(1, &name);
  glBindTexture(GL_TEXTURE_2D, name);
  const std::array<std::uint8_t, 4> texel{10, 20, 30, 40};
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, 1, 1);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, texel.data());
  glFinish();  // complete before the other context uses it
  const HeadlessContext::ShareGroup share = HeadlessContext::current_share_group();
  {
    const HeadlessContext shared(share);  // current now
    EXPECT_FALSE(shared.renderer().empty());
    EXPECT_EQ(glIsTexture(name), GL_TRUE);
    Framebuffer framebuffer = make_framebuffer();
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.get());
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, name, 0);
    std::array<std::uint8_t, 4> read{};
    glReadPixels(0, 0, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, read.data());
    EXPECT_EQ(read, texel);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    check_gl_error("shared context");
    first.reset();  // the shared context keeps the share group (and the display) alive
    EXPECT_EQ(glIsTexture(name), GL_TRUE);
    glDeleteTextures(1, &name);
    check_gl_error("shared context after the first is gone");
  }
  std::string error;
  std::thread([&error] {
    try {
      HeadlessContext::current_share_group();
    } catch (const ContextError& e) {
      error = e.what();
    }
  }).join();
  EXPECT_NE(error.find("no EGL context is current"), std::string::npos) << error;
}

TEST(HeadlessContext, MovesOwnership) {
  HeadlessContext first;
  const std::string renderer = first.renderer();
  HeadlessContext second(std::move(first));
  second.make_current();
  EXPECT_EQ(second.renderer(), renderer);
  check_gl_error("moved context");
}

TEST(HeadlessContext, ManyContextsInTurnLeakNothingVisible) {
  // Create and destroy repeatedly: a leak of displays or contexts shows up as a failure to
  // create one long before 20 rounds on most drivers' fd limits; mostly this guards the
  // teardown order.
  for (int round = 0; round < 20; ++round) {
    const HeadlessContext context;
    ASSERT_FALSE(context.renderer().empty()) << "round " << round;
  }
}

}  // namespace
}  // namespace skylit::gpu
