#pragma once
// From camera frames to linear radiance: reading sky images, camera response curves (sRGB, or
// calibrated from an exposure bracket with Debevec's method), exposure and gain, and merging a
// bracket to HDR.
#include <array>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace skylit::sky {

// Colour order: every cv::Mat here is OpenCV's BGR; radiance images are CV_32FC3, linear,
// relative units (code value through the inverse response, divided by exposure time × gain).
struct Exposure {
  double time_s = 1.0;   // exposure time, seconds
  double gain = 1.0;     // linear sensor gain (ISO / 100 for a camera that reports ISO)
};

// Inverse camera response: for each channel (B, G, R) and code value, the relative exposure
// (irradiance × time) that produces it. 256 entries for 8-bit frames, 65536 for 16-bit.
struct ResponseCurve {
  std::array<std::vector<float>, 3> bgr;
  int bits = 8;
  static ResponseCurve srgb(int bits);     // the sRGB transfer function, inverted
  static ResponseCurve linear(int bits);   // code / max code
};

// Calibrates an 8-bit camera's response from an exposure bracket of one static scene
// (cv::CalibrateDebevec). InputError when the frames differ in size or type, are not 8-bit, or
// are fewer than 2 or their times are not distinct.
ResponseCurve calibrate_response(std::span<const cv::Mat> frames, std::span<const Exposure> exposures);
// YAML: {bits: 8, b: [...], g: [...], r: [...]}; atomic write; InputError naming file and field.
void save_response(const ResponseCurve& curve, const std::filesystem::path& file);
ResponseCurve load_response(const std::filesystem::path& file);
// The response a setting names for frames of `bits` (8 or 16): "srgb", "linear" or a response
// file. A file's curve must be for that bit depth (InputError naming the file, its 'bits' and the
// fix otherwise): every program that takes a response setting looks it up here.
ResponseCurve response_for(const std::string& setting, int bits);

// A frame read as it is stored: 8/16-bit BGR (gray expanded, alpha dropped) or float BGR (EXR,
// HDR: taken as linear radiance). InputError naming the file for an unreadable or empty image.
cv::Mat read_sky_image(const std::filesystem::path& file);

// Whether the file is an image of a kind skylit reads, by its first bytes: OpenEXR, Radiance HDR,
// PNG, TIFF or JPEG. OpenCV would hand anything else to whichever of its codecs claims it (its
// DICOM reader aborts the process on some files).
bool is_supported_image(const std::filesystem::path& file);
// cv::imread of a supported image; an empty Mat, as imread gives, for anything else or a decoder's
// exception.
cv::Mat read_image(const std::filesystem::path& file, int flags);
// Exposure time and gain from the image's EXIF (ExposureTime, ISOSpeedRatings / 100), when the
// file carries them.
std::optional<Exposure> read_exposure_metadata(const std::filesystem::path& file);
// Writes a float image (CV_32FC3 BGR as channels R, G, B; CV_32FC1 as Y) as a ZIP-compressed
// OpenEXR, atomically; half floats when `half_float` (NaN/Inf kept, values over 65504 become
// Inf). read_sky_image reads it back. InputError naming the file when it cannot be written.
void write_sky_exr(const std::filesystem::path& file, const cv::Mat& image, bool half_float = false);

struct RadianceFrame {
  cv::Mat radiance;   // CV_32FC3, BGR, linear; may hold NaN, Inf or negatives from float inputs
  cv::Mat clipped;    // CV_8U, 255 where a channel sat at the top code (in every exposure of a
                      // bracket); empty for float inputs, which cannot tell
};

struct LinearisationOptions {
  // A code at or above this fraction of the top code counts as clipped (sensor saturation
  // arrives before the last code on many cameras).
  double clip_fraction = 0.98;
};

// One frame: float inputs are taken as radiance (divided by exposure); 8/16-bit inputs go
// through `response` (whose bits must match) and are divided by time × gain.
RadianceFrame linearise(const cv::Mat& frame, const ResponseCurve& response, const Exposure& exposure,
                        const LinearisationOptions& options = {});

// A bracket of 8/16-bit frames of one scene merged to HDR: per pixel a weighted mean of the
// linearised frames (hat weights, clipped and black codes left out); a pixel clipped in every
// frame keeps the value of the shortest exposure and is marked clipped. Frames must agree in
// size and type (InputError otherwise).
RadianceFrame merge_bracket(std::span<const cv::Mat> frames, std::span<const Exposure> exposures,
                            const ResponseCurve& response, const LinearisationOptions& options = {});

}  // namespace skylit::sky
