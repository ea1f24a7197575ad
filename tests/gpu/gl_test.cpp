// RAII GL names: each wrapper deletes its name, moves transfer ownership, and the error helpers
// name what went wrong.
#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "skylit/gpu/egl_context.hpp"
#include "skylit/gpu/gl.hpp"

namespace skylit::gpu {
namespace {

class GlNames : public ::testing::Test {
 protected:
  HeadlessContext context_;
};

TEST_F(GlNames, TextureIsDeletedWithItsOwner) {
  GLuint name = 0;
  {
    Texture texture = make_texture();
    name = texture.get();
    ASSERT_NE(name, 0u);
    glBindTexture(GL_TEXTURE_2D, name);  // a name becomes an object when first bound
    EXPECT_EQ(glIsTexture(name), GL_TRUE);
    glBindTexture(GL_TEXTURE_2D, 0);
  }
  EXPECT_EQ(glIsTexture(name), GL_FALSE);
  check_gl_error("texture");
}

TEST_F(GlNames, EveryKindIsDeletedWithItsOwner) {
  GLuint buffer_name = 0;
  GLuint framebuffer_name = 0;
  GLuint renderbuffer_name = 0;
  GLuint vertex_array_name = 0;
  GLuint program_name = 0;
  {
    Buffer buffer = make_buffer();
    Framebuffer framebuffer = make_framebuffer();
    Renderbuffer renderbuffer = make_renderbuffer();
    VertexArray vertex_array = make_vertex_array();
    Program program = make_program();
    buffer_name = buffer.get();
    framebuffer_name = framebuffer.get();
    renderbuffer_name = renderbuffer.get();
    vertex_array_name = vertex_array.get();
    program_name = program.get();
    glBindBuffer(GL_ARRAY_BUFFER, buffer_name);
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_name);
    glBindRenderbuffer(GL_RENDERBUFFER, renderbuffer_name);
    glBindVertexArray(vertex_array_name);
    EXPECT_EQ(glIsBuffer(buffer_name), GL_TRUE);
    EXPECT_EQ(glIsFramebuffer(framebuffer_name), GL_TRUE);
    EXPECT_EQ(glIsRenderbuffer(renderbuffer_name), GL_TRUE);
    EXPECT_EQ(glIsVertexArray(vertex_array_name), GL_TRUE);
    EXPECT_EQ(glIsProgram(program_name), GL_TRUE);
    glBindVertexArray(0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
  }
  EXPECT_EQ(glIsBuffer(buffer_name), GL_FALSE);
  EXPECT_EQ(glIsFramebuffer(framebuffer_name), GL_FALSE);
  EXPECT_EQ(glIsRenderbuffer(renderbuffer_name), GL_FALSE);
  EXPECT_EQ(glIsVertexArray(vertex_array_name), GL_FALSE);
  EXPECT_EQ(glIsProgram(program_name), GL_FALSE);
  check_gl_error("names");
}

TEST_F(GlNames, MoveTransfersOwnershipExactlyOnce) {
  Texture first = make_texture();
  const GLuint name = first.get();
  glBindTexture(GL_TEXTURE_2D, name);
  glBindTexture(GL_TEXTURE_2D, 0);
  Texture second(std::move(first));
  EXPECT_EQ(first.get(), 0u);  // NOLINT(bugprone-use-after-move): checking the moved-from state
  EXPECT_FALSE(first);
  EXPECT_EQ(second.get(), name);
  Texture third = make_texture();
  const GLuint third_name = third.get();
  glBindTexture(GL_TEXTURE_2D, third_name);
  glBindTexture(GL_TEXTURE_2D, 0);
  third = std::move(second);  // deletes third's old name, takes the first one
  EXPECT_EQ(third.get(), name);
  EXPECT_EQ(glIsTexture(third_name), GL_FALSE);
  EXPECT_EQ(glIsTexture(name), GL_TRUE);
  third.reset();
  EXPECT_EQ(glIsTexture(name), GL_FALSE);
  check_gl_error("moves");
}

TEST_F(GlNames, CheckGlErrorNamesThePlaceAndTheCode) {
  glBindTexture(0x1234, 0);  // not a texture target
  try {
    check_gl_error("binding a bogus target");
    FAIL() << "expected GlError";
  } catch (const GlError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("binding a bogus target"), std::string::npos) << message;
    EXPECT_NE(message.find("GL_INVALID_ENUM"), std::string::npos) << message;
  }
  EXPECT_NO_THROW(check_gl_error("nothing pending"));
}

TEST_F(GlNames, IncompleteFramebufferIsReportedByName) {
  Framebuffer framebuffer = make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.get());
  try {
    check_framebuffer_complete(GL_FRAMEBUFFER, "empty framebuffer");
    FAIL() << "expected GlError";
  } catch (const GlError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT"), std::string::npos) << message;
    EXPECT_NE(message.find("empty framebuffer"), std::string::npos) << message;
  }
  Renderbuffer colour = make_renderbuffer();
  glBindRenderbuffer(GL_RENDERBUFFER, colour.get());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, 4, 4);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour.get());
  EXPECT_NO_THROW(check_framebuffer_complete(GL_FRAMEBUFFER, "complete framebuffer"));
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  EXPECT_EQ(framebuffer_status_name(GL_FRAMEBUFFER_UNSUPPORTED), "GL_FRAMEBUFFER_UNSUPPORTED");
  check_gl_error("framebuffer");
}

}  // namespace
}  // namespace skylit::gpu
