#pragma once
// The service's shared state (Service::State): what it loaded, the threads' hand-over, counters
// and statistics. Each thread's work is in a file of its own: the sky thread (sky_thread.cpp),
// the camera thread (service.cpp), the render thread (render_loop.cpp), /status and /metrics
// (status_report.cpp).
#include <atomic>
#include <cstdint>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

#include "bake_info.hpp"
#include "history.hpp"
#include "skylit/live/jpeg_cache.hpp"
#include "live_tracking.hpp"
#include "recording.hpp"
#include "service_metrics.hpp"
#include "sky_link_receiver.hpp"
#include "sky_stage.hpp"
#include "skylit/bake_format/light_map.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/blend/basis.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/cpu_blender.hpp"
#include "skylit/camera/calibration.hpp"
#include "skylit/camera/stereo_calibration.hpp"
#include "skylit/capture/paired_source.hpp"
#include "skylit/capture/config.hpp"
#include "skylit/capture/frame_source.hpp"
#include "skylit/capture/reconnecting_source.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/live/frame_stats.hpp"
#include "skylit/live/mailbox.hpp"
#include "skylit/live/service.hpp"
#include "skylit/live/status_server.hpp"
#include "skylit/live/sun_shadow_exchange.hpp"
#include "skylit/render/building_irradiance.hpp"
#include "skylit/render/photometric.hpp"
#include "skylit/scene/mesh.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/sky/sky_estimate.hpp"

namespace skylit::live {

// What the sky thread hands to the render thread.
struct SkyState {
  std::uint64_t sequence = 0;
  double frame_timestamp = 0;   // the sky frame's own time
  std::optional<std::chrono::sys_seconds> utc;  // the sky frame's wall-clock time, when its source knows it
  double received = 0;          // steady seconds when it was estimated (or taken from the link)
  std::optional<double> published;  // from the link: when the sky node published it (system clock, s since 1970)
  std::vector<Eigen::Vector3d> S;  // one RGB per bake layer
  std::optional<blend::SunLight> sun;
  double sun_angular_radius = 0;
  bool sun_colour_corrected = false;  // sky::Sun::colour_corrected (sky.sun_colour: daylight)
  // sky::Sun::located_by, energy_estimator and energy_confidence (a clipped sun).
  std::string sun_located_by = "peak";
  std::string sun_energy_estimator = "measured";
  double sun_energy_confidence = 1.0;
  // Separated sources besides the sun (sky.max_sources > 1: lamps), brightest first, and the
  // radius of the disc each one's shadow map draws (sky::Sun::shadow_radius). The shadow maps
  // hold the sun (when there is one) and then these.
  std::vector<blend::SunLight> lamps;
  std::vector<double> lamp_shadow_radius;
  std::string sun_reason;
  int unseen_faces = 0;
  std::int64_t bad_pixels = 0;
  std::int64_t clipped_pixels = 0;
  bool sun_clipped = false;
  double estimate_ms = 0;
  // With the blend on the CPU: T of every plane (RGBA floats, blend::CpuBlender::rgba), blended on
  // the sky thread for this S and sun. A plane's pointer changes only when its blend ran, so the
  // render thread uploads what changed, even when it missed the skies in between. Null for a
  // plane out of view (blend.cull_planes): the render thread blends it when it comes into view.
  std::vector<std::shared_ptr<const std::vector<float>>> shadow_ratios;
  // The separated sources' visibility V over each plane behind this sky's blends (empty without a
  // shadow map; every source's texels one after another) and its revision: what the render
  // thread needs to blend a plane the sky thread left out.
  std::vector<std::shared_ptr<const std::vector<float>>> sun_visibility;
  std::uint64_t sun_revision = 0;
  // The sun's shadow map for this sky's sun, drawn and complete on the sky thread (the newest
  // one, also when the sun has not moved since: a sky the render thread missed still brings it);
  // null without a sun. The render thread switches to it when it differs from the one it has.
  SunShadowHandle sun_map;
  double cpu_blend_ms = 0;        // the CPU blend of every plane
  // The building's light for this S and these sources (render::BuildingIrradiance::sum), summed
  // on the sky thread so that the frame that takes the sky does not; null: the compositor sums.
  std::shared_ptr<const render::SkyIrradiance> building_light;
  double building_light_ms = 0;
  double sun_visibility_ms = 0;   // the sky thread's sun shadow map, and V read back for the CPU blend (when the sun moved)
};

// Every separated source of a sky in the shadow maps' order: the sun (when there is one), then
// the lamps. What blend::blend_weights_sources takes.
inline std::vector<blend::SunLight> separated_sources(const SkyState& sky) {
  std::vector<blend::SunLight> sources;
  if (sky.sun) sources.push_back(*sky.sun);
  sources.insert(sources.end(), sky.lamps.begin(), sky.lamps.end());
  return sources;
}

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
  SharedCpuBlend(const blend::BasisImages& basis, double skip_threshold, double change_threshold)
      : ratios(basis, skip_threshold, change_threshold) {}
  std::mutex mutex;
  blend::CpuBlender ratios;
};


// The sun a sky frame should show, for the console's aim check (docs/console.md): its elevation
// and azimuth at the frame's time from the site's location, and its angle to the sun found
// (`found`, a unit direction). Null without a location or a time.
nlohmann::json expected_sun(const scene::Site& site, const std::optional<std::chrono::sys_seconds>& utc,
                            const std::optional<Eigen::Vector3d>& found);

// A sun's direction as /status shows it (direction, elevation, azimuth).
nlohmann::json sun_direction_json(const Eigen::Vector3d& direction);

// The image as a JPEG for /sky.jpg and /frame.jpg; empty for an empty image.
std::vector<std::uint8_t> encode_jpeg(const cv::Mat& image);

// A source that answers "not yet" at once (a folder whose files have gone, a camera that is down
// between reconnection attempts) would have its thread spin: such an answer waits a little.
void pause_after_quick_not_yet(const capture::FrameResult& result, Clock::time_point asked);

struct Service::State {
  LiveConfig config;
  ServiceOptions options;
  std::atomic<bool> running{true};
  Counters counters;
  double started = now_seconds();

  // Loaded once.
  scene::Site site;
  scene::Mesh mesh;
  bake_format::Manifest manifest;
  std::vector<float> transfer;
  std::vector<float> ground_transfer;  // the bake's ground layer, with render.ground_light (moved into the compositor)
  bake_format::LightMapArrays light_map;  // the bake's light map, with render.light_map (no texels: none; moved as ground_transfer)
  // The building's sums per sky, the compositors' (made with the first, before the sky thread starts).
  std::shared_ptr<const render::BuildingIrradiance> building_irradiance;
  std::vector<blend::BasisImages> bases;
  camera::CameraCalibration sky_calibration, hmd_calibration;
  // camera.stereo: both cameras (hmd_calibration is its left); frames come side by side.
  std::optional<camera::StereoCalibration> stereo_camera;
  const capture::PairedSource* camera_pair = nullptr;  // camera.source kind pair: its counts
  std::string camera_last_error;                        // guarded by stats_mutex
  std::unique_ptr<geom::Dome> dome;
  // The sky: estimated here from a sky camera (sky_stage and sky_source), or taken from a sky
  // node over the site's link (sky_link; docs/site.md). One of the two.
  std::unique_ptr<SkyStage> sky_stage;
  std::unique_ptr<SkyLinkReceiver> sky_link;
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
  FrameTimes sun_shadow_times{600}, sky_sun_visibility_times{600}, building_light_times{600};
  FrameTimes sky_change_frame_times{600};  // frames that took a new sky (its shadow map and T)
  // From the camera thread receiving a frame to its composite being done (shown, recorded): the
  // part of motion-to-photon latency the service adds (docs/live.md, "Running the service").
  FrameTimes latency_times{600};
  // From the sky node publishing a sky to the first frame composited with it (skies from the link).
  FrameTimes sky_to_screen_times{600};
  RunningTotal frame_time_total, sky_to_screen_total;  // /metrics' summaries: since start
  double record_fps = 0;
  Recorder::Health recording;  // the render loop's copy, for the status
  std::optional<render::PhotometricMatch> photometric;
  std::optional<render::PhotometricMatch> photometric_right;  // camera.stereo's right camera, in stereo display
  // The ground's shadow contrast (sky.clipped_sun_energy: shadow_contrast): measured by the render
  // thread beside the photometric match, taken by the sky thread for the next clipped sun.
  struct GroundContrast {
    render::ShadowContrast contrast;
    double measured_at = 0;  // steady seconds
  };
  std::optional<GroundContrast> ground_contrast;
  // sky.bracket asked of a source that cannot bracket: single frames instead, flagged.
  std::atomic<bool> sky_bracket_unsupported{false};
  std::int64_t blend_skipped_layers = 0;

  std::unique_ptr<BakeInfo> bake_info;  // the console's bake view
  JpegCache frame_jpeg;                  // /frame.jpg, encoded once per new frame
  History history;                       // /history.json: a sample a second from the render thread
  std::unique_ptr<StatusServer> status;
  std::thread sky_thread, camera_thread;

  // The threads' work: the sky thread's (sky_thread.cpp), the camera thread's, and the render
  // thread's, run() (render_loop.cpp).
  class SkyThread;
  class RenderLoop;
  void sky_loop(std::promise<void>& ready);
  void camera_loop();
  nlohmann::json status_report() const;
  // The image of camera `eye` (0 left, 1 right) in a camera frame: the frame itself with one
  // camera; its half with camera.stereo (a view, no copy). InputError for a frame that is not the
  // two cameras side by side.
  cv::Mat camera_image(const capture::Frame& frame, int eye) const;
  nlohmann::json source_report(const capture::FrameSource& source, const capture::ReconnectingSource* reconnecting,
                               const SourceActivity& activity, double now) const;
};

}  // namespace skylit::live
