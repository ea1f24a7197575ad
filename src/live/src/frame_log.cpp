#include "skylit/live/frame_log.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "skylit/base/csv.hpp"
#include "skylit/base/error.hpp"
#include "skylit/sky/solar.hpp"

namespace skylit::live {

namespace fs = std::filesystem;

std::string recorder_kind(const fs::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".mp4" || ext == ".avi" || ext == ".mkv") return "video";
  return "images";
}

fs::path frame_log_path(const fs::path& record) {
  return recorder_kind(record) == "video" ? fs::path(record).replace_extension(".csv") : record / "frames.csv";
}

void FrameLogWriter::add(std::int64_t frame, const std::string& file, const RecordedFrame& info) {
  if (!log_.is_open()) {
    log_.open(frame_log_path(record_));
    if (!log_) throw InputError("--record: cannot write " + frame_log_path(record_).string());
    log_ << "frame,file,timestamp,sky_timestamp,sky_utc,sun_elevation_deg,sun_azimuth_deg,opacity\n";
  }
  char line[256];
  std::snprintf(line, sizeof line, "%lld,%s,%.6f,", static_cast<long long>(frame), file.c_str(), info.timestamp);
  log_ << line;
  if (info.sky_timestamp) {
    std::snprintf(line, sizeof line, "%.3f", *info.sky_timestamp);
    log_ << line;
  }
  log_ << ',' << (info.sky_utc ? sky::format_utc(*info.sky_utc) : std::string()) << ',';
  if (info.sun_direction) {
    const Eigen::Vector3d& d = *info.sun_direction;
    std::snprintf(line, sizeof line, "%.2f,%.2f", std::asin(std::clamp(d.z(), -1.0, 1.0)) * 180 / M_PI,
                  std::atan2(d.x(), d.y()) * 180 / M_PI);
    log_ << line;
  } else {
    log_ << ',';
  }
  log_ << ',';
  if (info.opacity) {
    std::snprintf(line, sizeof line, "%.4f", *info.opacity);
    log_ << line;
  }
  log_ << '\n' << std::flush;  // a process killed hard still leaves a readable log
}

namespace {

constexpr const char* kLogFix = "give the log skylit-live wrote";

// The log's rows by column name; a column the header lacks reads as an empty field.
class LogColumns {
 public:
  LogColumns(const fs::path& log, const CsvRow& header) : log_(log) {
    for (std::size_t c = 0; c < header.fields.size(); ++c) column_[header.fields[c].text] = c;
  }
  bool has(const std::string& name) const { return column_.count(name) != 0; }
  const CsvField* field(const CsvRow& row, const std::string& name) const {
    const auto found = column_.find(name);
    if (found == column_.end() || found->second >= row.fields.size()) return nullptr;
    return &row.fields[found->second];
  }
  std::string text(const CsvRow& row, const std::string& name) const {
    const CsvField* f = field(row, name);
    return f != nullptr ? f->text : std::string();
  }
  std::optional<double> number(const CsvRow& row, const std::string& name) const {
    const CsvField* f = field(row, name);
    if (f == nullptr || f->text.empty()) return std::nullopt;
    const auto value = parse_number(f->text);
    if (!value) throw InputError(input_message(log_, row.line, f->column, name, "'" + f->text + "' is not a number", kLogFix));
    return value;
  }
  std::optional<std::chrono::sys_seconds> utc(const CsvRow& row, const std::string& name) const {
    const CsvField* f = field(row, name);
    if (f == nullptr || f->text.empty()) return std::nullopt;
    try {
      return sky::parse_utc(f->text);
    } catch (const InputError&) {
      throw InputError(input_message(log_, row.line, f->column, name,
                                     "'" + f->text + "' is not a time like 2026-06-21T09:30:00Z", kLogFix));
    }
  }

 private:
  fs::path log_;
  std::map<std::string, std::size_t> column_;
};

}  // namespace

std::vector<LoggedFrame> read_frame_log(const fs::path& log) {
  std::ifstream in(log);
  if (!in) {
    throw InputError(log.string() + ": no frame log. Fix: give a recording made by skylit-live "
                                    "(it writes the log beside the video, or frames.csv in the folder)");
  }
  std::ostringstream text;
  text << in.rdbuf();
  CsvError error;
  const std::vector<CsvRow> rows = parse_csv(text.str(), &error);
  if (error.line > 0) throw InputError(input_message(log, error.line, error.column, "frame log", error.problem, kLogFix));
  if (rows.empty()) throw InputError(log.string() + ": the frame log is empty. Fix: record some frames first");
  const LogColumns columns(log, rows[0]);
  for (const char* name : {"frame", "file", "sky_timestamp", "sky_utc", "sun_elevation_deg"}) {
    if (!columns.has(name)) throw InputError(input_message(log, 1, 1, name, "missing from the header", kLogFix));
  }
  std::vector<LoggedFrame> frames;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    const CsvRow& row = rows[r];
    LoggedFrame f;
    const auto index = parse_number(columns.text(row, "frame"));
    if (!index) throw InputError(input_message(log, row.line, 1, "frame", "not a number", kLogFix));
    f.frame = std::llround(*index);
    f.file = columns.text(row, "file");
    f.timestamp = columns.number(row, "timestamp");
    f.sky_timestamp = columns.number(row, "sky_timestamp");
    f.sky_utc = columns.utc(row, "sky_utc");
    f.sun_elevation_deg = columns.number(row, "sun_elevation_deg");
    f.sun_azimuth_deg = columns.number(row, "sun_azimuth_deg");
    f.opacity = columns.number(row, "opacity");
    frames.push_back(f);
  }
  return frames;
}

}  // namespace skylit::live
