#pragma once
// How bright a clipped sun is, from the sky around it: a clear-sky model (Preetham's shape, ESRA's
// levels: sky_model.hpp) fitted to the frame's unclipped sky gives the sun that goes with that sky.
#include <optional>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "skylit/camera/lens.hpp"

namespace skylit::sky {

struct ClearSkyFitOptions {
  double min_sun_distance_deg = 15.0;  // the aureole around the sun is left out (Preetham has none)
  double min_elevation_deg = 5.0;      // so are the horizon's trees and buildings
  int max_pixels = 6000;               // the sky is subsampled to about this many pixels
  // The fit's relative RMS residual at which the sky no longer looks clear: confidence falls
  // linearly from 1 (a perfect fit) to 0 there.
  double cloudy_residual = 0.35;
  // The sky around the sun must look clear too (circumsolar_glow): at or below cloudy_glow the
  // sun is taken as behind a cloud (no confidence), at or above clear_glow as clear; linear
  // between. A clear sky's aureole gives about 0.64 at 5% exposure, a cumulus over the sun 0.12
  // to 0.41 (tests/sky/cloud_passing_test.cpp).
  double cloudy_glow = 0.2;
  double clear_glow = 0.5;
};

struct ClearSkyFit {
  double turbidity = 0;                      // Linke, 2 to 10
  Eigen::Vector3d scale = Eigen::Vector3d::Zero();  // frame radiance per model radiance, RGB
  double residual = 0;                       // relative RMS of the luminance fit
  double confidence = 0;                     // 1 − residual / cloudy_residual, in [0, 1]
  Eigen::Vector3d sun_energy = Eigen::Vector3d::Zero();  // the model's DNI in frame units, RGB
  int pixels = 0;
};

// Fits ClearSky(sun_direction, T) to the frame's sky pixels (sky: CV_8U, 255 where the pixel
// sees the sky; clipped: CV_8U or empty; exclude: CV_8U or empty, pixels to leave out) by the
// turbidity that explains their luminance best, with one scale per channel. nullopt when too
// few pixels remain (under 50) or the sun is below the horizon.
std::optional<ClearSkyFit> fit_clear_sky(const camera::Lens& lens, const cv::Mat& sky, const cv::Mat& radiance,
                                         const cv::Mat& clipped, const cv::Mat& exclude, const Eigen::Vector3d& sun_direction,
                                         const ClearSkyFitOptions& options = {});

// How much the sky just outside a clipped sun's blob glows, as a share of the clipping level: the
// median luminance of the unclipped sky pixels within `ring_deg` outside the blob (disc: CV_8U,
// its pixels), over the median luminance of the blob's clipped pixels. A clear sun sits in its
// aureole, which falls smoothly from the clipping level (a high share); a sun seen through a
// cloud is a clipped disc in the cloud's grey (a low one). nullopt without clipped pixels in the
// blob or unclipped ones around it.
std::optional<double> circumsolar_glow(const camera::Lens& lens, const cv::Mat& sky, const cv::Mat& radiance,
                                       const cv::Mat& clipped, const cv::Mat& disc, const Eigen::Vector3d& sun_direction,
                                       double ring_deg = 1.5);

}  // namespace skylit::sky
