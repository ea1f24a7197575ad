#pragma once
// Photometric match: the scale (and white balance) from the building's radiance to the camera's
// linear pixel values, so that the virtual building is as bright and as coloured as the real
// ground beside it; and the sun's energy from the same ground in and out of a real shadow.
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

// The sun's share of a real plane's light, from the plane in and out of a real shadow (a post's,
// a wall's): the HMD camera sees the same ground material lit (the photometric region, radiance
// ∝ D_sky + E_sun n·ω) and shadowed (∝ V · D_sky, V the sky the occluder leaves it, 1 for a thin
// post's shadow). Their ratio r gives
//
//     E_sun = D_sky ⊙ (V r − 1) / (n·ω)       per channel
//
// with D_sky the plane's unoccluded sky irradiance from S (the sky camera's, without its sun).
// Exposure, white balance and albedo cancel: only the contrast counts, which an 8-bit HMD camera
// exposed for the ground records well where the sky camera clips the sun.
struct ShadowContrastOptions {
  double sky_visibility = 1.0;      // V of the shadowed region: its ratio to the lit one under overcast
  double min_sun_cos = 0.087;       // n·ω below this (the sun within 5° of the plane): no estimate
  double min_contrast = 1.05;       // V r (luminance) below this: no shadow to measure
  int min_pixels = 64;              // per region
  double max_linear_value = 0.95;   // clipped pixels are left out (as PhotometricOptions)
};

struct ShadowContrast {
  bool ok = false;
  Eigen::Vector3d lit = Eigen::Vector3d::Zero();       // per-channel medians of the camera's linear values
  Eigen::Vector3d shadowed = Eigen::Vector3d::Zero();
  Eigen::Vector3d sun_energy = Eigen::Vector3d::Zero();  // E_sun, RGB, the sky's units (normal irradiance)
  // 1 − the two regions' relative spreads (median |P − median| / median, luminance), at least 0:
  // a uniform ground gives 1, a textured or partly lit shadow less.
  double confidence = 0;
  std::int64_t lit_pixels = 0, shadowed_pixels = 0;
  std::string problem;  // why not ok
};

// camera_linear, lit_region, shadowed_region as for estimate_photometric_match; sky_irradiance:
// D_sky of the plane (plane_irradiance without sources); sun_cos: n·ω of the plane and the sun.
// InputError for mismatched sizes or types, a non-positive sky irradiance or a visibility
// outside (0, 1].
ShadowContrast estimate_sun_from_shadow_contrast(const cv::Mat& camera_linear, const cv::Mat& lit_region,
                                                 const cv::Mat& shadowed_region, const Eigen::Vector3d& sky_irradiance,
                                                 double sun_cos, const ShadowContrastOptions& options = {});

}  // namespace skylit::render
