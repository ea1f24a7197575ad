// An HMD node's status as the sky node hears it on the broker (live::HeardNodes): a topic level
// naming the node (first byte: its length) and a payload from anyone who can publish. /site
// stays JSON and /metrics stays Prometheus' text format whatever they hold.
#include <algorithm>
#include <string>
#include <vector>

#include "fuzz_target.hpp"
#include "skylit/live/heard_nodes.hpp"

namespace {

// One sample line: NAME{LABEL="VALUE",...} VALUE, with the label values' escapes complete.
bool well_formed_sample(const std::string& line) {
  std::size_t at = line.find_first_of("{ ");
  if (at == std::string::npos || at == 0) return false;
  if (line[at] == '{') {
    ++at;
    while (at < line.size() && line[at] != '}') {
      const std::size_t equals = line.find("=\"", at);
      if (equals == std::string::npos) return false;
      at = equals + 2;
      for (; at < line.size() && line[at] != '"'; ++at) {
        if (line[at] == '\\') {
          if (++at >= line.size() || (line[at] != '\\' && line[at] != '"' && line[at] != 'n')) return false;
        }
      }
      if (at >= line.size()) return false;
      ++at;  // the closing quote
      if (at < line.size() && line[at] == ',') ++at;
    }
    if (at >= line.size()) return false;
    ++at;  // '}'
  }
  return at < line.size() && line[at] == ' ' && at + 1 < line.size();
}

}  // namespace

SKYLIT_FUZZ_TARGET(hmd_status) {
  if (size == 0) return 0;
  const std::size_t name_length = std::min<std::size_t>(data[0], size - 1);
  const std::string name(reinterpret_cast<const char*>(data + 1), name_length);
  skylit::live::HeardNodes nodes;
  nodes.hear("hmd-1", std::span<const std::uint8_t>(), 1.0);
  nodes.hear(name, {data + 1 + name_length, size - 1 - name_length}, 2.0);
  const nlohmann::json entries = nodes.site_entries(3.0);
  (void)entries.dump(2);  // throws on a string that is not UTF-8
  std::vector<skylit::live::Metric> metrics;
  skylit::live::append_hmd_node_metrics(entries, metrics);
  const std::string text = skylit::live::prometheus_text(metrics);
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t end = text.find('\n', start);
    skylit::fuzz::require(end != std::string::npos, "every line ends");
    const std::string line = text.substr(start, end - start);
    skylit::fuzz::require(line.rfind("# ", 0) == 0 || well_formed_sample(line), "a metric line is well formed");
    start = end + 1;
  }
  return 0;
}
