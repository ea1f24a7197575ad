#include "sky_link_receiver.hpp"

#include <cstdio>

namespace skylit::live {
namespace {

sky_link::MqttSettings with_will(sky_link::MqttSettings mqtt, const std::string& topic, const std::string& node) {
  mqtt.client_id = "skylit-hmd-" + node;
  mqtt.will = sky_link::MqttWill{topic, nlohmann::json{{"node", node}, {"state", "offline"}}.dump(), true};
  return mqtt;
}

std::string topic_root(const LinkSettings& link, const std::string& site_name) {
  return link.topic.empty() ? sky_link::default_topic_root(site_name) : link.topic;
}

}  // namespace

SkyLinkReceiver::SkyLinkReceiver(const LinkSettings& link, const sky_link::SkyIdentity& identity, const std::string& site_name)
    : topics_{topic_root(link, site_name)},
      node_(sky_link::node_name(link.node)),
      identity_(identity),
      client_(with_will(link.mqtt, topics_.node(node_), node_)) {
  client_.subscribe(topics_.sky(), [this](const std::string&, std::span<const std::uint8_t> payload, bool) { on_sky(payload); });
  client_.subscribe(topics_.sky_state(), [this](const std::string&, std::span<const std::uint8_t> payload, bool) {
    std::lock_guard lock(mutex_);
    sky_node_state_ = std::string(payload.begin(), payload.end()) == "online" ? "online" : "offline";
  });
  client_.subscribe(topics_.overlay(), [this](const std::string&, std::span<const std::uint8_t> payload, bool) {
    std::lock_guard lock(mutex_);
    overlay_.assign(payload.begin(), payload.end());
  });
}

SkyLinkReceiver::~SkyLinkReceiver() {
  skies_.close();
  // A goodbye says this node stopped on purpose: its status becomes "stopped", not its will.
  client_.publish(topics_.node(node_), nlohmann::json{{"node", node_}, {"state", "stopped"}}.dump(), true);
}

void SkyLinkReceiver::on_sky(std::span<const std::uint8_t> payload) {
  std::optional<sky_link::SkyOrder> last;
  {
    std::lock_guard lock(mutex_);
    last = last_;
  }
  sky_link::DecodedSky decoded = sky_link::decode_sky_message(payload, identity_, last);
  if (decoded.dropped == sky_link::DropReason::OutOfOrder && last) {
    // The sky node publishes its newest sky again after each reconnection (a restarted broker
    // has lost the retained one): the very sky taken already is a repeat, not a sky out of order.
    const sky_link::DecodedSky again = sky_link::decode_sky_message(payload, identity_, std::nullopt);
    if (again.message && again.message->run == last->run && again.message->sequence == last->sequence) {
      ++repeated_;
      return;
    }
  }
  std::lock_guard lock(mutex_);
  if (!decoded.message) {
    ++drops_[static_cast<std::size_t>(decoded.dropped)];
    last_drop = std::string(sky_link::drop_reason_name(decoded.dropped)) + ": " + decoded.detail;
    std::fprintf(stderr, "skylit-live: dropped a sky from %s: %s\n", topics_.sky().c_str(), last_drop.c_str());
    return;
  }
  last_ = sky_link::SkyOrder(decoded.message->sequence, decoded.message->run);
  ++taken_;
  skies_.put(std::move(*decoded.message));
}

std::vector<std::uint8_t> SkyLinkReceiver::overlay() const {
  std::lock_guard lock(mutex_);
  return overlay_;
}

bool SkyLinkReceiver::publish_status(const nlohmann::json& status) {
  return client_.publish(topics_.node(node_), status.dump(), true);
}

bool SkyLinkReceiver::sky_node_offline() const {
  std::lock_guard lock(mutex_);
  return sky_node_state_ == "offline";
}

std::array<std::uint64_t, 7> SkyLinkReceiver::drops() const {
  std::lock_guard lock(mutex_);
  return drops_;
}

nlohmann::json SkyLinkReceiver::report() const {
  nlohmann::json j;
  j["broker"] = client_.address();
  j["connected"] = client_.connected();
  j["connections"] = client_.connections();
  j["last_error"] = client_.last_error();
  j["topic"] = topics_.sky();
  j["node"] = node_;
  std::lock_guard lock(mutex_);
  j["sky_node"] = sky_node_state_;
  j["skies_taken"] = taken_.load();
  j["skies_repeated"] = repeated_.load();  // the sky taken already, published again after a reconnection
  nlohmann::json dropped = nlohmann::json::object();
  for (std::size_t k = 1; k < drops_.size(); ++k) {
    dropped[std::string(sky_link::drop_reason_name(static_cast<sky_link::DropReason>(k)))] = drops_[k];
  }
  j["dropped"] = dropped;
  j["last_drop"] = last_drop;
  if (last_) j["sequence"] = last_->sequence;
  return j;
}

}  // namespace skylit::live
