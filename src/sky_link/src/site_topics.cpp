#include "skylit/sky_link/site_topics.hpp"

#include <unistd.h>

#include <array>
#include <cctype>
#include <string_view>

#include "skylit/base/error.hpp"

namespace skylit::sky_link {
namespace {

std::string topic_level(std::string_view text) {
  std::string out;
  bool gap = false;
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) != 0 && u < 128) {
      if (gap && !out.empty()) out += '-';
      out += static_cast<char>(std::tolower(u));
      gap = false;
    } else {
      gap = true;
    }
  }
  return out;
}

}  // namespace

std::string SiteTopics::node_of(const std::string& topic) const {
  const std::string prefix = root + "/nodes/";
  if (topic.size() <= prefix.size() || topic.compare(0, prefix.size(), prefix) != 0) return {};
  const std::string name = topic.substr(prefix.size());
  return name.find('/') == std::string::npos ? name : std::string();
}

std::string default_topic_root(const std::string& site_name) {
  const std::string level = topic_level(site_name);
  return "skylit/" + (level.empty() ? std::string("site") : level);
}

std::string node_name(const std::string& wanted) {
  std::string name = topic_level(wanted);
  if (name.empty()) {
    std::array<char, 256> host{};
    if (::gethostname(host.data(), host.size() - 1) == 0) name = topic_level(host.data());
  }
  return name.empty() ? std::string("node") : name;
}

std::pair<std::string, int> parse_broker_address(const std::string& text, const std::string& field) {
  const std::size_t colon = text.rfind(':');
  const auto fail = [&](const std::string& why) -> std::pair<std::string, int> {
    throw InputError(field + " '" + text + "': " + why + ". Fix: give the broker as HOST:PORT, e.g. 127.0.0.1:1883");
  };
  if (colon == std::string::npos || colon == 0) return fail("no HOST:PORT");
  const std::string port_text = text.substr(colon + 1);
  int port = 0;
  for (const char c : port_text) {
    if (std::isdigit(static_cast<unsigned char>(c)) == 0 || port > 65535) return fail("the port is not a number in 1..65535");
    port = port * 10 + (c - '0');
  }
  if (port_text.empty() || port < 1 || port > 65535) return fail("the port is not a number in 1..65535");
  std::string host = text.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);  // [::1]
  return {host, port};
}

}  // namespace skylit::sky_link
