#pragma once
// skylit-sky-node's service (docs/site.md): the sky stage alone — sky frames → S and the sun, the
// code skylit-live's sky thread runs — publishing each new sky to the site's broker for every HMD
// node, the dome overlay once a second, and answering /status, /metrics and /site (every HMD node
// it has heard of).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "skylit/live/live_config.hpp"

namespace skylit::live {

struct SkyNodeOptions {
  std::optional<std::string> broker;         // "HOST:PORT": overrides link.broker
  std::optional<std::string> status_listen;  // overrides status.listen
  std::optional<std::int64_t> frames;        // stop after publishing this many skies
  bool quiet = false;                        // no progress line on stderr
};

class SkyNode {
 public:
  // Loads the site, the bake's manifest (the dome the skies are for), the sky camera's calibration
  // and source; connects in the background. InputError for anything wrong in them.
  SkyNode(const SkyNodeConfig& config, const SkyNodeOptions& options);
  ~SkyNode();  // says goodbye on the broker ("offline", retained)
  SkyNode(const SkyNode&) = delete;
  SkyNode& operator=(const SkyNode&) = delete;

  // Runs until stop(), the sky count, or the end of a finite sky source; returns the skies
  // published (estimated while the broker was away they are counted, and the newest is published
  // again on reconnection).
  std::int64_t run();
  void stop();  // safe from any thread

  std::string status_json() const;
  std::string metrics_text() const;
  std::string site_json() const;
  std::string status_address() const;  // empty without a status server

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace skylit::live
