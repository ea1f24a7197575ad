// skylit-contact-sheet: a grid of frames spread over a skylit-live recording, each labelled with
// the time of its sky and the sun's elevation (from the frame log beside the recording).
//
//     skylit-contact-sheet RECORDING -o sheet.png [--grid 3x3] [--width 320] [--utc-offset 9]
//                          [--span 0,1]
//
// RECORDING is a video (live.mp4, its log live.csv) or a folder of PNGs (its log frames.csv).
// Frames composited before the first sky estimate are left out.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "skylit/base/csv.hpp"
#include "skylit/base/error.hpp"
#include "skylit/live/service.hpp"
#include "skylit/sky/solar.hpp"

namespace {

namespace fs = std::filesystem;

struct LoggedFrame {
  long long index = 0;
  std::string file;
  std::string sky_utc;      // "" when the sky source gave no time
  std::string sun_elevation;  // degrees, "" without a sun
  bool has_sky = false;
};

std::vector<LoggedFrame> read_log(const fs::path& log) {
  std::ifstream in(log);
  if (!in) {
    throw skylit::InputError(log.string() + ": no frame log. Fix: give a recording made by skylit-live "
                                            "(it writes the log beside the video, or frames.csv in the folder)");
  }
  std::ostringstream text;
  text << in.rdbuf();
  skylit::CsvError error;
  const std::vector<skylit::CsvRow> rows = skylit::parse_csv(text.str(), &error);
  if (error.line > 0) {
    throw skylit::InputError(skylit::input_message(log, error.line, error.column, "frame log", error.problem,
                                                   "give the log skylit-live wrote"));
  }
  if (rows.empty()) throw skylit::InputError(log.string() + ": the frame log is empty. Fix: record some frames first");
  std::map<std::string, std::size_t> column;
  for (std::size_t c = 0; c < rows[0].fields.size(); ++c) column[rows[0].fields[c].text] = c;
  for (const char* name : {"frame", "file", "sky_timestamp", "sky_utc", "sun_elevation_deg"}) {
    if (!column.count(name)) {
      throw skylit::InputError(skylit::input_message(log, 1, 1, name, "missing from the header",
                                                     "give the log skylit-live wrote"));
    }
  }
  auto field = [&](const skylit::CsvRow& row, const char* name) {
    const std::size_t c = column[name];
    return c < row.fields.size() ? row.fields[c].text : std::string();
  };
  std::vector<LoggedFrame> frames;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    LoggedFrame f;
    const auto index = skylit::parse_number(field(rows[r], "frame"));
    if (!index) {
      throw skylit::InputError(skylit::input_message(log, rows[r].line, 1, "frame", "not a number",
                                                     "give the log skylit-live wrote"));
    }
    f.index = std::llround(*index);
    f.file = field(rows[r], "file");
    f.has_sky = !field(rows[r], "sky_timestamp").empty();
    f.sky_utc = field(rows[r], "sky_utc");
    f.sun_elevation = field(rows[r], "sun_elevation_deg");
    frames.push_back(f);
  }
  return frames;
}

// "06:40" at the offset (hours east of UTC), from the log's "YYYY-MM-DDTHH:MM:SSZ".
std::string local_time(const std::string& utc, double offset_hours) {
  if (utc.empty()) return "";
  const auto t = skylit::sky::parse_utc(utc) + std::chrono::seconds(std::llround(offset_hours * 3600));
  const std::string text = skylit::sky::format_utc(std::chrono::time_point_cast<std::chrono::seconds>(t));
  return text.substr(11, 5);
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
  CLI::App app{"skylit-contact-sheet: frames spread over a skylit-live recording, labelled with sky time and sun"};
  std::string recording, out, grid = "3x3", span_text = "0,1";
  int width = 320;
  double utc_offset = 0;
  app.add_option("recording", recording, "a video or a folder of PNGs recorded by skylit-live")->required();
  app.add_option("-o,--out", out, "the sheet (PNG)")->required();
  app.add_option("--grid", grid, "columns x rows")->capture_default_str();
  app.add_option("--width", width, "width of one frame on the sheet, pixels")->capture_default_str()->check(CLI::Range(32, 4096));
  app.add_option("--utc-offset", utc_offset, "hours east of UTC for the labels' times (9 for Japan)")->capture_default_str();
  app.add_option("--span", span_text, "the part of the run to spread the frames over, as fractions FROM,TO "
                                      "(0,1: all of it; 0.3,0.3 with --grid 1x1: one frame 30% in)")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

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
    const std::vector<LoggedFrame> logged = read_log(skylit::live::frame_log_path(path));
    std::vector<LoggedFrame> lit;
    std::copy_if(logged.begin(), logged.end(), std::back_inserter(lit), [](const LoggedFrame& f) { return f.has_sky; });
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
        while (index <= f.index && video.read(image)) ++index;
        if (index <= f.index || image.empty()) {
          throw skylit::InputError(path.string() + ": the video ends before frame " + std::to_string(f.index) +
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
      if (text.empty()) text = "frame " + std::to_string(chosen[k].index);
      text += chosen[k].sun_elevation.empty() ? "  no sun" : "  sun " + chosen[k].sun_elevation.substr(0, chosen[k].sun_elevation.find('.') + 2) + " deg";
      label(tile, text);
      const int col = static_cast<int>(k) % columns, row = static_cast<int>(k) / columns;
      tile.copyTo(sheet(cv::Rect(col * width, row * tile_height, width, tile_height)));
    }
    if (!cv::imwrite(out, sheet)) throw skylit::InputError("-o " + out + ": cannot write the sheet. Fix: check the folder");
    std::printf("skylit-contact-sheet: %zu of %zu frames with a sky on a %dx%d sheet: %s\n", images.size(), lit.size(),
                columns, rows, out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-contact-sheet: %s\n", e.what());
    return 2;
  }
  return 0;
}
