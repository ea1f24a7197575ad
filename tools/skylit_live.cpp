// skylit-live: the live compositor service.
//
//     skylit-live CONFIG.yaml [--headless] [--record OUT.mp4|DIR] [--frames N] [--status ADDR:PORT]
//
// SIGINT and SIGTERM end it cleanly (the recording is closed, threads joined).
#include <signal.h>

#include <atomic>
#include <cstdio>
#include <ctime>
#include <optional>
#include <string>
#include <thread>

#include <CLI/CLI.hpp>

#include "skylit/base/error.hpp"
#include "skylit/live/live_config.hpp"
#include "skylit/live/service.hpp"
#include "command_line.hpp"

namespace {

// Waits for SIGINT/SIGTERM on a thread of its own (the signals are blocked in every other
// thread, so no handler runs in the middle of a frame) and stops the service.
class SignalWatcher {
 public:
  SignalWatcher(skylit::live::Service& service, bool quiet) {
    thread_ = std::thread([this, &service, quiet] {
      sigset_t set;
      sigemptyset(&set);
      sigaddset(&set, SIGINT);
      sigaddset(&set, SIGTERM);
      const timespec wait{0, 200'000'000};
      while (!done_) {
        const int signal = sigtimedwait(&set, nullptr, &wait);
        if (signal == SIGINT || signal == SIGTERM) {
          if (!quiet) std::fprintf(stderr, "\nskylit-live: %s, stopping\n", signal == SIGINT ? "SIGINT" : "SIGTERM");
          service.stop();
        }
      }
    });
  }
  ~SignalWatcher() {
    done_ = true;
    thread_.join();
  }
  SignalWatcher(const SignalWatcher&) = delete;
  SignalWatcher& operator=(const SignalWatcher&) = delete;

 private:
  std::atomic<bool> done_{false};
  std::thread thread_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"skylit-live: sky and HMD camera frames in, composited frames out", "skylit-live"};
  skylit::tools::add_version_flag(app);
  std::string config_file, record, status;
  std::int64_t frames = 0;
  bool headless = false, profile = false, quiet = false;
  app.add_option("config", config_file, "the service's YAML configuration (docs/live.md)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_flag("--headless", headless, "no window, whatever the config says");
  app.add_option("--record", record, "write composited frames: a video (.mp4, .avi) or a folder of PNGs");
  app.add_option("--frames", frames, "stop after this many frames")->check(CLI::PositiveNumber);
  app.add_option("--status", status, "serve /status, /metrics, /sky.jpg, /frame.jpg on ADDR:PORT");
  app.add_flag("--profile", profile, "wait for the GPU after each stage, so that stage times are true");
  app.add_flag("-q,--quiet", quiet, "only warnings and errors: no progress line, no final status");
  if (const auto status_code = skylit::tools::parse_command_line(app, argc, argv)) return *status_code;

  // Block the signals before any thread starts, so that every thread inherits the mask.
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);

  try {
    const skylit::live::LiveConfig config = skylit::live::load_live_config(config_file);
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
    const SignalWatcher watcher(service, quiet);
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
