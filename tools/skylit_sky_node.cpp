// skylit-sky-node: the sky stage of a site, once for every HMD (docs/site.md).
//
//     skylit-sky-node CONFIG.yaml [--broker HOST:PORT] [--status ADDR:PORT] [--frames N] [--headless]
//
// SIGINT and SIGTERM end it cleanly, with a goodbye on the broker.
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "skylit/base/error.hpp"
#include "skylit/live/live_config.hpp"
#include "skylit/live/sky_node.hpp"
#include "command_line.hpp"
#include "signal_watcher.hpp"

int main(int argc, char** argv) {
  CLI::App app{"skylit-sky-node: sky frames in, the site's sky out to every HMD node over MQTT", "skylit-sky-node"};
  skylit::tools::add_version_flag(app);
  std::string config_file, broker, status;
  std::int64_t frames = 0;
  bool headless = false, quiet = false;
  app.add_option("config", config_file, "the sky node's YAML configuration (docs/site.md)")->required()->check(CLI::ExistingFile);
  app.add_option("--broker", broker, "the site's MQTT broker HOST:PORT, overriding link.broker");
  app.add_option("--status", status, "serve /status, /metrics, /site and /sky.jpg on ADDR:PORT");
  app.add_option("--frames", frames, "stop after publishing this many skies")->check(CLI::PositiveNumber);
  // The sky node never opens a window (its overlay is /sky.jpg); the flag lets scripts pass the
  // same options to it as to skylit-live.
  app.add_flag("--headless", headless, "accepted for symmetry with skylit-live: the sky node has no window");
  app.add_flag("-q,--quiet", quiet, "only warnings and errors: no progress line, no final status");
  if (const auto status_code = skylit::tools::parse_command_line(app, argc, argv)) return *status_code;

  skylit::tools::block_stop_signals();
  try {
    const skylit::live::SkyNodeConfig config = skylit::live::load_sky_node_config(config_file);
    skylit::live::SkyNodeOptions options;
    if (!broker.empty()) options.broker = broker;
    if (!status.empty()) options.status_listen = status;
    if (frames > 0) options.frames = frames;
    options.quiet = quiet;
    skylit::live::SkyNode node(config, options);
    if (!node.status_address().empty() && !quiet) {
      std::fprintf(stderr, "skylit-sky-node: status on http://%s/status, the site on http://%s/site\n",
                   node.status_address().c_str(), node.status_address().c_str());
    }
    const skylit::tools::SignalWatcher watcher([&node] { node.stop(); }, "skylit-sky-node", quiet);
    const std::int64_t published = node.run();
    if (!quiet) {
      std::printf("skylit-sky-node: %lld skies published\n", static_cast<long long>(published));
      std::fputs(node.status_json().c_str(), stdout);
    }
  } catch (const skylit::InputError& e) {
    std::fprintf(stderr, "skylit-sky-node: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-sky-node: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
