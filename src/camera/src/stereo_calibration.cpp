// A stereo camera's calibration file: two cameras in the single-camera schema under left: and
// right:, the right camera's pose relative to the left, and the reprojection errors.
#include "skylit/camera/stereo_calibration.hpp"

#include <array>
#include <cmath>
#include <span>
#include <sstream>
#include <string_view>

#include <yaml-cpp/yaml.h>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/yaml_reader.hpp"
#include "skylit/base/yaml_writer.hpp"
#include "calibration_yaml.hpp"

namespace skylit::camera {
namespace {

namespace fs = std::filesystem;

const std::array<std::string_view, 6> kStereoKeys{"left",  "right", "R_right_from_left", "t_right_from_left",
                                                  "rms",   "per_pair_errors"};

const char* const kStereoHint = "see docs/calibration.md (Stereo cameras); skylit-calib stereo writes this file";
const char* const kStereoRotationFix =
    "write the right camera's orientation in the left camera's frame as an orthonormal 3×3 matrix with "
    "determinant +1, row-major, 9 numbers with at least 7 significant digits (x_right = R x_left + t); "
    "skylit-calib stereo writes it";
const char* const kBaselineFix =
    "write the right camera's position in the left camera's frame in metres, e.g. [-0.064, 0, 0] for cameras "
    "64 mm apart (its length is the baseline); skylit-calib stereo measures it";
const char* const kErrorFix = "write the reprojection error in pixels, a number ≥ 0 (or remove the field)";

std::string baseline_problem(const Vec3& t) {
  std::ostringstream text;
  text << "the baseline (the length of t_right_from_left) is " << t.norm() << " m, under " << kMinBaselineM
       << " m: the two cameras would be at one point";
  return text.str();
}

class StereoParser {
 public:
  explicit StereoParser(const fs::path& file) : r_(file) {}

  StereoCalibration parse(const std::string& text) const {
    const YAML::Node root =
        r_.parse(text, std::string("correct the YAML syntax at that line (indentation, colons, brackets); ") + kStereoHint);
    if (!root.IsMap()) {
      r_.fail(root, "", root.IsNull() ? "the stereo calibration file is empty" : "the file must be a map of fields",
              std::string("write left:, right:, R_right_from_left and t_right_from_left; ") + kStereoHint);
    }
    r_.check_keys(root, "", kStereoKeys);
    StereoCalibration s;
    s.file = r_.file();
    s.left = camera(root, "left");
    s.right = camera(root, "right");

    const YAML::Node R = r_.require(root, "R_right_from_left", "R_right_from_left", kStereoRotationFix);
    const std::vector<double> values = r_.numbers(R, 9, "R_right_from_left", kStereoRotationFix);
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) s.R_right_from_left(row, col) = values[static_cast<std::size_t>(3 * row + col)];
    }
    if (const std::string problem = detail::rotation_problem(s.R_right_from_left); !problem.empty()) {
      r_.fail(R, "R_right_from_left", problem, kStereoRotationFix);
    }
    const YAML::Node t = r_.require(root, "t_right_from_left", "t_right_from_left", kBaselineFix);
    const std::vector<double> position = r_.numbers(t, 3, "t_right_from_left", kBaselineFix);
    s.t_right_from_left = Vec3(position[0], position[1], position[2]);
    if (s.baseline_m() < kMinBaselineM) r_.fail(t, "t_right_from_left", baseline_problem(s.t_right_from_left), kBaselineFix);

    if (const YAML::Node rms = YamlReader::optional(root, "rms")) s.rms = r_.non_negative(rms, "rms", kErrorFix);
    if (const YAML::Node errors = YamlReader::optional(root, "per_pair_errors")) {
      s.per_pair_errors = r_.numbers(errors, "per_pair_errors", kErrorFix);
      for (std::size_t i = 0; i < s.per_pair_errors.size(); ++i) {
        if (s.per_pair_errors[i] < 0) {
          r_.fail(errors[i], "per_pair_errors", "element " + std::to_string(i) + " is negative", kErrorFix);
        }
      }
    }
    return s;
  }

 private:
  CameraCalibration camera(const YAML::Node& root, const std::string& side) const {
    const std::string fix = "write the " + side +
                            " camera's calibration under '" + side +
                            ":', indented, in the schema of docs/sky.md (image_width, image_height, model, fx, fy, "
                            "cx, cy, D, R_site_from_camera); " + kStereoHint;
    const YAML::Node map = r_.require(root, side, side, fix);
    r_.expect_map(map, side, fix);
    return detail::parse_camera_map(r_, map, side + ".");
  }

  YamlReader r_;
};

[[noreturn]] void invalid(const StereoCalibration& s, const std::string& field, const std::string& problem,
                          const std::string& fix) {
  throw InputError(input_message(s.file, -1, -1, field, problem, fix));
}

// validate() of one camera, its errors naming the camera ("left: ...").
void validate_camera(const StereoCalibration& s, const CameraCalibration& c, const std::string& side) {
  CameraCalibration placed = c;
  placed.file = s.file;
  try {
    validate(placed);
  } catch (const InputError& e) {
    throw InputError(std::string(e.what()) + " (in " + side + ":)");
  }
}

}  // namespace

StereoCalibration load_stereo_calibration(const fs::path& file) {
  const std::string text = read_file(file);
  StereoCalibration calibration;
  try {
    calibration = StereoParser(file).parse(text);
  } catch (const YAML::Exception& e) {  // a construct the checks above did not foresee
    const int line = e.mark.line >= 0 ? e.mark.line + 1 : -1;
    const int column = e.mark.column >= 0 ? e.mark.column + 1 : -1;
    throw InputError(input_message(file, line, column, "", "cannot read the stereo calibration: " + e.msg,
                                   std::string("follow the schema; ") + kStereoHint));
  }
  validate(calibration);
  return calibration;
}

void validate(const StereoCalibration& s) {
  validate_camera(s, s.left, "left");
  validate_camera(s, s.right, "right");
  if (const std::string problem = detail::rotation_problem(s.R_right_from_left); !problem.empty()) {
    invalid(s, "R_right_from_left", problem, kStereoRotationFix);
  }
  if (!s.t_right_from_left.allFinite()) invalid(s, "t_right_from_left", "an element is not finite", kBaselineFix);
  if (s.baseline_m() < kMinBaselineM) invalid(s, "t_right_from_left", baseline_problem(s.t_right_from_left), kBaselineFix);
  if (s.rms && !(std::isfinite(*s.rms) && *s.rms >= 0)) invalid(s, "rms", "must be a finite number ≥ 0", kErrorFix);
  for (std::size_t i = 0; i < s.per_pair_errors.size(); ++i) {
    if (!(std::isfinite(s.per_pair_errors[i]) && s.per_pair_errors[i] >= 0)) {
      invalid(s, "per_pair_errors", "element " + std::to_string(i) + " must be a finite number ≥ 0", kErrorFix);
    }
  }
}

std::string stereo_calibration_to_yaml(const StereoCalibration& s) {
  std::vector<double> R(9);
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) R[static_cast<std::size_t>(3 * row + col)] = s.R_right_from_left(row, col);
  }
  // Each camera's mask is written relative to the stereo file's folder, where the reader resolves it.
  CameraCalibration left = s.left, right = s.right;
  left.file = right.file = s.file;
  using YAML::Key, YAML::Value, YAML::Comment;
  YAML::Emitter out;
  out << YamlCommentLine{"skylit stereo camera calibration (format: docs/calibration.md, Stereo cameras)."}
      << YAML::BeginMap << Key << "left" << Value;
  detail::emit_camera_map(out, left);
  out << Key << "right" << Value;
  detail::emit_camera_map(out, right);
  out << Key << "R_right_from_left" << Value << YamlNumbers{R}
      << Comment("row-major: x_right = R x_left + t (OpenCV camera frames)") << Key << "t_right_from_left" << Value
      << YamlNumbers{std::span<const double>(s.t_right_from_left.data(), 3)}
      << Comment("metres; the baseline is its length");
  if (s.rms) out << Key << "rms" << Value << YamlNumber{*s.rms} << Comment("reprojection error over both cameras, pixels");
  if (!s.per_pair_errors.empty()) out << Key << "per_pair_errors" << Value << YamlNumbers{s.per_pair_errors};
  out << YAML::EndMap;
  return yaml_document(out);
}

void save_stereo_calibration(const StereoCalibration& calibration, const fs::path& file) {
  StereoCalibration placed = calibration;
  placed.file = file;
  validate(placed);
  write_file_atomic(file, stereo_calibration_to_yaml(placed));
}

}  // namespace skylit::camera
