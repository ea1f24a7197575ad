// IMU samples: the replay of a recording, its CSV, and the `imu:` config node.
#include "skylit/track/imu.hpp"

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string_view>

#include <yaml-cpp/yaml.h>

#include "skylit/base/csv.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/yaml_reader.hpp"
#include "skylit/track/hid_imu.hpp"

namespace skylit::track {
namespace {

namespace fs = std::filesystem;

const char* const kImuHeader = "timestamp,gx,gy,gz,ax,ay,az";
constexpr std::array<std::string_view, 7> kColumns{"timestamp", "gx", "gy", "gz", "ax", "ay", "az"};
constexpr std::array<std::string_view, 4> kHidKeys{"kind", "profile", "path", "R_camera_from_imu"};
constexpr std::array<std::string_view, 3> kReplayKeys{"kind", "csv", "R_camera_from_imu"};
constexpr std::array<std::string_view, 2> kImuKinds{"hid", "replay"};

}  // namespace

const char* to_string(ImuState state) {
  switch (state) {
    case ImuState::Waiting: return "waiting";
    case ImuState::Streaming: return "streaming";
    case ImuState::Gone: return "gone";
    case ImuState::Closed: return "closed";
  }
  return "?";
}

double steady_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

ReplayImu::ReplayImu(std::vector<ImuSample> samples, const Eigen::Quaterniond& R_camera_from_imu, std::string name)
    : samples_(std::move(samples)), R_camera_from_imu_(R_camera_from_imu.normalized()), name_(std::move(name)) {
  if (samples_.empty()) throw std::invalid_argument("ReplayImu: no samples");
  for (std::size_t i = 1; i < samples_.size(); ++i) {
    if (!(samples_[i].timestamp > samples_[i - 1].timestamp)) {
      throw std::invalid_argument("ReplayImu: timestamps do not increase at sample " + std::to_string(i));
    }
  }
}

ReplayImu ReplayImu::load(const fs::path& csv, const Eigen::Quaterniond& R_camera_from_imu) {
  return ReplayImu(load_imu_csv(csv), R_camera_from_imu, csv.filename().string());
}

std::size_t ReplayImu::read(std::vector<ImuSample>& out, double until) {
  if (state_ == ImuState::Closed) return 0;
  std::size_t count = 0;
  while (next_ < samples_.size() && samples_[next_].timestamp <= until) {
    out.push_back(samples_[next_++]);
    ++count;
  }
  if (next_ > 0) state_ = ImuState::Streaming;
  // The recording ends like an unplugged device: no more samples, ever.
  if (next_ == samples_.size() && until > samples_.back().timestamp) state_ = ImuState::Gone;
  return count;
}

std::string ReplayImu::describe() const {
  return "IMU replay " + name_ + " (" + std::to_string(samples_.size()) + " samples)";
}

std::vector<ImuSample> load_imu_csv(const fs::path& csv) {
  const std::string text = read_file(csv);
  CsvError csv_error;
  const std::vector<CsvRow> rows = parse_csv(text, &csv_error);
  if (csv_error.line > 0) {
    throw InputError(input_message(csv, csv_error.line, csv_error.column, "", csv_error.problem,
                                   "write numbers only, separated by commas"));
  }
  const std::string header_fix = std::string("make the first line '") + kImuHeader + "'";
  if (rows.empty()) throw InputError(input_message(csv, -1, -1, "", "the file has no lines", header_fix + " and add one line per sample"));
  const CsvRow& header = rows.front();
  for (std::size_t i = 0; i < kColumns.size(); ++i) {
    if (header.fields.size() != kColumns.size() || header.fields[i].text != kColumns[i]) {
      const int column = i < header.fields.size() ? header.fields[i].column : 1;
      throw InputError(input_message(csv, header.line, column, "", std::string("the header is not '") + kImuHeader + "'", header_fix));
    }
  }
  if (rows.size() < 2) throw InputError(input_message(csv, -1, -1, "", "no samples after the header", "add one line per sample"));

  std::vector<ImuSample> samples;
  samples.reserve(rows.size() - 1);
  const std::string fix = std::string("write 7 numbers: ") + kImuHeader + " (seconds, rad/s, m/s²)";
  for (std::size_t r = 1; r < rows.size(); ++r) {
    const CsvRow& row = rows[r];
    if (row.fields.size() != kColumns.size()) {
      const int column = row.fields.size() > kColumns.size() ? row.fields[kColumns.size()].column : row.fields.back().column;
      throw InputError(input_message(csv, row.line, column, "", std::to_string(row.fields.size()) + " fields, 7 expected", fix));
    }
    double v[7];
    for (std::size_t i = 0; i < kColumns.size(); ++i) {
      const auto number = parse_number(row.fields[i].text);
      if (!number) {
        throw InputError(input_message(csv, row.line, row.fields[i].column, std::string(kColumns[i]),
                                       "'" + row.fields[i].text + "' is not a number", fix));
      }
      v[i] = *number;
    }
    ImuSample sample;
    sample.timestamp = v[0];
    sample.gyro = Eigen::Vector3d(v[1], v[2], v[3]);
    sample.accel = Eigen::Vector3d(v[4], v[5], v[6]);
    if (!samples.empty() && !(sample.timestamp > samples.back().timestamp)) {
      throw InputError(input_message(csv, row.line, row.fields[0].column, "timestamp",
                                     "does not increase (" + row.fields[0].text + " after " + rows[r - 1].fields[0].text + ")",
                                     "sort the lines by time and remove repeated times"));
    }
    samples.push_back(sample);
  }
  return samples;
}

void save_imu_csv(const fs::path& csv, const std::vector<ImuSample>& samples) {
  std::string text = std::string(kImuHeader) + "\n";
  char line[256];
  for (const ImuSample& s : samples) {
    std::snprintf(line, sizeof line, "%.9f,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", s.timestamp, s.gyro.x(), s.gyro.y(), s.gyro.z(),
                  s.accel.x(), s.accel.y(), s.accel.z());
    text += line;
  }
  write_file_atomic(csv, text);
}

ImuConfig parse_imu_config(const YAML::Node& node, const fs::path& file, const fs::path& root) {
  const YamlReader r(file, root);
  const char* const docs = "see docs/imu.md";
  if (!node.IsDefined() || node.IsNull()) r.fail(node, "imu", "missing", std::string("add an 'imu:' map with a kind; ") + docs);
  r.expect_map(node, "imu", std::string("write 'kind: hid' (profile) or 'kind: replay' (csv); ") + docs);
  const YAML::Node kind_node = r.require(node, "kind", "imu.kind", "write 'kind: hid' (a HID device and its profile) or 'kind: replay' (a CSV recording)");
  const std::string kind = r.choice(kind_node, "imu.kind", kImuKinds);

  ImuConfig config;
  if (kind == "hid") {
    r.check_keys(node, "imu.", kHidKeys);
    config.kind = ImuConfig::Kind::Hid;
    const std::string fix = "write the profile's path, e.g. 'profile: imu/dualshock4_usb.yaml' (the profiles are in config/imu)";
    config.profile = r.path(r.require(node, "profile", "imu.profile", fix), "imu.profile", fix);
    if (const YAML::Node path = YamlReader::optional(node, "path")) {
      config.path = r.text(path, "imu.path", "write the device path that 'skylit-calib hid list' shows, e.g. /dev/hidraw3");
    }
  } else {
    r.check_keys(node, "imu.", kReplayKeys);
    config.kind = ImuConfig::Kind::Replay;
    const std::string fix = std::string("write the recording's path, e.g. 'csv: head_imu.csv' (") + kImuHeader + ")";
    config.csv = r.path(r.require(node, "csv", "imu.csv", fix), "imu.csv", fix);
  }
  if (const YAML::Node rotation = YamlReader::optional(node, "R_camera_from_imu")) {
    const std::string fix = "write a unit quaternion qw, qx, qy, qz, e.g. [1, 0, 0, 0] (IMU axes along the camera's)";
    const auto q = r.numbers(rotation, 4, "imu.R_camera_from_imu", fix);
    const Eigen::Quaterniond quaternion(q[0], q[1], q[2], q[3]);
    if (std::abs(quaternion.norm() - 1.0) > 1e-3) {
      r.fail(rotation, "imu.R_camera_from_imu", "the quaternion's length is " + std::to_string(quaternion.norm()) + ", not 1", fix);
    }
    config.R_camera_from_imu = quaternion.normalized();
  }
  return config;
}

std::unique_ptr<ImuSource> open_imu(const ImuConfig& config) {
  if (config.kind == ImuConfig::Kind::Replay) {
    return std::make_unique<ReplayImu>(ReplayImu::load(config.csv, config.R_camera_from_imu.value_or(Eigen::Quaterniond::Identity())));
  }
  HidImuProfile profile = load_hid_imu_profile(config.profile);
  if (config.R_camera_from_imu) profile.R_camera_from_imu = *config.R_camera_from_imu;
  HidImuOptions options;
  options.path = config.path;
  return open_hid_imu(profile, options);
}

}  // namespace skylit::track
