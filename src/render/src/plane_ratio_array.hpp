#pragma once
// The virtual planes' shadow ratios gathered into one texture array, a layer per plane, for the
// building's fragment shader. With a sampler per plane, a SIMD renderer (llvmpipe) reads every
// plane's T for every fragment, since only constant expressions may index samplers; from the
// array, a fragment reads the plane that covers it and no other, whatever the site's count.
#include <span>
#include <vector>

#include <GLES3/gl31.h>

#include "skylit/gpu/gl.hpp"

namespace skylit::render {

class PlaneRatioArray {
 public:
  struct Size {
    int width = 0, height = 0;
  };
  // A layer per plane, each as large as the largest plane (RGBA32F); a layer's texels beyond its
  // plane's own size hold 1 and are never read. Call with the GL context current.
  explicit PlaneRatioArray(std::span<const Size> planes);

  // Copies each plane's T, as the blend left it (a 2D texture of any float format, of the plane's
  // size, or 1 × 1 for a constant that fills the plane), into its layer: a blit per plane, which
  // costs a plane's texels, not a frame's fragments. Leaves the framebuffer bindings as they were.
  // std::invalid_argument unless there is a texture per plane.
  void gather(std::span<const GLuint> textures);

  GLuint texture() const { return texture_.get(); }

 private:
  std::vector<Size> planes_;
  gpu::Texture texture_;
  gpu::Framebuffer read_, draw_;
};

}  // namespace skylit::render
