// Video files through OpenCV's video I/O; V4L2 cameras through OpenCV's V4L2 backend.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <fstream>
#include <regex>
#include <system_error>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "skylit/base/error.hpp"
#include "skylit/capture/sources.hpp"

namespace skylit::capture {
namespace {

namespace fs = std::filesystem;

double steady_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

bool is_device_number(const std::string& text) {
  return !text.empty() && std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
}

std::string read_first_line(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r' || line.back() == ' ')) line.pop_back();
  return line;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Video files.

VideoSource::VideoSource(const VideoSettings& settings, FrameChecks checks)
    : FrameSource(checks), settings_(settings), capture_(std::make_unique<cv::VideoCapture>()) {
  std::error_code ec;
  if (!fs::is_regular_file(settings_.file, ec)) {
    throw InputError(input_message(settings_.file, -1, -1, "path", "no such video file",
                                   "give the path of a video file (relative paths start at the config's folder)"));
  }
  if (!capture_->open(settings_.file.string(), cv::CAP_ANY) || !capture_->isOpened()) {
    throw InputError(input_message(settings_.file, -1, -1, "path", "OpenCV cannot decode this video",
                                   "convert it, e.g. 'ffmpeg -i IN -c:v mjpeg -q:v 2 OUT.avi', or give its frames "
                                   "as an image sequence (kind: images)"));
  }
  const double fps = capture_->get(cv::CAP_PROP_FPS);
  frame_period_ = fps > 0 && std::isfinite(fps) ? 1.0 / fps : 0.0;
}

VideoSource::~VideoSource() = default;

std::string VideoSource::describe() const { return "video " + settings_.file.string(); }

FrameResult VideoSource::read(double /*timeout_s*/) {
  Frame frame;
  if (!capture_->read(frame.image)) {
    if (!settings_.loop || sequence_ == 0) return {FrameStatus::EndOfStream, {}};
    // Back to the start; timestamps go on one frame period after the last.
    capture_->set(cv::CAP_PROP_POS_FRAMES, 0);
    pass_offset_ = last_timestamp_ + frame_period_;
    if (!capture_->read(frame.image)) return {FrameStatus::EndOfStream, {}};
  }
  frame.timestamp = pass_offset_ + capture_->get(cv::CAP_PROP_POS_MSEC) / 1000.0;
  last_timestamp_ = frame.timestamp;
  frame.sequence = sequence_++;
  return {FrameStatus::Ready, std::move(frame)};
}

// ---------------------------------------------------------------------------------------------
// V4L2 cameras.

std::vector<V4l2Device> list_v4l2_devices(const V4l2Paths& paths) {
  static const std::regex pattern(R"(video(\d+))");
  std::vector<std::pair<int, V4l2Device>> found;
  std::error_code ec;
  for (fs::directory_iterator it(paths.dev, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::smatch match;
    if (!std::regex_match(name, match, pattern)) continue;
    V4l2Device device;
    device.node = it->path();
    device.name = read_first_line(paths.sysfs / name / "name");
    found.emplace_back(std::stoi(match[1].str()), std::move(device));
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<V4l2Device> devices;
  for (auto& entry : found) devices.push_back(std::move(entry.second));
  return devices;
}

std::string describe_devices(const std::vector<V4l2Device>& devices) {
  if (devices.empty()) return "none found";
  std::string text;
  for (const V4l2Device& device : devices) {
    if (!text.empty()) text += ", ";
    text += device.node.string();
    if (!device.name.empty()) text += " (" + device.name + ")";
  }
  return text;
}

V4l2Source::V4l2Source(const V4l2Settings& settings, FrameChecks checks, const V4l2Paths& paths)
    : FrameSource(checks), bracket_settle_frames_(settings.bracket_settle_frames), capture_(std::make_unique<cv::VideoCapture>()) {
  node_ = is_device_number(settings.device) ? paths.dev / ("video" + settings.device) : fs::path(settings.device);
  std::error_code ec;
  if (settings.device.empty() || !fs::exists(node_, ec)) {
    throw InputError(input_message("", -1, -1, "device",
                                   "no V4L2 camera '" + (settings.device.empty() ? std::string("(empty)") : node_.string()) +
                                       "'; cameras present: " + describe_devices(list_v4l2_devices(paths)),
                                   "plug the camera in, or give one of the cameras present (an index such as 0, "
                                   "or a node such as /dev/video0)"));
  }
  name_ = read_first_line(paths.sysfs / fs::weakly_canonical(node_, ec).filename() / "name");
  const std::string who = node_.string() + (name_.empty() ? "" : " (" + name_ + ")");
  if (!capture_->open(node_.string(), cv::CAP_V4L2) || !capture_->isOpened()) {
    throw InputError(input_message("", -1, -1, "device", "cannot open the V4L2 camera " + who,
                                   "close any other program using it; check permissions (the user needs the "
                                   "'video' group); a UVC camera's second node is metadata only: try the "
                                   "other number. Cameras present: " +
                                       describe_devices(list_v4l2_devices(paths))));
  }
  if (settings.fourcc.size() == 4) {
    const auto& f = settings.fourcc;
    capture_->set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc(f[0], f[1], f[2], f[3]));
  }
  if (settings.width > 0) capture_->set(cv::CAP_PROP_FRAME_WIDTH, settings.width);
  if (settings.height > 0) capture_->set(cv::CAP_PROP_FRAME_HEIGHT, settings.height);
  if (settings.fps > 0) capture_->set(cv::CAP_PROP_FPS, settings.fps);
}

V4l2Source::~V4l2Source() = default;

std::string V4l2Source::describe() const {
  return "v4l2 " + node_.string() + (name_.empty() ? "" : " (" + name_ + ")");
}

bool V4l2Source::set_exposure_time(double seconds) {
  if (!(seconds > 0) || !std::isfinite(seconds)) return false;
  // V4L2_EXPOSURE_MANUAL is 1; exposure_time_absolute counts 100 µs.
  if (!capture_->set(cv::CAP_PROP_AUTO_EXPOSURE, 1)) return false;
  if (!capture_->set(cv::CAP_PROP_EXPOSURE, seconds * 1e4)) return false;
  exposure_time_ = seconds;
  return true;
}

std::optional<std::vector<Frame>> V4l2Source::read_bracket(std::span<const double> exposure_times_s, double timeout_s) {
  const std::optional<double> before = exposure_time_;
  std::vector<Frame> frames;
  bool any_set = false;
  for (const double exposure : exposure_times_s) {
    if (!set_exposure_time(exposure)) continue;
    any_set = true;
    bool ready = true;
    for (int k = 0; k < bracket_settle_frames_ && ready; ++k) ready = read(timeout_s).status == FrameStatus::Ready;
    if (!ready) break;
    FrameResult result = read(timeout_s);
    if (result.status != FrameStatus::Ready) break;
    result.frame.exposure_time = exposure;
    frames.push_back(std::move(result.frame));
  }
  if (!any_set) return std::nullopt;
  if (before) {
    set_exposure_time(*before);
  } else {
    // V4L2_EXPOSURE_APERTURE_PRIORITY (3): the camera's own auto exposure, as before the bracket.
    capture_->set(cv::CAP_PROP_AUTO_EXPOSURE, 3);
    exposure_time_.reset();
  }
  return frames;
}

bool V4l2Source::set_gain(double gain) {
  if (!std::isfinite(gain) || !capture_->set(cv::CAP_PROP_GAIN, gain)) return false;
  gain_ = gain;
  return true;
}

FrameResult V4l2Source::read(double timeout_s) {
  std::error_code ec;
  std::vector<int> ready;
  bool grabbed = false;
  try {
    // At least 1 ms: a timeout of 0 means "wait for ever" to OpenCV's V4L2 backend.
    const auto timeout_ns = static_cast<std::int64_t>(std::max(1e-3, timeout_s) * 1e9);
    grabbed = cv::VideoCapture::waitAny({*capture_}, ready, timeout_ns) && !ready.empty();
  } catch (const cv::Exception& e) {
    throw CaptureError(describe() + ": " + e.msg);
  }
  if (!fs::exists(node_, ec)) throw CaptureError(describe() + ": the device is gone");
  if (!grabbed) return {FrameStatus::NotYet, {}};
  Frame frame;
  if (!capture_->retrieve(frame.image)) throw CaptureError(describe() + ": the camera stopped delivering frames");
  // The V4L2 buffer's time (CLOCK_MONOTONIC, as std::chrono::steady_clock on Linux), else now.
  const double msec = capture_->get(cv::CAP_PROP_POS_MSEC);
  frame.timestamp = msec > 0 ? msec / 1000.0 : steady_seconds();
  // A live camera's frame is now: with the site's location the sky stage knows where the sun is.
  frame.utc = std::chrono::floor<std::chrono::seconds>(std::chrono::system_clock::now());
  frame.sequence = sequence_++;
  frame.exposure_time = exposure_time_;
  frame.gain = gain_;
  return {FrameStatus::Ready, std::move(frame)};
}

}  // namespace skylit::capture
