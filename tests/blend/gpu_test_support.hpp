#pragma once
// Shared by the GPU render tests: a sun visibility texture made from values on the CPU.
#include <span>
#include <stdexcept>
#include <vector>

#include "skylit/gpu/gl.hpp"
#include "skylit/blend/gpu_blend.hpp"

namespace skylit::blend::test {

// An R32F texture array holding V per texel (row-major, as the basis images), one layer per
// separated source (`values` holds the layers one after the other), owned here.
struct VisibilityTexture {
  VisibilityTexture(int width, int height, std::span<const float> values) : owner(gpu::make_texture()) {
    const std::size_t texels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    if (texels == 0 || values.empty() || values.size() % texels != 0) {
      throw std::invalid_argument("VisibilityTexture: one value per texel and layer");
    }
    const auto layers = static_cast<int>(values.size() / texels);
    glBindTexture(GL_TEXTURE_2D_ARRAY, owner.get());
    glTexStorage3D(GL_TEXTURE_2D_ARRAY, 1, GL_R32F, width, height, layers);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, 0, width, height, layers, GL_RED, GL_FLOAT, values.data());
    gpu::check_gl_error("VisibilityTexture");
    texture = {owner.get(), width, height, 1, layers};
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
