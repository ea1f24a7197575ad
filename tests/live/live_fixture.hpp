#pragma once
// Shared by the service's end-to-end tests: the small baked site of tests/compose (a 4 m tower and
// a 1.5 m annex on real ground, baked once per program), a tiny sky camera and HMD camera, sky and
// camera frames written by the test, and a skylit-live config in a temporary folder. The service
// runs in-process on a thread of its own (it makes its own GL context there).
#include <unistd.h>

#include <atomic>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "../compose/compose_fixture.hpp"
#include "../support/temp_dir.hpp"
#include "skylit/live/live_config.hpp"
#include "skylit/live/service.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_model.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::live_test {

namespace fs = std::filesystem;
using compose_test::BakedSite;
using Eigen::Vector3d;

// The sun of every sky the tests record: west-south-west, 35° up (the tower then shades the
// ground east-north-east of it).
inline constexpr double kSunAzimuthDeg = 250.0;
inline constexpr double kSunElevationDeg = 35.0;

// Where the HMD camera stands and looks (fixed pose): south-east of the tower, high enough to see
// the ground behind it.
inline const Vector3d kEye(11.0, -3.0, 8.0);
inline const Vector3d kTarget(2.0, 1.0, 0.5);

inline std::string quoted(const fs::path& path) { return std::string("'").append(path.string()).append("'"); }

// A pinhole HMD camera of width × height, 75° wide, mild barrel distortion (docs/sky.md schema).
inline void write_hmd_calibration(const fs::path& file, int width, int height) {
  const double f = 0.5 * width / std::tan(37.5 * std::numbers::pi / 180.0);
  std::ofstream(file) << "image_width: " << width << "\nimage_height: " << height << "\nmodel: pinhole\n"
                      << "fx: " << f << "\nfy: " << f << "\ncx: " << 0.5 * width - 0.5 << "\ncy: " << 0.5 * height - 0.5
                      << "\nD: [-0.1, 0.03, 0.0, 0.0, 0.0]\n"
                      << "R_site_from_camera: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nt_site_from_camera: [0, 0, 0]\n";
}

// An equidistant fisheye at the zenith whose 180° circle just fits a size × size image.
inline void write_sky_calibration(const fs::path& file, int size) {
  const double f = 0.98 * (0.5 * size) / (0.5 * std::numbers::pi);
  std::ofstream(file) << "image_width: " << size << "\nimage_height: " << size << "\nmodel: fisheye\n"
                      << "fx: " << f << "\nfy: " << f << "\ncx: " << 0.5 * size - 0.5 << "\ncy: " << 0.5 * size - 0.5
                      << "\nD: [0, 0, 0, 0]\n"
                      << "R_site_from_camera: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nt_site_from_camera: [0, 0, 0]\n";
}

// A clear sky (Preetham sky and ESRA sun) with the sun at azimuth/elevation, as the sky camera
// of `calibration` records it: linear float radiance.
inline cv::Mat clear_sky_frame(const fs::path& calibration, double azimuth_deg, double elevation_deg) {
  const camera::Lens lens(camera::load_calibration(calibration));
  sky::RenderOptions options;
  options.supersample = 2;
  return sky::render_fisheye(lens, sky::sky_function(sky::ClearSky(compose_test::from_angles(azimuth_deg, elevation_deg))),
                             options);
}

// An 8-bit camera frame of the real world: grey ground-like codes with a checker of 6-pixel
// cells whose phase moves with `index` (so that frames can be told apart).
inline cv::Mat camera_frame(int width, int height, int index) {
  cv::Mat image(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const bool light = ((x + 2 * index) / 6 + y / 6) % 2 == 0;
      const int base = light ? 172 : 148;
      image.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<std::uint8_t>(base - 8), static_cast<std::uint8_t>(base),
                                            static_cast<std::uint8_t>(base + 6));
    }
  }
  return image;
}

// A folder of frames with a frames.csv (file,timestamp).
inline void write_frames(const fs::path& dir, const std::vector<cv::Mat>& frames, double fps, const std::string& ext) {
  fs::create_directories(dir);
  std::string csv = "file,timestamp\n";
  for (std::size_t k = 0; k < frames.size(); ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%04zu.%s", k, ext.c_str());
    if (ext == "exr") {
      sky::write_sky_exr(dir / name, frames[k]);
    } else {
      cv::imwrite((dir / name).string(), frames[k]);
    }
    csv += std::string(name) + "," + std::to_string(static_cast<double>(k) / fps) + "\n";
  }
  std::ofstream(dir / "frames.csv") << csv;
}

// What a test changes in the config; the rest is the fixed rig.
struct RigOptions {
  int hmd_width = 96;
  int hmd_height = 72;
  int sky_size = 160;
  int camera_frames = 3;
  double camera_fps = 30;
  bool camera_loop = true;
  std::string camera_realtime = "1";   // the source's `realtime:` ("" for none)
  int sky_frames = 1;
  bool sky_loop = false;
  std::string sky_realtime;            // "" for none
  std::string sun = "auto";
  int max_sources = 1;                 // sky.max_sources (written when above 1)
  double stale_after = 30;
  std::string status;                  // status.listen, "" for none
  std::string camera_source_extra;     // more YAML in camera.source (lines indented by 4)
  std::string extra;                   // more top-level YAML
  std::string pose;                    // the `pose:` node's YAML in place of the fixed pose ("" for it)
};

// A temporary folder with the rig's calibrations, frames and config.yaml.
class Rig {
 public:
  explicit Rig(const RigOptions& options = {}) : options_(options) {
    write_hmd_calibration(dir_ / "hmd.yaml", options.hmd_width, options.hmd_height);
    write_sky_calibration(dir_ / "sky.yaml", options.sky_size);
    std::vector<cv::Mat> skies;
    for (int k = 0; k < options.sky_frames; ++k) {
      skies.push_back(clear_sky_frame(dir_ / "sky.yaml", kSunAzimuthDeg + 2.0 * k, kSunElevationDeg));
    }
    write_frames(dir_ / "sky", skies, 2.0, "exr");
    for (int k = 0; k < options.camera_frames; ++k) camera_frames_.push_back(camera_frame(options.hmd_width, options.hmd_height, k));
    write_frames(dir_ / "camera", camera_frames_, options.camera_fps, "png");
    write_config(config_file());
  }
  Rig(const Rig&) = delete;
  Rig& operator=(const Rig&) = delete;

  const fs::path& dir() const { return dir_.path(); }
  fs::path config_file() const { return dir_ / "config.yaml"; }
  const std::vector<cv::Mat>& camera_frames() const { return camera_frames_; }
  live::LiveConfig config() const { return live::load_live_config(config_file()); }

  // The config as YAML (the baked site's files by absolute path, the rest beside it).
  std::string config_text() const {
    const BakedSite& baked = BakedSite::get();
    std::ostringstream out;
    out << "root: /\n"  // the baked site lies in the suite's folder, not under this config's
        << "site: " << quoted(baked.dir / "site.yaml") << "\n"
        << "bake: " << quoted(baked.dir / "bake") << "\n"
        << "sky:\n"
        << "  calibration: sky.yaml\n"
        << "  source:\n    kind: images\n    path: sky\n    loop: " << (options_.sky_loop ? "true" : "false") << "\n"
        << (options_.sky_realtime.empty() ? "" : "    realtime: " + options_.sky_realtime + "\n")
        << "  rate: 0\n"
        << "  sun: " << options_.sun << "\n"
        << (options_.max_sources > 1 ? "  max_sources: " + std::to_string(options_.max_sources) + "\n" : std::string())
        << "  stale_after: " << options_.stale_after << "\n"
        << "camera:\n"
        << "  calibration: hmd.yaml\n"
        << "  source:\n    kind: images\n    path: camera\n    loop: " << (options_.camera_loop ? "true" : "false") << "\n"
        << (options_.camera_realtime.empty() ? "" : "    realtime: " + options_.camera_realtime + "\n")
        << options_.camera_source_extra;
    if (options_.pose.empty()) {
      out << "pose:\n  kind: fixed\n"
          << "  position: [" << kEye.x() << ", " << kEye.y() << ", " << kEye.z() << "]\n"
          << "  look_at: [" << kTarget.x() << ", " << kTarget.y() << ", " << kTarget.z() << "]\n";
    } else {
      out << options_.pose;
    }
    if (!options_.status.empty()) out << "status:\n  listen: " << options_.status << "\n";
    out << options_.extra;
    return out.str();
  }
  void write_config(const fs::path& file) const { std::ofstream(file) << config_text(); }

 private:
  RigOptions options_;
  test::TempDir dir_{"skylit_live_"};
  std::vector<cv::Mat> camera_frames_;
};

// A service running on a thread of its own; stopped and joined on destruction.
class RunningService {
 public:
  RunningService(const live::LiveConfig& config, const live::ServiceOptions& options)
      : service_(config, options), thread_([this] {
          try {
            frames_ = service_.run();
          } catch (const std::exception& e) {
            error_ = e.what();
          }
          done_ = true;
        }) {}
  ~RunningService() {
    service_.stop();
    if (thread_.joinable()) thread_.join();
  }
  RunningService(const RunningService&) = delete;
  RunningService& operator=(const RunningService&) = delete;

  live::Service& service() { return service_; }
  nlohmann::json status() const { return nlohmann::json::parse(service_.status_json()); }
  bool done() const { return done_; }
  // Waits (up to `timeout_s`) until `condition` holds for the status; false on timeout or when
  // the service ended first.
  bool wait_for(const std::function<bool(const nlohmann::json&)>& condition, double timeout_s = 60) const {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      if (condition(status())) return true;
      if (done_) return condition(status());
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }
  // Stops the service and waits for run() to return; its frame count.
  std::int64_t finish() {
    service_.stop();
    if (thread_.joinable()) thread_.join();
    return frames_;
  }
  // Waits for run() to return by itself (a frame count or a finite camera source).
  std::int64_t join() {
    if (thread_.joinable()) thread_.join();
    return frames_;
  }
  const std::string& error() const { return error_; }

 private:
  live::Service service_;
  std::int64_t frames_ = -1;
  std::string error_;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

inline live::ServiceOptions quiet_options() {
  live::ServiceOptions options;
  options.quiet = true;
  return options;
}

// Resident set size of this process, bytes (/proc/self/statm, second field).
inline std::int64_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  std::int64_t size = 0, resident = 0;
  statm >> size >> resident;
  return resident * static_cast<std::int64_t>(::sysconf(_SC_PAGESIZE));
}

// Largest |a − b| over all channels of two 8-bit images of one size.
inline int max_difference(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat difference;
  cv::absdiff(a, b, difference);
  double max = 0;
  cv::minMaxLoc(difference.reshape(1), nullptr, &max);
  return static_cast<int>(max);
}

// Frames composited so far, by the service's status report.
inline std::int64_t frames_of(const nlohmann::json& status) { return status["frames"].get<std::int64_t>(); }

// Whether the status report raises `flag`.
inline bool has_flag(const nlohmann::json& status, const std::string& flag) {
  const auto& flags = status["flags"];
  return std::any_of(flags.begin(), flags.end(), [&](const nlohmann::json& f) { return f == flag; });
}

}  // namespace skylit::live_test
