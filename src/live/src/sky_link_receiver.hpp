#pragma once
// An HMD node's end of the site link (docs/site.md): the sky node's skies, checked against this
// node's bake and taken newest-first; the sky node's state and overlay; and this node's own
// status, published retained with a last will that says it is gone.
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "skylit/live/live_config.hpp"
#include "skylit/live/mailbox.hpp"
#include "skylit/sky_link/mqtt_client.hpp"
#include "skylit/sky_link/site_topics.hpp"
#include "skylit/sky_link/sky_message.hpp"

namespace skylit::live {

class SkyLinkReceiver {
 public:
  // Connects in the background (a broker that is down is retried, never an error).
  SkyLinkReceiver(const LinkSettings& link, const sky_link::SkyIdentity& identity, const std::string& site_name);
  ~SkyLinkReceiver();
  SkyLinkReceiver(const SkyLinkReceiver&) = delete;
  SkyLinkReceiver& operator=(const SkyLinkReceiver&) = delete;

  // The newest sky taken since the last call, waiting up to `timeout`; empty on timeout or close.
  std::optional<sky_link::SkyMessage> take(std::chrono::milliseconds timeout) { return skies_.take(timeout); }
  void close() { skies_.close(); }

  // The sky node's dome overlay (JPEG), as last published; empty before one came.
  std::vector<std::uint8_t> overlay() const;
  // Publishes this node's status (retained on ROOT/nodes/NODE); false while disconnected.
  bool publish_status(const nlohmann::json& status);

  bool connected() const { return client_.connected(); }
  // The sky node said "offline" (its will, or a goodbye) and has not come back.
  bool sky_node_offline() const;
  // For /status: the broker, the connection, the sky node's state, skies taken and dropped.
  nlohmann::json report() const;
  // Skies dropped per reason (index: sky_link::DropReason), for /metrics.
  std::array<std::uint64_t, 7> drops() const;
  std::uint64_t taken() const { return taken_; }
  const sky_link::SiteTopics& topics() const { return topics_; }
  const std::string& node() const { return node_; }

 private:
  void on_sky(std::span<const std::uint8_t> payload);

  sky_link::SiteTopics topics_;
  std::string node_;
  sky_link::SkyIdentity identity_;
  Mailbox<sky_link::SkyMessage> skies_;
  mutable std::mutex mutex_;
  std::optional<sky_link::SkyOrder> last_;   // the newest sky taken
  std::array<std::uint64_t, 7> drops_{};
  std::string last_drop;                     // "other_dome: dome frequency: sky 4, bake 2"
  std::string sky_node_state_ = "unknown";   // online | offline | unknown (nothing heard)
  std::vector<std::uint8_t> overlay_;
  std::atomic<std::uint64_t> taken_{0};
  std::atomic<std::uint64_t> repeated_{0};
  sky_link::MqttClient client_;              // last: its thread calls into the members above
};

}  // namespace skylit::live
