#include "skylit/render/textures.hpp"

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

}  // namespace skylit::render
