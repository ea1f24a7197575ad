// GL error names and the factories of the RAII names (see gl.hpp).
#include "skylit/gpu/gl.hpp"

#include <sstream>

namespace skylit::gpu {

namespace {

std::string hex(GLenum code) {
  std::ostringstream text;
  text << "0x" << std::hex << code;
  return text.str();
}

template <typename Name, typename Generate>
Name generate(Generate gen, const char* what) {
  GLuint name = 0;
  gen(1, &name);
  if (name == 0) throw GlError(std::string(what) + " returned no name (" + gl_error_name(glGetError()) + ")");
  return Name(name);
}

}  // namespace

std::string gl_error_name(GLenum code) {
  switch (code) {
    case GL_NO_ERROR: return "GL_NO_ERROR";
    case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
    default: return "GL error " + hex(code);
  }
}

void check_gl_error(const std::string& where) {
  std::string errors;
  // glGetError returns one flag per call; a context lost mid-way keeps returning errors, so the
  // loop is bounded.
  for (int i = 0; i < 16; ++i) {
    const GLenum code = glGetError();
    if (code == GL_NO_ERROR) break;
    errors += (errors.empty() ? "" : ", ") + gl_error_name(code);
  }
  if (!errors.empty()) throw GlError("OpenGL ES error in " + where + ": " + errors);
}

std::string framebuffer_status_name(GLenum status) {
  switch (status) {
    case GL_FRAMEBUFFER_COMPLETE: return "GL_FRAMEBUFFER_COMPLETE";
    case GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT: return "GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT";
    case GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT: return "GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT";
    case GL_FRAMEBUFFER_INCOMPLETE_DIMENSIONS: return "GL_FRAMEBUFFER_INCOMPLETE_DIMENSIONS";
    case GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE: return "GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE";
    case GL_FRAMEBUFFER_UNSUPPORTED: return "GL_FRAMEBUFFER_UNSUPPORTED";
    case GL_FRAMEBUFFER_UNDEFINED: return "GL_FRAMEBUFFER_UNDEFINED";
    default: return "framebuffer status " + hex(status);
  }
}

void check_framebuffer_complete(GLenum target, const std::string& where) {
  const GLenum status = glCheckFramebufferStatus(target);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    throw GlError("framebuffer incomplete in " + where + ": " + framebuffer_status_name(status));
  }
}

Texture make_texture() { return generate<Texture>(glGenTextures, "glGenTextures"); }
Framebuffer make_framebuffer() { return generate<Framebuffer>(glGenFramebuffers, "glGenFramebuffers"); }
Buffer make_buffer() { return generate<Buffer>(glGenBuffers, "glGenBuffers"); }
VertexArray make_vertex_array() { return generate<VertexArray>(glGenVertexArrays, "glGenVertexArrays"); }
Renderbuffer make_renderbuffer() {
  return generate<Renderbuffer>(glGenRenderbuffers, "glGenRenderbuffers");
}

Shader make_shader(GLenum stage) {
  const GLuint name = glCreateShader(stage);
  if (name == 0) throw GlError("glCreateShader(" + hex(stage) + ") failed (" + gl_error_name(glGetError()) + ")");
  return Shader(name);
}

Program make_program() {
  const GLuint name = glCreateProgram();
  if (name == 0) throw GlError("glCreateProgram failed (" + gl_error_name(glGetError()) + ")");
  return Program(name);
}

}  // namespace skylit::gpu
