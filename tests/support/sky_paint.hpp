#pragma once
// Sky directions by azimuth and elevation, the angle between two, and a sky painted into a
// calibrated fisheye: shared by the sky stage's tests (sun, sources) and the end-to-end ones.
#include <cmath>
#include <functional>
#include <numbers>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "skylit/geom/dome.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::test {

// Site frame (x east, y north, z up); azimuth from north towards east, degrees.
inline geom::Vec3 from_angles(double azimuth_deg, double elevation_deg) {
  const double az = azimuth_deg * std::numbers::pi / 180.0, el = elevation_deg * std::numbers::pi / 180.0;
  return {std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)};
}

inline double angle(const geom::Vec3& a, const geom::Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

// The float BGR frame the lens sees of a sky of radiance(direction) (RGB, linear); pixels that
// see no direction are 0.
inline cv::Mat paint_sky(const camera::Lens& lens, const std::function<Eigen::Vector3d(const geom::Vec3&)>& radiance) {
  const camera::CameraCalibration& c = lens.calibration();
  cv::Mat image(c.image_height, c.image_width, CV_32FC3, cv::Scalar(0, 0, 0));
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const auto d = lens.pixel_to_site(camera::Vec2(x, y));
      if (!d) continue;
      const Eigen::Vector3d l = radiance(*d);
      image.at<cv::Vec3f>(y, x) = cv::Vec3f(static_cast<float>(l.z()), static_cast<float>(l.y()), static_cast<float>(l.x()));
    }
  }
  return image;
}

}  // namespace skylit::test
