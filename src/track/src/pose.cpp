#include "skylit/track/pose.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "skylit/base/csv.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit::track {
namespace {

constexpr double kQuaternionTolerance = 1e-3;  // |‖q‖ − 1| accepted (and normalised away)
const char* const kPoseHeader = "timestamp,x,y,z,qw,qx,qy,qz";

std::string format_position(const Vec3& p) {
  char text[96];
  std::snprintf(text, sizeof text, "(%.3f, %.3f, %.3f)", p.x(), p.y(), p.z());
  return text;
}

}  // namespace

Eigen::Quaterniond look_at(const Vec3& position, const Vec3& target, const Vec3& up) {
  const Vec3 view = target - position;
  if (!(view.norm() > 1e-12)) throw std::invalid_argument("look_at: the target is the camera's position");
  const Vec3 z = view.normalized();
  const Vec3 right = z.cross(up);  // OpenCV's x: right of the view with `up` above
  if (!(right.norm() > 1e-9 * std::max(1.0, up.norm()))) {
    throw std::invalid_argument("look_at: the view is parallel to 'up'");
  }
  const Vec3 x = right.normalized();
  const Vec3 y = z.cross(x);  // down
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return Eigen::Quaterniond(R).normalized();
}

FixedPose::FixedPose(const Pose& pose) : pose_(pose) { pose_.R_site_from_camera.normalize(); }

std::optional<Pose> FixedPose::pose_at(double timestamp) {
  Pose pose = pose_;
  pose.timestamp = timestamp;
  return pose;
}

std::string FixedPose::describe() const { return "fixed pose at " + format_position(pose_.t_site_from_camera); }

PoseTrack::PoseTrack(std::vector<Pose> samples, std::string name) : samples_(std::move(samples)), name_(std::move(name)) {
  if (samples_.empty()) throw std::invalid_argument("PoseTrack: no poses");
  for (std::size_t i = 0; i < samples_.size(); ++i) {
    if (std::abs(samples_[i].R_site_from_camera.norm() - 1.0) > kQuaternionTolerance) {
      throw std::invalid_argument("PoseTrack: pose " + std::to_string(i) + " has no unit quaternion");
    }
    samples_[i].R_site_from_camera.normalize();
    if (i > 0 && !(samples_[i].timestamp > samples_[i - 1].timestamp)) {
      throw std::invalid_argument("PoseTrack: timestamps do not increase at pose " + std::to_string(i));
    }
  }
}

std::optional<Pose> PoseTrack::pose_at(double timestamp) {
  const auto after = std::upper_bound(samples_.begin(), samples_.end(), timestamp,
                                      [](double t, const Pose& pose) { return t < pose.timestamp; });
  Pose pose;
  if (after == samples_.begin()) {
    pose = samples_.front();
  } else if (after == samples_.end()) {
    pose = samples_.back();
  } else {
    const Pose& a = *(after - 1);
    const Pose& b = *after;
    const double s = (timestamp - a.timestamp) / (b.timestamp - a.timestamp);
    pose.t_site_from_camera = (1.0 - s) * a.t_site_from_camera + s * b.t_site_from_camera;
    pose.R_site_from_camera = a.R_site_from_camera.slerp(s, b.R_site_from_camera).normalized();
  }
  pose.timestamp = timestamp;
  return pose;
}

std::string PoseTrack::describe() const {
  return "pose track " + name_ + " (" + std::to_string(samples_.size()) + " poses)";
}

PoseTrack PoseTrack::load(const std::filesystem::path& csv) {
  const std::string text = read_file(csv);
  CsvError csv_error;
  const std::vector<CsvRow> rows = parse_csv(text, &csv_error);
  if (csv_error.line > 0) {
    throw InputError(input_message(csv, csv_error.line, csv_error.column, "", csv_error.problem,
                                   "write numbers only, separated by commas"));
  }
  const std::string header_fix = std::string("make the first line '") + kPoseHeader + "'";
  if (rows.empty()) throw InputError(input_message(csv, -1, -1, "", "the file has no lines", header_fix + " and add one line per pose"));
  static const char* const kColumns[] = {"timestamp", "x", "y", "z", "qw", "qx", "qy", "qz"};
  const CsvRow& header = rows.front();
  for (std::size_t i = 0; i < 8; ++i) {
    if (header.fields.size() != 8 || header.fields[i].text != kColumns[i]) {
      const int column = i < header.fields.size() ? header.fields[i].column : 1;
      throw InputError(input_message(csv, header.line, column, "", "the header is not '" + std::string(kPoseHeader) + "'", header_fix));
    }
  }
  if (rows.size() < 2) throw InputError(input_message(csv, -1, -1, "", "no poses after the header", "add one line per pose"));

  std::vector<Pose> poses;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    const CsvRow& row = rows[r];
    const std::string fix = std::string("write 8 numbers: ") + kPoseHeader;
    if (row.fields.size() != 8) {
      const int column = row.fields.size() > 8 ? row.fields[8].column : row.fields.back().column;
      throw InputError(input_message(csv, row.line, column, "", std::to_string(row.fields.size()) + " fields, 8 expected", fix));
    }
    double v[8];
    for (std::size_t i = 0; i < 8; ++i) {
      const auto number = parse_number(row.fields[i].text);
      if (!number) {
        throw InputError(input_message(csv, row.line, row.fields[i].column, kColumns[i],
                                       "'" + row.fields[i].text + "' is not a number", fix));
      }
      v[i] = *number;
    }
    Pose pose;
    pose.timestamp = v[0];
    pose.t_site_from_camera = Vec3(v[1], v[2], v[3]);
    pose.R_site_from_camera = Eigen::Quaterniond(v[4], v[5], v[6], v[7]);
    const double norm = pose.R_site_from_camera.norm();
    if (std::abs(norm - 1.0) > kQuaternionTolerance) {
      char problem[96];
      std::snprintf(problem, sizeof problem, "the quaternion's length is %.6g, not 1", norm);
      throw InputError(input_message(csv, row.line, row.fields[4].column, "qw", problem,
                                     "write a unit quaternion qw, qx, qy, qz (1, 0, 0, 0: camera axes along the site's)"));
    }
    if (!poses.empty() && !(pose.timestamp > poses.back().timestamp)) {
      throw InputError(input_message(csv, row.line, row.fields[0].column, "timestamp",
                                     "does not increase (" + row.fields[0].text + " after " +
                                         rows[r - 1].fields[0].text + ")",
                                     "sort the lines by time and remove repeated times"));
    }
    poses.push_back(pose);
  }
  return PoseTrack(std::move(poses), csv.filename().string());
}

}  // namespace skylit::track
