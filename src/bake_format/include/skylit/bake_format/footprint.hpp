#pragma once
// Which layers of a plane's basis carry a shadow, and where: what the blend needs to read.
#include <cstdint>
#include <span>
#include <vector>

#include "skylit/bake_format/arrays.hpp"

namespace skylit::bake_format {

// A layer whose light the plane cannot see at all (A = 0, so B = 0) adds nothing; a layer that
// no texel sees shadowed (B = A everywhere, within a tolerance) adds the constant w·A, which one
// shared layer of ones carries for all of them; only the rest hold shadows, each within the
// rectangle of texels it shadows (outside it B = A).
struct LayerFootprint {
  enum class Kind { Dark, Unshadowed, Shadowed };
  Kind kind = Kind::Shadowed;
  // Shadowed: the smallest rectangle of texels holding every texel where A − B > tolerance · A.
  int col = 0, row = 0, cols = 0, rows = 0;
};

struct PlaneFootprint {
  std::vector<LayerFootprint> layers;
  int dark = 0, unshadowed = 0, shadowed = 0;
  std::uint64_t texels = 0;                // of the plane
  std::uint64_t shadowed_texels = 0;       // Σ over shadowed layers of their rectangles' areas
  // Layers a blend must read: the shadowed ones, plus one of ones when any layer is unshadowed.
  int needed_layers() const { return shadowed + (unshadowed > 0 ? 1 : 0); }
};

// `tolerance`: a texel is shadowed in layer l when A_l − B_l > tolerance · A_l (B as stored, half
// floats: their rounding is 2⁻¹¹ of the value, so tolerances from 1e-3 up ignore it). Leaving an
// unshadowed layer's B out changes T by at most the tolerance. std::invalid_argument for sizes
// that disagree or a tolerance outside [0, 1).
PlaneFootprint analyse_footprint(const ImageStack& stack, std::span<const double> unoccluded, double tolerance = 1e-3);

// The same from the stored half floats (what the live service loads).
PlaneFootprint analyse_footprint(const ImageStackHalf& stack, std::span<const double> unoccluded,
                                 double tolerance = 1e-3);

}  // namespace skylit::bake_format
