#include "recording.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <cstdio>
#include <exception>

#include <opencv2/imgcodecs.hpp>

#include "skylit/base/error.hpp"

namespace skylit::live {

namespace fs = std::filesystem;

Recorder::~Recorder() {
  try {
    finish({});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-live: the recording's last frames were lost: %s\n", e.what());
  }
}

void Recorder::write(const cv::Mat& frame, const RecordedFrame& info, const FrameRate& camera_rate) {
  if (recorder_kind(path_) != "video") {
    write_image(frame, info);
    return;
  }
  if (writer_.isOpened()) {
    write_video(frame, info);
    return;
  }
  pending_.push_back({frame.clone(), info});
  if (!fps_ && !camera_rate.settled && pending_.size() < kMaxPendingFrames) return;
  open(pending_.front().first.size(), camera_rate);
  flush_pending();
}

void Recorder::finish(const FrameRate& camera_rate) {
  if (pending_.empty()) return;
  if (!writer_.isOpened()) open(pending_.front().first.size(), camera_rate);
  flush_pending();
}

void Recorder::open(cv::Size size, const FrameRate& camera_rate) {
  double fps = fps_ ? *fps_ : camera_rate.hz ? *camera_rate.hz : fallback_fps_ ? *fallback_fps_ : 30.0;
  fps = std::clamp(fps, 0.1, 1000.0);
  if (!path_.parent_path().empty()) fs::create_directories(path_.parent_path());
  const int fourcc = path_.extension() == ".avi" ? cv::VideoWriter::fourcc('M', 'J', 'P', 'G')
                                                 : cv::VideoWriter::fourcc('m', 'p', '4', 'v');
  if (!writer_.open(path_.string(), fourcc, fps, size)) {
    throw InputError("--record " + path_.string() +
                     ": cannot open a video writer (no codec for this extension?); fix: use .avi, or a folder");
  }
  opened_fps_ = fps;
}

void Recorder::flush_pending() {
  for (auto& [image, info] : pending_) write_video(image, info);
  pending_.clear();
}

void Recorder::write_video(const cv::Mat& frame, const RecordedFrame& info) {
  // OpenCV's writer reports no failure, and a write the disk refuses leaves a damaged file: a
  // frame goes to the video only while its folder has room for it (the raw frame, which its
  // encoding never exceeds, and the muxer's buffers and index), and while the file is still there.
  const std::string problem = video_write_problem(frame.total() * frame.elemSize());
  if (!problem.empty()) {
    ++health_.lost;
    health_.failing = true;
    health_.last_error = problem;
    return;
  }
  writer_.write(frame);
  log_.add(count_, path_.filename().string(), info);
  ++count_;
  ++health_.written;
  health_.failing = false;
}

std::string Recorder::video_write_problem(std::uintmax_t frame_bytes) const {
  constexpr std::uintmax_t kMuxerReserveBytes = std::uintmax_t{1} << 20;
  const fs::path folder = path_.parent_path().empty() ? fs::path(".") : path_.parent_path();
  std::error_code error;
  if (!fs::exists(path_, error)) {
    return path_.string() + " was removed while recording: its frames are lost (restart to record anew)";
  }
  const fs::space_info space = fs::space(folder, error);
  if (error) return "cannot check the free space of " + folder.string() + ": " + error.message();
  if (space.available < frame_bytes + kMuxerReserveBytes) {
    return "no space left for " + path_.string() + ": " + std::to_string(space.available >> 10) + " KiB free in " +
           folder.string() + ", a frame needs up to " + std::to_string((frame_bytes + kMuxerReserveBytes) >> 10) +
           " KiB; frames are dropped until there is room";
  }
  return {};
}

void Recorder::write_image(const cv::Mat& frame, const RecordedFrame& info) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%06lld.png", static_cast<long long>(count_));
  const fs::path file = path_ / name;
  errno = 0;
  bool written = false;
  std::string error;
  try {
    std::error_code ignored;
    fs::create_directories(path_, ignored);  // again after a folder was removed
    written = cv::imwrite(file.string(), frame);
    if (!written) error = errno != 0 ? std::strerror(errno) : "the image could not be written";
  } catch (const cv::Exception& e) {
    error = e.what();
  }
  if (!written) {
    // A partial file (a full disk) is not a frame of the recording.
    std::error_code ignored;
    fs::remove(file, ignored);
    ++health_.lost;
    health_.failing = true;
    health_.last_error = "cannot write " + file.string() + ": " + error;
    return;
  }
  log_.add(count_, name, info);
  ++count_;
  ++health_.written;
  health_.failing = false;
}

}  // namespace skylit::live
