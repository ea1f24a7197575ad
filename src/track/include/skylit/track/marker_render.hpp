#pragma once
// Synthetic camera frames of a marker map: each tag's printed pattern (libapriltag's) on its
// plane in the site, seen through a calibrated lens from a known pose. For tests, benchmarks and
// demos of the tracker, where the true pose is known.
#include <cstdint>

#include <opencv2/core/mat.hpp>

#include "skylit/camera/lens.hpp"
#include "skylit/track/marker_map.hpp"
#include "skylit/track/pose.hpp"

namespace skylit::track {

struct MarkerRenderOptions {
  int supersampling = 4;            // samples per pixel along each axis
  double background = 110;          // grey level where no tag is (0..255)
  double black = 25;                // the tag's dark cells
  double white = 225;               // its light cells and the paper around it
  double paper_margin_cells = 1.0;  // white paper beyond the printed pattern, in cells
  double noise_sigma = 1.5;         // Gaussian noise, grey levels
  std::uint64_t seed = 1;           // of the noise
};

// Inverse mapping: each output pixel is split into supersampling² samples; each sample's ray
// (the lens model's unprojection at the pixel's corners, blended across the pixel, so distortion
// is exact to far below a thousandth of a pixel) meets the tag's plane at a point whose cell
// gives black or white; the pixel is the samples' mean (anti-aliased edges), plus Gaussian noise.
// A pixel covers [x − ½, x + ½] × [y − ½, y + ½] around its centre (x, y) (OpenCV).
//
// An 8-bit grey frame of the calibration's size. Tags seen from behind are not drawn.
cv::Mat render_markers(const MarkerMap& map, const camera::Lens& lens, const Pose& camera,
                       const MarkerRenderOptions& options = {});

}  // namespace skylit::track
