#include "skylit/sky/sun.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <vector>

#include "skylit/base/error.hpp"
#include "skylit/sky/sky_table.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// Rec. 709 luminance of a BGR pixel; bad values (NaN, Inf, negative) count as 0.
float clean(float v) { return std::isfinite(v) && v > 0.0f ? v : 0.0f; }
float luminance(const cv::Vec3f& bgr) {
  return 0.0722f * clean(bgr[0]) + 0.7152f * clean(bgr[1]) + 0.2126f * clean(bgr[2]);
}

double angle_between(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// The disc's pixels as an area light: merged into cells of a square grid on the plane tangent to
// the sun's direction, fine enough that at most about kMaxDiscSamples cells are occupied.
void merge_disc(Sun& sun, const std::vector<std::pair<Vec3, double>>& pixels) {
  double total = 0.0, extent = 0.0;
  const Vec3 axis = sun.direction;
  const Vec3 t1 = (std::abs(axis.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX()).cross(axis).normalized();
  const Vec3 t2 = axis.cross(t1);
  for (const auto& [d, e] : pixels) {
    total += e;
    extent = std::max({extent, std::abs(d.dot(t1)), std::abs(d.dot(t2))});
  }
  if (total <= 0.0) return;
  const double half_cells = std::sqrt(static_cast<double>(kMaxDiscSamples)) / 2.0;
  const double cell = std::max(extent / half_cells, 1e-12);
  std::map<std::pair<long, long>, std::pair<Vec3, double>> cells;
  for (const auto& [d, e] : pixels) {
    if (e <= 0.0) continue;
    // Eigen does not zero a default-constructed vector: start each cell explicitly.
    auto& c = cells.try_emplace({std::lround(d.dot(t1) / cell), std::lround(d.dot(t2) / cell)}, Vec3::Zero(), 0.0)
                  .first->second;
    c.first += e * d;
    c.second += e;
  }
  for (const auto& [key, c] : cells) {
    sun.disc_directions.push_back(c.first.normalized());
    sun.disc_weights.push_back(c.second / total);
  }
}

}  // namespace

SunDetector::SunDetector(const camera::Lens& lens, const cv::Mat& mask, SunOptions options)
    : lens_(&lens), options_(options) {
  const camera::CameraCalibration& c = lens.calibration();
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.cols != c.image_width || mask.rows != c.image_height)) {
    throw InputError(input_message(c.file, -1, -1, "mask",
                                   "the sky mask is not an 8-bit single-channel image of " +
                                       std::to_string(c.image_width) + "×" + std::to_string(c.image_height),
                                   "give a gray PNG of the calibration's image size"));
  }
  sky_ = cv::Mat(c.image_height, c.image_width, CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < c.image_height; ++y) {
    auto* row = sky_.ptr<std::uint8_t>(y);
    const std::uint8_t* hidden = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < c.image_width; ++x) {
      if (hidden && hidden[x] == 0) continue;
      const auto d = lens.pixel_to_site(Vec2(x, y));
      if (d && (*d).z() >= 0.0) row[x] = 255;
    }
  }
}

SunDetection SunDetector::detect(const cv::Mat& radiance, const cv::Mat& clipped) const {
  const camera::CameraCalibration& c = lens_->calibration();
  if (radiance.type() != CV_32FC3 || radiance.cols != c.image_width || radiance.rows != c.image_height) {
    throw InputError(input_message(c.file, -1, -1, "",
                                   "the sky frame is not a float BGR image of the calibration's size (" +
                                       std::to_string(c.image_width) + "×" + std::to_string(c.image_height) + ")",
                                   "linearise the frame first, and use the calibration of the camera that took it"));
  }
  if (!clipped.empty() && (clipped.type() != CV_8UC1 || clipped.size() != radiance.size())) {
    throw InputError("clipped mask: expected an 8-bit single-channel image of the frame's size");
  }
  SunDetection result;

  // The brightest sky pixel is the candidate.
  float peak = -1.0f;
  cv::Point peak_at(-1, -1);
  for (int y = 0; y < radiance.rows; ++y) {
    const auto* row = radiance.ptr<cv::Vec3f>(y);
    const auto* sky = sky_.ptr<std::uint8_t>(y);
    for (int x = 0; x < radiance.cols; ++x) {
      if (!sky[x]) continue;
      const float l = luminance(row[x]);
      if (l > peak) {
        peak = l;
        peak_at = {x, y};
      }
    }
  }
  if (peak_at.x < 0) {
    result.reason = "the frame sees no sky (all pixels masked or below the horizon)";
    return result;
  }
  if (peak <= 0.0f) {
    result.reason = "the sky is black";
    return result;
  }
  const Vec3 peak_dir = *lens_->pixel_to_site(Vec2(peak_at.x, peak_at.y));

  // A window that holds the background annulus around the peak.
  double pixel_angle = std::numeric_limits<double>::infinity();
  for (const cv::Point step : {cv::Point(1, 0), cv::Point(0, 1), cv::Point(-1, 0), cv::Point(0, -1)}) {
    const auto d = lens_->pixel_to_site(Vec2(peak_at.x + step.x, peak_at.y + step.y));
    if (d) pixel_angle = std::min(pixel_angle, angle_between(peak_dir, *d));
  }
  if (!std::isfinite(pixel_angle) || pixel_angle <= 0.0) {
    result.reason = "the lens model cannot measure angles around the brightest pixel";
    return result;
  }
  const int half = static_cast<int>(std::ceil(options_.background_outer_deg * kDeg / pixel_angle)) + 2;
  const cv::Rect window = cv::Rect(peak_at.x - half, peak_at.y - half, 2 * half + 1, 2 * half + 1) &
                          cv::Rect(0, 0, radiance.cols, radiance.rows);

  // Angles from the peak, and the background from the annulus (per-channel medians).
  cv::Mat angle(window.size(), CV_64FC1, cv::Scalar(-1.0));
  std::vector<double> ring_b, ring_g, ring_r, ring_y;
  int ring_clipped = 0;
  for (int y = 0; y < window.height; ++y) {
    for (int x = 0; x < window.width; ++x) {
      const int ix = window.x + x, iy = window.y + y;
      if (!sky_.at<std::uint8_t>(iy, ix)) continue;
      const auto d = lens_->pixel_to_site(Vec2(ix, iy));
      if (!d) continue;
      const double a = angle_between(peak_dir, *d);
      angle.at<double>(y, x) = a;
      if (a >= options_.background_inner_deg * kDeg && a <= options_.background_outer_deg * kDeg) {
        const cv::Vec3f& p = radiance.at<cv::Vec3f>(iy, ix);
        ring_b.push_back(clean(p[0]));
        ring_g.push_back(clean(p[1]));
        ring_r.push_back(clean(p[2]));
        ring_y.push_back(luminance(p));
        if (!clipped.empty() && clipped.at<std::uint8_t>(iy, ix)) ++ring_clipped;
      }
    }
  }
  if (ring_y.size() < 8) {
    result.reason = "too little sky around the brightest pixel to measure its background";
    return result;
  }
  const std::size_t ring_count = ring_y.size();
  const Eigen::Vector3d background(median(std::move(ring_r)), median(std::move(ring_g)),
                                   median(std::move(ring_b)));
  const double background_y = median(std::move(ring_y));
  const double contrast = background_y > 0.0 ? peak / background_y : std::numeric_limits<double>::infinity();
  const bool peak_clipped = !clipped.empty() && clipped.at<std::uint8_t>(peak_at) != 0;
  // A clipped peak hides the sun's true contrast; a compact clipped blob in an unclipped sky
  // still is a sun (with an energy that is a lower bound).
  const bool clipped_sun = peak_clipped && ring_clipped * 4 < static_cast<int>(ring_count);
  if (contrast < options_.min_contrast && !clipped_sun) {
    result.reason = "no compact sun: the brightest pixel is only " + std::to_string(contrast) +
                    "× its surroundings (needs " + std::to_string(options_.min_contrast) + "×)";
    return result;
  }

  // Pixels connected to the peak that pass `bright`, out to `max_angle` from the peak; true in
  // `reached_beyond` when the region would have gone further.
  const auto grow = [&](const auto& bright, double max_angle, bool& reached_beyond) {
    cv::Mat seen(window.size(), CV_8UC1, cv::Scalar(0));
    std::vector<cv::Point> stack{peak_at - window.tl()};
    std::vector<cv::Point> region;
    seen.at<std::uint8_t>(stack.back()) = 1;
    reached_beyond = false;
    while (!stack.empty()) {
      const cv::Point p = stack.back();
      stack.pop_back();
      region.push_back(p);
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const cv::Point q(p.x + dx, p.y + dy);
          if (q.x < 0 || q.y < 0 || q.x >= window.width || q.y >= window.height) continue;
          if (seen.at<std::uint8_t>(q) || angle.at<double>(q) < 0.0) continue;
          seen.at<std::uint8_t>(q) = 1;
          if (!bright(q + window.tl())) continue;
          if (angle.at<double>(q) > max_angle) {
            reached_beyond = true;
            continue;
          }
          stack.push_back(q);
        }
      }
    }
    return region;
  };
  const auto is_clipped = [&](cv::Point ip) { return !clipped.empty() && clipped.at<std::uint8_t>(ip) != 0; };

  // Compact: the core (brighter than halfway between background and peak, or clipped) must fit
  // in max_angular_radius. A sun's glow or a lossy capture's ringing may spread further; that
  // does not make it less of a sun, but a bright cloud whose core is wide is none.
  const double core_threshold = background_y + 0.5 * (peak - background_y);
  bool core_too_wide = false;
  const std::vector<cv::Point> core = grow(
      [&](cv::Point ip) { return luminance(radiance.at<cv::Vec3f>(ip)) >= core_threshold || is_clipped(ip); },
      options_.max_angular_radius_deg * kDeg, core_too_wide);
  if (core_too_wide) {
    result.reason = "no compact sun: the bright region around the brightest pixel is wider than " +
                    std::to_string(options_.max_angular_radius_deg) + "°";
    return result;
  }
  // The disc that goes to the sun term: everything connected that stands well above the
  // background, within the halo radius (beyond it the dome carries the light).
  const double threshold = background_y * options_.disc_factor;
  bool beyond_halo = false;
  const std::vector<cv::Point> disc = grow(
      [&](cv::Point ip) { return luminance(radiance.at<cv::Vec3f>(ip)) > threshold || is_clipped(ip); },
      options_.halo_radius_deg * kDeg, beyond_halo);

  Sun sun;
  Vec3 centroid = Vec3::Zero();
  std::vector<std::pair<Vec3, double>> pixels;  // direction, luminance energy above background
  pixels.reserve(disc.size());
  for (const cv::Point& p : disc) {
    const cv::Point ip = p + window.tl();
    const Vec3 d = *lens_->pixel_to_site(Vec2(ip.x, ip.y));
    const double w = block_solid_angle(*lens_, ip.x - 0.5, ip.y - 0.5, ip.x + 0.5, ip.y + 0.5);
    const cv::Vec3f& l = radiance.at<cv::Vec3f>(ip);
    const Eigen::Vector3d excess(std::max(0.0, clean(l[2]) - background.x()),
                                 std::max(0.0, clean(l[1]) - background.y()),
                                 std::max(0.0, clean(l[0]) - background.z()));
    sun.energy += w * excess;
    const double energy = w * (0.2126 * excess.x() + 0.7152 * excess.y() + 0.0722 * excess.z());
    centroid += energy * d;
    pixels.emplace_back(d, energy);
    if (!clipped.empty() && clipped.at<std::uint8_t>(ip)) sun.clipped = true;
  }
  if (centroid.norm() <= 0.0) {
    result.reason = "no compact sun: no energy above the background";
    return result;
  }
  sun.direction = centroid.normalized();
  for (const cv::Point& p : core) {
    const cv::Point ip = p + window.tl();
    sun.angular_radius = std::max(sun.angular_radius, angle_between(sun.direction, *lens_->pixel_to_site(Vec2(ip.x, ip.y))));
  }
  merge_disc(sun, pixels);
  sun.background = background;
  sun.contrast = contrast;
  sun.pixel_count = static_cast<int>(disc.size());

  result.mask = cv::Mat(radiance.size(), CV_8UC1, cv::Scalar(0));
  for (const cv::Point& p : disc) result.mask.at<std::uint8_t>(p + window.tl()) = 255;
  result.reason = sun.clipped ? "compact sun, clipped: its energy is a lower bound and shadows come out too weak"
                              : "compact sun";
  result.sun = sun;
  return result;
}

}  // namespace skylit::sky
