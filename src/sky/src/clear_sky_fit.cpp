// A clear-sky model fitted to a frame's unclipped sky (clear_sky_fit.hpp).
#include "skylit/sky/clear_sky_fit.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "skylit/geom/angles.hpp"
#include "skylit/sky/sky_model.hpp"

namespace skylit::sky {
namespace {

struct SkyPixel {
  Vec3 direction;
  Eigen::Vector3d rgb;  // frame radiance
};

using geom::kDeg;

}  // namespace

std::optional<ClearSkyFit> fit_clear_sky(const camera::Lens& lens, const cv::Mat& sky, const cv::Mat& radiance,
                                         const cv::Mat& clipped, const cv::Mat& exclude, const Eigen::Vector3d& sun_direction,
                                         const ClearSkyFitOptions& options) {
  const Vec3 sun = sun_direction.normalized();
  if (!(sun.z() > 0.0)) return std::nullopt;
  int candidates = 0;
  for (int y = 0; y < sky.rows; ++y) candidates += cv::countNonZero(sky.row(y));
  const int stride = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(candidates) / std::max(1, options.max_pixels))));
  const double min_cos_sun = std::cos(options.min_sun_distance_deg * kDeg);
  const double min_z = std::sin(options.min_elevation_deg * kDeg);
  std::vector<SkyPixel> pixels;
  for (int y = stride / 2; y < radiance.rows; y += stride) {
    for (int x = stride / 2; x < radiance.cols; x += stride) {
      if (!sky.at<std::uint8_t>(y, x)) continue;
      if (!clipped.empty() && clipped.at<std::uint8_t>(y, x)) continue;
      if (!exclude.empty() && exclude.at<std::uint8_t>(y, x)) continue;
      const auto d = lens.pixel_to_site(Vec2(x, y));
      if (!d || d->z() < min_z || d->dot(sun) > min_cos_sun) continue;
      const cv::Vec3f& p = radiance.at<cv::Vec3f>(y, x);
      const Eigen::Vector3d rgb(p[2], p[1], p[0]);
      if (!rgb.allFinite() || (rgb.array() < 0.0).any()) continue;
      pixels.push_back({*d, rgb});
    }
  }
  if (pixels.size() < 50) return std::nullopt;

  // The turbidity whose sky's shape explains the luminance best (one scale), on a grid then refined.
  std::vector<double> measured(pixels.size());
  double measured_sq = 0;
  for (std::size_t k = 0; k < pixels.size(); ++k) {
    measured[k] = rgb_luminance(pixels[k].rgb);
    measured_sq += measured[k] * measured[k];
  }
  if (!(measured_sq > 0)) return std::nullopt;
  const auto residual_at = [&](double turbidity) {
    const ClearSky model(sun, turbidity);
    double mm = 0, ym = 0;
    std::vector<double> m(pixels.size());
    for (std::size_t k = 0; k < pixels.size(); ++k) {
      m[k] = rgb_luminance(model.sky_radiance(pixels[k].direction));
      mm += m[k] * m[k];
      ym += measured[k] * m[k];
    }
    if (!(mm > 0)) return 1.0;
    const double scale = ym / mm;
    double rr = 0;
    for (std::size_t k = 0; k < pixels.size(); ++k) rr += (measured[k] - scale * m[k]) * (measured[k] - scale * m[k]);
    return std::sqrt(rr / measured_sq);
  };
  double best_t = 2.0, best = residual_at(2.0);
  for (double t = 2.5; t <= 10.0 + 1e-9; t += 0.5) {
    const double r = residual_at(t);
    if (r < best) {
      best = r;
      best_t = t;
    }
  }
  for (double step = 0.25; step >= 0.0625; step /= 2) {
    for (const double t : {best_t - step, best_t + step}) {
      if (t < 2.0 || t > 10.0) continue;
      const double r = residual_at(t);
      if (r < best) {
        best = r;
        best_t = t;
      }
    }
  }

  ClearSkyFit fit;
  fit.turbidity = best_t;
  fit.residual = best;
  fit.confidence = std::clamp(1.0 - best / options.cloudy_residual, 0.0, 1.0);
  fit.pixels = static_cast<int>(pixels.size());
  const ClearSky model(sun, best_t);
  Eigen::Vector3d mm = Eigen::Vector3d::Zero(), ym = Eigen::Vector3d::Zero();
  for (const SkyPixel& p : pixels) {
    const Eigen::Vector3d m = model.sky_radiance(p.direction);
    mm += m.cwiseProduct(m);
    ym += p.rgb.cwiseProduct(m);
  }
  for (int c = 0; c < 3; ++c) fit.scale[c] = mm[c] > 0 ? ym[c] / mm[c] : 0.0;
  fit.sun_energy = fit.scale.cwiseProduct(model.sun().irradiance);
  return fit;
}

std::optional<double> circumsolar_glow(const camera::Lens& lens, const cv::Mat& sky, const cv::Mat& radiance,
                                       const cv::Mat& clipped, const cv::Mat& disc, const Eigen::Vector3d& sun_direction,
                                       double ring_deg) {
  if (clipped.empty() || disc.empty()) return std::nullopt;
  const Vec3 sun = sun_direction.normalized();
  // The blob's clipped pixels and its reach from the sun.
  std::vector<double> blob;
  double reach = 0.0;
  for (int y = 0; y < disc.rows; ++y) {
    for (int x = 0; x < disc.cols; ++x) {
      if (!disc.at<std::uint8_t>(y, x)) continue;
      const auto d = lens.pixel_to_site(Vec2(x, y));
      if (d) reach = std::max(reach, std::acos(std::clamp(d->dot(sun), -1.0, 1.0)));
      if (!clipped.at<std::uint8_t>(y, x)) continue;
      const cv::Vec3f& p = radiance.at<cv::Vec3f>(y, x);
      blob.push_back(rgb_luminance(Eigen::Vector3d(p[2], p[1], p[0])));
    }
  }
  if (blob.empty()) return std::nullopt;
  const double outer = std::cos(reach + ring_deg * kDeg);
  // Only the blob's neighbourhood can be within the ring (fx: pixels per radian near the axis;
  // twice that as margin for the lens's stretch towards its rim).
  const int pad = static_cast<int>(std::ceil(2.0 * ring_deg * kDeg * std::max(lens.calibration().fx, lens.calibration().fy))) + 2;
  const cv::Rect near = (cv::boundingRect(disc) + cv::Size(2 * pad, 2 * pad) - cv::Point(pad, pad)) & cv::Rect(0, 0, radiance.cols, radiance.rows);
  std::vector<double> ring;
  for (int y = near.y; y < near.y + near.height; ++y) {
    for (int x = near.x; x < near.x + near.width; ++x) {
      if (!sky.at<std::uint8_t>(y, x) || disc.at<std::uint8_t>(y, x) || clipped.at<std::uint8_t>(y, x)) continue;
      const auto d = lens.pixel_to_site(Vec2(x, y));
      if (!d || d->dot(sun) < outer) continue;
      const cv::Vec3f& p = radiance.at<cv::Vec3f>(y, x);
      ring.push_back(rgb_luminance(Eigen::Vector3d(p[2], p[1], p[0])));
    }
  }
  if (ring.empty()) return std::nullopt;
  const auto median = [](std::vector<double>& v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double level = median(blob);
  return level > 0.0 ? std::optional<double>(median(ring) / level) : std::nullopt;
}

}  // namespace skylit::sky
