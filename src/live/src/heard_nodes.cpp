#include "skylit/live/heard_nodes.hpp"

#include <algorithm>

namespace skylit::live {
namespace {

// UTF-8 without control characters (what a topic level of a well-behaved client holds).
bool printable_utf8(const std::string& text) {
  for (std::size_t i = 0; i < text.size();) {
    const auto byte = static_cast<unsigned char>(text[i]);
    std::size_t length = 0;
    if (byte < 0x20 || byte == 0x7f) return false;
    if (byte < 0x80) {
      length = 1;
    } else if ((byte & 0xe0) == 0xc0 && byte >= 0xc2) {
      length = 2;
    } else if ((byte & 0xf0) == 0xe0) {
      length = 3;
    } else if ((byte & 0xf8) == 0xf0 && byte <= 0xf4) {
      length = 4;
    } else {
      return false;
    }
    if (i + length > text.size()) return false;
    for (std::size_t k = 1; k < length; ++k) {
      if ((static_cast<unsigned char>(text[i + k]) & 0xc0) != 0x80) return false;
    }
    if (length > 1) {
      // Overlong forms, surrogates and code points past U+10FFFF, which nlohmann refuses to dump.
      const auto second = static_cast<unsigned char>(text[i + 1]);
      if (byte == 0xe0 && second < 0xa0) return false;
      if (byte == 0xed && second >= 0xa0) return false;
      if (byte == 0xf0 && second < 0x90) return false;
      if (byte == 0xf4 && second >= 0x90) return false;
    }
    i += length;
  }
  return true;
}

}  // namespace

bool HeardNodes::hear(const std::string& name, std::span<const std::uint8_t> payload, double now) {
  if (name.empty() || name.size() > kMaxHmdNodeNameBytes || !printable_utf8(name)) return false;
  nlohmann::json status;
  if (payload.size() <= kMaxHmdStatusBytes) {
    status = nlohmann::json::parse(payload.begin(), payload.end(), nullptr, false);
  }
  if (status.is_discarded() || !status.is_object()) status = {{"state", "unreadable"}};
  if (nodes_.size() >= kMaxHmdNodes && nodes_.find(name) == nodes_.end()) {
    const auto oldest = std::min_element(nodes_.begin(), nodes_.end(),
                                         [](const auto& a, const auto& b) { return a.second.heard < b.second.heard; });
    nodes_.erase(oldest);
  }
  nodes_[name] = {std::move(status), now};
  return true;
}

nlohmann::json HeardNodes::site_entries(double now) const {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& [name, heard] : nodes_) {
    nlohmann::json entry;
    entry["node"] = name;
    entry["seconds_since_heard"] = now - heard.heard;
    for (const char* key : {"state", "frame_rate", "frame_time_ms", "latency_ms", "sky_to_screen_ms", "flags", "sky_sequence", "frames"}) {
      entry[key] = heard.status.contains(key) ? heard.status[key] : nlohmann::json(nullptr);
    }
    list.push_back(std::move(entry));
  }
  return list;
}

void append_hmd_node_metrics(const nlohmann::json& site_entries, std::vector<Metric>& m) {
  for (const auto& node : site_entries) {
    const std::string label = prometheus_label("node", node["node"].get<std::string>());
    m.push_back({"skylit_hmd_node_seconds_since_heard", "Seconds since each HMD node's last status.", "gauge",
                 node["seconds_since_heard"].get<double>(), label});
    m.push_back({"skylit_hmd_node_online", "1 while an HMD node's last status says it runs.", "gauge",
                 node["state"] == "offline" || node["state"] == "stopped" ? 0.0 : 1.0, label});
    if (node["frame_rate"].is_number()) {
      m.push_back({"skylit_hmd_node_frame_rate", "Each HMD node's frame rate, as it last said.", "gauge",
                   node["frame_rate"].get<double>(), label});
    }
  }
}

std::string prometheus_label(std::string_view name, std::string_view value) {
  std::string out(name);
  out += "=\"";
  for (const char c : value) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '"') {
      out += "\\\"";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  out += '"';
  return out;
}

}  // namespace skylit::live
