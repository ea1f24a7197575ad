// The lens models: fisheye (Kannala–Brandt) and pinhole (OpenCV's radial and tangential
// distortion), projected and inverted by Newton's method within their monotonic range.
#include "skylit/camera/lens.hpp"

#include <algorithm>
#include <cstdio>
#include <string>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/LU>

#include "skylit/base/error.hpp"

namespace skylit::camera {
namespace {

constexpr double kNewtonTolerance = 1e-15;   // radians, or normalised image units
constexpr int kNewtonIterations = 100;
constexpr int kMonotonicScanSteps = 4096;  // grid for the first turning point of θ_d(θ)

// ---------------------------------------------------------------------------------------------
// Lens model helpers.

// θ_d(θ) = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸) and its derivative.
double fisheye_distort(const std::vector<double>& k, double theta) { return lens_model::fisheye_distort(k, theta); }
double fisheye_slope(const std::vector<double>& k, double theta) {
  const double t2 = theta * theta;
  return 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
}

// Radial factor g(r²) of the pinhole model (rational when 8 coefficients) and dg/d(r²).
struct Radial {
  double g, dg, denominator;
};
Radial pinhole_radial(const std::vector<double>& D, double r2) {
  const double k1 = D[0], k2 = D[1], k3 = D[4];
  const double num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double dnum = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
  double den = 1.0, dden = 0.0;
  if (D.size() >= 8) {
    const double k4 = D[5], k5 = D[6], k6 = D[7];
    den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
    dden = k4 + r2 * (2.0 * k5 + r2 * 3.0 * k6);
  }
  return {num / den, (dnum * den - num * dden) / (den * den), den};
}

// d(r·g(r²))/dr, the slope of the pinhole's radial mapping (tangential terms left out: they do
// not fold the image).
bool pinhole_increasing(const std::vector<double>& D, double r) {
  const Radial radial = pinhole_radial(D, r * r);
  return radial.denominator > 0 && radial.g + 2.0 * r * r * radial.dg > 0;
}

// Normalised image point of a normalised pinhole point (x', y') and its Jacobian.
Vec2 pinhole_distort(const std::vector<double>& D, const Vec2& p, Eigen::Matrix2d* jacobian) {
  const double x = p.x(), y = p.y();
  const double p1 = D[2], p2 = D[3];
  const double r2 = x * x + y * y;
  const Radial radial = pinhole_radial(D, r2);
  const Vec2 out = lens_model::pinhole_distort(D, x, y);
  if (jacobian) {
    const double cross = 2.0 * x * y * radial.dg + 2.0 * p1 * x + 2.0 * p2 * y;
    (*jacobian) << radial.g + 2.0 * x * x * radial.dg + 2.0 * p1 * y + 6.0 * p2 * x, cross, cross,
        radial.g + 2.0 * y * y * radial.dg + 6.0 * p1 * y + 2.0 * p2 * x;
  }
  return out;
}

// Largest θ in (0, limit] up to which `increasing(θ)` holds throughout: a scan for the first
// failure, then bisection to the turning point.
template <typename Increasing>
double monotonic_limit(double limit, Increasing increasing) {
  double previous = 0.0;
  for (int i = 1; i <= kMonotonicScanSteps; ++i) {
    const double theta = limit * i / kMonotonicScanSteps;
    if (!increasing(theta)) {
      double lo = previous, hi = theta;
      for (int k = 0; k < 60; ++k) {
        const double mid = 0.5 * (lo + hi);
        (increasing(mid) ? lo : hi) = mid;
      }
      return lo;
    }
    previous = theta;
  }
  return limit;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

Lens::Lens(const CameraCalibration& calibration) : calibration_(calibration) {
  validate(calibration_);
  camera_from_site_ = calibration_.R_site_from_camera.transpose();
  const std::vector<double>& D = calibration_.D;
  if (calibration_.model == LensModel::Fisheye) {
    max_theta_ = monotonic_limit(std::numbers::pi,
                                 [&](double theta) { return fisheye_slope(D, theta) > 0; });
  } else {
    // Up to the first turn of the radial mapping r·g(r²), r = tan θ; never beyond the image plane.
    max_theta_ = monotonic_limit(std::numbers::pi / 2 * (1.0 - 1e-9), [&](double theta) {
      return pinhole_increasing(D, std::tan(theta));
    });
  }
  check_describes_a_camera();
}

void Lens::check_describes_a_camera() const {
  const CameraCalibration& c = calibration_;
  const auto fail = [&](const std::string& field, const std::string& problem, const std::string& fix) {
    throw InputError(input_message(c.file, -1, -1, field, problem, fix));
  };
  const double w = c.image_width, h = c.image_height;
  if (c.cx < -0.5 * w || c.cx > 1.5 * w) {
    fail("cx", "the principal point lies far outside the image (" + std::to_string(c.cx) + " for a width of " +
                   std::to_string(c.image_width) + ")", "write the principal point in pixels, near the image's centre");
  }
  if (c.cy < -0.5 * h || c.cy > 1.5 * h) {
    fail("cy", "the principal point lies far outside the image (" + std::to_string(c.cy) + " for a height of " +
                   std::to_string(c.image_height) + ")", "write the principal point in pixels, near the image's centre");
  }
  // The image's inscribed circle: where the principal point's nearest edge is (a pixel at least).
  const double radius = std::max(1.0, std::min({c.cx + 0.5, w - 0.5 - c.cx, c.cy + 0.5, h - 0.5 - c.cy}));
  const std::string distortion_fix = "calibrate the camera again (skylit-calib), or check the coefficients' order and signs";
  // The model must not fold back before that circle (a fisheye that reaches the horizon is whole).
  const bool whole_hemisphere = c.model == LensModel::Fisheye && max_theta_ >= std::numbers::pi / 2;
  const double reach = c.model == LensModel::Fisheye ? distort_theta(max_theta_)
                                                      : std::tan(max_theta_) * pinhole_radial(c.D, std::pow(std::tan(max_theta_), 2)).g;
  const double reach_px = std::min(c.fx, c.fy) * reach;  // how far from the principal point the model images
  if (!whole_hemisphere && reach_px < 0.999 * radius) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "the distortion turns back %.3g pixels from the principal point, inside the image (its nearest edge is "
                  "%.0f pixels away): the model folds the image there",
                  reach_px, radius);
    fail("D", text, distortion_fix);
  }
  // The image must span at least a degree: θ at the inscribed circle, along the narrower axis.
  const bool narrower_y = c.fy > c.fx;
  const double probe = std::min(radius, 0.99 * reach_px);  // a fisheye's circle may end inside the image
  const std::optional<Vec3> edge = unproject(narrower_y ? Vec2(c.cx, c.cy + probe) : Vec2(c.cx + probe, c.cy));
  const double half_angle = edge ? std::acos(std::clamp(edge->z(), -1.0, 1.0)) : 0.0;
  constexpr double kMinHalfAngle = 0.5 * std::numbers::pi / 180;
  if (half_angle < kMinHalfAngle) {
    const double undistorted = std::atan(probe / std::max(c.fx, c.fy));
    char text[200];
    std::snprintf(text, sizeof text, "the image spans %.3g° from its centre to its nearest edge; no camera sees less than half a degree",
                  half_angle * 180 / std::numbers::pi);
    if (undistorted < kMinHalfAngle) {
      fail(narrower_y ? "fy" : "fx", text, "write the focal length in pixels (about the image width for a 53° lens)");
    }
    fail("D", text, distortion_fix);
  }
}

double Lens::distort_theta(double theta) const { return fisheye_distort(calibration_.D, theta); }


std::optional<Vec3> Lens::unproject(const Vec2& pixel) const {
  if (!pixel.allFinite()) return std::nullopt;
  const CameraCalibration& c = calibration_;
  const Vec2 m((pixel.x() - c.cx) / c.fx, (pixel.y() - c.cy) / c.fy);
  if (c.model == LensModel::Fisheye) {
    const double theta_d = m.norm();
    if (theta_d == 0.0) return Vec3(0, 0, 1);
    if (theta_d > distort_theta(max_theta_)) return std::nullopt;
    // Safeguarded Newton on θ_d(θ) = target: θ_d is increasing on [0, max_theta], so the root is
    // unique and the bracket [lo, hi] always holds it.
    double lo = 0.0, hi = max_theta_;
    double theta = std::min(theta_d, max_theta_);
    for (int i = 0; i < kNewtonIterations; ++i) {
      const double residual = distort_theta(theta) - theta_d;
      if (residual == 0.0) break;
      (residual > 0 ? hi : lo) = theta;
      const double slope = fisheye_slope(c.D, theta);
      double next = slope > 0 ? theta - residual / slope : 0.5 * (lo + hi);
      if (!(next >= lo && next <= hi)) next = 0.5 * (lo + hi);
      const bool converged = std::abs(next - theta) <= kNewtonTolerance * std::max(1.0, theta);
      theta = next;
      if (converged) break;
    }
    const double s = std::sin(theta) / theta_d;
    return Vec3(m.x() * s, m.y() * s, std::cos(theta));
  }
  // Pinhole: Newton on the 2-D distortion, from the distorted point itself.
  Vec2 p = m;
  Eigen::Matrix2d J;
  for (int i = 0; i < kNewtonIterations; ++i) {
    const Vec2 residual = pinhole_distort(c.D, p, &J) - m;
    const double det = J.determinant();
    if (!std::isfinite(det) || std::abs(det) < 1e-300) return std::nullopt;
    const Vec2 delta = J.inverse() * residual;
    p -= delta;
    if (!p.allFinite()) return std::nullopt;
    if (delta.norm() <= kNewtonTolerance * std::max(1.0, p.norm())) break;
  }
  // Reject a root outside the monotonic range (a fold of the model) or one Newton missed.
  if (std::atan(p.norm()) > max_theta_) return std::nullopt;
  if ((pinhole_distort(c.D, p, nullptr) - m).norm() > 1e-9 * std::max(1.0, m.norm()))
    return std::nullopt;
  return Vec3(p.x(), p.y(), 1.0).normalized();
}

std::optional<Vec3> Lens::pixel_to_site(const Vec2& pixel) const {
  const std::optional<Vec3> camera = unproject(pixel);
  if (!camera) return std::nullopt;
  return Vec3(calibration_.R_site_from_camera * *camera);
}

std::optional<Vec2> Lens::site_to_pixel(const Vec3& site_direction) const {
  return project(camera_from_site_ * site_direction);
}

}  // namespace skylit::camera
