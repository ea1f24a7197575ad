#pragma once
// Move-only owners of OpenGL ES names: each deletes its name when destroyed. They must be
// destroyed while their context is current (the owner of the context sees to the order).
#include <GLES3/gl31.h>

#include <stdexcept>
#include <string>
#include <utility>

namespace skylit::gpu {

// A GL call failed (a bug or an exhausted driver, not bad input).
class GlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// "GL_INVALID_OPERATION", ... for glGetError codes.
std::string gl_error_name(GLenum code);
// Throws GlError naming `where` and every pending error code; clears them.
void check_gl_error(const std::string& where);
// "GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT", ... for glCheckFramebufferStatus results.
std::string framebuffer_status_name(GLenum status);
// Throws GlError naming `where` and the status when the bound framebuffer is not complete.
void check_framebuffer_complete(GLenum target, const std::string& where);

namespace detail {

// Owns one GL name; Deleter is a stateless functor that deletes it.
template <typename Deleter>
class GlName {
 public:
  GlName() = default;
  explicit GlName(GLuint name) : name_(name) {}
  ~GlName() { reset(); }
  GlName(GlName&& other) noexcept : name_(std::exchange(other.name_, 0)) {}
  GlName& operator=(GlName&& other) noexcept {
    if (this != &other) {
      reset();
      name_ = std::exchange(other.name_, 0);
    }
    return *this;
  }
  GlName(const GlName&) = delete;
  GlName& operator=(const GlName&) = delete;

  GLuint get() const { return name_; }
  explicit operator bool() const { return name_ != 0; }
  void reset() {
    if (name_ != 0) Deleter{}(name_);
    name_ = 0;
  }

 private:
  GLuint name_ = 0;
};

struct TextureDeleter { void operator()(GLuint name) const { glDeleteTextures(1, &name); } };
struct FramebufferDeleter { void operator()(GLuint name) const { glDeleteFramebuffers(1, &name); } };
struct BufferDeleter { void operator()(GLuint name) const { glDeleteBuffers(1, &name); } };
struct VertexArrayDeleter { void operator()(GLuint name) const { glDeleteVertexArrays(1, &name); } };
struct ProgramDeleter { void operator()(GLuint name) const { glDeleteProgram(name); } };
struct ShaderDeleter { void operator()(GLuint name) const { glDeleteShader(name); } };
struct RenderbufferDeleter { void operator()(GLuint name) const { glDeleteRenderbuffers(1, &name); } };
struct SamplerDeleter { void operator()(GLuint name) const { glDeleteSamplers(1, &name); } };

}  // namespace detail

using Texture = detail::GlName<detail::TextureDeleter>;
using Framebuffer = detail::GlName<detail::FramebufferDeleter>;
using Buffer = detail::GlName<detail::BufferDeleter>;
using VertexArray = detail::GlName<detail::VertexArrayDeleter>;
using Program = detail::GlName<detail::ProgramDeleter>;
using Shader = detail::GlName<detail::ShaderDeleter>;
using Renderbuffer = detail::GlName<detail::RenderbufferDeleter>;
using Sampler = detail::GlName<detail::SamplerDeleter>;

// Fresh names (glGen*/glCreate*); throw GlError when the driver gives none.
Texture make_texture();
Framebuffer make_framebuffer();
Buffer make_buffer();
VertexArray make_vertex_array();
Renderbuffer make_renderbuffer();
Shader make_shader(GLenum stage);
Program make_program();

}  // namespace skylit::gpu
