#pragma once
// What the sky node keeps of the HMD nodes it hears on the broker (/site, docs/site.md): each
// node's last status as it published it, bounded in size and in count, so that no publisher can
// grow the sky node's memory or break its pages.
#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "skylit/live/status_server.hpp"

namespace skylit::live {

inline constexpr std::size_t kMaxHmdStatusBytes = 64 * 1024;  // an HMD node's status is about 1 kB
inline constexpr std::size_t kMaxHmdNodes = 1024;
inline constexpr std::size_t kMaxHmdNodeNameBytes = 128;

class HeardNodes {
 public:
  // Node `name`'s status payload, heard at `now` (steady seconds). A payload that is not a JSON
  // object, or is larger than kMaxHmdStatusBytes, is kept as {"state": "unreadable"}. A name that
  // is empty, longer than kMaxHmdNodeNameBytes, not UTF-8 or with control characters is ignored
  // (returns false). Past kMaxHmdNodes, the node heard least recently is forgotten.
  bool hear(const std::string& name, std::span<const std::uint8_t> payload, double now);

  // /site's "nodes": per node, its name, the seconds since it was heard and the fields the
  // console shows (null where its status lacks them).
  nlohmann::json site_entries(double now) const;
  std::size_t size() const { return nodes_.size(); }

 private:
  struct Heard {
    nlohmann::json status;
    double heard = 0;
  };
  std::map<std::string, Heard> nodes_;
};

// The /metrics lines of site_entries(): seconds since heard, online, frame rate, labelled by node.
void append_hmd_node_metrics(const nlohmann::json& site_entries, std::vector<Metric>& metrics);

// `name="value"` with the value escaped as Prometheus' text format requires (\\, \" and \n).
std::string prometheus_label(std::string_view name, std::string_view value);

}  // namespace skylit::live
