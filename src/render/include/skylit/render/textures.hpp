#pragma once
// Textures filled from the CPU frame after frame, each allocated once and rewritten in place:
// an 8-bit image for the display, and a plane's shadow ratio T blended on the CPU. They must be
// used and destroyed while their GL context is current.
#include <span>
#include <vector>

#include <GLES3/gl31.h>

#include <opencv2/core/mat.hpp>

#include "skylit/gpu/gl.hpp"

namespace skylit::render {

// An 8-bit image (grey, or BGR sRGB codes) as an RGBA8 texture of its codes, row 0 the image's top, for
// gpu::WindowContext::present. Allocated again only when the size changes.
class ImageTexture {
 public:
  GLuint upload(const cv::Mat& codes);

 private:
  gpu::Texture texture_;
  cv::Size size_;
};

// A shadow-ratio texture from CPU data (blend::blend_cpu's output: width × height × 3 floats, RGB, row-major
// texels): RGBA32F, T in rgb. For the CPU blend path and for tests.
gpu::Texture upload_shadow_ratio(std::span<const float> rgb, int width, int height);

// Values from the CPU on the GPU, for the compositor: RGBA32F, rewritten in place, 1 until the
// first upload. The CPU blend's T of one plane; the light map's irradiance.
class ShadowRatioTexture {
 public:
  ShadowRatioTexture(int width, int height);
  void upload(const std::vector<float>& rgba);
  GLuint get() const { return texture_.get(); }

 private:
  int width_, height_;
  gpu::Texture texture_;
};

}  // namespace skylit::render
