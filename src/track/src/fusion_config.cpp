// The `fusion:` node of a config file.
#include <array>
#include <string_view>

#include <yaml-cpp/yaml.h>

#include "skylit/base/yaml_reader.hpp"
#include "skylit/track/fusion.hpp"

namespace skylit::track {
namespace {

constexpr std::array<std::string_view, 16> kFusionKeys{
    "gyro_noise",       "gyro_bias_walk", "initial_bias_sigma", "camera_rotation_sigma", "camera_position_sigma",
    "head_acceleration", "history",       "max_prediction",     "camera_timeout",        "lost_after",
    "hold_without_imu", "imu_timeout",    "reacquire_fade",     "position_filter",       "rotation_filter",
    "filter_rotation_with_gyro"};
constexpr std::array<std::string_view, 4> kFilterKeys{"enabled", "min_cutoff", "beta", "d_cutoff"};

OneEuroSettings parse_filter(const YamlReader& r, const YAML::Node& node, const std::string& field, OneEuroSettings s) {
  r.expect_map(node, field, "write a map: enabled, min_cutoff (Hz), beta (Hz per unit/s), d_cutoff (Hz); see docs/imu.md");
  r.check_keys(node, field + ".", kFilterKeys);
  if (const auto n = YamlReader::optional(node, "enabled")) s.enabled = r.boolean(n, field + ".enabled", "write true or false");
  if (const auto n = YamlReader::optional(node, "min_cutoff")) {
    s.min_cutoff = r.positive(n, field + ".min_cutoff", "write a cutoff in Hz, e.g. 1.0 (lower: steadier at rest, more lag)");
  }
  if (const auto n = YamlReader::optional(node, "beta")) {
    s.beta = r.non_negative(n, field + ".beta", "write a number ≥ 0, e.g. 0.5 (higher: less lag when moving)");
  }
  if (const auto n = YamlReader::optional(node, "d_cutoff")) {
    s.d_cutoff = r.positive(n, field + ".d_cutoff", "write a cutoff in Hz, e.g. 1.0");
  }
  return s;
}

}  // namespace

FusionSettings parse_fusion_settings(const YAML::Node& node, const std::filesystem::path& file) {
  const YamlReader r(file);
  FusionSettings s;
  if (!node.IsDefined() || node.IsNull()) return s;
  r.expect_map(node, "fusion", "write a map of fusion settings (every one optional); see docs/imu.md");
  r.check_keys(node, "fusion.", kFusionKeys);
  const auto positive = [&](const char* key, double& value, const char* fix) {
    if (const auto n = YamlReader::optional(node, key)) value = r.positive(n, std::string("fusion.") + key, fix);
  };
  const auto non_negative = [&](const char* key, double& value, const char* fix) {
    if (const auto n = YamlReader::optional(node, key)) value = r.non_negative(n, std::string("fusion.") + key, fix);
  };
  positive("gyro_noise", s.gyro_noise, "write the gyro's noise density in rad/s/√Hz (its datasheet), e.g. 0.003");
  positive("gyro_bias_walk", s.gyro_bias_walk, "write how fast the gyro bias wanders, rad/s/√s, e.g. 0.0002");
  positive("initial_bias_sigma", s.initial_bias_sigma, "write the gyro bias expected at start, rad/s, e.g. 0.05");
  positive("camera_rotation_sigma", s.camera_rotation_sigma, "write the marker tracker's rotation noise, radians, e.g. 0.01");
  positive("camera_position_sigma", s.camera_position_sigma, "write the marker tracker's position noise, metres, e.g. 0.01");
  positive("head_acceleration", s.head_acceleration, "write a typical head acceleration, m/s², e.g. 3");
  positive("history", s.history, "write how late a camera pose may come, seconds, e.g. 0.5");
  non_negative("max_prediction", s.max_prediction, "write the furthest prediction, seconds, e.g. 0.1 (0: none)");
  positive("camera_timeout", s.camera_timeout, "write seconds without camera poses before coasting, e.g. 0.2");
  positive("lost_after", s.lost_after, "write seconds without camera poses before lost (gyro live), e.g. 1.5");
  positive("hold_without_imu", s.hold_without_imu, "write seconds without camera poses before lost (no gyro), e.g. 0.5");
  positive("imu_timeout", s.imu_timeout, "write seconds without IMU samples before the IMU counts as gone, e.g. 0.1");
  non_negative("reacquire_fade", s.reacquire_fade, "write the fade-in time after a loss, seconds, e.g. 0.3");
  if (const auto n = YamlReader::optional(node, "position_filter")) {
    s.position_filter = parse_filter(r, n, "fusion.position_filter", s.position_filter);
  }
  if (const auto n = YamlReader::optional(node, "rotation_filter")) {
    s.rotation_filter = parse_filter(r, n, "fusion.rotation_filter", s.rotation_filter);
  }
  if (const auto n = YamlReader::optional(node, "filter_rotation_with_gyro")) {
    s.filter_rotation_with_gyro = r.boolean(n, "fusion.filter_rotation_with_gyro", "write true or false");
  }
  if (s.lost_after <= s.camera_timeout) {
    r.fail(node["lost_after"].IsDefined() ? node["lost_after"] : node, "fusion.lost_after",
           "must be longer than camera_timeout (" + std::to_string(s.camera_timeout) + " s)", "raise lost_after or lower camera_timeout");
  }
  if (s.hold_without_imu <= s.camera_timeout) {
    r.fail(node["hold_without_imu"].IsDefined() ? node["hold_without_imu"] : node, "fusion.hold_without_imu",
           "must be longer than camera_timeout (" + std::to_string(s.camera_timeout) + " s)",
           "raise hold_without_imu or lower camera_timeout");
  }
  return s;
}

}  // namespace skylit::track
