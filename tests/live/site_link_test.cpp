// A site over a real broker (docs/site.md): a sky node and an HMD node of the tests' baked site,
// both in-process, linked by Debian's mosquitto on a loopback port. The HMD node composites with
// the sky node's skies; it keeps compositing with the last one when the sky node or the broker
// goes away, says so in its flags, and takes the skies of a new sky node without a restart; bad
// messages are dropped and counted.
#include <algorithm>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "../support/mosquitto_broker.hpp"
#include "../support/promtool.hpp"
#include "live_fixture.hpp"
#include "skylit/live/sky_node.hpp"
#include "skylit/sky_link/mqtt_client.hpp"
#include "skylit/sky_link/site_topics.hpp"
#include "skylit/sky_link/sky_message.hpp"

namespace skylit::live_test {
namespace {

// The rig's sky frames (two, looped at 2 per second) as a sky node's config.
std::string sky_node_config(const Rig& rig, int broker_port, int max_sources = 1) {
  const BakedSite& baked = BakedSite::get();
  return "root: /\nsite: " + quoted(baked.dir / "site.yaml") + "\nbake: " + quoted(baked.dir / "bake") +
         "\nsky:\n  calibration: " + quoted(rig.dir() / "sky.yaml") + "\n  source:\n    kind: images\n    path: " +
         quoted(rig.dir() / "sky") + "\n    loop: true\n    realtime: 1\n  rate: 0\n  sun: auto\n" +
         "  max_sources: " + std::to_string(max_sources) + "\n" +
         "link:\n  broker: 127.0.0.1:" + std::to_string(broker_port) + "\n  node: sky\n";
}

// The rig's config with its sky from the broker.
std::string hmd_node_config(const Rig& rig, int broker_port, int max_sources = 1) {
  std::string text = rig.config_text();
  const std::size_t sky = text.find("sky:\n"), camera = text.find("camera:\n");
  return text.replace(sky, camera - sky, "sky:\n  source:\n    kind: mqtt\n    broker: 127.0.0.1:" + std::to_string(broker_port) +
                                             "\n    node: hmd-test\n  stale_after: 1\n  max_sources: " +
                                             std::to_string(max_sources) + "\n");
}

// A sky node running on a thread of its own until destroyed (which says goodbye).
class RunningSkyNode {
 public:
  explicit RunningSkyNode(const live::SkyNodeConfig& config) : node_(config, quiet()), thread_([this] { node_.run(); }) {}
  ~RunningSkyNode() {
    node_.stop();
    thread_.join();
  }
  RunningSkyNode(const RunningSkyNode&) = delete;
  RunningSkyNode& operator=(const RunningSkyNode&) = delete;
  nlohmann::json status() const { return nlohmann::json::parse(node_.status_json()); }
  nlohmann::json site() const { return nlohmann::json::parse(node_.site_json()); }
  std::string metrics() const { return node_.metrics_text(); }

 private:
  static live::SkyNodeOptions quiet() {
    live::SkyNodeOptions options;
    options.quiet = true;
    return options;
  }
  live::SkyNode node_;
  std::thread thread_;
};

bool wait_until(const std::function<bool()>& condition, double timeout_s = 60) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return condition();
}

std::uint64_t taken(const nlohmann::json& status) { return status["sky"]["skies_taken"].get<std::uint64_t>(); }
std::uint64_t dropped(const nlohmann::json& status, const char* reason) {
  return status["sky"]["dropped"][reason].get<std::uint64_t>();
}

TEST(SiteLink, AnHmdNodeCompositesTheSkyNodesSkiesAndOutlivesTheSkyNodeAndTheBroker) {
  test::MosquittoBroker broker;
  RigOptions options;
  options.sky_frames = 2;
  options.stale_after = 1;
  Rig rig(options);
  std::ofstream(rig.dir() / "sky_node.yaml") << sky_node_config(rig, broker.port());
  std::ofstream(rig.dir() / "hmd_node.yaml") << hmd_node_config(rig, broker.port());
  const live::SkyNodeConfig sky_config = live::load_sky_node_config(rig.dir() / "sky_node.yaml");

  auto sky_node = std::make_unique<RunningSkyNode>(sky_config);
  RunningService hmd(live::load_live_config(rig.dir() / "hmd_node.yaml"), quiet_options());

  // The sky comes over the link: the building is drawn, and the sky node hears the HMD node.
  ASSERT_TRUE(hmd.wait_for([](const nlohmann::json& s) { return s["state"] == "running" && taken(s) >= 2; })) << hmd.status().dump(2);
  const nlohmann::json first = hmd.status();
  EXPECT_EQ(first["sky"]["sky_node"], "online");
  EXPECT_FALSE(has_flag(first, "no_sky_yet"));
  EXPECT_EQ(first["sky"]["S"].size(), BakedSite::get().manifest.layer_count());
  ASSERT_TRUE(wait_until([&] {
    const nlohmann::json site = sky_node->site();
    return site["nodes"].size() == 1 && site["nodes"][0]["node"] == "hmd-test" && site["nodes"][0]["state"] == "running";
  })) << sky_node->site().dump(2);

  // The sky node goes: its goodbye reaches the HMD node, which keeps compositing the last sky.
  sky_node.reset();
  ASSERT_TRUE(hmd.wait_for([](const nlohmann::json& s) { return has_flag(s, "sky_node_offline"); })) << hmd.status().dump(2);
  const std::int64_t frames_then = frames_of(hmd.status());
  ASSERT_TRUE(hmd.wait_for([&](const nlohmann::json& s) { return frames_of(s) > frames_then + 3 && has_flag(s, "sky_stale"); }));
  EXPECT_EQ(hmd.status()["state"], "running");  // the building stays, lit by the last sky

  // A new sky node takes over (a later run, its sequence from 1 again): taken, no restart.
  const std::uint64_t before_new = taken(hmd.status());
  sky_node = std::make_unique<RunningSkyNode>(sky_config);
  ASSERT_TRUE(hmd.wait_for([&](const nlohmann::json& s) {
    return taken(s) >= before_new + 2 && !has_flag(s, "sky_node_offline") && !has_flag(s, "sky_stale");
  })) << hmd.status().dump(2);
  EXPECT_EQ(dropped(hmd.status(), "out_of_order"), 0u);

  // The broker restarts: both nodes keep running, reconnect, and the skies flow again.
  broker.stop();
  ASSERT_TRUE(hmd.wait_for([](const nlohmann::json& s) { return has_flag(s, "broker_unreachable"); })) << hmd.status().dump(2);
  const std::int64_t frames_down = frames_of(hmd.status());
  ASSERT_TRUE(hmd.wait_for([&](const nlohmann::json& s) { return frames_of(s) > frames_down + 3 && has_flag(s, "sky_stale"); }));
  broker.start();
  const std::uint64_t before_restart = taken(hmd.status());
  ASSERT_TRUE(hmd.wait_for([&](const nlohmann::json& s) {
    return taken(s) > before_restart && !has_flag(s, "broker_unreachable") && !has_flag(s, "sky_stale") &&
           s["sky"]["connections"].get<int>() >= 2;
  })) << hmd.status().dump(2);

  // Bad messages on the sky's topic: dropped with their reason, never taken, never a crash.
  sky_link::MqttSettings settings;
  settings.port = broker.port();
  sky_link::MqttClient intruder(settings);
  ASSERT_TRUE(intruder.wait_connected(10));
  const sky_link::SiteTopics topics{sky_link::default_topic_root(live::site_name_of(BakedSite::get().dir / "site.yaml"))};
  std::mt19937 random(7);
  std::vector<std::uint8_t> noise(300);
  for (auto& b : noise) b = static_cast<std::uint8_t>(random());
  ASSERT_TRUE(intruder.publish(topics.sky(), noise, false));
  sky_link::SkyMessage other;
  other.identity = {live::site_name_of(BakedSite::get().dir / "site.yaml"), 4, geom::DomeBasis::Faces, 160};
  other.sequence = 1u << 30;
  other.run = INT64_MAX / 2;
  other.S.assign(160, Eigen::Vector3d::Constant(0.1));
  ASSERT_TRUE(intruder.publish(topics.sky(), sky_link::encode_sky_message(other), false));
  sky_link::SkyMessage old = other;
  old.identity.dome_frequency = BakedSite::get().manifest.plan.frequency;
  old.identity.layers = static_cast<int>(BakedSite::get().manifest.layer_count());
  old.S.assign(old.identity.layers, Eigen::Vector3d::Constant(0.1));
  old.run = 1;  // long before the sky node's run
  ASSERT_TRUE(intruder.publish(topics.sky(), sky_link::encode_sky_message(old), false));
  ASSERT_TRUE(hmd.wait_for([](const nlohmann::json& s) {
    return dropped(s, "malformed") >= 1 && dropped(s, "other_dome") >= 1 && dropped(s, "out_of_order") >= 1;
  })) << hmd.status().dump(2);
  const nlohmann::json metrics_status = hmd.status();
  EXPECT_EQ(metrics_status["state"], "running");
  const std::string metrics = hmd.service().metrics_text();
  EXPECT_NE(metrics.find("skylit_sky_messages_dropped_total{reason=\"other_dome\"} 1"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("skylit_broker_connected 1"), std::string::npos);
  EXPECT_EQ(test::promtool_problems(metrics), "") << metrics;
  EXPECT_EQ(test::promtool_problems(sky_node->metrics()), "") << sky_node->metrics();
  EXPECT_TRUE(hmd.error().empty()) << hmd.error();
}

// A sky node that separates lamps publishes them; an HMD node draws a shadow map for each it
// takes (sky.max_sources), and one that takes the sun alone leaves them out.
TEST(SiteLink, LampsCrossTheLinkAndEachNodeTakesAsManyAsItDraws) {
  test::MosquittoBroker broker;
  RigOptions options;
  options.sky_frames = 2;
  Rig rig(options);
  std::ofstream(rig.dir() / "sky_node.yaml") << sky_node_config(rig, broker.port(), 4);
  const RunningSkyNode sky_node(live::load_sky_node_config(rig.dir() / "sky_node.yaml"));
  for (const int max_sources : {4, 1}) {
    std::ofstream(rig.dir() / "hmd_node.yaml") << hmd_node_config(rig, broker.port(), max_sources);
    RunningService hmd(live::load_live_config(rig.dir() / "hmd_node.yaml"), quiet_options());
    ASSERT_TRUE(hmd.wait_for([](const nlohmann::json& s) { return s["state"] == "running" && taken(s) >= 2; }))
        << hmd.status().dump(2);
    const nlohmann::json status = hmd.status();
    const int published = sky_node.status()["sky"]["lamps"].get<int>();
    ASSERT_GE(published, 1) << "the sky node separated no lamp: " << sky_node.status()["sky"].dump();
    ASSERT_FALSE(status["sky"]["sun"].is_null());
    // How the sky node found and weighed its sun crosses the link.
    EXPECT_EQ(status["sky"]["sun"]["located_by"], sky_node.status()["sky"]["sun"]["located_by"]);
    EXPECT_EQ(status["sky"]["sun"]["energy_estimator"], "measured");
    EXPECT_EQ(status["sky"]["lamps"].size(), static_cast<std::size_t>(std::min(published, max_sources - 1)))
        << status["sky"].dump();
    for (const auto& lamp : status["sky"]["lamps"]) EXPECT_GT(lamp["shadow_radius_deg"].get<double>(), 0.0);
    EXPECT_GE(status["sun_shadow_maps"]["drawn"].get<std::int64_t>(), 1);
    // /metrics counts them too (of the newest sky, which may have changed since the status).
    const std::string metrics = hmd.service().metrics_text();
    const std::size_t gauge = metrics.find("\nskylit_lamps_separated ");
    ASSERT_NE(gauge, std::string::npos) << metrics;
    const double lamps = std::stod(metrics.substr(gauge + std::string("\nskylit_lamps_separated ").size()));
    EXPECT_LE(lamps, max_sources - 1);
    if (max_sources == 1) {
      EXPECT_EQ(lamps, 0.0);
    }
    EXPECT_TRUE(hmd.error().empty()) << hmd.error();
  }
}

TEST(SiteLink, ABrokerThatIsDownAtStartIsWaitedFor) {
  test::MosquittoBroker broker;
  broker.stop();
  Rig rig;
  std::ofstream(rig.dir() / "hmd_node.yaml") << hmd_node_config(rig, broker.port());
  RunningService hmd(live::load_live_config(rig.dir() / "hmd_node.yaml"), quiet_options());
  // No broker, no sky: the camera image alone, flagged, the service up.
  ASSERT_TRUE(hmd.wait_for([](const nlohmann::json& s) {
    return frames_of(s) >= 3 && has_flag(s, "broker_unreachable") && has_flag(s, "no_sky_yet");
  })) << hmd.status().dump(2);
  EXPECT_FALSE(hmd.status()["sky"]["last_error"].get<std::string>().empty());
  broker.start();
  ASSERT_TRUE(hmd.wait_for([](const nlohmann::json& s) { return s["sky"]["connected"] == true; })) << hmd.status().dump(2);
  EXPECT_TRUE(hmd.error().empty()) << hmd.error();
}

TEST(SiteLink, ConfigErrorsNameTheField) {
  Rig rig;
  std::string text = hmd_node_config(rig, 1883);
  text.replace(text.find("127.0.0.1:1883"), 14, "127.0.0.1");
  std::ofstream(rig.dir() / "bad.yaml") << text;
  try {
    live::load_live_config(rig.dir() / "bad.yaml");
    FAIL() << "a broker without a port was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("sky.source.broker"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("HOST:PORT"), std::string::npos) << e.what();
  }
  std::ofstream(rig.dir() / "sky_bad.yaml") << "site: a.yaml\nbake: b\nsky:\n  source: {kind: mqtt, broker: 127.0.0.1:1}\n"
                                            << "link: {broker: 127.0.0.1:1883}\n";
  try {
    live::load_sky_node_config(rig.dir() / "sky_bad.yaml");
    FAIL() << "a sky node that takes its sky from MQTT was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("sky.source"), std::string::npos) << e.what();
  }
  // The ground's shadow contrast is an HMD node's: its camera sees the ground.
  std::string contrast = sky_node_config(rig, 1883);
  contrast.insert(contrast.find("link:"), "  clipped_sun_energy: shadow_contrast\n");
  std::ofstream(rig.dir() / "sky_contrast.yaml") << contrast;
  try {
    live::load_sky_node_config(rig.dir() / "sky_contrast.yaml");
    FAIL() << "a sky node with shadow_contrast was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("sky.clipped_sun_energy"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("HMD nodes"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace skylit::live_test
