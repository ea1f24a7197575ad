#include "skylit/render/textures.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace skylit::render {

GLuint ImageTexture::upload(const cv::Mat& codes) {
  cv::Mat rgba;
  cv::cvtColor(codes, rgba, codes.channels() == 1 ? cv::COLOR_GRAY2RGBA : cv::COLOR_BGR2RGBA);
  if (!texture_ || size_ != rgba.size()) {
    texture_ = gpu::make_texture();
    glBindTexture(GL_TEXTURE_2D, texture_.get());
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, rgba.cols, rgba.rows);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    size_ = rgba.size();
  }
  glBindTexture(GL_TEXTURE_2D, texture_.get());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, rgba.cols, rgba.rows, GL_RGBA, GL_UNSIGNED_BYTE, rgba.ptr());
  gpu::check_gl_error("uploading the camera frame for the display");
  return texture_.get();
}

ShadowRatioTexture::ShadowRatioTexture(int width, int height) : width_(width), height_(height) {
  texture_ = gpu::make_texture();
  glBindTexture(GL_TEXTURE_2D, texture_.get());
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, width_, height_);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  const std::vector<float> ones(4 * static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_), 1.0f);
  upload(ones);
}

void ShadowRatioTexture::upload(const std::vector<float>& rgba) {
  glBindTexture(GL_TEXTURE_2D, texture_.get());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width_, height_, GL_RGBA, GL_FLOAT, rgba.data());
  gpu::check_gl_error("uploading a shadow ratio blended on the CPU");
}

gpu::Texture upload_shadow_ratio(std::span<const float> rgb, int width, int height) {
  const std::size_t texels = static_cast<std::size_t>(std::max(width, 0)) * static_cast<std::size_t>(std::max(height, 0));
  if (texels == 0 || rgb.size() != 3 * texels) {
    throw std::invalid_argument("upload_shadow_ratio: " + std::to_string(rgb.size()) + " floats for " +
                                std::to_string(width) + "×" + std::to_string(height) + " texels (3 per texel expected)");
  }
  std::vector<float> rgba(4 * texels, 1.0f);
  for (std::size_t k = 0; k < texels; ++k) std::copy_n(rgb.begin() + static_cast<std::ptrdiff_t>(3 * k), 3, rgba.begin() + static_cast<std::ptrdiff_t>(4 * k));
  gpu::Texture texture = gpu::make_texture();
  glBindTexture(GL_TEXTURE_2D, texture.get());
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, width, height);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, height, GL_RGBA, GL_FLOAT, rgba.data());
  // Read with texelFetch or through a sampler object; complete either way.
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  gpu::check_gl_error("upload_shadow_ratio");
  return texture;
}

}  // namespace skylit::render
