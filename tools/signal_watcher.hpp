#pragma once
// SIGINT and SIGTERM for a service: blocked in every thread (block_stop_signals() before any
// thread starts), then waited for on a thread of the watcher's own, which calls `stop`, so that no
// handler runs in the middle of a frame.
#include <signal.h>

#include <atomic>
#include <cstdio>
#include <ctime>
#include <functional>
#include <string>
#include <thread>
#include <utility>

namespace skylit::tools {

inline void block_stop_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
}

class SignalWatcher {
 public:
  SignalWatcher(std::function<void()> stop, std::string program, bool quiet)
      : thread_([this, stop = std::move(stop), program = std::move(program), quiet] {
          sigset_t set;
          sigemptyset(&set);
          sigaddset(&set, SIGINT);
          sigaddset(&set, SIGTERM);
          const timespec wait{0, 200'000'000};
          while (!done_) {
            const int signal = sigtimedwait(&set, nullptr, &wait);
            if (signal == SIGINT || signal == SIGTERM) {
              if (!quiet) std::fprintf(stderr, "\n%s: %s, stopping\n", program.c_str(), signal == SIGINT ? "SIGINT" : "SIGTERM");
              stop();
            }
          }
        }) {}
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

}  // namespace skylit::tools
