#pragma once
// Where a site's nodes meet on the broker, under one root per site (docs/site.md, "Topics"):
// ROOT/sky (the latest sky, CBOR), ROOT/sky/overlay (JPEG, once a second), ROOT/sky/state (the
// sky node's "online" or its will "offline"), ROOT/nodes/NODE (each HMD node's status, JSON, or its
// will). All retained.
#include <string>
#include <utility>

namespace skylit::sky_link {

struct SiteTopics {
  std::string root;

  std::string sky() const { return root + "/sky"; }
  std::string overlay() const { return root + "/sky/overlay"; }
  std::string sky_state() const { return root + "/sky/state"; }
  std::string node(const std::string& name) const { return root + "/nodes/" + name; }
  std::string nodes() const { return root + "/nodes/+"; }  // every node's status
  // NODE of ROOT/nodes/NODE; empty for another topic.
  std::string node_of(const std::string& topic) const;
};

// skylit/<the site's name in lower case, runs of other characters than a-z and 0-9 as one '-'>:
// "Sample Gate" → skylit/sample-gate.
std::string default_topic_root(const std::string& site_name);

// A topic level for a node's name: the same rule ("hmd 1" → hmd-1); the host name when empty.
std::string node_name(const std::string& wanted);

// "HOST:PORT" → host and port; InputError naming `field` and the fix otherwise.
std::pair<std::string, int> parse_broker_address(const std::string& text, const std::string& field);

}  // namespace skylit::sky_link
