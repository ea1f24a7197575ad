#include "skylit/sky/radiometry.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <unistd.h>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "../support/temp_dir.hpp"

namespace skylit::sky {
namespace {

namespace fs = std::filesystem;

using skylit::test::TempDir;

// Expects InputError whose message contains every one of `parts`.
template <typename F>
void expect_input_error(F&& f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no InputError thrown";
  } catch (const InputError& e) {
    for (const std::string& part : parts) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << "'" << part << "' not in: " << e.what();
    }
  }
}

// IEC 61966-2-1 forward transfer (linear → encoded, both in [0, 1]).
double reference_srgb_encode(double linear) {
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

// ---------------------------------------------------------------------------------------------
// Response curves

TEST(Radiometry, SrgbCurveInvertsTheForwardFormula) {
  const ResponseCurve curve = ResponseCurve::srgb(8);
  ASSERT_EQ(curve.bits, 8);
  for (const auto& channel : curve.bgr) {
    ASSERT_EQ(channel.size(), 256U);
    EXPECT_EQ(channel.front(), 0.0F);
    EXPECT_FLOAT_EQ(channel.back(), 1.0F);
    for (std::size_t z = 0; z < channel.size(); ++z) {
      // Back through the forward formula: the code again, to well under a code (float storage).
      EXPECT_NEAR(reference_srgb_encode(channel[z]) * 255.0, static_cast<double>(z), 1e-3) << "code " << z;
      if (z > 0) {
        EXPECT_GT(channel[z], channel[z - 1]);
      }
    }
  }
  // Known values: the linear segment, and mid-grey.
  EXPECT_NEAR(curve.bgr[1][10], 10.0 / 255.0 / 12.92, 1e-8);
  EXPECT_NEAR(curve.bgr[1][128], 0.2158605, 1e-6);

  const ResponseCurve wide = ResponseCurve::srgb(16);
  ASSERT_EQ(wide.bgr[2].size(), 65536U);
  for (std::size_t z = 0; z < 65536; z += 97) {
    EXPECT_NEAR(reference_srgb_encode(wide.bgr[2][z]) * 65535.0, static_cast<double>(z), 0.05) << "code " << z;
  }
}

TEST(Radiometry, LinearCurveIsCodeOverTopCode) {
  const ResponseCurve curve = ResponseCurve::linear(16);
  ASSERT_EQ(curve.bgr[0].size(), 65536U);
  EXPECT_EQ(curve.bgr[0][0], 0.0F);
  EXPECT_FLOAT_EQ(curve.bgr[1][32768], static_cast<float>(32768.0 / 65535.0));
  EXPECT_EQ(curve.bgr[2][65535], 1.0F);
  EXPECT_FLOAT_EQ(ResponseCurve::linear(8).bgr[0][51], 0.2F);
}

TEST(Radiometry, CurvesRejectUnsupportedBits) {
  expect_input_error([] { (void)ResponseCurve::srgb(12); }, {"bits", "12"});
  expect_input_error([] { (void)ResponseCurve::linear(0); }, {"bits"});
}

// ---------------------------------------------------------------------------------------------
// Reading images

TEST(Radiometry, ReadsTheRealHdrSkies) {
  const fs::path dir = fs::path(SKYLIT_SOURCE_DIR) / "data" / "hdri";
  // The skies with the sun in view (park: ~1.2e4, warehouse: ~2e2); the others are overcast,
  // shaded or at night, with maxima from 2.6 to 65.
  const std::vector<std::string> sunny = {"park", "warehouse"};
  int count = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".exr") continue;
    ++count;
    const cv::Mat sky = read_sky_image(entry.path());
    ASSERT_EQ(sky.type(), CV_32FC3) << entry.path();
    EXPECT_EQ(sky.cols, 512) << entry.path();
    EXPECT_EQ(sky.rows, 256) << entry.path();
    float max_value = -std::numeric_limits<float>::infinity();
    int finite = 0;
    for (auto it = sky.begin<cv::Vec3f>(); it != sky.end<cv::Vec3f>(); ++it) {
      for (int c = 0; c < 3; ++c) {
        if (std::isfinite((*it)[c])) {
          ++finite;
          max_value = std::max(max_value, (*it)[c]);
        }
      }
    }
    EXPECT_GT(finite, 512 * 256 * 3 * 9 / 10) << entry.path();
    const std::string stem = entry.path().stem().string();
    if (std::find(sunny.begin(), sunny.end(), stem) != sunny.end()) {
      EXPECT_GT(max_value, 100.0F) << entry.path();
    } else {
      EXPECT_GT(max_value, 0.0F) << entry.path();
    }
  }
  EXPECT_EQ(count, 6);
}

TEST(Radiometry, ExrRoundTripsFloatHalfAndLuminance) {
  TempDir dir;
  cv::Mat image(7, 11, CV_32FC3);
  cv::randu(image, cv::Scalar::all(-1.0), cv::Scalar::all(1000.0));
  image.at<cv::Vec3f>(2, 3) = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), 0.5F};
  image.at<cv::Vec3f>(0, 0) = {1.0F, 2.0F, 3.0F};  // B, G, R

  write_sky_exr(dir.file("float.exr"), image);
  const cv::Mat back = read_sky_image(dir.file("float.exr"));
  ASSERT_EQ(back.type(), CV_32FC3);
  ASSERT_EQ(back.size(), image.size());
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        const float a = image.at<cv::Vec3f>(y, x)[c];
        const float b = back.at<cv::Vec3f>(y, x)[c];
        if (std::isnan(a)) {
          EXPECT_TRUE(std::isnan(b));
        } else {
          EXPECT_EQ(a, b);
        }
      }
    }
  }

  write_sky_exr(dir.file("half.exr"), image, true);
  const cv::Mat half = read_sky_image(dir.file("half.exr"));
  ASSERT_EQ(half.type(), CV_32FC3);
  EXPECT_EQ(half.at<cv::Vec3f>(0, 0), cv::Vec3f(1.0F, 2.0F, 3.0F));  // exact in half; order kept
  EXPECT_TRUE(std::isnan(half.at<cv::Vec3f>(2, 3)[0]));
  EXPECT_TRUE(std::isinf(half.at<cv::Vec3f>(2, 3)[1]));
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const float a = image.at<cv::Vec3f>(y, x)[2];
      EXPECT_NEAR(half.at<cv::Vec3f>(y, x)[2], a, std::abs(a) * 1e-3 + 1e-3);  // 11-bit mantissa
    }
  }

  cv::Mat gray(5, 4, CV_32FC1);
  cv::randu(gray, cv::Scalar::all(0.0), cv::Scalar::all(1e4));
  write_sky_exr(dir.file("y.exr"), gray);
  const cv::Mat y = read_sky_image(dir.file("y.exr"));
  ASSERT_EQ(y.type(), CV_32FC3);
  EXPECT_EQ(y.at<cv::Vec3f>(4, 3), cv::Vec3f::all(gray.at<float>(4, 3)));

  expect_input_error([&] { write_sky_exr(dir.file("bad.exr"), cv::Mat(4, 4, CV_8UC3)); }, {"bad.exr"});
  expect_input_error([&] { write_sky_exr(dir.file("no/such/dir/a.exr"), image); }, {"a.exr"});
}

TEST(Radiometry, ReadsIntegerAndHdrFormats) {
  TempDir dir;
  cv::Mat gray(6, 9, CV_8UC1, cv::Scalar(77));
  ASSERT_TRUE(cv::imwrite(dir.file("gray.png").string(), gray));
  const cv::Mat g = read_sky_image(dir.file("gray.png"));
  EXPECT_EQ(g.type(), CV_8UC3);
  EXPECT_EQ(g.at<cv::Vec3b>(5, 8), cv::Vec3b(77, 77, 77));

  cv::Mat bgra(6, 9, CV_16UC4, cv::Scalar(1000, 2000, 3000, 65535));
  ASSERT_TRUE(cv::imwrite(dir.file("bgra16.png").string(), bgra));
  const cv::Mat b = read_sky_image(dir.file("bgra16.png"));
  EXPECT_EQ(b.type(), CV_16UC3);
  EXPECT_EQ(b.at<cv::Vec3w>(1, 1), cv::Vec3w(1000, 2000, 3000));

  cv::Mat gray16(4, 4, CV_16UC1, cv::Scalar(40000));
  ASSERT_TRUE(cv::imwrite(dir.file("gray16.png").string(), gray16));
  EXPECT_EQ(read_sky_image(dir.file("gray16.png")).at<cv::Vec3w>(3, 3), cv::Vec3w::all(40000));

  cv::Mat hdr(8, 8, CV_32FC3, cv::Scalar(150.0, 200.0, 300.0));
  ASSERT_TRUE(cv::imwrite(dir.file("sky.hdr").string(), hdr));
  const cv::Mat h = read_sky_image(dir.file("sky.hdr"));
  ASSERT_EQ(h.type(), CV_32FC3);
  // RGBE: an 8-bit mantissa per channel under the largest channel's exponent.
  EXPECT_NEAR(h.at<cv::Vec3f>(2, 2)[0], 150.0, 300.0 / 128.0);
  EXPECT_NEAR(h.at<cv::Vec3f>(2, 2)[2], 300.0, 300.0 / 128.0);
}

TEST(Radiometry, ReadSkyImageRejectsBadFilesByName) {
  TempDir dir;
  expect_input_error([&] { (void)read_sky_image(dir.file("missing.png")); }, {"missing.png", "does not exist"});
  expect_input_error([&] { (void)read_sky_image(dir.write("empty.jpg", "")); }, {"empty.jpg", "empty"});
  expect_input_error([&] { (void)read_sky_image(dir.write("junk.png", "not an image at all")); },
                     {"junk.png", "not an image of a kind skylit reads"});
  // A PNG's signature over bytes that are no PNG: for the decoder to refuse.
  expect_input_error([&] { (void)read_sky_image(dir.write("fake.png", std::string("\x89PNG\r\n\x1a\n", 8) + "garbage")); },
                     {"fake.png", "decoded"});
  // The OpenEXR magic number followed by nothing sensible.
  expect_input_error([&] { (void)read_sky_image(dir.write("trunc.exr", std::string("\x76\x2f\x31\x01\x02\0\0\0", 8))); },
                     {"trunc.exr", "OpenEXR"});
  // A real EXR cut short.
  write_sky_exr(dir.file("whole.exr"), cv::Mat(32, 32, CV_32FC3, cv::Scalar::all(1.0)));
  const std::string bytes = read_file(dir.file("whole.exr"));
  expect_input_error([&] { (void)read_sky_image(dir.write("cut.exr", bytes.substr(0, bytes.size() / 2))); },
                     {"cut.exr"});
  // 32-bit signed samples are no camera's output.
  ASSERT_TRUE(cv::imwrite(dir.file("signed.tiff").string(), cv::Mat(4, 4, CV_32SC1, cv::Scalar(5))));
  expect_input_error([&] { (void)read_sky_image(dir.file("signed.tiff")); }, {"signed.tiff", "unsupported"});
  expect_input_error([&] { (void)read_sky_image(fs::path()); }, {"does not exist"});
  expect_input_error([&] { (void)read_sky_image(dir.file("")); }, {"not a regular file"});
}

// ---------------------------------------------------------------------------------------------
// EXIF

void put16(std::vector<std::uint8_t>& b, std::uint16_t v) {
  b.push_back(static_cast<std::uint8_t>(v & 0xFF));
  b.push_back(static_cast<std::uint8_t>(v >> 8));
}
void put32(std::vector<std::uint8_t>& b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>((v >> (8 * i)) & 0xFF));
}
void put_entry(std::vector<std::uint8_t>& b, std::uint16_t tag, std::uint16_t type, std::uint32_t value) {
  put16(b, tag);
  put16(b, type);
  put32(b, 1);
  put32(b, value);
}

// A little-endian TIFF block: IFD0 → Exif IFD with ExposureTime 1/250 (and ISOSpeedRatings 200).
std::vector<std::uint8_t> exif_tiff(bool with_iso) {
  std::vector<std::uint8_t> t = {'I', 'I', 42, 0};
  put32(t, 8);                                  // IFD0 offset
  put16(t, 1);                                  // IFD0: one entry
  put_entry(t, 0x8769, 4, 26);                  // ExifIFDPointer (LONG) → offset 26
  put32(t, 0);                                  // no next IFD
  const std::uint16_t entries = with_iso ? 2 : 1;
  const std::uint32_t data_offset = 26 + 2 + 12U * entries + 4;
  put16(t, entries);
  put_entry(t, 0x829A, 5, data_offset);         // ExposureTime (RATIONAL) → data
  if (with_iso) {
    put16(t, 0x8827);                           // ISOSpeedRatings (SHORT), value inline
    put16(t, 3);
    put32(t, 1);
    put16(t, 200);
    put16(t, 0);
  }
  put32(t, 0);
  put32(t, 1);                                  // 1/250 s
  put32(t, 250);
  return t;
}

// A JPEG from OpenCV with an APP1 "Exif" segment inserted right after SOI.
std::string jpeg_with_app1(const std::vector<std::uint8_t>& tiff) {
  std::vector<std::uint8_t> jpeg;
  cv::imencode(".jpg", cv::Mat(16, 16, CV_8UC3, cv::Scalar(10, 120, 240)), jpeg);
  std::vector<std::uint8_t> app1 = {0xFF, 0xE1, 0, 0, 'E', 'x', 'i', 'f', 0, 0};
  app1.insert(app1.end(), tiff.begin(), tiff.end());
  const std::size_t length = app1.size() - 2;
  app1[2] = static_cast<std::uint8_t>(length >> 8);
  app1[3] = static_cast<std::uint8_t>(length & 0xFF);
  jpeg.insert(jpeg.begin() + 2, app1.begin(), app1.end());
  return std::string(jpeg.begin(), jpeg.end());
}

TEST(Radiometry, ReadsExposureFromExif) {
  TempDir dir;
  const fs::path file = dir.write("bracket_0.jpg", jpeg_with_app1(exif_tiff(true)));
  const std::optional<Exposure> exposure = read_exposure_metadata(file);
  ASSERT_TRUE(exposure.has_value());
  EXPECT_DOUBLE_EQ(exposure->time_s, 0.004);
  EXPECT_DOUBLE_EQ(exposure->gain, 2.0);
  // The image itself still decodes.
  EXPECT_EQ(read_sky_image(file).size(), cv::Size(16, 16));

  const std::optional<Exposure> no_iso = read_exposure_metadata(dir.write("no_iso.jpg", jpeg_with_app1(exif_tiff(false))));
  ASSERT_TRUE(no_iso.has_value());
  EXPECT_DOUBLE_EQ(no_iso->time_s, 0.004);
  EXPECT_DOUBLE_EQ(no_iso->gain, 1.0);
}

TEST(Radiometry, ExposureMetadataAbsentOrBroken) {
  TempDir dir;
  std::vector<std::uint8_t> plain;
  cv::imencode(".jpg", cv::Mat(8, 8, CV_8UC3, cv::Scalar::all(50)), plain);
  EXPECT_FALSE(read_exposure_metadata(dir.write("plain.jpg", std::string(plain.begin(), plain.end()))));
  ASSERT_TRUE(cv::imwrite(dir.file("plain.png").string(), cv::Mat(8, 8, CV_8UC3, cv::Scalar::all(50))));
  EXPECT_FALSE(read_exposure_metadata(dir.file("plain.png")));
  write_sky_exr(dir.file("sky.exr"), cv::Mat(8, 8, CV_32FC3, cv::Scalar::all(1.0)));
  EXPECT_FALSE(read_exposure_metadata(dir.file("sky.exr")));
  EXPECT_FALSE(read_exposure_metadata(dir.write("text.jpg", "hello")));
  // A truncated TIFF block and one with offsets pointing far outside it: no crash, no value.
  std::vector<std::uint8_t> tiff = exif_tiff(true);
  EXPECT_FALSE(read_exposure_metadata(
      dir.write("short.jpg", jpeg_with_app1(std::vector<std::uint8_t>(tiff.begin(), tiff.begin() + 30)))));
  std::vector<std::uint8_t> wild = tiff;
  wild[18] = 0xFF;  // ExifIFDPointer's low byte → offset 0xFF..
  wild[19] = 0xFF;
  EXPECT_FALSE(read_exposure_metadata(dir.write("wild.jpg", jpeg_with_app1(wild))));
  // Zero denominator.
  std::vector<std::uint8_t> zero = tiff;
  zero[zero.size() - 4] = 0;
  zero[zero.size() - 3] = 0;
  EXPECT_FALSE(read_exposure_metadata(dir.write("zero.jpg", jpeg_with_app1(zero))));
  expect_input_error([&] { (void)read_exposure_metadata(dir.file("missing.jpg")); }, {"missing.jpg"});
}

// ---------------------------------------------------------------------------------------------
// Linearisation

TEST(Radiometry, LinearisesCodesThroughTheCurveAndExposure) {
  cv::Mat frame(2, 3, CV_8UC3, cv::Scalar(0, 0, 0));
  frame.at<cv::Vec3b>(0, 0) = {10, 128, 255};
  frame.at<cv::Vec3b>(0, 1) = {249, 100, 0};
  frame.at<cv::Vec3b>(0, 2) = {250, 100, 0};  // 250 ≥ 0.98 × 255
  const ResponseCurve srgb = ResponseCurve::srgb(8);
  const RadianceFrame out = linearise(frame, srgb, {0.01, 2.0});
  ASSERT_EQ(out.radiance.type(), CV_32FC3);
  ASSERT_EQ(out.clipped.type(), CV_8UC1);
  const cv::Vec3f p = out.radiance.at<cv::Vec3f>(0, 0);
  EXPECT_FLOAT_EQ(p[0], srgb.bgr[0][10] / 0.02F);
  EXPECT_FLOAT_EQ(p[1], srgb.bgr[1][128] / 0.02F);
  EXPECT_FLOAT_EQ(p[2], 1.0F / 0.02F);
  EXPECT_EQ(out.clipped.at<std::uint8_t>(0, 0), 255);
  EXPECT_EQ(out.clipped.at<std::uint8_t>(0, 1), 0);
  EXPECT_EQ(out.clipped.at<std::uint8_t>(0, 2), 255);
  EXPECT_EQ(out.clipped.at<std::uint8_t>(1, 0), 0);
  // A looser clip threshold.
  EXPECT_EQ(linearise(frame, srgb, {}, {0.9}).clipped.at<std::uint8_t>(0, 1), 255);

  cv::Mat wide(1, 2, CV_16UC3, cv::Scalar(0, 32768, 65535));
  const RadianceFrame w = linearise(wide, ResponseCurve::linear(16), {0.5, 1.0});
  EXPECT_FLOAT_EQ(w.radiance.at<cv::Vec3f>(0, 1)[1], static_cast<float>(32768.0 / 65535.0 / 0.5));
  EXPECT_EQ(w.clipped.at<std::uint8_t>(0, 1), 255);

  // Gray frames are expanded.
  const RadianceFrame g = linearise(cv::Mat(2, 2, CV_8UC1, cv::Scalar(51)), ResponseCurve::linear(8), {});
  EXPECT_FLOAT_EQ(g.radiance.at<cv::Vec3f>(1, 1)[2], 0.2F);
}

TEST(Radiometry, FloatFramesPassThroughWithNaN) {
  cv::Mat frame(2, 2, CV_32FC3, cv::Scalar(2.0, 4.0, 8.0));
  frame.at<cv::Vec3f>(0, 1) = {std::numeric_limits<float>::quiet_NaN(), -3.0F,
                               std::numeric_limits<float>::infinity()};
  const RadianceFrame out = linearise(frame, ResponseCurve::srgb(8), {0.5, 4.0});
  ASSERT_EQ(out.radiance.type(), CV_32FC3);
  EXPECT_TRUE(out.clipped.empty());
  EXPECT_EQ(out.radiance.at<cv::Vec3f>(0, 0), cv::Vec3f(1.0F, 2.0F, 4.0F));
  const cv::Vec3f odd = out.radiance.at<cv::Vec3f>(0, 1);
  EXPECT_TRUE(std::isnan(odd[0]));
  EXPECT_FLOAT_EQ(odd[1], -1.5F);
  EXPECT_TRUE(std::isinf(odd[2]));
  // The response curve is not consulted for float frames (any bits will do).
  EXPECT_NO_THROW(linearise(frame, ResponseCurve{}, {}));
  // Double frames are float too.
  cv::Mat f64(1, 1, CV_64FC3, cv::Scalar(1.0, 2.0, 3.0));
  EXPECT_EQ(linearise(f64, ResponseCurve::srgb(8), {}).radiance.at<cv::Vec3f>(0, 0), cv::Vec3f(1.0F, 2.0F, 3.0F));
}

TEST(Radiometry, LineariseRejectsBadInput) {
  const cv::Mat frame(4, 4, CV_8UC3, cv::Scalar::all(100));
  expect_input_error([&] { (void)linearise(cv::Mat(), ResponseCurve::srgb(8), {}); }, {"empty"});
  expect_input_error([&] { (void)linearise(frame, ResponseCurve::srgb(16), {}); }, {"bits", "8-bit frame"});
  expect_input_error([&] { (void)linearise(cv::Mat(2, 2, CV_16UC3), ResponseCurve::srgb(8), {}); }, {"bits"});
  expect_input_error([&] { (void)linearise(frame, ResponseCurve::srgb(8), {0.0, 1.0}); }, {"time_s"});
  expect_input_error([&] { (void)linearise(frame, ResponseCurve::srgb(8), {std::nan(""), 1.0}); }, {"time_s"});
  expect_input_error([&] { (void)linearise(frame, ResponseCurve::srgb(8), {1.0, -1.0}); }, {"gain"});
  expect_input_error([&] { (void)linearise(frame, ResponseCurve::srgb(8), {}, {1.5}); }, {"clip_fraction"});
  ResponseCurve short_curve = ResponseCurve::srgb(8);
  short_curve.bgr[1].resize(10);
  expect_input_error([&] { (void)linearise(frame, short_curve, {}); }, {"'g'", "10 entries"});
  expect_input_error([&] { (void)linearise(cv::Mat(2, 2, CV_16SC3), ResponseCurve::srgb(8), {}); }, {"unsupported"});
  expect_input_error([&] { (void)linearise(cv::Mat(2, 2, CV_8UC2), ResponseCurve::srgb(8), {}); }, {"channels"});
}

// ---------------------------------------------------------------------------------------------
// Brackets

// Truth radiance, BGR: log-uniform over 10^5 along x, tinted per channel, with a patch far
// brighter than any exposure can hold (the sun) and a black patch.
cv::Mat synthetic_sky(int width, int height) {
  cv::Mat radiance(height, width, CV_32FC3);
  const cv::Vec3f tint(0.6F, 0.8F, 1.0F);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double u = (x + 0.37 * y) / (width + 0.37 * height);  // varies along both axes
      const double level = 0.8 * std::pow(10.0, -5.0 * u);
      cv::Vec3f& p = radiance.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) p[c] = static_cast<float>(level * tint[c] * (1.0 + 0.1 * std::sin(0.3 * y + c)));
    }
  }
  radiance(cv::Rect(2, 2, 6, 6)).setTo(cv::Scalar::all(1e4));  // sun
  radiance(cv::Rect(width - 8, height - 8, 6, 6)).setTo(cv::Scalar::all(0.0));  // black
  return radiance;
}

// Renders radiance × time through an encoding (linear → [0, 1]) to 8-bit codes.
template <typename Encode>
cv::Mat render_8bit(const cv::Mat& radiance, double time, Encode encode) {
  cv::Mat frame(radiance.size(), CV_8UC3);
  for (int y = 0; y < radiance.rows; ++y) {
    for (int x = 0; x < radiance.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        const double v = std::clamp(radiance.at<cv::Vec3f>(y, x)[c] * time, 0.0, 1.0);
        frame.at<cv::Vec3b>(y, x)[c] = static_cast<std::uint8_t>(std::lround(255.0 * encode(v)));
      }
    }
  }
  return frame;
}

TEST(Radiometry, MergesAnSrgbBracketBackToRadiance) {
  const cv::Mat truth = synthetic_sky(256, 96);
  // Five exposures 12x apart: the brightest sky at code ~240 in the shortest, the darkest at
  // ~84 in the longest. Half a code of 8-bit sRGB quantisation, merged with hat weights, is then
  // at most 1.9% of the radiance anywhere in the range (a frame at a low code carries weight but
  // little precision), hence the 2% bound.
  std::vector<Exposure> exposures;
  std::vector<cv::Mat> frames;
  for (int k = 0; k < 5; ++k) {
    exposures.push_back({std::pow(12.0, k) / 4.0, 4.0});  // gain enters like time
    frames.push_back(render_8bit(truth, exposures.back().time_s * exposures.back().gain, reference_srgb_encode));
  }
  // Given out of order: the merge sorts by exposure.
  std::swap(frames[0], frames[3]);
  std::swap(exposures[0], exposures[3]);
  const RadianceFrame merged = merge_bracket(frames, exposures, ResponseCurve::srgb(8));
  ASSERT_EQ(merged.radiance.type(), CV_32FC3);
  ASSERT_EQ(merged.clipped.type(), CV_8UC1);

  const cv::Rect sun(2, 2, 6, 6);
  const cv::Rect black(truth.cols - 8, truth.rows - 8, 6, 6);
  double worst = 0.0;
  int checked = 0;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      const cv::Point p(x, y);
      if (sun.contains(p)) {
        EXPECT_EQ(merged.clipped.at<std::uint8_t>(p), 255);
        // The shortest exposure's value: the top code over time x gain = 1.
        EXPECT_FLOAT_EQ(merged.radiance.at<cv::Vec3f>(p)[1], 1.0F);
        continue;
      }
      EXPECT_EQ(merged.clipped.at<std::uint8_t>(p), 0) << x << "," << y;
      if (black.contains(p)) {
        EXPECT_EQ(merged.radiance.at<cv::Vec3f>(p), cv::Vec3f(0, 0, 0));
        continue;
      }
      for (int c = 0; c < 3; ++c) {
        const double t = truth.at<cv::Vec3f>(p)[c];
        const double m = merged.radiance.at<cv::Vec3f>(p)[c];
        worst = std::max(worst, std::abs(m - t) / t);
        ++checked;
      }
    }
  }
  EXPECT_LT(worst, 0.02) << "worst relative error over " << checked << " samples";
  RecordProperty("worst_relative_error", std::to_string(worst));
}

TEST(Radiometry, MergeUsesHatWeightsAndFallbacks) {
  // Codes chosen per pixel; a linear curve with an offset so that code 0 has a value.
  ResponseCurve curve = ResponseCurve::linear(8);
  for (auto& channel : curve.bgr) {
    for (std::size_t z = 0; z < 256; ++z) channel[z] = static_cast<float>((z + 1) / 256.0);
  }
  const auto lin = [&](int z, double e) { return (z + 1) / 256.0 / e; };
  cv::Mat shortf(1, 4, CV_8UC3, cv::Scalar::all(0));
  cv::Mat longf(1, 4, CV_8UC3, cv::Scalar::all(0));
  shortf.at<cv::Vec3b>(0, 0) = cv::Vec3b::all(100);  // weight 100
  longf.at<cv::Vec3b>(0, 0) = cv::Vec3b::all(220);   // weight 35
  shortf.at<cv::Vec3b>(0, 1) = cv::Vec3b::all(255);  // clipped everywhere
  longf.at<cv::Vec3b>(0, 1) = cv::Vec3b::all(252);
  shortf.at<cv::Vec3b>(0, 2) = cv::Vec3b::all(0);    // black everywhere
  longf.at<cv::Vec3b>(0, 2) = cv::Vec3b::all(0);
  shortf.at<cv::Vec3b>(0, 3) = cv::Vec3b(40, 0, 40);  // G black in the short frame only
  longf.at<cv::Vec3b>(0, 3) = cv::Vec3b(255, 9, 80);  // B clipped in the long frame only
  const std::vector<cv::Mat> frames = {longf, shortf};
  const std::vector<Exposure> exposures = {{2.0, 1.0}, {1.0, 1.0}};
  const RadianceFrame out = merge_bracket(frames, exposures, curve);
  const cv::Vec3f p0 = out.radiance.at<cv::Vec3f>(0, 0);
  EXPECT_FLOAT_EQ(p0[1], static_cast<float>((100 * lin(100, 1.0) + 35 * lin(220, 2.0)) / 135.0));
  EXPECT_EQ(out.clipped.at<std::uint8_t>(0, 0), 0);
  EXPECT_FLOAT_EQ(out.radiance.at<cv::Vec3f>(0, 1)[0], static_cast<float>(lin(255, 1.0)));  // shortest
  EXPECT_EQ(out.clipped.at<std::uint8_t>(0, 1), 255);
  EXPECT_FLOAT_EQ(out.radiance.at<cv::Vec3f>(0, 2)[2], static_cast<float>(lin(0, 2.0)));  // longest
  EXPECT_EQ(out.clipped.at<std::uint8_t>(0, 2), 0);
  const cv::Vec3f p3 = out.radiance.at<cv::Vec3f>(0, 3);
  EXPECT_FLOAT_EQ(p3[0], static_cast<float>(lin(40, 1.0)));
  EXPECT_FLOAT_EQ(p3[1], static_cast<float>(lin(9, 2.0)));
  EXPECT_FLOAT_EQ(p3[2], static_cast<float>((40 * lin(40, 1.0) + 80 * lin(80, 2.0)) / 120.0));
  EXPECT_EQ(out.clipped.at<std::uint8_t>(0, 3), 0);

  // One frame is a bracket of one: linearise with fallbacks.
  const RadianceFrame single = merge_bracket(std::vector<cv::Mat>{shortf}, std::vector<Exposure>{{1.0, 1.0}}, curve);
  EXPECT_FLOAT_EQ(single.radiance.at<cv::Vec3f>(0, 0)[0], static_cast<float>(lin(100, 1.0)));
  EXPECT_EQ(single.clipped.at<std::uint8_t>(0, 1), 255);
}

TEST(Radiometry, MergesSixteenBitBrackets) {
  cv::Mat a(2, 2, CV_16UC3, cv::Scalar::all(30000));
  cv::Mat b(2, 2, CV_16UC3, cv::Scalar::all(60000));
  const RadianceFrame out = merge_bracket(std::vector<cv::Mat>{a, b}, std::vector<Exposure>{{1.0, 1.0}, {2.0, 1.0}},
                                          ResponseCurve::linear(16));
  const double expected = (30000.0 * (30000.0 / 65535.0) + 5535.0 * (60000.0 / 65535.0 / 2.0)) / 35535.0;
  EXPECT_NEAR(out.radiance.at<cv::Vec3f>(1, 1)[2], expected, 1e-6);
}

TEST(Radiometry, MergesAMegapixelBracket) {
  // Speed is measured, not asserted: the time goes to the test's XML properties.
  cv::Mat base(1024, 1024, CV_8UC3);
  cv::randu(base, cv::Scalar::all(0), cv::Scalar::all(256));
  std::vector<cv::Mat> frames = {base, base.clone(), base.clone()};
  const std::vector<Exposure> exposures = {{0.001, 1.0}, {0.004, 1.0}, {0.016, 1.0}};
  const auto start = std::chrono::steady_clock::now();
  const RadianceFrame out = merge_bracket(frames, exposures, ResponseCurve::srgb(8));
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(out.radiance.size(), cv::Size(1024, 1024));
  RecordProperty("merge_1024x1024x3_ms", std::to_string(ms));
  std::printf("merge_bracket 1024x1024, 3 frames: %.1f ms\n", ms);
}

TEST(Radiometry, MergeRejectsMismatchedFrames) {
  const cv::Mat a(4, 4, CV_8UC3, cv::Scalar::all(100));
  const ResponseCurve srgb = ResponseCurve::srgb(8);
  const std::vector<Exposure> two = {{1.0, 1.0}, {2.0, 1.0}};
  expect_input_error([&] { (void)merge_bracket(std::vector<cv::Mat>{}, std::vector<Exposure>{}, srgb); }, {"no frames"});
  expect_input_error([&] { (void)merge_bracket(std::vector<cv::Mat>{a, cv::Mat(5, 4, CV_8UC3)}, two, srgb); },
                     {"frame 1", "size or type"});
  expect_input_error([&] { (void)merge_bracket(std::vector<cv::Mat>{a, cv::Mat(4, 4, CV_16UC3)}, two, srgb); },
                     {"frame 1", "size or type"});
  expect_input_error([&] { (void)merge_bracket(std::vector<cv::Mat>{a, a}, std::vector<Exposure>{{1.0, 1.0}}, srgb); },
                     {"1 exposures for 2 frames"});
  expect_input_error([&] { (void)merge_bracket(std::vector<cv::Mat>{a, cv::Mat()}, two, srgb); }, {"frame 1", "empty"});
  const cv::Mat f(4, 4, CV_32FC3, cv::Scalar::all(1.0));
  expect_input_error([&] { (void)merge_bracket(std::vector<cv::Mat>{f, f}, two, srgb); }, {"float"});
  expect_input_error([&] { (void)merge_bracket(std::vector<cv::Mat>{a, a}, two, ResponseCurve::srgb(16)); }, {"bits"});
  expect_input_error([&] { (void)merge_bracket(std::vector<cv::Mat>{a, a}, std::vector<Exposure>{{1.0, 1.0}, {-2.0, 1.0}}, srgb); },
                     {"frame 1", "time_s"});
}

// ---------------------------------------------------------------------------------------------
// Calibration

double gamma_encode(double linear) { return std::pow(linear, 1.0 / 2.2); }

// A smooth scene (log radiance over 10^2 across the image, a different tint per channel).
cv::Mat smooth_scene(int size) {
  cv::Mat radiance(size, size, CV_32FC3);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const double u = (x + y) / (2.0 * (size - 1));
      const double level = std::pow(10.0, -2.0 * u) * (1.0 + 0.2 * std::sin(0.05 * x) * std::cos(0.07 * y));
      radiance.at<cv::Vec3f>(y, x) = cv::Vec3f(static_cast<float>(0.7 * level), static_cast<float>(0.9 * level),
                                               static_cast<float>(level));
    }
  }
  return radiance;
}

TEST(Radiometry, CalibratesAGammaCurveFromABracket) {
  const cv::Mat truth = smooth_scene(160);
  std::vector<Exposure> exposures;
  std::vector<cv::Mat> frames;
  for (int k = 0; k < 6; ++k) {
    exposures.push_back({0.25 * std::pow(2.0, k), 1.0});
    frames.push_back(render_8bit(truth, exposures.back().time_s, gamma_encode));
  }
  const ResponseCurve curve = calibrate_response(frames, exposures);
  ASSERT_EQ(curve.bits, 8);
  const float mid = ResponseCurve::srgb(8).bgr[0][128];
  double worst_shape = 0.0;
  for (std::size_t c = 0; c < 3; ++c) {
    ASSERT_EQ(curve.bgr[c].size(), 256U);
    EXPECT_FLOAT_EQ(curve.bgr[c][128], mid);
    for (std::size_t z = 1; z < 256; ++z) {
      ASSERT_TRUE(std::isfinite(curve.bgr[c][z]));
      EXPECT_GE(curve.bgr[c][z], curve.bgr[c][z - 1]) << "channel " << c << " code " << z;
    }
    // Shape against the true gamma 2.2, relative to code 128, over the well-exposed codes.
    for (std::size_t z = 24; z <= 240; ++z) {
      const double expected = std::pow(static_cast<double>(z) / 128.0, 2.2);
      const double got = curve.bgr[c][z] / mid;
      worst_shape = std::max(worst_shape, std::abs(got - expected) / expected);
    }
  }
  EXPECT_LT(worst_shape, 0.05);
  RecordProperty("worst_curve_shape_error", std::to_string(worst_shape));

  // Merging with the calibrated curve recovers the radiance up to one overall scale.
  const RadianceFrame merged = merge_bracket(frames, exposures, curve);
  std::vector<double> ratios;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      for (int c = 0; c < 3; ++c) ratios.push_back(merged.radiance.at<cv::Vec3f>(y, x)[c] / truth.at<cv::Vec3f>(y, x)[c]);
    }
  }
  std::vector<double> sorted = ratios;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  const double scale = sorted[sorted.size() / 2];
  EXPECT_NEAR(scale, mid / std::pow(128.0 / 255.0, 2.2), 0.05);  // the pin at code 128
  double worst = 0.0;
  for (double r : ratios) worst = std::max(worst, std::abs(r / scale - 1.0));
  EXPECT_LT(worst, 0.04);
  RecordProperty("worst_merge_error", std::to_string(worst));
}

TEST(Radiometry, CalibrationRejectsBadBrackets) {
  const cv::Mat a(32, 32, CV_8UC3, cv::Scalar::all(100));
  const std::vector<Exposure> two = {{1.0, 1.0}, {2.0, 1.0}};
  expect_input_error([&] { (void)calibrate_response(std::vector<cv::Mat>{a}, std::vector<Exposure>{{1.0, 1.0}}); },
                     {"at least 2"});
  expect_input_error([&] { (void)calibrate_response(std::vector<cv::Mat>{a, cv::Mat(32, 40, CV_8UC3)}, two); },
                     {"frame 1", "size or type"});
  expect_input_error([&] { (void)calibrate_response(std::vector<cv::Mat>{a, cv::Mat(32, 32, CV_8UC1)}, two); },
                     {"frame 1", "size or type"});
  expect_input_error([&] {
    (void)calibrate_response(std::vector<cv::Mat>{cv::Mat(32, 32, CV_16UC3), cv::Mat(32, 32, CV_16UC3)}, two);
  }, {"8-bit"});
  expect_input_error([&] { (void)calibrate_response(std::vector<cv::Mat>{a, a}, std::vector<Exposure>{{1.0, 2.0}, {2.0, 1.0}}); },
                     {"distinct"});
  expect_input_error([&] { (void)calibrate_response(std::vector<cv::Mat>{a, a}, std::vector<Exposure>{{1.0, 1.0}}); },
                     {"exposures"});
  expect_input_error([&] {
    (void)calibrate_response(std::vector<cv::Mat>{cv::Mat(4, 4, CV_8UC3), cv::Mat(4, 4, CV_8UC3)}, two);
  }, {"16x16"});
}

// ---------------------------------------------------------------------------------------------
// Response YAML

TEST(Radiometry, ResponseRoundTripsThroughYaml) {
  TempDir dir;
  ResponseCurve curve = ResponseCurve::srgb(8);
  curve.bgr[0][200] = std::nextafter(curve.bgr[0][200], 1.0F);  // exactness, not just closeness
  save_response(curve, dir.file("response.yaml"));
  const ResponseCurve back = load_response(dir.file("response.yaml"));
  EXPECT_EQ(back.bits, 8);
  EXPECT_EQ(back.bgr, curve.bgr);

  const ResponseCurve wide = ResponseCurve::srgb(16);
  save_response(wide, dir.file("wide.yaml"));
  EXPECT_EQ(load_response(dir.file("wide.yaml")).bgr, wide.bgr);

  ResponseCurve broken = ResponseCurve::srgb(8);
  broken.bgr[2].pop_back();
  expect_input_error([&] { save_response(broken, dir.file("broken.yaml")); }, {"broken.yaml", "'r'"});
  EXPECT_FALSE(fs::exists(dir.file("broken.yaml")));
}

std::string curve_yaml(int bits, const std::string& b, const std::string& g, const std::string& r) {
  return "bits: " + std::to_string(bits) + "\nb: " + b + "\ng: " + g + "\nr: " + r + "\n";
}

std::string ramp(int n, int break_at = -1, const std::string& bad = "") {
  std::string s = "[";
  for (int z = 0; z < n; ++z) {
    if (z > 0) s += ", ";
    s += z == break_at ? bad : std::to_string(z);
  }
  return s + "]";
}

TEST(Radiometry, LoadResponseNamesFileAndField) {
  TempDir dir;
  const std::string good = ramp(256);
  EXPECT_NO_THROW(load_response(dir.write("ok.yaml", curve_yaml(8, good, good, good))));
  expect_input_error([&] { (void)load_response(dir.file("missing.yaml")); }, {"missing.yaml"});
  expect_input_error([&] { (void)load_response(dir.write("syntax.yaml", "bits: [8\nb: ]")); }, {"syntax.yaml", "YAML"});
  expect_input_error([&] { (void)load_response(dir.write("list.yaml", "- 1\n- 2\n")); }, {"list.yaml", "map"});
  expect_input_error([&] { (void)load_response(dir.write("nobits.yaml", "b: []\ng: []\nr: []\n")); },
                     {"nobits.yaml", "'bits'", "missing"});
  expect_input_error([&] { (void)load_response(dir.write("bits12.yaml", curve_yaml(12, good, good, good))); },
                     {"bits12.yaml:1:", "'bits'", "8 or 16"});
  expect_input_error([&] { (void)load_response(dir.write("short.yaml", curve_yaml(8, good, ramp(255), good))); },
                     {"short.yaml:3:", "'g'", "255 values", "256"});
  expect_input_error([&] { (void)load_response(dir.write("wrongbits.yaml", curve_yaml(16, good, good, good))); },
                     {"wrongbits.yaml:2:", "'b'", "65536"});
  expect_input_error([&] { (void)load_response(dir.write("down.yaml", curve_yaml(8, good, good, ramp(256, 100, "3")))); },
                     {"down.yaml:4:", "'r[100]'", "monotonic"});
  expect_input_error([&] { (void)load_response(dir.write("nan.yaml", curve_yaml(8, ramp(256, 7, ".nan"), good, good))); },
                     {"nan.yaml:2:", "'b[7]'", "finite"});
  expect_input_error([&] { (void)load_response(dir.write("inf.yaml", curve_yaml(8, good, good, ramp(256, 255, ".inf")))); },
                     {"inf.yaml", "'r[255]'", "finite"});
  expect_input_error([&] { (void)load_response(dir.write("word.yaml", curve_yaml(8, good, ramp(256, 3, "three"), good))); },
                     {"word.yaml", "'g[3]'", "not a number"});
  std::string zeros = "[0";
  for (int z = 1; z < 256; ++z) zeros += ", 0";
  zeros += "]";
  expect_input_error([&] { (void)load_response(dir.write("flat.yaml", curve_yaml(8, good, good, zeros))); },
                     {"flat.yaml", "'r'", "flat"});
  expect_input_error([&] { (void)load_response(dir.write("extra.yaml", curve_yaml(8, good, good, good) + "gamma: 2.2\n")); },
                     {"extra.yaml:5:", "'gamma'", "unknown"});
  expect_input_error([&] { (void)load_response(dir.write("nog.yaml", "bits: 8\nb: " + good + "\nr: " + good + "\n")); },
                     {"nog.yaml", "'g'", "missing"});
  expect_input_error([&] { (void)load_response(dir.write("scalar.yaml", "bits: 8\nb: 1\ng: 1\nr: 1\n")); },
                     {"scalar.yaml:2:", "'b'", "list"});
}

// skylit-shade and skylit-live look a response up here; only one of the two checked the bit
// depth of a file's curve before, the other failed later with a message that named no file.
TEST(Radiometry, ResponseForNamesTheSettingAndChecksTheBitDepth) {
  TempDir dir;
  EXPECT_EQ(response_for("srgb", 16).bgr, ResponseCurve::srgb(16).bgr);
  EXPECT_EQ(response_for("linear", 8).bgr, ResponseCurve::linear(8).bgr);
  const std::string good = ramp(256);
  const fs::path file = dir.write("camera.yaml", curve_yaml(8, good, good, good));
  EXPECT_EQ(response_for(file.string(), 8).bgr, load_response(file).bgr);
  // A 16-bit frame with a curve for 8-bit codes: the file, its field and line, both depths, the fix.
  expect_input_error([&] { (void)response_for(file.string(), 16); },
                     {file.string() + ":1:", "field 'bits'", "8-bit", "16-bit", "Fix: calibrate a response", "srgb"});
  expect_input_error([&] { (void)response_for((dir.path() / "missing.yaml").string(), 8); }, {"missing.yaml"});
}

}  // namespace
}  // namespace skylit::sky
