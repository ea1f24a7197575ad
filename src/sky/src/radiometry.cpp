#include "skylit/sky/radiometry.hpp"

#include <algorithm>
#include <initializer_list>
#include <charconv>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <memory>
#include <numeric>
#include <string>
#include <string_view>
#include <system_error>

#include <Imath/ImathBox.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <libexif/exif-data.h>
#include <libexif/exif-loader.h>
#include <libexif/exif-utils.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>
#include <yaml-cpp/yaml.h>

#include "skylit/base/error.hpp"
#include "skylit/base/exr_header.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/yaml_reader.hpp"
#include "skylit/base/yaml_writer.hpp"
#include "skylit/sky/srgb.hpp"

namespace skylit::sky {
namespace {

namespace fs = std::filesystem;

// Images beyond this are not sky frames; refusing them keeps a corrupt header from asking for
// terabytes.
constexpr long long kMaxImageSide = 1 << 16;
constexpr long long kMaxImagePixels = 1LL << 28;
constexpr int kMidCode8 = 128;                 // Debevec pins g(128) = 0; we pin it to sRGB's value
constexpr int kDebevecSamples = 150;           // pixels sampled on a grid (OpenCV's default is 70)
constexpr float kDebevecLambda = 10.0F;        // OpenCV's default smoothness
constexpr const char* kResponseFix = "re-run the response calibration, or use the sRGB curve";

int code_count(int bits) { return 1 << bits; }

bool valid_bits(int bits) { return bits == 8 || bits == 16; }

// ---------------------------------------------------------------------------------------------
// Reading images

[[noreturn]] void unreadable(const fs::path& file, const std::string& problem, const std::string& fix) {
  throw InputError(input_message(file, -1, -1, "", problem, fix));
}

bool has_exr_magic(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::array<unsigned char, 4> magic{};
  in.read(reinterpret_cast<char*>(magic.data()), magic.size());
  return in.gcount() == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01;
}

cv::Mat read_exr(const fs::path& file) {
  const std::string fix = "re-export the image as OpenEXR with R, G, B (or Y) channels";
  try {
    check_exr_header(file, {kMaxImageSide, 1 << 20}, fix.c_str());
    Imf::InputFile in(file.c_str());
    const Imf::Header& header = in.header();
    const Imath::Box2i window = header.dataWindow();
    const long long width = static_cast<long long>(window.max.x) - window.min.x + 1;
    const long long height = static_cast<long long>(window.max.y) - window.min.y + 1;
    if (window.isEmpty() || width <= 0 || height <= 0) unreadable(file, "the OpenEXR image is empty", fix);
    if (width > kMaxImageSide || height > kMaxImageSide || width * height > kMaxImagePixels) {
      unreadable(file, "the OpenEXR image is " + std::to_string(width) + "x" + std::to_string(height) +
                           ", too large for a sky frame", "downscale the image");
    }
    const Imf::ChannelList& channels = header.channels();
    const bool rgb = channels.findChannel("R") && channels.findChannel("G") && channels.findChannel("B");
    const bool luminance = channels.findChannel("Y") != nullptr;
    if (!rgb && !luminance) {
      std::string found;
      for (auto it = channels.begin(); it != channels.end(); ++it) found += std::string(found.empty() ? "" : ", ") + it.name();
      unreadable(file, "the OpenEXR image has no R, G, B or Y channels (found: " +
                           (found.empty() ? std::string("none") : found) + ")", fix);
    }
    for (auto it = channels.begin(); it != channels.end(); ++it) {
      if (it.channel().xSampling != 1 || it.channel().ySampling != 1) {
        unreadable(file, std::string("the OpenEXR channel '") + it.name() + "' is subsampled", fix);
      }
    }
    const int rows = static_cast<int>(height);
    const int cols = static_cast<int>(width);
    // OpenEXR converts half (and uint) channels to float as it fills the slices.
    Imf::FrameBuffer buffer;
    cv::Mat image;
    if (rgb) {
      image.create(rows, cols, CV_32FC3);
      const std::array<const char*, 3> bgr{"B", "G", "R"};
      for (std::size_t c = 0; c < bgr.size(); ++c) {
        buffer.insert(bgr[c], Imf::Slice::Make(Imf::FLOAT, image.ptr<float>() + c, window, 3 * sizeof(float),
                                               image.step[0]));
      }
    } else {
      image.create(rows, cols, CV_32FC1);
      buffer.insert("Y", Imf::Slice::Make(Imf::FLOAT, image.ptr<float>(), window, sizeof(float), image.step[0]));
    }
    in.setFrameBuffer(buffer);
    in.readPixels(window.min.y, window.max.y);
    if (!rgb) cv::cvtColor(image, image, cv::COLOR_GRAY2BGR);
    return image;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    unreadable(file, std::string("not a readable OpenEXR image (") + e.what() + ")", fix);
  }
}

// 1, 3 or 4 channels of a supported depth → 3-channel BGR of the same depth (float kept float).
cv::Mat to_bgr(cv::Mat image, const fs::path& file, const std::string& fix) {
  const int depth = image.depth();
  if (depth == CV_16F || depth == CV_64F) {
    image.convertTo(image, CV_32F);
  } else if (depth != CV_8U && depth != CV_16U && depth != CV_32F) {
    unreadable(file, "unsupported pixel type (signed or 32-bit integer samples)", fix);
  }
  switch (image.channels()) {
    case 3:
      return image;
    case 1: {
      cv::Mat bgr;
      cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
      return bgr;
    }
    case 4: {
      cv::Mat bgr;
      cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
      return bgr;
    }
    default:
      unreadable(file, "unsupported channel count " + std::to_string(image.channels()) + " (need 1, 3 or 4)",
                 fix);
  }
}

// ---------------------------------------------------------------------------------------------
// EXIF

struct ExifLoaderDeleter {
  void operator()(ExifLoader* loader) const { exif_loader_unref(loader); }
};
struct ExifDataDeleter {
  void operator()(ExifData* data) const { exif_data_unref(data); }
};

std::optional<double> exif_number(ExifData* data, ExifTag tag) {
  ExifEntry* entry = exif_data_get_entry(data, tag);
  if (entry == nullptr || entry->data == nullptr || entry->components < 1) return std::nullopt;
  const ExifByteOrder order = exif_data_get_byte_order(data);
  const std::size_t size = entry->size;
  switch (entry->format) {
    case EXIF_FORMAT_RATIONAL: {
      if (size < 8) return std::nullopt;
      const ExifRational r = exif_get_rational(entry->data, order);
      if (r.denominator == 0) return std::nullopt;
      return static_cast<double>(r.numerator) / static_cast<double>(r.denominator);
    }
    case EXIF_FORMAT_SRATIONAL: {
      if (size < 8) return std::nullopt;
      const ExifSRational r = exif_get_srational(entry->data, order);
      if (r.denominator == 0) return std::nullopt;
      return static_cast<double>(r.numerator) / static_cast<double>(r.denominator);
    }
    case EXIF_FORMAT_SHORT:
      if (size < 2) return std::nullopt;
      return static_cast<double>(exif_get_short(entry->data, order));
    case EXIF_FORMAT_LONG:
      if (size < 4) return std::nullopt;
      return static_cast<double>(exif_get_long(entry->data, order));
    default:
      return std::nullopt;
  }
}

// ---------------------------------------------------------------------------------------------
// Response curves

std::string channel_name(std::size_t c) {
  static constexpr std::array<const char*, 3> kNames{"b", "g", "r"};
  return kNames[c];
}

void check_curve(const ResponseCurve& curve, const std::string& what) {
  if (!valid_bits(curve.bits)) {
    throw InputError(input_message({}, -1, -1, "bits", what + ": the response curve has bits = " +
                                                           std::to_string(curve.bits),
                                   "use an 8- or 16-bit response curve"));
  }
  const auto n = static_cast<std::size_t>(code_count(curve.bits));
  for (std::size_t c = 0; c < 3; ++c) {
    if (curve.bgr[c].size() != n) {
      throw InputError(input_message({}, -1, -1, channel_name(c),
                                     what + ": the response curve has " + std::to_string(curve.bgr[c].size()) +
                                         " entries for " + std::to_string(curve.bits) + "-bit codes (need " +
                                         std::to_string(n) + ")",
                                     kResponseFix));
    }
  }
}

void check_exposure(const Exposure& exposure, const std::string& what) {
  const auto bad = [](double v) { return !std::isfinite(v) || v <= 0.0; };
  if (bad(exposure.time_s)) {
    throw InputError(input_message({}, -1, -1, "time_s", what + ": exposure time " + std::to_string(exposure.time_s) +
                                                             " s is not a positive number",
                                   "pass the frame's exposure time in seconds (EXIF ExposureTime)"));
  }
  if (bad(exposure.gain) || bad(exposure.time_s * exposure.gain)) {
    throw InputError(input_message({}, -1, -1, "gain", what + ": gain " + std::to_string(exposure.gain) +
                                                           " is not a positive number",
                                   "pass the linear gain (ISO / 100), or 1"));
  }
}

void check_options(const LinearisationOptions& options, const std::string& what) {
  if (!(options.clip_fraction > 0.0 && options.clip_fraction <= 1.0)) {
    throw InputError(input_message({}, -1, -1, "clip_fraction",
                                   what + ": clip_fraction " + std::to_string(options.clip_fraction) +
                                       " is outside (0, 1]",
                                   "use a fraction of the top code such as 0.98"));
  }
}

// Depth of a frame → the bits of the response it needs (0 for float).
int frame_bits(const cv::Mat& frame) {
  switch (frame.depth()) {
    case CV_8U: return 8;
    case CV_16U: return 16;
    default: return 0;
  }
}

// A frame as 3-channel BGR for the linearisation loops (no copy when it already is).
cv::Mat frame_as_bgr(const cv::Mat& frame, const std::string& what) {
  if (frame.empty()) {
    throw InputError(input_message({}, -1, -1, "frame", what + ": the frame is empty",
                                   "pass a decoded image (check that the file was read)"));
  }
  const int depth = frame.depth();
  if (depth != CV_8U && depth != CV_16U && depth != CV_32F && depth != CV_16F && depth != CV_64F) {
    throw InputError(input_message({}, -1, -1, "frame", what + ": unsupported pixel type (signed integers)",
                                   "pass 8/16-bit unsigned or float frames"));
  }
  if (frame.channels() != 1 && frame.channels() != 3 && frame.channels() != 4) {
    throw InputError(input_message({}, -1, -1, "frame",
                                   what + ": " + std::to_string(frame.channels()) + " channels (need 1, 3 or 4)",
                                   "pass a gray, BGR or BGRA frame"));
  }
  return to_bgr(frame, {}, {});
}

// The lowest code that counts as clipped.
int clip_code(int max_code, double clip_fraction) {
  return static_cast<int>(std::ceil(clip_fraction * max_code - 1e-9));
}

template <typename Code>
void linearise_codes(const cv::Mat& bgr, const ResponseCurve& response, double scale, int clip_from,
                     RadianceFrame& out) {
  std::array<std::vector<float>, 3> lut;
  for (std::size_t c = 0; c < 3; ++c) {
    lut[c].resize(response.bgr[c].size());
    for (std::size_t z = 0; z < lut[c].size(); ++z) lut[c][z] = static_cast<float>(response.bgr[c][z] * scale);
  }
  out.radiance.create(bgr.size(), CV_32FC3);
  out.clipped.create(bgr.size(), CV_8U);
  for (int y = 0; y < bgr.rows; ++y) {
    const Code* in = bgr.ptr<Code>(y);
    float* radiance = out.radiance.ptr<float>(y);
    std::uint8_t* clipped = out.clipped.ptr<std::uint8_t>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      bool any = false;
      for (int c = 0; c < 3; ++c) {
        const Code z = in[3 * x + c];
        radiance[3 * x + c] = lut[static_cast<std::size_t>(c)][z];
        any = any || z >= clip_from;
      }
      clipped[x] = any ? 255 : 0;
    }
  }
}

template <typename Code>
void merge_codes(const std::vector<cv::Mat>& frames, const std::vector<double>& exposures,
                 const ResponseCurve& response, int clip_from, RadianceFrame& out) {
  const std::size_t n = frames.size();
  const std::size_t codes = response.bgr[0].size();
  const int max_code = static_cast<int>(codes) - 1;
  // Tables per code: hat weight (0 for black and clipped codes), clipped flag; per frame and
  // channel: linear value already divided by the exposure.
  std::vector<float> weight(codes);
  std::vector<std::uint8_t> is_clipped(codes);
  for (std::size_t z = 0; z < codes; ++z) {
    const int code = static_cast<int>(z);
    is_clipped[z] = code >= clip_from ? 1 : 0;
    weight[z] = (code == 0 || is_clipped[z] != 0) ? 0.0F : static_cast<float>(std::min(code, max_code - code));
  }
  std::vector<std::array<std::vector<float>, 3>> lut(n);
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t c = 0; c < 3; ++c) {
      lut[k][c].resize(codes);
      for (std::size_t z = 0; z < codes; ++z) {
        lut[k][c][z] = static_cast<float>(response.bgr[c][z] / exposures[k]);
      }
    }
  }
  const cv::Size size = frames[0].size();
  out.radiance.create(size, CV_32FC3);
  out.clipped.create(size, CV_8U);
  std::vector<const Code*> rows(n);
  for (int y = 0; y < size.height; ++y) {
    for (std::size_t k = 0; k < n; ++k) rows[k] = frames[k].ptr<Code>(y);
    float* radiance = out.radiance.ptr<float>(y);
    std::uint8_t* clipped = out.clipped.ptr<std::uint8_t>(y);
    for (int x = 0; x < size.width; ++x) {
      bool pixel_clipped = false;
      for (int c = 0; c < 3; ++c) {
        const auto i = static_cast<std::size_t>(3 * x + c);
        const auto cc = static_cast<std::size_t>(c);
        float sum = 0.0F;
        float total = 0.0F;
        std::size_t longest_unclipped = n;  // frames run from the shortest exposure to the longest
        for (std::size_t k = 0; k < n; ++k) {
          const Code z = rows[k][i];
          sum += weight[z] * lut[k][cc][z];
          total += weight[z];
          if (is_clipped[z] == 0) longest_unclipped = k;
        }
        float value;
        if (total > 0.0F) {
          value = sum / total;
        } else if (longest_unclipped == n) {
          // Saturated in every frame: the shortest exposure is the best lower bound.
          value = lut[0][cc][rows[0][i]];
          pixel_clipped = true;
        } else {
          // Black (code 0) wherever not clipped: the longest such exposure resolves darkness best.
          value = lut[longest_unclipped][cc][rows[longest_unclipped][i]];
        }
        radiance[i] = value;
      }
      clipped[x] = pixel_clipped ? 255 : 0;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Response YAML

// A YAML number: decimal or exponent form, or YAML's .inf/.nan spellings (which the caller then
// rejects as not finite).
std::optional<double> parse_number(const std::string& text) {
  static const std::array<std::string_view, 9> kSpecial{".nan", ".NaN", ".NAN", ".inf", ".Inf", ".INF",
                                                        "+.inf", "-.inf", "-.Inf"};
  if (std::find(kSpecial.begin(), kSpecial.end(), text) != kSpecial.end()) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if (first != last && *first == '+') ++first;
  double value = 0.0;
  const auto [end, error] = std::from_chars(first, last, value);
  if (error != std::errc() || end != last || first == last) return std::nullopt;
  return value;
}

constexpr std::array<std::string_view, 4> kResponseKeys{"bits", "b", "g", "r"};

// Reads a response file; with `frame_bits`, refuses a curve for another bit depth at its 'bits'.
class ResponseParser {
 public:
  explicit ResponseParser(fs::path file) : r_(std::move(file)) {}

  ResponseCurve parse(std::optional<int> frame_bits = std::nullopt) const {
    const YAML::Node root = r_.load();
    if (!root.IsMap()) r_.fail(root, "", "a response curve file must be a map {bits, b, g, r}", kResponseFix);
    r_.check_keys(root, "", kResponseKeys);
    ResponseCurve curve;
    const YAML::Node bits = r_.require(root, "bits", "bits", "'bits: 8' (or 16)");
    curve.bits = static_cast<int>(r_.integer(bits, "bits", 8, 16, "write 8 or 16"));
    if (!valid_bits(curve.bits)) {
      r_.fail(bits, "bits", "bits = " + std::to_string(curve.bits) + " is not supported", "write 8 or 16");
    }
    if (frame_bits && curve.bits != *frame_bits) {
      r_.fail(bits, "bits",
              "the response curve is for " + std::to_string(curve.bits) + "-bit frames, the frames are " +
                  std::to_string(*frame_bits) + "-bit",
              "calibrate a response for this camera mode (skylit-sky response), or use the sRGB curve (srgb)");
    }
    const auto n = static_cast<std::size_t>(code_count(curve.bits));
    for (std::size_t c = 0; c < 3; ++c) {
      const std::string field = channel_name(c);
      const YAML::Node list =
          r_.require(root, field, field, "one value per code, " + std::to_string(n) + " in all; or " + kResponseFix);
      if (!list.IsSequence()) r_.fail(list, field, "not a list of numbers", kResponseFix);
      if (list.size() != n) {
        r_.fail(list, field,
                std::to_string(list.size()) + " values for " + std::to_string(curve.bits) + "-bit codes (need " +
                    std::to_string(n) + ")",
                "write one value per code, or set bits to match the list");
      }
      std::vector<float>& values = curve.bgr[c];
      values.resize(n);
      std::size_t z = 0;
      // Iterating (not indexing) and from_chars (not as<double>, a stringstream per value) keep
      // a 16-bit curve's 196608 values fast to load.
      for (auto it = list.begin(); it != list.end(); ++it, ++z) {
        const YAML::Node item = *it;
        const auto item_field = [&] { return field + "[" + std::to_string(z) + "]"; };
        if (!item.IsScalar()) r_.fail(item, item_field(), "not a number", kResponseFix);
        const std::string& scalar = item.Scalar();
        const std::optional<double> v = parse_number(scalar);
        if (!v) r_.fail(item, item_field(), "'" + scalar + "' is not a number", kResponseFix);
        if (!std::isfinite(*v) || *v < 0.0 || *v > std::numeric_limits<float>::max()) {
          r_.fail(item, item_field(), "value " + scalar + " is not a finite non-negative number", kResponseFix);
        }
        values[z] = static_cast<float>(*v);
        if (z > 0 && values[z] < values[z - 1]) {
          r_.fail(item, item_field(),
                  "the curve decreases (" + std::to_string(values[z]) + " after " + std::to_string(values[z - 1]) +
                      "); a response curve is monotonic",
                  kResponseFix);
        }
      }
      if (!(values.back() > values.front())) {
        r_.fail(list, field, "the curve is flat", kResponseFix);
      }
    }
    return curve;
  }

 private:
  YamlReader r_;
};

}  // namespace

// -----------------------------------------------------------------------------------------------

ResponseCurve ResponseCurve::srgb(int bits) {
  if (!valid_bits(bits)) {
    throw InputError(input_message({}, -1, -1, "bits", "no sRGB curve for " + std::to_string(bits) + "-bit codes",
                                   "use 8 or 16 bits"));
  }
  ResponseCurve curve;
  curve.bits = bits;
  const int n = code_count(bits);
  std::vector<float> values(static_cast<std::size_t>(n));
  for (int z = 0; z < n; ++z) {
    values[static_cast<std::size_t>(z)] = static_cast<float>(srgb_decode(static_cast<double>(z) / (n - 1)));
  }
  curve.bgr = {values, values, values};
  return curve;
}

ResponseCurve ResponseCurve::linear(int bits) {
  if (!valid_bits(bits)) {
    throw InputError(input_message({}, -1, -1, "bits", "no linear curve for " + std::to_string(bits) + "-bit codes",
                                   "use 8 or 16 bits"));
  }
  ResponseCurve curve;
  curve.bits = bits;
  const int n = code_count(bits);
  std::vector<float> values(static_cast<std::size_t>(n));
  for (int z = 0; z < n; ++z) values[static_cast<std::size_t>(z)] = static_cast<float>(static_cast<double>(z) / (n - 1));
  curve.bgr = {values, values, values};
  return curve;
}

ResponseCurve calibrate_response(std::span<const cv::Mat> frames, std::span<const Exposure> exposures) {
  const std::string what = "calibrate_response";
  if (frames.size() < 2) {
    throw InputError(input_message({}, -1, -1, "frames", what + ": " + std::to_string(frames.size()) +
                                                             " frame(s); a bracket needs at least 2",
                                   "capture the same scene at 2 or more exposure times"));
  }
  if (exposures.size() != frames.size()) {
    throw InputError(input_message({}, -1, -1, "exposures",
                                   what + ": " + std::to_string(exposures.size()) + " exposures for " +
                                       std::to_string(frames.size()) + " frames",
                                   "pass one exposure per frame"));
  }
  std::vector<cv::Mat> images;
  std::vector<float> times;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const std::string where = what + ", frame " + std::to_string(k);
    if (frames[k].empty() || frames[k].depth() != CV_8U) {
      throw InputError(input_message({}, -1, -1, "frames", where + ": not an 8-bit image",
                                     "calibrate with 8-bit frames (JPEG or 8-bit PNG) straight from the camera"));
    }
    if (frames[k].size() != frames[0].size() || frames[k].type() != frames[0].type()) {
      throw InputError(input_message({}, -1, -1, "frames", where + ": size or type differs from frame 0",
                                     "use frames of one camera mode, all the same size"));
    }
    if (frames[k].cols < 16 || frames[k].rows < 16) {
      throw InputError(input_message({}, -1, -1, "frames", where + ": smaller than 16x16 pixels",
                                     "use full-size frames"));
    }
    check_exposure(exposures[k], where);
    images.push_back(frame_as_bgr(frames[k], where));
    times.push_back(static_cast<float>(exposures[k].time_s * exposures[k].gain));
  }
  std::vector<float> sorted = times;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t k = 1; k < sorted.size(); ++k) {
    if (!(sorted[k] > sorted[k - 1] * 1.001F)) {
      throw InputError(input_message({}, -1, -1, "exposures",
                                     what + ": two frames share the exposure time x gain " + std::to_string(sorted[k]),
                                     "bracket with distinct exposure times (e.g. steps of 1 to 2 stops)"));
    }
  }
  cv::Mat response;
  try {
    cv::createCalibrateDebevec(kDebevecSamples, kDebevecLambda, false)->process(images, response, times);
  } catch (const cv::Exception& e) {
    throw InputError(input_message({}, -1, -1, "frames", what + ": calibration failed (" + e.msg + ")",
                                   "use a bracket of a static scene with a wide range of brightness"));
  }
  CV_Assert(response.rows * response.cols == 256 && response.type() == CV_32FC3);

  // OpenCV returns exp(g): exposure per code, scale pinned by g(128) = 0 in each channel. Make it
  // monotonic outward from the pinned code (the ends have no data, only smoothness) and rescale
  // so that code 128 maps where sRGB maps it: a calibrated curve is then a drop-in for srgb(8).
  const float mid = ResponseCurve::srgb(8).bgr[0][kMidCode8];
  ResponseCurve curve;
  curve.bits = 8;
  for (int c = 0; c < 3; ++c) {
    std::vector<float>& values = curve.bgr[static_cast<std::size_t>(c)];
    values.resize(256);
    for (int z = 0; z < 256; ++z) values[static_cast<std::size_t>(z)] = response.at<cv::Vec3f>(z)[c];
    float pin = values[kMidCode8];
    if (!std::isfinite(pin) || pin <= 0.0F) pin = 1.0F;
    for (float& v : values) {
      v = std::isfinite(v) && v > 0.0F ? v / pin * mid : 0.0F;
    }
    values[kMidCode8] = mid;
    for (int z = kMidCode8 + 1; z < 256; ++z) {
      auto& v = values[static_cast<std::size_t>(z)];
      v = std::max(v, values[static_cast<std::size_t>(z - 1)]);
    }
    for (int z = kMidCode8 - 1; z >= 0; --z) {
      auto& v = values[static_cast<std::size_t>(z)];
      v = std::min(v, values[static_cast<std::size_t>(z + 1)]);
    }
  }
  return curve;
}

void save_response(const ResponseCurve& curve, const fs::path& file) {
  check_curve(curve, file.string());
  // Refuse to write what load_response would refuse to read.
  for (std::size_t c = 0; c < 3; ++c) {
    const std::vector<float>& values = curve.bgr[c];
    for (std::size_t z = 0; z < values.size(); ++z) {
      if (!std::isfinite(values[z]) || values[z] < 0.0F || (z > 0 && values[z] < values[z - 1])) {
        throw InputError(input_message(file, -1, -1, channel_name(c) + "[" + std::to_string(z) + "]",
                                       "the curve is not finite, non-negative and monotonic there",
                                       kResponseFix));
      }
    }
  }
  // Numbers only, nothing to quote: written directly rather than through YAML::Emitter (base/
  // yaml_writer.hpp), which takes 0.5 s over a 16-bit curve's 196608 values (this: 0.05 s) and
  // puts each list on one line, where this keeps 16 values a line.
  std::string text = "# skylit inverse camera response: relative exposure per code, B G R\n";
  text += "bits: " + std::to_string(curve.bits) + "\n";
  for (std::size_t c = 0; c < 3; ++c) {
    text += channel_name(c) + ": [";
    for (std::size_t z = 0; z < curve.bgr[c].size(); ++z) {
      if (z > 0) text += z % 16 == 0 ? ",\n    " : ", ";
      text += format_number(curve.bgr[c][z]);
    }
    text += "]\n";
  }
  write_file_atomic(file, text);
}

ResponseCurve load_response(const fs::path& file) { return ResponseParser(file).parse(); }

ResponseCurve response_for(const std::string& setting, int bits) {
  if (setting == "srgb") return ResponseCurve::srgb(bits);
  if (setting == "linear") return ResponseCurve::linear(bits);
  return ResponseParser(setting).parse(bits);
}

bool is_supported_image(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::array<unsigned char, 10> b{};
  in.read(reinterpret_cast<char*>(b.data()), b.size());
  const auto n = in.gcount();
  const auto starts = [&](std::initializer_list<unsigned char> magic) {
    return n >= static_cast<std::streamsize>(magic.size()) && std::equal(magic.begin(), magic.end(), b.begin());
  };
  return starts({0x76, 0x2f, 0x31, 0x01}) ||                      // OpenEXR
         starts({'#', '?'}) ||                                    // Radiance HDR (#?RADIANCE, #?RGBE)
         starts({0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a}) || // PNG
         starts({'I', 'I', 0x2a, 0x00}) || starts({'M', 'M', 0x00, 0x2a}) ||  // TIFF
         starts({0xff, 0xd8, 0xff});                              // JPEG
}

cv::Mat read_image(const fs::path& file, int flags) {
  if (!is_supported_image(file)) return {};
  try {
    return cv::imread(file.string(), flags);
  } catch (const cv::Exception&) {
    return {};
  }
}

cv::Mat read_sky_image(const fs::path& file) {
  const std::string fix = "pass an existing image (OpenEXR, Radiance HDR, PNG, TIFF, JPEG)";
  std::error_code ec;
  if (!fs::exists(file, ec)) unreadable(file, "the image file does not exist", fix);
  if (!fs::is_regular_file(file, ec)) unreadable(file, "not a regular file", fix);
  if (fs::file_size(file, ec) == 0 || ec) unreadable(file, "the image file is empty", fix);
  check_readable(file);  // imread says nothing of permissions
  if (has_exr_magic(file)) return read_exr(file);
  if (!is_supported_image(file)) unreadable(file, "not an image of a kind skylit reads", fix);
  cv::Mat image;
  try {
    image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    unreadable(file, "the image could not be decoded (" + e.msg + ")", fix);
  }
  if (image.empty()) unreadable(file, "the image could not be decoded (unknown format or corrupt)", fix);
  return to_bgr(image, file, "convert it to 8/16-bit or float gray, BGR or BGRA");
}

std::optional<Exposure> read_exposure_metadata(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) {
    unreadable(file, "the image file does not exist", "pass an existing image");
  }
  std::unique_ptr<ExifLoader, ExifLoaderDeleter> loader(exif_loader_new());
  if (!loader) return std::nullopt;
  exif_loader_write_file(loader.get(), file.c_str());
  const unsigned char* buffer = nullptr;
  unsigned int size = 0;
  exif_loader_get_buf(loader.get(), &buffer, &size);
  if (buffer == nullptr || size == 0) return std::nullopt;
  std::unique_ptr<ExifData, ExifDataDeleter> data(exif_data_new());
  if (!data) return std::nullopt;
  // Following the specification would make libexif invent default values for missing tags.
  exif_data_unset_option(data.get(), EXIF_DATA_OPTION_FOLLOW_SPECIFICATION);
  exif_data_load_data(data.get(), buffer, size);

  const std::optional<double> time = exif_number(data.get(), EXIF_TAG_EXPOSURE_TIME);
  if (!time || !std::isfinite(*time) || *time <= 0.0) return std::nullopt;
  Exposure exposure;
  exposure.time_s = *time;
  const std::optional<double> iso = exif_number(data.get(), EXIF_TAG_ISO_SPEED_RATINGS);
  if (iso && *iso > 0.0) exposure.gain = *iso / 100.0;
  return exposure;
}

void write_sky_exr(const fs::path& file, const cv::Mat& image, bool half_float) {
  if (image.empty() || image.depth() != CV_32F || (image.channels() != 3 && image.channels() != 1)) {
    throw InputError(input_message(file, -1, -1, "image", "not a CV_32FC3 or CV_32FC1 image",
                                   "pass linear radiance as 32-bit float BGR or gray"));
  }
  cv::Mat pixels;
  if (half_float) {
    image.convertTo(pixels, CV_16F);
  } else {
    pixels = image.isContinuous() ? image : image.clone();
  }
  const Imf::PixelType type = half_float ? Imf::HALF : Imf::FLOAT;
  const std::size_t sample = pixels.elemSize1();
  const std::size_t channels = static_cast<std::size_t>(pixels.channels());
  write_file_atomic_with(file, [&](const fs::path& tmp) {
    try {
      Imf::Header header(pixels.cols, pixels.rows);
      header.compression() = Imf::ZIP_COMPRESSION;
      Imf::FrameBuffer buffer;
      char* base = reinterpret_cast<char*>(pixels.data);
      if (channels == 3) {
        const std::array<const char*, 3> bgr{"B", "G", "R"};
        for (std::size_t c = 0; c < 3; ++c) {
          header.channels().insert(bgr[c], Imf::Channel(type));
          buffer.insert(bgr[c], Imf::Slice(type, base + c * sample, 3 * sample, pixels.step[0]));
        }
      } else {
        header.channels().insert("Y", Imf::Channel(type));
        buffer.insert("Y", Imf::Slice(type, base, sample, pixels.step[0]));
      }
      Imf::OutputFile out(tmp.c_str(), header);
      out.setFrameBuffer(buffer);
      out.writePixels(pixels.rows);
    } catch (const std::exception& e) {
      throw InputError(input_message(file, -1, -1, "", std::string("cannot write OpenEXR (") + e.what() + ")",
                                     "check the directory exists, is writable and has space"));
    }
  });
}

RadianceFrame linearise(const cv::Mat& frame, const ResponseCurve& response, const Exposure& exposure,
                        const LinearisationOptions& options) {
  const std::string what = "linearise";
  check_exposure(exposure, what);
  check_options(options, what);
  const cv::Mat bgr = frame_as_bgr(frame, what);
  const double scale = 1.0 / (exposure.time_s * exposure.gain);
  RadianceFrame out;
  const int bits = frame_bits(bgr);
  if (bits == 0) {
    // Float frames are radiance already; NaN, Inf and negatives pass through for the luminance
    // stage to judge.
    bgr.convertTo(out.radiance, CV_32F, scale);
    return out;
  }
  check_curve(response, what);
  if (response.bits != bits) {
    throw InputError(input_message({}, -1, -1, "bits",
                                   what + ": a " + std::to_string(bits) + "-bit frame with a " +
                                       std::to_string(response.bits) + "-bit response curve",
                                   "use a response curve of the frame's bit depth"));
  }
  const int clip_from = clip_code(code_count(bits) - 1, options.clip_fraction);
  if (bits == 8) {
    linearise_codes<std::uint8_t>(bgr, response, scale, clip_from, out);
  } else {
    linearise_codes<std::uint16_t>(bgr, response, scale, clip_from, out);
  }
  return out;
}

RadianceFrame merge_bracket(std::span<const cv::Mat> frames, std::span<const Exposure> exposures,
                            const ResponseCurve& response, const LinearisationOptions& options) {
  const std::string what = "merge_bracket";
  if (frames.empty()) {
    throw InputError(input_message({}, -1, -1, "frames", what + ": no frames", "pass the frames of a bracket"));
  }
  if (exposures.size() != frames.size()) {
    throw InputError(input_message({}, -1, -1, "exposures",
                                   what + ": " + std::to_string(exposures.size()) + " exposures for " +
                                       std::to_string(frames.size()) + " frames",
                                   "pass one exposure per frame"));
  }
  check_options(options, what);
  check_curve(response, what);
  // Frames sorted from the shortest exposure to the longest: the merge's fallbacks need the order.
  std::vector<std::size_t> order(frames.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const std::string where = what + ", frame " + std::to_string(k);
    check_exposure(exposures[k], where);
    if (frames[k].empty()) {
      throw InputError(input_message({}, -1, -1, "frames", where + ": the frame is empty",
                                     "pass decoded images (check that every file was read)"));
    }
    if (frames[k].size() != frames[0].size() || frames[k].type() != frames[0].type()) {
      throw InputError(input_message({}, -1, -1, "frames",
                                     where + ": size or type differs from frame 0 (" +
                                         std::to_string(frames[k].cols) + "x" + std::to_string(frames[k].rows) +
                                         " vs " + std::to_string(frames[0].cols) + "x" +
                                         std::to_string(frames[0].rows) + ")",
                                     "merge frames of one camera mode, all the same size and bit depth"));
    }
  }
  const int bits = frame_bits(frames[0]);
  if (bits == 0) {
    throw InputError(input_message({}, -1, -1, "frames", what + ": float frames are radiance already",
                                   "merge 8/16-bit frames, or linearise each float frame on its own"));
  }
  if (response.bits != bits) {
    throw InputError(input_message({}, -1, -1, "bits",
                                   what + ": " + std::to_string(bits) + "-bit frames with a " +
                                       std::to_string(response.bits) + "-bit response curve",
                                   "use a response curve of the frames' bit depth"));
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return exposures[a].time_s * exposures[a].gain < exposures[b].time_s * exposures[b].gain;
  });
  std::vector<cv::Mat> sorted;
  std::vector<double> scales;
  for (std::size_t k : order) {
    sorted.push_back(frame_as_bgr(frames[k], what));
    scales.push_back(exposures[k].time_s * exposures[k].gain);
  }
  const int clip_from = clip_code(code_count(bits) - 1, options.clip_fraction);
  RadianceFrame out;
  if (bits == 8) {
    merge_codes<std::uint8_t>(sorted, scales, response, clip_from, out);
  } else {
    merge_codes<std::uint16_t>(sorted, scales, response, clip_from, out);
  }
  return out;
}

}  // namespace skylit::sky
