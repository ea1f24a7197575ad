// The service's own frames per setting of the trade table (skylit-bench trade --live-seconds):
// skylit-live run on the setting's bake, end to end (see trade_rows.hpp, run_live).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/camera/calibration.hpp"
#include "skylit/render/building_irradiance.hpp"
#include "skylit/scene/site.hpp"
#include "trade_rows.hpp"

namespace skylit::study::trade {
namespace {

namespace fs = std::filesystem;

constexpr int kCameraHz = 60;
constexpr int kCameraImages = 24;  // looped

std::string shell_quoted(const fs::path& path) {
  std::string out = "'";
  for (const char c : path.string()) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string yaml_quoted(const fs::path& path) {
  std::string out = "'";
  for (const char c : path.string()) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

// The camera's frames and calibration, made once per size.
fs::path camera_folder(const fs::path& work_dir, const std::string& hmd_calib, int width, int height) {
  const fs::path dir = work_dir / ("camera_" + std::to_string(width) + "x" + std::to_string(height));
  if (fs::exists(dir / "hmd.yaml")) return dir;
  fs::create_directories(dir / "frames");
  cv::RNG random(20261127);
  for (int k = 0; k < kCameraImages; ++k) {
    cv::Mat image(height, width, CV_8UC3);
    random.fill(image, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(256));
    char name[32];
    std::snprintf(name, sizeof name, "frame_%03d.png", k);
    cv::imwrite((dir / "frames" / name).string(), image);
  }
  camera::save_calibration(study::scaled_camera(hmd_calib, width, height), dir / "hmd.yaml");
  return dir;
}

}  // namespace

LiveRun run_live(const TradeOptions& o, const Setting& s, const fs::path& site_file, const fs::path& bake_dir) {
  const std::string& program = o.live_program;
  const std::string& sky_calib = o.sky_calib;
  const double seconds = o.live_seconds, sky_interval = o.sky_interval;
  const fs::path work_dir = fs::path(o.out_dir) / "live";
  const fs::path camera = camera_folder(work_dir, o.hmd_calib, o.frame_width, o.frame_height);
  const fs::path dir = work_dir / s.label();
  fs::create_directories(dir);
  // The site as the bake was made for it: the trade's bakes set the dome themselves, and the
  // service refuses a bake whose dome differs from its site's.
  scene::Site site = scene::load_site(site_file);
  site.dome_frequency = s.bake.frequency;
  site.dome_basis = s.bake.basis;
  const fs::path site_copy = site_file.parent_path() / ("site_" + s.bake.name() + ".yaml");
  std::ofstream(site_copy) << scene::site_to_yaml(site);
  // The sky simulator's clear day, a sky frame every minute of sky time, `sky_interval` apart.
  const double interval = sky_interval > 0.0 ? sky_interval : 1.0;
  std::ostringstream config;
  config << "root: /\n"
         << "site: " << yaml_quoted(fs::absolute(site_copy)) << "\n"
         << "bake: " << yaml_quoted(fs::absolute(bake_dir)) << "\n"
         << "sky:\n  calibration: " << yaml_quoted(fs::absolute(sky_calib)) << "\n"
         << "  source:\n    kind: sky-sim\n    calibration: " << yaml_quoted(fs::absolute(sky_calib)) << "\n"
         << "    sky: clear\n    start: 2026-06-21T09:00:00+09:00\n    every: 1min\n    frames: 0\n"
         << "    latitude: " << o.sequence_lat << "\n    longitude: " << o.sequence_lon << "\n"
         << "    realtime: " << 60.0 / interval << "\n"
         << "  rate: 0\n  sun: " << (s.sun ? "auto" : "off") << "\n"
         << "  max_sources: " << (s.sun ? s.sources : 1) << "\n"
         << "  smoothing: " << s.smoothing << "\n"
         << "camera:\n  calibration: " << yaml_quoted(fs::absolute(camera / "hmd.yaml")) << "\n"
         << "  source: {kind: images, path: " << yaml_quoted(fs::absolute(camera / "frames")) << ", fps: " << kCameraHz
         << ", loop: true, realtime: 1}\n"
         << "pose: {kind: fixed, position: [0, " << -kVisitorDistance << ", 1.6], look_at: [0, 0, 3]}\n"
         << "blend:\n  device: auto\n  basis: " << blend::form_name(s.form.form) << "\n"
         << "  storage: " << (s.bits == 8 ? "unorm8" : "half") << "\n"
         << "  skip_threshold: " << s.skip_threshold << "\n  change_threshold: " << s.change_threshold << "\n"
         << "render:\n  scale: " << s.render_scale << "\n"
         << "  light_map_precision: " << render::light_map_precision_name(o.light_map_precision) << "\n";
  // The ground's light as the error measures it (the estimate with the bake's ground layer).
  if (o.ground_albedo > 0.0 && bake_format::read_manifest(bake_dir).ground) {
    config << "  ground_light: true\n  ground_albedo: " << o.ground_albedo << "\n";
  }
  std::ofstream(dir / "config.yaml") << config.str();
  const int frames = std::max(30, static_cast<int>(seconds * kCameraHz));
  const fs::path log = dir / "skylit-live.log";
  const std::string command = shell_quoted(program) + " " + shell_quoted(dir / "config.yaml") + " --headless --frames " +
                              std::to_string(frames) + " 2>" + shell_quoted(log);
  const auto start = std::chrono::steady_clock::now();
  std::FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) throw std::runtime_error("could not start " + program);
  std::string out;
  char buffer[4096];
  for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, n);
  const int status = ::pclose(pipe);
  LiveRun run;
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::size_t json_start = out.find('{');
  if (status != 0 || json_start == std::string::npos) {
    throw std::runtime_error("skylit-live failed on setting '" + s.label() + "' (exit status " + std::to_string(status) +
                             "): see " + log.string());
  }
  const nlohmann::json report = nlohmann::json::parse(out.substr(json_start));
  run.frames_per_second = report.value("frame_rate", 0.0);
  if (report.contains("frame_time_ms")) {
    run.frame_p50_ms = report["frame_time_ms"].value("p50", 0.0);
    run.frame_p99_ms = report["frame_time_ms"].value("p99", 0.0);
  }
  run.composited = report.value("frames", static_cast<std::int64_t>(0));
  run.dropped = report.value("dropped_frames", static_cast<std::int64_t>(0));
  if (report.contains("camera")) run.camera_frames = report["camera"].value("frames", static_cast<std::int64_t>(0));
  if (report.contains("blend")) run.device = report["blend"].value("device", std::string());
  return run;
}

}  // namespace skylit::study::trade
