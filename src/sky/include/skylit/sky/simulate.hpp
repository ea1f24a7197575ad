#pragma once
// Sky simulation: what a calibrated sky camera would record under a given sky, from an
// equirectangular HDR image or an analytic sky (ClearSky, OvercastSky, any direction → RGB
// function), as linear float frames or clipped 8-bit frames. Feeds the live path's tests and
// demos with skies whose answer is known. Write the frames with write_sky_exr (radiometry.hpp)
// in float: the sun exceeds half's range.
#include <chrono>
#include <filesystem>
#include <functional>
#include <optional>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "skylit/camera/lens.hpp"
#include "skylit/sky/sky_model.hpp"

namespace skylit::sky {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// Equirectangular convention (site frame, x east, y north, z up), for a W × H image with pixel
// centres at integer coordinates (OpenCV's convention, as the lens models):
//   azimuth   az = 2π (x + 0.5) / W − π     from north towards east: the image's vertical centre
//                                           line (edge coordinate W/2) looks north, x increasing
//                                           turns clockwise seen from above (north → east →
//                                           south); the left and right edges look south.
//   elevation el = π/2 − π (y + 0.5) / H    the top edge (row 0) is the zenith, the bottom edge
//                                           (last row) the nadir; the horizon is edge row H/2.
//   direction  (sin az cos el, cos az cos el, sin el)
// Images are OpenCV BGR; the sky functions return RGB (Eigen r, g, b).
//
// Unit site direction of the continuous pixel position (x, y) of a w × h equirect.
Vec3 equirect_direction(int width, int height, double x, double y);
// Continuous pixel position of a site direction (any length > 0): x in [−0.5, W − 0.5),
// y in [−0.5, H − 0.5].
Vec2 equirect_pixel(int width, int height, const Vec3& site_direction);
// Exact solid angle (sr) of one pixel of row `row`: (2π / W) (sin el_top − sin el_bottom).
double equirect_pixel_solid_angle(int width, int height, int row);

// A sky to render: a smooth part sampled per pixel, and an optional sun disc added
// analytically (its energy deposited into the pixels it overlaps), because a disc 0.53° wide
// is smaller than a pixel of most sky cameras and point samples would miss it or blow it up.
// `sky` must not contain the disc itself (it would be counted twice).
struct SkyFunction {
  std::function<Eigen::Vector3d(const Vec3& site_direction)> sky;  // linear RGB radiance
  std::optional<SunDisc> sun;
};
SkyFunction sky_function(const ClearSky& sky);     // its sky_radiance and its sun (if up)
SkyFunction sky_function(const OvercastSky& sky);  // no sun

// An analytic sky as the simulators describe it (skylit-sky, the sky-sim frame source).
struct AnalyticSkySettings {
  enum class Kind { Clear, Overcast };
  Kind kind = Kind::Clear;
  double turbidity = 3.0;        // clear sky haze, 2..10
  double zenith_radiance = 5.0;  // overcast zenith radiance
  double latitude_deg = 0;       // clear: the place whose sun is drawn
  double longitude_deg = 0;
};
// The sky at `utc`: ClearSky with the sun where solar_position puts it at the settings' place,
// or OvercastSky (time and place ignored). InputError naming the field for a turbidity,
// radiance, latitude or longitude out of range.
SkyFunction analytic_sky(const AnalyticSkySettings& settings, std::chrono::sys_seconds utc);

// An equirect sky image as linear radiance (CV_32FC3 BGR): float files (EXR, HDR) as stored,
// 8/16-bit files taken as sRGB-encoded. InputError naming the file when it cannot be read.
// The caller may warn when it is not 2:1 (it is used all the same).
cv::Mat read_equirect(const std::filesystem::path& file);

// Rendering options shared by the renderers.
struct RenderOptions {
  int supersample = 4;  // sub-pixel samples per axis (1..16): each pixel is the mean of s² points
  // Site azimuth (radians, from north towards east) that the equirect's centre column looks
  // at: a site direction of azimuth a is read at equirect azimuth a − azimuth_offset.
  double azimuth_offset = 0;
};

// The sky camera's view of an equirect (CV_32FC3 BGR, any size ≥ 2 × 2, lower hemisphere
// included: a fisheye's corners see the ground). Each pixel the lens images (its centre
// unprojects) is the mean over the supersample² sub-pixel positions that unproject of a
// bilinear lookup, wrapped in azimuth; other pixels are 0. CV_32FC3 BGR, calibration size.
// std::invalid_argument for an empty or non-CV_32FC3 equirect or supersample outside 1..16.
cv::Mat render_fisheye(const camera::Lens& lens, const cv::Mat& equirect, const RenderOptions& options = {});
// The same for an analytic sky; the sun's disc is deposited so that Σ L_p Ω_p over the pixels
// it covers (Ω_p from block_solid_angle) equals its irradiance (within 0.1% where the lens sees
// it whole).
cv::Mat render_fisheye(const camera::Lens& lens, const SkyFunction& sky, const RenderOptions& options = {});
// An equirect of an analytic sky (CV_32FC3 BGR), sun disc deposited the same way with
// equirect_pixel_solid_angle. azimuth_offset is ignored.
cv::Mat render_equirect(const SkyFunction& sky, int width, int height, const RenderOptions& options = {});

// A clipped 8-bit frame, as a camera would write it: code = sRGB(clamp(L × exposure_scale,
// 0, 1)) rounded; NaN and negatives give 0. CV_8UC3 BGR from CV_32FC3.
cv::Mat to_8bit(const cv::Mat& radiance, double exposure_scale);
// The exposure scale of a camera that meters its sky: the median luminance of the pixels where
// `sky` (CV_8U) is non-zero lands at `median_fraction` of full scale (0.18: middle grey), all
// brighter than 1 / scale clipping. std::invalid_argument for a fraction outside (0, 1] or a
// sky whose median is not above 0.
double auto_exposure_scale(const cv::Mat& radiance, const cv::Mat& sky, double median_fraction);

// Σ_p L_p Ω_p (RGB) over the pixels of a sky-camera image whose centre direction is above the
// horizon, Ω_p from block_solid_angle of the pixel: the image's estimate of ∫ L dω over the
// upper hemisphere (for checks and tests).
Eigen::Vector3d fisheye_hemisphere_energy(const camera::Lens& lens, const cv::Mat& radiance);
// The same for an equirect: the exact ∫ L dω over its upper half (a row cut by the horizon
// counts by its upper part).
Eigen::Vector3d equirect_hemisphere_energy(const cv::Mat& equirect);

}  // namespace skylit::sky
