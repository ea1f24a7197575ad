// The sky thread: sky frames → S and the sun, smoothed over time; the sun's shadow map when the
// sun moved; with the blend on the CPU, T of every plane in view; each sky handed to the render
// thread and to /status.
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <optional>
#include <span>
#include <thread>
#include <vector>

#include <sys/resource.h>
#include <unistd.h>

#include "service_state.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/blend/workers.hpp"
#include "skylit/sky/overlay.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/sky_model.hpp"
#include "skylit/sky/sky_smoothing.hpp"

namespace skylit::live {
namespace {

// How much lower the sky thread's CPU priority is than the render thread's (nice levels).
constexpr int kSkyThreadNiceness = 10;

// The sun's shadow map is drawn again (by the sky thread) when the sun has moved by more than a
// tenth of its radius.
bool sun_moved(const Eigen::Vector3d& drawn_for, const Eigen::Vector3d& sun, double angular_radius) {
  return drawn_for.dot(sun) < std::cos(std::max(1e-4, 0.1 * angular_radius));
}
double shadow_angular_radius(double estimated) { return std::max(estimated, 0.0047); }  // the real sun's at least

// A ground contrast older than this is not used (the HMD looked away, the shadow moved off).
constexpr double kGroundContrastMaxAge = 10.0;  // seconds

std::vector<geom::Plane> bake_planes(const bake_format::Manifest& manifest) {
  std::vector<geom::Plane> planes;
  for (const auto& record : manifest.planes) planes.push_back(record.plane);
  return planes;
}

// A sky frame's estimate on its way out: what the render thread takes, and what /sky.jpg's
// overlay is drawn from.
struct EstimatedSky {
  SkyState state;
  sky::RadianceFrame radiance;
  sky::SkyEstimate estimate;
};

}  // namespace

// When the sky may have a sun, this thread draws the sun's shadow maps (sun_maps), in a GL
// context of its own that shares objects with the render thread's: the render thread never
// draws one, it switches to each finished map (the building's own sun shadow; with the GPU
// blend, the planes' V). With the blend on the CPU its objects live here too: the blend
// threads, each plane's T, and V of each map read back for it.
class Service::State::SkyThread {
 public:
  explicit SkyThread(State& state) : s(state), cpu(state.blend_on_cpu) {}
  void run(std::promise<void>& ready);

 private:
  static void lower_priority();
  void set_up();
  std::optional<std::vector<capture::Frame>> next_frames();
  EstimatedSky estimate(std::span<const capture::Frame> frames);
  void run_from_link();
  void publish_node_status();
  void apply_ground_contrast(SkyState& state) const;
  bool draw_sun_map(SkyState& state);
  void blend_planes(SkyState& state);
  void sum_building_light(SkyState& state) const;
  void publish(EstimatedSky& sky);

  State& s;
  const bool cpu;
  std::unique_ptr<blend::BlendWorkers> workers;
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
  std::vector<render::ShadowSource> shadow_sources;  // what the last map was drawn for
  double last_estimate = -1e300, last_overlay = -1e300;
  std::uint64_t sequence = 0;
};

void Service::State::sky_loop(std::promise<void>& ready) { SkyThread(*this).run(ready); }

void Service::State::SkyThread::run(std::promise<void>& ready) {
  lower_priority();
  try {
    set_up();
    ready.set_value();
  } catch (...) {
    ready.set_exception(std::current_exception());
    return;
  }
  if (s.sky_link) {
    run_from_link();
    return;
  }
  while (s.running) {
    // 1. The next sky frame (or bracket), when one is due (sky.rate).
    const std::optional<std::vector<capture::Frame>> frames = next_frames();
    if (!frames) continue;
    try {
      // 2. S and the sun from it, smoothed over time.
      EstimatedSky sky = estimate(*frames);
      apply_ground_contrast(sky.state);
      // 3. The sun's shadow map for a sun that moved, complete before the sky is handed over.
      if (!draw_sun_map(sky.state)) break;  // closed: the service is stopping
      // 4. With the blend on the CPU: T of every plane in view, so that the render thread only uploads it.
      if (cpu) blend_planes(sky.state);
      // 5. The building's light for this sky, so that the frame that takes it does not sum it.
      sum_building_light(sky.state);
      // 6. To the render thread, and to /status.
      publish(sky);
    } catch (const std::exception& e) {
      ++s.counters.sky_errors;
    }
  }
}

void Service::State::SkyThread::lower_priority() {
  // This thread's work (the sky estimate, the sun's shadow map, the CPU blend; in the demo also
  // the simulated sky) yields the cores to the render thread's: it runs niced, and so do the
  // blend threads it starts, which inherit its niceness (llvmpipe's rasterizer threads are the
  // process's, shared with the render thread, and keep theirs). On a machine with few cores a
  // new sky then no longer slows the frames composited meanwhile; it comes a little later
  // instead. (Per thread on Linux; where it fails, nothing changes.)
  const auto thread = static_cast<id_t>(::gettid());
  errno = 0;
  const int niceness = ::getpriority(PRIO_PROCESS, thread);
  if (errno == 0) static_cast<void>(::setpriority(PRIO_PROCESS, thread, std::min(niceness + kSkyThreadNiceness, 19)));
}

void Service::State::SkyThread::set_up() {
  if (cpu) {
    workers = std::make_unique<blend::BlendWorkers>(s.config.blend.threads);
    for (const auto& basis : s.bases) {
      s.cpu_blends.push_back(std::make_unique<SharedCpuBlend>(basis, s.config.blend.skip_threshold, s.config.blend.change_threshold));
    }
    if (s.config.sky.sun) visibility.resize(s.bases.size());
  }
  if (s.config.sky.sun) {
    context.emplace(s.share_group);
    render::SunShadowOptions map_options;
    map_options.max_sources = s.config.sky.max_sources;
    s.sun_maps.create(s.mesh, bake_planes(s.manifest), map_options);
    maps_owner.maps = &s.sun_maps;
    shadow_maps = true;
  }
}

std::optional<std::vector<capture::Frame>> Service::State::SkyThread::next_frames() {
  SkyFrames result;
  const auto asked = Clock::now();
  try {
    bool unsupported = s.sky_bracket_unsupported;
    result = next_sky_frames(*s.sky_source, s.config.sky.bracket, 0.2, unsupported);
    s.sky_bracket_unsupported = unsupported;
  } catch (const std::exception& e) {
    ++s.counters.sky_errors;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    return std::nullopt;
  }
  if (result.status == capture::FrameStatus::EndOfStream) {
    s.sky_activity.ended = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the last S stays (and goes stale)
    return std::nullopt;
  }
  if (result.status != capture::FrameStatus::Ready) {
    pause_after_quick_not_yet(capture::FrameResult{result.status, {}}, asked);
    return std::nullopt;
  }
  s.counters.sky_frames += static_cast<std::int64_t>(result.frames.size());
  s.sky_activity.frame();
  const capture::Frame& frame = result.frames.front();
  if (s.config.sky.rate > 0 && frame.timestamp - last_estimate < 1.0 / s.config.sky.rate) return std::nullopt;
  last_estimate = frame.timestamp;
  return std::move(result.frames);
}

EstimatedSky Service::State::SkyThread::estimate(std::span<const capture::Frame> frames) {
  const capture::Frame& frame = frames.front();
  SkyStage::Result result = s.sky_stage->estimate(frames);
  const sky::SkyEstimate& estimate = result.estimate;
  SkyState state;
  state.sequence = ++sequence;
  state.frame_timestamp = frame.timestamp;
  state.utc = frame.utc;
  state.received = now_seconds();
  state.S = sky::layer_radiances(estimate.luminance);
  if (estimate.sun) {
    state.sun = blend::SunLight{estimate.sun->direction, estimate.sun->energy};
    state.sun_angular_radius = estimate.sun->angular_radius;
    state.sun_clipped = estimate.sun->clipped;
    state.sun_colour_corrected = estimate.sun->colour_corrected;
    state.sun_located_by = estimate.sun->located_by;
    state.sun_energy_estimator = estimate.sun->energy_estimator;
    state.sun_energy_confidence = estimate.sun->energy_confidence;
  }
  // sources[0] is the sun when there is one; the rest are lamps (sky.max_sources).
  for (std::size_t k = estimate.sun ? 1 : 0; k < estimate.sources.size(); ++k) {
    state.lamps.push_back(blend::SunLight{estimate.sources[k].direction, estimate.sources[k].energy});
    const sky::Sun& lamp = estimate.sources[k];
    state.lamp_shadow_radius.push_back(lamp.shadow_radius > 0 ? lamp.shadow_radius : lamp.angular_radius);
  }
  state.sun_reason = estimate.sun_reason;
  state.unseen_faces = estimate.luminance.unseen_faces;
  state.bad_pixels = estimate.luminance.nan_pixels + estimate.luminance.inf_pixels + estimate.luminance.negative_pixels;
  state.clipped_pixels = estimate.luminance.clipped_pixels;
  state.estimate_ms = result.estimate_ms;
  return {std::move(state), std::move(result.radiance), std::move(result.estimate)};
}

namespace {

// A published sky as the render thread takes it: the same S and sources as the sky node's own,
// at most max_sources of them.
SkyState sky_from_message(const sky_link::SkyMessage& message, int max_sources) {
  SkyState state;
  state.sequence = message.sequence;
  state.frame_timestamp = message.frame_timestamp;
  if (message.utc) state.utc = std::chrono::sys_seconds(std::chrono::seconds(*message.utc));
  state.received = now_seconds();
  state.published = message.published;
  state.S = message.S;
  if (!message.sources.empty() && message.sources.front().sun) {  // the sun first, when there is one
    const sky_link::PublishedSource& sun = message.sources.front();
    state.sun = blend::SunLight{sun.direction, sun.energy};
    state.sun_angular_radius = sun.angular_radius;
    state.sun_clipped = sun.clipped;
    state.sun_colour_corrected = sun.colour_corrected;
    state.sun_located_by = sun.located_by;
    state.sun_energy_estimator = sun.energy_estimator;
    state.sun_energy_confidence = sun.energy_confidence;
  }
  for (std::size_t k = state.sun ? 1 : 0; k < message.sources.size(); ++k) {
    if (static_cast<int>(k) >= max_sources) break;
    state.lamps.push_back(blend::SunLight{message.sources[k].direction, message.sources[k].energy});
    const sky_link::PublishedSource& lamp = message.sources[k];
    state.lamp_shadow_radius.push_back(lamp.shadow_radius > 0 ? lamp.shadow_radius : lamp.angular_radius);
  }
  state.sun_reason = message.sun_reason;
  state.unseen_faces = message.unseen_faces;
  state.bad_pixels = message.bad_pixels;
  state.clipped_pixels = message.clipped_pixels;
  return state;
}

}  // namespace

// An HMD node: skies come from the sky node over the link; the sun's map, the blends and the
// hand-over are as for a sky estimated here. Once a second this node's status goes out.
void Service::State::SkyThread::run_from_link() {
  double last_status = -1e300;
  while (s.running) {
    if (const double now = now_seconds(); now - last_status >= 1.0) {
      last_status = now;
      publish_node_status();
    }
    std::optional<sky_link::SkyMessage> message = s.sky_link->take(std::chrono::milliseconds(200));
    if (!message) continue;
    try {
      ++s.counters.sky_frames;
      s.sky_activity.frame();
      EstimatedSky sky{sky_from_message(*message, s.config.sky.max_sources), {}, {}};
      apply_ground_contrast(sky.state);
      if (!draw_sun_map(sky.state)) break;
      if (cpu) blend_planes(sky.state);
      sum_building_light(sky.state);
      publish(sky);
    } catch (const std::exception& e) {
      ++s.counters.sky_errors;
    }
  }
}

// What the sky node's /site shows of this node (docs/site.md, "Node status").
void Service::State::SkyThread::publish_node_status() {
  const nlohmann::json report = s.status_report();
  nlohmann::json node_status;
  node_status["node"] = s.sky_link->node();
  node_status["state"] = report["state"];
  node_status["frame_rate"] = report["frame_rate"];
  node_status["frame_time_ms"] = report["frame_time_ms"];
  node_status["latency_ms"] = report["latency_ms"];
  node_status["sky_to_screen_ms"] = report["sky_to_screen_ms"];
  node_status["flags"] = report["flags"];
  node_status["sky_sequence"] = report["sky"].contains("sequence") ? report["sky"]["sequence"] : nlohmann::json(nullptr);
  node_status["frames"] = report["frames"];
  node_status["time"] = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  s.sky_link->publish_status(node_status);
}

// sky.clipped_sun_energy: shadow_contrast. A clipped sun takes the energy the ground's shadow
// contrast measured, when that is recent and more than its pixels say (they are a lower bound).
void Service::State::SkyThread::apply_ground_contrast(SkyState& state) const {
  if (s.config.sky.clipped_sun_energy != sky::ClippedSunEnergy::ShadowContrast || !state.sun || !state.sun_clipped) return;
  std::optional<GroundContrast> ground;
  {
    std::lock_guard lock(s.stats_mutex);
    ground = s.ground_contrast;
  }
  if (!ground || !ground->contrast.ok || state.received - ground->measured_at > kGroundContrastMaxAge) return;
  if (!(sky::rgb_luminance(ground->contrast.sun_energy) > sky::rgb_luminance(state.sun->energy))) return;
  state.sun->energy = ground->contrast.sun_energy;
  state.sun_energy_estimator = "shadow_contrast";
  state.sun_energy_confidence = ground->contrast.confidence;
}

// False when the maps are closed (the service is stopping).
bool Service::State::SkyThread::draw_sun_map(SkyState& state) {
  // The sources to draw: the sun (its disc at least the real sun's), then the lamps.
  std::vector<render::ShadowSource> sources;
  if (state.sun) sources.push_back({state.sun->direction.normalized(), shadow_angular_radius(state.sun_angular_radius)});
  for (std::size_t k = 0; k < state.lamps.size(); ++k) {
    sources.push_back({state.lamps[k].direction.normalized(), std::max(state.lamp_shadow_radius[k], 0.0)});
  }
  // Drawn again when the set of sources changed or one moved by a tenth of its radius.
  bool moved = sources.size() != shadow_sources.size();
  for (std::size_t k = 0; !moved && k < sources.size(); ++k) {
    moved = sun_moved(shadow_sources[k].direction, sources[k].direction, sources[k].angular_radius);
  }
  if (!sources.empty() && shadow_maps && moved) {
    const auto sun_start = Clock::now();
    SunShadowHandle map = s.sun_maps.draw(sources, !state.lamps.empty());
    if (!map) return false;
    last_map = std::move(map);
    shadow_sources = sources;
    ++sun_revision;
    if (cpu) {
      for (std::size_t j = 0; j < visibility.size(); ++j) {
        std::vector<float> values;
        for (int k = 0; k < static_cast<int>(sources.size()); ++k) {
          const std::vector<float> layer = last_map->map().read_visibility(static_cast<int>(j), k);
          values.insert(values.end(), layer.begin(), layer.end());
        }
        visibility[j] = std::make_shared<const std::vector<float>>(std::move(values));
      }
    }
    state.sun_visibility_ms = std::chrono::duration<double, std::milli>(Clock::now() - sun_start).count();
  }
  if (!sources.empty()) state.sun_map = last_map;
  return true;
}

void Service::State::SkyThread::blend_planes(SkyState& state) {
  const auto blend_start = Clock::now();
  state.sun_visibility = visibility;
  state.sun_revision = sun_revision;
  for (std::size_t j = 0; j < s.cpu_blends.size(); ++j) {
    if (s.config.blend.cull_planes && !s.plane_views[j].in_view) {
      ++s.plane_views[j].blends_out_of_view;
      state.shadow_ratios.push_back(nullptr);
      continue;
    }
    const blend::BlendWeights weights = blend::blend_weights_sources(s.bases[j], state.S, separated_sources(state));
    const std::span<const float> sun_visibility =
        shadow_maps && visibility[j] ? std::span<const float>(*visibility[j]) : std::span<const float>();
    std::lock_guard blend_lock(s.cpu_blends[j]->mutex);
    const bool ran = s.cpu_blends[j]->ratios.blend_sources(weights, sun_visibility, sun_revision, workers.get());
    ++(ran ? s.counters.blends_run : s.counters.blends_skipped);
    state.shadow_ratios.push_back(s.cpu_blends[j]->ratios.rgba());
  }
  state.cpu_blend_ms = std::chrono::duration<double, std::milli>(Clock::now() - blend_start).count();
  std::lock_guard lock(s.stats_mutex);
  s.blend_times.add(state.cpu_blend_ms / 1e3, now_seconds());
}

void Service::State::SkyThread::sum_building_light(SkyState& state) const {
  if (!s.building_irradiance || state.S.size() != s.building_irradiance->layer_count()) return;  // the compositor says why
  const auto start = Clock::now();
  state.building_light = std::make_shared<const render::SkyIrradiance>(s.building_irradiance->sum(state.S, state.sun, state.lamps));
  state.building_light_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  ++s.counters.building_light_sky_thread;
  std::lock_guard lock(s.stats_mutex);
  s.building_light_times.add(state.building_light_ms / 1e3, now_seconds());
}

void Service::State::SkyThread::publish(EstimatedSky& sky) {
  SkyState& state = sky.state;
  if (state.sun_visibility_ms > 0) {
    std::lock_guard lock(s.stats_mutex);
    s.sky_sun_visibility_times.add(state.sun_visibility_ms / 1e3, now_seconds());
  }
  ++s.counters.sky_estimates;
  if (s.status && s.sky_stage && state.received - last_overlay >= 1.0) {
    last_overlay = state.received;
    s.sky_jpeg.set(encode_jpeg(sky::draw_sky_overlay(s.sky_stage->estimator().lens(), *s.dome, sky.radiance.radiance, sky.estimate)));
  }
  {
    SkyState for_status = state;
    for_status.sun_map = nullptr;  // /status holds no map: a slot is free once the render thread is done with it
    for_status.building_light = nullptr;  // nor the building's sums: they go with the render thread's sky
    s.latest_sky.set(std::move(for_status));
  }
  s.sky_box.put(std::move(state));
}

}  // namespace skylit::live
