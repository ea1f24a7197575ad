#include "skylit/sky/sun.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "skylit/base/error.hpp"
#include "skylit/sky/sky_model.hpp"
#include "skylit/sky/sky_table.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/geom/angles.hpp"

namespace skylit::sky {
namespace {

using geom::kDeg;

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
  double second_moment = 0.0;
  for (const auto& [d, e] : pixels) {
    total += e;
    extent = std::max({extent, std::abs(d.dot(t1)), std::abs(d.dot(t2))});
    const double angle = std::acos(std::clamp(d.dot(axis), -1.0, 1.0));
    second_moment += std::max(e, 0.0) * angle * angle;
  }
  if (total <= 0.0) return;
  sun.shadow_radius = std::sqrt(2.0 * second_moment / total);
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

// What detect() reads: the frame, its clipped mask (may be empty), the pixels that see the sky.
struct DetectionInput {
  const cv::Mat& radiance;
  const cv::Mat& clipped;
  const cv::Mat& sky;
  const camera::Lens& lens;
  const SunOptions& options;
};

// The brightest sky pixel and what the steps learn around it. Each step returns why there is
// no sun, or "" to go on.
struct Candidate {
  float peak = -1.0f;
  cv::Point peak_at{-1, -1};
  Vec3 peak_dir = Vec3::Zero();
  cv::Rect window;                 // holds the background annulus around the peak
  cv::Mat angle;                   // CV_64F, window-sized: angle from the peak, -1 off the sky
  Eigen::Vector3d background = Eigen::Vector3d::Zero();  // RGB, the annulus's medians
  double background_y = 0;
  double contrast = 0;
  std::vector<cv::Point> core, disc;  // window coordinates
};

bool is_clipped(const cv::Mat& clipped, cv::Point ip) { return !clipped.empty() && clipped.at<std::uint8_t>(ip) != 0; }

// Around the candidate's pixel (peak_at), a window that holds everything out to `radius_deg`.
std::string place_window(const DetectionInput& in, Candidate& c, double radius_deg) {
  const cv::Point& peak_at = c.peak_at;
  const auto at = in.lens.pixel_to_site(Vec2(peak_at.x, peak_at.y));
  if (!at) return "the lens model cannot place the brightest pixel";
  const Vec3& peak_dir = c.peak_dir = *at;
  double pixel_angle = std::numeric_limits<double>::infinity();
  for (const cv::Point step : {cv::Point(1, 0), cv::Point(0, 1), cv::Point(-1, 0), cv::Point(0, -1)}) {
    const auto d = in.lens.pixel_to_site(Vec2(peak_at.x + step.x, peak_at.y + step.y));
    if (d) pixel_angle = std::min(pixel_angle, angle_between(peak_dir, *d));
  }
  if (!std::isfinite(pixel_angle) || pixel_angle <= 0.0) {
    return "the lens model cannot measure angles around the brightest pixel";
  }
  const int half = static_cast<int>(std::ceil(radius_deg * kDeg / pixel_angle)) + 2;
  c.window = cv::Rect(peak_at.x - half, peak_at.y - half, 2 * half + 1, 2 * half + 1) &
             cv::Rect(0, 0, in.radiance.cols, in.radiance.rows);
  return "";
}

// The brightest sky pixel is the candidate; around it, a window that holds the background annulus.
std::string find_candidate(const DetectionInput& in, Candidate& c) {
  const cv::Mat& radiance = in.radiance;
  float& peak = c.peak;
  cv::Point& peak_at = c.peak_at;
  for (int y = 0; y < radiance.rows; ++y) {
    const auto* row = radiance.ptr<cv::Vec3f>(y);
    const auto* sky = in.sky.ptr<std::uint8_t>(y);
    for (int x = 0; x < radiance.cols; ++x) {
      if (!sky[x]) continue;
      const float l = luminance(row[x]);
      if (l > peak) {
        peak = l;
        peak_at = {x, y};
      }
    }
  }
  if (peak_at.x < 0) return "the frame sees no sky (all pixels masked or below the horizon)";
  if (peak <= 0.0f) return "the sky is black";
  return place_window(in, c, in.options.background_outer_deg);
}

// Angles from the peak over the window (-1 off the sky).
void measure_angles(const DetectionInput& in, Candidate& c) {
  const cv::Rect& window = c.window;
  cv::Mat& angle = c.angle = cv::Mat(window.size(), CV_64FC1, cv::Scalar(-1.0));
  for (int y = 0; y < window.height; ++y) {
    for (int x = 0; x < window.width; ++x) {
      const int ix = window.x + x, iy = window.y + y;
      if (!in.sky.at<std::uint8_t>(iy, ix)) continue;
      const auto d = in.lens.pixel_to_site(Vec2(ix, iy));
      if (d) angle.at<double>(y, x) = angle_between(c.peak_dir, *d);
    }
  }
}

// The background: per-channel medians over the annulus [inner, outer] radians from the peak (its
// clipped pixels left out when `unclipped_only`). Returns how many annulus pixels there were, and
// how many of them clipped.
std::pair<std::size_t, int> ring_background(const DetectionInput& in, Candidate& c, double inner, double outer,
                                            bool unclipped_only = false) {
  std::vector<double> ring_b, ring_g, ring_r, ring_y;
  int ring_clipped = 0;
  for (int y = 0; y < c.window.height; ++y) {
    for (int x = 0; x < c.window.width; ++x) {
      const double a = c.angle.at<double>(y, x);
      if (a < inner || a > outer) continue;
      const int ix = c.window.x + x, iy = c.window.y + y;
      if (unclipped_only && is_clipped(in.clipped, {ix, iy})) {
        ++ring_clipped;
        continue;
      }
      const cv::Vec3f& p = in.radiance.at<cv::Vec3f>(iy, ix);
      ring_b.push_back(clean(p[0]));
      ring_g.push_back(clean(p[1]));
      ring_r.push_back(clean(p[2]));
      ring_y.push_back(luminance(p));
      if (is_clipped(in.clipped, {ix, iy})) ++ring_clipped;
    }
  }
  const std::size_t count = ring_y.size();
  c.background = Eigen::Vector3d(median(std::move(ring_r)), median(std::move(ring_g)), median(std::move(ring_b)));
  c.background_y = median(std::move(ring_y));
  c.contrast = c.background_y > 0.0 ? c.peak / c.background_y : std::numeric_limits<double>::infinity();
  return {count, ring_clipped};
}

// Angles from the peak, and the background from the annulus (per-channel medians); the peak's
// contrast against it.
std::string measure_background(const DetectionInput& in, Candidate& c) {
  measure_angles(in, c);
  const auto [ring_count, ring_clipped] =
      ring_background(in, c, in.options.background_inner_deg * kDeg, in.options.background_outer_deg * kDeg);
  if (ring_count < 8) return "too little sky around the brightest pixel to measure its background";
  const bool peak_clipped = is_clipped(in.clipped, c.peak_at);
  // A clipped peak hides the sun's true contrast; a compact clipped blob in an unclipped sky
  // still is a sun (with an energy that is a lower bound).
  const bool clipped_sun = peak_clipped && ring_clipped * 4 < static_cast<int>(ring_count);
  if (c.contrast < in.options.min_contrast && !clipped_sun) {
    return "no compact sun: the brightest pixel is only " + std::to_string(c.contrast) + "× its surroundings (needs " +
           std::to_string(in.options.min_contrast) + "×)";
  }
  return "";
}

// Pixels connected to the peak that pass `bright`, out to `max_angle` from the peak; true in
// `reached_beyond` when the region would have gone further.
template <typename Bright>
std::vector<cv::Point> grow(const Candidate& c, const Bright& bright, double max_angle, bool& reached_beyond) {
  const cv::Rect& window = c.window;
  const cv::Mat& angle = c.angle;
  cv::Mat seen(window.size(), CV_8UC1, cv::Scalar(0));
  std::vector<cv::Point> stack{c.peak_at - window.tl()};
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
}

// Compact: the core (brighter than halfway between background and peak, or clipped) must fit
// in max_angular_radius. A sun's glow or a lossy capture's ringing may spread further; that
// does not make it less of a sun, but a bright cloud whose core is wide is none.
std::string measure_core(const DetectionInput& in, Candidate& c) {
  const double core_threshold = c.background_y + 0.5 * (c.peak - c.background_y);
  bool core_too_wide = false;
  c.core = grow(
      c,
      [&](cv::Point ip) { return luminance(in.radiance.at<cv::Vec3f>(ip)) >= core_threshold || is_clipped(in.clipped, ip); },
      in.options.max_angular_radius_deg * kDeg, core_too_wide);
  if (core_too_wide) {
    return "no compact sun: the bright region around the brightest pixel is wider than " +
           std::to_string(in.options.max_angular_radius_deg) + "°";
  }
  return "";
}

// The disc that goes to the sun term: everything connected that stands well above the
// background, within the halo radius (beyond it the dome carries the light).
void find_disc(const DetectionInput& in, Candidate& c) {
  const double threshold = c.background_y * in.options.disc_factor;
  bool beyond_halo = false;
  c.disc = grow(
      c, [&](cv::Point ip) { return luminance(in.radiance.at<cv::Vec3f>(ip)) > threshold || is_clipped(in.clipped, ip); },
      in.options.halo_radius_deg * kDeg, beyond_halo);
}

// E_sun: the disc's energy above the background; its direction the energy's centroid, its
// angular radius the core's around that direction.
std::string estimate_sun(const DetectionInput& in, const Candidate& c, Sun& sun) {
  const cv::Rect& window = c.window;
  const Eigen::Vector3d& background = c.background;
  Vec3 centroid = Vec3::Zero();
  std::vector<std::pair<Vec3, double>> pixels;  // direction, luminance energy above background
  pixels.reserve(c.disc.size());
  for (const cv::Point& p : c.disc) {
    const cv::Point ip = p + window.tl();
    const Vec3 d = *in.lens.pixel_to_site(Vec2(ip.x, ip.y));
    const double w = block_solid_angle(in.lens, ip.x - 0.5, ip.y - 0.5, ip.x + 0.5, ip.y + 0.5);
    const cv::Vec3f& l = in.radiance.at<cv::Vec3f>(ip);
    const Eigen::Vector3d excess(std::max(0.0, clean(l[2]) - background.x()),
                                 std::max(0.0, clean(l[1]) - background.y()),
                                 std::max(0.0, clean(l[0]) - background.z()));
    sun.energy += w * excess;
    const double energy = w * (0.2126 * excess.x() + 0.7152 * excess.y() + 0.0722 * excess.z());
    centroid += energy * d;
    pixels.emplace_back(d, energy);
    if (!in.clipped.empty() && in.clipped.at<std::uint8_t>(ip)) sun.clipped = true;
  }
  if (centroid.norm() <= 0.0) return "no compact sun: no energy above the background";
  sun.direction = centroid.normalized();
  for (const cv::Point& p : c.core) {
    const cv::Point ip = p + window.tl();
    sun.angular_radius = std::max(sun.angular_radius, angle_between(sun.direction, *in.lens.pixel_to_site(Vec2(ip.x, ip.y))));
  }
  merge_disc(sun, pixels);
  sun.background = background;
  sun.contrast = c.contrast;
  sun.pixel_count = static_cast<int>(c.disc.size());
  return "";
}

// A clipped region's centre (solid-angle weighted), solid angle, reach from the centre (to the
// far edge of its farthest pixel) and roundness: its solid angle over the disc of that reach.
struct BlobShape {
  Vec3 centre = Vec3::UnitZ();
  double area = 0.0, radius = 0.0, roundness = 0.0;
};

BlobShape blob_shape(const camera::Lens& lens, const std::vector<cv::Point>& pixels) {
  BlobShape shape;
  Vec3 sum = Vec3::Zero();
  std::vector<Vec3> directions;
  for (const cv::Point& ip : pixels) {
    const auto d = lens.pixel_to_site(Vec2(ip.x, ip.y));
    if (!d) continue;
    const double w = block_solid_angle(lens, ip.x - 0.5, ip.y - 0.5, ip.x + 0.5, ip.y + 0.5);
    sum += w * *d;
    shape.area += w;
    directions.push_back(*d);
  }
  if (directions.empty() || !(sum.norm() > 0.0)) return shape;
  shape.centre = sum.normalized();
  for (const Vec3& d : directions) shape.radius = std::max(shape.radius, angle_between(shape.centre, d));
  shape.radius += 0.5 * std::sqrt(shape.area / static_cast<double>(directions.size()));  // half a pixel
  shape.roundness = shape.area / (2.0 * std::numbers::pi * (1.0 - std::cos(shape.radius)));
  return shape;
}

std::string not_round(const BlobShape& shape) {
  return "no sun: the clipped region there (reaching " + std::to_string(shape.radius / kDeg) +
         "° from its centre) is not round (it fills " + std::to_string(shape.roundness) +
         " of that disc), a bright cloud rather than a sun";
}

// Without an expectation: the largest clipped region of the sky that is round and no wider than
// max_clipped_radius (the sun's blob, where a metered 8-bit camera also clips a bright horizon or
// cloud); the pixel nearest its centre, or why there is none.
std::optional<cv::Point> round_clipped_region(const DetectionInput& in, std::string& why) {
  cv::Mat mask;
  cv::bitwise_and(in.clipped, in.sky, mask);
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::optional<cv::Point> best;
  double best_area = 0.0;
  why = "no sun: no clipped region of the sky is round and narrower than " + std::to_string(in.options.max_clipped_radius_deg) + "°";
  for (int k = 1; k < count; ++k) {
    const cv::Rect box(stats.at<int>(k, cv::CC_STAT_LEFT), stats.at<int>(k, cv::CC_STAT_TOP), stats.at<int>(k, cv::CC_STAT_WIDTH),
                       stats.at<int>(k, cv::CC_STAT_HEIGHT));
    std::vector<cv::Point> pixels;
    for (int y = box.y; y < box.y + box.height; ++y) {
      for (int x = box.x; x < box.x + box.width; ++x) {
        if (labels.at<int>(y, x) == k) pixels.emplace_back(x, y);
      }
    }
    const BlobShape shape = blob_shape(in.lens, pixels);
    if (shape.radius > in.options.max_clipped_radius_deg * kDeg || shape.roundness < in.options.min_clipped_roundness ||
        shape.area <= best_area) {
      continue;
    }
    best_area = shape.area;
    double nearest = -2.0;
    for (const cv::Point& ip : pixels) {
      const double c = in.lens.pixel_to_site(Vec2(ip.x, ip.y))->dot(shape.centre);
      if (c > nearest) {
        nearest = c;
        best = ip;
      }
    }
  }
  return best;
}

// A clipped blob at `seed` as the sun (SunOptions, "a clipped sun"): the blob no wider than
// max_clipped_radius, round unless expected; its background just outside it; its direction the
// expected one, or the blob's centre; its disc for shadows the sun's own.
std::string detect_clipped(const DetectionInput& in, cv::Point seed, const std::optional<Vec3>& expected, Candidate& c,
                           Sun& sun) {
  const SunOptions& o = in.options;
  c.peak_at = seed;
  c.peak = luminance(in.radiance.at<cv::Vec3f>(seed));
  // The blob, and the background annulus just outside it.
  const double window_deg = o.max_clipped_radius_deg + 1.0 + (o.background_outer_deg - o.background_inner_deg);
  if (std::string reason = place_window(in, c, window_deg); !reason.empty()) return reason;
  measure_angles(in, c);
  bool too_wide = false;
  c.core = grow(c, [&](cv::Point ip) { return is_clipped(in.clipped, ip); }, o.max_clipped_radius_deg * kDeg, too_wide);
  // Without an expectation a clipped region wider than that is an overexposed sky; with one,
  // the sun is where it is expected, in whatever the camera clipped around it.
  if (too_wide && !expected) {
    return "no sun: the clipped region there is wider than " + std::to_string(o.max_clipped_radius_deg) +
           "°, an overexposed sky rather than a sun";
  }
  double reach = 0.0;
  std::vector<cv::Point> blob;
  for (const cv::Point& p : c.core) {
    blob.push_back(p + c.window.tl());
    reach = std::max(reach, c.angle.at<double>(p));
  }
  const BlobShape shape = blob_shape(in.lens, blob);
  if (!expected && shape.roundness < o.min_clipped_roundness) return not_round(shape);
  const double inner = reach + 1.0 * kDeg;
  const auto [ring_count, ring_clipped] =
      ring_background(in, c, inner, inner + (o.background_outer_deg - o.background_inner_deg) * kDeg, expected.has_value());
  if (ring_count < 8 || (!expected && ring_clipped * 4 >= static_cast<int>(ring_count))) {
    return "no sun: too little unclipped sky around the clipped region to measure its background";
  }
  const double threshold = c.background_y * o.disc_factor;
  bool beyond = false;
  c.disc = grow(
      c, [&](cv::Point ip) { return luminance(in.radiance.at<cv::Vec3f>(ip)) > threshold || is_clipped(in.clipped, ip); },
      reach + o.halo_radius_deg * kDeg, beyond);
  if (std::string reason = estimate_sun(in, c, sun); !reason.empty()) return reason;
  sun.direction = expected ? Vec3(expected->normalized()) : shape.centre;
  sun.located_by = expected ? "expected" : "clipped shape";
  sun.clipped = true;
  sun.energy_confidence = 0.0;  // a lower bound, by how much unknown
  // The blob is the camera's, not the sun's: shadows take the sun's own disc.
  sun.angular_radius = sun.shadow_radius = kSunAngularRadius;
  sun.disc_directions = {sun.direction};
  sun.disc_weights = {1.0};
  return "";
}

// The clipped sky pixel nearest `expected`, when one lies within the tolerance.
std::optional<cv::Point> clipped_near(const DetectionInput& in, const Vec3& expected) {
  const Vec3 e = expected.normalized();
  const double min_cos = std::cos(in.options.expected_tolerance_deg * kDeg);
  std::optional<cv::Point> best;
  double best_cos = min_cos;
  for (int y = 0; y < in.clipped.rows; ++y) {
    const auto* clipped = in.clipped.ptr<std::uint8_t>(y);
    const auto* sky = in.sky.ptr<std::uint8_t>(y);
    for (int x = 0; x < in.clipped.cols; ++x) {
      if (!clipped[x] || !sky[x]) continue;
      const auto d = in.lens.pixel_to_site(Vec2(x, y));
      if (d && d->dot(e) >= best_cos) {
        best_cos = d->dot(e);
        best = cv::Point(x, y);
      }
    }
  }
  return best;
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

SunDetection SunDetector::detect(const cv::Mat& radiance, const cv::Mat& clipped, const std::optional<Vec3>& expected) const {
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
  if (expected && (!expected->allFinite() || !(expected->norm() > 0.0))) {
    throw std::invalid_argument("SunDetector::detect: the expected sun direction is zero or not finite");
  }
  SunDetection result;
  const DetectionInput in{radiance, clipped, sky_, *lens_, options_};
  const auto found = [&](const Candidate& candidate, const Sun& sun, std::string reason) {
    result.mask = cv::Mat(radiance.size(), CV_8UC1, cv::Scalar(0));
    for (const cv::Point& p : candidate.disc) result.mask.at<std::uint8_t>(p + candidate.window.tl()) = 255;
    result.reason = std::move(reason);
    result.sun = sun;
    return result;
  };
  // A clipped blob where the location and time put the sun is the sun, however wide.
  if (expected && !clipped.empty() && expected->z() > 0.0) {
    if (const std::optional<cv::Point> seed = clipped_near(in, *expected)) {
      Candidate candidate;
      Sun sun;
      const std::string reason = detect_clipped(in, *seed, expected, candidate, sun);
      if (reason.empty()) return found(candidate, sun, "clipped sun where the location and time put it: its energy is estimated");
      result.reason = reason;
      return result;
    }
  }
  Candidate candidate;
  result.reason = find_candidate(in, candidate);
  if (result.reason.empty()) result.reason = measure_background(in, candidate);
  if (result.reason.empty()) result.reason = measure_core(in, candidate);
  // A clipped peak that is no compact sun (a clipped frame's brightest pixel is any clipped
  // pixel): without a time, the round clipped region is the sun.
  if (!result.reason.empty() && !expected && candidate.peak_at.x >= 0 && is_clipped(clipped, candidate.peak_at)) {
    std::string why;
    if (const std::optional<cv::Point> seed = round_clipped_region(in, why)) {
      Candidate blob;
      Sun sun;
      const std::string reason = detect_clipped(in, *seed, std::nullopt, blob, sun);
      if (reason.empty()) return found(blob, sun, "clipped sun, found by the clipped region's shape: its energy is estimated");
      result.reason = reason;
    } else {
      result.reason = why;
    }
  }
  if (!result.reason.empty()) return result;
  find_disc(in, candidate);
  Sun sun;
  result.reason = estimate_sun(in, candidate, sun);
  if (!result.reason.empty()) return result;
  if (sun.clipped) sun.energy_confidence = 0.0;
  return found(candidate, sun,
               sun.clipped ? "compact sun, clipped: its energy is a lower bound and shadows come out too weak" : "compact sun");
}

Eigen::Vector3d daylight_sun_colour(double elevation) {
  const double degrees = std::clamp(elevation * 180.0 / std::numbers::pi, 0.0, 90.0);
  // Kasten and Young's air mass; at the horizon about 38.
  const double air_mass = 1.0 / (std::sin(degrees * std::numbers::pi / 180.0) + 0.50572 * std::pow(degrees + 6.07995, -1.6364));
  const std::array<double, 3> wavelength_um{0.610, 0.550, 0.465};
  Eigen::Vector3d colour;
  for (int c = 0; c < 3; ++c) {
    const double l = wavelength_um[static_cast<std::size_t>(c)];
    const double planck = std::pow(l, -5.0) / std::expm1(14388.0 / (l * 5800.0));
    const double rayleigh = 0.008735 * std::pow(l, -4.08), aerosol = 0.1 * std::pow(l, -1.3);
    colour[c] = planck * std::exp(-air_mass * (rayleigh + aerosol));
  }
  return colour / colour.maxCoeff();
}

bool plausible_sun_colour(const Eigen::Vector3d& energy) {
  if (!energy.allFinite() || !(energy.maxCoeff() > 0.0) || energy.minCoeff() < 0.0) return false;
  const double r = energy.x(), g = energy.y(), b = energy.z();
  return g >= 0.2 * r && r >= 0.7 * g && b <= 1.3 * g;
}

bool correct_sun_colour(Sun& sun) {
  if (plausible_sun_colour(sun.energy)) return false;
  Eigen::Vector3d measured = sun.energy;
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(measured[c]) || measured[c] < 0.0) measured[c] = 0.0;
  }
  const double brightest = measured.maxCoeff();
  if (!(brightest > 0.0)) return false;  // no light: nothing to colour
  const Eigen::Vector3d colour = daylight_sun_colour(std::asin(std::clamp(sun.direction.normalized().z(), -1.0, 1.0)));
  sun.measured_energy = sun.energy;
  sun.energy = colour * brightest;
  sun.colour_corrected = true;
  return true;
}

}  // namespace skylit::sky
