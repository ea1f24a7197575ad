// The photometric match's estimator (per-channel median of P / (ρ/π · D) over a reference region)
// and the sun's energy from the same ground in and out of a real shadow.
#include "skylit/render/photometric.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "skylit/base/error.hpp"

namespace skylit::render {
namespace {

double median(std::vector<double>& values) {
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  double upper = *middle;
  if (values.size() % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), middle);
  return 0.5 * (lower + upper);
}

void require_positive(const Eigen::Vector3d& value, const std::string& name) {
  if (!value.allFinite() || value.minCoeff() <= 0.0) {
    throw InputError(input_message({}, -1, -1, name,
                                   "the " + name + " of the photometric reference region must be positive and finite",
                                   "give the region's albedo as three numbers in (0, 1] and estimate under a sky that lights it"));
  }
}

// The per-channel medians of a region's usable pixels (finite, positive, not clipped) and their
// relative spreads (median |P − median| / median).
struct RegionStatistics {
  Eigen::Vector3d median = Eigen::Vector3d::Zero();
  Eigen::Vector3d spread = Eigen::Vector3d::Zero();
  std::int64_t used = 0;
  std::int64_t rejected = 0;
};

void require_frame_and_region(const cv::Mat& camera_linear, const cv::Mat& region, const std::string& field) {
  if (camera_linear.type() != CV_32FC3 || region.type() != CV_8U || camera_linear.size() != region.size()) {
    throw InputError(input_message({}, -1, -1, field,
                                   "the photometric estimate needs a CV_32FC3 linear frame and a CV_8U region mask of the same size",
                                   "linearise the camera frame first and draw the region at the frame's size"));
  }
}

RegionStatistics region_statistics(const cv::Mat& camera_linear, const cv::Mat& region, double max_linear_value) {
  std::vector<double> values[3];
  RegionStatistics statistics;
  for (int y = 0; y < camera_linear.rows; ++y) {
    const auto* pixel = camera_linear.ptr<cv::Vec3f>(y);
    const auto* inside = region.ptr<std::uint8_t>(y);
    for (int x = 0; x < camera_linear.cols; ++x) {
      if (inside[x] == 0) continue;
      const Eigen::Vector3d rgb(pixel[x][2], pixel[x][1], pixel[x][0]);
      if (!rgb.allFinite() || rgb.minCoeff() <= 0.0 || rgb.maxCoeff() >= max_linear_value) {
        ++statistics.rejected;
        continue;
      }
      for (int c = 0; c < 3; ++c) values[c].push_back(rgb[c]);
    }
  }
  statistics.used = static_cast<std::int64_t>(values[0].size());
  if (statistics.used == 0) return statistics;
  for (int c = 0; c < 3; ++c) {
    const double m = median(values[c]);
    for (double& v : values[c]) v = std::abs(v - m);
    statistics.median[c] = m;
    statistics.spread[c] = median(values[c]) / m;
  }
  return statistics;
}

// Rec. 709 luminance weights, as the sky's rgb_luminance.
double luminance(const Eigen::Vector3d& rgb) { return 0.2126 * rgb.x() + 0.7152 * rgb.y() + 0.0722 * rgb.z(); }

}  // namespace

PhotometricEstimate estimate_photometric_match(const cv::Mat& camera_linear, const cv::Mat& region,
                                               const Eigen::Vector3d& irradiance,
                                               const Eigen::Vector3d& albedo,
                                               const PhotometricOptions& options) {
  require_frame_and_region(camera_linear, region, "region");
  require_positive(irradiance, "irradiance");
  require_positive(albedo, "albedo");

  // The expected value of a unit-k pixel is ρ/π · D, the same over the region: the median of
  // P / (ρ/π · D) is the median of P over it.
  const Eigen::Vector3d expected = albedo.cwiseProduct(irradiance) / std::numbers::pi;
  const RegionStatistics statistics = region_statistics(camera_linear, region, options.max_linear_value);
  PhotometricEstimate estimate;
  estimate.pixels_used = statistics.used;
  estimate.pixels_rejected = statistics.rejected;
  if (estimate.pixels_used < options.min_pixels) {
    estimate.problem = "the reference region has " + std::to_string(estimate.pixels_used) +
                       " usable pixels (at least " + std::to_string(options.min_pixels) +
                       " needed): it is out of view, hidden, clipped or black";
    return estimate;
  }
  estimate.match.scale = statistics.median.cwiseQuotient(expected);
  estimate.spread = statistics.spread;
  estimate.ok = true;
  return estimate;
}

ShadowContrast estimate_sun_from_shadow_contrast(const cv::Mat& camera_linear, const cv::Mat& lit_region,
                                                 const cv::Mat& shadowed_region, const Eigen::Vector3d& sky_irradiance,
                                                 double sun_cos, const ShadowContrastOptions& options) {
  require_frame_and_region(camera_linear, lit_region, "region");
  require_frame_and_region(camera_linear, shadowed_region, "shadowed_region");
  if (!sky_irradiance.allFinite() || sky_irradiance.minCoeff() <= 0.0) {
    throw InputError(input_message({}, -1, -1, "irradiance",
                                   "the plane's sky irradiance must be positive and finite for the shadow contrast",
                                   "estimate under a sky that lights the plane"));
  }
  if (!(options.sky_visibility > 0.0 && options.sky_visibility <= 1.0)) {
    throw InputError(input_message({}, -1, -1, "shadowed_sky_visibility",
                                   "value " + std::to_string(options.sky_visibility) + " is outside (0, 1]",
                                   "the shadowed region's brightness over the lit region's under an overcast sky, "
                                   "e.g. 1 for a thin post's shadow"));
  }
  ShadowContrast result;
  const RegionStatistics lit = region_statistics(camera_linear, lit_region, options.max_linear_value);
  const RegionStatistics shadowed = region_statistics(camera_linear, shadowed_region, options.max_linear_value);
  result.lit = lit.median;
  result.shadowed = shadowed.median;
  result.lit_pixels = lit.used;
  result.shadowed_pixels = shadowed.used;
  if (lit.used < options.min_pixels || shadowed.used < options.min_pixels) {
    result.problem = "the lit region has " + std::to_string(lit.used) + " and the shadowed region " +
                     std::to_string(shadowed.used) + " usable pixels (at least " + std::to_string(options.min_pixels) +
                     " each needed): out of view, hidden, clipped or black";
    return result;
  }
  if (!(sun_cos >= options.min_sun_cos)) {
    result.problem = "the sun is too low over the plane (n·ω " + std::to_string(sun_cos) + ") for its shadow's contrast";
    return result;
  }
  const double contrast = options.sky_visibility * luminance(lit.median) / luminance(shadowed.median);
  if (!(contrast >= options.min_contrast)) {
    result.problem = "no contrast between the regions (" + std::to_string(contrast) +
                     "): the shadowed region is lit, or a cloud covers the sun";
    return result;
  }
  const Eigen::Vector3d ratio = lit.median.cwiseQuotient(shadowed.median);
  for (int c = 0; c < 3; ++c) {
    result.sun_energy[c] = std::max(0.0, sky_irradiance[c] * (options.sky_visibility * ratio[c] - 1.0) / sun_cos);
  }
  result.confidence = std::clamp(1.0 - luminance(lit.spread) - luminance(shadowed.spread), 0.0, 1.0);
  result.ok = true;
  return result;
}

}  // namespace skylit::render
