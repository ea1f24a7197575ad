// Head pose from the visible tags: IPPE per tag for the starts, Levenberg–Marquardt over all.
#include "skylit/track/marker_pose.hpp"
#include "skylit/camera/lens.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

namespace skylit::track {
namespace {

using Vec2 = Eigen::Vector2d;
using Mat3 = Eigen::Matrix3d;

// A corner whose ray leaves the optical axis by more than this cannot be put on the normalised
// image plane (a fisheye's rim); its tag is left out.
constexpr double kMinRayZ = 0.1;  // cos 84°
// Error counted for a corner that falls behind the camera or outside the lens model.
constexpr double kUnprojectableErrorPx = 1e4;
// The starts tried: the IPPE solutions of this many tags, the largest in the frame first.
constexpr std::size_t kStartTags = 3;
// At most this many starts are refined (each a Levenberg–Marquardt run over every corner).
constexpr std::size_t kMaxRefinements = 4;

struct Observation {
  const MarkerTag* tag = nullptr;
  const TagDetection* detection = nullptr;
  std::array<Vec3, 4> site;        // the map's corners
  std::array<Vec2, 4> normalised;  // the detected corners on the z = 1 plane
  double edge_px = 0;
};

// camera = R · site + t (OpenCV's rvec/tvec convention).
struct CameraFromSite {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();
};

struct Candidate {
  CameraFromSite pose;
  double rms_px = 0;
};

Pose to_pose(const CameraFromSite& c) {
  Pose pose;
  pose.R_site_from_camera = Eigen::Quaterniond(Mat3(c.R.transpose())).normalized();
  pose.t_site_from_camera = -(c.R.transpose() * c.t);
  return pose;
}

double rotation_difference_deg(const CameraFromSite& a, const CameraFromSite& b) {
  const Eigen::AngleAxisd difference(Mat3(a.R * b.R.transpose()));
  return std::abs(difference.angle()) * 180.0 / std::numbers::pi;
}

CameraFromSite from_cv(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  CameraFromSite c;
  cv::cv2eigen(R, c.R);
  c.t = Vec3(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return c;
}

void to_cv(const CameraFromSite& c, cv::Mat& rvec, cv::Mat& tvec) {
  cv::Mat R;
  cv::eigen2cv(c.R, R);
  cv::Rodrigues(R, rvec);
  tvec = (cv::Mat_<double>(3, 1) << c.t.x(), c.t.y(), c.t.z());
}

// Sum of squared pixel errors of one tag's corners under a pose.
double tag_squared_error(const Observation& o, const CameraFromSite& c, const camera::Lens& lens) {
  double sum = 0;
  for (std::size_t k = 0; k < 4; ++k) {
    const Vec3 camera = c.R * o.site[k] + c.t;
    const std::optional<Vec2> pixel = camera.z() > 0 ? lens.project(camera) : std::nullopt;
    const double error = pixel ? (*pixel - o.detection->corners[k]).norm() : kUnprojectableErrorPx;
    sum += error * error;
  }
  return sum;
}

double rms_over(std::span<const Observation* const> tags, const CameraFromSite& c, const camera::Lens& lens) {
  double sum = 0;
  for (const Observation* o : tags) sum += tag_squared_error(*o, c, lens);
  return std::sqrt(sum / (4.0 * static_cast<double>(tags.size())));
}

// The two IPPE solutions of one tag, as camera-from-site poses.
std::vector<CameraFromSite> ippe_starts(const Observation& o) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (int k = 0; k < 4; ++k) {
    const Vec3 p = tag_corner_in_tag(o.tag->size, k);
    object.emplace_back(p.x(), p.y(), p.z());
    const Vec2& n = o.normalised[static_cast<std::size_t>(k)];
    image.emplace_back(n.x(), n.y());
  }
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    cv::solvePnPGeneric(object, image, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvecs, tvecs, false, cv::SOLVEPNP_IPPE);
  } catch (const cv::Exception&) {
    return {};  // degenerate corners (a collapsed quad): no start from this tag
  }
  // camera = R_ct · tag + t_ct and tag = R_stᵀ (site − t_st) give camera from site.
  const Mat3 R_st = o.tag->R_site_from_tag.toRotationMatrix();
  std::vector<CameraFromSite> starts;
  for (std::size_t i = 0; i < rvecs.size(); ++i) {
    const CameraFromSite tag_pose = from_cv(rvecs[i], tvecs[i]);
    CameraFromSite c;
    c.R = tag_pose.R * R_st.transpose();
    c.t = tag_pose.t - c.R * o.tag->t_site_from_tag;
    if (c.R.allFinite() && c.t.allFinite()) starts.push_back(c);
  }
  return starts;
}

// Levenberg–Marquardt over every corner of `tags` from `start` (normalised image coordinates).
CameraFromSite refine(std::span<const Observation* const> tags, const CameraFromSite& start) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (const Observation* o : tags) {
    for (std::size_t k = 0; k < 4; ++k) {
      object.emplace_back(o->site[k].x(), o->site[k].y(), o->site[k].z());
      image.emplace_back(o->normalised[k].x(), o->normalised[k].y());
    }
  }
  cv::Mat rvec, tvec;
  to_cv(start, rvec, tvec);
  try {
    cv::solvePnPRefineLM(object, image, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec,
                         cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-10));
  } catch (const cv::Exception&) {
    return start;
  }
  const CameraFromSite refined = from_cv(rvec, tvec);
  return refined.R.allFinite() && refined.t.allFinite() ? refined : start;
}

struct Solution {
  Candidate best;
  std::optional<Candidate> alternative;
};

// The starts (the IPPE pair of the largest few tags), ranked by their error over all of `tags`,
// refined in that order; a start near one already refined is skipped (it would fall into the
// same minimum), and the search stops once two different minima are known. The best, and the
// best that differs from it.
std::optional<Solution> solve_over(std::span<const Observation* const> tags, const camera::Lens& lens,
                                   const MarkerPoseOptions& options) {
  std::vector<const Observation*> by_size(tags.begin(), tags.end());
  std::stable_sort(by_size.begin(), by_size.end(),
                   [](const Observation* a, const Observation* b) { return a->edge_px > b->edge_px; });
  std::vector<Candidate> starts;
  for (std::size_t i = 0; i < std::min(kStartTags, by_size.size()); ++i) {
    for (const CameraFromSite& start : ippe_starts(*by_size[i])) starts.push_back({start, rms_over(tags, start, lens)});
  }
  if (starts.empty()) return std::nullopt;
  std::stable_sort(starts.begin(), starts.end(), [](const Candidate& a, const Candidate& b) { return a.rms_px < b.rms_px; });
  const auto distinct = [&](const CameraFromSite& a, const CameraFromSite& b) {
    return rotation_difference_deg(a, b) > options.distinct_deg;
  };
  std::vector<Candidate> refined;
  std::vector<CameraFromSite> tried;
  for (const Candidate& start : starts) {
    if (refined.size() >= kMaxRefinements) break;
    const auto near = [&](const auto& other) { return !distinct(start.pose, other); };
    if (std::any_of(tried.begin(), tried.end(), near) ||
        std::any_of(refined.begin(), refined.end(), [&](const Candidate& c) { return near(c.pose); })) {
      continue;
    }
    tried.push_back(start.pose);
    const CameraFromSite pose = refine(tags, start.pose);
    refined.push_back({pose, rms_over(tags, pose, lens)});
    const bool two_minima = std::any_of(refined.begin(), refined.end() - 1,
                                        [&](const Candidate& c) { return distinct(c.pose, pose); });
    if (two_minima) break;
  }
  std::stable_sort(refined.begin(), refined.end(), [](const Candidate& a, const Candidate& b) { return a.rms_px < b.rms_px; });
  Solution solution{refined.front(), std::nullopt};
  for (std::size_t i = 1; i < refined.size(); ++i) {
    if (distinct(refined[i].pose, solution.best.pose)) {
      solution.alternative = refined[i];
      break;
    }
  }
  return solution;
}

void check_options(const MarkerPoseOptions& o) {
  const auto positive = [](double v) { return v > 0 && std::isfinite(v); };
  if (!positive(o.outlier_px) || !positive(o.max_error_px) || !positive(o.distinct_deg) || !(o.distant_tag_px >= 0) ||
      !(o.max_ambiguity >= 0 && o.max_ambiguity <= 1)) {
    throw std::invalid_argument(
        "MarkerPoseOptions: outlier_px, max_error_px and distinct_deg must be positive, distant_tag_px ≥ 0, max_ambiguity in 0..1");
  }
}

}  // namespace

std::string MarkerSolve::describe_flags() const {
  std::string text;
  const auto add = [&](bool flag, const char* name) {
    if (flag) text += (text.empty() ? "" : ", ") + std::string(name);
  };
  add(no_tags, "no tags");
  add(ambiguous, "ambiguous");
  add(single_distant_tag, "single distant tag");
  add(high_error, "high error");
  return text.empty() ? "ok" : text;
}

MarkerSolve solve_marker_pose(const MarkerMap& map, const camera::Lens& lens, std::span<const TagDetection> detections,
                              const MarkerPoseOptions& options) {
  check_options(options);
  MarkerSolve result;
  std::vector<Observation> observations;
  observations.reserve(detections.size());
  for (const TagDetection& detection : detections) {
    const MarkerTag* tag = map.find(detection.id);
    if (tag == nullptr) {
      result.tags_unknown.push_back(detection.id);
      continue;
    }
    Observation o;
    o.tag = tag;
    o.detection = &detection;
    o.site = tag_corners_in_site(*tag);
    bool usable = true;
    for (std::size_t k = 0; k < 4 && usable; ++k) {
      const std::optional<Vec3> ray = lens.unproject(detection.corners[k]);
      usable = ray && ray->z() > kMinRayZ;
      if (usable) o.normalised[k] = ray->head<2>() / ray->z();
      o.edge_px += (detection.corners[(k + 1) % 4] - detection.corners[k]).norm() / 4.0;
    }
    if (usable) observations.push_back(o);
  }
  // The same id twice in one frame: a second print of a tag, or a misdetection; neither can be
  // told from the other, so both go.
  std::map<int, int> count;
  for (const Observation& o : observations) ++count[o.tag->id];
  for (const auto& [tag_id, n] : count) {
    if (n < 2) continue;
    result.tags_rejected.push_back(tag_id);
    const int twice = tag_id;  // a structured binding is not captured by clang 14 (the fuzz build)
    std::erase_if(observations, [twice](const Observation& other) { return other.tag->id == twice; });
  }
  std::vector<const Observation*> inliers;
  for (const Observation& o : observations) inliers.push_back(&o);
  std::vector<const Observation*> rejected;

  std::optional<Solution> solution = inliers.empty() ? std::nullopt : solve_over(inliers, lens, options);
  // Outliers: while some tag reprojects badly and at least two others remain to agree, drop the
  // tag whose removal leaves the rest with the smallest error.
  while (solution && inliers.size() >= 3) {
    double worst = 0;
    for (const Observation* o : inliers) {
      worst = std::max(worst, std::sqrt(tag_squared_error(*o, solution->best.pose, lens) / 4.0));
    }
    if (worst <= options.outlier_px) break;
    std::size_t drop = 0;
    std::optional<Solution> best_without;
    for (std::size_t i = 0; i < inliers.size(); ++i) {
      std::vector<const Observation*> others = inliers;
      others.erase(others.begin() + static_cast<std::ptrdiff_t>(i));
      std::optional<Solution> without = solve_over(others, lens, options);
      if (without && (!best_without || without->best.rms_px < best_without->best.rms_px)) {
        best_without = without;
        drop = i;
      }
    }
    if (!best_without) break;
    rejected.push_back(inliers[drop]);
    inliers.erase(inliers.begin() + static_cast<std::ptrdiff_t>(drop));
    solution = best_without;
  }

  for (const Observation* o : inliers) result.tags_used.push_back(o->tag->id);
  for (const Observation* o : rejected) result.tags_rejected.push_back(o->tag->id);
  if (!solution) {
    result.no_tags = inliers.empty();
    result.high_error = !inliers.empty();  // tags seen but no solution: nothing to trust
    return result;
  }
  const Candidate& best = solution->best;
  result.pose = to_pose(best.pose);
  result.rms_px = best.rms_px;
  if (solution->alternative) {
    result.alternative = to_pose(solution->alternative->pose);
    result.alternative_rms_px = solution->alternative->rms_px;
    result.ambiguity = solution->alternative->rms_px > 0 ? std::min(1.0, best.rms_px / solution->alternative->rms_px) : 1.0;
  }
  for (const auto* list : {&inliers, &rejected}) {
    for (const Observation* o : *list) {
      result.residuals.push_back(
          {o->tag->id, std::sqrt(tag_squared_error(*o, best.pose, lens) / 4.0), o->edge_px, CameraSide::Left});
    }
  }
  result.single_distant_tag = inliers.size() == 1 && inliers.front()->edge_px < options.distant_tag_px;
  result.ambiguous = result.ambiguity > options.max_ambiguity;
  result.high_error = result.rms_px > options.max_error_px;
  return result;
}

}  // namespace skylit::track
