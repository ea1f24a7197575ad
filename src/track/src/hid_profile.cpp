// HID IMU profiles (config/imu/*.yaml) and the report decoder they configure.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <string_view>

#include <yaml-cpp/yaml.h>

#include "skylit/base/error.hpp"
#include "skylit/base/yaml_reader.hpp"
#include "skylit/track/hid_imu.hpp"

namespace skylit::track {
namespace {

namespace fs = std::filesystem;

constexpr std::array<std::string_view, 10> kHidProfileKeys{"name",      "vendor_id", "product_id", "report_id", "report_size",
                                                 "timestamp", "gyro",      "accel",      "axes",      "R_camera_from_imu"};
constexpr std::array<std::string_view, 4> kTimestampKeys{"offset", "type", "endian", "scale"};
constexpr std::array<std::string_view, 4> kVectorKeys{"offsets", "type", "endian", "scale"};
constexpr std::array<std::string_view, 7> kTypes{"int8", "uint8", "int16", "uint16", "int32", "uint32", "float32"};
constexpr std::array<std::string_view, 2> kEndians{"little", "big"};
const char* const kHidProfileDocs = "see docs/imu.md (HID profiles)";

HidFieldType type_from(std::string_view name) {
  if (name == "int8") return HidFieldType::Int8;
  if (name == "uint8") return HidFieldType::UInt8;
  if (name == "int16") return HidFieldType::Int16;
  if (name == "uint16") return HidFieldType::UInt16;
  if (name == "int32") return HidFieldType::Int32;
  if (name == "uint32") return HidFieldType::UInt32;
  return HidFieldType::Float32;
}

struct FieldFormat {
  HidFieldType type = HidFieldType::Int16;
  Endian endian = Endian::Little;
};

FieldFormat parse_format(const YamlReader& r, const YAML::Node& node, const std::string& field) {
  FieldFormat format;
  format.type = type_from(r.choice(r.require(node, "type", field + ".type", "one of int8, uint8, int16, uint16, int32, uint32, float32"),
                                   field + ".type", kTypes));
  if (const YAML::Node endian = YamlReader::optional(node, "endian")) {
    format.endian = r.choice(endian, field + ".endian", kEndians) == "big" ? Endian::Big : Endian::Little;
  }
  return format;
}

std::size_t parse_offset(const YamlReader& r, const YAML::Node& node, const std::string& field, std::size_t report_size,
                         HidFieldType type) {
  const std::size_t size = field_size(type);
  const std::string fix = "write the byte offset from the report's first byte (the report id, when the device numbers its reports), 0 to " +
                          std::to_string(report_size - size);
  const auto offset = static_cast<std::size_t>(r.integer(node, field, 0, 65535, fix));
  if (offset + size > report_size) {
    r.fail(node, field,
           "the field's bytes " + std::to_string(offset) + ".." + std::to_string(offset + size - 1) + " end past report_size " +
               std::to_string(report_size),
           fix + ", or raise report_size");
  }
  return offset;
}

double parse_scale(const YamlReader& r, const YAML::Node& node, const std::string& field, const std::string& fix) {
  const double value = r.number(node, field, fix);
  if (value == 0) r.fail(node, field, "the scale is 0", fix);
  return value;
}

std::array<HidField, 3> parse_vector(const YamlReader& r, const YAML::Node& root, const char* key, std::size_t report_size,
                                     const std::string& unit) {
  const std::string field = key;
  const std::string example = "e.g. '" + field + ": {offsets: [13, 15, 17], type: int16, endian: little, scale: 0.001}'";
  const YAML::Node node = r.require(root, key, field, example + "; " + kHidProfileDocs);
  r.expect_map(node, field, example);
  r.check_keys(node, field + ".", kVectorKeys);
  const FieldFormat format = parse_format(r, node, field);
  const YAML::Node offsets = r.require(node, "offsets", field + ".offsets", "write the byte offsets of x, y and z, " + example);
  if (!offsets.IsSequence() || offsets.size() != 3) r.fail(offsets, field + ".offsets", "expected 3 byte offsets (x, y, z)", example);
  const std::string scale_fix = "write " + unit + " per count: one number, or three (x, y, z); a negative scale flips an axis";
  const YAML::Node scale = r.require(node, "scale", field + ".scale", scale_fix);
  std::array<double, 3> scales{};
  if (scale.IsSequence()) {
    const auto values = r.numbers(scale, 3, field + ".scale", scale_fix);
    for (std::size_t i = 0; i < 3; ++i) {
      if (values[i] == 0) r.fail(scale[i], field + ".scale", "a scale is 0", scale_fix);
      scales[i] = values[i];
    }
  } else {
    scales.fill(parse_scale(r, scale, field + ".scale", scale_fix));
  }
  std::array<HidField, 3> fields{};
  for (std::size_t i = 0; i < 3; ++i) {
    fields[i].type = format.type;
    fields[i].endian = format.endian;
    fields[i].offset = parse_offset(r, offsets[i], field + ".offsets", report_size, format.type);
    fields[i].scale = scales[i];
  }
  return fields;
}

// `axes: [x, -z, y]`: IMU axis i is the named device axis (with its sign).
Eigen::Matrix3d parse_axes(const YamlReader& r, const YAML::Node& node) {
  const std::string fix = "write which device axis each IMU axis is, with its sign, e.g. [x, -z, y]; every axis once";
  if (!node.IsSequence() || node.size() != 3) r.fail(node, "axes", "expected 3 axis names", fix);
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  std::array<bool, 3> used{};
  for (std::size_t i = 0; i < 3; ++i) {
    const std::string name = r.text(node[i], "axes", fix);
    const bool negative = name.size() == 2 && name[0] == '-';
    const std::string axis = negative ? name.substr(1) : (name.size() == 2 && name[0] == '+' ? name.substr(1) : name);
    if (axis != "x" && axis != "y" && axis != "z") r.fail(node[i], "axes", "'" + name + "' is not an axis", fix);
    const auto column = static_cast<std::size_t>(axis[0] - 'x');
    if (used[column]) r.fail(node[i], "axes", "device axis " + axis + " appears twice", fix);
    used[column] = true;
    m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(column)) = negative ? -1.0 : 1.0;
  }
  if (m.determinant() < 0) {
    r.fail(node, "axes", "the mapping mirrors the axes (a left-handed frame)",
           "flip the sign of one axis; if the device's own axes are left-handed, flip one axis by a negative scale");
  }
  return m;
}

std::uint16_t parse_id(const YamlReader& r, const YAML::Node& node, const std::string& field) {
  return static_cast<std::uint16_t>(
      r.integer(node, field, 0, 0xFFFF, "write the USB id in hex, e.g. 0x054c ('skylit-calib hid list' shows them)"));
}

}  // namespace

std::size_t field_size(HidFieldType type) {
  switch (type) {
    case HidFieldType::Int8:
    case HidFieldType::UInt8: return 1;
    case HidFieldType::Int16:
    case HidFieldType::UInt16: return 2;
    case HidFieldType::Int32:
    case HidFieldType::UInt32:
    case HidFieldType::Float32: return 4;
  }
  return 0;
}

double read_raw(std::span<const std::uint8_t> report, const HidField& field) {
  const std::size_t size = field_size(field.type);
  std::uint32_t bits = 0;
  for (std::size_t i = 0; i < size; ++i) {
    const std::size_t byte = field.endian == Endian::Little ? field.offset + i : field.offset + size - 1 - i;
    bits |= static_cast<std::uint32_t>(report[byte]) << (8 * i);
  }
  switch (field.type) {
    case HidFieldType::Int8: return static_cast<std::int8_t>(bits);
    case HidFieldType::UInt8: return static_cast<std::uint8_t>(bits);
    case HidFieldType::Int16: return static_cast<std::int16_t>(bits);
    case HidFieldType::UInt16: return static_cast<std::uint16_t>(bits);
    case HidFieldType::Int32: return static_cast<std::int32_t>(bits);
    case HidFieldType::UInt32: return bits;
    case HidFieldType::Float32: return std::bit_cast<float>(bits);
  }
  return 0;
}

bool HidImuProfile::matches(std::uint16_t vendor, std::uint16_t product) const {
  return vendor == vendor_id && std::find(product_ids.begin(), product_ids.end(), product) != product_ids.end();
}

HidImuProfile parse_hid_imu_profile(const YAML::Node& root, const fs::path& file) {
  const YamlReader r(file);
  r.expect_map(root, "", std::string("write a HID IMU profile: name, vendor_id, product_id, report_id, report_size, timestamp, gyro, accel, axes; ") + kHidProfileDocs);
  r.check_keys(root, "", kHidProfileKeys);
  HidImuProfile p;
  p.file = file;
  p.name = r.text(r.require(root, "name", "name", "write the device's name, e.g. 'Sony DualShock 4 (USB)'"), "name", "write the device's name");
  p.vendor_id = parse_id(r, r.require(root, "vendor_id", "vendor_id", "write the USB vendor id, e.g. 0x054c"), "vendor_id");
  const YAML::Node products = r.require(root, "product_id", "product_id", "write the USB product id, or a list of them, e.g. [0x05c4, 0x09cc]");
  if (products.IsSequence()) {
    if (products.size() == 0) r.fail(products, "product_id", "the list is empty", "write at least one product id");
    for (const auto& id : products) p.product_ids.push_back(parse_id(r, id, "product_id"));
  } else {
    p.product_ids.push_back(parse_id(r, products, "product_id"));
  }
  if (const YAML::Node id = YamlReader::optional(root, "report_id")) {
    p.report_id = static_cast<std::uint8_t>(r.integer(id, "report_id", 0, 255, "write the input report's id (its first byte), e.g. 0x01; leave it out when the device does not number its reports"));
  }
  p.report_size = static_cast<std::size_t>(r.integer(r.require(root, "report_size", "report_size", "write the input report's length in bytes, report id included, e.g. 64"),
                                                     "report_size", 1, 4096, "write the input report's length in bytes, report id included, e.g. 64"));
  if (const YAML::Node ts = YamlReader::optional(root, "timestamp")) {
    const std::string example = "e.g. 'timestamp: {offset: 10, type: uint16, endian: little, scale: 5.333e-6}'";
    r.expect_map(ts, "timestamp", example);
    r.check_keys(ts, "timestamp.", kTimestampKeys);
    HidField field;
    const FieldFormat format = parse_format(r, ts, "timestamp");
    field.type = format.type;
    field.endian = format.endian;
    field.offset = parse_offset(r, r.require(ts, "offset", "timestamp.offset", example), "timestamp.offset", p.report_size, field.type);
    field.scale = r.positive(r.require(ts, "scale", "timestamp.scale", "write seconds per count, " + example), "timestamp.scale",
                             "write seconds per count (a positive number)");
    p.timestamp = field;
  }
  p.gyro = parse_vector(r, root, "gyro", p.report_size, "rad/s");
  p.accel = parse_vector(r, root, "accel", p.report_size, "m/s²");
  if (const YAML::Node axes = YamlReader::optional(root, "axes")) p.imu_from_device = parse_axes(r, axes);
  if (const YAML::Node rotation = YamlReader::optional(root, "R_camera_from_imu")) {
    const std::string fix = "write a unit quaternion qw, qx, qy, qz, e.g. [1, 0, 0, 0] (IMU axes along the camera's)";
    const auto q = r.numbers(rotation, 4, "R_camera_from_imu", fix);
    const Eigen::Quaterniond quaternion(q[0], q[1], q[2], q[3]);
    if (std::abs(quaternion.norm() - 1.0) > 1e-3) {
      r.fail(rotation, "R_camera_from_imu", "the quaternion's length is " + std::to_string(quaternion.norm()) + ", not 1", fix);
    }
    p.R_camera_from_imu = quaternion.normalized();
  }
  return p;
}

HidImuProfile load_hid_imu_profile(const fs::path& file) {
  const YamlReader r(file);
  return parse_hid_imu_profile(r.load(), file);
}

std::vector<HidImuProfile> load_hid_imu_profiles(const fs::path& folder) {
  std::error_code error;
  if (!fs::is_directory(folder, error)) {
    throw InputError(input_message(folder, -1, -1, "", "is not a folder", "give the folder of the IMU profiles (config/imu)"));
  }
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.is_regular_file() && entry.path().extension() == ".yaml") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  std::vector<HidImuProfile> profiles;
  for (const auto& file : files) profiles.push_back(load_hid_imu_profile(file));
  return profiles;
}

DeviceClock::DeviceClock(double max_drift) : max_drift_(max_drift) {}

double DeviceClock::to_host(double device_seconds, double receive_seconds) {
  const double candidate = receive_seconds - device_seconds;
  if (!started_) {
    started_ = true;
    offset_ = candidate;
  } else {
    offset_ = std::min(candidate, offset_ + max_drift_ * std::max(0.0, device_seconds - last_device_));
  }
  last_device_ = device_seconds;
  return device_seconds + offset_;
}

HidReportDecoder::HidReportDecoder(HidImuProfile profile) : profile_(std::move(profile)) {}

void HidReportDecoder::reset() {
  clock_.reset();
  have_counter_ = false;
}

double HidReportDecoder::device_seconds(std::span<const std::uint8_t> report, double receive_seconds) {
  const HidField& field = *profile_.timestamp;
  const double raw = read_raw(report, field);
  if (field.type == HidFieldType::Float32) return raw * field.scale;
  // Integer counters wrap: the count is taken modulo 2^bits, and when more than one wrap may
  // have passed (a stall longer than the period) the host's clock says how many.
  const unsigned bits = static_cast<unsigned>(8 * field_size(field.type));
  const std::uint64_t modulus = std::uint64_t{1} << bits;
  const auto count = static_cast<std::uint64_t>(static_cast<std::int64_t>(raw)) & (modulus - 1);
  if (!have_counter_) {
    have_counter_ = true;
    device_time_ = static_cast<double>(count) * field.scale;
  } else {
    const std::uint64_t delta = (count - last_count_) & (modulus - 1);
    double step = static_cast<double>(delta) * field.scale;
    const double period = static_cast<double>(modulus) * field.scale;
    const double elapsed = receive_seconds - last_receive_;
    if (elapsed - step > 0.5 * period) step += std::floor((elapsed - step) / period + 0.5) * period;
    device_time_ += step;
  }
  last_count_ = count;
  last_receive_ = receive_seconds;
  return device_time_;
}

DecodeStatus HidReportDecoder::decode(std::span<const std::uint8_t> report, double receive_seconds, ImuSample& sample) {
  if (profile_.report_id && (report.empty() || report[0] != *profile_.report_id)) return DecodeStatus::WrongReportId;
  std::size_t needed = 0;
  for (const auto& field : profile_.gyro) needed = std::max(needed, field.offset + field_size(field.type));
  for (const auto& field : profile_.accel) needed = std::max(needed, field.offset + field_size(field.type));
  if (profile_.timestamp) needed = std::max(needed, profile_.timestamp->offset + field_size(profile_.timestamp->type));
  if (report.size() < needed) return DecodeStatus::TooShort;

  Eigen::Vector3d gyro, accel;
  for (std::size_t i = 0; i < 3; ++i) {
    gyro[static_cast<Eigen::Index>(i)] = read_raw(report, profile_.gyro[i]) * profile_.gyro[i].scale;
    accel[static_cast<Eigen::Index>(i)] = read_raw(report, profile_.accel[i]) * profile_.accel[i].scale;
  }
  sample.gyro = profile_.imu_from_device * gyro;
  sample.accel = profile_.imu_from_device * accel;
  sample.timestamp = profile_.timestamp ? clock_.to_host(device_seconds(report, receive_seconds), receive_seconds) : receive_seconds;
  return DecodeStatus::Ok;
}

}  // namespace skylit::track
