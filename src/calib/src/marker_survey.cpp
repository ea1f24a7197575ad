// A marker map from photos: chained initial poses, then a bundle adjustment of every camera and
// tag pose over every corner (Ceres: automatic differentiation through the lens, a robust loss,
// sparse Schur complement), and the tags' covariance.
#include "skylit/calib/marker_survey.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <thread>

#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "skylit/base/error.hpp"
#include "skylit/track/marker_pose.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/geom/angles.hpp"
#include "skylit/sky/radiometry.hpp"

namespace skylit::calib {
namespace {

using geom::kDeg;
using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
// A corner this close to the camera's plane (metres in front) is left out of a step: the lens
// model cannot image it and its derivative is meaningless.
constexpr double kMinDepth = 1e-3;

// y = R · x + t.
struct Rigid {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();

  Vec3 operator*(const Vec3& x) const { return R * x + t; }
  Rigid operator*(const Rigid& other) const { return {R * other.R, R * other.t + t}; }
  Rigid inverse() const { return {R.transpose(), -(R.transpose() * t)}; }
};

Rigid camera_from_site(const track::Pose& pose) {
  const Rigid site_from_camera{pose.R_site_from_camera.toRotationMatrix(), pose.t_site_from_camera};
  return site_from_camera.inverse();
}

Rigid site_from_tag(const track::MarkerTag& tag) { return {tag.R_site_from_tag.toRotationMatrix(), tag.t_site_from_tag}; }

double angle_between_deg(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg; }

// A tag seen in a photo.
struct Sighting {
  std::size_t photo = 0;
  const track::TagDetection* detection = nullptr;
};

std::string join_ids(const std::vector<int>& ids) {
  std::string text;
  for (int id : ids) {
    if (!text.empty()) text += ", ";
    text += std::to_string(id);
  }
  return text;
}

[[noreturn]] void refuse(const std::string& field, const std::string& problem, const std::string& fix) {
  throw InputError(input_message("", -1, -1, field, problem, fix));
}

void check_options(const MarkerSurveyOptions& o) {
  (void)track::tag_family_layout(o.family);  // std::invalid_argument for an unknown family
  if (o.origin_id < 0) refuse("--origin", "a tag id is not negative", "give the id printed under the origin tag");
  const auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!(o.default_size == 0 || positive(o.default_size))) {
    refuse("--size", "the tag size must be a positive length", "give the edge of the tags' black square in metres, e.g. --size 0.2");
  }
  for (const auto& [id, size] : o.sizes) {
    if (!positive(size)) {
      refuse("--tag-size", "tag " + std::to_string(id) + " has a size that is not a positive length",
             "give ID=METRES, the edge of its black square, e.g. --tag-size 3=0.16");
    }
  }
  if (o.min_photos < 1) refuse("min_photos", "must be at least 1", "use 2 (the default)");
  if (!positive(o.robust_px)) refuse("robust_px", "must be a positive number of pixels", "use 2 (the default)");
  if (o.max_iterations < 1) refuse("max_iterations", "must be at least 1", "use 100 (the default)");
  const Eigen::Quaterniond& q = o.origin_pose.R_site_from_tag;
  if (std::abs(q.norm() - 1) > 1e-3 || !o.origin_pose.t_site_from_tag.allFinite()) {
    refuse("--origin-pose", "the orientation is not a unit quaternion", "give x,y,z,qw,qx,qy,qz with qw²+qx²+qy²+qz² = 1");
  }
}

// The state of the refinement: every posed photo's camera-from-site and every mapped tag's
// site-from-tag (the origin's fixed).
struct SurveyState {
  std::vector<Rigid> cameras;  // by camera index
  std::vector<Rigid> tags;     // by tag index
};

struct Corner {
  std::size_t camera = 0;      // camera index
  std::size_t tag = 0;         // tag index
  Vec3 in_tag;                 // the corner in its tag's frame
  Vec2 detected;               // pixels
};

// The residual of one corner (pixels); nullopt when it cannot be imaged.
std::optional<Vec2> corner_residual(const camera::Lens& lens, const SurveyState& s, const Corner& c) {
  const Vec3 camera = s.cameras[c.camera] * (s.tags[c.tag] * c.in_tag);
  if (camera.z() < kMinDepth) return std::nullopt;
  const std::optional<Vec2> pixel = lens.project(camera);
  if (!pixel) return std::nullopt;
  return *pixel - c.detected;
}

// A pose as one Ceres parameter block: a unit quaternion (Eigen's x, y, z, w order), then the
// translation. One block per pose, so that the cameras form an independent set to eliminate.
struct PoseBlock {
  std::array<double, 7> x{};

  explicit PoseBlock(const Rigid& pose) {
    Eigen::Map<Eigen::Quaterniond>(x.data()) = Eigen::Quaterniond(pose.R).normalized();
    Eigen::Map<Vec3>(x.data() + 4) = pose.t;
  }
  double* data() { return x.data(); }
  Rigid rigid() const {
    return {Eigen::Map<const Eigen::Quaterniond>(x.data()).normalized().toRotationMatrix(), Eigen::Map<const Vec3>(x.data() + 4)};
  }
};
using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;

// One corner's reprojection error through the camera's pose, the tag's pose and the lens, with
// exact derivatives (automatic differentiation through the lens model too). A corner that cannot
// be imaged at a trial step makes that step fail, so the solver takes a shorter one.
class CornerReprojection {
 public:
  CornerReprojection(const camera::Lens& lens, const Vec3& in_tag, const Vec2& detected)
      : lens_(lens), in_tag_(in_tag), detected_(detected) {}

  template <typename T>
  bool operator()(const T* camera_from_site, const T* site_from_tag, T* residual) const {
    using V3 = Eigen::Matrix<T, 3, 1>;
    using Rotation = Eigen::Map<const Eigen::Quaternion<T>>;
    const V3 site = Rotation(site_from_tag) * in_tag_.cast<T>() + Eigen::Map<const V3>(site_from_tag + 4);
    const V3 in_camera = Rotation(camera_from_site) * site + Eigen::Map<const V3>(camera_from_site + 4);
    if (in_camera.z() < kMinDepth) return false;
    const std::optional<Eigen::Matrix<T, 2, 1>> pixel = lens_.project_as<T>(in_camera);
    if (!pixel) return false;
    residual[0] = pixel->x() - detected_.x();
    residual[1] = pixel->y() - detected_.y();
    return true;
  }

 private:
  const camera::Lens& lens_;
  Vec3 in_tag_;
  Vec2 detected_;
};

struct Refinement {
  int iterations = 0;
  // 1σ of each tag's rotation (radians) and position (metres), the origin's 0; +inf where the
  // fit does not determine the tag (a rank-deficient Jacobian).
  std::vector<double> sigma_rotation, sigma_position;
};

// Every camera and free tag pose at once, minimising the corners' robustly weighted reprojection
// error (Ceres: Levenberg–Marquardt, the Schur complement over the cameras, sparse), then the
// tags' covariance σ² (JᵀJ)⁻¹ with σ² from the residuals left.
Refinement refine(const camera::Lens& lens, const std::vector<Corner>& corners, const std::vector<bool>& tag_free,
                  const MarkerSurveyOptions& o, SurveyState& state) {
  std::vector<PoseBlock> cameras, tags;
  for (const Rigid& c : state.cameras) cameras.emplace_back(c);
  for (const Rigid& t : state.tags) tags.emplace_back(t);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  std::unique_ptr<ceres::LossFunction> loss;
  if (o.loss == MarkerSurveyOptions::RobustLoss::Cauchy) {
    loss = std::make_unique<ceres::CauchyLoss>(o.robust_px);
  } else {
    loss = std::make_unique<ceres::HuberLoss>(o.robust_px);
  }
  PoseManifold pose_manifold;
  for (const Corner& c : corners) {
    // Corners the starting poses cannot image are left out (a solver cannot start from them).
    if (!corner_residual(lens, state, c)) continue;
    auto* cost = new ceres::AutoDiffCostFunction<CornerReprojection, 2, 7, 7>(new CornerReprojection(lens, c.in_tag, c.detected));
    problem.AddResidualBlock(cost, loss.get(), cameras[c.camera].data(), tags[c.tag].data());
  }
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (PoseBlock& c : cameras) {
    if (!problem.HasParameterBlock(c.data())) continue;
    problem.SetManifold(c.data(), &pose_manifold);
    ordering->AddElementToGroup(c.data(), 0);
  }
  for (std::size_t t = 0; t < tags.size(); ++t) {
    if (!problem.HasParameterBlock(tags[t].data())) continue;
    problem.SetManifold(tags[t].data(), &pose_manifold);
    if (!tag_free[t]) problem.SetParameterBlockConstant(tags[t].data());
    ordering->AddElementToGroup(tags[t].data(), 1);
  }

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) ? ceres::SPARSE_SCHUR
                                                                                                     : ceres::DENSE_SCHUR;
  options.linear_solver_ordering = ordering;  // cameras eliminated first: a site has more photos than tags
  options.max_num_iterations = o.max_iterations;
  options.function_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  options.num_threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);

  Refinement out;
  out.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  if (summary.IsSolutionUsable()) {
    for (std::size_t k = 0; k < cameras.size(); ++k) state.cameras[k] = cameras[k].rigid();
    for (std::size_t t = 0; t < tags.size(); ++t) state.tags[t] = tags[t].rigid();
  }

  out.sigma_rotation.assign(tags.size(), 0.0);
  out.sigma_position.assign(tags.size(), 0.0);
  double squared = 0;
  int imaged = 0;
  for (const Corner& c : corners) {
    if (const std::optional<Vec2> r = corner_residual(lens, state, c)) {
      squared += r->squaredNorm();
      ++imaged;
    }
  }
  std::size_t unknowns = 6 * cameras.size();
  for (bool free : tag_free) unknowns += free ? 6 : 0;
  const double redundancy = 2.0 * imaged - static_cast<double>(unknowns);
  const double sigma2 = redundancy > 0 ? squared / redundancy : 0.0;
  std::vector<std::pair<const double*, const double*>> blocks;
  for (std::size_t t = 0; t < tags.size(); ++t) {
    if (tag_free[t] && problem.HasParameterBlock(tags[t].data())) blocks.emplace_back(tags[t].data(), tags[t].data());
  }
  ceres::Covariance::Options covariance_options;
  covariance_options.num_threads = options.num_threads;
  ceres::Covariance covariance(covariance_options);
  const bool computed = !blocks.empty() && covariance.Compute(blocks, &problem);
  for (std::size_t t = 0; t < tags.size(); ++t) {
    if (!tag_free[t]) continue;
    // In the manifold's tangent: rotation, then translation.
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> tangent = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>::Constant(
        std::numeric_limits<double>::infinity());
    if (computed && problem.HasParameterBlock(tags[t].data())) {
      covariance.GetCovarianceBlockInTangentSpace(tags[t].data(), tags[t].data(), tangent.data());
    }
    // The quaternion manifold's tangent is half the rotation angle: exp(δ) = (cos|δ|, sin|δ| δ/|δ|).
    out.sigma_rotation[t] = 2 * std::sqrt(std::max(0.0, sigma2 * tangent.topLeftCorner<3, 3>().trace()));
    out.sigma_position[t] = std::sqrt(std::max(0.0, sigma2 * tangent.bottomRightCorner<3, 3>().trace()));
  }
  return out;
}

// The tag's pose in the site from one photo whose camera is known, through the tag's two planar
// solutions: the pose in the camera from a map holding the tag alone, at identity.
std::vector<Rigid> tag_candidates(const track::TagDetection& detection, double size, const Rigid& cam_from_site,
                                  const camera::Lens& lens) {
  track::MarkerMap alone;
  track::MarkerTag tag;
  tag.id = detection.id;
  tag.size = size;
  alone.tags.push_back(tag);
  const track::MarkerSolve solve = track::solve_marker_pose(alone, lens, std::span(&detection, 1));
  std::vector<Rigid> candidates;
  const Rigid site_from_cam = cam_from_site.inverse();
  for (const std::optional<track::Pose>& pose : {solve.pose, solve.alternative}) {
    if (!pose) continue;
    // The pose is the camera in the tag's frame: tag_from_camera.
    const Rigid tag_from_camera{pose->R_site_from_camera.toRotationMatrix(), pose->t_site_from_camera};
    candidates.push_back(site_from_cam * tag_from_camera.inverse());
  }
  return candidates;
}

double squared_error(const track::TagDetection& detection, double size, const Rigid& site_from_tag_pose,
                     const Rigid& cam_from_site, const camera::Lens& lens) {
  double sum = 0;
  for (int k = 0; k < 4; ++k) {
    const Vec3 in_camera = cam_from_site * (site_from_tag_pose * track::tag_corner_in_tag(size, k));
    const std::optional<Vec2> pixel = in_camera.z() >= kMinDepth ? lens.project(in_camera) : std::nullopt;
    const double e = pixel ? (*pixel - detection.corners[static_cast<std::size_t>(k)]).norm() : 1e4;
    sum += e * e;
  }
  return sum;
}

track::MarkerTag to_tag(int id, double size, const Rigid& pose) {
  track::MarkerTag tag;
  tag.id = id;
  tag.size = size;
  tag.R_site_from_tag = Eigen::Quaterniond(pose.R).normalized();
  tag.t_site_from_tag = pose.t;
  return tag;
}

}  // namespace

std::vector<MarkerPhoto> detect_marker_photos(std::span<const std::filesystem::path> photos, const camera::CameraCalibration& camera,
                                              const track::TagDetectorOptions& detector_options) {
  track::TagDetector detector(detector_options);
  std::vector<MarkerPhoto> out;
  for (const std::filesystem::path& file : photos) {
    const cv::Mat image = sky::read_image(file, cv::IMREAD_GRAYSCALE);
    if (image.empty()) {
      throw InputError(input_message(file, -1, -1, "photo", "cannot be read as an image", "give JPEG or PNG photos of the site"));
    }
    if (image.cols != camera.image_width || image.rows != camera.image_height) {
      throw InputError(input_message(
          file, -1, -1, "photo",
          "is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + " but the camera calibration (" +
              camera.file.string() + ") is " + std::to_string(camera.image_width) + "x" + std::to_string(camera.image_height),
          "take the photos with the calibrated camera at its calibrated resolution, or calibrate it at this one "
          "(skylit-calib camera)"));
    }
    out.push_back({file.filename().string(), detector.detect(image)});
  }
  return out;
}

MarkerSurvey survey_markers(std::span<const MarkerPhoto> given, const camera::CameraCalibration& camera,
                            const MarkerSurveyOptions& options) {
  check_options(options);
  // An id found twice in one photo is on the site twice (or misread): neither copy can be
  // trusted, so both are left out of that photo and the installer is told.
  std::vector<MarkerPhoto> photos;
  std::vector<std::string> duplicate_advice;
  for (const MarkerPhoto& photo : given) {
    std::map<int, int> count;
    for (const track::TagDetection& d : photo.detections) ++count[d.id];
    MarkerPhoto kept{photo.name, {}};
    for (const track::TagDetection& d : photo.detections) {
      if (count[d.id] == 1) kept.detections.push_back(d);
    }
    for (const auto& [id, n] : count) {
      if (n > 1) {
        duplicate_advice.push_back("tag " + std::to_string(id) + " is seen " + std::to_string(n) + " times in " + photo.name +
                                   " (left out of that photo): each id must be on the site once; replace the copies");
      }
    }
    photos.push_back(std::move(kept));
  }
  const camera::Lens lens(camera);
  const auto size_of = [&](int id) {
    const auto it = options.sizes.find(id);
    return it != options.sizes.end() ? it->second : options.default_size;
  };

  // Which photos saw each tag.
  std::map<int, std::vector<Sighting>> sightings;
  for (std::size_t p = 0; p < photos.size(); ++p) {
    for (const track::TagDetection& d : photos[p].detections) sightings[d.id].push_back({p, &d});
  }
  if (!sightings.contains(options.origin_id)) {
    std::vector<int> seen;
    for (const auto& [id, list] : sightings) seen.push_back(id);
    refuse("--origin",
           "the origin tag " + std::to_string(options.origin_id) + " is in none of the " + std::to_string(photos.size()) +
               " photo(s) (" + (seen.empty() ? std::string("no tags of family ") + options.family + " found at all" : "tags seen: " + join_ids(seen)) + ")",
           seen.empty() ? "check --family and that the tags are sharp and at least 30 px across in the photos"
                        : "photograph the origin tag together with the others, or choose a tag that was seen with --origin");
  }
  if (size_of(options.origin_id) <= 0) {
    refuse("--size", "the origin tag " + std::to_string(options.origin_id) + " has no size",
           "give --size METRES (every tag) or --tag-size " + std::to_string(options.origin_id) + "=METRES");
  }

  // Chaining: pose the photos that see placed tags, place the tags those photos see, repeat.
  std::map<int, Rigid> placed;
  placed[options.origin_id] = site_from_tag(options.origin_pose);
  std::vector<std::optional<Rigid>> posed(photos.size());
  const auto known_in = [&](std::size_t p) {
    track::MarkerMap map;
    map.family = options.family;
    std::vector<track::TagDetection> seen;
    for (const track::TagDetection& d : photos[p].detections) {
      const auto it = placed.find(d.id);
      if (it == placed.end()) continue;
      map.tags.push_back(to_tag(d.id, size_of(d.id), it->second));
      seen.push_back(d);
    }
    return std::pair(map, seen);
  };
  for (bool progress = true; progress;) {
    progress = false;
    // Photos resting on one tag whose two planar solutions fit alike wait until nothing else
    // can be posed: by then another photo may have placed a second tag for them.
    for (bool accept_ambiguous : {false, true}) {
      for (std::size_t p = 0; p < photos.size(); ++p) {
        if (posed[p]) continue;
        const auto [map, seen] = known_in(p);
        if (map.tags.empty()) continue;
        const track::MarkerSolve solve = track::solve_marker_pose(map, lens, seen);
        if (!solve.pose || (solve.ambiguous && !accept_ambiguous)) continue;
        posed[p] = camera_from_site(*solve.pose);
        progress = true;
      }
      if (progress) break;
    }
    for (const auto& [id, list] : sightings) {
      if (placed.contains(id) || size_of(id) <= 0) continue;
      std::vector<const Sighting*> in_posed;
      for (const Sighting& s : list) {
        if (posed[s.photo]) in_posed.push_back(&s);
      }
      if (in_posed.empty()) continue;
      // Every photo's candidates, judged by their error in all the posed photos that see the tag.
      std::optional<Rigid> best;
      double best_error = std::numeric_limits<double>::infinity();
      for (const Sighting* s : in_posed) {
        for (const Rigid& candidate : tag_candidates(*s->detection, size_of(id), *posed[s->photo], lens)) {
          double error = 0;
          for (const Sighting* other : in_posed) error += squared_error(*other->detection, size_of(id), candidate, *posed[other->photo], lens);
          if (error < best_error) {
            best_error = error;
            best = candidate;
          }
        }
      }
      if (!best) continue;
      placed[id] = *best;
      progress = true;
    }
  }

  // Tags seen in too few posed photos are left out; photos that then see no mapped tag with them.
  MarkerSurvey survey;
  const auto posed_photos_of = [&](int id) {
    int count = 0;
    for (const Sighting& s : sightings[id]) count += posed[s.photo] ? 1 : 0;
    return count;
  };
  for (bool changed = true; changed;) {
    changed = false;
    for (auto it = placed.begin(); it != placed.end();) {
      if (it->first != options.origin_id && posed_photos_of(it->first) < options.min_photos) {
        it = placed.erase(it);
        changed = true;
      } else {
        ++it;
      }
    }
    for (std::size_t p = 0; p < photos.size(); ++p) {
      if (!posed[p]) continue;
      const bool sees_mapped = std::any_of(photos[p].detections.begin(), photos[p].detections.end(),
                                           [&](const track::TagDetection& d) { return placed.contains(d.id); });
      if (!sees_mapped) {
        posed[p].reset();
        changed = true;
      }
    }
  }
  std::vector<int> placed_ids;
  for (const auto& [id, pose] : placed) placed_ids.push_back(id);
  for (const auto& [id, list] : sightings) {
    if (placed.contains(id)) continue;
    LeftOutTag left{id, static_cast<int>(list.size()), ""};
    const int in_posed = posed_photos_of(id);
    const std::string with = "take a photo showing tag " + std::to_string(id) + " together with a mapped tag (" + join_ids(placed_ids) + ")";
    if (size_of(id) <= 0) {
      left.reason = "no size given: add --tag-size " + std::to_string(id) + "=METRES, or --size for every tag";
    } else if (in_posed == 0) {
      left.reason = "never seen together with a mapped tag, so it cannot be placed: " + with;
    } else {
      left.reason = "seen in " + std::to_string(in_posed) + " posed photo(s), fewer than " + std::to_string(options.min_photos) +
                    ", so nothing checks its pose: " + with + " from another place";
    }
    survey.left_out.push_back(left);
  }

  // The unknowns.
  std::vector<std::size_t> camera_of_photo(photos.size(), 0);
  std::vector<std::size_t> photo_of_camera;
  SurveyState state;
  for (std::size_t p = 0; p < photos.size(); ++p) {
    if (!posed[p]) continue;
    camera_of_photo[p] = photo_of_camera.size();
    photo_of_camera.push_back(p);
    state.cameras.push_back(*posed[p]);
  }
  if (photo_of_camera.size() < 2) {
    refuse("photos",
           "too few views: " + std::to_string(photo_of_camera.size()) + " of " + std::to_string(photos.size()) +
               " photo(s) could be posed from the origin tag " + std::to_string(options.origin_id) +
               " and the tags chained to it; the map needs at least 2",
           "take 6 or more photos from different places, each showing two or more tags, the origin tag in several of "
           "them");
  }
  std::map<int, std::size_t> tag_index;
  std::vector<int> tag_ids;
  std::vector<bool> tag_free;
  for (const auto& [id, pose] : placed) {
    tag_index[id] = tag_ids.size();
    tag_ids.push_back(id);
    tag_free.push_back(id != options.origin_id);
    state.tags.push_back(pose);
  }
  std::vector<Corner> corners;
  for (std::size_t p = 0; p < photos.size(); ++p) {
    if (!posed[p]) continue;
    for (const track::TagDetection& d : photos[p].detections) {
      const auto it = tag_index.find(d.id);
      if (it == tag_index.end()) continue;
      for (int k = 0; k < 4; ++k) {
        corners.push_back({camera_of_photo[p], it->second, track::tag_corner_in_tag(size_of(d.id), k),
                           d.corners[static_cast<std::size_t>(k)]});
      }
    }
  }
  const Refinement refinement = refine(lens, corners, tag_free, options, state);
  survey.iterations = refinement.iterations;

  // Residuals per tag and per photo.
  std::vector<double> tag_sum(tag_ids.size(), 0), photo_sum(photos.size(), 0);
  double total = 0;
  std::vector<int> tag_corners(tag_ids.size(), 0), photo_corners(photos.size(), 0);
  for (const Corner& c : corners) {
    const std::optional<Vec2> r = corner_residual(lens, state, c);
    const double e2 = r ? r->squaredNorm() : 1e8;
    const std::size_t p = photo_of_camera[c.camera];
    tag_sum[c.tag] += e2;
    ++tag_corners[c.tag];
    photo_sum[p] += e2;
    ++photo_corners[p];
    total += e2;
  }
  survey.corners = static_cast<int>(corners.size());
  survey.rms_px = std::sqrt(total / std::max(1, survey.corners));

  survey.map.family = options.family;
  for (std::size_t t = 0; t < tag_ids.size(); ++t) {
    const int id = tag_ids[t];
    survey.map.tags.push_back(to_tag(id, size_of(id), state.tags[t]));
    SurveyedTag s;
    s.id = id;
    s.origin = id == options.origin_id;
    s.photos = tag_corners[t] / 4;
    s.rms_px = std::sqrt(tag_sum[t] / std::max(1, tag_corners[t]));
    s.sigma_rotation_deg = refinement.sigma_rotation[t] / kDeg;
    s.sigma_position_m = refinement.sigma_position[t];
    std::set<std::size_t> cameras_seeing;
    for (const Corner& c : corners) {
      if (c.tag == t) cameras_seeing.insert(c.camera);
    }
    std::vector<Vec3> directions;
    for (std::size_t c : cameras_seeing) directions.push_back((state.cameras[c].inverse().t - state.tags[t].t).normalized());
    for (std::size_t a = 0; a < directions.size(); ++a) {
      for (std::size_t b = a + 1; b < directions.size(); ++b) {
        s.view_spread_deg = std::max(s.view_spread_deg, angle_between_deg(directions[a], directions[b]));
      }
    }
    survey.tags.push_back(s);
  }

  for (std::size_t p = 0; p < photos.size(); ++p) {
    SurveyedPhoto out;
    out.name = photos[p].name;
    out.posed = posed[p].has_value();
    if (out.posed) {
      const Rigid site_from_camera = state.cameras[camera_of_photo[p]].inverse();
      out.camera.R_site_from_camera = Eigen::Quaterniond(site_from_camera.R).normalized();
      out.camera.t_site_from_camera = site_from_camera.t;
      out.rms_px = std::sqrt(photo_sum[p] / std::max(1, photo_corners[p]));
      for (const track::TagDetection& d : photos[p].detections) {
        if (tag_index.contains(d.id)) out.tags.push_back(d.id);
      }
    } else if (photos[p].detections.empty()) {
      out.reason = "no " + options.family + " tags found";
    } else {
      std::vector<int> ids;
      for (const track::TagDetection& d : photos[p].detections) ids.push_back(d.id);
      out.reason = "tags " + join_ids(ids) + " only, none of them mapped";
    }
    survey.photos.push_back(out);
  }

  // Advice.
  char line[320];
  const std::size_t posed_count = photo_of_camera.size();
  if (posed_count < 6) {
    std::snprintf(line, sizeof line,
                  "only %zu photo(s) are posed: take 6 or more, from places around the site, each showing two or more tags",
                  posed_count);
    survey.advice.emplace_back(line);
  }
  if (survey.map.tags.size() < 2) {
    survey.advice.emplace_back("no tag besides the origin is mapped: take photos showing the origin tag together with the others");
  }
  for (const SurveyedTag& t : survey.tags) {
    if (t.rms_px > options.advise_rms_px) {
      std::snprintf(line, sizeof line,
                    "tag %d reprojects with %.2f px RMS: check that it did not move between the photos and that it is flat, "
                    "then retake the photos that show it",
                    t.id, t.rms_px);
      survey.advice.emplace_back(line);
    }
    if (t.photos >= 2 && t.view_spread_deg < options.advise_spread_deg) {
      std::snprintf(line, sizeof line,
                    "tag %d was photographed from directions only %.0f° apart (poor coverage: its distance is poorly fixed): "
                    "photograph it also from further left and right, 30° or more apart",
                    t.id, t.view_spread_deg);
      survey.advice.emplace_back(line);
    }
    if (t.sigma_position_m > options.advise_sigma_m) {
      std::snprintf(line, sizeof line,
                    "tag %d's position is uncertain by %.1f cm (1σ): take more photos of it, closer, with a mapped tag in "
                    "view",
                    t.id, 100 * t.sigma_position_m);
      survey.advice.emplace_back(line);
    }
  }
  survey.advice.insert(survey.advice.end(), duplicate_advice.begin(), duplicate_advice.end());
  for (const LeftOutTag& t : survey.left_out) survey.advice.push_back("tag " + std::to_string(t.id) + " is not mapped: " + t.reason);
  return survey;
}

cv::Mat draw_marker_survey(const MarkerSurvey& survey, const MarkerSurveyOptions& options, int size_px) {
  const int header = 40;
  cv::Mat image(size_px + header, size_px, CV_8UC3, cv::Scalar(255, 255, 255));
  // The plan's extent: tags and cameras, with a margin.
  Eigen::AlignedBox2d box;
  for (const track::MarkerTag& t : survey.map.tags) box.extend(t.t_site_from_tag.head<2>());
  for (const SurveyedPhoto& p : survey.photos) {
    if (p.posed) box.extend(p.camera.t_site_from_camera.head<2>());
  }
  if (box.isEmpty()) return image;
  const double span = std::max({box.sizes().x(), box.sizes().y(), 1.0});
  const double margin = 60;
  const double scale = (size_px - 2 * margin) / span;  // pixels per metre
  const Eigen::Vector2d centre = box.center();
  const auto to_px = [&](const Eigen::Vector2d& site) {
    return cv::Point2d(size_px / 2.0 + (site.x() - centre.x()) * scale, header + size_px / 2.0 - (site.y() - centre.y()) * scale);
  };
  const auto to_pt = [](const cv::Point2d& p) { return cv::Point(cvRound(p.x), cvRound(p.y)); };

  // A 1 m grid (10 m when the site is large).
  const double step = span > 40 ? 10.0 : 1.0;
  for (double x = std::floor((centre.x() - span) / step) * step; x <= centre.x() + span; x += step) {
    const cv::Point2d a = to_px({x, centre.y() - span}), b = to_px({x, centre.y() + span});
    cv::line(image, to_pt(a), to_pt(b), cv::Scalar(235, 235, 235), 1);
  }
  for (double y = std::floor((centre.y() - span) / step) * step; y <= centre.y() + span; y += step) {
    const cv::Point2d a = to_px({centre.x() - span, y}), b = to_px({centre.x() + span, y});
    cv::line(image, to_pt(a), to_pt(b), cv::Scalar(235, 235, 235), 1);
  }
  // Sight lines from each camera to the tags it saw.
  std::map<int, Vec3> tag_position;
  for (const track::MarkerTag& t : survey.map.tags) tag_position[t.id] = t.t_site_from_tag;
  for (const SurveyedPhoto& p : survey.photos) {
    if (!p.posed) continue;
    for (int id : p.tags) {
      cv::line(image, to_pt(to_px(p.camera.t_site_from_camera.head<2>())), to_pt(to_px(tag_position[id].head<2>())),
               cv::Scalar(215, 215, 215), 1, cv::LINE_AA);
    }
  }
  // Cameras: a blue dot and the view direction.
  for (const SurveyedPhoto& p : survey.photos) {
    if (!p.posed) continue;
    const cv::Point2d at = to_px(p.camera.t_site_from_camera.head<2>());
    const Vec3 view = p.camera.R_site_from_camera * Vec3::UnitZ();
    cv::circle(image, to_pt(at), 4, cv::Scalar(200, 90, 20), cv::FILLED, cv::LINE_AA);
    if (view.head<2>().norm() > 0.1) {
      const Eigen::Vector2d d = view.head<2>().normalized();
      cv::line(image, to_pt(at), to_pt(at + cv::Point2d(d.x() * 22, -d.y() * 22)), cv::Scalar(200, 90, 20), 2, cv::LINE_AA);
    }
  }
  // Tags: a bar along the printed x axis, the facing as an arrow, id and residual.
  for (std::size_t k = 0; k < survey.map.tags.size(); ++k) {
    const track::MarkerTag& t = survey.map.tags[k];
    const SurveyedTag& s = survey.tags[k];
    const cv::Scalar colour = s.rms_px > options.advise_rms_px ? cv::Scalar(30, 30, 220) : cv::Scalar(40, 150, 40);
    const Mat3 R = t.R_site_from_tag.toRotationMatrix();
    const double half = std::max(t.size / 2, 8 / scale);  // at least a few pixels long
    const cv::Point2d a = to_px((t.t_site_from_tag - R.col(0) * half).head<2>());
    const cv::Point2d b = to_px((t.t_site_from_tag + R.col(0) * half).head<2>());
    const cv::Point2d at = to_px(t.t_site_from_tag.head<2>());
    cv::line(image, to_pt(a), to_pt(b), colour, 4, cv::LINE_AA);
    const Vec3 facing = R.col(2);
    if (facing.head<2>().norm() > 0.3) {
      const Eigen::Vector2d d = facing.head<2>().normalized();
      cv::arrowedLine(image, to_pt(at), to_pt(at + cv::Point2d(d.x() * 18, -d.y() * 18)), colour, 1, cv::LINE_AA, 0, 0.35);
    } else {
      cv::circle(image, to_pt(at), 6, colour, 1, cv::LINE_AA);  // lying flat (or face down)
    }
    char label[64];
    std::snprintf(label, sizeof label, "%s%d  %.2f px", s.origin ? "origin " : "", t.id, s.rms_px);
    cv::putText(image, label, to_pt(at + cv::Point2d(8, -8)), cv::FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv::LINE_AA);
  }
  // Header and scale bar.
  char title[160];
  std::snprintf(title, sizeof title, "%zu tags, %zu photos posed, RMS %.2f px   (x east, y north)", survey.map.tags.size(),
                static_cast<std::size_t>(std::count_if(survey.photos.begin(), survey.photos.end(),
                                                       [](const SurveyedPhoto& p) { return p.posed; })),
                survey.rms_px);
  cv::putText(image, title, cv::Point(10, 26), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  const int bar = cvRound(step * scale);
  const cv::Point origin(20, image.rows - 20);
  cv::line(image, origin, origin + cv::Point(bar, 0), cv::Scalar(0, 0, 0), 2);
  cv::putText(image, step > 1 ? "10 m" : "1 m", origin + cv::Point(0, -8), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  return image;
}

}  // namespace skylit::calib
