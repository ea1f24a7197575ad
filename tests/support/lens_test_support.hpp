#pragma once
// Shared by the calibration, sky-table and luminance tests: the sample sky camera and its
// (cached) sky tables.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <numbers>
#include <string>
#include <unistd.h>

#include <opencv2/core.hpp>

#include "skylit/geom/dome.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/sky_table.hpp"

namespace skylit::sky::lens_testing {

inline std::filesystem::path sample_calibration_file() {
  return std::filesystem::path(SKYLIT_SOURCE_DIR) / "config" / "sky_camera.yaml";
}

// An ideal equidistant fisheye looking at the zenith, `size`² pixels, centred, whose image edge
// (half the side from the centre) lies `edge_degrees` from the optical axis.
inline camera::CameraCalibration equidistant(int size, double edge_degrees) {
  camera::CameraCalibration c;
  c.image_width = size;
  c.image_height = size;
  c.model = camera::LensModel::Fisheye;
  c.cx = c.cy = (size - 1) / 2.0;
  c.fx = c.fy = (size / 2.0) / (edge_degrees * std::numbers::pi / 180.0);
  c.D = {0, 0, 0, 0};
  return c;
}

// Rotation about the site's x axis (east) by `degrees`: tilts an upward camera towards south.
inline Eigen::Matrix3d tilt_about_east(double degrees) {
  const double a = degrees * std::numbers::pi / 180.0;
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a);
  return R;
}

// 0 outside the disc of `radius` pixels around the image centre.
inline cv::Mat disc_mask(const camera::CameraCalibration& c, double radius) {
  cv::Mat mask(c.image_height, c.image_width, CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < c.image_height; ++y) {
    for (int x = 0; x < c.image_width; ++x) {
      if (std::hypot(x - c.cx, y - c.cy) <= radius) mask.at<std::uint8_t>(y, x) = 255;
    }
  }
  return mask;
}

// The sample calibration (config/sky_camera.yaml), domes and the sample tables, built once per
// test program: a 1024² table takes a noticeable fraction of a second and many tests read it.
inline const camera::Lens& sample_lens() {
  static const camera::Lens lens(camera::load_calibration(sample_calibration_file()));
  return lens;
}
inline const geom::Dome& dome(int frequency) {
  static std::map<int, geom::Dome> cache;  // the tests run on one thread
  auto it = cache.find(frequency);
  if (it == cache.end()) it = cache.emplace(frequency, geom::Dome(frequency)).first;
  return it->second;
}
inline const SkyTable& sample_table(int frequency, int step) {
  static std::map<std::pair<int, int>, SkyTable> cache;
  const std::pair<int, int> key(frequency, step);
  auto it = cache.find(key);
  if (it == cache.end()) {
    SkyTableOptions options;
    options.step = step;
    it = cache.emplace(key, build_sky_table(sample_lens(), dome(frequency), options)).first;
  }
  return it->second;
}

// A frame whose every pixel holds f(site direction of the pixel centre) (f gives R G B; the frame
// is BGR), 0 where the lens model does not reach.
template <typename F>
cv::Mat frame_of(const camera::Lens& lens, F f) {
  const camera::CameraCalibration& c = lens.calibration();
  cv::Mat frame(c.image_height, c.image_width, CV_32FC3, cv::Scalar(0, 0, 0));
  for (int y = 0; y < c.image_height; ++y) {
    auto* row = frame.ptr<cv::Vec3f>(y);
    for (int x = 0; x < c.image_width; ++x) {
      if (const std::optional<Vec3> d = lens.pixel_to_site(Vec2(x, y))) {
        const Eigen::Vector3d value = f(*d);
        row[x] = cv::Vec3f(static_cast<float>(value.z()), static_cast<float>(value.y()), static_cast<float>(value.x()));
      }
    }
  }
  return frame;
}

}  // namespace skylit::sky::lens_testing
