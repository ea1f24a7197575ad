// /status and /metrics: the service's state as JSON (status_report) and as Prometheus text, from
// its counters, statistics and sources.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "service_state.hpp"
#include "skylit/base/process_memory.hpp"
#include "skylit/blend/forms.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/gpu/egl_context.hpp"

namespace skylit::live {

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

nlohmann::json expected_sun(const scene::Site& site, const std::optional<std::chrono::sys_seconds>& utc,
                            const std::optional<Eigen::Vector3d>& found) {
  if (!site.location || !utc) return nullptr;
  const sky::SolarPosition position = sky::solar_position(*utc, site.location->latitude_deg, site.location->longitude_deg);
  char place[64];
  std::snprintf(place, sizeof place, "%.4f° %s, %.4f° %s", std::abs(site.location->latitude_deg),
                site.location->latitude_deg >= 0 ? "N" : "S", std::abs(site.location->longitude_deg),
                site.location->longitude_deg >= 0 ? "E" : "W");
  nlohmann::json j = {{"elevation_deg", position.elevation_rad * 180 / M_PI},
                      {"azimuth_deg", position.azimuth_rad * 180 / M_PI},
                      {"location", place}};
  j["offset_deg"] = found ? nlohmann::json(std::acos(std::clamp(found->normalized().dot(position.direction()), -1.0, 1.0)) * 180 / M_PI)
                          : nlohmann::json(nullptr);
  return j;
}

nlohmann::json sun_direction_json(const Eigen::Vector3d& d) {
  double azimuth = std::atan2(d.x(), d.y()) * 180 / M_PI;
  if (azimuth < 0) azimuth += 360;  // from north towards east, [0, 360), as the solar position's
  return {{"direction", {d.x(), d.y(), d.z()}},
          {"elevation_deg", std::asin(std::clamp(d.z(), -1.0, 1.0)) * 180 / M_PI},
          {"azimuth_deg", azimuth}};
}

nlohmann::json Service::State::status_report() const {
  nlohmann::json j;
  const double now = now_seconds();
  j["uptime_s"] = now - started;
  const ProcessMemory memory = process_memory();
  j["memory"] = {{"heap_in_use_bytes", memory.heap_in_use_bytes},
                 {"heap_held_bytes", memory.heap_held_bytes},
                 {"resident_bytes", memory.resident_bytes}};
  // Before the first sky the building is not drawn: its shading and shadows need S.
  j["state"] = sky_drawn ? "running" : "waiting for sky";
  {
    std::lock_guard lock(stats_mutex);
    j["frame_rate"] = frame_times.rate();
    j["frame_time_ms"] = {{"p50", 1e3 * frame_times.percentile(0.5)}, {"p99", 1e3 * frame_times.percentile(0.99)}};
    j["latency_ms"] = {{"p50", 1e3 * latency_times.percentile(0.5)}, {"p99", 1e3 * latency_times.percentile(0.99)}};
    if (sky_link) {  // skies from a sky node: from its publishing a sky to the first frame with it
      j["sky_to_screen_ms"] = sky_to_screen_times.count() == 0
                                  ? nlohmann::json(nullptr)
                                  : nlohmann::json{{"p50", 1e3 * sky_to_screen_times.percentile(0.5)},
                                                   {"p99", 1e3 * sky_to_screen_times.percentile(0.99)}};
    }
    j["sky_change_frame_ms"] = {{"p50", 1e3 * sky_change_frame_times.percentile(0.5)},
                                {"p99", 1e3 * sky_change_frame_times.percentile(0.99)}};
    j["stage_ms_p50"] = {{"sun_shadow", 1e3 * sun_shadow_times.percentile(0.5)},
                         {"blend", 1e3 * blend_times.percentile(0.5)},
                         {"upload", 1e3 * upload_times.percentile(0.5)},
                         {"sky_sun_visibility", 1e3 * sky_sun_visibility_times.percentile(0.5)},
                         {"building_light", 1e3 * building_light_times.percentile(0.5)},
                         {"composite", 1e3 * composite_times.percentile(0.5)},
                         {"record", 1e3 * record_times.percentile(0.5)}};
    if (photometric) j["photometric_scale"] = {photometric->scale.x(), photometric->scale.y(), photometric->scale.z()};
    if (photometric_right) {
      j["photometric_scale_right"] = {photometric_right->scale.x(), photometric_right->scale.y(), photometric_right->scale.z()};
    }
    if (ground_contrast) {
      // What an installer reads to set shadowed_sky_visibility: under an overcast sky, shadowed
      // over lit is V.
      const render::ShadowContrast& c = ground_contrast->contrast;
      j["shadow_contrast"] = {{"ok", c.ok},
                              {"problem", c.problem.empty() ? nlohmann::json(nullptr) : nlohmann::json(c.problem)},
                              {"lit", {c.lit.x(), c.lit.y(), c.lit.z()}},
                              {"shadowed", {c.shadowed.x(), c.shadowed.y(), c.shadowed.z()}},
                              {"sun_energy", {c.sun_energy.x(), c.sun_energy.y(), c.sun_energy.z()}},
                              {"confidence", c.confidence},
                              {"age_s", now - ground_contrast->measured_at}};
    }
    if (record_fps > 0) j["record_fps"] = record_fps;
    if (!config.output.record.empty()) {
      j["recording"] = {{"path", config.output.record.string()}, {"written", recording.written},
                        {"lost", recording.lost}, {"failing", recording.failing},
                        {"last_error", recording.last_error.empty() ? nlohmann::json(nullptr) : nlohmann::json(recording.last_error)}};
    }
  }
  j["frames"] = counters.frames.load();
  j["frames_without_sky"] = counters.frames_without_sky.load();
  j["dropped_frames"] = camera_box.overwritten();
  nlohmann::json camera_json = source_report(*camera_source, camera_reconnecting, camera_activity, now);
  camera_json["frames"] = counters.camera_frames.load();
  camera_json["malformed"] = camera_source->counts().dropped();
  camera_json["errors"] = counters.camera_errors.load();
  {
    std::lock_guard lock(stats_mutex);
    // The camera thread's last failure with a frame (last_error is the source's own).
    camera_json["last_frame_error"] = camera_last_error.empty() ? nlohmann::json(nullptr) : nlohmann::json(camera_last_error);
  }
  if (camera_pair) {
    // A pair of cameras (camera.source kind pair): frames paired, and each side's left without a partner.
    const capture::PairCounts pairs = camera_pair->pair_counts();
    camera_json["pair"] = {{"paired", pairs.paired}, {"unpaired_left", pairs.unpaired_left},
                           {"unpaired_right", pairs.unpaired_right}, {"tolerance_ms", 1e3 * camera_pair->tolerance_s()}};
  }
  if (stereo_camera) camera_json["stereo"] = {{"calibration", config.camera.stereo.string()}, {"baseline_m", stereo_camera->baseline_m()}};
  const FrameRate rate = camera_rate.rate();
  camera_json["frame_rate_hz"] = rate.hz ? nlohmann::json(*rate.hz) : nlohmann::json(nullptr);
  j["camera"] = camera_json;
  nlohmann::json pose_json = tracking->report();
  pose_json["missing"] = counters.pose_missing.load();
  pose_json["fade"] = {{"state", to_string(fade->state())}, {"opacity", fade->opacity()}, {"fade_s", fade->fade_s()}};
  j["pose"] = pose_json;
  // How much of the building (and its shadows) the frames show: 1 tracked, 0 lost (BuildingFade).
  j["opacity"] = fade->opacity();
  nlohmann::json sky_json;
  std::vector<std::string> flags;
  if (sky_link) {
    // Skies from the sky node (docs/site.md): the link's state instead of a camera's.
    sky_json = sky_link->report();
    sky_json["source"] = "mqtt " + sky_json["broker"].get<std::string>() + " " + sky_json["topic"].get<std::string>();
    sky_json["state"] = sky_link->connected() ? "running" : "reconnecting";
    sky_json["reconnect_attempts"] = std::max<std::uint64_t>(sky_json["connections"].get<std::uint64_t>(), 1) - 1;
    sky_json["seconds_since_frame"] =
        sky_activity.last_frame < 0 ? nlohmann::json(nullptr) : nlohmann::json(now - sky_activity.last_frame);
    sky_json["malformed"] = sky_json["dropped"]["malformed"];
    if (!sky_link->connected()) flags.push_back("broker_unreachable");
    if (sky_link->sky_node_offline()) flags.push_back("sky_node_offline");
  } else {
    sky_json = source_report(*sky_source, sky_reconnecting, sky_activity, now);
    sky_json["malformed"] = sky_source->counts().dropped();
  }
  sky_json["frames"] = counters.sky_frames.load();
  sky_json["estimates"] = counters.sky_estimates.load();
  sky_json["errors"] = counters.sky_errors.load();
  if (camera_json["state"] == "reconnecting") flags.push_back("camera_reconnecting");
  if (sky_json["state"] == "reconnecting" && !sky_link) flags.push_back("sky_reconnecting");
  if (!config.sky.bracket.empty()) {
    sky_json["bracket"] = {{"exposures_s", config.sky.bracket}, {"unsupported", sky_bracket_unsupported.load()}};
    if (sky_bracket_unsupported) flags.push_back("sky_bracket_unsupported");
  }
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
      sky_json["sun"] = sun_direction_json(d);
      sky_json["sun"]["energy"] = {latest->sun->energy.x(), latest->sun->energy.y(), latest->sun->energy.z()};
      sky_json["sun"]["angular_radius_deg"] = latest->sun_angular_radius * 180 / M_PI;
      sky_json["sun"]["clipped"] = latest->sun_clipped;
      if (latest->sun_clipped) flags.push_back("sun_clipped");
      sky_json["sun"]["colour_corrected"] = latest->sun_colour_corrected;
      if (latest->sun_colour_corrected) flags.push_back("sun_colour_corrected");
      sky_json["sun"]["located_by"] = latest->sun_located_by;
      sky_json["sun"]["energy_estimator"] = latest->sun_energy_estimator;
      sky_json["sun"]["energy_confidence"] = latest->sun_energy_confidence;
      if (latest->sun_energy_estimator != "measured") flags.push_back("sun_energy_estimated");
    } else {
      sky_json["sun"] = nullptr;
    }
    // The lamps (sky.max_sources > 1), each with its shadow map.
    nlohmann::json lamps = nlohmann::json::array();
    for (std::size_t k = 0; k < latest->lamps.size(); ++k) {
      nlohmann::json lamp = sun_direction_json(latest->lamps[k].direction);
      lamp["energy"] = {latest->lamps[k].energy.x(), latest->lamps[k].energy.y(), latest->lamps[k].energy.z()};
      lamp["shadow_radius_deg"] = latest->lamp_shadow_radius[k] * 180 / M_PI;
      lamps.push_back(std::move(lamp));
    }
    sky_json["lamps"] = std::move(lamps);
    const nlohmann::json expected = expected_sun(site, latest->utc, latest->sun ? std::optional(latest->sun->direction) : std::nullopt);
    if (!expected.is_null()) sky_json["sun_expected"] = expected;
    if (age > config.sky.stale_after) flags.push_back("sky_stale");
    if (latest->unseen_faces > 0) flags.push_back("faces_unseen");
    if (latest->bad_pixels > 0) flags.push_back("bad_pixels");
  } else {
    sky_json["age_s"] = nullptr;
    flags.push_back("no_sky_yet");
  }
  tracking->add_flags(flags);
  if (j.contains("recording") && j["recording"]["failing"].get<bool>()) flags.push_back("recording_failing");
  if (const BuildingFade::State state = fade->state(); state == BuildingFade::State::FadingOut || state == BuildingFade::State::Hidden) {
    flags.push_back("pose_lost");  // the building fades out, or is hidden, until a pose returns
  }
  j["sky"] = sky_json;
  j["blends"] = {{"run", counters.blends_run.load()}, {"skipped", counters.blends_skipped.load()}};
  j["building_light_sums"] = {{"sky_thread", counters.building_light_sky_thread.load()},
                              {"in_frame", counters.building_light_in_frame.load()}};
  j["light_map"] = {{"precision", render::light_map_precision_name(config.render.light_map_precision)},
                    {"bytes", counters.light_map_bytes.load()}};
  // The sun's shadow maps, all drawn on the sky thread: drawn, switched to by the render thread
  // (a skipped one was overtaken by a newer sun before a frame took it), and draws that waited
  // for the render thread to free a map.
  const SunShadowExchange::Counts maps = sun_maps.counts();
  j["sun_shadow_maps"] = {{"drawn_on", "sky thread"}, {"drawn", maps.drawn}, {"taken", maps.taken},
                          {"slot_waits", maps.slot_waits}};
  nlohmann::json blend_json;
  blend_json["setting"] = blend_device_name(config.blend.device);
  blend_json["basis"] = std::string(blend::form_name(config.blend.basis));
  nlohmann::json planes_json = nlohmann::json::array();
  for (std::size_t k = 0; k < bases.size() && k < manifest.planes.size(); ++k) {
    nlohmann::json plane;
    plane["name"] = manifest.planes[k].plane.name;
    plane["layers"] = bases[k].layers;                  // the images each blend sums
    plane["source_layers"] = bases[k].source_layers();  // the dome's layers S is given for
    if (config.blend.basis == blend::BasisForm::Pca && manifest.planes[k].pca) plane["max_error"] = manifest.planes[k].pca->max_error;
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
    blend_json["software_renderer"] = gpu::is_software_renderer(renderer);
  } else {
    blend_json["device"] = nullptr;  // decided when run() has its GL context
  }
  j["blend"] = blend_json;
  j["flags"] = flags;
  return j;
}

std::string Service::status_json() const { return state_->status_report().dump(2) + "\n"; }

namespace {

// A Prometheus summary: the quantiles of the recent window, and the sum and count since start.
void add_summary(std::vector<Metric>& m, const std::string& name, const std::string& help, const FrameTimes& recent,
                 const RunningTotal& total) {
  m.push_back({name, help, "summary", recent.percentile(0.5), "quantile=\"0.5\""});
  m.push_back({name, help, "summary", recent.percentile(0.99), "quantile=\"0.99\""});
  m.push_back({name + "_sum", help, "summary", total.sum, ""});
  m.push_back({name + "_count", help, "summary", double(total.count), ""});
}

}  // namespace

std::string Service::metrics_text() const {
  const State& s = *state_;
  const nlohmann::json j = s.status_report();
  std::vector<Metric> m;
  m.push_back({"skylit_frames_total", "Frames composited.", "counter", double(s.counters.frames.load()), ""});
  m.push_back({"process_resident_memory_bytes", "Resident memory size in bytes.", "gauge",
               j["memory"]["resident_bytes"].get<double>(), ""});
  m.push_back({"skylit_heap_in_use_bytes", "Bytes the program holds from malloc (a leak grows this).", "gauge",
               j["memory"]["heap_in_use_bytes"].get<double>(), ""});
  m.push_back({"skylit_heap_held_bytes", "Bytes malloc holds from the system: in use, and freed but kept.", "gauge",
               j["memory"]["heap_held_bytes"].get<double>(), ""});
  m.push_back({"skylit_dropped_frames_total", "Camera frames replaced before the renderer took them.", "counter",
               double(s.camera_box.overwritten()), ""});
  m.push_back({"skylit_camera_frames_total", "Camera frames received.", "counter", double(s.counters.camera_frames.load()), ""});
  m.push_back({"skylit_camera_malformed_total", "Camera frames dropped as malformed.", "counter",
               double(s.camera_source->counts().dropped()), ""});
  m.push_back({"skylit_sky_frames_total", "Sky frames received.", "counter", double(s.counters.sky_frames.load()), ""});
  m.push_back({"skylit_sky_estimates_total", "Sky estimates made.", "counter", double(s.counters.sky_estimates.load()), ""});
  if (s.sky_source) {
    m.push_back({"skylit_sky_malformed_total", "Sky frames dropped as malformed.", "counter",
                 double(s.sky_source->counts().dropped()), ""});
  }
  if (s.sky_link) {
    const auto drops = s.sky_link->drops();
    for (std::size_t k = 1; k < drops.size(); ++k) {
      const std::string reason(sky_link::drop_reason_name(static_cast<sky_link::DropReason>(k)));
      m.push_back({"skylit_sky_messages_dropped_total", "Skies from the sky node dropped, by reason.", "counter",
                   double(drops[k]), "reason=\"" + reason + "\""});
    }
    m.push_back({"skylit_sky_messages_taken_total", "Skies from the sky node taken.", "counter", double(s.sky_link->taken()), ""});
    m.push_back({"skylit_broker_connected", "1 while connected to the site's MQTT broker.", "gauge",
                 s.sky_link->connected() ? 1.0 : 0.0, ""});
    if (!j["sky_to_screen_ms"].is_null()) {
      std::lock_guard lock(s.stats_mutex);
      add_summary(m, "skylit_sky_to_screen_seconds",
                  "From the sky node publishing a sky to the first frame composited with it (quantiles over the last 600 skies).",
                  s.sky_to_screen_times, s.sky_to_screen_total);
    }
  }
  m.push_back({"skylit_pose_missing_total", "Frames without a pose at their time.", "counter",
               double(s.counters.pose_missing.load()), ""});
  m.push_back({"skylit_blends_total", "Plane blends run.", "counter", double(s.counters.blends_run.load()), "result=\"run\""});
  m.push_back({"skylit_blends_total", "Plane blends run.", "counter", double(s.counters.blends_skipped.load()), "result=\"skipped\""});
  const char* sums_help = "The building's light summed for a new sky: ahead on the sky thread, or in the frame that took it.";
  m.push_back({"skylit_building_light_sums_total", sums_help, "counter", double(s.counters.building_light_sky_thread.load()),
               "on=\"sky_thread\""});
  m.push_back({"skylit_building_light_sums_total", sums_help, "counter", double(s.counters.building_light_in_frame.load()),
               "on=\"frame\""});
  m.push_back({"skylit_light_map_bytes", "Bytes the building's light map holds for its sums (0: none).", "gauge",
               double(s.counters.light_map_bytes.load()), ""});
  m.push_back({"skylit_frame_rate", "Frames per second over the last 600 frames.", "gauge", j["frame_rate"].get<double>(), ""});
  {
    std::lock_guard lock(s.stats_mutex);
    add_summary(m, "skylit_frame_time_seconds", "Frame time (quantiles over the last 600 frames).", s.frame_times, s.frame_time_total);
  }
  const auto& sky = j["sky"];
  m.push_back({"skylit_sky_age_seconds", "Age of the newest sky estimate.", "gauge",
               sky["age_s"].is_null() ? std::numeric_limits<double>::infinity() : sky["age_s"].get<double>(), ""});
  m.push_back({"skylit_sun_detected", "1 while the newest sky has a sun.", "gauge", sky.contains("sun") && !sky["sun"].is_null() ? 1.0 : 0.0, ""});
  m.push_back({"skylit_lamps_separated", "Lamps separated in the newest sky, each with a shadow map (sky.max_sources).", "gauge",
               sky.contains("lamps") ? static_cast<double>(sky["lamps"].size()) : 0.0, ""});
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
  if (j.contains("recording")) {
    m.push_back({"skylit_recording_frames_lost_total", "Composited frames the recording could not write (a full disk).",
                 "counter", j["recording"]["lost"].get<double>(), ""});
  }
  s.tracking->add_metrics(m);
  for (const auto& flag : j["flags"]) {
    m.push_back({"skylit_flag", "1 for each condition the status reports.", "gauge", 1.0, "flag=\"" + flag.get<std::string>() + "\""});
  }
  return prometheus_text(m);
}

}  // namespace skylit::live
