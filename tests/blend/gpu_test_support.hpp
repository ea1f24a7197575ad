#pragma once
// Shared by the GPU render tests: a sun visibility texture made from values on the CPU.
#include <span>
#include <stdexcept>
#include <vector>

#include "skylit/gpu/gl.hpp"
#include "skylit/blend/gpu_blend.hpp"

namespace skylit::blend::test {

// An R32F texture holding V per texel (row-major, as the basis images), owned here.
struct VisibilityTexture {
  VisibilityTexture(int width, int height, std::span<const float> values) : owner(gpu::make_texture()) {
    if (values.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
      throw std::invalid_argument("VisibilityTexture: one value per texel");
    }
    glBindTexture(GL_TEXTURE_2D, owner.get());
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_R32F, width, height);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, height, GL_RED, GL_FLOAT, values.data());
    gpu::check_gl_error("VisibilityTexture");
    texture = {owner.get(), width, height, 1};
  }
  gpu::Texture owner;
  SunVisibilityTexture texture;
};

inline GpuBlendOptions blend_options(BasisStorage storage, ShadowRatioFormat output) {
  GpuBlendOptions options;
  options.storage = storage;
  options.output = output;
  return options;
}

}  // namespace skylit::blend::test
