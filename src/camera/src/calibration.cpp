#include "skylit/camera/lens.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <sstream>
#include <string_view>

#include <Eigen/LU>
#include <opencv2/core.hpp>
#include <yaml-cpp/yaml.h>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/yaml_reader.hpp"
#include "skylit/base/yaml_writer.hpp"
#include "calibration_yaml.hpp"

namespace skylit::camera {
namespace {

using detail::rotation_problem;

namespace fs = std::filesystem;

constexpr int kMaxImageSize = 1 << 15;       // pixels per side; keeps pixel indices in int32
constexpr double kRotationTolerance = 1e-6;  // |RᵀR − I| and |det R − 1|, per element

const std::array<std::string_view, 13> kKeys{"image_width",
                                             "image_height",
                                             "model",
                                             "fx",
                                             "fy",
                                             "cx",
                                             "cy",
                                             "D",
                                             "R_site_from_camera",
                                             "t_site_from_camera",
                                             "mask",
                                             "rms",
                                             "per_view_errors"};

const char* const kSchemaHint = "see docs/sky.md (Sky-camera calibration)";


std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

std::string model_name(LensModel model) {
  return model == LensModel::Fisheye ? "fisheye" : "pinhole";
}

bool valid_coefficient_count(LensModel model, std::size_t count) {
  return model == LensModel::Fisheye ? count == 4 : (count == 4 || count == 5 || count == 8);
}

std::string coefficient_fix(LensModel model) {
  return model == LensModel::Fisheye
             ? "write the 4 fisheye coefficients k1..k4, e.g. 'D: [0, 0, 0, 0]' (all 0: "
               "equidistant)"
             : "write 4, 5 or 8 coefficients in OpenCV's order k1, k2, p1, p2[, k3[, k4, k5, k6]], "
               "e.g. 'D: [0, 0, 0, 0, 0]'";
}

// Pinhole coefficients are kept as 5 (k1 k2 p1 p2 k3) or 8 (rational model): the missing k3 of a
// 4-coefficient calibration is 0.
std::vector<double> normalise_coefficients(LensModel model, const std::vector<double>& D) {
  if (model != LensModel::Pinhole || D.size() != 4) return D;
  return {D[0], D[1], D[2], D[3], 0.0};  // (push_back here trips GCC 12's -Warray-bounds)
}

const char* const kRotationFix =
    "write the camera's orientation as an orthonormal 3×3 matrix with determinant +1, row-major, "
    "9 numbers with at least 7 significant digits (columns: the camera's x right, y down and z "
    "forward axes in site coordinates, x east, y north, z up)";

// A path from a calibration file, relative to that file's directory (normalised, so that a
// mask written relative to another place reads back as the same path).
fs::path resolve(const fs::path& file, const std::string& text) {
  const fs::path path(text);
  return (path.is_absolute() ? path : file.parent_path() / path).lexically_normal();
}

// ---------------------------------------------------------------------------------------------
// The skylit YAML schema.

class CalibrationParser {
 public:
  // `prefix`: how errors name the map holding the fields ("left." in a stereo file; empty).
  CalibrationParser(const YamlReader& reader, std::string prefix) : r_(reader), prefix_(std::move(prefix)) {}

  // A whole single-camera file.
  CameraCalibration parse(const std::string& text) const {
    const YAML::Node root = r_.parse(
        text, std::string("correct the YAML syntax at that line (indentation, colons, brackets); ") + kSchemaHint);
    if (root.IsNull()) {
      fail(root, "", "the calibration file is empty",
           std::string("write image_width, image_height, model, fx, fy, cx, cy, D and "
                       "R_site_from_camera; ") +
               kSchemaHint);
    }
    if (!root.IsMap()) {
      fail(root, "", "the calibration file must be a map of fields",
           std::string("write image_width, image_height, model, fx, fy, cx, cy, D and "
                       "R_site_from_camera; ") +
               kSchemaHint);
    }
    return parse_map(root);
  }

  // The camera's fields in `root`, a map.
  CameraCalibration parse_map(const YAML::Node& root) const {
    check_keys(root);

    CameraCalibration c;
    c.file = r_.file();
    const std::string size_fix = "write the image size in pixels as an integer from 1 to " +
                                 std::to_string(kMaxImageSize) + ", e.g. 1024";
    c.image_width = image_size(root, "image_width", size_fix);
    c.image_height = image_size(root, "image_height", size_fix);

    const std::string model_fix =
        "write 'model: fisheye' (OpenCV's cv::fisheye model) or "
        "'model: pinhole' (OpenCV's radial-tangential model)";
    const YAML::Node model = require(root, "model", model_fix);
    const std::string model_text = model.IsScalar() ? lower(model.Scalar()) : std::string();
    if (model_text == "fisheye") {
      c.model = LensModel::Fisheye;
    } else if (model_text == "pinhole") {
      c.model = LensModel::Pinhole;
    } else {
      fail(model, "model",
           "unknown lens model" + (model.IsScalar() ? " '" + model.Scalar() + "'" : std::string()),
           model_fix);
    }

    const std::string focal_fix =
        "write the focal length in pixels, a positive number (for an "
        "equidistant fisheye: image-circle radius in pixels / (FOV/2 in "
        "radians))";
    c.fx = r_.positive(require(root, "fx", focal_fix), full_name("fx"), focal_fix);
    c.fy = r_.positive(require(root, "fy", focal_fix), full_name("fy"), focal_fix);
    const std::string centre_fix =
        "write the principal point in pixels (OpenCV: pixel centres at "
        "integers, so the image centre of a 1024-pixel side is 511.5)";
    c.cx = r_.number(require(root, "cx", centre_fix), full_name("cx"), centre_fix);
    c.cy = r_.number(require(root, "cy", centre_fix), full_name("cy"), centre_fix);

    const YAML::Node D = require(root, "D", coefficient_fix(c.model));
    std::vector<double> coefficients = r_.numbers(D, full_name("D"), coefficient_fix(c.model));
    if (!valid_coefficient_count(c.model, coefficients.size())) {
      fail(D, "D",
           std::to_string(coefficients.size()) + " coefficients do not fit the " +
               model_name(c.model) + " model",
           coefficient_fix(c.model));
    }
    c.D = normalise_coefficients(c.model, coefficients);

    const YAML::Node R = require(root, "R_site_from_camera", kRotationFix);
    c.R_site_from_camera = matrix3(R, "R_site_from_camera");
    if (const std::string problem = rotation_problem(c.R_site_from_camera); !problem.empty()) {
      fail(R, "R_site_from_camera", problem, kRotationFix);
    }

    if (const YAML::Node t = YamlReader::optional(root, "t_site_from_camera")) {
      const std::string fix =
          "write the camera's position in the site frame, 3 numbers in "
          "metres, e.g. [0, 0, 2.5]";
      const std::vector<double> values = r_.numbers(t, 3, full_name("t_site_from_camera"), fix);
      c.t_site_from_camera = Vec3(values[0], values[1], values[2]);
    }

    if (const YAML::Node mask = YamlReader::optional(root, "mask")) {
      const std::string fix =
          "write the mask image's path relative to this file, e.g. "
          "'mask: sky_mask.png' (8-bit, image size, 0 where the sky is hidden)";
      if (!mask.IsScalar() || mask.Scalar().empty())
        fail(mask, "mask", "expected a file name", fix);
      c.mask = resolve(r_.file(), mask.Scalar());
    }

    const std::string error_fix =
        "write the reprojection error in pixels, a number ≥ 0 (or "
        "remove the field)";
    if (const YAML::Node rms = YamlReader::optional(root, "rms")) {
      c.rms = r_.number(rms, full_name("rms"), error_fix);
      if (*c.rms < 0) fail(rms, "rms", "the error is negative", error_fix);
    }
    if (const YAML::Node errors = YamlReader::optional(root, "per_view_errors")) {
      c.per_view_errors = r_.numbers(errors, full_name("per_view_errors"), error_fix);
      for (std::size_t i = 0; i < c.per_view_errors.size(); ++i) {
        if (c.per_view_errors[i] < 0) {
          fail(errors[i], "per_view_errors", "element " + std::to_string(i) + " is negative",
               error_fix);
        }
      }
    }
    return c;
  }

 private:
  [[noreturn]] void fail(const YAML::Node& node, const std::string& field, const std::string& problem,
                         const std::string& fix) const {
    r_.fail(node, full_name(field), problem, fix);
  }

  // The field's name as errors give it ("left.fx" in a stereo file).
  std::string full_name(const std::string& name) const { return prefix_ + name; }

  void check_keys(const YAML::Node& map) const {
    // OpenCV's keys in a file without OpenCV's header: say so, rather than "unknown field".
    for (const auto& entry : map) {
      const std::string key = entry.first.IsScalar() ? entry.first.Scalar() : std::string();
      if (key == "camera_matrix" || key == "distortion_coefficients") {
        fail(entry.first, key, "this looks like an OpenCV FileStorage file without its header",
             "make '%YAML:1.0' the first line (OpenCV's YAML), or convert it to the skylit schema; " +
                 std::string(kSchemaHint));
      }
    }
    r_.check_keys(map, prefix_, kKeys);
  }

  YAML::Node require(const YAML::Node& map, const std::string& key, const std::string& fix) const {
    return r_.require(map, key, full_name(key), fix);
  }

  // From 1 to kMaxImageSize.
  int image_size(const YAML::Node& map, const std::string& key, const std::string& fix) const {
    return static_cast<int>(r_.integer(require(map, key, fix), full_name(key), 1, kMaxImageSize, fix));
  }

  // 9 numbers row-major, or 3 rows of 3.
  Eigen::Matrix3d matrix3(const YAML::Node& node, const std::string& field) const {
    std::vector<double> values;
    if (node.IsSequence() && node.size() == 3 && node[0].IsSequence()) {
      for (std::size_t r = 0; r < 3; ++r) {
        const std::vector<double> row = r_.numbers(node[r], full_name(field), kRotationFix);
        if (row.size() != 3) fail(node[r], field, "expected 3 rows of 3 numbers", kRotationFix);
        values.insert(values.end(), row.begin(), row.end());
      }
    } else {
      values = r_.numbers(node, full_name(field), kRotationFix);
      if (values.size() != 9) {
        fail(node, field, "expected 9 numbers (row-major), got " + std::to_string(values.size()),
             kRotationFix);
      }
    }
    Eigen::Matrix3d R;
    for (int r = 0; r < 3; ++r) {
      for (int col = 0; col < 3; ++col) R(r, col) = values[static_cast<std::size_t>(3 * r + col)];
    }
    return R;
  }

  const YamlReader& r_;
  std::string prefix_;
};

// ---------------------------------------------------------------------------------------------
// OpenCV FileStorage files (YAML with "%YAML:1.0", XML, JSON), as written by OpenCV's tools.

class OpenCVReader {
 public:
  OpenCVReader(fs::path file, const std::string& text) : file_(std::move(file)), text_(text) {}

  CameraCalibration parse() {
    cv::FileStorage storage;
    try {
      storage.open(text_, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    } catch (const cv::Exception& e) {
      fail("", "OpenCV cannot parse the file: " + e.msg,
           "repair the file (it is read as an OpenCV FileStorage file because of its first line)");
    }
    if (!storage.isOpened()) {
      fail("", "OpenCV cannot parse the file",
           "repair the file (it is read as an OpenCV FileStorage file because of its first line)");
    }
    try {
      return read(storage);
    } catch (const cv::Exception& e) {
      fail("", "OpenCV cannot read a field: " + e.msg,
           "write camera_matrix and distortion_coefficients as matrices and the sizes as integers");
    }
  }

 private:
  [[noreturn]] void fail(const std::string& field, const std::string& problem,
                         const std::string& fix) const {
    throw InputError(input_message(file_, -1, -1, field, problem, fix));
  }

  CameraCalibration read(const cv::FileStorage& storage) const {
    CameraCalibration c;
    c.file = file_;
    const std::string size_fix = "write '" + std::string("image_width") +
                                 "' and 'image_height' as integers from 1 to " +
                                 std::to_string(kMaxImageSize);
    c.image_width = integer(storage["image_width"], "image_width", size_fix);
    c.image_height = integer(storage["image_height"], "image_height", size_fix);

    const std::string camera_fix =
        "write the 3×3 camera matrix [fx 0 cx; 0 fy cy; 0 0 1] as an "
        "opencv-matrix (zero skew)";
    const cv::Mat K = matrix(storage["camera_matrix"], "camera_matrix", camera_fix);
    if (K.rows != 3 || K.cols != 3) {
      fail("camera_matrix",
           "expected a 3×3 matrix, got " + std::to_string(K.rows) + "×" + std::to_string(K.cols),
           camera_fix);
    }
    if (K.at<double>(0, 1) != 0.0 || K.at<double>(1, 0) != 0.0 || K.at<double>(2, 0) != 0.0 ||
        K.at<double>(2, 1) != 0.0 || K.at<double>(2, 2) != 1.0) {
      fail("camera_matrix", "the matrix is not [fx 0 cx; 0 fy cy; 0 0 1] (skew is not supported)",
           camera_fix);
    }
    c.fx = K.at<double>(0, 0);
    c.fy = K.at<double>(1, 1);
    c.cx = K.at<double>(0, 2);
    c.cy = K.at<double>(1, 2);

    const cv::Mat D = matrix(storage["distortion_coefficients"], "distortion_coefficients",
                             "write the distortion coefficients as a 1×N opencv-matrix");
    if (D.rows != 1 && D.cols != 1) {
      fail("distortion_coefficients", "expected a 1×N or N×1 matrix",
           "write the distortion coefficients as a 1×N opencv-matrix");
    }
    std::vector<double> coefficients(D.begin<double>(), D.end<double>());

    c.model = LensModel::Pinhole;
    const cv::FileNode model = storage["model"];
    const cv::FileNode fisheye = storage["fisheye"];
    const std::string model_fix = "write model: \"fisheye\" or model: \"pinhole\"";
    if (!model.empty() && !model.isNone()) {
      if (!model.isString()) fail("model", "expected a string", model_fix);
      const std::string text = lower(model.string());
      if (text == "fisheye") {
        c.model = LensModel::Fisheye;
      } else if (text != "pinhole") {
        fail("model", "unknown lens model '" + model.string() + "'", model_fix);
      }
    } else if (!fisheye.empty() && !fisheye.isNone()) {
      if (!fisheye.isInt() && !fisheye.isReal()) {
        fail("fisheye", "expected 0 or 1", "write 'fisheye: 1' for a cv::fisheye calibration");
      }
      if (static_cast<double>(fisheye) != 0.0) c.model = LensModel::Fisheye;
    }
    if (!valid_coefficient_count(c.model, coefficients.size())) {
      fail("distortion_coefficients",
           std::to_string(coefficients.size()) + " coefficients do not fit the " +
               model_name(c.model) + " model",
           coefficient_fix(c.model) + (c.model == LensModel::Pinhole
                                           ? " (for a cv::fisheye calibration add 'fisheye: 1')"
                                           : std::string()));
    }
    c.D = normalise_coefficients(c.model, coefficients);

    if (const cv::FileNode R = storage["R_site_from_camera"]; !R.empty() && !R.isNone()) {
      std::vector<double> values;
      if (R.isSeq()) {
        values = sequence(R, "R_site_from_camera", kRotationFix);
      } else {
        const cv::Mat m = matrix(R, "R_site_from_camera", kRotationFix);
        values.assign(m.begin<double>(), m.end<double>());
      }
      if (values.size() != 9) {
        fail("R_site_from_camera", "expected 9 numbers (a 3×3 matrix)", kRotationFix);
      }
      for (int r = 0; r < 3; ++r) {
        for (int col = 0; col < 3; ++col) {
          c.R_site_from_camera(r, col) = values[static_cast<std::size_t>(3 * r + col)];
        }
      }
    }
    if (const cv::FileNode t = storage["t_site_from_camera"]; !t.empty() && !t.isNone()) {
      std::vector<double> values;
      if (t.isSeq()) {
        values = sequence(t, "t_site_from_camera", "write 3 numbers in metres");
      } else {
        const cv::Mat m = matrix(t, "t_site_from_camera", "write 3 numbers in metres");
        values.assign(m.begin<double>(), m.end<double>());
      }
      if (values.size() != 3)
        fail("t_site_from_camera", "expected 3 numbers", "write 3 numbers in metres");
      c.t_site_from_camera = Vec3(values[0], values[1], values[2]);
    }
    if (const cv::FileNode mask = storage["mask"]; !mask.empty() && !mask.isNone()) {
      if (!mask.isString() || mask.string().empty()) {
        fail("mask", "expected a file name", "write the mask image's path relative to this file");
      }
      c.mask = resolve(file_, mask.string());
    }
    // OpenCV's calibration sample writes avg_reprojection_error and per_view_reprojection_errors.
    for (const char* key : {"rms", "avg_reprojection_error"}) {
      if (const cv::FileNode rms = storage[key]; !rms.empty() && rms.isReal()) {
        c.rms = static_cast<double>(rms);
        break;
      }
    }
    for (const char* key : {"per_view_errors", "per_view_reprojection_errors"}) {
      const cv::FileNode errors = storage[key];
      if (errors.empty() || errors.isNone()) continue;
      if (errors.isSeq()) {
        c.per_view_errors = sequence(errors, key, "write the per-view errors as a list of numbers");
      } else {
        const cv::Mat m = matrix(errors, key, "write the per-view errors as a list of numbers");
        c.per_view_errors.assign(m.begin<double>(), m.end<double>());
      }
      break;
    }
    return c;
  }

  int integer(const cv::FileNode& node, const std::string& field, const std::string& fix) const {
    if (node.empty() || node.isNone()) fail(field, "required field is missing", "add it: " + fix);
    if (!node.isInt()) fail(field, "expected an integer", fix);
    const int value = static_cast<int>(node);
    if (value < 1 || value > kMaxImageSize) {
      fail(field,
           "the size " + std::to_string(value) + " is outside 1.." + std::to_string(kMaxImageSize),
           fix);
    }
    return value;
  }

  // A list of numbers, element by element (OpenCV's vector reader trips GCC's null-dereference
  // analysis under -Werror).
  std::vector<double> sequence(const cv::FileNode& node, const std::string& field,
                               const std::string& fix) const {
    std::vector<double> values;
    for (cv::FileNodeIterator it = node.begin(); it != node.end(); ++it) {
      const cv::FileNode element = *it;
      if (!element.isInt() && !element.isReal()) fail(field, "expected a list of numbers", fix);
      values.push_back(static_cast<double>(element));
    }
    return values;
  }

  cv::Mat matrix(const cv::FileNode& node, const std::string& field, const std::string& fix) const {
    if (node.empty() || node.isNone()) fail(field, "required field is missing", "add it: " + fix);
    cv::Mat m;
    if (node.isSeq()) {
      m = cv::Mat(sequence(node, field, fix), true).reshape(1, 1);
    } else {
      node >> m;
    }
    if (m.empty()) fail(field, "expected a matrix", fix);
    if (m.channels() != 1) fail(field, "expected a one-channel matrix", fix);
    cv::Mat converted;
    m.convertTo(converted, CV_64F);
    return converted;
  }

  fs::path file_;
  const std::string& text_;
};

// OpenCV FileStorage files are recognised by their content, whatever their extension.
bool is_opencv_storage(const std::string& text) {
  const std::size_t first = text.find_first_not_of(" \t\r\n\xEF\xBB\xBF");
  if (first == std::string::npos) return false;
  const std::string_view start(text.data() + first, text.size() - first);
  if (start.starts_with("%YAML:")) return true;  // OpenCV's own header ("%YAML:1.0")
  if (start.starts_with("<?xml") || start.starts_with("<opencv_storage>")) return true;
  return start.starts_with("{") && text.find("\"camera_matrix\"") != std::string::npos;
}

[[noreturn]] void invalid(const CameraCalibration& c, const std::string& field,
                          const std::string& problem, const std::string& fix) {
  throw InputError(input_message(c.file, -1, -1, field, problem, fix));
}


}  // namespace

namespace detail {

// The first problem of R as a rotation, or empty.
std::string rotation_problem(const Eigen::Matrix3d& R) {
  if (!R.allFinite()) return "the matrix has a non-finite element";
  const double orthogonality =
      (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = R.determinant();
  if (orthogonality > kRotationTolerance) {
    std::ostringstream text;
    text << "the matrix is not a rotation: RᵀR differs from the identity by up to " << orthogonality
         << " (allowed " << kRotationTolerance << ")";
    return text.str();
  }
  if (std::abs(det - 1.0) > kRotationTolerance) {
    std::ostringstream text;
    text << "the matrix is not a rotation: its determinant is " << det
         << (det < 0 ? " (a reflection: one axis is flipped)" : "") << ", not +1";
    return text.str();
  }
  return {};
}

CameraCalibration parse_camera_map(const YamlReader& reader, const YAML::Node& map, const std::string& prefix) {
  return CalibrationParser(reader, prefix).parse_map(map);
}

}  // namespace detail

CameraCalibration load_calibration(const std::filesystem::path& file) {
  const std::string text = read_file(file);
  CameraCalibration calibration;
  if (is_opencv_storage(text)) {
    calibration = OpenCVReader(file, text).parse();
  } else {
    try {
      const YamlReader reader(file);
      calibration = CalibrationParser(reader, "").parse(text);
    } catch (const YAML::Exception& e) {  // a construct the checks above did not foresee
      const int line = e.mark.line >= 0 ? e.mark.line + 1 : -1;
      const int column = e.mark.column >= 0 ? e.mark.column + 1 : -1;
      throw InputError(input_message(file, line, column, "",
                                     "cannot read the calibration: " + e.msg,
                                     std::string("follow the schema in ") + kSchemaHint));
    }
  }
  validate(calibration);
  return calibration;
}

void validate(const CameraCalibration& c) {
  const std::string size_fix =
      "write the image size in pixels, an integer from 1 to " + std::to_string(kMaxImageSize);
  if (c.image_width < 1 || c.image_width > kMaxImageSize) {
    invalid(c, "image_width", "the width " + std::to_string(c.image_width) + " is out of range",
            size_fix);
  }
  if (c.image_height < 1 || c.image_height > kMaxImageSize) {
    invalid(c, "image_height", "the height " + std::to_string(c.image_height) + " is out of range",
            size_fix);
  }
  const std::string focal_fix = "write the focal length in pixels, a positive number";
  if (!(std::isfinite(c.fx) && c.fx > 0)) invalid(c, "fx", "must be a positive number", focal_fix);
  if (!(std::isfinite(c.fy) && c.fy > 0)) invalid(c, "fy", "must be a positive number", focal_fix);
  if (!std::isfinite(c.cx))
    invalid(c, "cx", "must be a finite number", "write the principal point in pixels");
  if (!std::isfinite(c.cy))
    invalid(c, "cy", "must be a finite number", "write the principal point in pixels");
  if (!valid_coefficient_count(c.model, c.D.size())) {
    invalid(c, "D",
            std::to_string(c.D.size()) + " coefficients do not fit the " + model_name(c.model) +
                " model",
            coefficient_fix(c.model));
  }
  for (std::size_t i = 0; i < c.D.size(); ++i) {
    if (!std::isfinite(c.D[i])) {
      invalid(c, "D", "coefficient " + std::to_string(i) + " is not finite",
              coefficient_fix(c.model));
    }
  }
  if (const std::string problem = rotation_problem(c.R_site_from_camera); !problem.empty()) {
    invalid(c, "R_site_from_camera", problem, kRotationFix);
  }
  if (!c.t_site_from_camera.allFinite()) {
    invalid(c, "t_site_from_camera", "an element is not finite", "write 3 numbers in metres");
  }
  const std::string error_fix = "write the reprojection error in pixels, a number ≥ 0";
  if (c.rms && !(std::isfinite(*c.rms) && *c.rms >= 0)) {
    invalid(c, "rms", "must be a finite number ≥ 0", error_fix);
  }
  for (std::size_t i = 0; i < c.per_view_errors.size(); ++i) {
    if (!(std::isfinite(c.per_view_errors[i]) && c.per_view_errors[i] >= 0)) {
      invalid(c, "per_view_errors", "element " + std::to_string(i) + " must be a finite number ≥ 0",
              error_fix);
    }
  }
}

void detail::emit_camera_map(YAML::Emitter& out, const CameraCalibration& c) {
  // The mask is written relative to the YAML's directory when the YAML's place is known, so
  // that load_calibration of the written file resolves it to the same path.
  fs::path mask = c.mask;
  if (!mask.empty() && !c.file.empty()) {
    const fs::path relative = mask.lexically_relative(c.file.parent_path());
    if (!relative.empty()) mask = relative;
  }
  std::vector<double> R(9);
  for (int r = 0; r < 3; ++r) {
    for (int col = 0; col < 3; ++col)
      R[static_cast<std::size_t>(3 * r + col)] = c.R_site_from_camera(r, col);
  }
  const bool fisheye = c.model == LensModel::Fisheye;
  using YAML::Key, YAML::Value, YAML::Comment;
  out << YAML::BeginMap
      << Key << "image_width" << Value << c.image_width
      << Key << "image_height" << Value << c.image_height
      << Key << "model" << Value << model_name(c.model)
      << Comment(fisheye ? "cv::fisheye: theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8)"
                         : "OpenCV radial-tangential (cv::projectPoints)")
      << Key << "fx" << Value << YamlNumber{c.fx} << Comment("pixels")
      << Key << "fy" << Value << YamlNumber{c.fy}
      << Key << "cx" << Value << YamlNumber{c.cx}
      << Key << "cy" << Value << YamlNumber{c.cy}
      << Key << "D" << Value << YamlNumbers{c.D}
      << Comment(fisheye ? "k1, k2, k3, k4 (all 0: equidistant)" : "k1, k2, p1, p2, k3[, k4, k5, k6]")
      << Key << "R_site_from_camera" << Value << YamlNumbers{R}
      << Comment("row-major; camera x right, y down, z forward -> site x east, y north, z up")
      << Key << "t_site_from_camera" << Value
      << YamlNumbers{std::span<const double>(c.t_site_from_camera.data(), 3)} << Comment("metres");
  if (!mask.empty()) {
    out << Key << "mask" << Value << YamlText{mask.generic_string()} << Comment("0 where the sky is hidden");
  }
  if (c.rms) out << Key << "rms" << Value << YamlNumber{*c.rms} << Comment("reprojection error, pixels");
  if (!c.per_view_errors.empty()) out << Key << "per_view_errors" << Value << YamlNumbers{c.per_view_errors};
  out << YAML::EndMap;
}

std::string calibration_to_yaml(const CameraCalibration& c) {
  YAML::Emitter out;
  out << YamlCommentLine{"skylit camera calibration (format: docs/sky.md). Pixel centres at integers (OpenCV)."};
  detail::emit_camera_map(out, c);
  return yaml_document(out);
}

void save_calibration(const CameraCalibration& calibration, const std::filesystem::path& file) {
  validate(calibration);
  CameraCalibration placed = calibration;
  placed.file = file;  // so that the mask is written relative to where the YAML goes
  write_file_atomic(file, calibration_to_yaml(placed));
}


}  // namespace skylit::camera
