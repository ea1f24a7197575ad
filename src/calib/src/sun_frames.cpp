#include "skylit/calib/sun_frames.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <string_view>

#include <libexif/exif-data.h>
#include <opencv2/imgproc.hpp>

#include "skylit/base/csv.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/geom/angles.hpp"
#include "printf_text.hpp"

namespace skylit::calib {
namespace {

using geom::kDeg;
namespace fs = std::filesystem;

struct ExifDataDeleter {
  void operator()(ExifData* data) const { exif_data_unref(data); }
};

// The ASCII value of a tag, trimmed of NULs and spaces; empty when absent.
std::string exif_text(ExifData* data, ExifTag tag) {
  ExifEntry* entry = exif_data_get_entry(data, tag);
  if (entry == nullptr || entry->data == nullptr || entry->format != EXIF_FORMAT_ASCII) return {};
  std::string text(reinterpret_cast<const char*>(entry->data), entry->size);
  const std::size_t end = text.find_last_not_of(std::string("\0 ", 2));
  return end == std::string::npos ? std::string() : text.substr(0, end + 1);
}

}  // namespace

std::vector<TimedFrame> read_frame_list(const fs::path& csv) {
  const std::string text = read_file(csv);
  CsvError error;
  const std::vector<CsvRow> rows = parse_csv(text, &error);
  if (!error.problem.empty()) {
    throw InputError(input_message(csv, error.line, error.column, "", error.problem, "close the quote"));
  }
  const std::string header_fix = "make the first line a header naming the columns, e.g. 'timestamp,file'";
  if (rows.empty()) throw InputError(input_message(csv, -1, -1, "", "no rows", header_fix + ", then one row per frame"));
  const auto column = [&](std::string_view name) -> std::optional<std::size_t> {
    for (std::size_t k = 0; k < rows[0].fields.size(); ++k) {
      if (rows[0].fields[k].text == name) return k;
    }
    return std::nullopt;
  };
  const auto file_column = column("file");
  const auto time_column = column("timestamp");
  if (!file_column || !time_column) {
    throw InputError(input_message(csv, rows[0].line, 1, "", "the header lacks a 'file' or a 'timestamp' column", header_fix));
  }
  std::vector<TimedFrame> frames;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    const CsvRow& row = rows[r];
    if (row.fields.size() <= std::max(*file_column, *time_column)) {
      throw InputError(input_message(csv, row.line, 1, "", "the row has " + std::to_string(row.fields.size()) + " field(s)",
                                     "give every row a file and a timestamp"));
    }
    const CsvField& file = row.fields[*file_column];
    const CsvField& time = row.fields[*time_column];
    if (file.text.empty()) throw InputError(input_message(csv, row.line, file.column, "file", "empty", "name the frame's image"));
    TimedFrame frame;
    const fs::path path(file.text);
    frame.file = path.is_absolute() ? path : csv.parent_path() / path;
    try {
      frame.utc = sky::parse_utc(time.text);
    } catch (const InputError& e) {
      throw InputError(input_message(csv, row.line, time.column, "timestamp", e.what(),
                                     "write the time the frame was taken as ISO 8601 with its zone, e.g. "
                                     "2026-06-21T09:30:00+09:00"));
    }
    frames.push_back(frame);
  }
  if (frames.empty())
    throw InputError(input_message(csv, -1, -1, "", "the CSV lists no frames", "add one row per frame: file,timestamp"));
  return frames;
}

std::chrono::sys_seconds photo_time(const fs::path& photo, const std::string& utc_offset) {
  std::unique_ptr<ExifData, ExifDataDeleter> data(exif_data_new_from_file(photo.c_str()));
  const std::string csv_fix = "list the frames with their times in a CSV (--frames, columns file,timestamp)";
  if (!data) {
    throw InputError(input_message(photo, -1, -1, "EXIF", "the photo carries no EXIF data (no time it was taken)", csv_fix));
  }
  std::string taken = exif_text(data.get(), EXIF_TAG_DATE_TIME_ORIGINAL);
  if (taken.empty()) taken = exif_text(data.get(), EXIF_TAG_DATE_TIME);
  // "YYYY:MM:DD HH:MM:SS"
  if (taken.size() < 19 || taken[4] != ':' || taken[7] != ':') {
    throw InputError(input_message(
        photo, -1, -1, "EXIF DateTimeOriginal",
        taken.empty() ? std::string("absent") : std::string("'").append(taken).append("' is not a date and time"), csv_fix));
  }
  std::string zone = exif_text(data.get(), EXIF_TAG_OFFSET_TIME_ORIGINAL);
  if (zone.empty()) zone = utc_offset;
  if (zone.empty()) {
    throw InputError(input_message(photo, -1, -1, "EXIF OffsetTimeOriginal", "the camera did not record its time zone",
                                   "give the zone its clock was set to, e.g. --utc-offset +09:00 (Z for UTC), or " + csv_fix));
  }
  std::string iso = taken.substr(0, 19);
  iso[4] = '-';
  iso[7] = '-';
  iso[10] = 'T';
  try {
    return sky::parse_utc(iso + zone);
  } catch (const InputError& e) {
    throw InputError(input_message(photo, -1, -1, "EXIF time", e.what(), "give --utc-offset as +hh:mm, or " + csv_fix));
  }
}

sky::RadianceFrame read_radiance(const fs::path& file, const SunSearchOptions& options) {
  const cv::Mat image = sky::read_sky_image(file);
  if (image.depth() == CV_32F) return sky::linearise(image, sky::ResponseCurve::linear(8), sky::Exposure{});
  const int bits = image.depth() == CV_16U ? 16 : 8;
  if (options.response && options.response->bits != bits) {
    throw InputError(input_message(
        file, -1, -1, "",
        "a " + std::to_string(bits) + "-bit frame and a " + std::to_string(options.response->bits) + "-bit response curve",
        "give the response curve of this camera and bit depth, or leave out --response (sRGB)"));
  }
  return sky::linearise(image, options.response ? *options.response : sky::ResponseCurve::srgb(bits), sky::Exposure{});
}

std::vector<FrameSun> find_sun(const camera::CameraCalibration& intrinsics, std::span<const TimedFrame> frames, double latitude_deg,
                               double longitude_deg, const SunSearchOptions& options) {
  // Directions in the camera frame: the lens with the identity for R.
  camera::CameraCalibration camera = intrinsics;
  camera.R_site_from_camera.setIdentity();
  const camera::Lens lens(camera);
  const cv::Mat mask = sky::load_calibration_mask(camera);
  const sky::SunDetector detector(lens, mask, options.sun);

  std::vector<FrameSun> out;
  for (const TimedFrame& frame : frames) {
    FrameSun result;
    result.frame = frame;
    result.solar = sky::solar_position(frame.utc, latitude_deg, longitude_deg);
    const sky::RadianceFrame radiance = read_radiance(frame.file, options);
    if (radiance.radiance.cols != camera.image_width || radiance.radiance.rows != camera.image_height) {
      throw InputError(input_message(frame.file, -1, -1, "",
                                     "the frame is " + std::to_string(radiance.radiance.cols) + "x" +
                                         std::to_string(radiance.radiance.rows) + ", the calibration " +
                                         std::to_string(camera.image_width) + "x" + std::to_string(camera.image_height),
                                     "use the calibration of the camera (and resolution) that took the frames"));
    }
    const sky::SunDetection detection = detector.detect(radiance.radiance, radiance.clipped);
    const double elevation = result.solar.elevation_rad / kDeg;
    if (!detection.sun) {
      result.reason = "no sun found: " + detection.reason;
    } else {
      const Vec3 direction = detection.sun->direction.normalized();
      result.pixel = lens.project(direction);
      if (elevation < options.min_sun_elevation_deg) {
        result.reason =
            format("a sun was found, but at this time the sun is %.1f° high", elevation) + ": check the time and its zone";
      } else {
        result.observation = SunObservation{frame.file.filename().string(), direction, result.solar.direction()};
        result.reason = "sun found";
      }
    }
    out.push_back(std::move(result));
  }
  return out;
}

std::vector<SunObservation> observations_of(std::span<const FrameSun> frames) {
  std::vector<SunObservation> observations;
  for (const FrameSun& f : frames) {
    if (f.observation) observations.push_back(*f.observation);
  }
  return observations;
}

cv::Mat draw_orientation(const camera::CameraCalibration& oriented, const cv::Mat& background, std::span<const FrameSun> frames,
                         const std::vector<bool>& inlier) {
  const cv::Size size(oriented.image_width, oriented.image_height);
  cv::Mat canvas(size, CV_8UC3, cv::Scalar(0, 0, 0));
  if (!background.empty() && background.size() == size && background.type() == CV_8UC3) background.copyTo(canvas);
  const camera::Lens lens(oriented);
  const double scale = std::max(size.width, size.height) / 1000.0;
  const int thick = std::max(1, static_cast<int>(std::lround(2 * scale)));
  const auto to_point = [](const camera::Vec2& p) { return cv::Point(cvRound(p.x()), cvRound(p.y())); };
  const auto site_direction = [](double azimuth_deg, double elevation_deg) {
    const double a = azimuth_deg * kDeg, e = elevation_deg * kDeg;
    return camera::Vec3(std::sin(a) * std::cos(e), std::cos(a) * std::cos(e), std::sin(e));
  };

  // The horizon, in pieces where the lens sees it.
  std::vector<cv::Point> piece;
  for (int k = 0; k <= 360; ++k) {
    const auto p = lens.site_to_pixel(site_direction(k, 0.0));
    if (p) {
      piece.push_back(to_point(*p));
    } else if (!piece.empty()) {
      cv::polylines(canvas, piece, false, cv::Scalar(200, 200, 200), thick, cv::LINE_AA);
      piece.clear();
    }
  }
  if (piece.size() > 1) cv::polylines(canvas, piece, false, cv::Scalar(200, 200, 200), thick, cv::LINE_AA);
  const double font = 0.8 * std::max(scale, 0.5);
  const std::array<std::pair<const char*, double>, 4> compass{{{"N", 0.0}, {"E", 90.0}, {"S", 180.0}, {"W", 270.0}}};
  for (const auto& [label, azimuth] : compass) {
    if (const auto p = lens.site_to_pixel(site_direction(azimuth, 8.0))) {
      cv::putText(canvas, label, to_point(*p) - cv::Point(cvRound(8 * font), -cvRound(8 * font)), cv::FONT_HERSHEY_SIMPLEX, font,
                  cv::Scalar(255, 255, 255), thick, cv::LINE_AA);
    }
  }

  const int ring = std::max(4, static_cast<int>(std::lround(8 * scale)));
  std::size_t observation = 0;
  for (const FrameSun& f : frames) {
    bool used = true;
    if (f.observation) {
      used = observation >= inlier.size() || inlier[observation];
      ++observation;
    }
    if (f.pixel) {
      const cv::Scalar colour = (f.observation && used) ? cv::Scalar(0, 220, 0) : cv::Scalar(0, 0, 255);
      cv::circle(canvas, to_point(*f.pixel), ring, colour, thick, cv::LINE_AA);
    }
    const auto predicted = f.solar.elevation_rad > 0 ? lens.site_to_pixel(f.solar.direction()) : std::nullopt;
    if (predicted) {
      const cv::Point p = to_point(*predicted);
      if (f.pixel) cv::line(canvas, to_point(*f.pixel), p, cv::Scalar(0, 200, 255), std::max(1, thick / 2), cv::LINE_AA);
      cv::drawMarker(canvas, p, cv::Scalar(0, 255, 255), cv::MARKER_CROSS, 2 * ring, std::max(1, thick / 2), cv::LINE_AA);
    }
  }
  const int line = static_cast<int>(std::lround(30 * std::max(scale, 0.5)));
  cv::putText(canvas, "ring: sun found (red: left out)   cross: sun computed", {line / 2, size.height - line / 2},
              cv::FONT_HERSHEY_SIMPLEX, 0.5 * font, cv::Scalar(255, 255, 255), std::max(1, thick / 2), cv::LINE_AA);
  return canvas;
}

}  // namespace skylit::calib
