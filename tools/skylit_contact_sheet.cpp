// skylit-contact-sheet: a grid of frames spread over a skylit-live recording, each labelled with
// the time of its sky and the sun's elevation (from the frame log beside the recording).
//
//     skylit-contact-sheet RECORDING... -o sheet.png [--grid 3x3] [--width 320] [--utc-offset 9]
//                          [--span 0,1] [--times 4]
//
// RECORDING is a video (live.mp4, its log live.csv) or a folder of PNGs (its log frames.csv).
// Frames composited before the first sky estimate are left out. Several recordings (the HMD nodes
// of one site) go side by side, a column each, a row per sky time that all of them showed.
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
#include "skylit/base/files.hpp"
#include "skylit/live/frame_log.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/sky/radiometry.hpp"
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

// The frames of a recording, in the order asked.
std::vector<cv::Mat> read_frames(const fs::path& path, const std::vector<LoggedFrame>& chosen) {
  std::vector<cv::Mat> images;
  if (fs::is_directory(path)) {
    for (const LoggedFrame& f : chosen) {
      cv::Mat image = skylit::sky::read_image(path / f.file, cv::IMREAD_COLOR);
      if (image.empty()) throw skylit::InputError((path / f.file).string() + ": cannot read the frame. Fix: keep the recording whole");
      images.push_back(image);
    }
    return images;
  }
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
  return images;
}

std::vector<LoggedFrame> frames_with_sky(const fs::path& path) {
  if (!fs::is_directory(path)) skylit::check_readable(path);  // the video itself, before its log
  const std::vector<LoggedFrame> logged = skylit::live::read_frame_log(skylit::live::frame_log_path(path));
  std::vector<LoggedFrame> lit;
  std::copy_if(logged.begin(), logged.end(), std::back_inserter(lit), [](const LoggedFrame& f) { return f.sky_timestamp.has_value(); });
  if (lit.empty()) throw skylit::InputError(path.string() + ": no frame of the recording has a sky. Fix: record longer");
  return lit;
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
  std::vector<std::string> recordings;
  std::string out, grid = "3x3", span_text = "0,1";
  int width = 320, times = 4;
  double utc_offset = 0;
  app.add_option("recording", recordings, "a video or a folder of PNGs recorded by skylit-live; several: side by side")
      ->required()
      ->check(CLI::ExistingPath);
  app.add_option("-o,--out", out, "the sheet (PNG)")->required();
  app.add_option("--grid", grid, "columns x rows")->capture_default_str();
  app.add_option("--width", width, "width of one frame on the sheet, pixels")->capture_default_str()->check(CLI::Range(32, 4096));
  app.add_option("--utc-offset", utc_offset, "hours east of UTC for the labels' times (9 for Japan)")->capture_default_str();
  app.add_option("--span", span_text, "the part of the run to spread the frames over, as fractions FROM,TO "
                                      "(0,1: all of it; 0.3,0.3 with --grid 1x1: one frame 30% in)")->capture_default_str();
  app.add_option("--times", times, "with several recordings: the sky times, one row each")->capture_default_str()->check(CLI::Range(1, 100));
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
    std::vector<std::vector<LoggedFrame>> chosen;  // per column of recordings (one column: the grid)
    std::vector<std::vector<cv::Mat>> images;
    if (recordings.size() == 1) {
      const fs::path path(recordings.front());
      const std::vector<LoggedFrame> lit = frames_with_sky(path);
      const std::size_t count = std::min(lit.size(), static_cast<std::size_t>(columns * rows));
      std::vector<LoggedFrame> spread;
      const double last = static_cast<double>(lit.size() - 1);
      for (std::size_t k = 0; k < count; ++k) {
        const double along = count == 1 ? span_from : span_from + (span_to - span_from) * static_cast<double>(k) / static_cast<double>(count - 1);
        spread.push_back(lit[static_cast<std::size_t>(std::lround(along * last))]);
      }
      chosen.push_back(spread);
      images.push_back(read_frames(path, spread));
      std::printf("skylit-contact-sheet: %zu of %zu frames with a sky on a %dx%d sheet: %s\n", spread.size(), lit.size(),
                  columns, rows, out.c_str());
    } else {
      // The sky times every recording showed, spread over --span; per recording its first frame of each.
      std::vector<std::vector<LoggedFrame>> lit;
      for (const std::string& r : recordings) lit.push_back(frames_with_sky(r));
      std::vector<double> common;
      for (const LoggedFrame& f : lit.front()) {
        const double t = *f.sky_timestamp;
        if (!common.empty() && common.back() == t) continue;
        const bool everywhere = std::all_of(lit.begin() + 1, lit.end(), [t](const std::vector<LoggedFrame>& frames) {
          return std::any_of(frames.begin(), frames.end(), [t](const LoggedFrame& g) { return *g.sky_timestamp == t; });
        });
        if (everywhere) common.push_back(t);
      }
      if (common.empty()) {
        throw skylit::InputError("the recordings share no sky time. Fix: give recordings of HMD nodes that ran under the same sky node");
      }
      const std::size_t count = std::min(common.size(), static_cast<std::size_t>(times));
      std::vector<double> picked;
      for (std::size_t k = 0; k < count; ++k) {
        const double along = count == 1 ? span_from : span_from + (span_to - span_from) * static_cast<double>(k) / static_cast<double>(count - 1);
        picked.push_back(common[static_cast<std::size_t>(std::lround(along * static_cast<double>(common.size() - 1)))]);
      }
      for (std::size_t r = 0; r < recordings.size(); ++r) {
        std::vector<LoggedFrame> column;
        for (const double t : picked) {
          column.push_back(*std::find_if(lit[r].begin(), lit[r].end(), [t](const LoggedFrame& g) { return *g.sky_timestamp == t; }));
        }
        chosen.push_back(column);
        images.push_back(read_frames(recordings[r], column));
      }
      columns = static_cast<int>(recordings.size());
      rows = static_cast<int>(count);
      std::printf("skylit-contact-sheet: %zu recordings side by side at %zu of the %zu sky times they share: %s\n",
                  recordings.size(), count, common.size(), out.c_str());
    }

    const cv::Mat& first = images.front().front();
    const int tile_height = static_cast<int>(std::lround(static_cast<double>(width) * first.rows / first.cols));
    cv::Mat sheet(rows * tile_height, columns * width, CV_8UC3, cv::Scalar(32, 32, 32));
    const bool side_by_side = recordings.size() > 1;
    for (std::size_t c = 0; c < images.size(); ++c) {
      for (std::size_t k = 0; k < images[c].size(); ++k) {
        const LoggedFrame& f = chosen[c][k];
        cv::Mat tile;
        cv::resize(images[c][k], tile, {width, tile_height}, 0, 0, cv::INTER_AREA);
        std::string text = local_time(f.sky_utc, utc_offset);
        if (text.empty()) text = "frame " + std::to_string(f.frame);
        text += f.sun_elevation_deg ? "  sun " + elevation_label(*f.sun_elevation_deg) + " deg" : "  no sun";
        if (side_by_side) text = fs::path(recordings[c]).stem().string() + "  " + text;
        label(tile, text);
        const int col = side_by_side ? static_cast<int>(c) : static_cast<int>(k) % columns;
        const int row = side_by_side ? static_cast<int>(k) : static_cast<int>(k) / columns;
        tile.copyTo(sheet(cv::Rect(col * width, row * tile_height, width, tile_height)));
      }
    }
    if (!cv::imwrite(out, sheet)) throw skylit::InputError("-o " + out + ": cannot write the sheet. Fix: check the folder");
  } catch (const skylit::InputError& e) {
    std::fprintf(stderr, "skylit-contact-sheet: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-contact-sheet: internal error: %s\n", e.what());
    return 3;
  }
  return 0;
}
