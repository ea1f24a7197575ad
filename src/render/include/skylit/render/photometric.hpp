#pragma once
// Photometric match: the scale (and white balance) from the building's radiance to the camera's
// linear pixel values, so that the virtual building is as bright and as coloured as the real
// ground beside it.
#include <cstdint>
#include <string>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace skylit::render {

// The renderer computes radiance L = ρ/π · E from the sky parameters S (relative units); the
// camera records a linear value P = k ⊙ L per channel, k folding in exposure, gain, lens
// transmission and white balance. k is set in the config, or estimated from a reference region
// of real ground of known albedo ρ that nothing virtual shadows: there E is the plane's
// unoccluded irradiance D = Σ_i S_i A_i + E_sun max(0, n·ω_sun), so each pixel gives
// k = P / (ρ/π · D), and the estimate is the per-channel median over the region's pixels
// (robust to a stray object, a puddle or a person crossing it).
struct PhotometricMatch {
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();  // k, RGB: camera linear value per unit radiance
};

struct PhotometricOptions {
  int min_pixels = 64;              // fewer usable pixels in the region: no estimate
  double max_linear_value = 0.95;   // pixels with a channel at or above this are taken as clipped
                                    // (for 8-bit frames: code 250 of 255 after linearisation)
};

struct PhotometricEstimate {
  bool ok = false;
  PhotometricMatch match;                                   // valid when ok
  std::int64_t pixels_used = 0;
  std::int64_t pixels_rejected = 0;                         // clipped, black, non-finite
  Eigen::Vector3d spread = Eigen::Vector3d::Zero();         // median |k_p − k| / k per channel
  std::string problem;                                      // why not ok
};

// camera_linear: CV_32FC3 BGR linear values (the camera frame through its response curve).
// region: CV_8U of the same size, non-zero on the reference region's pixels (for a rectangle on a
// real plane, Compositor::region_mask draws it). irradiance: D of that plane for this sky
// (plane_irradiance); albedo: ρ of the region, RGB. InputError for mismatched sizes or types or
// an albedo or irradiance that is not positive and finite.
PhotometricEstimate estimate_photometric_match(const cv::Mat& camera_linear, const cv::Mat& region,
                                               const Eigen::Vector3d& irradiance,
                                               const Eigen::Vector3d& albedo,
                                               const PhotometricOptions& options = {});

}  // namespace skylit::render
