#include "study/study.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "skylit/baker/visibility.hpp"
#include "skylit/base/files.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"

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

fs::path coarse_site(const fs::path& site_file, int scale, const fs::path& dir) {
  scene::Site site = scene::load_site(site_file);
  for (auto& p : site.planes) {
    p.width = std::max(4, p.width / scale);
    p.height = std::max(4, p.height / scale);
  }
  site.model = fs::absolute(site.model);
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

DenseReference dense_reference(const cv::Mat& equirect, const scene::Site& site, const scene::Mesh& mesh,
                               int reference_supersample) {
  DenseReference reference;
  std::vector<Vec3> directions;
  std::vector<Eigen::Vector3d> weights;
  cv::Mat near_bright(equirect.size(), CV_8UC1, cv::Scalar(0));
  if (reference_supersample > 1) {
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
        ++reference.supersampled;
        const int n = reference_supersample;
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
  }  reference.seconds = seconds_since(t);
  return reference;
}

sky::CameraCalibration scaled_camera(const fs::path& calibration_file, int width, int height) {
  sky::CameraCalibration c = sky::load_calibration(calibration_file);
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

}  // namespace skylit::study
