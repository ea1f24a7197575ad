// NumPy .npy files (format version 1.0 written; 1.0, 2.0 and 3.0 read), float32 or uint32
// little-endian.
#include <bit>
#include <cstring>
#include <limits>
#include <optional>
#include <fstream>
#include <stdexcept>

#include "skylit/bake_format/arrays.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit::bake_format {
namespace {

namespace fs = std::filesystem;

// The data are written and read as the host's float32 bytes; every platform skylit runs on
// (x86-64, aarch64) is little-endian, which is what '<f4' means.
static_assert(std::endian::native == std::endian::little, "npy I/O assumes a little-endian host");

constexpr char kMagic[] = "\x93NUMPY";
constexpr std::size_t kMagicSize = 6;
constexpr std::size_t kAlignment = 64;
constexpr const char* kFix = "re-bake, or save the array with numpy.save(path, a.astype('<f4'))";

[[noreturn]] void bad(const fs::path& file, const std::string& field, const std::string& problem) {
  throw InputError(input_message(file, -1, -1, field, problem, kFix));
}

std::string shape_text(std::span<const std::size_t> shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  if (shape.size() == 1) s += ",";  // Python's one-element tuple
  return s + ")";
}

// Elements of `shape`, or nullopt when the product (or its bytes) would not fit 64 bits: a shape
// read from a file is anyone's.
std::optional<std::uint64_t> checked_element_count(std::span<const std::size_t> shape) {
  std::uint64_t n = 1;
  for (std::size_t d : shape) {
    if (__builtin_mul_overflow(n, static_cast<std::uint64_t>(d), &n)) return std::nullopt;
  }
  if (n > std::numeric_limits<std::uint64_t>::max() / sizeof(float)) return std::nullopt;
  return n;
}

std::uint64_t element_count(std::span<const std::size_t> shape) { return checked_element_count(shape).value_or(0); }

// The value text of `key` in the header's Python dict literal, e.g. "'<f4'", "False", "(3, 4)".
std::string dict_value(const fs::path& file, const std::string& header, const std::string& key) {
  std::size_t at = header.find("'" + key + "'");
  if (at == std::string::npos) at = header.find("\"" + key + "\"");
  if (at == std::string::npos) bad(file, key, "missing from the .npy header");
  at = header.find(':', at + key.size() + 2);
  if (at == std::string::npos) bad(file, key, "has no value in the .npy header");
  ++at;
  while (at < header.size() && header[at] == ' ') ++at;
  if (at >= header.size()) bad(file, key, "has no value in the .npy header");
  std::size_t end = at;
  if (header[at] == '(') {
    end = header.find(')', at);
    if (end == std::string::npos) bad(file, key, "unterminated tuple");
    return header.substr(at, end - at + 1);
  }
  if (header[at] == '\'' || header[at] == '"') {
    end = header.find(header[at], at + 1);
    if (end == std::string::npos) bad(file, key, "unterminated string");
    return header.substr(at + 1, end - at - 1);
  }
  while (end < header.size() && header[end] != ',' && header[end] != '}') ++end;
  std::string value = header.substr(at, end - at);
  while (!value.empty() && value.back() == ' ') value.pop_back();
  return value;
}

std::vector<std::size_t> parse_shape(const fs::path& file, const std::string& tuple) {
  std::vector<std::size_t> shape;
  std::size_t i = 1;  // past '('
  while (i < tuple.size()) {
    while (i < tuple.size() && (tuple[i] == ' ' || tuple[i] == ',')) ++i;
    if (i >= tuple.size() || tuple[i] == ')') break;
    std::size_t end = i;
    while (end < tuple.size() && tuple[end] >= '0' && tuple[end] <= '9') ++end;
    // 'L' is Python 2's long suffix, still found in old files.
    if (end == i || end - i > 18) bad(file, "shape", "is not a tuple of sizes: " + tuple);
    shape.push_back(static_cast<std::size_t>(std::stoull(tuple.substr(i, end - i))));
    i = end;
    if (i < tuple.size() && tuple[i] == 'L') ++i;
  }
  return shape;
}

// Four-byte elements of type `descr` ('<f4', '<u4').
void write_npy_bytes(const fs::path& file, const std::string& descr, std::span<const std::byte> data,
                     std::span<const std::size_t> shape) {
  if (element_count(shape) * 4 != data.size()) {
    throw std::invalid_argument("write_npy: shape " + shape_text(shape) + " does not hold " +
                                std::to_string(data.size() / 4) + " values");
  }
  std::string header = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape_text(shape) + ", }";
  // Magic (6) + version (2) + length (2) + header + '\n' padded with spaces to a multiple of 64.
  const std::size_t unpadded = kMagicSize + 4 + header.size() + 1;
  header.append((kAlignment - unpadded % kAlignment) % kAlignment, ' ');
  header += '\n';
  if (header.size() > 0xffff) throw std::invalid_argument("write_npy: header too long for format 1.0");

  std::string bytes(kMagic, kMagicSize);
  bytes += '\x01';
  bytes += '\x00';
  bytes += static_cast<char>(header.size() & 0xff);
  bytes += static_cast<char>(header.size() >> 8);
  bytes += header;
  const std::size_t offset = bytes.size();
  bytes.resize(offset + data.size_bytes());
  if (!data.empty()) std::memcpy(bytes.data() + offset, data.data(), data.size_bytes());
  write_file_atomic(file, std::as_bytes(std::span<const char>(bytes)));
}

// The elements of a file of type `descr`, as raw bytes.
std::string read_npy_bytes(const fs::path& file, const std::string& descr, NpyInfo& info) {
  info = read_npy_info(file);
  if (info.descr != descr) {
    bad(file, "descr", "is '" + info.descr + "', expected '" + descr + "'");
  }
  const std::uint64_t count = element_count(info.shape);
  // As large as the header says, and no larger (read_npy_info checked the size against it).
  std::string bytes = read_file(file, info.data_offset + count * 4);
  // The file may have changed since read_npy_info; check again against what was read.
  if (bytes.size() != info.data_offset + count * 4) bad(file, "data", "the file changed while it was read");
  return bytes;
}

}  // namespace

void write_npy(const fs::path& file, std::span<const float> data, std::span<const std::size_t> shape) {
  write_npy_bytes(file, "<f4", std::as_bytes(data), shape);
}

void write_npy_u32(const fs::path& file, std::span<const std::uint32_t> data, std::span<const std::size_t> shape) {
  write_npy_bytes(file, "<u4", std::as_bytes(data), shape);
}

NpyInfo read_npy_info(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    throw InputError(file.string() + ": cannot be opened (" + (fs::exists(file) ? "unreadable" : "no such file") +
                     "). Fix: " + kFix);
  }
  char preamble[12] = {};
  in.read(preamble, 8);
  if (in.gcount() != 8 || std::memcmp(preamble, kMagic, kMagicSize) != 0) {
    bad(file, "magic", "not a NumPy .npy file (no \\x93NUMPY signature)");
  }
  const int major = static_cast<unsigned char>(preamble[6]);
  std::uint64_t header_size = 0;
  std::uint64_t offset = 0;
  if (major == 1) {
    in.read(preamble + 8, 2);
    if (in.gcount() != 2) bad(file, "header", "the file is truncated");
    header_size = static_cast<unsigned char>(preamble[8]) | (static_cast<unsigned>(static_cast<unsigned char>(preamble[9])) << 8);
    offset = 10;
  } else if (major == 2 || major == 3) {
    in.read(preamble + 8, 4);
    if (in.gcount() != 4) bad(file, "header", "the file is truncated");
    for (int k = 3; k >= 0; --k) header_size = (header_size << 8) | static_cast<unsigned char>(preamble[8 + k]);
    offset = 12;
  } else {
    bad(file, "version", "format version " + std::to_string(major) + " is not supported (1, 2 or 3)");
  }
  if (header_size > (1u << 24)) bad(file, "header", "implausible header length " + std::to_string(header_size));
  std::string header(header_size, '\0');
  in.read(header.data(), static_cast<std::streamsize>(header_size));
  if (static_cast<std::uint64_t>(in.gcount()) != header_size) bad(file, "header", "the file is truncated");

  const std::string descr = dict_value(file, header, "descr");
  if (descr != "<f4" && descr != "<u4") {
    bad(file, "descr", "is '" + descr + "', expected '<f4' (little-endian float32) or '<u4' (uint32)");
  }
  const std::string fortran = dict_value(file, header, "fortran_order");
  if (fortran != "False") bad(file, "fortran_order", "is " + fortran + ", expected False (C order)");
  NpyInfo info;
  info.descr = descr;
  info.shape = parse_shape(file, dict_value(file, header, "shape"));
  info.data_offset = offset + header_size;
  if (!checked_element_count(info.shape)) {
    bad(file, "shape", shape_text(info.shape) + " holds more elements than any file can (the product overflows)");
  }

  const std::uint64_t expected = info.data_offset + element_count(info.shape) * sizeof(float);
  const std::uint64_t actual = fs::file_size(file);
  if (actual != expected) {
    bad(file, "data",
        "the file has " + std::to_string(actual) + " bytes but shape " + shape_text(info.shape) + " needs " +
            std::to_string(expected) + (actual < expected ? " (truncated)" : " (trailing bytes)"));
  }
  return info;
}

std::vector<float> read_npy(const fs::path& file, std::vector<std::size_t>* shape) {
  NpyInfo info;
  const std::string bytes = read_npy_bytes(file, "<f4", info);
  const std::uint64_t count = element_count(info.shape);
  std::vector<float> data(count);
  if (count) std::memcpy(data.data(), bytes.data() + info.data_offset, count * sizeof(float));
  if (shape) *shape = info.shape;
  return data;
}

std::vector<std::uint32_t> read_npy_u32(const fs::path& file, std::vector<std::size_t>* shape) {
  NpyInfo info;
  const std::string bytes = read_npy_bytes(file, "<u4", info);
  std::vector<std::uint32_t> data(element_count(info.shape));
  if (!data.empty()) std::memcpy(data.data(), bytes.data() + info.data_offset, data.size() * 4);
  if (shape) *shape = info.shape;
  return data;
}

}  // namespace skylit::bake_format
