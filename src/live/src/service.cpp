#include "skylit/live/service.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

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
#include "skylit/render/compositor.hpp"
#include "skylit/render/cpu_blend.hpp"
#include "skylit/render/gpu_blend.hpp"
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
};

// Composited frames to a video file or a folder of PNGs, with a frame log beside them (CSV, one
// line per frame, flushed as it goes: `live.mp4` → `live.csv`, a folder → its `frames.csv`, which
// the images source reads back).
class Recorder {
 public:
  explicit Recorder(fs::path path) : path_(std::move(path)) {}
  void write(const cv::Mat& frame, double fps, const RecordedFrame& info) {
    const bool video = recorder_kind(path_) == "video";
    std::string file;
    if (video) {
      if (!writer_.isOpened()) {
        if (!path_.parent_path().empty()) fs::create_directories(path_.parent_path());
        const int fourcc = path_.extension() == ".avi" ? cv::VideoWriter::fourcc('M', 'J', 'P', 'G')
                                                       : cv::VideoWriter::fourcc('m', 'p', '4', 'v');
        if (!writer_.open(path_.string(), fourcc, fps, frame.size())) {
          throw InputError("--record " + path_.string() +
                           ": cannot open a video writer (no codec for this extension?); fix: use .avi, or a folder");
        }
      }
      writer_.write(frame);
      file = path_.filename().string();
    } else {
      if (count_ == 0) fs::create_directories(path_);
      char name[32];
      std::snprintf(name, sizeof name, "frame_%06lld.png", static_cast<long long>(count_));
      if (!cv::imwrite((path_ / name).string(), frame)) throw InputError("--record: cannot write " + (path_ / name).string());
      file = name;
    }
    log(file, info);
    ++count_;
  }

 private:
  void log(const std::string& file, const RecordedFrame& info) {
    if (!log_.is_open()) {
      log_.open(frame_log_path(path_));
      if (!log_) throw InputError("--record: cannot write " + frame_log_path(path_).string());
      log_ << "frame,file,timestamp,sky_timestamp,sky_utc,sun_elevation_deg,sun_azimuth_deg\n";
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
    log_ << '\n' << std::flush;  // a process killed hard still leaves a readable log
  }

  fs::path path_;
  cv::VideoWriter writer_;
  std::ofstream log_;
  std::int64_t count_ = 0;
};

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
  std::unique_ptr<track::PoseSource> pose_source;

  // Hand-over.
  Mailbox<SkyState> sky_box;
  Mailbox<capture::Frame> camera_box;
  Latest<SkyState> latest_sky;
  Latest<std::vector<std::uint8_t>> sky_jpeg;
  Latest<cv::Mat> latest_frame;

  // Statistics (render thread writes, status reads).
  mutable std::mutex stats_mutex;
  FrameTimes frame_times{600}, blend_times{600}, composite_times{600}, record_times{600};
  std::optional<render::PhotometricMatch> photometric;
  std::int64_t blend_skipped_layers = 0;

  std::unique_ptr<StatusServer> status;
  std::thread sky_thread, camera_thread;

  void sky_loop();
  void camera_loop();
  nlohmann::json status_report() const;
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
    s.bases.push_back(render::load_basis(config.bake, s.manifest, static_cast<int>(j)));
  }
  s.sky_calibration = sky::load_calibration(config.sky.calibration);
  s.hmd_calibration = sky::load_calibration(config.camera.calibration);
  s.dome = std::make_unique<geom::Dome>(s.manifest.plan.frequency);
  sky::SkyEstimateOptions estimate_options;
  estimate_options.sun_mode = config.sky.sun ? sky::SunMode::Auto : sky::SunMode::Off;
  estimate_options.table.basis = s.manifest.plan.basis;
  s.estimator = std::make_unique<sky::SkyEstimator>(s.sky_calibration, *s.dome, estimate_options);
  s.sky_source = capture::open_source(with_reconnect(config.sky.source));
  s.camera_source = capture::open_source(with_reconnect(config.camera.source));
  s.pose_source = track::open_pose_source(config.pose);
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
}

std::string Service::status_address() const { return state_->status ? state_->status->address() : std::string(); }

void Service::State::sky_loop() {
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
      std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the last S stays (and goes stale)
      continue;
    }
    if (result.status != capture::FrameStatus::Ready) {
      pause_after_quick_not_yet(result, asked);
      continue;
    }
    ++counters.sky_frames;
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
      ++counters.sky_estimates;
      if (status && state.received - last_overlay >= 1.0) {
        last_overlay = state.received;
        sky_jpeg.set(encode_jpeg(sky::draw_sky_overlay(estimator->lens(), *dome, radiance.radiance, estimate)));
      }
      latest_sky.set(state);
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
        camera_box.put(std::move(result.frame));
      } else if (result.status == capture::FrameStatus::EndOfStream) {
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
  if (s.options.headless) {
    headless.emplace();
  } else {
    gpu::WindowOptions window_options;
    window_options.width = s.hmd_calibration.image_width;
    window_options.height = s.hmd_calibration.image_height;
    window_options.title = "skylit-live: " + s.config.file.filename().string();
    window = std::make_unique<gpu::WindowContext>(window_options);
  }
  if (!s.options.quiet) {
    std::fprintf(stderr, "skylit-live: GPU %s\n", (window ? window->description() : headless->description()).c_str());
  }

  std::vector<geom::Plane> planes;
  for (const auto& record : s.manifest.planes) planes.push_back(record.plane);
  render::SunShadowMap shadow_map(s.mesh, planes);
  render::GpuBlendOptions blend_options;
  blend_options.storage = s.config.blend.unorm8 ? render::BasisStorage::Unorm8 : render::BasisStorage::Half;
  blend_options.skip_threshold = s.config.blend.skip_threshold;
  blend_options.change_threshold = s.config.blend.change_threshold;
  std::vector<std::unique_ptr<render::GpuBlender>> blenders;
  std::vector<GLuint> ratios;
  for (const auto& basis : s.bases) {
    blenders.push_back(std::make_unique<render::GpuBlender>(basis, blend_options));
    ratios.push_back(0);  // T = 1 until the first sky
  }
  render::CompositorOptions compositor_options;
  compositor_options.photometric.scale = s.config.photometric.scale;
  render::Compositor compositor(s.site, s.mesh, s.manifest, s.transfer, s.hmd_calibration, compositor_options);
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
  if (!record.empty()) recorder.emplace(record);

  s.sky_thread = std::thread([&s] { s.sky_loop(); });
  s.camera_thread = std::thread([&s] { s.camera_loop(); });

  std::optional<SkyState> sky;
  std::optional<render::CameraPose> last_pose;
  double last_sun_update_direction_dot = -2;
  Eigen::Vector3d shadow_direction = Eigen::Vector3d::Zero();
  std::int64_t frames = 0;
  double last_progress = 0, first_frame_timestamp = -1, last_frame_timestamp = 0;
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
    if (first_frame_timestamp < 0) first_frame_timestamp = frame->timestamp;
    last_frame_timestamp = frame->timestamp;

    // The newest sky, when one came: new weights, the sun's shadow map, the blends.
    double blend_ms = 0;
    if (auto fresh = s.sky_box.try_take()) {
      const auto t0 = Clock::now();
      sky = std::move(fresh);
      if (sky->sun) {
        // The map is redrawn when the sun has moved by more than a tenth of its radius.
        last_sun_update_direction_dot = shadow_direction.dot(sky->sun->direction);
        if (last_sun_update_direction_dot < std::cos(std::max(1e-4, 0.1 * sky->sun_angular_radius))) {
          shadow_map.update(sky->sun->direction, std::max(sky->sun_angular_radius, 0.0047));
          shadow_direction = sky->sun->direction;
        }
      }
      for (std::size_t j = 0; j < blenders.size(); ++j) {
        const render::BlendWeights weights = render::blend_weights(s.bases[j], sky->S, sky->sun);
        const bool ran = blenders[j]->blend(weights, weights.sun.isZero() ? nullptr : &shadow_map.visibility(static_cast<int>(j)));
        ++(ran ? s.counters.blends_run : s.counters.blends_skipped);
        ratios[j] = blenders[j]->shadow_ratio_texture();
      }
      if (s.options.profile) glFinish();
      blend_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    }
    if (!sky) ++s.counters.frames_without_sky;

    std::optional<track::Pose> pose = s.pose_source->pose_at(frame->timestamp);
    if (pose) {
      render::CameraPose camera_pose;
      camera_pose.R_site_from_camera = pose->R_site_from_camera.toRotationMatrix();
      camera_pose.t_site_from_camera = pose->t_site_from_camera;
      last_pose = camera_pose;
    } else {
      ++s.counters.pose_missing;
    }
    if (!last_pose) continue;  // nothing to draw from yet

    const std::vector<Eigen::Vector3d> no_sky(s.manifest.layer_count(), Eigen::Vector3d::Zero());
    render::CompositeInput input;
    input.camera = frame->image;
    input.pose = *last_pose;
    input.sky = sky ? std::span<const Eigen::Vector3d>(sky->S) : std::span<const Eigen::Vector3d>(no_sky);
    input.sun = sky ? sky->sun : std::nullopt;
    input.shadow_ratios = sky ? std::span<const GLuint>(ratios) : std::span<const GLuint>();
    input.sun_shadow = sky && sky->sun ? &shadow_map : nullptr;
    if (reference_plane && sky && frames % s.config.photometric.every == 0) {
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
    const auto t1 = Clock::now();
    // Read back only what someone takes: the recorder, /frame.jpg. A window shows the GPU's copy.
    cv::Mat composite;
    if (recorder || s.status || !window) {
      composite = compositor.composite(input);
    } else {
      compositor.draw(input);
    }
    if (window) window->present(compositor.display_texture(), s.hmd_calibration.image_width, s.hmd_calibration.image_height);
    const double composite_ms = std::chrono::duration<double, std::milli>(Clock::now() - t1).count();
    const auto t2 = Clock::now();
    if (recorder) {
      const double span = last_frame_timestamp - first_frame_timestamp;
      const double fps = frames > 0 && span > 0 ? std::clamp(frames / span, 1.0, 120.0) : 30.0;
      RecordedFrame info;
      info.timestamp = frame->timestamp;
      if (sky) {
        info.sky_timestamp = sky->frame_timestamp;
        info.sky_utc = sky->utc;
        if (sky->sun) info.sun_direction = sky->sun->direction;
      }
      recorder->write(composite, fps, info);
    }
    if (s.status) s.latest_frame.set(composite);
    const double record_ms = std::chrono::duration<double, std::milli>(Clock::now() - t2).count();
    ++frames;
    ++s.counters.frames;
    const double end = now_seconds();
    {
      std::lock_guard lock(s.stats_mutex);
      s.frame_times.add(std::chrono::duration<double>(Clock::now() - frame_start).count(), end);
      if (blend_ms > 0) s.blend_times.add(blend_ms / 1e3, end);
      s.composite_times.add(composite_ms / 1e3, end);
      s.record_times.add(record_ms / 1e3, end);
    }
    if (!s.options.quiet && end - last_progress > 1.0) {
      last_progress = end;
      std::lock_guard lock(s.stats_mutex);
      std::fprintf(stderr, "\rskylit-live: %lld frames, %.1f frames/s, p50 %.1f ms%s   ", static_cast<long long>(frames),
                   s.frame_times.rate(), 1e3 * s.frame_times.percentile(0.5), sky ? "" : " (no sky yet)");
    }
    if (s.options.frames && frames >= *s.options.frames) break;
  }
  s.running = false;
  s.camera_box.close();
  if (s.sky_thread.joinable()) s.sky_thread.join();
  if (s.camera_thread.joinable()) s.camera_thread.join();
  if (!s.options.quiet) std::fprintf(stderr, "\n");
  return frames;
}

nlohmann::json Service::State::status_report() const {
  nlohmann::json j;
  const double now = now_seconds();
  j["uptime_s"] = now - started;
  {
    std::lock_guard lock(stats_mutex);
    j["frame_rate"] = frame_times.rate();
    j["frame_time_ms"] = {{"p50", 1e3 * frame_times.percentile(0.5)}, {"p99", 1e3 * frame_times.percentile(0.99)}};
    j["stage_ms_p50"] = {{"blend", 1e3 * blend_times.percentile(0.5)},
                         {"composite", 1e3 * composite_times.percentile(0.5)},
                         {"record", 1e3 * record_times.percentile(0.5)}};
    if (photometric) j["photometric_scale"] = {photometric->scale.x(), photometric->scale.y(), photometric->scale.z()};
  }
  j["frames"] = counters.frames.load();
  j["frames_without_sky"] = counters.frames_without_sky.load();
  j["dropped_frames"] = camera_box.overwritten();
  j["camera"] = {{"source", camera_source->describe()},
                 {"frames", counters.camera_frames.load()},
                 {"malformed", camera_source->counts().dropped()},
                 {"errors", counters.camera_errors.load()}};
  j["pose"] = {{"source", pose_source->describe()}, {"missing", counters.pose_missing.load()}};
  nlohmann::json sky_json;
  sky_json["source"] = sky_source->describe();
  sky_json["frames"] = counters.sky_frames.load();
  sky_json["estimates"] = counters.sky_estimates.load();
  sky_json["malformed"] = sky_source->counts().dropped();
  sky_json["errors"] = counters.sky_errors.load();
  std::vector<std::string> flags;
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
  j["sky"] = sky_json;
  j["blends"] = {{"run", counters.blends_run.load()}, {"skipped", counters.blends_skipped.load()}};
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
  for (const auto& flag : j["flags"]) {
    m.push_back({"skylit_flag", "1 for each condition the status reports.", "gauge", 1.0, "flag=\"" + flag.get<std::string>() + "\""});
  }
  return prometheus_text(m);
}

}  // namespace skylit::live
