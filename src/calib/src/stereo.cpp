// A stereo camera from pairs of board photos: each camera's intrinsics (intrinsics.cpp), a first
// relative pose averaged over the pairs (chordal mean of the rotations), then the relative pose
// and every board's pose refined together over every corner in both cameras (Ceres, intrinsics
// fixed), outlier pairs dropped, and the rectified pair as a check.
#include "skylit/calib/stereo.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <ceres/ceres.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "skylit/base/error.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/geom/angles.hpp"
#include "printf_text.hpp"

namespace skylit::calib {
namespace {

namespace fs = std::filesystem;
using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

// A corner closer than this to a camera's plane (metres in front) cannot be imaged.
constexpr double kStereoMinDepth = 1e-3;

// y = R · x + t.
struct StereoRigid {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();

  Vec3 operator*(const Vec3& x) const { return R * x + t; }
  StereoRigid operator*(const StereoRigid& other) const { return {R * other.R, R * other.t + t}; }
  StereoRigid inverse() const { return {R.transpose(), -(R.transpose() * t)}; }
};

double middle_value(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double rotation_angle_deg(const Mat3& a, const Mat3& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() / geom::kDeg;
}

// The rotation nearest (Frobenius) to the mean of `rotations`: the chordal L2 mean.
Mat3 chordal_mean(const std::vector<Mat3>& rotations) {
  Mat3 sum = Mat3::Zero();
  for (const Mat3& R : rotations) sum += R;
  const Eigen::JacobiSVD<Mat3> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 flip = Mat3::Identity();
  flip(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * flip * svd.matrixV().transpose();
}

// The board's pose in a camera (camera_from_board) from its corners: the corners' directions
// through the lens (any model), then a planar PnP on the normalised image plane.
std::optional<StereoRigid> board_pose(const camera::Lens& lens, const BoardView& view) {
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> normalised;
  for (std::size_t i = 0; i < view.image.size(); ++i) {
    const std::optional<Vec3> d = lens.unproject(Vec2(view.image[i].x, view.image[i].y));
    if (!d || d->z() < 0.05) continue;  // beyond what a plane projection can hold
    object.push_back(view.object[i]);
    normalised.emplace_back(static_cast<float>(d->x() / d->z()), static_cast<float>(d->y() / d->z()));
  }
  if (object.size() < 4) return std::nullopt;
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(object, normalised, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE)) {
    return std::nullopt;
  }
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  StereoRigid pose;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) pose.R(r, c) = R.at<double>(r, c);
    pose.t(r) = tvec.at<double>(r);
  }
  return pose;
}

// A pose as one Ceres parameter block: a unit quaternion (Eigen's x, y, z, w order), then the
// translation.
struct StereoPoseBlock {
  std::array<double, 7> x{};

  explicit StereoPoseBlock(const StereoRigid& pose) {
    Eigen::Map<Eigen::Quaterniond>(x.data()) = Eigen::Quaterniond(pose.R).normalized();
    Eigen::Map<Vec3>(x.data() + 4) = pose.t;
  }
  double* data() { return x.data(); }
  StereoRigid rigid() const {
    return {Eigen::Map<const Eigen::Quaterniond>(x.data()).normalized().toRotationMatrix(), Eigen::Map<const Vec3>(x.data() + 4)};
  }
};
using StereoPoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;

template <typename T>
Eigen::Matrix<T, 3, 1> transform(const T* pose, const Eigen::Matrix<T, 3, 1>& x) {
  return Eigen::Map<const Eigen::Quaternion<T>>(pose) * x + Eigen::Map<const Eigen::Matrix<T, 3, 1>>(pose + 4);
}

template <typename T>
bool pixel_residual(const camera::Lens& lens, const Eigen::Matrix<T, 3, 1>& in_camera, const Vec2& detected, T* residual) {
  if (in_camera.z() < kStereoMinDepth) return false;
  const std::optional<Eigen::Matrix<T, 2, 1>> pixel = lens.project_as<T>(in_camera);
  if (!pixel) return false;
  residual[0] = pixel->x() - detected.x();
  residual[1] = pixel->y() - detected.y();
  return true;
}

// A corner seen by the left camera: the board's pose in the left camera, then the left lens.
class LeftCornerError {
 public:
  LeftCornerError(const camera::Lens& lens, const Vec3& on_board, const Vec2& detected)
      : lens_(lens), on_board_(on_board), detected_(detected) {}
  template <typename T>
  bool operator()(const T* left_from_board, T* residual) const {
    return pixel_residual<T>(lens_, transform(left_from_board, on_board_.cast<T>().eval()), detected_, residual);
  }

 private:
  const camera::Lens& lens_;
  Vec3 on_board_;
  Vec2 detected_;
};

// The same corner seen by the right camera: through the left camera and the stereo pose.
class RightCornerError {
 public:
  RightCornerError(const camera::Lens& lens, const Vec3& on_board, const Vec2& detected)
      : lens_(lens), on_board_(on_board), detected_(detected) {}
  template <typename T>
  bool operator()(const T* right_from_left, const T* left_from_board, T* residual) const {
    const Eigen::Matrix<T, 3, 1> in_left = transform(left_from_board, on_board_.cast<T>().eval());
    return pixel_residual<T>(lens_, transform(right_from_left, in_left), detected_, residual);
  }

 private:
  const camera::Lens& lens_;
  Vec3 on_board_;
  Vec2 detected_;
};

struct StereoFit {
  StereoRigid right_from_left;
  std::vector<StereoRigid> left_from_board;  // per pair
  std::vector<double> pair_rms;              // per pair, both photos' corners, pixels
  double rms = 0;
  int iterations = 0;
};

Vec3 board_point(const cv::Point3f& p) { return {p.x, p.y, p.z}; }
Vec2 image_point(const cv::Point2f& p) { return {p.x, p.y}; }

// The squared pixel errors of a pair's corners in both photos, and how many; a corner the poses
// cannot image counts as 100 px.
std::pair<double, std::size_t> pair_squared_error(const camera::Lens& left, const camera::Lens& right, const PhotoPair& pair,
                                                  const StereoRigid& right_from_left, const StereoRigid& left_from_board) {
  const auto error = [](const camera::Lens& lens, const Vec3& in_camera, const Vec2& detected) {
    const std::optional<Vec2> pixel = in_camera.z() >= kStereoMinDepth ? lens.project(in_camera) : std::nullopt;
    return pixel ? (*pixel - detected).squaredNorm() : 1e4;
  };
  double sum = 0;
  for (std::size_t i = 0; i < pair.left->object.size(); ++i) {
    sum += error(left, left_from_board * board_point(pair.left->object[i]), image_point(pair.left->image[i]));
  }
  const StereoRigid right_from_board = right_from_left * left_from_board;
  for (std::size_t i = 0; i < pair.right->object.size(); ++i) {
    sum += error(right, right_from_board * board_point(pair.right->object[i]), image_point(pair.right->image[i]));
  }
  return {sum, pair.left->object.size() + pair.right->object.size()};
}

void measure(const camera::Lens& left, const camera::Lens& right, const std::vector<const PhotoPair*>& pairs, StereoFit& fit) {
  double total = 0;
  std::size_t count = 0;
  fit.pair_rms.clear();
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto [sum, n] = pair_squared_error(left, right, *pairs[k], fit.right_from_left, fit.left_from_board[k]);
    fit.pair_rms.push_back(std::sqrt(sum / static_cast<double>(std::max<std::size_t>(n, 1))));
    total += sum;
    count += n;
  }
  fit.rms = std::sqrt(total / static_cast<double>(std::max<std::size_t>(count, 1)));
}

// The relative pose and every board's pose in the left camera at once, minimising the squared
// reprojection error of every corner in both cameras (Levenberg–Marquardt, the boards eliminated
// by the Schur complement), the lenses fixed.
void refine_jointly(const camera::Lens& left, const camera::Lens& right, const std::vector<const PhotoPair*>& pairs,
                    StereoFit& fit) {
  StereoPoseBlock stereo(fit.right_from_left);
  std::vector<StereoPoseBlock> boards;
  for (const StereoRigid& b : fit.left_from_board) boards.emplace_back(b);
  StereoPoseManifold manifold;  // outlives the problem that refers to it
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const PhotoPair& pair = *pairs[k];
    for (std::size_t i = 0; i < pair.left->object.size(); ++i) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LeftCornerError, 2, 7>(new LeftCornerError(
                                   left, board_point(pair.left->object[i]), image_point(pair.left->image[i]))),
                               nullptr, boards[k].data());
    }
    for (std::size_t i = 0; i < pair.right->object.size(); ++i) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RightCornerError, 2, 7, 7>(new RightCornerError(
                                   right, board_point(pair.right->object[i]), image_point(pair.right->image[i]))),
                               nullptr, stereo.data(), boards[k].data());
    }
  }
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  problem.SetManifold(stereo.data(), &manifold);
  ordering->AddElementToGroup(stereo.data(), 1);
  for (StereoPoseBlock& b : boards) {
    problem.SetManifold(b.data(), &manifold);
    ordering->AddElementToGroup(b.data(), 0);
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.linear_solver_ordering = ordering;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-14;
  options.gradient_tolerance = 1e-14;
  options.parameter_tolerance = 1e-14;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  fit.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  if (summary.IsSolutionUsable()) {
    fit.right_from_left = stereo.rigid();
    for (std::size_t k = 0; k < boards.size(); ++k) fit.left_from_board[k] = boards[k].rigid();
  }
  measure(left, right, pairs, fit);
}

// The first relative pose: one estimate per pair (the board's pose in each camera), rotations
// averaged (chordal mean), then again without those more than 3× the median angle away (at least
// 1°), the translations averaged over the same pairs.
StereoFit initial_fit(const camera::Lens& left, const camera::Lens& right, const std::vector<const PhotoPair*>& pairs,
                      std::vector<std::string>& unposed) {
  StereoFit fit;
  std::vector<StereoRigid> estimates;
  for (const PhotoPair* pair : pairs) {
    const std::optional<StereoRigid> in_left = board_pose(left, *pair->left);
    const std::optional<StereoRigid> in_right = board_pose(right, *pair->right);
    if (!in_left || !in_right) {
      unposed.push_back(pair->name());
      fit.left_from_board.emplace_back();
      continue;
    }
    fit.left_from_board.push_back(*in_left);
    estimates.push_back(*in_right * in_left->inverse());
  }
  if (estimates.empty()) return fit;
  std::vector<Mat3> rotations;
  for (const StereoRigid& e : estimates) rotations.push_back(e.R);
  const Mat3 first = chordal_mean(rotations);
  std::vector<double> angles;
  for (const Mat3& R : rotations) angles.push_back(rotation_angle_deg(first, R));
  const double limit = std::max(3.0 * middle_value(angles), 1.0);
  std::vector<Mat3> kept;
  Vec3 t_sum = Vec3::Zero();
  for (std::size_t k = 0; k < estimates.size(); ++k) {
    if (angles[k] > limit) continue;
    kept.push_back(estimates[k].R);
    t_sum += estimates[k].t;
  }
  fit.right_from_left.R = chordal_mean(kept);
  fit.right_from_left.t = t_sum / static_cast<double>(kept.size());
  return fit;
}

std::string join_rejected(const std::vector<RejectedPair>& rejected) {
  std::string text;
  for (const RejectedPair& r : rejected) {
    if (!text.empty()) text += "; ";
    text += r.name + " (" + r.reason + ")";
  }
  return text;
}

const char* const kMorePairsFix =
    "take 10–20 pairs of sharp photos at the same moment, the whole board in view of both cameras, at several "
    "distances and tilts and covering both images, and check --board and --square against the printed board";

// The intrinsics of one camera, its errors naming the camera.
IntrinsicsResult calibrate_camera(const BoardPhotos& photos, const IntrinsicsOptions& options, const std::string& side) {
  try {
    return calibrate_intrinsics(photos.views, photos.rejected, photos.image_size, options);
  } catch (const InputError& e) {
    throw InputError("the " + side + " camera: " + e.what());
  }
}

const RejectedView* find_rejected(const IntrinsicsResult& result, const std::string& name) {
  const auto it = std::find_if(result.rejected.begin(), result.rejected.end(), [&](const RejectedView& r) { return r.name == name; });
  return it == result.rejected.end() ? nullptr : &*it;
}

bool used_by(const IntrinsicsResult& result, const std::string& name) {
  return std::any_of(result.used.begin(), result.used.end(), [&](const NamedView& v) { return v.name == name; });
}

// Why a pair is not used, or empty when both of its views calibrated their cameras.
std::string pair_problem(const PhotoPair& pair, const IntrinsicsResult& left, const IntrinsicsResult& right) {
  const std::string left_name = pair.left_file.filename().string(), right_name = pair.right_file.filename().string();
  if (!pair.left && !pair.right) {
    return "the board is found in neither photo (" + left_name + ": " + pair.left_reason + "; " + right_name + ": " +
           pair.right_reason + ")";
  }
  if (!pair.right) return "the board is found in the left photo only (" + right_name + ": " + pair.right_reason + ")";
  if (!pair.left) return "the board is found in the right photo only (" + left_name + ": " + pair.left_reason + ")";
  for (const auto& [name, result, side] : {std::tuple{left_name, &left, "left"}, std::tuple{right_name, &right, "right"}}) {
    if (used_by(*result, name)) continue;
    const RejectedView* why = find_rejected(*result, name);
    return name + " was left out of the " + side + " camera's calibration" + (why ? ": " + why->reason : std::string());
  }
  return {};
}

// R1, R2, P1, P2 of the rectification (OpenCV's), for the two models alike: both pinhole with
// cv::stereoRectify, both fisheye with cv::fisheye::stereoRectify, a pinhole with a fisheye with
// cv::stereoRectify on the bare camera matrices.
struct Rectification {
  cv::Mat R1, R2, P1, P2;
  cv::Size size;
};

cv::Mat camera_matrix(const camera::CameraCalibration& c) {
  return (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
}

Rectification rectification(const camera::StereoCalibration& s) {
  Rectification r;
  r.size = cv::Size(s.left.image_width, s.left.image_height);
  cv::Mat R(3, 3, CV_64F), T(3, 1, CV_64F), Q;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) R.at<double>(i, j) = s.R_right_from_left(i, j);
    T.at<double>(i) = s.t_right_from_left(i);
  }
  const cv::Mat K1 = camera_matrix(s.left), K2 = camera_matrix(s.right);
  const cv::Mat D1(s.left.D, true), D2(s.right.D, true);
  const bool left_fisheye = s.left.model == camera::LensModel::Fisheye;
  const bool right_fisheye = s.right.model == camera::LensModel::Fisheye;
  if (left_fisheye && right_fisheye) {
    cv::fisheye::stereoRectify(K1, D1, K2, D2, r.size, R, T, r.R1, r.R2, r.P1, r.P2, Q, cv::CALIB_ZERO_DISPARITY, r.size, 0.0,
                               1.0);
  } else if (!left_fisheye && !right_fisheye) {
    cv::stereoRectify(K1, D1, K2, D2, r.size, R, T, r.R1, r.R2, r.P1, r.P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0);
  } else {
    cv::stereoRectify(K1, cv::noArray(), K2, cv::noArray(), r.size, R, T, r.R1, r.R2, r.P1, r.P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0);
  }
  return r;
}

// A detected corner's place in the rectified image.
std::optional<cv::Point2d> rectified_point(const camera::Lens& lens, const cv::Mat& R, const cv::Mat& P, const cv::Point2f& pixel) {
  const std::optional<Vec3> d = lens.unproject(Vec2(pixel.x, pixel.y));
  if (!d) return std::nullopt;
  Mat3 Rr;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) Rr(i, j) = R.at<double>(i, j);
  }
  const Vec3 v = Rr * *d;
  if (v.z() <= 1e-6) return std::nullopt;
  return cv::Point2d(P.at<double>(0, 0) * v.x() / v.z() + P.at<double>(0, 2), P.at<double>(1, 1) * v.y() / v.z() + P.at<double>(1, 2));
}

cv::Mat rectified_image(const camera::CameraCalibration& c, const cv::Mat& image, const cv::Mat& R, const cv::Mat& P,
                        cv::Size size) {
  cv::Mat map1, map2, out;
  const cv::Mat K = camera_matrix(c), D(c.D, true);
  if (c.model == camera::LensModel::Fisheye) {
    cv::fisheye::initUndistortRectifyMap(K, D, R, P, size, CV_32FC1, map1, map2);
  } else {
    cv::initUndistortRectifyMap(K, D, R, P, size, CV_32FC1, map1, map2);
  }
  cv::Mat bgr;
  if (image.channels() == 1) {
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  } else {
    bgr = image;
  }
  cv::remap(bgr, out, map1, map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0, 0, 0));
  return out;
}

}  // namespace

std::string PhotoPair::name() const { return left_file.filename().string() + " + " + right_file.filename().string(); }

StereoPhotos detect_stereo_boards(std::span<const fs::path> left_photos, std::span<const fs::path> right_photos,
                                  const BoardDetector& detector) {
  if (left_photos.size() != right_photos.size()) {
    throw InputError(input_message("", -1, -1, "--left/--right",
                                   std::to_string(left_photos.size()) + " left photo(s) but " +
                                       std::to_string(right_photos.size()) + " right photo(s)",
                                   "give the photos in pairs taken at the same moment, the k-th --left photo with the k-th "
                                   "--right one, as many of each"));
  }
  for (const auto& [photos, option] : {std::pair{left_photos, "--left"}, std::pair{right_photos, "--right"}}) {
    std::set<std::string> names;
    for (const fs::path& p : photos) {
      if (!names.insert(p.filename().string()).second) {
        throw InputError(input_message("", -1, -1, option, "two photos are named " + p.filename().string(),
                                       "give each photo of a camera its own file name (the reports name photos by it)"));
      }
    }
  }
  StereoPhotos out;
  out.left = detect_boards(left_photos, detector);
  out.right = detect_boards(right_photos, detector);
  const auto fill = [](const BoardPhotos& found, const fs::path& file, std::optional<BoardView>& view, std::string& reason) {
    const std::string name = file.filename().string();
    for (const NamedView& v : found.views) {
      if (v.name == name) view = v.view;
    }
    for (const RejectedView& r : found.rejected) {
      if (r.name == name) reason = r.reason;
    }
  };
  for (std::size_t k = 0; k < left_photos.size(); ++k) {
    PhotoPair pair;
    pair.left_file = left_photos[k];
    pair.right_file = right_photos[k];
    fill(out.left, pair.left_file, pair.left, pair.left_reason);
    fill(out.right, pair.right_file, pair.right, pair.right_reason);
    out.pairs.push_back(std::move(pair));
  }
  return out;
}

StereoResult calibrate_stereo(const StereoPhotos& photos, const StereoOptions& options) {
  StereoResult result;
  result.left = calibrate_camera(photos.left, options.left, "left");
  result.right = calibrate_camera(photos.right, options.right, "right");
  const camera::Lens left(result.left.calibration), right(result.right.calibration);

  std::vector<const PhotoPair*> pairs;
  std::vector<std::size_t> indices;
  for (std::size_t k = 0; k < photos.pairs.size(); ++k) {
    const std::string problem = pair_problem(photos.pairs[k], result.left, result.right);
    if (problem.empty()) {
      pairs.push_back(&photos.pairs[k]);
      indices.push_back(k);
    } else {
      result.rejected.push_back({photos.pairs[k].name(), problem});
    }
  }
  const auto too_few = [&](std::size_t usable) {
    std::string problem = std::to_string(usable) + " usable pair(s) of " + std::to_string(photos.pairs.size()) +
                          "; the stereo calibration needs at least " + std::to_string(options.min_pairs) +
                          " with the board in both photos";
    if (!result.rejected.empty()) problem += ". Not used: " + join_rejected(result.rejected);
    throw InputError(problem + ". Fix: " + kMorePairsFix);
  };
  if (static_cast<int>(pairs.size()) < options.min_pairs) too_few(pairs.size());

  std::vector<std::string> unposed;
  StereoFit fit = initial_fit(left, right, pairs, unposed);
  if (!unposed.empty()) {
    // A board no PnP could pose: dropped with its reason.
    for (std::size_t k = pairs.size(); k-- > 0;) {
      if (std::find(unposed.begin(), unposed.end(), pairs[k]->name()) == unposed.end()) continue;
      result.rejected.push_back({pairs[k]->name(), "the board's pose could not be found in both photos"});
      pairs.erase(pairs.begin() + static_cast<std::ptrdiff_t>(k));
      indices.erase(indices.begin() + static_cast<std::ptrdiff_t>(k));
      fit.left_from_board.erase(fit.left_from_board.begin() + static_cast<std::ptrdiff_t>(k));
    }
    if (static_cast<int>(pairs.size()) < options.min_pairs) too_few(pairs.size());
  }
  refine_jointly(left, right, pairs, fit);

  // Outlier pairs, once: their errors are measured against a fit they took part in.
  const double limit = std::max(options.outlier_factor * middle_value(fit.pair_rms), options.outlier_floor_px);
  std::vector<std::size_t> keep;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (fit.pair_rms[k] <= limit) keep.push_back(k);
  }
  if (keep.size() < pairs.size() && static_cast<int>(keep.size()) >= options.min_pairs) {
    std::vector<const PhotoPair*> kept_pairs;
    std::vector<std::size_t> kept_indices;
    std::vector<StereoRigid> kept_boards;
    std::size_t next = 0;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      if (next < keep.size() && keep[next] == k) {
        kept_pairs.push_back(pairs[k]);
        kept_indices.push_back(indices[k]);
        kept_boards.push_back(fit.left_from_board[k]);
        ++next;
      } else {
        result.rejected.push_back({pairs[k]->name(), format("reprojection error %.2f px", fit.pair_rms[k]) +
                                                         format(", over %.2f px (3× the median): blurred, the board moved "
                                                                "between the two photos, or they were not taken at the same moment",
                                                                limit)});
      }
    }
    pairs = std::move(kept_pairs);
    indices = std::move(kept_indices);
    fit.left_from_board = std::move(kept_boards);
    refine_jointly(left, right, pairs, fit);
  }

  camera::StereoCalibration& s = result.calibration;
  s.left = result.left.calibration;
  s.right = result.right.calibration;
  s.R_right_from_left = fit.right_from_left.R;
  s.t_right_from_left = fit.right_from_left.t;
  s.rms = fit.rms;
  s.per_pair_errors = fit.pair_rms;
  result.iterations = fit.iterations;
  for (std::size_t k = 0; k < pairs.size(); ++k) result.used.push_back({indices[k], pairs[k]->name(), fit.pair_rms[k]});

  // The rectification check: a corner's rows in the two rectified images.
  const Rectification r = rectification(s);
  std::vector<double> row_errors;
  for (const PhotoPair* pair : pairs) {
    for (std::size_t i = 0; i < pair->left->image.size(); ++i) {
      // The same board corner in the right photo (a ChArUco view holds the corners it saw).
      const std::vector<cv::Point3f>& right_object = pair->right->object;
      const auto same = std::find(right_object.begin(), right_object.end(), pair->left->object[i]);
      if (same == right_object.end()) continue;
      const std::optional<cv::Point2d> a = rectified_point(left, r.R1, r.P1, pair->left->image[i]);
      const std::optional<cv::Point2d> b =
          rectified_point(right, r.R2, r.P2, pair->right->image[static_cast<std::size_t>(same - right_object.begin())]);
      if (a && b) row_errors.push_back(std::abs(a->y - b->y));
    }
  }
  if (!row_errors.empty()) {
    double sum = 0;
    for (double e : row_errors) sum += e;
    result.rectified_row_error_px = sum / static_cast<double>(row_errors.size());
    // A corner or two found a few pixels off in one photo would make the largest misleading.
    const auto p95 = row_errors.begin() + static_cast<std::ptrdiff_t>(0.95 * static_cast<double>(row_errors.size() - 1));
    std::nth_element(row_errors.begin(), p95, row_errors.end());
    result.rectified_row_error_p95_px = *p95;
  }

  if (static_cast<int>(result.used.size()) < options.recommended_pairs) {
    result.advice.push_back("only " + std::to_string(result.used.size()) + " pair(s) were used: take at least " +
                            std::to_string(options.recommended_pairs) +
                            " pairs with the whole board in view of both cameras, at several distances and tilts");
  }
  if (fit.rms > options.max_rms_px) {
    result.advice.push_back(format("the RMS reprojection error %.2f px", fit.rms) + format(" is above %.1f px: ", options.max_rms_px) +
                            "check that both photos of a pair were taken at the same moment with the board held still, "
                            "that the board is flat and rigid, and that each camera's own error is small");
  }
  if (!result.rejected.empty()) {
    result.advice.push_back(std::to_string(result.rejected.size()) + " pair(s) were not used: " + join_rejected(result.rejected) +
                            "; retake them with the whole board in view of both cameras, sharp and evenly lit");
  }
  for (const auto& [intrinsics, side] : {std::pair{&result.left, "left"}, std::pair{&result.right, "right"}}) {
    for (std::string line : intrinsics->advice) {
      // stereo draws no coverage image: the advice stands without the pointer to one.
      const std::string pointer = " (see the coverage image)";
      if (const std::size_t at = line.find(pointer); at != std::string::npos) line.erase(at, pointer.size());
      result.advice.push_back(std::string(side) + " camera: " + line);
    }
  }
  return result;
}

cv::Mat draw_rectification(const StereoResult& result, const PhotoPair& pair, const cv::Mat& left_image, const cv::Mat& right_image) {
  const camera::StereoCalibration& s = result.calibration;
  const Rectification r = rectification(s);
  cv::Mat left = rectified_image(s.left, left_image, r.R1, r.P1, r.size);
  cv::Mat right = rectified_image(s.right, right_image, r.R2, r.P2, r.size);
  const double scale = std::max(r.size.width, r.size.height) / 1000.0;
  const int thick = std::max(1, static_cast<int>(std::lround(scale)));
  // The corners, where both photos found them, on their rectified rows.
  const camera::Lens left_lens(s.left), right_lens(s.right);
  const int radius = std::max(2, static_cast<int>(std::lround(3 * scale)));
  for (const auto& [image, lens, view, R, P] :
       {std::tuple{&left, &left_lens, &pair.left, &r.R1, &r.P1}, std::tuple{&right, &right_lens, &pair.right, &r.R2, &r.P2}}) {
    if (!*view) continue;
    for (const cv::Point2f& p : (*view)->image) {
      if (const std::optional<cv::Point2d> q = rectified_point(*lens, *R, *P, p)) {
        cv::circle(*image, *q, radius, cv::Scalar(0, 0, 255), cv::FILLED, cv::LINE_AA);
      }
    }
  }
  cv::Mat canvas;
  cv::hconcat(left, right, canvas);
  const int lines = 24;
  for (int k = 1; k < lines; ++k) {
    const int y = k * canvas.rows / lines;
    cv::line(canvas, {0, y}, {canvas.cols - 1, y}, cv::Scalar(0, 220, 0), thick, cv::LINE_AA);
  }
  cv::line(canvas, {left.cols, 0}, {left.cols, canvas.rows - 1}, cv::Scalar(255, 255, 255), thick);
  const double font = 0.5 * std::max(scale, 0.6);
  const int height = static_cast<int>(std::lround(24 * std::max(scale, 0.6)));
  const std::string line1 = pair.name() + ", rectified";
  const std::string line2 = format("rows of the corners differ by %.2f px (mean)", result.rectified_row_error_px) +
                            format(", RMS %.2f px", s.rms.value_or(0.0));
  for (const auto& [text, row] : {std::pair{line1, 1}, std::pair{line2, 2}}) {
    cv::putText(canvas, text, {height / 2, row * height}, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), 3 * thick,
                cv::LINE_AA);
    cv::putText(canvas, text, {height / 2, row * height}, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(255, 255, 255), thick,
                cv::LINE_AA);
  }
  return canvas;
}

std::string stereo_yaml(const StereoResult& result, const StereoPhotos& photos, const std::string& summary) {
  std::ostringstream out;
  out << "# Written by " << summary << ", from " << result.used.size() << " of " << photos.pairs.size() << " pair(s).\n"
      << "# Each camera's R_site_from_camera is the identity: the head pose places the left camera, and\n"
      << "# R_right_from_left, t_right_from_left the right one.\n"
      << camera::stereo_calibration_to_yaml(result.calibration) << "# per_pair_errors follow the pairs in this order:";
  for (const UsedPair& p : result.used) out << " " << p.name << ";";
  out << "\n";
  if (!result.rejected.empty()) {
    out << "# pairs not used:\n";
    for (const RejectedPair& r : result.rejected) out << "#   " << r.name << ": " << r.reason << "\n";
  }
  return out.str();
}

}  // namespace skylit::calib
