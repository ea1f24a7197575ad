#include "skylit/calib/orientation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <utility>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "skylit/base/error.hpp"
#include "skylit/geom/angles.hpp"
#include "printf_text.hpp"

namespace skylit::calib {
namespace {

using geom::kDeg;
constexpr std::size_t kMaxCandidatePairs = 20000;  // beyond: a fixed random sample of pairs
constexpr int kMaxRefits = 10;

double largest_spread(std::span<const SunObservation> observations, const std::vector<bool>* use) {
  double spread = 0;
  for (std::size_t i = 0; i < observations.size(); ++i) {
    if (use && !(*use)[i]) continue;
    for (std::size_t j = i + 1; j < observations.size(); ++j) {
      if (use && !(*use)[j]) continue;
      spread = std::max(spread, angle_deg(observations[i].site_direction, observations[j].site_direction));
    }
  }
  return spread;
}

struct Evaluation {
  std::vector<double> residual_deg;
  std::vector<bool> inlier;
  int inliers = 0;
  double clipped_cost = 0;  // Σ min(residual, threshold): ties between equal counts
};

Evaluation evaluate(const Eigen::Matrix3d& R, std::span<const SunObservation> observations, double threshold_deg) {
  Evaluation e;
  for (const SunObservation& o : observations) {
    const double r = angle_deg(o.site_direction, R * o.camera_direction);
    e.residual_deg.push_back(r);
    e.inlier.push_back(r <= threshold_deg);
    e.inliers += r <= threshold_deg ? 1 : 0;
    e.clipped_cost += std::min(r, threshold_deg);
  }
  return e;
}

Eigen::Matrix3d fit_subset(std::span<const SunObservation> observations, const std::vector<bool>& use) {
  std::vector<Vec3> site, camera;
  for (std::size_t k = 0; k < observations.size(); ++k) {
    if (!use[k]) continue;
    site.push_back(observations[k].site_direction);
    camera.push_back(observations[k].camera_direction);
  }
  return solve_wahba(site, camera);
}

}  // namespace

double angle_deg(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg; }

Eigen::Matrix3d solve_wahba(std::span<const Vec3> site, std::span<const Vec3> camera, std::span<const double> weights) {
  Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < site.size() && k < camera.size(); ++k) {
    const double w = weights.empty() ? 1.0 : weights[k];
    B += w * site[k].normalized() * camera[k].normalized().transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(B, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d V = svd.matrixV();
  const Eigen::Vector3d d(1.0, 1.0, (U.determinant() * V.determinant()) < 0 ? -1.0 : 1.0);
  return U * d.asDiagonal() * V.transpose();
}

OrientationFit fit_orientation(std::span<const SunObservation> observations, const OrientationOptions& options) {
  const std::size_t n = observations.size();
  const std::string more_frames =
      "Fix: give sky frames with the sun visible (a clear sky, the sun not hidden by the mount) at "
      "2 or more times, spread over 2 hours or more, or use --level-compass";
  if (n < 2) {
    throw InputError("the sun was found in " + std::to_string(n) +
                     " frame(s); the orientation needs it in at least 2 frames at " + "different times. " + more_frames);
  }
  const double spread = largest_spread(observations, nullptr);
  if (spread < options.min_spread_deg) {
    throw InputError(format("the sun moved only %.1f° between the frames where it was found", spread) +
                     format(" (needs %.0f°): the rotation about its direction is undetermined. ", options.min_spread_deg) +
                     more_frames);
  }

  // Candidate rotations from pairs of observations far enough apart.
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      if (angle_deg(observations[i].site_direction, observations[j].site_direction) >= options.min_spread_deg)
        pairs.emplace_back(i, j);
    }
  }
  if (pairs.size() > kMaxCandidatePairs) {
    std::mt19937 random(12345);
    std::shuffle(pairs.begin(), pairs.end(), random);
    pairs.resize(kMaxCandidatePairs);
  }
  Evaluation best;
  best.inliers = -1;
  Eigen::Matrix3d best_R = Eigen::Matrix3d::Identity();
  for (const auto& [i, j] : pairs) {
    const std::array<Vec3, 2> site{observations[i].site_direction, observations[j].site_direction};
    const std::array<Vec3, 2> camera{observations[i].camera_direction, observations[j].camera_direction};
    const Eigen::Matrix3d R = solve_wahba(site, camera);
    Evaluation e = evaluate(R, observations, options.outlier_threshold_deg);
    if (e.inliers > best.inliers || (e.inliers == best.inliers && e.clipped_cost < best.clipped_cost)) {
      best = std::move(e);
      best_R = R;
    }
  }
  // Refit on the inliers until the set settles.
  for (int k = 0; k < kMaxRefits && best.inliers >= 2; ++k) {
    const Eigen::Matrix3d R = fit_subset(observations, best.inlier);
    Evaluation e = evaluate(R, observations, options.outlier_threshold_deg);
    const bool settled = e.inlier == best.inlier;
    if (e.inliers < 2) break;
    best = std::move(e);
    best_R = R;
    if (settled) break;
  }
  const double inlier_spread = largest_spread(observations, &best.inlier);
  if (best.inliers < 2 || inlier_spread < options.min_spread_deg) {
    throw InputError(format("no two frames agree on an orientation within %.1f°", options.outlier_threshold_deg) +
                     " (the sun detections disagree with the solar positions: check the frames' times and time "
                     "zone, --lat and --lon (east positive), and the intrinsics). " +
                     more_frames);
  }

  OrientationFit fit;
  fit.R_site_from_camera = best_R;
  fit.residual_deg = best.residual_deg;
  fit.inlier = best.inlier;
  fit.inliers = best.inliers;
  fit.spread_deg = inlier_spread;
  double sum = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (fit.inlier[k]) sum += fit.residual_deg[k] * fit.residual_deg[k];
  }
  fit.rms_deg = std::sqrt(sum / fit.inliers);

  if (fit.spread_deg < options.recommended_spread_deg) {
    fit.advice.push_back(format("the sun moved only %.0f° across the frames used", fit.spread_deg) +
                         format(" (aim for %.0f° or more, about 2–3 hours): the rotation about its path is weakly "
                                "determined; add frames from earlier or later in the day",
                                options.recommended_spread_deg));
  }
  if (fit.inliers < static_cast<int>(n)) {
    std::string names;
    for (std::size_t k = 0; k < n; ++k) {
      if (fit.inlier[k]) continue;
      if (!names.empty()) names += ", ";
      names.append(observations[k].name).append(format(" (%.1f°)", fit.residual_deg[k]));
    }
    fit.advice.push_back(std::to_string(n - static_cast<std::size_t>(fit.inliers)) +
                         " frame(s) disagree with the fit by more than " + format("%.1f°", options.outlier_threshold_deg) +
                         " and were left out: " + names +
                         " (a reflection or a bright cloud edge taken for the sun, or a wrong timestamp)");
  }
  if (fit.rms_deg > 0.5) {
    fit.advice.push_back(format("the residuals' RMS is %.2f°", fit.rms_deg) +
                         ": check the intrinsics (RMS of the fisheye calibration), the frames' time zone and "
                         "clock, and --lat/--lon");
  }
  return fit;
}

Eigen::Matrix3d level_compass_rotation(double bearing_deg) {
  if (!std::isfinite(bearing_deg)) {
    throw InputError(input_message("", -1, -1, "--level-compass", "the bearing is not a number",
                                   "give the compass bearing of the image's x axis in degrees, e.g. 90 for east"));
  }
  const double b = bearing_deg * kDeg;
  Eigen::Matrix3d R;
  R.col(0) = Vec3(std::sin(b), std::cos(b), 0.0);   // image x: towards the bearing
  R.col(1) = Vec3(-std::cos(b), std::sin(b), 0.0);  // image y = z × x
  R.col(2) = Vec3(0.0, 0.0, 1.0);                   // optical axis: the zenith
  return R;
}

double rotation_difference_deg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const Eigen::AngleAxisd difference(a * b.transpose());
  return std::abs(difference.angle()) / kDeg;
}

Pointing describe_pointing(const Eigen::Matrix3d& R) {
  Pointing p;
  p.tilt_from_zenith_deg = angle_deg(R.col(2), Vec3::UnitZ());
  const Vec3 x = R.col(0);
  double bearing = std::atan2(x.x(), x.y()) / kDeg;
  if (bearing < 0) bearing += 360.0;
  p.image_x_bearing_deg = bearing;
  return p;
}

}  // namespace skylit::calib
