// Plane image stacks (OpenEXR, half) and arrays (.npy, float32) round trip, in the layout that
// Python and image tools expect.
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

#include "bake_fixtures.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit::bake_format {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

// Texel values covering [0, π]: exact zeros, π itself, tiny and mid-range values.
float texel_value(int layer, int row, int col) {
  if ((row + col + layer) % 11 == 0) return 0.0f;
  if ((row * 7 + col + layer) % 13 == 0) return static_cast<float>(std::numbers::pi);
  return static_cast<float>(std::numbers::pi * std::fmod(0.013 * layer + 0.031 * row + 0.0071 * col, 1.0) + 1e-3);
}

std::string file_bytes(const fs::path& file) { return read_file(file); }

// The 4-byte little-endian integer right after `key` in `bytes`.
std::int32_t int_after(const std::string& bytes, const std::string& key) {
  const std::size_t at = bytes.find(key);
  if (at == std::string::npos) return -1;
  std::int32_t value = 0;
  std::memcpy(&value, bytes.data() + at + key.size(), sizeof value);
  return value;
}

TEST(ExrStack, FortyLayersRoundTripWithinHalfPrecision) {
  TempDir dir;
  // Taller than one 16-row ZIP block and not a multiple of it; width ≠ height catches a transpose.
  ImageStack stack;
  stack.width = 13;
  stack.height = 37;
  stack.layers = 40;
  stack.data.resize(static_cast<std::size_t>(stack.width * stack.height * stack.layers));
  std::vector<std::string> names;
  for (int l = 0; l < stack.layers; ++l) {
    names.push_back(face_layer_name(l));
    for (int row = 0; row < stack.height; ++row) {
      for (int col = 0; col < stack.width; ++col) {
        stack.layer(l)[static_cast<std::size_t>(row * stack.width + col)] = texel_value(l, row, col);
      }
    }
  }
  EXPECT_EQ(face_layer_name(7), "face_007");
  EXPECT_EQ(face_layer_name(639), "face_639");
  const fs::path file = dir / "ground.exr";
  write_exr_stack(file, stack, names);

  std::vector<std::string> read_names;
  const ImageStack back = read_exr_stack(file, &read_names);
  ASSERT_EQ(back.width, 13);
  ASSERT_EQ(back.height, 37);
  ASSERT_EQ(back.layers, 40);
  EXPECT_EQ(read_names, names);
  int zeros = 0;
  int pis = 0;
  double worst = 0.0;
  for (std::size_t k = 0; k < stack.data.size(); ++k) {
    const float want = stack.data[k];
    const float got = back.data[k];
    if (want == 0.0f) {
      EXPECT_EQ(got, 0.0f) << k;
      ++zeros;
      continue;
    }
    if (want == static_cast<float>(std::numbers::pi)) ++pis;
    const double rel = std::abs(got - want) / want;
    worst = std::max(worst, rel);
    ASSERT_LE(rel, 1e-3) << "texel " << k << ": " << want << " read as " << got;
  }
  EXPECT_GT(zeros, 100);
  EXPECT_GT(pis, 100);
  // Half has an 11-bit significand: rounding error at most 2^-11 ≈ 4.9e-4.
  EXPECT_LE(worst, std::ldexp(1.0, -11) * 1.0001);
  EXPECT_GT(worst, 0.0);  // it really is stored as half

  // The file is what other tools expect: ZIP (3), HALF (1) channels named "<layer>.Y".
  const std::string bytes = file_bytes(file);
  ASSERT_EQ(bytes.substr(0, 4), std::string("\x76\x2f\x31\x01", 4));
  const std::string compression_key("compression\0compression\0", 24);
  EXPECT_EQ(int_after(bytes, compression_key), 1);
  EXPECT_EQ(bytes[bytes.find(compression_key) + compression_key.size() + 4], 3);
  EXPECT_EQ(int_after(bytes, std::string("face_000.Y\0", 11)), 1);
  EXPECT_EQ(int_after(bytes, std::string("face_039.Y\0", 11)), 1);
  EXPECT_EQ(bytes.find(std::string("face_040.Y\0", 11)), std::string::npos);

  const ExrInfo info = read_exr_info(file);
  EXPECT_EQ(info.width, 13);
  EXPECT_EQ(info.height, 37);
  EXPECT_EQ(info.layer_names, names);
}

TEST(ExrStack, LayersComeBackInNumericOrderBeyondAThousand) {
  TempDir dir;
  ImageStack stack;
  stack.width = 2;
  stack.height = 1;
  stack.layers = 3;
  stack.data = {1, 1, 2, 2, 3, 3};
  const std::vector<std::string> names = {face_layer_name(99), face_layer_name(100), face_layer_name(1000)};
  write_exr_stack(dir / "s.exr", stack, names);
  std::vector<std::string> back_names;
  const ImageStack back = read_exr_stack(dir / "s.exr", &back_names);
  EXPECT_EQ(back_names, names);
  EXPECT_EQ(back.data, stack.data);
}

TEST(ExrStack, TruncatedOrForeignFilesAreInputErrors) {
  TempDir dir;
  ImageStack stack;
  stack.width = 64;
  stack.height = 64;
  stack.layers = 4;
  stack.data.resize(64 * 64 * 4);
  for (std::size_t k = 0; k < stack.data.size(); ++k) stack.data[k] = static_cast<float>(std::sin(0.1 * k) + 1.0);
  const std::vector<std::string> names = {"a", "b", "c", "d"};
  const fs::path file = dir / "cut.exr";
  write_exr_stack(file, stack, names);
  fs::resize_file(file, fs::file_size(file) * 2 / 3);
  try {
    read_exr_stack(file);
    FAIL() << "a truncated file was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cut.exr"), std::string::npos) << e.what();
  }
  fs::resize_file(file, 100);  // inside the header
  EXPECT_THROW(read_exr_info(file), InputError);
  { std::ofstream(dir / "text.exr") << "not an image"; }
  EXPECT_THROW(read_exr_stack(dir / "text.exr"), InputError);
  EXPECT_THROW(read_exr_info(dir / "text.exr"), InputError);
  EXPECT_THROW(read_exr_stack(dir / "absent.exr"), InputError);
  // A failed write leaves no file behind.
  EXPECT_ANY_THROW(write_exr_stack(dir / "no-such-dir" / "x.exr", stack, names));
  EXPECT_FALSE(fs::exists(dir / "no-such-dir" / "x.exr"));
}

// Headers that would make OpenEXR allocate what a size field says are refused before it reads
// them: an attribute larger than the file (found by fuzzing: OpenEXR asked for 1.6 GB), a data
// window larger than any plane, and a channel list that runs past its own size field.
TEST(ExrStack, OversizedHeadersAreInputErrorsBeforeAnythingIsAllocated) {
  const fs::path corpus = fs::path(SKYLIT_SOURCE_DIR) / "fuzz/corpus/exr";
  const std::string attribute = skylit::test::error_of([&] { read_exr_info(corpus / "crash-opaque-attribute-of-1.6GB.exr"); });
  EXPECT_NE(attribute.find("bytes, more than the rest of the file"), std::string::npos) << attribute;
  EXPECT_THROW(read_exr_stack(corpus / "crash-channel-list-past-its-size.exr"), InputError);

  TempDir dir;
  ImageStack stack{4, 3, 1, std::vector<float>(12, 0.5f)};
  const fs::path file = dir / "wide.exr";
  write_exr_stack(file, stack, std::vector<std::string>{"a"});
  std::string bytes = file_bytes(file);
  const std::string key = std::string("dataWindow") + '\0' + "box2i" + '\0';
  const std::size_t at = bytes.find(key);
  ASSERT_NE(at, std::string::npos);
  const std::int32_t huge = 999999;  // xMax: a window a million texels wide
  std::memcpy(bytes.data() + at + key.size() + 4 + 8, &huge, sizeof huge);
  std::ofstream(file, std::ios::binary) << bytes;
  const std::string window = skylit::test::error_of([&] { read_exr_stack(file); });
  EXPECT_NE(window.find("data window is 1000000x3, larger than 16384 on a side"), std::string::npos) << window;
}

TEST(Npy, RoundTripIsExactAndTheHeaderIsNumpys) {
  TempDir dir;
  const std::size_t shape[] = {3, 40};
  std::vector<float> data(120);
  for (std::size_t k = 0; k < data.size(); ++k) data[k] = static_cast<float>(std::numbers::pi / (k + 1.0));
  data[0] = 0.0f;
  data[1] = -0.0f;
  data[2] = std::numeric_limits<float>::denorm_min();
  data[3] = std::numeric_limits<float>::max();
  const fs::path file = dir / "transfer.npy";
  write_npy(file, data, shape);

  const std::string bytes = read_file(file);
  ASSERT_GE(bytes.size(), 10U);
  EXPECT_EQ(bytes.substr(0, 6), std::string("\x93NUMPY", 6));
  EXPECT_EQ(bytes[6], 1);
  EXPECT_EQ(bytes[7], 0);
  const std::size_t header_len = static_cast<unsigned char>(bytes[8]) | static_cast<unsigned char>(bytes[9]) << 8;
  EXPECT_EQ((10 + header_len) % 64, 0U);
  const std::string header = bytes.substr(10, header_len);
  const std::string dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (3, 40), }";
  EXPECT_EQ(header.rfind(dict, 0), 0U) << header;
  EXPECT_EQ(header.back(), '\n');
  EXPECT_EQ(header.find_first_not_of(' ', dict.size()), header_len - 1);  // spaces, then '\n'

  EXPECT_EQ(bytes.size(), 10 + header_len + 120 * 4);
  EXPECT_EQ(std::memcmp(bytes.data() + 10 + header_len, data.data(), 120 * 4), 0);

  std::vector<std::size_t> back_shape;
  const std::vector<float> back = read_npy(file, &back_shape);
  EXPECT_EQ(back_shape, (std::vector<std::size_t>{3, 40}));
  ASSERT_EQ(back.size(), data.size());
  EXPECT_EQ(std::memcmp(back.data(), data.data(), data.size() * 4), 0);  // bitwise, -0 included

  // One dimension is written as Python writes a one-element tuple.
  const std::size_t flat[] = {4};
  const float four[] = {1, 2, 3, 4};
  write_npy(dir / "flat.npy", four, flat);
  EXPECT_NE(read_file(dir / "flat.npy").find("'shape': (4,), }"), std::string::npos);
  EXPECT_EQ(read_npy(dir / "flat.npy", &back_shape), (std::vector<float>{1, 2, 3, 4}));
  EXPECT_EQ(back_shape, (std::vector<std::size_t>{4}));
  EXPECT_THROW(write_npy(dir / "bad.npy", four, shape), std::invalid_argument);
}

TEST(Npy, ReadsVersionTwoAndRefusesOtherTypesOrders) {
  TempDir dir;
  const auto make = [&](const std::string& name, int major, const std::string& dict, std::size_t floats) {
    std::string header = dict;
    const std::size_t prefix = major == 1 ? 10 : 12;
    header.append((64 - (prefix + header.size() + 1) % 64) % 64, ' ');
    header += '\n';
    std::string bytes("\x93NUMPY", 6);
    bytes += static_cast<char>(major);
    bytes += '\0';
    const std::size_t n = header.size();
    bytes += static_cast<char>(n & 0xff);
    bytes += static_cast<char>(n >> 8);
    if (major != 1) bytes += std::string(2, '\0');
    bytes += header;
    bytes += std::string(floats * 4, '\0');
    write_file_atomic(dir / name, bytes);
    return dir / name;
  };
  std::vector<std::size_t> shape;
  // Keys in another order, version 2.0 (4-byte header length): still read.
  const fs::path v2 = make("v2.npy", 2, "{'shape': (2, 3), 'fortran_order': False, 'descr': '<f4'}", 6);
  EXPECT_EQ(read_npy(v2, &shape).size(), 6U);
  EXPECT_EQ(shape, (std::vector<std::size_t>{2, 3}));

  const auto refused = [&](const fs::path& file, const char* word) {
    try {
      read_npy(file, &shape);
      ADD_FAILURE() << file << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(file.filename().string()), std::string::npos) << e.what();
    }
  };
  refused(make("f8.npy", 1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }", 12), "descr");
  refused(make("fortran.npy", 1, "{'descr': '<f4', 'fortran_order': True, 'shape': (2, 3), }", 6), "fortran_order");
  refused(make("short.npy", 1, "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }", 5), "truncated");
  refused(make("long.npy", 1, "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }", 7), "trailing");
  // A shape whose product wraps to 0 in 64 bits: the header alone would "match" the file's size.
  refused(make("wrap.npy", 1, "{'descr': '<f4', 'fortran_order': False, 'shape': (4294967296, 4294967296, 16), }", 0),
          "overflows");
  { std::ofstream(dir / "text.npy") << "hello, world"; }
  refused(dir / "text.npy", "NUMPY");
}

}  // namespace
}  // namespace skylit::bake_format
