// A stereo camera's pose from both frames' tags: each camera's own solve gives the starts, one
// Levenberg–Marquardt (Ceres) over every corner of both refines them, the right camera's corners
// through the fixed extrinsics.
#include "skylit/track/marker_pose_stereo.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <numbers>
#include <optional>
#include <set>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>
#include <ceres/ceres.h>

namespace skylit::track {
// Named, not anonymous: the module is one unity build, and marker_pose.cpp's helpers have the
// same names.
namespace stereo_pose {

using Vec2 = Eigen::Vector2d;
using Mat3 = Eigen::Matrix3d;

// Error counted for a corner that falls behind its camera or outside the lens model (as in
// marker_pose.cpp, so that errors of both solves compare).
constexpr double kUnprojectableErrorPx = 1e4;
// Corners nearer than this to a camera's plane are not projected (metres).
constexpr double kMinDepthM = 1e-3;
// At most this many starts are refined (each a Levenberg–Marquardt run over every corner).
constexpr std::size_t kMaxRefinements = 4;

// The left camera: camera = R · site + t.
struct LeftFromSite {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();
};

// One tag in one camera's frame.
struct View {
  CameraSide camera = CameraSide::Left;
  int id = 0;
  std::array<Vec3, 4> site;     // the map's corners
  std::array<Vec2, 4> corners;  // detected, pixels of that camera's frame
  double edge_px = 0;
};

struct Rig {
  const camera::Lens& left;
  const camera::Lens& right;
  StereoExtrinsics extrinsics;

  const camera::Lens& lens(CameraSide side) const { return side == CameraSide::Left ? left : right; }
};

struct Candidate {
  LeftFromSite pose;
  double rms_px = 0;
};

struct Solution {
  Candidate best;
  std::optional<Candidate> alternative;
};

LeftFromSite from_pose(const Pose& pose) {
  LeftFromSite c;
  c.R = pose.R_site_from_camera.toRotationMatrix().transpose();
  c.t = -(c.R * pose.t_site_from_camera);
  return c;
}

Pose to_pose(const LeftFromSite& c) {
  Pose pose;
  pose.R_site_from_camera = Eigen::Quaterniond(Mat3(c.R.transpose())).normalized();
  pose.t_site_from_camera = -(c.R.transpose() * c.t);
  return pose;
}

double rotation_difference_deg(const LeftFromSite& a, const LeftFromSite& b) {
  const Eigen::AngleAxisd difference(Mat3(a.R * b.R.transpose()));
  return std::abs(difference.angle()) * 180.0 / std::numbers::pi;
}

double view_squared_error(const Rig& rig, const View& view, const LeftFromSite& c) {
  double sum = 0;
  for (std::size_t k = 0; k < 4; ++k) {
    Vec3 p = c.R * view.site[k] + c.t;
    if (view.camera == CameraSide::Right) p = rig.extrinsics.R_right_from_left * p + rig.extrinsics.t_right_from_left;
    const std::optional<Vec2> pixel = p.z() > kMinDepthM ? rig.lens(view.camera).project(p) : std::nullopt;
    const double error = pixel ? (*pixel - view.corners[k]).norm() : kUnprojectableErrorPx;
    sum += error * error;
  }
  return sum;
}

double view_rms(const Rig& rig, const View& view, const LeftFromSite& c) { return std::sqrt(view_squared_error(rig, view, c) / 4.0); }

double rms_over(const Rig& rig, std::span<const View* const> views, const LeftFromSite& c) {
  double sum = 0;
  for (const View* v : views) sum += view_squared_error(rig, *v, c);
  return std::sqrt(sum / (4.0 * static_cast<double>(views.size())));
}

// One view's four corners in pixels of its camera's (distorted) frame; the parameters are the
// left camera's rotation (Eigen's quaternion order x, y, z, w) and translation.
class ViewError {
 public:
  ViewError(const camera::Lens& lens, const StereoExtrinsics* right_from_left, const View& view)
      : lens_(lens), right_from_left_(right_from_left), view_(view) {}

  template <typename T>
  bool operator()(const T* rotation, const T* translation, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> R(rotation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(translation);
    for (std::size_t k = 0; k < 4; ++k) {
      Eigen::Matrix<T, 3, 1> p = R * view_.site[k].cast<T>() + t;
      if (right_from_left_ != nullptr) {
        p = right_from_left_->R_right_from_left.cast<T>() * p + right_from_left_->t_right_from_left.cast<T>();
      }
      if (p.z() < T(kMinDepthM)) return false;
      const std::optional<Eigen::Matrix<T, 2, 1>> pixel = lens_.project_as<T>(p);
      if (!pixel) return false;
      residual[2 * k] = pixel->x() - view_.corners[k].x();
      residual[2 * k + 1] = pixel->y() - view_.corners[k].y();
    }
    return true;
  }

 private:
  const camera::Lens& lens_;
  const StereoExtrinsics* right_from_left_;  // null for the left camera's views
  View view_;
};

// Levenberg–Marquardt over every corner of `views` from `start`.
LeftFromSite refine(const Rig& rig, std::span<const View* const> views, const LeftFromSite& start) {
  Eigen::Quaterniond q(start.R);
  q.normalize();
  std::array<double, 4> rotation{q.x(), q.y(), q.z(), q.w()};
  Vec3 translation = start.t;
  ceres::Problem problem;
  for (const View* view : views) {
    const StereoExtrinsics* right_from_left = view->camera == CameraSide::Right ? &rig.extrinsics : nullptr;
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<ViewError, 8, 4, 3>(new ViewError(rig.lens(view->camera), right_from_left, *view)),
        nullptr, rotation.data(), translation.data());
  }
  problem.SetManifold(rotation.data(), new ceres::EigenQuaternionManifold);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 30;
  options.function_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  options.gradient_tolerance = 1e-14;
  options.logging_type = ceres::SILENT;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable()) return start;  // a start with a corner behind its camera
  LeftFromSite refined;
  refined.R = Eigen::Quaterniond(rotation[3], rotation[0], rotation[1], rotation[2]).normalized().toRotationMatrix();
  refined.t = translation;
  return refined.R.allFinite() && refined.t.allFinite() ? refined : start;
}

// The starts ranked by their error over `views` and refined in that order; a start near one
// already tried or refined is skipped (it would fall into the same minimum), and the search stops
// once two different minima are known (marker_pose.cpp's search, over both cameras).
Solution solve_over(const Rig& rig, std::span<const View* const> views, std::span<const LeftFromSite> start_poses,
                    const MarkerPoseOptions& options) {
  std::vector<Candidate> starts;
  for (const LeftFromSite& start : start_poses) starts.push_back({start, rms_over(rig, views, start)});
  std::stable_sort(starts.begin(), starts.end(), [](const Candidate& a, const Candidate& b) { return a.rms_px < b.rms_px; });
  const auto distinct = [&](const LeftFromSite& a, const LeftFromSite& b) {
    return rotation_difference_deg(a, b) > options.distinct_deg;
  };
  std::vector<Candidate> refined;
  std::vector<LeftFromSite> tried;
  for (const Candidate& start : starts) {
    if (refined.size() >= kMaxRefinements) break;
    const auto near = [&](const LeftFromSite& other) { return !distinct(start.pose, other); };
    if (std::any_of(tried.begin(), tried.end(), near) ||
        std::any_of(refined.begin(), refined.end(), [&](const Candidate& c) { return near(c.pose); })) {
      continue;
    }
    tried.push_back(start.pose);
    const LeftFromSite pose = refine(rig, views, start.pose);
    refined.push_back({pose, rms_over(rig, views, pose)});
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

// The views of the tags `ids` in one camera's detections (an id detected twice gives none: the
// single solve rejected it).
std::vector<View> views_of(const MarkerMap& map, std::span<const TagDetection> detections, std::span<const int> ids,
                           CameraSide camera) {
  std::vector<View> views;
  for (const int id : ids) {
    const auto same = [id](const TagDetection& d) { return d.id == id; };
    const MarkerTag* tag = map.find(id);
    if (tag == nullptr || std::count_if(detections.begin(), detections.end(), same) != 1) continue;
    const TagDetection& detection = *std::find_if(detections.begin(), detections.end(), same);
    View view;
    view.camera = camera;
    view.id = id;
    view.site = tag_corners_in_site(*tag);
    view.corners = detection.corners;
    for (std::size_t k = 0; k < 4; ++k) view.edge_px += (detection.corners[(k + 1) % 4] - detection.corners[k]).norm() / 4.0;
    views.push_back(view);
  }
  return views;
}

std::size_t distinct_tags(std::span<const View* const> views) {
  std::set<int> ids;
  for (const View* v : views) ids.insert(v->id);
  return ids.size();
}

std::vector<int> sorted_union(std::initializer_list<const std::vector<int>*> lists) {
  std::set<int> ids;
  for (const std::vector<int>* list : lists) ids.insert(list->begin(), list->end());
  return {ids.begin(), ids.end()};
}

void check_extrinsics(const StereoExtrinsics& e) {
  const bool rotation = e.R_right_from_left.allFinite() &&
                        (e.R_right_from_left * e.R_right_from_left.transpose() - Mat3::Identity()).norm() < 1e-6 &&
                        e.R_right_from_left.determinant() > 0;
  if (!rotation || !e.t_right_from_left.allFinite()) {
    throw std::invalid_argument("solve_marker_pose_stereo: R_right_from_left must be a rotation and t_right_from_left finite");
  }
}

// A stereo result from one camera's solve alone (the other saw no usable tag): that solve, with
// the other camera's unknown ids and its unusable tags listed.
MarkerSolve with_other_camera_listed(MarkerSolve solve, const MarkerSolve& other) {
  solve.tags_rejected = sorted_union({&solve.tags_rejected, &other.tags_rejected, &other.tags_used});
  solve.tags_unknown = sorted_union({&solve.tags_unknown, &other.tags_unknown});
  solve.no_tags = solve.no_tags && other.no_tags;
  if (!solve.pose) solve.high_error = !solve.no_tags;  // tags seen but no solution: nothing to trust
  return solve;
}

MarkerSolve solve(const MarkerMap& map, const Rig& rig, std::span<const TagDetection> left_detections,
                  std::span<const TagDetection> right_detections, const MarkerPoseOptions& options) {
  const MarkerSolve left = solve_marker_pose(map, rig.left, left_detections, options);
  const MarkerSolve right = as_left_camera(solve_marker_pose(map, rig.right, right_detections, options), rig.extrinsics);
  if (!right.pose) return with_other_camera_listed(left, right);
  if (!left.pose) return with_other_camera_listed(right, left);
  if (left.tags_used.empty() || right.tags_used.empty()) return left.tags_used.empty() ? right : left;

  // Each camera's tags that its own solve kept; the views it rejected are reported, not used.
  std::vector<View> used_views = views_of(map, left_detections, left.tags_used, CameraSide::Left);
  for (const View& v : views_of(map, right_detections, right.tags_used, CameraSide::Right)) used_views.push_back(v);
  std::vector<View> rejected_views = views_of(map, left_detections, left.tags_rejected, CameraSide::Left);
  for (const View& v : views_of(map, right_detections, right.tags_rejected, CameraSide::Right)) rejected_views.push_back(v);
  std::vector<const View*> used;
  for (const View& v : used_views) used.push_back(&v);
  std::vector<const View*> rejected;
  for (const View& v : rejected_views) rejected.push_back(&v);

  std::vector<LeftFromSite> starts;
  for (const MarkerSolve* single : {&left, &right}) {
    starts.push_back(from_pose(*single->pose));
    if (single->alternative) starts.push_back(from_pose(*single->alternative));
  }
  Solution solution = solve_over(rig, used, starts, options);
  // Views that disagree with the joint pose: while some view reprojects badly and at least two
  // other tags remain to agree, drop the view whose removal leaves the rest agreeing best.
  std::vector<int> dropped_jointly;
  while (distinct_tags(used) >= 3) {
    double worst = 0;
    for (const View* v : used) worst = std::max(worst, view_rms(rig, *v, solution.best.pose));
    if (worst <= options.outlier_px) break;
    std::vector<LeftFromSite> restarts = starts;
    restarts.push_back(solution.best.pose);
    std::size_t drop = 0;
    std::optional<Solution> best_without;
    for (std::size_t i = 0; i < used.size(); ++i) {
      std::vector<const View*> others = used;
      others.erase(others.begin() + static_cast<std::ptrdiff_t>(i));
      Solution without = solve_over(rig, others, restarts, options);
      if (!best_without || without.best.rms_px < best_without->best.rms_px) {
        best_without = without;
        drop = i;
      }
    }
    dropped_jointly.push_back(used[drop]->id);
    rejected.push_back(used[drop]);
    used.erase(used.begin() + static_cast<std::ptrdiff_t>(drop));
    solution = *best_without;
  }

  MarkerSolve result;
  const Candidate& best = solution.best;
  result.pose = to_pose(best.pose);
  result.rms_px = best.rms_px;
  if (solution.alternative) {
    result.alternative = to_pose(solution.alternative->pose);
    result.alternative_rms_px = solution.alternative->rms_px;
    result.ambiguity = solution.alternative->rms_px > 0 ? std::min(1.0, best.rms_px / solution.alternative->rms_px) : 1.0;
  }
  std::vector<int> used_ids;
  for (const View* v : used) used_ids.push_back(v->id);
  result.tags_used = sorted_union({&used_ids});
  result.tags_rejected = sorted_union({&left.tags_rejected, &right.tags_rejected, &dropped_jointly});
  result.tags_unknown = sorted_union({&left.tags_unknown, &right.tags_unknown});
  double largest_edge_px = 0;
  for (const auto* list : {&used, &rejected}) {
    for (const View* v : *list) result.residuals.push_back({v->id, view_rms(rig, *v, best.pose), v->edge_px, v->camera});
  }
  for (const View* v : used) largest_edge_px = std::max(largest_edge_px, v->edge_px);
  result.single_distant_tag = result.tags_used.size() == 1 && largest_edge_px < options.distant_tag_px;
  result.ambiguous = result.ambiguity > options.max_ambiguity;
  result.high_error = result.rms_px > options.max_error_px;
  return result;
}

}  // namespace stereo_pose

Pose left_camera_pose(const Pose& right_camera, const StereoExtrinsics& extrinsics) {
  const Eigen::Matrix3d R_site_from_right = right_camera.R_site_from_camera.toRotationMatrix();
  Pose left;
  left.timestamp = right_camera.timestamp;
  left.R_site_from_camera = Eigen::Quaterniond(Eigen::Matrix3d(R_site_from_right * extrinsics.R_right_from_left)).normalized();
  left.t_site_from_camera = right_camera.t_site_from_camera + R_site_from_right * extrinsics.t_right_from_left;
  return left;
}

Pose right_camera_pose(const Pose& left_camera, const StereoExtrinsics& extrinsics) {
  const Eigen::Matrix3d R_site_from_right = left_camera.R_site_from_camera.toRotationMatrix() * extrinsics.R_right_from_left.transpose();
  Pose right;
  right.timestamp = left_camera.timestamp;
  right.R_site_from_camera = Eigen::Quaterniond(R_site_from_right).normalized();
  right.t_site_from_camera = left_camera.t_site_from_camera - R_site_from_right * extrinsics.t_right_from_left;
  return right;
}

MarkerSolve as_left_camera(MarkerSolve solve, const StereoExtrinsics& extrinsics) {
  if (solve.pose) solve.pose = left_camera_pose(*solve.pose, extrinsics);
  if (solve.alternative) solve.alternative = left_camera_pose(*solve.alternative, extrinsics);
  for (TagResidual& residual : solve.residuals) residual.camera = CameraSide::Right;
  return solve;
}

MarkerSolve solve_marker_pose_stereo(const MarkerMap& map, const camera::Lens& left_lens, const camera::Lens& right_lens,
                                     const Eigen::Matrix3d& R_right_from_left, const Vec3& t_right_from_left,
                                     std::span<const TagDetection> left_detections,
                                     std::span<const TagDetection> right_detections, const MarkerPoseOptions& options) {
  const stereo_pose::Rig rig{left_lens, right_lens, {R_right_from_left, t_right_from_left}};
  stereo_pose::check_extrinsics(rig.extrinsics);
  return stereo_pose::solve(map, rig, left_detections, right_detections, options);
}

}  // namespace skylit::track
