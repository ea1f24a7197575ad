#pragma once
// The live service: sky frames → S (sky thread), HMD camera frames (camera thread), and the
// render thread that blends, shades and composites each camera frame with the newest sky and
// the pose at its time. Threads hand the newest value to the next through latest-value
// mailboxes, so a slow stage drops frames instead of queueing them: memory stays flat for hours.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "skylit/live/live_config.hpp"

namespace skylit::live {

struct ServiceOptions {
  bool headless = true;                       // no window, whatever the config says
  std::optional<std::int64_t> frames;         // stop after this many composited frames
  // or after this many composited with a sky (the building drawn lit), however long the first
  // sky takes: what a test that compares lit frames waits for.
  std::optional<std::int64_t> frames_with_sky;
  std::optional<std::filesystem::path> record; // overrides output.record
  std::optional<std::string> status_listen;   // overrides status.listen
  bool profile = false;                       // wait for the GPU after each stage (true per-stage times)
  bool quiet = false;                         // no progress line on stderr
};

class Service {
 public:
  // Loads the site, bake, calibrations, sources and GPU objects; refuses to start (InputError)
  // when the bake does not match the site (dome, basis, planes), naming what differs.
  Service(const LiveConfig& config, const ServiceOptions& options);
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  // Runs until stop(), the frame count, or the end of a finite camera source. The calling thread
  // becomes the render thread (it owns the GL context). Returns the number of frames composited.
  std::int64_t run();
  // Ends run() soon; safe from any thread (a signal handler's thread, the status server).
  void stop();

  // What /status and /metrics answer (thread-safe).
  std::string status_json() const;
  std::string metrics_text() const;
  // The bound status address ("127.0.0.1:8080"), empty without a status server.
  std::string status_address() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Refuses a bake that was not made for this site: the planes (names, geometry, resolution) must
// agree, and so must the dome's frequency and basis, unless the bake was made with the preset the
// config names (skylit-bake --preset P, then `preset: P`), whose dome replaces the site's. A bake
// made with a preset needs that preset in the config. InputError listing every difference and the fix.
void check_bake_matches_site(const std::filesystem::path& bake_dir, const std::filesystem::path& site_file,
                             const std::string& config_preset = "");

}  // namespace skylit::live
