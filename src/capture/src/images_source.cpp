// Image sequences: a folder or a glob, timestamps from a CSV beside them or a frame rate.
#include <glob.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <set>
#include <system_error>

#include <opencv2/core.hpp>

#include "skylit/base/csv.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/capture/sources.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/solar.hpp"

namespace skylit::capture {
namespace {

namespace fs = std::filesystem;

const char* const kImageExtensions[] = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".exr", ".hdr", ".pfm"};

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

bool is_image(const fs::path& file) {
  const std::string ext = lower(file.extension().string());
  return std::find(std::begin(kImageExtensions), std::end(kImageExtensions), ext) != std::end(kImageExtensions);
}

bool is_glob(const std::string& text) { return text.find_first_of("*?[") != std::string::npos; }

// Files matching a shell pattern, sorted (glob(3) sorts them).
std::vector<fs::path> glob_files(const std::string& pattern) {
  glob_t matches{};
  const int status = ::glob(pattern.c_str(), GLOB_ERR, nullptr, &matches);
  std::vector<fs::path> files;
  if (status == 0) {
    for (std::size_t i = 0; i < matches.gl_pathc; ++i) {
      const fs::path file(matches.gl_pathv[i]);
      std::error_code ec;
      if (fs::is_regular_file(file, ec)) files.push_back(file);
    }
  }
  ::globfree(&matches);
  return files;
}

std::vector<fs::path> folder_images(const fs::path& folder) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.is_regular_file() && is_image(entry.path())) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

struct Stamp {
  double seconds = 0;  // as written, or seconds since the first ISO time
  std::optional<std::chrono::sys_seconds> utc;
};

struct Row {
  std::string file;
  int line = 0;
  Stamp stamp;
};

// The rows of a CSV with a header naming `file` and `timestamp` (other columns ignored), or of
// headerless rows of file,timestamp; in the file's order.
std::vector<Row> read_timestamps(const fs::path& csv) {
  const std::string text = read_file(csv);
  CsvError csv_error;
  const std::vector<CsvRow> rows = parse_csv(text, &csv_error);
  if (csv_error.line > 0) {
    throw InputError(input_message(csv, csv_error.line, csv_error.column, "", csv_error.problem,
                                   "close the quote, or write the file name without quotes"));
  }
  const std::string fix = "write one row per image: file,timestamp (seconds, or an ISO 8601 time with a zone)";
  if (rows.empty()) throw InputError(input_message(csv, -1, -1, "", "the file has no rows", fix));

  std::size_t file_column = 0;
  std::size_t time_column = 1;
  std::size_t first_row = 0;
  const auto header_index = [&](const std::string& name) -> std::optional<std::size_t> {
    for (std::size_t i = 0; i < rows[0].fields.size(); ++i) {
      if (lower(rows[0].fields[i].text) == name) return i;
    }
    return std::nullopt;
  };
  const auto file_header = header_index("file");
  const auto time_header = header_index("timestamp");
  if (file_header || time_header) {
    if (!file_header || !time_header) {
      throw InputError(input_message(csv, rows[0].line, 1, "", "the header lacks a 'file' or a 'timestamp' column",
                                     "name the columns file and timestamp in the first line"));
    }
    file_column = *file_header;
    time_column = *time_header;
    first_row = 1;
  }

  std::vector<Row> stamps;
  std::set<std::string> seen;
  std::optional<std::chrono::sys_seconds> first_utc;
  std::optional<bool> iso;
  for (std::size_t r = first_row; r < rows.size(); ++r) {
    const CsvRow& row = rows[r];
    const std::size_t needed = std::max(file_column, time_column) + 1;
    if (row.fields.size() < needed) {
      const int column = row.fields.empty() ? 1 : row.fields.back().column;
      throw InputError(input_message(csv, row.line, column, "",
                                     std::to_string(row.fields.size()) + " field(s), " +
                                         std::to_string(needed) + " needed",
                                     fix));
    }
    const CsvField& name = row.fields[file_column];
    const CsvField& time = row.fields[time_column];
    if (name.text.empty()) throw InputError(input_message(csv, row.line, name.column, "file", "empty file name", fix));
    Stamp stamp;
    if (const auto number = parse_number(time.text)) {
      if (iso && *iso) {
        throw InputError(input_message(csv, row.line, time.column, "timestamp",
                                       "a number among ISO 8601 times", "write every timestamp the same way"));
      }
      iso = false;
      stamp.seconds = *number;
    } else {
      if (iso && !*iso) {
        throw InputError(input_message(csv, row.line, time.column, "timestamp",
                                       "'" + time.text + "' is not a number", "write every timestamp in seconds"));
      }
      try {
        stamp.utc = sky::parse_utc(time.text);
      } catch (const InputError&) {
        throw InputError(input_message(csv, row.line, time.column, "timestamp",
                                       "'" + time.text + "' is neither seconds nor an ISO 8601 time", fix));
      }
      iso = true;
      if (!first_utc) first_utc = stamp.utc;
      stamp.seconds = std::chrono::duration<double>(*stamp.utc - *first_utc).count();
    }
    if (!seen.insert(name.text).second) {
      throw InputError(input_message(csv, row.line, name.column, "file", "'" + name.text + "' is listed twice",
                                     "keep one row per image"));
    }
    stamps.push_back({name.text, row.line, stamp});
  }
  return stamps;
}

}  // namespace

ImagesSource::ImagesSource(const ImagesSettings& settings, FrameChecks checks)
    : FrameSource(checks), pattern_(settings.path), loop_(settings.loop) {
  std::error_code ec;
  std::vector<fs::path> files;
  fs::path folder;
  const std::string text = settings.path.string();
  if (fs::is_directory(settings.path, ec)) {
    files = folder_images(settings.path);
    folder = settings.path;
  } else if (is_glob(text)) {
    files = glob_files(text);
    folder = settings.path.parent_path();
  } else if (fs::is_regular_file(settings.path, ec)) {
    files = {settings.path};
    folder = settings.path.parent_path();
  }
  if (files.empty()) {
    throw InputError(input_message(settings.path, -1, -1, "path",
                                   fs::exists(settings.path, ec) || is_glob(text) ? "no images match"
                                                                                   : "no such file or folder",
                                   "give a folder of images (PNG, JPEG, TIFF, EXR, HDR) or a glob such as "
                                   "'frames/*.png'"));
  }

  fs::path csv = settings.timestamps;
  if (csv.empty()) {
    for (const char* name : {"frames.csv", "timestamps.csv"}) {
      if (fs::is_regular_file(folder / name, ec)) {
        csv = folder / name;
        break;
      }
    }
  }
  if (!csv.empty()) {
    const std::vector<Row> rows = read_timestamps(csv);
    if (fs::is_directory(settings.path, ec)) {
      // A folder with a CSV: the frames are the files the CSV lists (skylit-sky writes an EXR
      // and a PNG of each frame; frames.csv names one of them).
      for (const Row& row : rows) {
        const fs::path file = (csv.parent_path() / row.file).lexically_normal();
        if (!fs::is_regular_file(file, ec)) {
          throw InputError(input_message(csv, row.line, 1, "file", "'" + row.file + "' does not exist",
                                         "remove the row, or put the image beside the CSV"));
        }
        files_.push_back({file, row.stamp.seconds, row.stamp.utc});
      }
    } else {
      // A glob: its files, each timed by its row (by name, then by stem: frame_0001.png finds
      // the row of frame_0001.exr).
      std::map<std::string, const Stamp*> by_name;
      std::map<std::string, const Stamp*> by_stem;
      for (const Row& row : rows) {
        by_name.emplace(row.file, &row.stamp);
        by_stem.emplace(fs::path(row.file).stem().string(), &row.stamp);
      }
      for (const fs::path& file : files) {
        const Stamp* stamp = nullptr;
        if (auto it = by_name.find(file.filename().string()); it != by_name.end()) stamp = it->second;
        if (auto it = by_stem.find(file.stem().string()); !stamp && it != by_stem.end()) stamp = it->second;
        if (!stamp) {
          throw InputError(input_message(csv, -1, -1, "file", "no row for '" + file.filename().string() + "'",
                                         "add a row '" + file.filename().string() + ",TIMESTAMP', or move the image away"));
        }
        files_.push_back({file, stamp->seconds, stamp->utc});
      }
    }
    if (files_.empty()) {
      throw InputError(input_message(csv, -1, -1, "", "no rows", "add one row per image: file,timestamp"));
    }
    std::stable_sort(files_.begin(), files_.end(),
                     [](const Entry& a, const Entry& b) { return a.timestamp < b.timestamp; });
  } else {
    if (!settings.fps || !(*settings.fps > 0) || !std::isfinite(*settings.fps)) {
      throw InputError(input_message(settings.path, -1, -1, "fps",
                                     settings.fps ? "the frame rate must be positive" : "no timestamps for the images",
                                     "put a frames.csv (file,timestamp) beside the images, or give 'fps: 30'"));
    }
    for (std::size_t k = 0; k < files.size(); ++k) {
      files_.push_back({files[k], static_cast<double>(k) / *settings.fps, std::nullopt});
    }
  }
  // A loop starts one frame interval after the last frame.
  const double span = files_.back().timestamp - files_.front().timestamp;
  const double interval = files_.size() > 1 ? span / static_cast<double>(files_.size() - 1)
                                            : (settings.fps ? 1.0 / *settings.fps : 1.0);
  loop_period_ = span + interval;
}

std::string ImagesSource::describe() const { return "images " + pattern_.string(); }

FrameResult ImagesSource::read(double /*timeout_s*/) {
  // At most one pass over unreadable files per call.
  for (std::size_t tried = 0; tried < files_.size(); ++tried) {
    if (next_ >= files_.size()) {
      if (!loop_) return {FrameStatus::EndOfStream, {}};
      next_ = 0;
      ++pass_;
    }
    const std::size_t index = next_++;
    const Entry& entry = files_[index];
    Frame frame;
    std::optional<sky::Exposure> exposure;
    try {
      frame.image = sky::read_sky_image(entry.file);
      exposure = sky::read_exposure_metadata(entry.file);
    } catch (const std::exception&) {
      // A file cut short while being copied, or gone between the two reads: the sequence goes on.
      count_unreadable();
      continue;
    }
    frame.timestamp = entry.timestamp + static_cast<double>(pass_) * loop_period_;
    frame.sequence = pass_ * static_cast<std::int64_t>(files_.size()) + static_cast<std::int64_t>(index);
    if (entry.utc) {
      frame.utc = *entry.utc + std::chrono::seconds(std::llround(static_cast<double>(pass_) * loop_period_));
    }
    if (exposure) {
      frame.exposure_time = exposure->time_s;
      frame.gain = exposure->gain;
    }
    return {FrameStatus::Ready, std::move(frame)};
  }
  return {next_ >= files_.size() && !loop_ ? FrameStatus::EndOfStream : FrameStatus::NotYet, {}};
}

}  // namespace skylit::capture
