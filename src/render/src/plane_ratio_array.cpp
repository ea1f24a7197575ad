#include "plane_ratio_array.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>

namespace skylit::render {

PlaneRatioArray::PlaneRatioArray(std::span<const Size> planes) : planes_(planes.begin(), planes.end()) {
  Size layer;
  for (const Size& s : planes_) {
    if (s.width <= 0 || s.height <= 0) throw std::invalid_argument("PlaneRatioArray: a plane without texels");
    layer.width = std::max(layer.width, s.width);
    layer.height = std::max(layer.height, s.height);
  }
  if (planes_.empty()) return;
  texture_ = gpu::make_texture();
  glBindTexture(GL_TEXTURE_2D_ARRAY, texture_.get());
  glTexStorage3D(GL_TEXTURE_2D_ARRAY, 1, GL_RGBA32F, layer.width, layer.height, static_cast<GLsizei>(planes_.size()));
  // Read with texelFetch or through the compositor's bilinear sampler object; complete either way.
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
  read_ = gpu::make_framebuffer();
  draw_ = gpu::make_framebuffer();

  // Every texel 1, the padding included: a bilinear lookup at a plane's last texel gives its
  // neighbour a weight of 0, and 0 times a finite value is 0.
  GLint previous = 0;
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &previous);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, draw_.get());
  const std::array<float, 4> ones{1.0f, 1.0f, 1.0f, 1.0f};
  for (std::size_t j = 0; j < planes_.size(); ++j) {
    glFramebufferTextureLayer(GL_DRAW_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, texture_.get(), 0, static_cast<GLint>(j));
    glClearBufferfv(GL_COLOR, 0, ones.data());
  }
  glFramebufferTextureLayer(GL_DRAW_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, 0, 0, 0);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(previous));
  gpu::check_gl_error("PlaneRatioArray: allocating the virtual planes' shadow ratios");
}

void PlaneRatioArray::gather(std::span<const GLuint> textures) {
  if (textures.size() != planes_.size()) {
    throw std::invalid_argument("PlaneRatioArray::gather: " + std::to_string(textures.size()) + " textures for " +
                                std::to_string(planes_.size()) + " planes");
  }
  if (planes_.empty()) return;
  GLint previous_read = 0, previous_draw = 0;
  glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &previous_read);
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &previous_draw);
  const GLboolean scissor = glIsEnabled(GL_SCISSOR_TEST);
  glDisable(GL_SCISSOR_TEST);  // it clips blits too
  glBindFramebuffer(GL_READ_FRAMEBUFFER, read_.get());
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, draw_.get());
  for (std::size_t j = 0; j < planes_.size(); ++j) {
    GLint width = 0, height = 0;
    glBindTexture(GL_TEXTURE_2D, textures[j]);
    glGetTexLevelParameteriv(GL_TEXTURE_2D, 0, GL_TEXTURE_WIDTH, &width);
    glGetTexLevelParameteriv(GL_TEXTURE_2D, 0, GL_TEXTURE_HEIGHT, &height);
    glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, textures[j], 0);
    glFramebufferTextureLayer(GL_DRAW_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, texture_.get(), 0, static_cast<GLint>(j));
    // The plane's size: a copy; 1 × 1: its texel over the whole plane.
    glBlitFramebuffer(0, 0, width, height, 0, 0, planes_[j].width, planes_[j].height, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  }
  glBindTexture(GL_TEXTURE_2D, 0);
  glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, 0, 0);
  glFramebufferTextureLayer(GL_DRAW_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, 0, 0, 0);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(previous_read));
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(previous_draw));
  if (scissor == GL_TRUE) glEnable(GL_SCISSOR_TEST);
  gpu::check_gl_error("PlaneRatioArray: gathering the virtual planes' shadow ratios");
}

}  // namespace skylit::render
