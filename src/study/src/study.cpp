#include "skylit/study/study.hpp"

#include <algorithm>
#include <stdexcept>
#include <cmath>
#include <numbers>
#include <cstdint>
#include <random>

#include "skylit/baker/visibility.hpp"
#include "skylit/base/files.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::study {

namespace fs = std::filesystem;

Errors errors_of(std::vector<double> diffs) {
  Errors e;
  if (diffs.empty()) return e;
  double sum = 0;
  for (double d : diffs) sum += d * d;
  e.rms = std::sqrt(sum / static_cast<double>(diffs.size()));
  const auto at = diffs.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(diffs.size() - 1));
  std::nth_element(diffs.begin(), at, diffs.end());
  e.p99 = *at;
  e.max = *std::max_element(diffs.begin(), diffs.end());
  return e;
}

Errors errors_of(std::span<const double> diffs, std::span<const double> weights) {
  if (diffs.size() != weights.size()) throw std::invalid_argument("errors_of: one weight per diff");
  std::vector<std::pair<double, double>> sorted;
  double total = 0, sum = 0;
  for (std::size_t k = 0; k < diffs.size(); ++k) {
    if (!(weights[k] > 0)) continue;
    sorted.emplace_back(diffs[k], weights[k]);
    total += weights[k];
    sum += weights[k] * diffs[k] * diffs[k];
  }
  Errors e;
  if (sorted.empty()) return e;
  std::sort(sorted.begin(), sorted.end());
  e.rms = std::sqrt(sum / total);
  e.max = sorted.back().first;
  double below = 0;
  for (const auto& [d, w] : sorted) {
    below += w;
    e.p99 = d;
    if (below >= 0.99 * total) break;
  }
  return e;
}

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2), values.end());
  return values[values.size() / 2];
}

double luminance(const Eigen::Vector3d& rgb) { return rgb.dot(Eigen::Vector3d(0.2126, 0.7152, 0.0722)); }
double degrees_between(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI; }

double EquirectSun::energy_within(double radius_deg, const cv::Mat& equirect) const {
  double e = 0;
  for (int row = 0; row < equirect.rows; ++row) {
    const double omega = sky::equirect_pixel_solid_angle(equirect.cols, equirect.rows, row);
    for (int col = 0; col < equirect.cols; ++col) {
      const Vec3 d = sky::equirect_direction(equirect.cols, equirect.rows, col, row);
      if (d.z() <= 0.0 || degrees_between(d, peak) > radius_deg) continue;
      const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
      e += std::max(0.0, luminance(Eigen::Vector3d(l[2], l[1], l[0]) - background)) * omega;
    }
  }
  return e;
}

EquirectSun equirect_sun(const cv::Mat& equirect) {
  EquirectSun sun;
  double best = 0;
  std::vector<double> all;
  for (int row = 0; row < equirect.rows; ++row) {
    for (int col = 0; col < equirect.cols; ++col) {
      const Vec3 d = sky::equirect_direction(equirect.cols, equirect.rows, col, row);
      if (d.z() <= 0.0) continue;
      const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
      const double y = luminance(Eigen::Vector3d(l[2], l[1], l[0]));
      all.push_back(y);
      if (y > best) {
        best = y;
        sun.peak = d;
      }
    }
  }
  std::nth_element(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(all.size() / 2), all.end());
  sun.found = best > 100.0 * all[all.size() / 2];  // as basis_study: 100× the median
  if (!sun.found) return sun;
  std::vector<double> ring[3];
  for (int row = 0; row < equirect.rows; ++row) {
    for (int col = 0; col < equirect.cols; ++col) {
      const Vec3 d = sky::equirect_direction(equirect.cols, equirect.rows, col, row);
      const double angle = degrees_between(d, sun.peak);
      if (d.z() <= 0.0 || angle < 6.0 || angle > 15.0) continue;
      const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
      for (int c = 0; c < 3; ++c) ring[c].push_back(l[2 - c]);
    }
  }
  for (int c = 0; c < 3; ++c) {
    std::nth_element(ring[c].begin(), ring[c].begin() + static_cast<std::ptrdiff_t>(ring[c].size() / 2), ring[c].end());
    sun.background[c] = ring[c][ring[c].size() / 2];
  }
  Vec3 centroid = Vec3::Zero();
  double total = 0;
  for (int row = 0; row < equirect.rows; ++row) {
    const double omega = sky::equirect_pixel_solid_angle(equirect.cols, equirect.rows, row);
    for (int col = 0; col < equirect.cols; ++col) {
      const Vec3 d = sky::equirect_direction(equirect.cols, equirect.rows, col, row);
      if (d.z() <= 0.0 || degrees_between(d, sun.peak) > kOracleRadiusDeg) continue;
      const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
      const Eigen::Vector3d above = (Eigen::Vector3d(l[2], l[1], l[0]) - sun.background).cwiseMax(0.0) * omega;
      sun.energy += above;
      sun.directions.push_back(d);
      sun.weights.push_back(luminance(above));
      sun.pixels.emplace_back(row, col);
      centroid += luminance(above) * d;
      total += luminance(above);
    }
  }
  for (double& w : sun.weights) w /= total;
  sun.centroid = centroid.normalized();
  return sun;
}

GroundView real_ground_view(const cv::Mat& equirect, const Vec3& sun, double occluder_deg) {
  GroundView view;
  const Vec3 towards = sun.normalized();
  for (int row = 0; row < equirect.rows; ++row) {
    const double omega = sky::equirect_pixel_solid_angle(equirect.cols, equirect.rows, row);
    for (int col = 0; col < equirect.cols; ++col) {
      const Vec3 d = sky::equirect_direction(equirect.cols, equirect.rows, col, row);
      if (d.z() <= 0.0) continue;
      const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
      const Eigen::Vector3d e = Eigen::Vector3d(l[2], l[1], l[0]).cwiseMax(0.0) * omega * d.z();
      view.lit_irradiance += e;
      if (degrees_between(d, towards) > occluder_deg) view.shadowed_irradiance += e;
    }
  }
  constexpr int kWidth = 160, kHeight = 100;
  constexpr double kAlbedo = 0.2;
  // Exposed for its brightest channel (a sun of one colour would clip the others' median).
  const double exposure = 0.5 / (kAlbedo / std::numbers::pi * view.lit_irradiance.maxCoeff());
  cv::Mat radiance(kHeight, kWidth, CV_32FC3);
  std::mt19937 random(11);
  std::uniform_real_distribution<double> texture(0.85, 1.15);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const Eigen::Vector3d& e = x < kWidth / 2 ? view.lit_irradiance : view.shadowed_irradiance;
      const Eigen::Vector3d l = texture(random) * kAlbedo / std::numbers::pi * e;
      radiance.at<cv::Vec3f>(y, x) = cv::Vec3f(static_cast<float>(l.z()), static_cast<float>(l.y()), static_cast<float>(l.x()));
    }
  }
  view.linear = sky::linearise(sky::to_8bit(radiance, exposure), sky::ResponseCurve::srgb(8), {}).radiance;
  view.lit = cv::Mat(kHeight, kWidth, CV_8U, cv::Scalar(0));
  view.shadowed = view.lit.clone();
  view.lit(cv::Rect(0, 0, kWidth / 2, kHeight)).setTo(255);
  view.shadowed(cv::Rect(kWidth / 2, 0, kWidth / 2, kHeight)).setTo(255);
  return view;
}

fs::path coarse_site(const fs::path& site_file, int scale, const fs::path& dir) {
  scene::Site site = scene::load_site(site_file);
  for (auto& p : site.planes) {
    p.width = std::max(4, p.width / scale);
    p.height = std::max(4, p.height / scale);
  }
  site.model = fs::absolute(site.model);
  site.root = site.model.parent_path();  // the coarse copy lies elsewhere; its model stays where it is
  const fs::path out = dir / "site.yaml";
  write_file_atomic(out, scene::site_to_yaml(site));
  return out;
}

cv::Mat read_clean_sky(const fs::path& file) {
  cv::Mat equirect = sky::read_sky_image(file);
  for (int row = 0; row < equirect.rows; ++row) {
    for (auto* p = equirect.ptr<float>(row), *end = p + 3 * equirect.cols; p != end; ++p) {
      *p = std::isfinite(*p) && *p > 0.0f ? *p : 0.0f;
    }
  }
  return equirect;
}

EquirectLights equirect_lights(const cv::Mat& equirect, int supersample) {
  EquirectLights lights;
  std::vector<Vec3>& directions = lights.directions;
  std::vector<Eigen::Vector3d>& weights = lights.weights;
  cv::Mat near_bright(equirect.size(), CV_8UC1, cv::Scalar(0));
  if (supersample > 1) {
    std::vector<double> all;
    for (int row = 0; row < equirect.rows / 2; ++row) {
      for (int col = 0; col < equirect.cols; ++col) {
        const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
        all.push_back(luminance(Eigen::Vector3d(l[2], l[1], l[0])));
      }
    }
    std::nth_element(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(all.size() / 2), all.end());
    const double median_y = all[all.size() / 2];
    for (int row = 0; row < equirect.rows; ++row) {
      for (int col = 0; col < equirect.cols; ++col) {
        const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
        if (luminance(Eigen::Vector3d(l[2], l[1], l[0])) <= kBrightOverMedian * median_y) continue;
        for (int dy = -2; dy <= 2; ++dy) {
          for (int dx = -2; dx <= 2; ++dx) {
            near_bright.at<std::uint8_t>(std::clamp(row + dy, 0, equirect.rows - 1),
                                         (col + dx + equirect.cols) % equirect.cols) = 255;
          }
        }
      }
    }
  }
  const auto bilinear = [&](double x, double y) {
    const int w = equirect.cols, h = equirect.rows;
    const double fx = std::floor(x), fy = std::floor(y);
    const double tx = x - fx, ty = y - fy;
    const int x0 = (static_cast<int>(fx) % w + w) % w, x1 = (x0 + 1) % w;
    const int y0 = std::clamp(static_cast<int>(fy), 0, h - 1), y1 = std::clamp(static_cast<int>(fy) + 1, 0, h - 1);
    Eigen::Vector3d rgb;
    for (int ch = 0; ch < 3; ++ch) {
      const double top = (1 - tx) * equirect.at<cv::Vec3f>(y0, x0)[ch] + tx * equirect.at<cv::Vec3f>(y0, x1)[ch];
      const double bottom = (1 - tx) * equirect.at<cv::Vec3f>(y1, x0)[ch] + tx * equirect.at<cv::Vec3f>(y1, x1)[ch];
      rgb[2 - ch] = (1 - ty) * top + ty * bottom;
    }
    return rgb;
  };
  for (int row = 0; row < equirect.rows; ++row) {
    const double solid_angle = sky::equirect_pixel_solid_angle(equirect.cols, equirect.rows, row);
    for (int col = 0; col < equirect.cols; ++col) {
      if (near_bright.at<std::uint8_t>(row, col)) {
        ++lights.supersampled;
        const int n = supersample;
        for (int j = 0; j < n; ++j) {
          const double y = row - 0.5 + (j + 0.5) / n;
          // Solid angle of the sub-row: the band between its edges, split over n columns.
          const double top = M_PI / 2 - M_PI * (y + 0.5 - 0.5 / n) / equirect.rows;
          const double bottom = M_PI / 2 - M_PI * (y + 0.5 + 0.5 / n) / equirect.rows;
          const double sub_angle = 2.0 * M_PI / equirect.cols / n * (std::sin(top) - std::sin(bottom));
          for (int i = 0; i < n; ++i) {
            const double x = col - 0.5 + (i + 0.5) / n;
            const Vec3 d = sky::equirect_direction(equirect.cols, equirect.rows, x, y);
            if (d.z() <= 0.0) continue;
            directions.push_back(d);
            weights.push_back(bilinear(x, y) * sub_angle);
          }
        }
        continue;
      }
      const Vec3 d = sky::equirect_direction(equirect.cols, equirect.rows, col, row);
      if (d.z() <= 0.0) continue;
      const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
      directions.push_back(d);
      weights.emplace_back(l[2] * solid_angle, l[1] * solid_angle, l[0] * solid_angle);
    }
  }
  return lights;
}

DenseReference dense_reference(const cv::Mat& equirect, const scene::Site& site, const scene::Mesh& mesh,
                               int reference_supersample) {
  return dense_reference(equirect_lights(equirect, reference_supersample), site, mesh);
}

DenseReference dense_reference(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh) {
  DenseReference reference;
  reference.supersampled = lights.supersampled;
  const std::vector<Vec3>& directions = lights.directions;
  const std::vector<Eigen::Vector3d>& weights = lights.weights;
  const auto t = Clock::now();
  for (const auto& plane : site.planes) {
    std::vector<Eigen::Vector3d> visible(static_cast<std::size_t>(plane.width) * plane.height);
    baker::weighted_plane_visibility(mesh, plane, directions, weights, visible);
    Eigen::Vector3d total = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < directions.size(); ++k) total += std::max(0.0, plane.normal().dot(directions[k])) * weights[k];
    for (auto& v : visible) {
      for (int c = 0; c < 3; ++c) v[c] = total[c] > 0.0 ? v[c] / total[c] : 1.0;
    }
    reference.planes.push_back(std::move(visible));
    reference.totals.push_back(total);
  }  reference.seconds = seconds_since(t);
  return reference;
}

double sequence_time(const SequenceOptions& options, int frame) { return frame * options.interval_s; }

double sequence_dimming(const SequenceOptions& options, int frame) {
  const double duration = options.frames * options.interval_s;
  const double a = 0.25 * duration, b = 0.75 * duration, t = sequence_time(options, frame);
  if (t <= a || t >= b) return 1.0;
  return 1.0 - options.cloud * 0.5 * (1.0 - std::cos(2.0 * M_PI * (t - a) / (b - a)));
}

sky::SkyFunction sequence_sky(const SequenceOptions& options, int frame) {
  sky::AnalyticSkySettings settings;
  settings.kind = sky::AnalyticSkySettings::Kind::Clear;
  settings.turbidity = options.turbidity;
  settings.latitude_deg = options.latitude_deg;
  settings.longitude_deg = options.longitude_deg;
  const auto utc = options.start + std::chrono::seconds(static_cast<long long>(std::lround(sequence_time(options, frame))));
  sky::SkyFunction clear = sky::analytic_sky(settings, utc);
  const double d = sequence_dimming(options, frame), sky_scale = 0.7 + 0.3 * d;
  sky::SkyFunction out;
  out.sky = [f = std::move(clear.sky), sky_scale](const Vec3& direction) -> Eigen::Vector3d { return sky_scale * f(direction); };
  out.sun = clear.sun;
  if (out.sun) out.sun->irradiance *= d;
  return out;
}

namespace {

// Σ_p L_p Ω_p max(0, n·ω_p) V(x, ω_p) per texel of every plane, and Σ_p L_p Ω_p max(0, n·ω_p) per
// plane, over the pixels of `equirect` above the horizon.
struct ReferenceSums {
  std::vector<std::vector<Eigen::Vector3d>> visible;
  std::vector<Eigen::Vector3d> total;
};

ReferenceSums reference_sums(const cv::Mat& equirect, const scene::Site& site, const scene::Mesh& mesh) {
  const EquirectLights lights = equirect_lights(equirect, 1);
  const std::vector<Vec3>& directions = lights.directions;
  const std::vector<Eigen::Vector3d>& weights = lights.weights;
  ReferenceSums sums;
  for (const auto& plane : site.planes) {
    std::vector<Eigen::Vector3d> visible(static_cast<std::size_t>(plane.width) * plane.height);
    baker::weighted_plane_visibility(mesh, plane, directions, weights, visible);
    Eigen::Vector3d total = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < directions.size(); ++k) total += std::max(0.0, plane.normal().dot(directions[k])) * weights[k];
    sums.visible.push_back(std::move(visible));
    sums.total.push_back(total);
  }
  return sums;
}

// The sun's disc as directions with equal weights: a 9 × 9 grid (odd rows shifted by a quarter step) over the square around it, the
// points within its angular radius.
std::vector<Vec3> disc_directions(const sky::SunDisc& sun) {
  const Vec3 c = sun.direction.normalized();
  const Vec3 e1 = (std::abs(c.z()) < 0.9 ? c.cross(Vec3::UnitZ()) : c.cross(Vec3::UnitX())).normalized();
  const Vec3 e2 = c.cross(e1);
  std::vector<Vec3> out;
  const double r = std::tan(sun.angular_radius);
  for (int i = -4; i <= 4; ++i) {
    for (int j = -4; j <= 4; ++j) {
      const double x = (i + 0.5 * (j % 2 != 0 ? 0.5 : 0.0)) / 4.5, y = j / 4.5;
      if (x * x + y * y > 1.0) continue;
      out.push_back((c + r * (x * e1 + y * e2)).normalized());
    }
  }
  return out;
}

}  // namespace

SequenceReference sequence_reference(const SequenceOptions& options, const scene::Site& site, const scene::Mesh& mesh,
                                     int equirect_width, double key_interval_s) {
  SequenceReference reference;
  const auto t = Clock::now();
  // Key frames of the sky part: every key_interval_s, and the last frame.
  const int step = std::max(1, static_cast<int>(std::lround(key_interval_s / options.interval_s)));
  std::vector<int> keys;
  for (int k = 0; k < options.frames - 1; k += step) keys.push_back(k);
  keys.push_back(std::max(0, options.frames - 1));
  std::vector<ReferenceSums> key_sums;
  for (int k : keys) {
    sky::SkyFunction f = sequence_sky(options, k);
    const double sky_scale = 0.7 + 0.3 * sequence_dimming(options, k);
    f.sun.reset();
    const auto unscaled = [g = f.sky, sky_scale](const Vec3& d) -> Eigen::Vector3d { return g(d) / sky_scale; };
    const cv::Mat equirect = sky::render_equirect({unscaled, std::nullopt}, equirect_width, equirect_width / 2, {.supersample = 2});
    key_sums.push_back(reference_sums(equirect, site, mesh));
  }
  for (int k = 0; k < options.frames; ++k) {
    std::size_t a = 0;
    while (a + 1 < keys.size() && keys[a + 1] <= k) ++a;
    const std::size_t b = std::min(a + 1, keys.size() - 1);
    const double u = keys[b] == keys[a] ? 0.0 : static_cast<double>(k - keys[a]) / (keys[b] - keys[a]);
    const double sky_scale = 0.7 + 0.3 * sequence_dimming(options, k);
    const sky::SkyFunction f = sequence_sky(options, k);
    std::vector<std::vector<Eigen::Vector3d>> planes;
    for (std::size_t j = 0; j < site.planes.size(); ++j) {
      const geom::Plane& plane = site.planes[j];
      std::vector<Eigen::Vector3d> T(key_sums[a].visible[j].size());
      Eigen::Vector3d total = sky_scale * ((1 - u) * key_sums[a].total[j] + u * key_sums[b].total[j]);
      for (std::size_t x = 0; x < T.size(); ++x) T[x] = sky_scale * ((1 - u) * key_sums[a].visible[j][x] + u * key_sums[b].visible[j][x]);
      if (f.sun && f.sun->direction.z() > 0.0) {
        const double cosine = std::max(0.0, plane.normal().dot(f.sun->direction.normalized()));
        if (cosine > 0.0) {
          const std::vector<Vec3> disc = disc_directions(*f.sun);
          const std::vector<double> w(disc.size(), 1.0);
          std::vector<float> v(T.size());
          baker::area_light_visibility(mesh, plane, disc, w, v);
          const Eigen::Vector3d e = f.sun->irradiance * cosine;
          for (std::size_t x = 0; x < T.size(); ++x) T[x] += e * static_cast<double>(v[x]);
          total += e;
        }
      }
      for (auto& value : T) {
        for (int c = 0; c < 3; ++c) value[c] = total[c] > 0.0 ? value[c] / total[c] : 1.0;
      }
      planes.push_back(std::move(T));
    }
    reference.frames.push_back(std::move(planes));
  }
  reference.seconds = seconds_since(t);
  return reference;
}

camera::CameraCalibration scaled_camera(const fs::path& calibration_file, int width, int height) {
  camera::CameraCalibration c = camera::load_calibration(calibration_file);
  const double s = static_cast<double>(width) / c.image_width;
  c.fx *= s;
  c.fy *= s;
  c.cx = (width - 1) / 2.0;   // centred, whatever the aspect ratio
  c.cy = (height - 1) / 2.0;
  c.image_width = width;
  c.image_height = height;
  return c;
}

render::CameraPose visitor_pose() {
  const Eigen::Vector3d eye(0.0, -kVisitorDistance, 1.6);
  const Eigen::Vector3d forward = (Eigen::Vector3d(0.0, 0.0, 3.0) - eye).normalized();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  render::CameraPose pose;
  pose.R_site_from_camera.col(0) = right;
  pose.R_site_from_camera.col(1) = forward.cross(right);  // down
  pose.R_site_from_camera.col(2) = forward;
  pose.t_site_from_camera = eye;
  return pose;
}

BenchSources bench_sources(const Eigen::Vector3d& sun, int count, const Eigen::Vector3d& lamp_energy) {
  BenchSources out;
  out.discs.push_back({sun, 0.0047});
  for (int k = 1; k < count; ++k) {
    const double az = k * 137.5 * std::numbers::pi / 180, el = (35.0 + 4.0 * ((k * 7) % 11)) * std::numbers::pi / 180;
    const Eigen::Vector3d d(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el));
    out.discs.push_back({d, 2.0 * std::numbers::pi / 180});
    out.lamps.push_back({d, lamp_energy});
  }
  return out;
}

}  // namespace skylit::study
