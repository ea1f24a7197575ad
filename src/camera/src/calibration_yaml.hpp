#pragma once
// The camera schema's fields as one YAML map, read and written: a camera's calibration file is
// one such map, a stereo calibration holds two (left:, right:).
#include <string>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include "skylit/base/yaml_reader.hpp"
#include "skylit/camera/calibration.hpp"

namespace skylit::camera::detail {

// The camera in `map`: InputError through `reader` naming the field with `prefix` ("left.fx").
CameraCalibration parse_camera_map(const YamlReader& reader, const YAML::Node& map, const std::string& prefix);
// The camera's fields as a block map (the mask relative to calibration.file's folder).
void emit_camera_map(YAML::Emitter& out, const CameraCalibration& calibration);
// The first problem of R as a rotation (not orthonormal, a reflection), or empty.
std::string rotation_problem(const Eigen::Matrix3d& R);

}  // namespace skylit::camera::detail
