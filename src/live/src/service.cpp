#include "skylit/live/service.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include <sys/resource.h>
#include <unistd.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "cpu_shadow_ratios.hpp"
#include "live_tracking.hpp"
#include "sun_shadow_exchange.hpp"

#include "skylit/bake/format.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/capture/config.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/gpu/window_context.hpp"
#include "skylit/live/frame_stats.hpp"
#include "skylit/live/mailbox.hpp"
#include "skylit/live/status_server.hpp"
#include "skylit/render/blend_workers.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/render/cpu_blend.hpp"
#include "skylit/render/gpu_blend.hpp"
#include "skylit/render/hmd_distortion.hpp"
#include "skylit/render/plane_view.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/sky/calibration.hpp"
#include "skylit/sky/overlay.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/sky/sky_smoothing.hpp"
#include "skylit/sky/solar.hpp"

namespace skylit::live {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double now_seconds() { return std::chrono::duration<double>(Clock::now().time_since_epoch()).count(); }

// What the sky thread hands to the render thread.
struct SkyState {
  std::uint64_t sequence = 0;
  double frame_timestamp = 0;   // the sky frame's own time
  std::optional<std::chrono::sys_seconds> utc;  // the sky frame's wall-clock time, when its source knows it
  double received = 0;          // steady seconds when it was estimated
  std::vector<Eigen::Vector3d> S;  // one RGB per bake layer
  std::optional<render::SunLight> sun;
  double sun_angular_radius = 0;
  std::string sun_reason;
  int unseen_faces = 0;
  std::int64_t bad_pixels = 0;
  std::int64_t clipped_pixels = 0;
  bool sun_clipped = false;
  double estimate_ms = 0;
  // With the blend on the CPU: T of every plane (RGBA floats, CpuShadowRatios::rgba), blended on
  // the sky thread for this S and sun. A plane's pointer changes only when its blend ran, so the
  // render thread uploads what changed, even when it missed the skies in between. Null for a
  // plane out of view (blend.cull_planes): the render thread blends it when it comes into view.
  std::vector<std::shared_ptr<const std::vector<float>>> shadow_ratios;
  // The sun's visibility V over each plane behind this sky's blends (empty without a sun shadow
  // map) and its revision: what the render thread needs to blend a plane the sky thread left out.
  std::vector<std::shared_ptr<const std::vector<float>>> sun_visibility;
  std::uint64_t sun_revision = 0;
  // The sun's shadow map for this sky's sun, drawn and complete on the sky thread (the newest
  // one, also when the sun has not moved since: a sky the render thread missed still brings it);
  // null without a sun. The render thread switches to it when it differs from the one it has.
  SunShadowHandle sun_map;
  double cpu_blend_ms = 0;        // the CPU blend of every plane
  double sun_visibility_ms = 0;   // the sky thread's sun shadow map, and V read back for the CPU blend (when the sun moved)
};

// A source's health for /status: when its last frame came, whether it has ended.
struct SourceActivity {
  std::atomic<double> last_frame{-1};   // steady seconds; < 0: none yet
  std::atomic<bool> ended{false};       // a finite source has no more frames
  void frame() {
    last_frame = now_seconds();
    ended = false;
  }
};

// A frame rate from frame timestamps: the median interval between consecutive frames of the
// first kRateIntervals (a frame dropped or late moves a median little).
struct FrameRate {
  std::optional<double> hz;
  bool settled = false;   // measured over kRateIntervals intervals (or the source has ended)
};
constexpr std::size_t kRateIntervals = 8;

class FrameRateMeter {
 public:
  void add(double timestamp) {
    std::lock_guard lock(mutex_);
    if (intervals_.size() >= kRateIntervals) return;
    if (last_ && timestamp > *last_) intervals_.push_back(timestamp - *last_);
    last_ = timestamp;
  }
  void end() {
    std::lock_guard lock(mutex_);
    ended_ = true;
  }
  FrameRate rate() const {
    std::lock_guard lock(mutex_);
    FrameRate rate;
    rate.settled = ended_ || intervals_.size() >= kRateIntervals;
    if (intervals_.empty()) return rate;
    std::vector<double> sorted = intervals_;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    rate.hz = 1.0 / sorted[sorted.size() / 2];
    return rate;
  }

 private:
  mutable std::mutex mutex_;
  std::optional<double> last_;
  std::vector<double> intervals_;
  bool ended_ = false;
};

// The rate a camera source is configured for, where its config gives one.
std::optional<double> configured_rate(const capture::SourceConfig& config) {
  if (const auto* images = std::get_if<capture::ImagesSettings>(&config.settings); images && images->fps) return images->fps;
  if (const auto* v4l2 = std::get_if<capture::V4l2Settings>(&config.settings); v4l2 && v4l2->fps > 0) return v4l2->fps;
  return std::nullopt;
}

// When the camera thread received each of the last frames (steady seconds), by frame timestamp:
// the render thread's frame has waited in the mailbox since then.
class ArrivalTimes {
 public:
  void put(double frame_timestamp, double arrived) {
    std::lock_guard lock(mutex_);
    entries_[next_] = {frame_timestamp, arrived};
    next_ = (next_ + 1) % entries_.size();
  }
  std::optional<double> find(double frame_timestamp) const {
    std::lock_guard lock(mutex_);
    for (const auto& [timestamp, arrived] : entries_) {
      if (arrived >= 0 && timestamp == frame_timestamp) return arrived;
    }
    return std::nullopt;
  }

 private:
  static std::array<std::pair<double, double>, 8> empty_entries() {
    std::array<std::pair<double, double>, 8> entries;
    entries.fill({0.0, -1.0});
    return entries;
  }
  mutable std::mutex mutex_;
  std::array<std::pair<double, double>, 8> entries_ = empty_entries();  // (frame timestamp, arrival); arrival < 0: unused
  std::size_t next_ = 0;
};

// One plane's view of the current frame (blend.cull_planes): the render thread writes in_view
// from each frame's pose, the sky thread reads it to leave out the planes no view can see.
struct PlaneView {
  std::atomic<bool> in_view{true};                  // true until a pose says otherwise
  std::atomic<std::int64_t> blends_out_of_view{0};  // blends of a new sky left out, the plane out of view
  std::atomic<std::int64_t> blends_on_return{0};    // blends run as the plane came back into view
};

// With the blend on the CPU: one plane's blender, used by the sky thread for each new sky and by
// the render thread for a plane that comes into view with T of an older sky.
struct SharedCpuBlend {
  SharedCpuBlend(const render::BasisImages& basis, double skip_threshold, double change_threshold)
      : ratios(basis, skip_threshold, change_threshold) {}
  std::mutex mutex;
  CpuShadowRatios ratios;
};

struct Counters {
  std::atomic<std::int64_t> frames{0};
  std::atomic<std::int64_t> camera_frames{0};
  std::atomic<std::int64_t> sky_frames{0};
  std::atomic<std::int64_t> sky_estimates{0};
  std::atomic<std::int64_t> blends_run{0};
  std::atomic<std::int64_t> blends_skipped{0};
  std::atomic<std::int64_t> pose_missing{0};
  std::atomic<std::int64_t> frames_without_sky{0};
  std::atomic<std::int64_t> sky_errors{0};
  std::atomic<std::int64_t> camera_errors{0};
};

std::string recorder_kind(const fs::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".mp4" || ext == ".avi" || ext == ".mkv") return "video";
  return "images";
}

// What the frame log says of each recorded frame (the contact sheet's labels come from it).
struct RecordedFrame {
  double timestamp = 0;                          // the camera frame's
  std::optional<double> sky_timestamp;           // the sky frame's, on the sky source's clock; none: no sky yet
  std::optional<std::chrono::sys_seconds> sky_utc;
  std::optional<Eigen::Vector3d> sun_direction;  // towards the sun, when the sky has one
  std::optional<double> opacity;                 // the building's (BuildingFade); none: the camera image as it came
};

// Composited frames to a video file or a folder of PNGs, with a frame log beside them (CSV, one
// line per frame, flushed as it goes: `live.mp4` → `live.csv`, a folder → its `frames.csv`, which
// the images source reads back).
//
// A video's frame rate: `fps` when given (record.fps), else the HMD camera's (FrameRate, from its
// frames' timestamps, or `fallback_fps` from its config when too few frames came to measure it).
// The rate must be known when the file is opened, so the first frames wait here (a few seconds at
// most) until the camera's rate is settled.
class Recorder {
 public:
  Recorder(fs::path path, std::optional<double> fps, std::optional<double> fallback_fps)
      : path_(std::move(path)), fps_(fps), fallback_fps_(fallback_fps) {}
  ~Recorder() {
    try {
      finish({});
    } catch (const std::exception& e) {
      std::fprintf(stderr, "skylit-live: the recording's last frames were lost: %s\n", e.what());
    }
  }
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  void write(const cv::Mat& frame, const RecordedFrame& info, const FrameRate& camera_rate) {
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

  // Writes the frames that wait for the rate (at the end of a run).
  void finish(const FrameRate& camera_rate) {
    if (pending_.empty()) return;
    if (!writer_.isOpened()) open(pending_.front().first.size(), camera_rate);
    flush_pending();
  }

  // The video's frame rate (0 before the file is opened, and for a folder of images).
  double fps() const { return opened_fps_; }

 private:
  static constexpr std::size_t kMaxPendingFrames = 2 * kRateIntervals;

  void open(cv::Size size, const FrameRate& camera_rate) {
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

  void flush_pending() {
    for (auto& [image, info] : pending_) write_video(image, info);
    pending_.clear();
  }

  void write_video(const cv::Mat& frame, const RecordedFrame& info) {
    writer_.write(frame);
    log(path_.filename().string(), info);
    ++count_;
  }

  void write_image(const cv::Mat& frame, const RecordedFrame& info) {
    if (count_ == 0) fs::create_directories(path_);
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06lld.png", static_cast<long long>(count_));
    if (!cv::imwrite((path_ / name).string(), frame)) throw InputError("--record: cannot write " + (path_ / name).string());
    log(name, info);
    ++count_;
  }

  void log(const std::string& file, const RecordedFrame& info) {
    if (!log_.is_open()) {
      log_.open(frame_log_path(path_));
      if (!log_) throw InputError("--record: cannot write " + frame_log_path(path_).string());
      log_ << "frame,file,timestamp,sky_timestamp,sky_utc,sun_elevation_deg,sun_azimuth_deg,opacity\n";
    }
    char line[256];
    std::snprintf(line, sizeof line, "%lld,%s,%.6f,", static_cast<long long>(count_), file.c_str(), info.timestamp);
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

  fs::path path_;
  std::optional<double> fps_, fallback_fps_;
  double opened_fps_ = 0;
  std::vector<std::pair<cv::Mat, RecordedFrame>> pending_;
  cv::VideoWriter writer_;
  std::ofstream log_;
  std::int64_t count_ = 0;
};

// The camera frame as it is (the display before the sky is known): an sRGB RGBA8 texture, row 0
// the image's top, for WindowContext::present. 8-bit frames are sRGB codes; float ones linear.
class CameraTexture {
 public:
  GLuint upload(const cv::Mat& image) {
    cv::Mat codes = image;
    if (image.depth() == CV_32F) {
      cv::Mat linear;
      cv::max(image, 0.0, linear);
      cv::Mat srgb(linear.size(), linear.type());
      linear.forEach<cv::Vec3f>([&srgb](const cv::Vec3f& v, const int* at) {
        cv::Vec3f& out = srgb.at<cv::Vec3f>(at[0], at[1]);
        for (int c = 0; c < 3; ++c) {
          const float x = std::min(v[c], 1.0f);
          out[c] = 255.0f * (x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f);
        }
      });
      srgb.convertTo(codes, CV_8U);
    }
    cv::Mat rgba;
    cv::cvtColor(codes, rgba, codes.channels() == 1 ? cv::COLOR_GRAY2RGBA : cv::COLOR_BGR2RGBA);
    if (!texture_ || size_ != rgba.size()) {
      texture_ = gpu::make_texture();
      glBindTexture(GL_TEXTURE_2D, texture_.get());
      glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, rgba.cols, rgba.rows);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      size_ = rgba.size();
    }
    glBindTexture(GL_TEXTURE_2D, texture_.get());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, rgba.cols, rgba.rows, GL_RGBA, GL_UNSIGNED_BYTE, rgba.ptr());
    gpu::check_gl_error("uploading the camera frame for the display");
    return texture_.get();
  }

 private:
  gpu::Texture texture_;
  cv::Size size_;
};

// The CPU blend's T of one plane on the GPU, for the compositor: RGBA32F, rewritten in place.
class ShadowRatioTexture {
 public:
  ShadowRatioTexture(int width, int height) : width_(width), height_(height) {
    texture_ = gpu::make_texture();
    glBindTexture(GL_TEXTURE_2D, texture_.get());
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, width_, height_);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    const std::vector<float> ones(4 * static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_), 1.0f);
    upload(ones);
  }
  void upload(const std::vector<float>& rgba) {
    glBindTexture(GL_TEXTURE_2D, texture_.get());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width_, height_, GL_RGBA, GL_FLOAT, rgba.data());
    gpu::check_gl_error("uploading a shadow ratio blended on the CPU");
  }
  GLuint get() const { return texture_.get(); }

 private:
  int width_, height_;
  gpu::Texture texture_;
};

// A software GL renderer draws on the CPU: there the CPU blend is the faster one by far.
bool software_renderer(const std::string& renderer) {
  std::string lower = renderer;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* name : {"llvmpipe", "softpipe", "swrast", "software rasterizer"}) {
    if (lower.find(name) != std::string::npos) return true;
  }
  return false;
}

std::string gl_renderer() {
  const auto* text = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return text != nullptr ? std::string(text) : std::string("unknown");
}

std::vector<std::uint8_t> encode_jpeg(const cv::Mat& image) {
  std::vector<std::uint8_t> bytes;
  if (!image.empty()) cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, 85});
  return bytes;
}

sky::ResponseCurve response_for(const std::string& setting, int bits) {
  if (setting == "srgb") return sky::ResponseCurve::srgb(bits);
  if (setting == "linear") return sky::ResponseCurve::linear(bits);
  return sky::load_response(setting);
}

// A source that answers "not yet" at once (a folder whose files have gone, a camera that is down
// between reconnection attempts) would have its thread spin: such an answer waits a little.
void pause_after_quick_not_yet(const capture::FrameResult& result, Clock::time_point asked) {
  if (result.status == capture::FrameStatus::NotYet && Clock::now() - asked < std::chrono::milliseconds(10)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

// How much lower the sky thread's CPU priority is than the render thread's (nice levels).
constexpr int kSkyThreadNiceness = 10;

// The sun's shadow map is drawn again (by the sky thread) when the sun has moved by more than a
// tenth of its radius.
bool sun_moved(const Eigen::Vector3d& drawn_for, const Eigen::Vector3d& sun, double angular_radius) {
  return drawn_for.dot(sun) < std::cos(std::max(1e-4, 0.1 * angular_radius));
}
double shadow_angular_radius(double estimated) { return std::max(estimated, 0.0047); }  // the real sun's at least

std::vector<geom::Plane> bake_planes(const bake::Manifest& manifest) {
  std::vector<geom::Plane> planes;
  for (const auto& record : manifest.planes) planes.push_back(record.plane);
  return planes;
}

capture::SourceConfig with_reconnect(capture::SourceConfig config) {
  // A service that runs all day reopens what fails, whatever the config forgot to say.
  if (!config.reconnect) config.reconnect = capture::BackoffSettings{};
  return config;
}

}  // namespace

fs::path frame_log_path(const fs::path& record) {
  return recorder_kind(record) == "video" ? fs::path(record).replace_extension(".csv") : record / "frames.csv";
}

void check_bake_matches_site(const fs::path& bake_dir, const fs::path& site_file) {
  const scene::Site site = scene::load_site(site_file);
  const bake::Manifest manifest = bake::read_manifest(bake_dir);
  std::vector<std::string> differences;
  if (manifest.plan.frequency != site.dome_frequency) {
    differences.push_back("dome frequency: bake " + std::to_string(manifest.plan.frequency) + ", site " +
                          std::to_string(site.dome_frequency));
  }
  if (manifest.plan.basis != site.dome_basis) differences.push_back("dome basis differs");
  if (manifest.planes.size() != site.planes.size()) {
    differences.push_back("planes: bake has " + std::to_string(manifest.planes.size()) + ", site " +
                          std::to_string(site.planes.size()));
  }
  for (std::size_t j = 0; j < std::min(manifest.planes.size(), site.planes.size()); ++j) {
    const geom::Plane& a = manifest.planes[j].plane;
    const geom::Plane& b = site.planes[j];
    const std::string label = "plane " + std::to_string(j) + " '" + b.name + "'";
    if (a.name != b.name) differences.push_back(label + ": the bake's is named '" + a.name + "'");
    if ((a.origin - b.origin).norm() > 1e-6 || (a.u - b.u).norm() > 1e-6 || (a.v - b.v).norm() > 1e-6) {
      differences.push_back(label + ": origin, u or v differ");
    }
    if (a.width != b.width || a.height != b.height) {
      differences.push_back(label + ": resolution " + std::to_string(a.width) + "×" + std::to_string(a.height) +
                            " in the bake, " + std::to_string(b.width) + "×" + std::to_string(b.height) + " in the site");
    }
  }
  if (!differences.empty()) {
    std::string message = bake_dir.string() + ": the bake was not made for " + site_file.string() + ":";
    for (const auto& d : differences) message += "\n  - " + d;
    message += "\nFix: bake again (skylit-bake " + site_file.string() + " -o " + bake_dir.string() +
               " --force), or point the config's `bake` at the bake made for this site.";
    throw InputError(message);
  }
}

struct Service::State {
  LiveConfig config;
  ServiceOptions options;
  std::atomic<bool> running{true};
  Counters counters;
  double started = now_seconds();

  // Loaded once.
  scene::Site site;
  scene::Mesh mesh;
  bake::Manifest manifest;
  std::vector<float> transfer;
  std::vector<render::BasisImages> bases;
  sky::CameraCalibration sky_calibration, hmd_calibration;
  std::unique_ptr<geom::Dome> dome;
  std::unique_ptr<sky::SkyEstimator> estimator;
  std::unique_ptr<capture::FrameSource> sky_source, camera_source;
  // The ReconnectingSource inside each (the service always reopens what fails).
  const capture::ReconnectingSource* sky_reconnecting = nullptr;
  const capture::ReconnectingSource* camera_reconnecting = nullptr;
  std::unique_ptr<LiveTracking> tracking;  // the pose: fixed, a track, or the marker tracker (and IMU)
  std::unique_ptr<BuildingFade> fade;      // the building's opacity as the pose is lost and returns
  SourceActivity sky_activity, camera_activity;
  FrameRateMeter camera_rate;
  ArrivalTimes camera_arrivals;

  // Where T is blended, decided in run() once the GL renderer is known (before the sky thread starts).
  std::atomic<bool> blend_decided{false};
  std::atomic<bool> blend_on_cpu{false};
  std::string renderer;             // GL_RENDERER; written before blend_decided is set
  // The render thread has a sky: the building and its shadows are drawn (before: the camera image).
  std::atomic<bool> sky_drawn{false};
  // One per plane (manifest order).
  std::unique_ptr<PlaneView[]> plane_views;
  // With the blend on the CPU: made by the sky thread before it is ready, then shared.
  std::vector<std::unique_ptr<SharedCpuBlend>> cpu_blends;

  // The sun's shadow maps: drawn on the sky thread in a GL context that shares objects with the
  // render thread's (share_group, set by run() before the sky thread starts), used by the render
  // thread. Declared before the mailboxes, whose skies hold handles to its maps.
  gpu::HeadlessContext::ShareGroup share_group;
  SunShadowExchange sun_maps;

  // Hand-over.
  Mailbox<SkyState> sky_box;
  Mailbox<capture::Frame> camera_box;
  Latest<SkyState> latest_sky;
  Latest<std::vector<std::uint8_t>> sky_jpeg;
  Latest<cv::Mat> latest_frame;

  // Statistics (render thread writes, status reads).
  mutable std::mutex stats_mutex;
  FrameTimes frame_times{600}, blend_times{600}, upload_times{600}, composite_times{600}, record_times{600};
  FrameTimes sun_shadow_times{600}, sky_sun_visibility_times{600};
  FrameTimes sky_change_frame_times{600};  // frames that took a new sky (its shadow map and T)
  // From the camera thread receiving a frame to its composite being done (shown, recorded): the
  // part of motion-to-photon latency the service adds (docs/live.md, "Latency").
  FrameTimes latency_times{600};
  double record_fps = 0;
  std::optional<render::PhotometricMatch> photometric;
  std::int64_t blend_skipped_layers = 0;

  std::unique_ptr<StatusServer> status;
  std::thread sky_thread, camera_thread;

  void sky_loop(std::promise<void>& ready);
  void camera_loop();
  nlohmann::json status_report() const;
  nlohmann::json source_report(const capture::FrameSource& source, const capture::ReconnectingSource* reconnecting,
                               const SourceActivity& activity, double now) const;
};

Service::Service(const LiveConfig& config, const ServiceOptions& options) : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.config = config;
  s.options = options;
  check_bake_matches_site(config.bake, config.site);
  s.site = scene::load_site(config.site);
  s.mesh = scene::load_model(s.site.model, s.site.up, s.site.scale);
  s.manifest = bake::read_manifest(config.bake);
  std::vector<std::size_t> shape;
  s.transfer = bake::read_npy(config.bake / s.manifest.transfer_file, &shape);
  for (std::size_t j = 0; j < s.manifest.planes.size(); ++j) {
    if (config.blend.basis == BlendSettings::Basis::Pca && !s.manifest.planes[j].pca) {
      throw InputError(input_message(config.file, -1, -1, "blend.basis",
                                     "pca, and the bake " + config.bake.string() + " has no PCA form of plane '" +
                                         s.manifest.planes[j].plane.name + "'",
                                     "compress the bake: skylit-bake compress " + config.bake.string() +
                                         " --pca-variance 0.999; or set 'basis: full'"));
    }
    const render::BasisForm form = config.blend.basis == BlendSettings::Basis::Pca    ? render::BasisForm::Pca
                                   : config.blend.basis == BlendSettings::Basis::Lean ? render::BasisForm::Lean
                                   : config.blend.basis == BlendSettings::Basis::Cropped ? render::BasisForm::Cropped
                                                                                    : render::BasisForm::Full;
    s.bases.push_back(render::load_basis(config.bake, s.manifest, static_cast<int>(j), form));
  }
  s.plane_views = std::make_unique<PlaneView[]>(s.bases.size());
  s.sky_calibration = sky::load_calibration(config.sky.calibration);
  s.hmd_calibration = sky::load_calibration(config.camera.calibration);
  s.dome = std::make_unique<geom::Dome>(s.manifest.plan.frequency);
  sky::SkyEstimateOptions estimate_options;
  estimate_options.sun_mode = config.sky.sun ? sky::SunMode::Auto : sky::SunMode::Off;
  estimate_options.table.basis = s.manifest.plan.basis;
  s.estimator = std::make_unique<sky::SkyEstimator>(s.sky_calibration, *s.dome, estimate_options);
  capture::OpenedSource sky_opened = capture::open_source_with_status(with_reconnect(config.sky.source));
  s.sky_source = std::move(sky_opened.source);
  s.sky_reconnecting = sky_opened.reconnecting;
  capture::OpenedSource camera_opened = capture::open_source_with_status(with_reconnect(config.camera.source));
  s.camera_source = std::move(camera_opened.source);
  s.camera_reconnecting = camera_opened.reconnecting;
  s.tracking = std::make_unique<LiveTracking>(config, s.hmd_calibration);
  s.fade = std::make_unique<BuildingFade>(config.tracking.fade_s);
  const auto listen = options.status_listen ? options.status_listen : config.status_listen;
  if (listen) {
    const auto [host, port] = parse_listen_address(*listen, "status.listen");
    StatusHandlers handlers;
    State* self = &s;
    handlers.status_json = [self] { return self->status_report().dump(2) + "\n"; };
    handlers.metrics_text = [this] { return metrics_text(); };
    handlers.sky_jpeg = [self] { return self->sky_jpeg.get().value_or(std::vector<std::uint8_t>{}); };
    handlers.frame_jpeg = [self] { return encode_jpeg(self->latest_frame.get().value_or(cv::Mat())); };
    s.status = std::make_unique<StatusServer>(host, port, handlers);
  }
}

Service::~Service() {
  stop();
  if (state_->sky_thread.joinable()) state_->sky_thread.join();
  if (state_->camera_thread.joinable()) state_->camera_thread.join();
}

void Service::stop() {
  state_->running = false;
  state_->camera_box.close();
  state_->sun_maps.close();  // a sky thread waiting for the render thread to free a map
}

std::string Service::status_address() const { return state_->status ? state_->status->address() : std::string(); }

void Service::State::sky_loop(std::promise<void>& ready) {
  // This thread's work (the sky estimate, the sun's shadow map, the CPU blend; in the demo also
  // the simulated sky) yields the cores to the render thread's: it runs niced, and so do the
  // blend threads it starts, which inherit its niceness (llvmpipe's rasterizer threads are the
  // process's, shared with the render thread, and keep theirs). On a machine with few cores a
  // new sky then no longer slows the frames composited meanwhile; it comes a little later
  // instead. (Per thread on Linux; where it fails, nothing changes.)
  {
    const auto thread = static_cast<id_t>(::gettid());
    errno = 0;
    const int niceness = ::getpriority(PRIO_PROCESS, thread);
    if (errno == 0) static_cast<void>(::setpriority(PRIO_PROCESS, thread, std::min(niceness + kSkyThreadNiceness, 19)));
  }
  // When the sky may have a sun, this thread draws the sun's shadow maps (sun_maps), in a GL
  // context of its own that shares objects with the render thread's: the render thread never
  // draws one, it switches to each finished map (the building's own sun shadow; with the GPU
  // blend, the planes' V). With the blend on the CPU its objects live here too: the blend
  // threads, each plane's T, and V of each map read back for it.
  const bool cpu = blend_on_cpu;
  std::unique_ptr<render::BlendWorkers> workers;
  std::optional<gpu::HeadlessContext> context;
  // Destroys the maps in this thread's context before the context goes (declared after it).
  struct MapsOwner {
    SunShadowExchange* maps = nullptr;
    ~MapsOwner() {
      if (maps == nullptr) return;
      try {
        maps->destroy();
      } catch (const std::exception& e) {
        std::fprintf(stderr, "skylit-live: destroying the sun shadow maps: %s\n", e.what());
      }
    }
  } maps_owner;
  bool shadow_maps = false;
  SunShadowHandle last_map;
  std::vector<std::shared_ptr<const std::vector<float>>> visibility;
  std::uint64_t sun_revision = 0;
  Eigen::Vector3d shadow_direction = Eigen::Vector3d::Zero();
  try {
    if (cpu) {
      workers = std::make_unique<render::BlendWorkers>(config.blend.threads);
      for (const auto& basis : bases) {
        cpu_blends.push_back(std::make_unique<SharedCpuBlend>(basis, config.blend.skip_threshold, config.blend.change_threshold));
      }
      if (config.sky.sun) visibility.resize(bases.size());
    }
    if (config.sky.sun) {
      context.emplace(share_group);
      sun_maps.create(mesh, bake_planes(manifest));
      maps_owner.maps = &sun_maps;
      shadow_maps = true;
    }
    ready.set_value();
  } catch (...) {
    ready.set_exception(std::current_exception());
    return;
  }

  sky::SkySmoother smoother(config.sky.smoothing);
  double last_estimate = -1e300, last_overlay = -1e300;
  std::uint64_t sequence = 0;
  while (running) {
    capture::FrameResult result;
    const auto asked = Clock::now();
    try {
      result = sky_source->next(0.2);
    } catch (const std::exception& e) {
      ++counters.sky_errors;
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      continue;
    }
    if (result.status == capture::FrameStatus::EndOfStream) {
      sky_activity.ended = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the last S stays (and goes stale)
      continue;
    }
    if (result.status != capture::FrameStatus::Ready) {
      pause_after_quick_not_yet(result, asked);
      continue;
    }
    ++counters.sky_frames;
    sky_activity.frame();
    const capture::Frame& frame = result.frame;
    if (config.sky.rate > 0 && frame.timestamp - last_estimate < 1.0 / config.sky.rate) continue;
    last_estimate = frame.timestamp;
    try {
      const auto t0 = Clock::now();
      sky::Exposure exposure;
      if (frame.exposure_time) exposure.time_s = *frame.exposure_time;
      if (frame.gain) exposure.gain = *frame.gain;
      const int bits = frame.image.depth() == CV_16U ? 16 : 8;
      const sky::RadianceFrame radiance =
          frame.image.depth() == CV_32F ? sky::linearise(frame.image, sky::ResponseCurve::linear(8), exposure)
                                        : sky::linearise(frame.image, response_for(config.sky.response, bits), exposure);
      sky::SkyEstimate estimate = smoother.smooth(frame.timestamp, estimator->estimate(radiance));
      SkyState state;
      state.sequence = ++sequence;
      state.frame_timestamp = frame.timestamp;
      state.utc = frame.utc;
      state.received = now_seconds();
      state.S = sky::layer_radiances(estimate.luminance);
      if (estimate.sun) {
        state.sun = render::SunLight{estimate.sun->direction, estimate.sun->energy};
        state.sun_angular_radius = estimate.sun->angular_radius;
        state.sun_clipped = estimate.sun->clipped;
      }
      state.sun_reason = estimate.sun_reason;
      state.unseen_faces = estimate.luminance.unseen_faces;
      state.bad_pixels = estimate.luminance.nan_pixels + estimate.luminance.inf_pixels + estimate.luminance.negative_pixels;
      state.clipped_pixels = estimate.luminance.clipped_pixels;
      state.estimate_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      // The sun's shadow map for a sun that moved, complete before the sky is handed over.
      if (state.sun && shadow_maps && sun_moved(shadow_direction, state.sun->direction, state.sun_angular_radius)) {
        const auto sun_start = Clock::now();
        SunShadowHandle map = sun_maps.draw(state.sun->direction, shadow_angular_radius(state.sun_angular_radius));
        if (!map) break;  // closed: the service is stopping
        last_map = std::move(map);
        shadow_direction = state.sun->direction;
        ++sun_revision;
        if (cpu) {
          for (std::size_t j = 0; j < visibility.size(); ++j) {
            visibility[j] = std::make_shared<const std::vector<float>>(last_map->map().read_visibility(static_cast<int>(j)));
          }
        }
        state.sun_visibility_ms = std::chrono::duration<double, std::milli>(Clock::now() - sun_start).count();
      }
      if (state.sun) state.sun_map = last_map;
      if (cpu) {
        // T of every plane for this S and sun, now, so that the render thread only uploads it.
        const auto blend_start = Clock::now();
        state.sun_visibility = visibility;
        state.sun_revision = sun_revision;
        for (std::size_t j = 0; j < cpu_blends.size(); ++j) {
          if (config.blend.cull_planes && !plane_views[j].in_view) {
            ++plane_views[j].blends_out_of_view;
            state.shadow_ratios.push_back(nullptr);
            continue;
          }
          const render::BlendWeights weights = render::blend_weights(bases[j], state.S, state.sun);
          const std::span<const float> sun_visibility =
              shadow_maps && visibility[j] ? std::span<const float>(*visibility[j]) : std::span<const float>();
          std::lock_guard blend_lock(cpu_blends[j]->mutex);
          const bool ran = cpu_blends[j]->ratios.blend(weights, sun_visibility, sun_revision, workers.get());
          ++(ran ? counters.blends_run : counters.blends_skipped);
          state.shadow_ratios.push_back(cpu_blends[j]->ratios.rgba());
        }
        state.cpu_blend_ms = std::chrono::duration<double, std::milli>(Clock::now() - blend_start).count();
        std::lock_guard lock(stats_mutex);
        blend_times.add(state.cpu_blend_ms / 1e3, now_seconds());
      }
      if (state.sun_visibility_ms > 0) {
        std::lock_guard lock(stats_mutex);
        sky_sun_visibility_times.add(state.sun_visibility_ms / 1e3, now_seconds());
      }
      ++counters.sky_estimates;
      if (status && state.received - last_overlay >= 1.0) {
        last_overlay = state.received;
        sky_jpeg.set(encode_jpeg(sky::draw_sky_overlay(estimator->lens(), *dome, radiance.radiance, estimate)));
      }
      {
        SkyState for_status = state;
        for_status.sun_map = nullptr;  // /status holds no map: a slot is free once the render thread is done with it
        latest_sky.set(std::move(for_status));
      }
      sky_box.put(std::move(state));
    } catch (const std::exception& e) {
      ++counters.sky_errors;
    }
  }
}

void Service::State::camera_loop() {
  while (running) {
    try {
      const auto asked = Clock::now();
      capture::FrameResult result = camera_source->next(0.2);
      pause_after_quick_not_yet(result, asked);
      if (result.status == capture::FrameStatus::Ready) {
        ++counters.camera_frames;
        camera_activity.frame();
        camera_rate.add(result.frame.timestamp);
        // The marker tracker runs here, before the frame is handed over, rather than on a thread
        // of its own: it costs about 3 ms a 1280×720 frame on one core (bench/RESULTS.md,
        // Tracking), a tenth of a 30 Hz frame's interval, and so the render thread always finds
        // the pose of the very frame it draws (a tracking thread would give it the previous
        // frame's pose, or make it wait). Every frame is tracked, even those the renderer drops.
        tracking->on_camera_frame(result.frame.image, result.frame.timestamp);
        camera_arrivals.put(result.frame.timestamp, now_seconds());
        camera_box.put(std::move(result.frame));
      } else if (result.status == capture::FrameStatus::EndOfStream) {
        camera_activity.ended = true;
        camera_rate.end();
        camera_box.close();  // a finite recording has ended: the render thread finishes
        return;
      }
    } catch (const std::exception&) {
      ++counters.camera_errors;
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
}

std::int64_t Service::run() {
  State& s = *state_;
  // The GL context: a window on the display, or none (headless). Declared first, so that every
  // GL object below is destroyed while it is still current.
  std::optional<gpu::HeadlessContext> headless;
  std::unique_ptr<gpu::WindowContext> window;
  std::optional<render::HmdProfile> hmd_profile;
  if (s.options.headless) {
    headless.emplace();
  } else {
    gpu::WindowOptions window_options;
    window_options.width = s.hmd_calibration.image_width;
    window_options.height = s.hmd_calibration.image_height;
    window_options.title = "skylit-live: " + s.config.file.filename().string();
    if (s.config.display) {
      // The HMD display (docs/hmd.md): a window of the panel's size, or full screen on the monitor.
      hmd_profile = render::load_hmd_profile(s.config.display->profile);
      window_options.width = hmd_profile->panel_width;
      window_options.height = hmd_profile->panel_height;
      window_options.monitor = s.config.display->monitor;
    }
    window = std::make_unique<gpu::WindowContext>(window_options);
  }
  if (!s.options.quiet) {
    std::fprintf(stderr, "skylit-live: GPU %s\n", (window ? window->description() : headless->description()).c_str());
  }

  // Where T is blended: a software renderer (no GPU) blends far slower than the CPU blend does.
  s.renderer = gl_renderer();
  const BlendDevice setting = s.config.blend.device;
  const bool cpu = setting == BlendDevice::Cpu || (setting == BlendDevice::Auto && software_renderer(s.renderer));
  s.blend_on_cpu = cpu;
  s.blend_decided = true;
  if (!s.options.quiet) {
    std::fprintf(stderr, "skylit-live: blend on the %s (blend.device %s; GL renderer %s%s)\n", cpu ? "CPU" : "GPU",
                 blend_device_name(setting).c_str(), s.renderer.c_str(),
                 software_renderer(s.renderer) ? ", a software one" : "");
  }

  // The sun's shadow map (the building's own sun shadow, and with the GPU blend the planes' V)
  // is drawn by the sky thread in a context that shares this one's objects: this thread switches
  // to each finished map (its GL commands wait on the map's fence) and fences its last use of
  // the one before, which the sky thread then redraws for a later sun (sun_shadow_exchange.hpp).
  s.share_group = gpu::HeadlessContext::current_share_group();
  SunShadowHandle sun_map;  // the map this thread draws with
  std::vector<std::unique_ptr<render::GpuBlender>> blenders;     // blend.device gpu
  std::vector<ShadowRatioTexture> cpu_ratios;                     // blend.device cpu
  // The CPU blend's T each texture holds (kept alive, so that a new T never shares its address).
  std::vector<std::shared_ptr<const std::vector<float>>> uploaded(s.bases.size());
  std::vector<GLuint> ratios;
  if (cpu) {
    for (const auto& basis : s.bases) {
      cpu_ratios.emplace_back(basis.width, basis.height);
      ratios.push_back(cpu_ratios.back().get());
    }
  } else {
    render::GpuBlendOptions blend_options;
    blend_options.storage = s.config.blend.storage == BlendSettings::Storage::Unorm8 ? render::BasisStorage::Unorm8
                            : s.config.blend.storage == BlendSettings::Storage::Eac  ? render::BasisStorage::Eac11
                                                                                     : render::BasisStorage::Half;
    blend_options.skip_threshold = s.config.blend.skip_threshold;
    blend_options.change_threshold = s.config.blend.change_threshold;
    for (const auto& basis : s.bases) {
      blenders.push_back(std::make_unique<render::GpuBlender>(basis, blend_options));
      ratios.push_back(blenders.back()->shadow_ratio_texture());
    }
  }
  render::CompositorOptions compositor_options;
  compositor_options.photometric.scale = s.config.photometric.scale;
  compositor_options.lens.render_scale = s.config.render.scale;
  render::Compositor compositor(s.site, s.mesh, s.manifest, s.transfer, s.hmd_calibration, compositor_options);
  std::optional<CameraTexture> camera_texture;
  if (window) camera_texture.emplace();
  std::optional<render::HmdDistortion> hmd;
  if (window && hmd_profile) hmd.emplace(*hmd_profile);
  const bool stereo = hmd && s.config.display->stereo;
  if (hmd && !s.options.quiet) {
    std::fprintf(stderr, "skylit-live: HMD display '%s': %s, %d×%d panel%s%s\n", hmd_profile->name.c_str(),
                 stereo ? "stereo (a render per eye)" : "mono", hmd_profile->panel_width, hmd_profile->panel_height,
                 s.config.display->monitor.empty() ? ", in a window" : ", full screen on ",
                 s.config.display->monitor.c_str());
  }
  // Shows a texture of the camera's size (row 0 the top): through the HMD's lenses, or as it is.
  auto present = [&](GLuint texture, int width, int height) {
    if (hmd) {
      hmd->draw(std::span<const GLuint>(&texture, 1), width, height);
      window->present(hmd->panel_texture(), hmd_profile->panel_width, hmd_profile->panel_height);
    } else {
      window->present(texture, width, height);
    }
  };
  std::optional<int> reference_plane;
  if (s.config.photometric.plane) {
    for (std::size_t j = 0; j < s.manifest.planes.size(); ++j) {
      if (s.manifest.planes[j].plane.name == *s.config.photometric.plane) reference_plane = static_cast<int>(j);
    }
    if (!reference_plane) {
      throw InputError(input_message(s.config.file, -1, -1, "photometric.estimate.plane",
                                     "no plane '" + *s.config.photometric.plane + "' in the bake",
                                     "name one of the site's planes"));
    }
  }

  std::optional<Recorder> recorder;
  const fs::path record = s.options.record ? *s.options.record : s.config.output.record;
  if (!record.empty()) recorder.emplace(record, s.config.output.record_fps, configured_rate(s.config.camera.source));

  // The sky thread sets up (with the CPU blend: its threads and GL context) before the first frame.
  std::promise<void> sky_ready;
  s.sky_thread = std::thread([&s, &sky_ready] { s.sky_loop(sky_ready); });
  sky_ready.get_future().get();
  s.camera_thread = std::thread([&s] { s.camera_loop(); });

  // blend.cull_planes: which planes this frame's view can see (every eye's, in stereo), through
  // the compositor's pinhole view, which holds every ray it draws; a plane's box is grown by the
  // cover distance, within which a building fragment takes the plane's T.
  const std::size_t plane_count = s.bases.size();
  render::PlaneViewOptions view_options;
  view_options.thickness = compositor_options.cover_distance;
  const double ipd = stereo && hmd_profile ? hmd_profile->ipd : 0.0;
  auto plane_seen = [&](std::size_t j, const render::CameraPose& pose) {
    const geom::Plane& plane = s.manifest.planes[j].plane;
    const render::PinholeCamera& view = compositor.lens_remap().pinhole;
    if (render::plane_in_view(plane, pose, view, view_options)) return true;
    if (!stereo) return false;
    return render::plane_in_view(plane, render::eye_pose(pose, ipd, 0), view, view_options) ||
           render::plane_in_view(plane, render::eye_pose(pose, ipd, 1), view, view_options);
  };
  std::vector<char> in_view(plane_count, 1);
  // Planes whose T is not that of the current sky: with the GPU blend, every plane when a sky
  // comes, until it is blended; with the CPU blend, those the sky thread left out of view. A
  // plane is blended before the first frame that can see it.
  std::vector<char> behind_sky(plane_count, 0);

  std::optional<SkyState> sky;
  std::optional<render::CameraPose> last_pose;
  std::int64_t frames = 0;
  // The photometric scale is first estimated on the first frame with a sky (until then the
  // configured scale would show the building far too bright or dark), then every `every` frames.
  std::optional<std::int64_t> last_photometric_estimate;
  double last_progress = 0;
  bool said_waiting = false;
  while (s.running) {
    std::optional<capture::Frame> frame = s.camera_box.take(std::chrono::milliseconds(200));
    if (window) {
      window->poll_events();  // the window stays responsive while no frame comes
      if (window->close_requested()) break;
    }
    if (!frame) {
      if (s.camera_box.closed()) break;
      continue;
    }
    const auto frame_start = Clock::now();

    // The newest sky, when one came: the sun's shadow map, then T (blended on the GPU here, or
    // on the CPU by the sky thread and uploaded here).
    double sun_shadow_ms = 0, blend_ms = 0, upload_ms = 0;
    bool sky_changed = false;
    if (auto fresh = s.sky_box.try_take()) {
      sky_changed = true;
      SunShadowHandle fresh_map = std::move(fresh->sun_map);
      sky = std::move(fresh);
      if (fresh_map && fresh_map != sun_map) {
        // A new sun's map, complete: switch to it (no drawing here, whatever the sun did).
        const auto sun_start = Clock::now();
        fresh_map->wait();
        s.sun_maps.release(sun_map);
        sun_map = std::move(fresh_map);
        if (s.options.profile) glFinish();
        sun_shadow_ms = std::chrono::duration<double, std::milli>(Clock::now() - sun_start).count();
      }
      const auto t0 = Clock::now();
      for (std::size_t j = 0; j < plane_count; ++j) {
        const std::shared_ptr<const std::vector<float>> rgba =
            cpu && j < sky->shadow_ratios.size() ? sky->shadow_ratios[j] : nullptr;
        behind_sky[j] = rgba == nullptr;
        if (rgba == nullptr || rgba == uploaded[j]) continue;
        cpu_ratios[j].upload(*rgba);
        uploaded[j] = rgba;
      }
      if (s.options.profile) glFinish();
      if (cpu) upload_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      if (!s.sky_drawn && !s.options.quiet) std::fprintf(stderr, "\rskylit-live: the sky is known: drawing the building\n");
      s.sky_drawn = true;
    }
    if (!sky) {
      ++s.counters.frames_without_sky;
      if (!said_waiting && !s.options.quiet) {
        std::fprintf(stderr, "skylit-live: waiting for sky: showing the camera image only\n");
      }
      said_waiting = true;
    }

    // The frame is shown after the time it has waited since it came and the time a frame takes
    // to draw (the median of the last ones): the latency the pipeline adds, for status.
    double display_delay = 0;
    const std::optional<double> arrived = s.camera_arrivals.find(frame->timestamp);
    if (arrived) {
      std::lock_guard lock(s.stats_mutex);
      display_delay = now_seconds() - *arrived + s.frame_times.percentile(0.5);
    }
    std::optional<track::Pose> pose = s.tracking->pose_for_frame(frame->timestamp, display_delay);
    if (pose) {
      render::CameraPose camera_pose;
      camera_pose.R_site_from_camera = pose->R_site_from_camera.toRotationMatrix();
      camera_pose.t_site_from_camera = pose->t_site_from_camera;
      last_pose = camera_pose;
    } else {
      ++s.counters.pose_missing;
    }
    // Which planes this frame can show (before the first pose: all of them); the sky thread
    // leaves the others out of its next blends.
    if (last_pose) {
      for (std::size_t j = 0; j < plane_count; ++j) {
        in_view[j] = !s.config.blend.cull_planes || plane_seen(j, *last_pose);
        s.plane_views[j].in_view = in_view[j] != 0;
      }
    }
    // T of the current sky for every plane in view that lacks it (GPU: blended here; CPU: a plane
    // the sky thread left out, blended here on the CPU before it is drawn).
    if (sky) {
      const auto t0 = Clock::now();
      int blended = 0;
      for (std::size_t j = 0; j < plane_count; ++j) {
        if (!behind_sky[j]) continue;
        if (!in_view[j]) {
          if (sky_changed && !cpu) ++s.plane_views[j].blends_out_of_view;  // the sky thread counts its own
          continue;
        }
        const render::BlendWeights weights = render::blend_weights(s.bases[j], sky->S, sky->sun);
        bool ran = false;
        if (cpu) {
          std::shared_ptr<const std::vector<float>> rgba;
          {
            SharedCpuBlend& shared = *s.cpu_blends[j];
            std::lock_guard blend_lock(shared.mutex);
            const std::span<const float> sun_visibility = j < sky->sun_visibility.size() && sky->sun_visibility[j]
                                                              ? std::span<const float>(*sky->sun_visibility[j])
                                                              : std::span<const float>();
            ran = shared.ratios.blend(weights, sun_visibility, sky->sun_revision, nullptr);
            rgba = shared.ratios.rgba();
          }
          if (rgba && rgba != uploaded[j]) {
            cpu_ratios[j].upload(*rgba);
            uploaded[j] = rgba;
          }
          ++s.plane_views[j].blends_on_return;
        } else {
          ran = blenders[j]->blend(weights, weights.sun.isZero(0) || !sun_map ? nullptr : &sun_map->map().visibility(static_cast<int>(j)));
          if (!sky_changed) ++s.plane_views[j].blends_on_return;
        }
        ++(ran ? s.counters.blends_run : s.counters.blends_skipped);
        behind_sky[j] = 0;
        ++blended;
      }
      if (blended > 0) {
        if (s.options.profile) glFinish();
        // The CPU blend's `blend` stage is the sky thread's; a plane blended here as it came
        // back into view counts with the upload of T, the render thread's share of the CPU blend.
        (cpu ? upload_ms : blend_ms) += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      }
    }
    // Without a pose the building fades out at the last one; a pose back after a loss fades it
    // in from nothing (BuildingFade), so it never jumps to the new pose at full opacity.
    const double opacity = s.fade->next(pose.has_value(), frame->timestamp);
    // Before the sky is known the building would be drawn unlit (black): the camera image alone.
    if (sky && !last_pose) continue;  // nothing to draw from yet

    const auto t1 = Clock::now();
    cv::Mat composite;
    // With tracking lost and the building faded out, the frame is the camera image unchanged,
    // which the compositor would give at opacity 0 (tested): shown as it is, without its passes.
    if (!sky || opacity <= 0.0) {
      composite = frame->image;
      if (window) present(camera_texture->upload(composite), composite.cols, composite.rows);
    } else {
      render::CompositeInput input;
      input.camera = frame->image;
      input.pose = *last_pose;
      input.sky = sky->S;
      input.sun = sky->sun;
      input.shadow_ratios = ratios;
      input.sun_shadow = sky->sun && sun_map ? &sun_map->map() : nullptr;
      input.opacity = opacity;
      if (reference_plane &&
          (!last_photometric_estimate || frames - *last_photometric_estimate >= s.config.photometric.every)) {
        last_photometric_estimate = frames;
        const cv::Mat region = compositor.region_mask(*reference_plane, s.config.photometric.region[0],
                                                      s.config.photometric.region[1], s.config.photometric.region[2],
                                                      s.config.photometric.region[3], *last_pose);
        const sky::RadianceFrame linear = sky::linearise(frame->image, sky::ResponseCurve::srgb(8), {});
        const render::PhotometricEstimate found = render::estimate_photometric_match(
            linear.radiance, region,
            render::plane_irradiance(s.manifest.planes[static_cast<std::size_t>(*reference_plane)], sky->S, sky->sun),
            s.config.photometric.albedo);
        if (found.ok) {
          std::lock_guard lock(s.stats_mutex);
          s.photometric = found.match;
        }
      }
      {
        std::lock_guard lock(s.stats_mutex);
        input.photometric = s.photometric;
      }
      // Read back only what someone takes: the recorder, /frame.jpg. A window shows the GPU's copy.
      // The recorder and /frame.jpg take the undistorted composite from the camera's own pose;
      // in stereo the HMD gets one composite per eye besides.
      if (recorder || s.status || !window) {
        composite = compositor.composite(input);
      } else if (!stereo) {
        compositor.draw(input);
      }
      if (stereo) {
        render::draw_hmd_frame(compositor, *hmd, input, render::StereoMode::stereo);
        window->present(hmd->panel_texture(), hmd_profile->panel_width, hmd_profile->panel_height);
      } else if (window) {
        present(compositor.display_texture(), s.hmd_calibration.image_width, s.hmd_calibration.image_height);
      }
    }
    const double composite_ms = std::chrono::duration<double, std::milli>(Clock::now() - t1).count();
    const auto t2 = Clock::now();
    if (recorder) {
      RecordedFrame info;
      info.timestamp = frame->timestamp;
      if (sky) {
        info.sky_timestamp = sky->frame_timestamp;
        info.sky_utc = sky->utc;
        if (sky->sun) info.sun_direction = sky->sun->direction;
        info.opacity = opacity;
      }
      recorder->write(composite, info, s.camera_rate.rate());
    }
    if (s.status) s.latest_frame.set(composite);
    const double record_ms = std::chrono::duration<double, std::milli>(Clock::now() - t2).count();
    ++frames;
    ++s.counters.frames;
    const double end = now_seconds();
    {
      std::lock_guard lock(s.stats_mutex);
      s.frame_times.add(std::chrono::duration<double>(Clock::now() - frame_start).count(), end);
      if (sky_changed) s.sky_change_frame_times.add(std::chrono::duration<double>(Clock::now() - frame_start).count(), end);
      if (arrived) s.latency_times.add(end - *arrived, end);
      if (sun_shadow_ms > 0) s.sun_shadow_times.add(sun_shadow_ms / 1e3, end);
      if (blend_ms > 0) s.blend_times.add(blend_ms / 1e3, end);
      if (upload_ms > 0) s.upload_times.add(upload_ms / 1e3, end);
      s.composite_times.add(composite_ms / 1e3, end);
      s.record_times.add(record_ms / 1e3, end);
      if (recorder) s.record_fps = recorder->fps();
    }
    if (!s.options.quiet && end - last_progress > 1.0) {
      last_progress = end;
      std::lock_guard lock(s.stats_mutex);
      std::fprintf(stderr, "\rskylit-live: %lld frames, %.1f frames/s, p50 %.1f ms%s   ", static_cast<long long>(frames),
                   s.frame_times.rate(), 1e3 * s.frame_times.percentile(0.5), sky ? "" : " (waiting for sky)");
    }
    if (s.options.frames && frames >= *s.options.frames) break;
  }
  s.running = false;
  s.camera_box.close();
  s.sun_maps.release(sun_map);  // the sky thread destroys the maps once this thread's frames are done with them
  s.sun_maps.close();
  if (s.sky_thread.joinable()) s.sky_thread.join();
  if (s.camera_thread.joinable()) s.camera_thread.join();
  if (recorder) {
    recorder->finish(s.camera_rate.rate());
    std::lock_guard lock(s.stats_mutex);
    s.record_fps = recorder->fps();
  }
  if (!s.options.quiet) std::fprintf(stderr, "\n");
  return frames;
}

// A source's connection: running, reconnecting (down, reopened with backoff) or ended (a finite
// source has no more frames); reopening attempts (successful or not), the last failure's message
// and the time since its last frame.
nlohmann::json Service::State::source_report(const capture::FrameSource& source,
                                             const capture::ReconnectingSource* reconnecting,
                                             const SourceActivity& activity, double now) const {
  nlohmann::json j;
  j["source"] = source.describe();
  const std::optional<capture::ReconnectStatus> link =
      reconnecting ? std::optional(reconnecting->status()) : std::nullopt;
  j["state"] = link && !link->connected ? "reconnecting" : activity.ended ? "ended" : "running";
  j["reconnect_attempts"] = link ? link->reconnects + link->failed_attempts : 0;
  j["reconnects"] = link ? link->reconnects : 0;
  j["last_error"] = link ? link->last_error : std::string();
  if (link && !link->connected) j["next_attempt_in_s"] = link->next_attempt_in_s;
  const double last = activity.last_frame;
  j["seconds_since_frame"] = last < 0 ? nlohmann::json(nullptr) : nlohmann::json(now - last);
  return j;
}

nlohmann::json Service::State::status_report() const {
  nlohmann::json j;
  const double now = now_seconds();
  j["uptime_s"] = now - started;
  // Before the first sky the building is not drawn: its shading and shadows need S.
  j["state"] = sky_drawn ? "running" : "waiting for sky";
  {
    std::lock_guard lock(stats_mutex);
    j["frame_rate"] = frame_times.rate();
    j["frame_time_ms"] = {{"p50", 1e3 * frame_times.percentile(0.5)}, {"p99", 1e3 * frame_times.percentile(0.99)}};
    j["latency_ms"] = {{"p50", 1e3 * latency_times.percentile(0.5)}, {"p99", 1e3 * latency_times.percentile(0.99)}};
    j["sky_change_frame_ms"] = {{"p50", 1e3 * sky_change_frame_times.percentile(0.5)},
                                {"p99", 1e3 * sky_change_frame_times.percentile(0.99)}};
    j["stage_ms_p50"] = {{"sun_shadow", 1e3 * sun_shadow_times.percentile(0.5)},
                         {"blend", 1e3 * blend_times.percentile(0.5)},
                         {"upload", 1e3 * upload_times.percentile(0.5)},
                         {"sky_sun_visibility", 1e3 * sky_sun_visibility_times.percentile(0.5)},
                         {"composite", 1e3 * composite_times.percentile(0.5)},
                         {"record", 1e3 * record_times.percentile(0.5)}};
    if (photometric) j["photometric_scale"] = {photometric->scale.x(), photometric->scale.y(), photometric->scale.z()};
    if (record_fps > 0) j["record_fps"] = record_fps;
  }
  j["frames"] = counters.frames.load();
  j["frames_without_sky"] = counters.frames_without_sky.load();
  j["dropped_frames"] = camera_box.overwritten();
  nlohmann::json camera_json = source_report(*camera_source, camera_reconnecting, camera_activity, now);
  camera_json["frames"] = counters.camera_frames.load();
  camera_json["malformed"] = camera_source->counts().dropped();
  camera_json["errors"] = counters.camera_errors.load();
  const FrameRate rate = camera_rate.rate();
  camera_json["frame_rate_hz"] = rate.hz ? nlohmann::json(*rate.hz) : nlohmann::json(nullptr);
  j["camera"] = camera_json;
  nlohmann::json pose_json = tracking->report();
  pose_json["missing"] = counters.pose_missing.load();
  pose_json["fade"] = {{"state", to_string(fade->state())}, {"opacity", fade->opacity()}, {"fade_s", fade->fade_s()}};
  j["pose"] = pose_json;
  // How much of the building (and its shadows) the frames show: 1 tracked, 0 lost (BuildingFade).
  j["opacity"] = fade->opacity();
  nlohmann::json sky_json = source_report(*sky_source, sky_reconnecting, sky_activity, now);
  sky_json["frames"] = counters.sky_frames.load();
  sky_json["estimates"] = counters.sky_estimates.load();
  sky_json["malformed"] = sky_source->counts().dropped();
  sky_json["errors"] = counters.sky_errors.load();
  std::vector<std::string> flags;
  if (camera_json["state"] == "reconnecting") flags.push_back("camera_reconnecting");
  if (sky_json["state"] == "reconnecting") flags.push_back("sky_reconnecting");
  if (const auto latest = latest_sky.get()) {
    const double age = now - latest->received;
    sky_json["age_s"] = age;
    sky_json["utc"] = latest->utc ? nlohmann::json(sky::format_utc(*latest->utc)) : nlohmann::json(nullptr);
    sky_json["estimate_ms"] = latest->estimate_ms;
    nlohmann::json S = nlohmann::json::array();
    for (const auto& v : latest->S) S.push_back({v.x(), v.y(), v.z()});
    sky_json["S"] = S;
    sky_json["unseen_faces"] = latest->unseen_faces;
    sky_json["bad_pixels"] = latest->bad_pixels;
    sky_json["clipped_pixels"] = latest->clipped_pixels;
    sky_json["sun_reason"] = latest->sun_reason;
    if (latest->sun) {
      const auto& d = latest->sun->direction;
      sky_json["sun"] = {{"direction", {d.x(), d.y(), d.z()}},
                         {"elevation_deg", std::asin(std::clamp(d.z(), -1.0, 1.0)) * 180 / M_PI},
                         {"azimuth_deg", std::atan2(d.x(), d.y()) * 180 / M_PI},
                         {"energy", {latest->sun->energy.x(), latest->sun->energy.y(), latest->sun->energy.z()}},
                         {"angular_radius_deg", latest->sun_angular_radius * 180 / M_PI},
                         {"clipped", latest->sun_clipped}};
      if (latest->sun_clipped) flags.push_back("sun_clipped");
    } else {
      sky_json["sun"] = nullptr;
    }
    if (age > config.sky.stale_after) flags.push_back("sky_stale");
    if (latest->unseen_faces > 0) flags.push_back("faces_unseen");
    if (latest->bad_pixels > 0) flags.push_back("bad_pixels");
  } else {
    sky_json["age_s"] = nullptr;
    flags.push_back("no_sky_yet");
  }
  tracking->add_flags(flags);
  if (const BuildingFade::State state = fade->state(); state == BuildingFade::State::FadingOut || state == BuildingFade::State::Hidden) {
    flags.push_back("pose_lost");  // the building fades out, or is hidden, until a pose returns
  }
  j["sky"] = sky_json;
  j["blends"] = {{"run", counters.blends_run.load()}, {"skipped", counters.blends_skipped.load()}};
  // The sun's shadow maps, all drawn on the sky thread: drawn, switched to by the render thread
  // (a skipped one was overtaken by a newer sun before a frame took it), and draws that waited
  // for the render thread to free a map.
  const SunShadowExchange::Counts maps = sun_maps.counts();
  j["sun_shadow_maps"] = {{"drawn_on", "sky thread"}, {"drawn", maps.drawn}, {"taken", maps.taken},
                          {"slot_waits", maps.slot_waits}};
  nlohmann::json blend_json;
  blend_json["setting"] = blend_device_name(config.blend.device);
  blend_json["basis"] = config.blend.basis == BlendSettings::Basis::Pca    ? "pca"
                        : config.blend.basis == BlendSettings::Basis::Lean ? "lean"
                        : config.blend.basis == BlendSettings::Basis::Cropped ? "cropped"
                                                                          : "full";
  nlohmann::json planes_json = nlohmann::json::array();
  for (std::size_t k = 0; k < bases.size() && k < manifest.planes.size(); ++k) {
    nlohmann::json plane;
    plane["name"] = manifest.planes[k].plane.name;
    plane["layers"] = bases[k].layers;                  // the images each blend sums
    plane["source_layers"] = bases[k].source_layers();  // the dome's layers S is given for
    if (config.blend.basis == BlendSettings::Basis::Pca && manifest.planes[k].pca) plane["max_error"] = manifest.planes[k].pca->max_error;
    // blend.cull_planes: whether the latest pose can see the plane, the blends of new skies left
    // out while it could not, and those run as it came back into view.
    plane["in_view"] = plane_views[k].in_view.load();
    plane["blends_out_of_view"] = plane_views[k].blends_out_of_view.load();
    plane["blends_on_return"] = plane_views[k].blends_on_return.load();
    planes_json.push_back(plane);
  }
  blend_json["planes"] = planes_json;
  blend_json["cull_planes"] = config.blend.cull_planes;
  if (blend_decided) {
    blend_json["device"] = blend_on_cpu ? "cpu" : "gpu";
    blend_json["renderer"] = renderer;
    blend_json["software_renderer"] = software_renderer(renderer);
  } else {
    blend_json["device"] = nullptr;  // decided when run() has its GL context
  }
  j["blend"] = blend_json;
  j["flags"] = flags;
  return j;
}

std::string Service::status_json() const { return state_->status_report().dump(2) + "\n"; }

std::string Service::metrics_text() const {
  const State& s = *state_;
  const nlohmann::json j = s.status_report();
  std::vector<Metric> m;
  m.push_back({"skylit_frames_total", "Frames composited.", "counter", double(s.counters.frames.load()), ""});
  m.push_back({"skylit_dropped_frames_total", "Camera frames replaced before the renderer took them.", "counter",
               double(s.camera_box.overwritten()), ""});
  m.push_back({"skylit_camera_frames_total", "Camera frames received.", "counter", double(s.counters.camera_frames.load()), ""});
  m.push_back({"skylit_camera_malformed_total", "Camera frames dropped as malformed.", "counter",
               double(s.camera_source->counts().dropped()), ""});
  m.push_back({"skylit_sky_frames_total", "Sky frames received.", "counter", double(s.counters.sky_frames.load()), ""});
  m.push_back({"skylit_sky_estimates_total", "Sky estimates made.", "counter", double(s.counters.sky_estimates.load()), ""});
  m.push_back({"skylit_sky_malformed_total", "Sky frames dropped as malformed.", "counter",
               double(s.sky_source->counts().dropped()), ""});
  m.push_back({"skylit_pose_missing_total", "Frames without a pose at their time.", "counter",
               double(s.counters.pose_missing.load()), ""});
  m.push_back({"skylit_blends_total", "Plane blends run.", "counter", double(s.counters.blends_run.load()), "result=\"run\""});
  m.push_back({"skylit_blends_total", "Plane blends run.", "counter", double(s.counters.blends_skipped.load()), "result=\"skipped\""});
  m.push_back({"skylit_frame_rate", "Frames per second over the last 600 frames.", "gauge", j["frame_rate"].get<double>(), ""});
  m.push_back({"skylit_frame_time_seconds", "Frame time percentiles over the last 600 frames.", "gauge",
               j["frame_time_ms"]["p50"].get<double>() / 1e3, "quantile=\"0.5\""});
  m.push_back({"skylit_frame_time_seconds", "Frame time percentiles over the last 600 frames.", "gauge",
               j["frame_time_ms"]["p99"].get<double>() / 1e3, "quantile=\"0.99\""});
  const auto& sky = j["sky"];
  m.push_back({"skylit_sky_age_seconds", "Age of the newest sky estimate.", "gauge",
               sky["age_s"].is_null() ? std::numeric_limits<double>::infinity() : sky["age_s"].get<double>(), ""});
  m.push_back({"skylit_sun_detected", "1 while the newest sky has a sun.", "gauge", sky.contains("sun") && !sky["sun"].is_null() ? 1.0 : 0.0, ""});
  if (sky.contains("S")) {
    const char* channels[3] = {"r", "g", "b"};
    for (std::size_t i = 0; i < sky["S"].size(); ++i) {
      for (int c = 0; c < 3; ++c) {
        m.push_back({"skylit_sky_luminance", "Luminance parameter S per bake layer and channel.", "gauge",
                     sky["S"][i][static_cast<std::size_t>(c)].get<double>(),
                     "layer=\"" + std::to_string(i) + "\",channel=\"" + channels[c] + "\""});
      }
    }
  }
  for (const char* name : {"camera", "sky"}) {
    const auto& source = j[name];
    const std::string label = std::string("source=\"") + name + "\"";
    for (const char* state : {"running", "reconnecting", "ended"}) {
      m.push_back({"skylit_source_state", "1 for the state each source is in (running, reconnecting, ended).", "gauge",
                   source["state"] == state ? 1.0 : 0.0, label + ",state=\"" + state + "\""});
    }
    m.push_back({"skylit_source_reconnect_attempts_total", "Attempts at reopening a source that failed.", "counter",
                 source["reconnect_attempts"].get<double>(), label});
    m.push_back({"skylit_source_seconds_since_frame", "Seconds since the source's last frame (+Inf before the first).", "gauge",
                 source["seconds_since_frame"].is_null() ? std::numeric_limits<double>::infinity()
                                                         : source["seconds_since_frame"].get<double>(),
                 label});
  }
  m.push_back({"skylit_building_opacity", "How much of the building and its shadows is shown: 1 tracked, 0 tracking lost.",
               "gauge", s.fade->opacity(), ""});
  m.push_back({"skylit_waiting_for_sky", "1 while no sky is known (the camera image is shown alone).", "gauge",
               j["state"] == "waiting for sky" ? 1.0 : 0.0, ""});
  if (!j["blend"]["device"].is_null()) {
    m.push_back({"skylit_blend_on_cpu", "1 when the shadow ratios are blended on the CPU, 0 on the GPU.", "gauge",
                 j["blend"]["device"] == "cpu" ? 1.0 : 0.0, ""});
  }
  for (const auto& plane : j["blend"]["planes"]) {
    const std::string label = "plane=\"" + plane["name"].get<std::string>() + "\"";
    m.push_back({"skylit_plane_in_view", "1 while the latest pose can see the plane (blend.cull_planes).", "gauge",
                 plane["in_view"].get<bool>() ? 1.0 : 0.0, label});
    m.push_back({"skylit_plane_blends_out_of_view_total", "Blends of a new sky left out, the plane out of view.",
                 "counter", plane["blends_out_of_view"].get<double>(), label});
  }
  s.tracking->add_metrics(m);
  for (const auto& flag : j["flags"]) {
    m.push_back({"skylit_flag", "1 for each condition the status reports.", "gauge", 1.0, "flag=\"" + flag.get<std::string>() + "\""});
  }
  return prometheus_text(m);
}

}  // namespace skylit::live
