#include "skylit/live/sky_node.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "bake_info.hpp"
#include "history.hpp"
#include "service_metrics.hpp"
#include "service_state.hpp"
#include "sky_stage.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/base/error.hpp"
#include "skylit/capture/reconnecting_source.hpp"
#include "skylit/live/heard_nodes.hpp"
#include "skylit/live/status_server.hpp"
#include "skylit/sky/overlay.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/sky_link/mqtt_client.hpp"
#include "skylit/sky_link/site_topics.hpp"
#include "skylit/sky_link/sky_message.hpp"

namespace skylit::live {
namespace {

double system_seconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

sky_link::SkyMessage message_of(const sky_link::SkyIdentity& identity, std::uint64_t sequence, std::int64_t run,
                                const capture::Frame& frame, const sky::SkyEstimate& estimate) {
  sky_link::SkyMessage m;
  m.identity = identity;
  m.sequence = sequence;
  m.run = run;
  m.frame_timestamp = frame.timestamp;
  if (frame.utc) m.utc = frame.utc->time_since_epoch().count();
  m.S = sky::layer_radiances(estimate.luminance);
  // Every separated source (sky.max_sources), the sun first when there is one.
  for (std::size_t k = 0; k < estimate.sources.size(); ++k) {
    const sky::Sun& source = estimate.sources[k];
    const bool sun = k == 0 && estimate.sun.has_value();
    // The sun as smoothed (its energy), the lamps as found.
    const sky::Sun& published = sun ? *estimate.sun : source;
    m.sources.push_back({published.direction, published.energy, published.angular_radius, published.clipped, sun,
                         published.shadow_radius, published.colour_corrected, published.located_by,
                         published.energy_estimator, published.energy_confidence});
  }
  if (estimate.sources.empty() && estimate.sun) {
    m.sources.push_back({estimate.sun->direction, estimate.sun->energy, estimate.sun->angular_radius, estimate.sun->clipped, true,
                         0.0, estimate.sun->colour_corrected, estimate.sun->located_by, estimate.sun->energy_estimator,
                         estimate.sun->energy_confidence});
  }
  m.sun_reason = estimate.sun_reason;
  m.unseen_faces = estimate.luminance.unseen_faces;
  m.bad_pixels = estimate.luminance.nan_pixels + estimate.luminance.inf_pixels + estimate.luminance.negative_pixels;
  m.clipped_pixels = estimate.luminance.clipped_pixels;
  return m;
}

LinkSettings with_broker(LinkSettings link, const std::optional<std::string>& broker) {
  if (broker) std::tie(link.mqtt.host, link.mqtt.port) = sky_link::parse_broker_address(*broker, "--broker");
  return link;
}

}  // namespace

struct SkyNode::State {
  SkyNodeConfig config;
  SkyNodeOptions options;
  LinkSettings link;
  std::atomic<bool> running{true};
  double started = now_seconds();
  std::string site_name;
  sky_link::SkyIdentity identity;
  sky_link::SiteTopics topics;
  std::string node;
  std::int64_t run = 0;  // this run's start, µs since 1970 (SkyMessage::run)
  bake_format::Manifest manifest;
  scene::Site site;
  camera::CameraCalibration calibration;
  std::unique_ptr<geom::Dome> dome;
  std::unique_ptr<SkyStage> stage;
  std::unique_ptr<capture::FrameSource> source;
  const capture::ReconnectingSource* reconnecting = nullptr;
  SourceActivity activity;
  std::atomic<bool> bracket_unsupported{false};  // sky.bracket asked of a source that cannot

  mutable std::mutex mutex;  // guards what the status server reads below
  std::uint64_t sequence = 0;
  std::int64_t estimates = 0, published = 0, publish_failures = 0, errors = 0;
  std::size_t message_bytes = 0;
  double last_estimate_ms = 0;
  std::optional<sky_link::SkyMessage> latest;
  double latest_time = 0;  // steady seconds when it was estimated
  std::vector<std::uint8_t> latest_bytes, overlay;
  HeardNodes nodes;  // steady seconds

  std::unique_ptr<BakeInfo> bake_info;
  History history;
  std::unique_ptr<sky_link::MqttClient> client;  // after what its handlers touch
  std::unique_ptr<StatusServer> status;

  nlohmann::json status_report() const;
  nlohmann::json site_report() const;
  void publish_latest(bool overlay_too);
};

SkyNode::SkyNode(const SkyNodeConfig& config, const SkyNodeOptions& options) : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.config = config;
  s.options = options;
  s.link = with_broker(config.link, options.broker);
  check_bake_matches_site(config.bake, config.site, config.preset);
  s.manifest = bake_format::read_manifest(config.bake);
  s.site = scene::load_site(config.site);
  s.site_name = site_name_of(config.site);
  s.identity = {s.site_name, s.manifest.plan.frequency, s.manifest.plan.basis, static_cast<int>(s.manifest.layer_count())};
  s.topics = {s.link.topic.empty() ? sky_link::default_topic_root(s.site_name) : s.link.topic};
  s.node = sky_link::node_name(s.link.node.empty() ? "sky" : s.link.node);
  s.run = std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  s.calibration = camera::load_calibration(config.sky.calibration);
  s.dome = std::make_unique<geom::Dome>(s.manifest.plan.frequency);
  s.stage = std::make_unique<SkyStage>(s.calibration, *s.dome, s.manifest.plan.basis, config.sky, s.site.location);
  capture::SourceConfig source_config = config.sky.source;
  if (!source_config.reconnect) source_config.reconnect = capture::BackoffSettings{};  // a node that runs all day reopens what fails
  capture::OpenedSource opened = capture::open_source_with_status(source_config);
  s.source = std::move(opened.source);
  s.reconnecting = opened.reconnecting;

  sky_link::MqttSettings mqtt = s.link.mqtt;
  mqtt.client_id = "skylit-sky-" + s.node;
  mqtt.will = sky_link::MqttWill{s.topics.sky_state(), "offline", true};
  s.client = std::make_unique<sky_link::MqttClient>(mqtt);
  State* self = &s;
  s.client->subscribe(s.topics.nodes(), [self](const std::string& topic, std::span<const std::uint8_t> payload, bool) {
    const std::string name = self->topics.node_of(topic);
    if (name.empty()) return;
    std::lock_guard lock(self->mutex);
    self->nodes.hear(name, payload, now_seconds());
  });

  const auto listen = options.status_listen ? options.status_listen : config.status_listen;
  if (listen) {
    const auto [host, port] = parse_listen_address(*listen, "status.listen");
    StatusHandlers handlers;
    handlers.title = "skylit-sky-node";
    handlers.status_json = [self] { return self->status_report().dump(2) + "\n"; };
    handlers.metrics_text = [this] { return metrics_text(); };
    handlers.site_json = [self] { return self->site_report().dump(2) + "\n"; };
    handlers.sky_jpeg = [self] {
      std::lock_guard lock(self->mutex);
      return self->overlay;
    };
    s.bake_info = std::make_unique<BakeInfo>(config.bake, s.manifest, config.site);
    handlers.bake_json = [self] { return self->bake_info->report().dump(2) + "\n"; };
    handlers.bake_preview = [self](const std::string& name) { return self->bake_info->preview(name); };
    handlers.history_json = [self] { return self->history.json(now_seconds()).dump() + "\n"; };
    handlers.token = status_token(host, config.status_access.token_file, config.status_access.allow_unauthenticated, "skylit-sky-node");
    s.status = std::make_unique<StatusServer>(host, port, handlers);
  }
}

SkyNode::~SkyNode() {
  stop();
  // A goodbye: the HMD nodes see the sky node gone at once rather than after its keepalive.
  state_->client->publish(state_->topics.sky_state(), "offline", true);
}

void SkyNode::stop() { state_->running = false; }

std::string SkyNode::status_address() const { return state_->status ? state_->status->address() : std::string(); }

// Publishes the newest sky (and overlay) again: after a reconnection, a broker that restarted
// without persistence has lost its retained messages.
void SkyNode::State::publish_latest(bool overlay_too) {
  std::vector<std::uint8_t> bytes, image;
  {
    std::lock_guard lock(mutex);
    bytes = latest_bytes;
    if (overlay_too) image = overlay;
  }
  client->publish(topics.sky_state(), "online", true);
  if (!bytes.empty()) client->publish(topics.sky(), bytes, true);
  if (!image.empty()) client->publish(topics.overlay(), image, true);
}

std::int64_t SkyNode::run() {
  State& s = *state_;
  double last_estimate = -1e300, last_overlay = -1e300, last_progress = 0;
  std::uint64_t connections_seen = 0;
  while (s.running) {
    if (const std::uint64_t connections = s.client->connections(); connections != connections_seen && s.client->connected()) {
      connections_seen = connections;
      s.publish_latest(true);
    }
    SkyFrames result;
    const auto asked = Clock::now();
    try {
      bool unsupported = s.bracket_unsupported;
      result = next_sky_frames(*s.source, s.config.sky.bracket, 0.2, unsupported);
      s.bracket_unsupported = unsupported;
    } catch (const std::exception& e) {
      std::lock_guard lock(s.mutex);
      ++s.errors;
      continue;
    }
    if (result.status == capture::FrameStatus::EndOfStream) {
      s.activity.ended = true;
      break;  // a finite recording has ended: its last sky stays retained on the broker
    }
    if (result.status != capture::FrameStatus::Ready) {
      pause_after_quick_not_yet(capture::FrameResult{result.status, {}}, asked);
      continue;
    }
    s.activity.frame();
    const capture::Frame& frame = result.frames.front();
    if (s.config.sky.rate > 0 && frame.timestamp - last_estimate < 1.0 / s.config.sky.rate) continue;
    last_estimate = frame.timestamp;
    try {
      const SkyStage::Result sky = s.stage->estimate(result.frames);
      sky_link::SkyMessage message;
      {
        std::lock_guard lock(s.mutex);
        message = message_of(s.identity, ++s.sequence, s.run, frame, sky.estimate);
      }
      message.published = system_seconds();
      std::vector<std::uint8_t> bytes = sky_link::encode_sky_message(message);
      const bool sent = s.client->publish(s.topics.sky(), bytes, true);
      const double now = now_seconds();
      std::vector<std::uint8_t> image;
      if (now - last_overlay >= 1.0) {
        last_overlay = now;
        image = encode_jpeg(sky::draw_sky_overlay(s.stage->estimator().lens(), *s.dome, sky.radiance.radiance, sky.estimate));
        s.client->publish(s.topics.overlay(), image, true);
      }
      std::lock_guard lock(s.mutex);
      ++s.estimates;
      ++(sent ? s.published : s.publish_failures);
      s.message_bytes = bytes.size();
      s.last_estimate_ms = sky.estimate_ms;
      s.history.add({now, mean_of(message.S), std::nullopt, std::nullopt});
      s.latest = std::move(message);
      s.latest_time = now;
      s.latest_bytes = std::move(bytes);
      if (!image.empty()) s.overlay = std::move(image);
      if (s.options.frames && s.published >= *s.options.frames) break;
    } catch (const std::exception& e) {
      std::lock_guard lock(s.mutex);
      ++s.errors;
      std::fprintf(stderr, "skylit-sky-node: sky frame at %.3f s: %s\n", frame.timestamp, e.what());
    }
    if (!s.options.quiet && now_seconds() - last_progress > 1.0) {
      last_progress = now_seconds();
      std::lock_guard lock(s.mutex);
      std::fprintf(stderr, "\rskylit-sky-node: %lld skies published, %zu HMD nodes heard%s   ",
                   static_cast<long long>(s.published), s.nodes.size(), s.client->connected() ? "" : " (broker unreachable)");
    }
  }
  if (!s.options.quiet) std::fprintf(stderr, "\n");
  std::lock_guard lock(s.mutex);
  return s.published;
}

nlohmann::json SkyNode::State::status_report() const {
  const double now = now_seconds();
  nlohmann::json j;
  j["uptime_s"] = now - started;
  j["node"] = node;
  j["site"] = site_name;
  j["dome"] = {{"frequency", identity.dome_frequency}, {"basis", std::string(geom::basis_name(identity.basis))},
               {"layers", identity.layers}};
  j["broker"] = {{"address", client->address()},   {"connected", client->connected()},
                 {"connections", client->connections()}, {"last_error", client->last_error()},
                 {"topic", topics.sky()}};
  const std::optional<capture::ReconnectStatus> camera_link =
      reconnecting ? std::optional(reconnecting->status()) : std::nullopt;
  j["source"] = {{"source", source->describe()},
                 {"state", camera_link && !camera_link->connected ? "reconnecting" : activity.ended ? "ended" : "running"},
                 {"seconds_since_frame", activity.last_frame < 0 ? nlohmann::json(nullptr) : nlohmann::json(now - activity.last_frame)}};
  std::vector<std::string> flags;
  if (!client->connected()) flags.push_back("broker_unreachable");
  if (camera_link && !camera_link->connected) flags.push_back("sky_reconnecting");
  if (!config.sky.bracket.empty()) {
    j["source"]["bracket"] = {{"exposures_s", config.sky.bracket}, {"unsupported", bracket_unsupported.load()}};
    if (bracket_unsupported) flags.push_back("sky_bracket_unsupported");
  }
  std::lock_guard lock(mutex);
  j["state"] = latest ? "running" : "waiting for sky";
  j["skies"] = {{"estimated", estimates}, {"published", published}, {"not_published", publish_failures}, {"errors", errors},
                {"sequence", sequence}, {"run", run}, {"message_bytes", message_bytes}, {"estimate_ms", last_estimate_ms}};
  if (latest) {
    const std::optional<std::chrono::sys_seconds> utc =
        latest->utc ? std::optional(std::chrono::sys_seconds(std::chrono::seconds(*latest->utc))) : std::nullopt;
    nlohmann::json S = nlohmann::json::array();
    for (const auto& v : latest->S) S.push_back({v.x(), v.y(), v.z()});
    j["sky"] = {{"frame_timestamp", latest->frame_timestamp},
                {"utc", utc ? nlohmann::json(sky::format_utc(*utc)) : nlohmann::json(nullptr)},
                {"age_s", now - latest_time},
                {"sequence", latest->sequence},
                {"S", S},
                {"sun_reason", latest->sun_reason},
                {"unseen_faces", latest->unseen_faces},
                {"bad_pixels", latest->bad_pixels},
                {"clipped_pixels", latest->clipped_pixels}};
    std::optional<Eigen::Vector3d> found;
    j["sky"]["lamps"] = static_cast<int>(std::count_if(latest->sources.begin(), latest->sources.end(),
                                                        [](const sky_link::PublishedSource& p) { return !p.sun; }));
    if (!latest->sources.empty() && latest->sources.front().sun) {
      const sky_link::PublishedSource& sun = latest->sources.front();
      found = sun.direction;
      j["sky"]["sun"] = sun_direction_json(sun.direction);
      j["sky"]["sun"]["energy"] = {sun.energy.x(), sun.energy.y(), sun.energy.z()};
      j["sky"]["sun"]["angular_radius_deg"] = sun.angular_radius * 180 / M_PI;
      j["sky"]["sun"]["clipped"] = sun.clipped;
      if (sun.clipped) flags.push_back("sun_clipped");
      j["sky"]["sun"]["colour_corrected"] = sun.colour_corrected;
      if (sun.colour_corrected) flags.push_back("sun_colour_corrected");
      j["sky"]["sun"]["located_by"] = sun.located_by;
      j["sky"]["sun"]["energy_estimator"] = sun.energy_estimator;
      j["sky"]["sun"]["energy_confidence"] = sun.energy_confidence;
      if (sun.energy_estimator != "measured") flags.push_back("sun_energy_estimated");
    } else {
      j["sky"]["sun"] = nullptr;
    }
    const nlohmann::json expected = expected_sun(site, utc, found);
    if (!expected.is_null()) j["sky"]["sun_expected"] = expected;
    if (latest->unseen_faces > 0) flags.push_back("faces_unseen");
    if (latest->bad_pixels > 0) flags.push_back("bad_pixels");
  } else {
    flags.push_back("no_sky_yet");
  }
  j["hmd_nodes"] = nodes.size();
  j["flags"] = flags;
  return j;
}

// Every HMD node heard of: its last status as it published it, and the seconds since.
nlohmann::json SkyNode::State::site_report() const {
  const double now = now_seconds();
  nlohmann::json j;
  j["site"] = site_name;
  j["topic"] = topics.root;
  std::lock_guard lock(mutex);
  j["sky"] = {{"node", node}, {"sequence", sequence}, {"run", run}, {"published", published}};
  j["nodes"] = nodes.site_entries(now);
  return j;
}

std::string SkyNode::status_json() const { return state_->status_report().dump(2) + "\n"; }
std::string SkyNode::site_json() const { return state_->site_report().dump(2) + "\n"; }

std::string SkyNode::metrics_text() const {
  const State& s = *state_;
  const nlohmann::json j = s.status_report();
  const nlohmann::json site = s.site_report();
  std::vector<Metric> m;
  m.push_back({"skylit_sky_estimates_total", "Sky estimates made.", "counter", j["skies"]["estimated"].get<double>(), ""});
  m.push_back({"skylit_sky_published_total", "Skies published to the broker.", "counter", j["skies"]["published"].get<double>(), ""});
  m.push_back({"skylit_sky_not_published_total", "Skies estimated while the broker was unreachable.", "counter",
               j["skies"]["not_published"].get<double>(), ""});
  m.push_back({"skylit_sky_errors_total", "Sky frames that failed to estimate.", "counter", j["skies"]["errors"].get<double>(), ""});
  m.push_back({"skylit_sky_message_bytes", "Size of the last sky message.", "gauge", j["skies"]["message_bytes"].get<double>(), ""});
  m.push_back({"skylit_broker_connected", "1 while connected to the site's MQTT broker.", "gauge",
               j["broker"]["connected"].get<bool>() ? 1.0 : 0.0, ""});
  m.push_back({"skylit_hmd_nodes", "HMD nodes heard of.", "gauge", double(site["nodes"].size()), ""});
  append_hmd_node_metrics(site["nodes"], m);
  for (const auto& flag : j["flags"]) {
    m.push_back({"skylit_flag", "1 for each condition the status reports.", "gauge", 1.0, prometheus_label("flag", flag.get<std::string>())});
  }
  return prometheus_text(m);
}

}  // namespace skylit::live
