#include "skylit/live/service.hpp"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "service_state.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/model.hpp"
#include "skylit/base/error.hpp"
#include "skylit/render/hmd_profile.hpp"
#include "skylit/track/marker_map.hpp"

namespace skylit::live {
namespace {

namespace fs = std::filesystem;

capture::SourceConfig with_reconnect(capture::SourceConfig config) {
  // A service that runs all day reopens what fails, whatever the config forgot to say.
  if (!config.reconnect) config.reconnect = capture::BackoffSettings{};
  return config;
}

}  // namespace

std::vector<std::uint8_t> encode_jpeg(const cv::Mat& image) {
  std::vector<std::uint8_t> bytes;
  if (!image.empty()) cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, 85});
  return bytes;
}

void pause_after_quick_not_yet(const capture::FrameResult& result, Clock::time_point asked) {
  if (result.status == capture::FrameStatus::NotYet && Clock::now() - asked < std::chrono::milliseconds(10)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

void check_bake_matches_site(const fs::path& bake_dir, const fs::path& site_file, const std::string& config_preset) {
  const scene::Site site = scene::load_site(site_file);
  const bake_format::Manifest manifest = bake_format::read_manifest(bake_dir);
  const std::string& bake_preset = manifest.plan.preset;
  if (!bake_preset.empty() && bake_preset != config_preset) {
    throw InputError(bake_dir.string() + ": the bake was made with preset '" + bake_preset + "' (dome frequency " +
                     std::to_string(manifest.plan.frequency) + ", " + std::string(geom::basis_name(manifest.plan.basis)) +
                     " basis), and the config " +
                     (config_preset.empty() ? "names no preset" : "names preset '" + config_preset + "'") +
                     ".\nFix: set `preset: " + bake_preset + "` in the config, or bake again with " +
                     (config_preset.empty() ? "no preset" : "--preset " + config_preset) + " (skylit-bake " +
                     site_file.string() + " -o " + bake_dir.string() +
                     (config_preset.empty() ? "" : " --preset " + config_preset) + " --force).");
  }
  std::vector<std::string> differences;
  // A preset's bake takes its dome from the preset, not from the site.
  if (bake_preset.empty()) {
    if (manifest.plan.frequency != site.dome_frequency) {
      differences.push_back("dome frequency: bake " + std::to_string(manifest.plan.frequency) + ", site " +
                            std::to_string(site.dome_frequency));
    }
    if (manifest.plan.basis != site.dome_basis) {
      differences.push_back("dome basis: bake " + std::string(geom::basis_name(manifest.plan.basis)) + ", site " +
                            std::string(geom::basis_name(site.dome_basis)));
    }
  }
  if (manifest.planes.size() != site.planes.size()) {
    differences.push_back("planes: bake has " + std::to_string(manifest.planes.size()) + ", site " +
                          std::to_string(site.planes.size()));
  }
  for (std::size_t j = 0; j < std::min(manifest.planes.size(), site.planes.size()); ++j) {
    const geom::Plane& a = manifest.planes[j].plane;
    const geom::Plane& b = site.planes[j];
    const std::string label = "plane " + std::to_string(j) + " '" + b.name + "'";
    if (a.name != b.name) differences.push_back(label + ": the bake's is named '" + a.name + "'");
    if ((a.origin - b.origin).norm() > 1e-6 || (a.u - b.u).norm() > 1e-6 || (a.v - b.v).norm() > 1e-6) {
      differences.push_back(label + ": origin, u or v differ");
    }
    if (a.width != b.width || a.height != b.height) {
      differences.push_back(label + ": resolution " + std::to_string(a.width) + "×" + std::to_string(a.height) +
                            " in the bake, " + std::to_string(b.width) + "×" + std::to_string(b.height) + " in the site");
    }
  }
  if (!differences.empty()) {
    std::string message = bake_dir.string() + ": the bake was not made for " + site_file.string() + ":";
    for (const auto& d : differences) message += "\n  - " + d;
    const std::string preset_option = config_preset.empty() ? "" : " --preset " + config_preset;
    message += "\nFix: bake again (skylit-bake " + site_file.string() + " -o " + bake_dir.string() + preset_option +
               " --force), or point the config's `bake` at the bake made for this site.";
    throw InputError(message);
  }
}

namespace {

// The site from above for the console's HMD view: each plane's outline, and with the marker
// tracker every tag of the marker map (its id and corners), in site metres.
std::string site_map_json(const scene::Site& site, const track::PoseConfig& pose) {
  nlohmann::json j;
  nlohmann::json planes = nlohmann::json::array();
  for (const geom::Plane& p : site.planes) {
    nlohmann::json corners = nlohmann::json::array();
    for (const Eigen::Vector3d& c : {p.origin, Eigen::Vector3d(p.origin + p.u), Eigen::Vector3d(p.origin + p.u + p.v), Eigen::Vector3d(p.origin + p.v)}) {
      corners.push_back({c.x(), c.y(), c.z()});
    }
    planes.push_back({{"name", p.name}, {"corners", corners}});
  }
  j["planes"] = planes;
  nlohmann::json tags = nlohmann::json::array();
  if (pose.kind == track::PoseConfig::Kind::Markers) {
    const track::MarkerMap map = track::load_marker_map(pose.marker_map);
    for (const track::MarkerTag& tag : map.tags) {
      nlohmann::json corners = nlohmann::json::array();
      for (const Eigen::Vector3d& c : track::tag_corners_in_site(tag)) corners.push_back({c.x(), c.y(), c.z()});
      tags.push_back({{"id", tag.id}, {"corners", corners}});
    }
    j["map"] = map.file.string();
  }
  j["tags"] = tags;
  return j.dump() + "\n";
}

}  // namespace

Service::Service(const LiveConfig& config, const ServiceOptions& options) : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.config = config;
  s.options = options;
  check_bake_matches_site(config.bake, config.site, config.preset);
  s.site = scene::load_site(config.site);
  s.manifest = bake_format::read_manifest(config.bake);
  s.mesh = bake_format::load_baked_model(s.site, config.bake, s.manifest);
  std::vector<std::size_t> shape;
  s.transfer = bake_format::read_npy(config.bake / s.manifest.transfer_file, &shape);
  if (config.render.ground_light) {
    if (!s.manifest.ground) {
      throw InputError(input_message(config.file, -1, -1, "render.ground_light",
                                     "true, and the bake " + config.bake.string() + " has no ground layer",
                                     "re-bake with skylit-bake --ground-samples 256 (the default), or set "
                                     "'render: {ground_light: false}'"));
    }
    s.ground_transfer = bake_format::read_npy(config.bake / s.manifest.ground->file, &shape);
  }
  if (s.manifest.light_map && config.render.light_map) {
    const bool has_pca = s.manifest.light_map->pca.has_value();
    if (config.render.light_map_form == "pca" && !has_pca) {
      throw InputError(input_message(config.file, -1, -1, "render.light_map_form",
                                     "pca, and the bake " + config.bake.string() + " has no PCA form of its light map",
                                     "add it with skylit-bake compress " + config.bake.string() +
                                         " --light-map-components 16, or set 'render: {light_map_form: auto}'"));
    }
    if (config.render.light_map_form == "full" && !s.manifest.light_map->has_full_form()) {
      throw InputError(input_message(config.file, -1, -1, "render.light_map_form",
                                     "full, and the bake " + config.bake.string() + " keeps only its light map's PCA form "
                                     "(skylit-bake --light-map-pca-only)",
                                     "set 'render: {light_map_form: auto}', or re-bake with --light-map-keep-full"));
    }
    const bool pca = has_pca && config.render.light_map_form != "full";
    s.light_map = bake_format::read_light_map(config.bake, s.manifest, pca ? bake_format::LightMapForm::Pca : bake_format::LightMapForm::Full);
    if (!config.render.ground_light) s.light_map.ground = {};
  }
  for (std::size_t j = 0; j < s.manifest.planes.size(); ++j) {
    if (config.blend.basis == blend::BasisForm::Pca && !s.manifest.planes[j].pca) {
      throw InputError(input_message(config.file, -1, -1, "blend.basis",
                                     "pca, and the bake " + config.bake.string() + " has no PCA form of plane '" +
                                         s.manifest.planes[j].plane.name + "'",
                                     "compress the bake: skylit-bake compress " + config.bake.string() +
                                         " --pca-variance 0.999; or set 'basis: full'"));
    }
    s.bases.push_back(blend::load_basis(config.bake, s.manifest, static_cast<int>(j), config.blend.basis));
  }
  s.plane_views = std::make_unique<PlaneView[]>(s.bases.size());
  // Every file the config names is read now, whatever the mode: a headless check of a config
  // with a broken HMD profile must fail here, not on the HMD.
  if (config.display) static_cast<void>(render::load_hmd_profile(config.display->profile));
  if (!config.camera.stereo.empty()) {
    s.stereo_camera = camera::load_stereo_calibration(config.camera.stereo);
    s.hmd_calibration = s.stereo_camera->left;
  } else {
    s.hmd_calibration = camera::load_calibration(config.camera.calibration);
  }
  s.dome = std::make_unique<geom::Dome>(s.manifest.plan.frequency);
  if (config.sky.link) {
    const std::string site_name = site_name_of(config.site);
    const sky_link::SkyIdentity identity{site_name, s.manifest.plan.frequency, s.manifest.plan.basis,
                                         static_cast<int>(s.manifest.layer_count())};
    s.sky_link = std::make_unique<SkyLinkReceiver>(*config.sky.link, identity, site_name);
  } else {
    s.sky_calibration = camera::load_calibration(config.sky.calibration);
    s.sky_stage = std::make_unique<SkyStage>(s.sky_calibration, *s.dome, s.manifest.plan.basis, config.sky, s.site.location);
    capture::OpenedSource sky_opened = capture::open_source_with_status(with_reconnect(config.sky.source));
    s.sky_source = std::move(sky_opened.source);
    s.sky_reconnecting = sky_opened.reconnecting;
  }
  capture::OpenedSource camera_opened = capture::open_source_with_status(with_reconnect(config.camera.source));
  s.camera_source = std::move(camera_opened.source);
  s.camera_reconnecting = camera_opened.reconnecting;
  s.camera_pair = camera_opened.paired;
  s.tracking = std::make_unique<LiveTracking>(config, s.hmd_calibration, s.stereo_camera ? &*s.stereo_camera : nullptr);
  s.fade = std::make_unique<BuildingFade>(config.tracking.fade_s);
  const auto listen = options.status_listen ? options.status_listen : config.status_listen;
  if (listen) {
    const auto [host, port] = parse_listen_address(*listen, "status.listen");
    StatusHandlers handlers;
    State* self = &s;
    handlers.status_json = [self] { return self->status_report().dump(2) + "\n"; };
    handlers.metrics_text = [this] { return metrics_text(); };
    handlers.sky_jpeg = [self] {
      return self->sky_link ? self->sky_link->overlay() : self->sky_jpeg.get().value_or(std::vector<std::uint8_t>{});
    };
    handlers.frame_jpeg = [self] { return self->frame_jpeg.get(self->latest_frame); };
    s.bake_info = std::make_unique<BakeInfo>(config.bake, s.manifest, config.site);
    handlers.bake_json = [self] { return self->bake_info->report().dump(2) + "\n"; };
    handlers.bake_preview = [self](const std::string& name) { return self->bake_info->preview(name); };
    handlers.history_json = [self] { return self->history.json(now_seconds()).dump() + "\n"; };
    handlers.map_json = [map = site_map_json(s.site, config.pose)] { return map; };
    handlers.title = config.sky.link ? "skylit-live " + s.sky_link->node() : "skylit-live";
    handlers.token = status_token(host, config.status_access.token_file, config.status_access.allow_unauthenticated, "skylit-live");
    s.status = std::make_unique<StatusServer>(host, port, handlers);
  }
}

Service::~Service() {
  stop();
  if (state_->sky_thread.joinable()) state_->sky_thread.join();
  if (state_->camera_thread.joinable()) state_->camera_thread.join();
}

void Service::stop() {
  state_->running = false;
  state_->camera_box.close();
  if (state_->sky_link) state_->sky_link->close();
  state_->sun_maps.close();  // a sky thread waiting for the render thread to free a map
}

std::string Service::status_address() const { return state_->status ? state_->status->address() : std::string(); }

void Service::State::camera_loop() {
  while (running) {
    try {
      const auto asked = Clock::now();
      capture::FrameResult result = camera_source->next(0.2);
      pause_after_quick_not_yet(result, asked);
      if (result.status == capture::FrameStatus::Ready) {
        ++counters.camera_frames;
        camera_activity.frame();
        camera_rate.add(result.frame.timestamp);
        // The marker tracker runs here, before the frame is handed over, rather than on a thread
        // of its own: it costs about 3 ms a 1280×720 frame on one core (bench/RESULTS.md,
        // Tracking), a tenth of a 30 Hz frame's interval, and so the render thread always finds
        // the pose of the very frame it draws (a tracking thread would give it the previous
        // frame's pose, or make it wait). Every frame is tracked, even those the renderer drops.
        tracking->on_camera_frame(camera_image(result.frame, 0), result.frame.timestamp,
                                  stereo_camera ? camera_image(result.frame, 1) : cv::Mat());
        camera_arrivals.put(result.frame.timestamp, now_seconds());
        camera_box.put(std::move(result.frame));
      } else if (result.status == capture::FrameStatus::EndOfStream) {
        camera_activity.ended = true;
        camera_rate.end();
        camera_box.close();  // a finite recording has ended: the render thread finishes
        return;
      }
    } catch (const std::exception& e) {
      ++counters.camera_errors;
      {
        std::lock_guard lock(stats_mutex);
        camera_last_error = e.what();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
}

cv::Mat Service::State::camera_image(const capture::Frame& frame, int eye) const {
  if (!stereo_camera) return frame.image;
  const camera::CameraCalibration& c = eye == 0 ? stereo_camera->left : stereo_camera->right;
  if (frame.image.cols != stereo_camera->left.image_width + stereo_camera->right.image_width ||
      frame.image.rows != c.image_height) {
    throw InputError(input_message(config.file, -1, -1, "camera.stereo",
                                   "a camera frame of " + std::to_string(frame.image.cols) + "×" +
                                       std::to_string(frame.image.rows) + " is not the two cameras side by side (" +
                                       std::to_string(stereo_camera->left.image_width) + "×" +
                                       std::to_string(stereo_camera->left.image_height) + " and " +
                                       std::to_string(stereo_camera->right.image_width) + "×" +
                                       std::to_string(stereo_camera->right.image_height) + ")",
                                   "give a pair source (kind: pair) or a side-by-side stereo camera, and the "
                                   "calibration of its cameras"));
  }
  const int x = eye == 0 ? 0 : stereo_camera->left.image_width;
  return frame.image(cv::Rect(x, 0, c.image_width, c.image_height));
}

}  // namespace skylit::live
