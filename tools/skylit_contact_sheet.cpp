// skylit-contact-sheet: a grid of frames spread over a skylit-live recording, each labelled with
// the time of its sky and the sun's elevation (from the frame log beside the recording).
//
//     skylit-contact-sheet RECORDING -o sheet.png [--grid 3x3] [--width 320] [--utc-offset 9]
//                          [--span 0,1]
//
// RECORDING is a video (live.mp4, its log live.csv) or a folder of PNGs (its log frames.csv).
// Frames composited before the first sky estimate are left out.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "skylit/base/error.hpp"
#include "skylit/live/frame_log.hpp"
#include "skylit/sky/solar.hpp"
#include "command_line.hpp"

namespace {

namespace fs = std::filesystem;

using skylit::live::LoggedFrame;

// "06:40" at the offset (hours east of UTC), from the log's sky_utc; "" without one.
std::string local_time(const std::optional<std::chrono::sys_seconds>& utc, double offset_hours) {
  if (!utc) return "";
  const auto t = *utc + std::chrono::seconds(std::llround(offset_hours * 3600));
  const std::string text = skylit::sky::format_utc(std::chrono::time_point_cast<std::chrono::seconds>(t));
  return text.substr(11, 5);
}

// The sun's elevation to a tenth of a degree, cut rather than rounded, as the log's two
// decimals read ("12.3" for 12.37).
std::string elevation_label(double degrees) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", degrees);
  const std::string logged(text);
  return logged.substr(0, logged.find('.') + 2);
}

void label(cv::Mat& tile, const std::string& text) {
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  const double scale = std::max(0.35, tile.cols / 640.0);
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, font, scale, 1, &baseline);
  cv::rectangle(tile, {0, 0}, {size.width + 8, size.height + baseline + 8}, cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(tile, text, {4, size.height + 4}, font, scale, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"skylit-contact-sheet: frames spread over a skylit-live recording, labelled with sky time and sun",
               "skylit-contact-sheet"};
  skylit::tools::add_version_flag(app);
  bool quiet = false;
  skylit::tools::add_quiet_flag(app, quiet);
  std::string recording, out, grid = "3x3", span_text = "0,1";
  int width = 320;
  double utc_offset = 0;
  app.add_option("recording", recording, "a video or a folder of PNGs recorded by skylit-live")
      ->required()
      ->check(CLI::ExistingPath);
  app.add_option("-o,--out", out, "the sheet (PNG)")->required();
  app.add_option("--grid", grid, "columns x rows")->capture_default_str();
  app.add_option("--width", width, "width of one frame on the sheet, pixels")->capture_default_str()->check(CLI::Range(32, 4096));
  app.add_option("--utc-offset", utc_offset, "hours east of UTC for the labels' times (9 for Japan)")->capture_default_str();
  app.add_option("--span", span_text, "the part of the run to spread the frames over, as fractions FROM,TO "
                                      "(0,1: all of it; 0.3,0.3 with --grid 1x1: one frame 30% in)")->capture_default_str();
  if (const auto status = skylit::tools::parse_command_line(app, argc, argv)) return *status;
  if (quiet) skylit::tools::quiet_stdout();

  try {
    int columns = 0, rows = 0;
    if (std::sscanf(grid.c_str(), "%dx%d", &columns, &rows) != 2 || columns < 1 || rows < 1 || columns * rows > 100) {
      throw skylit::InputError("--grid '" + grid + "': not COLUMNSxROWS. Fix: e.g. --grid 3x3");
    }
    double span_from = 0, span_to = 1;
    if (std::sscanf(span_text.c_str(), "%lf,%lf", &span_from, &span_to) != 2 || !(0 <= span_from && span_from <= span_to && span_to <= 1)) {
      throw skylit::InputError("--span '" + span_text + "': not FROM,TO with 0 <= FROM <= TO <= 1. Fix: e.g. --span 0,1");
    }
    const fs::path path(recording);
    const std::vector<LoggedFrame> logged = skylit::live::read_frame_log(skylit::live::frame_log_path(path));
    std::vector<LoggedFrame> lit;
    std::copy_if(logged.begin(), logged.end(), std::back_inserter(lit), [](const LoggedFrame& f) { return f.sky_timestamp.has_value(); });
    if (lit.empty()) throw skylit::InputError(path.string() + ": no frame of the recording has a sky. Fix: record longer");
    const std::size_t count = std::min(lit.size(), static_cast<std::size_t>(columns * rows));
    std::vector<LoggedFrame> chosen;
    const double last = static_cast<double>(lit.size() - 1);
    for (std::size_t k = 0; k < count; ++k) {
      const double along = count == 1 ? span_from : span_from + (span_to - span_from) * static_cast<double>(k) / static_cast<double>(count - 1);
      chosen.push_back(lit[static_cast<std::size_t>(std::lround(along * last))]);
    }

    // The chosen frames, in order.
    std::vector<cv::Mat> images;
    if (fs::is_directory(path)) {
      for (const LoggedFrame& f : chosen) {
        cv::Mat image = cv::imread((path / f.file).string(), cv::IMREAD_COLOR);
        if (image.empty()) throw skylit::InputError((path / f.file).string() + ": cannot read the frame. Fix: keep the recording whole");
        images.push_back(image);
      }
    } else {
      cv::VideoCapture video(path.string());
      if (!video.isOpened()) throw skylit::InputError(path.string() + ": cannot open the video. Fix: give a finished recording");
      long long index = 0;
      cv::Mat image;
      for (const LoggedFrame& f : chosen) {
        while (index <= f.frame && video.read(image)) ++index;
        if (index <= f.frame || image.empty()) {
          throw skylit::InputError(path.string() + ": the video ends before frame " + std::to_string(f.frame) +
                                   ". Fix: give a finished recording (skylit-live closes it on exit)");
        }
        images.push_back(image.clone());
      }
    }

    const int tile_height = static_cast<int>(std::lround(static_cast<double>(width) * images[0].rows / images[0].cols));
    cv::Mat sheet(rows * tile_height, columns * width, CV_8UC3, cv::Scalar(32, 32, 32));
    for (std::size_t k = 0; k < images.size(); ++k) {
      cv::Mat tile;
      cv::resize(images[k], tile, {width, tile_height}, 0, 0, cv::INTER_AREA);
      std::string text = local_time(chosen[k].sky_utc, utc_offset);
      if (text.empty()) text = "frame " + std::to_string(chosen[k].frame);
      text += chosen[k].sun_elevation_deg ? "  sun " + elevation_label(*chosen[k].sun_elevation_deg) + " deg" : "  no sun";
      label(tile, text);
      const int col = static_cast<int>(k) % columns, row = static_cast<int>(k) / columns;
      tile.copyTo(sheet(cv::Rect(col * width, row * tile_height, width, tile_height)));
    }
    if (!cv::imwrite(out, sheet)) throw skylit::InputError("-o " + out + ": cannot write the sheet. Fix: check the folder");
    std::printf("skylit-contact-sheet: %zu of %zu frames with a sky on a %dx%d sheet: %s\n", images.size(), lit.size(),
                columns, rows, out.c_str());
  } catch (const skylit::InputError& e) {
    std::fprintf(stderr, "skylit-contact-sheet: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-contact-sheet: internal error: %s\n", e.what());
    return 3;
  }
  return 0;
}
