// The photometric match's estimator: per-channel median of P / (ρ/π · D) over a reference region.
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

}  // namespace

PhotometricEstimate estimate_photometric_match(const cv::Mat& camera_linear, const cv::Mat& region,
                                               const Eigen::Vector3d& irradiance,
                                               const Eigen::Vector3d& albedo,
                                               const PhotometricOptions& options) {
  if (camera_linear.type() != CV_32FC3 || region.type() != CV_8U || camera_linear.size() != region.size()) {
    throw InputError(input_message({}, -1, -1, "region",
                                   "the photometric estimate needs a CV_32FC3 linear frame and a CV_8U region mask of the same size",
                                   "linearise the camera frame first and draw the region at the frame's size"));
  }
  require_positive(irradiance, "irradiance");
  require_positive(albedo, "albedo");

  // k per pixel and channel; the expected value of a unit-k pixel is ρ/π · D.
  const Eigen::Vector3d expected = albedo.cwiseProduct(irradiance) / std::numbers::pi;
  std::vector<double> ratios[3];
  PhotometricEstimate estimate;
  for (int y = 0; y < camera_linear.rows; ++y) {
    const auto* pixel = camera_linear.ptr<cv::Vec3f>(y);
    const auto* inside = region.ptr<std::uint8_t>(y);
    for (int x = 0; x < camera_linear.cols; ++x) {
      if (inside[x] == 0) continue;
      const Eigen::Vector3d rgb(pixel[x][2], pixel[x][1], pixel[x][0]);
      if (!rgb.allFinite() || rgb.minCoeff() <= 0.0 || rgb.maxCoeff() >= options.max_linear_value) {
        ++estimate.pixels_rejected;
        continue;
      }
      for (int c = 0; c < 3; ++c) ratios[c].push_back(rgb[c] / expected[c]);
    }
  }
  estimate.pixels_used = static_cast<std::int64_t>(ratios[0].size());
  if (estimate.pixels_used < options.min_pixels) {
    estimate.problem = "the reference region has " + std::to_string(estimate.pixels_used) +
                       " usable pixels (at least " + std::to_string(options.min_pixels) +
                       " needed): it is out of view, hidden, clipped or black";
    return estimate;
  }
  for (int c = 0; c < 3; ++c) {
    const double k = median(ratios[c]);
    for (double& r : ratios[c]) r = std::abs(r - k);
    estimate.match.scale[c] = k;
    estimate.spread[c] = median(ratios[c]) / k;
  }
  estimate.ok = true;
  return estimate;
}

}  // namespace skylit::render
