#pragma once
// Timestamped sky frames for the sky camera's orientation: where their times come from (a CSV
// like skylit-sky's frames.csv, or the photos' EXIF), the sun found in each frame through the
// lens and the sun's computed position at that time, and the picture that shows both.
#include <chrono>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "skylit/calib/orientation.hpp"
#include "skylit/camera/calibration.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/sky/sun.hpp"

namespace skylit::calib {

struct TimedFrame {
  std::filesystem::path file;
  std::chrono::sys_seconds utc{};
};

// A CSV whose header names the columns `file` and `timestamp` (other columns ignored: skylit-sky's
// frames.csv is one), timestamps ISO 8601 with a zone ("2026-06-21T09:30:00+09:00"), files
// relative to the CSV's folder. InputError naming the line and column of a bad row.
std::vector<TimedFrame> read_frame_list(const std::filesystem::path& csv);

// When a photo was taken: EXIF DateTimeOriginal (or DateTime), in the zone of OffsetTimeOriginal
// when the camera wrote it, otherwise `utc_offset` ("+09:00", "-0500", "Z"). InputError naming the
// photo and saying what to do when there is no time or no zone.
std::chrono::sys_seconds photo_time(const std::filesystem::path& photo, const std::string& utc_offset);

struct FrameSun {
  TimedFrame frame;
  sky::SolarPosition solar;                   // where the sun is at the frame's time
  std::optional<camera::Vec2> pixel;             // where the sun was found in the frame
  std::optional<SunObservation> observation;  // the pair for the fit (found, and above the horizon)
  std::string reason;                         // "sun found", or why the frame gives no pair
};

struct SunSearchOptions {
  sky::SunOptions sun;
  // 8/16-bit frames go through this response (sRGB when absent); float frames are radiance.
  std::optional<sky::ResponseCurve> response;
  double min_sun_elevation_deg = 0;  // frames whose computed sun is lower give no pair
};

// A frame as linear radiance (the response for 8/16-bit frames; clipped pixels marked).
// InputError naming the file when it cannot be read.
sky::RadianceFrame read_radiance(const std::filesystem::path& file, const SunSearchOptions& options);

// The sun in each frame, through `intrinsics` (its R_site_from_camera is ignored: directions
// are in the camera frame; its mask is used when it names one), and the solar position at the
// frame's time at (latitude, longitude). InputError naming the file for a frame that cannot be
// read or is not of the calibration's size.
std::vector<FrameSun> find_sun(const camera::CameraCalibration& intrinsics, std::span<const TimedFrame> frames, double latitude_deg,
                               double longitude_deg, const SunSearchOptions& options = {});

// The observations of the frames that have one, in order (what fit_orientation takes).
std::vector<SunObservation> observations_of(std::span<const FrameSun> frames);

// The installer's check: `background` (8-bit BGR of the calibration's size, e.g. a tone-mapped
// frame) with, for every frame, the sun where it was found (a green ring; red when `inlier`
// says it was left out) and where the orientation `oriented` (intrinsics with R set) puts the
// computed sun (a yellow cross), joined by a line; the horizon and N, E, S, W drawn through the
// same orientation. `inlier`: per observation (observations_of's order), may be empty.
cv::Mat draw_orientation(const camera::CameraCalibration& oriented, const cv::Mat& background, std::span<const FrameSun> frames,
                         const std::vector<bool>& inlier);

}  // namespace skylit::calib
