// The render thread (Service::run): each camera frame in turn through numbered stages, each
// timed by a StageTimer into the frame statistics: the newest sky and its sun's shadow map, T
// uploaded or blended, the pose, the composite shown, the frame recorded, its times kept.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <future>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "recording.hpp"
#include "service_state.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/gpu/window_context.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/render/hmd_distortion.hpp"
#include "skylit/render/hmd_profile.hpp"
#include "skylit/render/plane_view.hpp"
#include "skylit/render/stereo_camera.hpp"
#include "skylit/render/textures.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/srgb.hpp"
#include "skylit/gpu/egl_context.hpp"

namespace skylit::live {
namespace {

namespace fs = std::filesystem;

// The rate a camera source is configured for, where its config gives one.
std::optional<double> configured_rate(const capture::SourceConfig& config) {
  if (const auto* images = std::get_if<capture::ImagesSettings>(&config.settings); images && images->fps) return images->fps;
  if (const auto* v4l2 = std::get_if<capture::V4l2Settings>(&config.settings); v4l2 && v4l2->fps > 0) return v4l2->fps;
  // A pair of cameras runs at its left camera's rate.
  if (const auto* pair = std::get_if<capture::PairSettings>(&config.settings); pair && pair->left) return configured_rate(*pair->left);
  return std::nullopt;
}

std::string gl_renderer() {
  const auto* text = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return text != nullptr ? std::string(text) : std::string("unknown");
}

// The camera frame as it is (the display before the sky is known): an sRGB RGBA8 texture, row 0
// the image's top, for WindowContext::present. 8-bit frames are sRGB codes; float ones linear.
class CameraTexture {
 public:
  GLuint upload(const cv::Mat& image) {
    cv::Mat codes = image;
    if (image.depth() == CV_32F) {
      cv::Mat srgb(image.size(), image.type());
      image.forEach<cv::Vec3f>([&srgb](const cv::Vec3f& v, const int* at) {
        cv::Vec3f& out = srgb.at<cv::Vec3f>(at[0], at[1]);
        for (int c = 0; c < 3; ++c) out[c] = 255.0f * sky::srgb_encode(v[c]);
      });
      srgb.convertTo(codes, CV_8U);
    }
    return texture_.upload(codes);
  }

 private:
  render::ImageTexture texture_;
};

}  // namespace

// The render thread's objects and the state it keeps from frame to frame. The GL context is
// declared first, so that every GL object after it is destroyed while it is still current.
class Service::State::RenderLoop {
 public:
  // The GL context (a window or none), the blend's device and objects, the compositor and the
  // display, the photometric reference plane and the recorder.
  explicit RenderLoop(State& state);
  // Starts the sky and camera threads, draws frames until the end, then stops the threads.
  // Returns the number of frames composited.
  std::int64_t run();

 private:
  // Set-up.
  void open_context();
  void choose_blend_device();
  void make_shadow_ratios();
  void make_compositor_and_display();
  void find_reference_plane();
  void start_threads();
  // A frame's stages (run()'s steps).
  std::optional<capture::Frame> take_camera_frame();
  bool take_sky(FrameStageTimes& times);
  void upload_sky_ratios(FrameStageTimes& times);
  void note_sky(bool sky_changed);
  struct FramePose {
    bool has_pose = false;            // the frame has its own pose (last_pose keeps the last one)
    std::optional<double> arrived;    // when the camera thread received it, when known
  };
  FramePose pose_frame(const capture::Frame& frame);
  void blend_behind_sky(FrameStageTimes& times, bool sky_changed);
  cv::Mat composite_and_show(FrameStageTimes& times, const capture::Frame& frame, double opacity);
  void record(FrameStageTimes& times, const capture::Frame& frame, const cv::Mat& composite, double opacity);
  void keep_times(const FrameStageTimes& times, std::optional<double> arrived, bool sky_changed);
  std::int64_t finish();
  // Their parts.
  void present(GLuint texture, int width, int height);
  bool plane_seen(std::size_t j, const render::CameraPose& pose) const;
  void estimate_photometric(const capture::Frame& frame);

  State& s;
  const std::size_t plane_count;
  std::optional<gpu::HeadlessContext> headless;
  std::unique_ptr<gpu::WindowContext> window;
  std::optional<render::HmdProfile> hmd_profile;
  bool cpu = false;  // the blend's device: the CPU (the sky thread) or the GPU (here)
  SunShadowHandle sun_map;  // the map this thread draws with
  std::vector<std::unique_ptr<blend::GpuBlender>> blenders;     // blend.device gpu
  std::vector<render::ShadowRatioTexture> cpu_ratios;            // blend.device cpu
  // The CPU blend's T each texture holds (kept alive, so that a new T never shares its address).
  std::vector<std::shared_ptr<const std::vector<float>>> uploaded;
  std::vector<GLuint> ratios;
  render::CompositorOptions compositor_options;
  std::optional<render::Compositor> compositor;
  // camera.stereo in display.mode stereo: the right camera's compositor (compositor: the left's).
  std::optional<render::Compositor> compositor_right;
  std::optional<CameraTexture> camera_texture;
  std::optional<render::HmdDistortion> hmd;
  bool stereo = false;
  std::optional<int> reference_plane;
  std::optional<Recorder> recorder;

  // blend.cull_planes: which planes this frame's view can see (every eye's, in stereo), through
  // the compositor's pinhole view, which holds every ray it draws; a plane's box is grown by the
  // cover distance, within which a building fragment takes the plane's T.
  render::PlaneViewOptions view_options;
  double ipd = 0;
  std::vector<char> in_view;
  // Planes whose T is not that of the current sky: with the GPU blend, every plane when a sky
  // comes, until it is blended; with the CPU blend, those the sky thread left out of view. A
  // plane is blended before the first frame that can see it.
  std::vector<char> behind_sky;

  std::optional<SkyState> sky;
  std::optional<render::CameraPose> last_pose;
  std::int64_t frames = 0, frames_with_sky = 0;
  // The photometric scale is first estimated on the first frame with a sky (until then the
  // configured scale would show the building far too bright or dark), then every `every` frames.
  std::optional<std::int64_t> last_photometric_estimate;
  double last_progress = 0;
  bool said_waiting = false;
  bool ended = false;  // the camera has ended, or the window was closed
};

std::int64_t Service::run() {
  State::RenderLoop loop(*state_);
  return loop.run();
}

Service::State::RenderLoop::RenderLoop(State& state)
    : s(state), plane_count(state.bases.size()), uploaded(state.bases.size()) {
  open_context();
  choose_blend_device();
  make_shadow_ratios();
  make_compositor_and_display();
  find_reference_plane();
  const fs::path record = s.options.record ? *s.options.record : s.config.output.record;
  if (!record.empty()) recorder.emplace(record, s.config.output.record_fps, configured_rate(s.config.camera.source));
  view_options.thickness = compositor_options.cover_distance;
  ipd = stereo && hmd_profile ? hmd_profile->ipd : 0.0;
  in_view.assign(plane_count, 1);
  behind_sky.assign(plane_count, 0);
}

std::int64_t Service::State::RenderLoop::run() {
  start_threads();
  while (s.running) {
    // 1. The newest camera frame (none for 200 ms: the window is kept responsive meanwhile).
    std::optional<capture::Frame> frame = take_camera_frame();
    if (!frame) {
      if (ended) break;
      continue;
    }
    FrameStageTimes times(s.options.profile);
    // 2. The newest sky, when one came, and its sun's shadow map, switched to (the sky thread drew it).
    const bool sky_changed = take_sky(times);
    // 3. T of the new sky from the CPU blend, uploaded (and the planes it left out noted).
    if (sky_changed) upload_sky_ratios(times);
    note_sky(sky_changed);
    // 4. The pose at the frame's time, and the planes it can see.
    const FramePose posed = pose_frame(*frame);
    // 5. T of the current sky for every plane in view that lacks it.
    if (sky) blend_behind_sky(times, sky_changed);
    // 6. The building's opacity: without a pose it fades out at the last one; a pose back after a
    //    loss fades it in from nothing (BuildingFade), so it never jumps to the new pose at full
    //    opacity. Before the sky is known the building would be drawn unlit (black): the camera
    //    image alone.
    const double opacity = s.fade->next(posed.has_pose, frame->timestamp);
    if (sky && !last_pose) continue;  // nothing to draw from yet
    // 7. The composite, shown.
    const cv::Mat composite = composite_and_show(times, *frame, opacity);
    // 8. Recorded, and kept for /frame.jpg.
    record(times, *frame, composite, opacity);
    // 9. The frame's times into the statistics, and the progress line.
    keep_times(times, posed.arrived, sky_changed);
    if (sky) ++frames_with_sky;
    if (s.options.frames && frames >= *s.options.frames) break;
    if (s.options.frames_with_sky && frames_with_sky >= *s.options.frames_with_sky) break;
  }
  return finish();
}

void Service::State::RenderLoop::open_context() {
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
}

void Service::State::RenderLoop::choose_blend_device() {
  // Where T is blended: a software renderer (no GPU) blends far slower than the CPU blend does.
  s.renderer = gl_renderer();
  const BlendDevice setting = s.config.blend.device;
  cpu = setting == BlendDevice::Cpu || (setting == BlendDevice::Auto && gpu::is_software_renderer(s.renderer));
  s.blend_on_cpu = cpu;
  s.blend_decided = true;
  if (!s.options.quiet) {
    std::fprintf(stderr, "skylit-live: blend on the %s (blend.device %s; GL renderer %s%s)\n", cpu ? "CPU" : "GPU",
                 blend_device_name(setting).c_str(), s.renderer.c_str(),
                 gpu::is_software_renderer(s.renderer) ? ", a software one" : "");
  }
}

void Service::State::RenderLoop::make_shadow_ratios() {
  // The sun's shadow map (the building's own sun shadow, and with the GPU blend the planes' V)
  // is drawn by the sky thread in a context that shares this one's objects: this thread switches
  // to each finished map (its GL commands wait on the map's fence) and fences its last use of
  // the one before, which the sky thread then redraws for a later sun (sun_shadow_exchange.hpp).
  s.share_group = gpu::HeadlessContext::current_share_group();
  if (cpu) {
    for (const auto& basis : s.bases) {
      cpu_ratios.emplace_back(basis.width, basis.height);
      ratios.push_back(cpu_ratios.back().get());
    }
  } else {
    blend::GpuBlendOptions blend_options;
    blend_options.storage = s.config.blend.storage;
    blend_options.skip_threshold = s.config.blend.skip_threshold;
    blend_options.change_threshold = s.config.blend.change_threshold;
    for (const auto& basis : s.bases) {
      blenders.push_back(std::make_unique<blend::GpuBlender>(basis, blend_options));
      ratios.push_back(blenders.back()->shadow_ratio_texture());
    }
  }
}

void Service::State::RenderLoop::make_compositor_and_display() {
  compositor_options.photometric.scale = s.config.photometric.scale;
  compositor_options.lens.render_scale = s.config.render.scale;
  compositor_options.light_map_precision = s.config.render.light_map_precision;
  if (s.config.render.ground_light) {
    compositor_options.ground_albedo = s.config.render.ground_albedo.value_or(s.config.photometric.albedo);
  }
  // The first compositor takes the bake's arrays and makes the building's sums per sky; the right
  // eye's shares them, and the sky thread sums them ahead for each sky.
  render::CompositorOptions first = compositor_options;
  if (s.config.render.ground_light) first.ground_transfer = std::move(s.ground_transfer);
  first.light_map = std::move(s.light_map);
  compositor.emplace(s.site, s.mesh, s.manifest, s.transfer, s.hmd_calibration, std::move(first));
  s.building_irradiance = compositor->building_irradiance();
  s.counters.light_map_bytes = static_cast<std::int64_t>(s.building_irradiance->light_map_bytes());
  compositor_options.building_irradiance = s.building_irradiance;
  if (window) camera_texture.emplace();
  if (window && hmd_profile) hmd.emplace(*hmd_profile);
  stereo = hmd && s.config.display->stereo;
  if (stereo && s.stereo_camera) {
    compositor_right.emplace(s.site, s.mesh, s.manifest, s.transfer, s.stereo_camera->right, compositor_options);
  }
  if (hmd && !s.options.quiet) {
    std::fprintf(stderr, "skylit-live: HMD display '%s': %s, %d×%d panel%s%s\n", hmd_profile->name.c_str(),
                 !stereo ? "mono" : s.stereo_camera ? "stereo (a render per eye, a camera per eye)" : "stereo (a render per eye)",
                 hmd_profile->panel_width, hmd_profile->panel_height,
                 s.config.display->monitor.empty() ? ", in a window" : ", full screen on ",
                 s.config.display->monitor.c_str());
  }
}

void Service::State::RenderLoop::find_reference_plane() {
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
}

void Service::State::RenderLoop::start_threads() {
  // The sky thread sets up (with the CPU blend: its threads and GL context) before the first frame.
  std::promise<void> sky_ready;
  State& shared = s;
  s.sky_thread = std::thread([&shared, &sky_ready] { shared.sky_loop(sky_ready); });
  sky_ready.get_future().get();
  s.camera_thread = std::thread([&shared] { shared.camera_loop(); });
}

// Shows a texture of the camera's size (row 0 the top): through the HMD's lenses, or as it is.
void Service::State::RenderLoop::present(GLuint texture, int width, int height) {
  if (hmd) {
    hmd->draw(std::span<const GLuint>(&texture, 1), width, height);
    window->present(hmd->panel_texture(), hmd_profile->panel_width, hmd_profile->panel_height);
  } else {
    window->present(texture, width, height);
  }
}

bool Service::State::RenderLoop::plane_seen(std::size_t j, const render::CameraPose& pose) const {
  const geom::Plane& plane = s.manifest.planes[j].plane;
  const render::PinholeCamera& view = compositor->lens_remap().pinhole;
  if (render::plane_in_view(plane, pose, view, view_options)) return true;
  if (!stereo) return false;
  if (compositor_right) {  // a camera per eye: the right camera's view too
    return render::plane_in_view(plane, render::stereo_camera_poses(pose, *s.stereo_camera)[1],
                                 compositor_right->lens_remap().pinhole, view_options);
  }
  return render::plane_in_view(plane, render::eye_pose(pose, ipd, 0), view, view_options) ||
         render::plane_in_view(plane, render::eye_pose(pose, ipd, 1), view, view_options);
}

// Nullopt, with `ended` set, when the loop ends (the camera has ended, the window was closed).
std::optional<capture::Frame> Service::State::RenderLoop::take_camera_frame() {
  std::optional<capture::Frame> frame = s.camera_box.take(std::chrono::milliseconds(200));
  if (window) {
    window->poll_events();  // the window stays responsive while no frame comes
    if (window->close_requested()) {
      ended = true;
      return std::nullopt;
    }
  }
  if (!frame && s.camera_box.closed()) ended = true;
  return frame;
}

// Whether a new sky came. A new sun's map comes complete: switched to, not drawn here, whatever
// the sun did.
bool Service::State::RenderLoop::take_sky(FrameStageTimes& times) {
  auto fresh = s.sky_box.try_take();
  if (!fresh) return false;
  SunShadowHandle fresh_map = std::move(fresh->sun_map);
  sky = std::move(fresh);
  if (fresh_map && fresh_map != sun_map) {
    StageTimer timer(times, Stage::SunShadow);
    fresh_map->wait();
    s.sun_maps.release(sun_map);
    sun_map = std::move(fresh_map);
  }
  return true;
}

// With the GPU blend there is nothing to upload (and nothing timed): every plane waits for its
// blend here.
void Service::State::RenderLoop::upload_sky_ratios(FrameStageTimes& times) {
  StageTimer timer(times, cpu ? std::optional(Stage::Upload) : std::nullopt);
  for (std::size_t j = 0; j < plane_count; ++j) {
    const std::shared_ptr<const std::vector<float>> rgba =
        cpu && j < sky->shadow_ratios.size() ? sky->shadow_ratios[j] : nullptr;
    behind_sky[j] = rgba == nullptr;
    if (rgba == nullptr || rgba == uploaded[j]) continue;
    cpu_ratios[j].upload(*rgba);
    uploaded[j] = rgba;
  }
}

// Says once that the sky is known (the building is drawn from then on); until then counts the
// frames shown without one.
void Service::State::RenderLoop::note_sky(bool sky_changed) {
  if (sky_changed) {
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
}

// The frame's pose, and which planes it can see.
Service::State::RenderLoop::FramePose Service::State::RenderLoop::pose_frame(const capture::Frame& frame) {
  // The frame is shown after the time it has waited since it came and the time a frame takes
  // to draw (the median of the last ones): the latency the pipeline adds, for status.
  double display_delay = 0;
  const std::optional<double> arrived = s.camera_arrivals.find(frame.timestamp);
  if (arrived) {
    std::lock_guard lock(s.stats_mutex);
    display_delay = now_seconds() - *arrived + s.frame_times.percentile(0.5);
  }
  std::optional<track::Pose> pose = s.tracking->pose_for_frame(frame.timestamp, display_delay);
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
  return {pose.has_value(), arrived};
}

// GPU: blended here; CPU: a plane the sky thread left out, blended here on the CPU before it is
// drawn. The CPU blend's `blend` stage is the sky thread's; a plane blended here as it came back
// into view counts with the upload of T, the render thread's share of the CPU blend.
void Service::State::RenderLoop::blend_behind_sky(FrameStageTimes& times, bool sky_changed) {
  StageTimer timer(times, cpu ? Stage::Upload : Stage::Blend);
  int blended = 0;
  for (std::size_t j = 0; j < plane_count; ++j) {
    if (!behind_sky[j]) continue;
    if (!in_view[j]) {
      if (sky_changed && !cpu) ++s.plane_views[j].blends_out_of_view;  // the sky thread counts its own
      continue;
    }
    const blend::BlendWeights weights = blend::blend_weights_sources(s.bases[j], sky->S, separated_sources(*sky));
    const bool lit = std::any_of(weights.sources.begin(), weights.sources.end(),
                                 [](const Eigen::Vector3f& w) { return !w.isZero(0); });
    bool ran = false;
    if (cpu) {
      std::shared_ptr<const std::vector<float>> rgba;
      {
        SharedCpuBlend& shared = *s.cpu_blends[j];
        std::lock_guard blend_lock(shared.mutex);
        const std::span<const float> sun_visibility = j < sky->sun_visibility.size() && sky->sun_visibility[j]
                                                          ? std::span<const float>(*sky->sun_visibility[j])
                                                          : std::span<const float>();
        ran = shared.ratios.blend_sources(weights, sun_visibility, sky->sun_revision, nullptr);
        rgba = shared.ratios.rgba();
      }
      if (rgba && rgba != uploaded[j]) {
        cpu_ratios[j].upload(*rgba);
        uploaded[j] = rgba;
      }
      ++s.plane_views[j].blends_on_return;
    } else {
      ran = blenders[j]->blend(weights, !lit || !sun_map ? nullptr : &sun_map->map().visibility(static_cast<int>(j)));
      if (!sky_changed) ++s.plane_views[j].blends_on_return;
    }
    ++(ran ? s.counters.blends_run : s.counters.blends_skipped);
    behind_sky[j] = 0;
    ++blended;
  }
  if (blended == 0) timer.cancel();
}

void Service::State::RenderLoop::estimate_photometric(const capture::Frame& frame) {
  last_photometric_estimate = frames;
  const cv::Mat region = compositor->region_mask(*reference_plane, s.config.photometric.region[0],
                                                 s.config.photometric.region[1], s.config.photometric.region[2],
                                                 s.config.photometric.region[3], *last_pose);
  const sky::RadianceFrame linear = sky::linearise(s.camera_image(frame, 0), sky::ResponseCurve::srgb(8), {});
  const render::PhotometricEstimate found = render::estimate_photometric_match(
      linear.radiance, region,
      render::plane_irradiance(s.manifest.planes[static_cast<std::size_t>(*reference_plane)], sky->S, sky->sun, sky->lamps),
      s.config.photometric.albedo);
  if (found.ok) {
    std::lock_guard lock(s.stats_mutex);
    s.photometric = found.match;
  }
  if (compositor_right) {
    // The right camera's own match: two cameras seldom expose alike.
    const cv::Mat right_region = compositor_right->region_mask(
        *reference_plane, s.config.photometric.region[0], s.config.photometric.region[1], s.config.photometric.region[2],
        s.config.photometric.region[3], render::stereo_camera_poses(*last_pose, *s.stereo_camera)[1]);
    const render::PhotometricEstimate right = render::estimate_photometric_match(
        sky::linearise(s.camera_image(frame, 1), sky::ResponseCurve::srgb(8), {}).radiance, right_region,
        render::plane_irradiance(s.manifest.planes[static_cast<std::size_t>(*reference_plane)], sky->S, sky->sun, sky->lamps),
        s.config.photometric.albedo);
    if (right.ok) {
      std::lock_guard lock(s.stats_mutex);
      s.photometric_right = right.match;
    }
  }
  if (s.config.photometric.shadowed_region && sky->sun) {
    const std::array<double, 4>& r = *s.config.photometric.shadowed_region;
    const cv::Mat shadowed = compositor->region_mask(*reference_plane, r[0], r[1], r[2], r[3], *last_pose);
    const bake_format::PlaneRecord& plane = s.manifest.planes[static_cast<std::size_t>(*reference_plane)];
    render::ShadowContrastOptions options;
    options.sky_visibility = s.config.photometric.shadowed_sky_visibility;
    const Eigen::Vector3d sky_irradiance = render::plane_irradiance(plane, sky->S, std::nullopt);
    State::GroundContrast measured;
    measured.measured_at = now_seconds();
    if (sky_irradiance.allFinite() && sky_irradiance.minCoeff() > 0.0) {
      measured.contrast = render::estimate_sun_from_shadow_contrast(
          linear.radiance, region, shadowed, sky_irradiance, plane.plane.normal().dot(sky->sun->direction.normalized()), options);
    } else {
      measured.contrast.problem = "the sky does not light the plane";
    }
    std::lock_guard lock(s.stats_mutex);
    s.ground_contrast = std::move(measured);
  }
}

// The composite, shown in the window (when there is one); returns it when someone takes it.
cv::Mat Service::State::RenderLoop::composite_and_show(FrameStageTimes& times, const capture::Frame& frame,
                                                        double opacity) {
  StageTimer timer(times, Stage::Composite);
  cv::Mat composite;
  // With tracking lost and the building faded out, the frame is the camera image unchanged,
  // which the compositor would give at opacity 0 (tested): shown as it is, without its passes.
  if (!sky || opacity <= 0.0) {
    composite = s.camera_image(frame, 0);
    if (window) present(camera_texture->upload(composite), composite.cols, composite.rows);
    return composite;
  }
  render::CompositeInput input;
  input.camera = s.camera_image(frame, 0);
  input.pose = *last_pose;
  input.sky = sky->S;
  input.sun = sky->sun;
  input.shadow_ratios = ratios;
  input.sun_shadow = sky->sun && sun_map ? &sun_map->map() : nullptr;
  // The lamps light the building per vertex, through their visibility from the same map (its
  // sources: the sun first when there is one).
  input.lamps = sky->lamps;
  if (!sky->lamps.empty() && sun_map) {
    const std::vector<std::vector<float>>& vertex = sun_map->vertex_visibility();
    const std::size_t first = sky->sun ? 1 : 0;
    if (vertex.size() == first + sky->lamps.size()) input.lamp_vertex_visibility = std::span(vertex).subspan(first);
  }
  input.irradiance = sky->building_light;
  input.opacity = opacity;
  if (reference_plane &&
      (!last_photometric_estimate || frames - *last_photometric_estimate >= s.config.photometric.every)) {
    estimate_photometric(frame);
  }
  {
    std::lock_guard lock(s.stats_mutex);
    input.photometric = s.photometric;
  }
  // Read back only what someone takes: the recorder, /frame.jpg. A window shows the GPU's copy.
  // The recorder and /frame.jpg take the undistorted composite from the camera's own pose;
  // in stereo the HMD gets one composite per eye besides.
  if (recorder || s.status || !window) {
    composite = compositor->composite(input);
  } else if (!stereo) {
    compositor->draw(input);
  }
  if (stereo && compositor_right) {
    // Each eye its own camera's image, from that camera's pose (docs/hmd.md, "Stereo cameras").
    std::array<render::CompositeInput, 2> eyes{input, input};
    eyes[1].camera = s.camera_image(frame, 1);
    {
      std::lock_guard lock(s.stats_mutex);
      if (s.photometric_right) eyes[1].photometric = s.photometric_right;
    }
    eyes[1].pose = render::stereo_camera_poses(input.pose, *s.stereo_camera)[1];
    const std::array<render::Compositor*, 2> compositors{&*compositor, &*compositor_right};
    render::draw_hmd_frame(compositors, *hmd, eyes);
    window->present(hmd->panel_texture(), hmd_profile->panel_width, hmd_profile->panel_height);
  } else if (stereo) {
    render::draw_hmd_frame(*compositor, *hmd, input, render::StereoMode::stereo);
    window->present(hmd->panel_texture(), hmd_profile->panel_width, hmd_profile->panel_height);
  } else if (window) {
    present(compositor->display_texture(), s.hmd_calibration.image_width, s.hmd_calibration.image_height);
  }
  for (const render::Compositor* drawn : {&*compositor, compositor_right ? &*compositor_right : nullptr}) {
    if (drawn != nullptr && drawn->last_stats().building_light_summed) ++s.counters.building_light_in_frame;
  }
  return composite;
}

void Service::State::RenderLoop::record(FrameStageTimes& times, const capture::Frame& frame, const cv::Mat& composite,
                                        double opacity) {
  StageTimer timer(times, Stage::Record);
  if (recorder) {
    RecordedFrame info;
    info.timestamp = frame.timestamp;
    if (sky) {
      info.sky_timestamp = sky->frame_timestamp;
      info.sky_utc = sky->utc;
      if (sky->sun) info.sun_direction = sky->sun->direction;
      info.opacity = opacity;
    }
    recorder->write(composite, info, s.camera_rate.rate());
    const Recorder::Health health = recorder->health();
    std::lock_guard lock(s.stats_mutex);
    s.recording = health;
  }
  if (s.status) s.latest_frame.set(composite);
}

void Service::State::RenderLoop::keep_times(const FrameStageTimes& times, std::optional<double> arrived,
                                            bool sky_changed) {
  ++frames;
  ++s.counters.frames;
  const double end = now_seconds();
  {
    std::lock_guard lock(s.stats_mutex);
    const double frame_time = std::chrono::duration<double>(Clock::now() - times.start).count();
    s.frame_times.add(frame_time, end);
    s.frame_time_total.add(frame_time);
    if (sky_changed) s.sky_change_frame_times.add(frame_time, end);
    if (sky_changed && sky && sky->published) {
      // Sky to screen across the link: the sky node's clock against this node's (one clock on one
      // machine; NTP-close across machines).
      const double system_now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
      s.sky_to_screen_times.add(system_now - *sky->published, end);
      s.sky_to_screen_total.add(system_now - *sky->published);
    }
    if (arrived) s.latency_times.add(end - *arrived, end);
    if (times.timed(Stage::SunShadow)) s.sun_shadow_times.add(times.at(Stage::SunShadow) / 1e3, end);
    if (times.timed(Stage::Blend)) s.blend_times.add(times.at(Stage::Blend) / 1e3, end);
    if (times.timed(Stage::Upload)) s.upload_times.add(times.at(Stage::Upload) / 1e3, end);
    s.composite_times.add(times.at(Stage::Composite) / 1e3, end);
    s.record_times.add(times.at(Stage::Record) / 1e3, end);
    if (recorder) s.record_fps = recorder->fps();
    if (s.history.due(end)) {
      s.history.add({end, sky ? mean_of(sky->S) : std::nullopt, 1e3 * s.frame_times.percentile(0.5),
                     1e3 * s.latency_times.percentile(0.5)});
    }
  }
  if (!s.options.quiet && end - last_progress > 1.0) {
    last_progress = end;
    std::lock_guard lock(s.stats_mutex);
    std::fprintf(stderr, "\rskylit-live: %lld frames, %.1f frames/s, p50 %.1f ms%s   ", static_cast<long long>(frames),
                 s.frame_times.rate(), 1e3 * s.frame_times.percentile(0.5), sky ? "" : " (waiting for sky)");
  }
}

std::int64_t Service::State::RenderLoop::finish() {
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

}  // namespace skylit::live
