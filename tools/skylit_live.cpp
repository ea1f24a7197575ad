// skylit-live: the live compositor service.
//
//     skylit-live CONFIG.yaml [--headless] [--record OUT.mp4|DIR] [--frames N] [--status ADDR:PORT]
//                 [--broker HOST:PORT]
//
// SIGINT and SIGTERM end it cleanly (the recording is closed, threads joined).
#include <cstdio>
#include <optional>
#include <string>
#include <tuple>

#include <CLI/CLI.hpp>

#include "skylit/base/error.hpp"
#include "skylit/live/live_config.hpp"
#include "skylit/live/service.hpp"
#include "skylit/sky_link/site_topics.hpp"
#include "command_line.hpp"
#include "signal_watcher.hpp"


int main(int argc, char** argv) {
  CLI::App app{"skylit-live: sky and HMD camera frames in, composited frames out", "skylit-live"};
  skylit::tools::add_version_flag(app);
  std::string config_file, record, status, broker;
  std::int64_t frames = 0;
  bool headless = false, profile = false, quiet = false;
  app.add_option("config", config_file, "the service's YAML configuration (docs/live.md)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_flag("--headless", headless, "no window, whatever the config says");
  app.add_option("--record", record, "write composited frames: a video (.mp4, .avi) or a folder of PNGs");
  app.add_option("--frames", frames, "stop after this many frames")->check(CLI::PositiveNumber);
  app.add_option("--status", status, "serve /status, /metrics, /sky.jpg, /frame.jpg on ADDR:PORT");
  app.add_option("--broker", broker, "the site's MQTT broker, overriding sky.source's (with sky.source kind mqtt)");
  app.add_flag("--profile", profile, "wait for the GPU after each stage, so that stage times are true");
  app.add_flag("-q,--quiet", quiet, "only warnings and errors: no progress line, no final status");
  if (const auto status_code = skylit::tools::parse_command_line(app, argc, argv)) return *status_code;

  skylit::tools::block_stop_signals();
  try {
    skylit::live::LiveConfig config = skylit::live::load_live_config(config_file);
    if (!broker.empty()) {
      if (!config.sky.link) {
        throw skylit::InputError("--broker " + broker + ": " + config_file +
                                 " takes its skies from a sky camera, not from a broker. Fix: set sky.source to "
                                 "{kind: mqtt, broker: HOST:PORT} (docs/site.md), or leave --broker out");
      }
      std::tie(config.sky.link->mqtt.host, config.sky.link->mqtt.port) =
          skylit::sky_link::parse_broker_address(broker, "--broker");
    }
    skylit::live::ServiceOptions options;
    options.headless = headless || !(config.output.window || config.display);  // a display section opens the window
    if (frames > 0) options.frames = frames;
    if (!record.empty()) options.record = record;
    if (!status.empty()) options.status_listen = status;
    options.profile = profile;
    options.quiet = quiet;
    skylit::live::Service service(config, options);
    if (!service.status_address().empty() && !quiet) {
      std::fprintf(stderr, "skylit-live: status on http://%s/status\n", service.status_address().c_str());
    }
    const skylit::tools::SignalWatcher watcher([&service] { service.stop(); }, "skylit-live", quiet);
    const std::int64_t done = service.run();
    if (!quiet) {
      std::printf("skylit-live: %lld frames composited\n", static_cast<long long>(done));
      std::fputs(service.status_json().c_str(), stdout);
    }
  } catch (const skylit::InputError& e) {
    std::fprintf(stderr, "skylit-live: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-live: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
