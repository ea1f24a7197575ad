#pragma once
// skylit-live's configuration: one YAML file, paths relative to it (docs/live.md, "Configuration").
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "skylit/base/presets.hpp"
#include "skylit/blend/forms.hpp"
#include "skylit/capture/config.hpp"
#include "skylit/render/building_irradiance.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/sky_link/mqtt_client.hpp"
#include "skylit/track/fusion.hpp"
#include "skylit/track/imu.hpp"
#include "skylit/track/pose.hpp"

namespace skylit::live {

// Who may open the status server's console and JSON (docs/console.md, "Access"): anyone on a
// loopback address; off it, the bearer of the token (a cookie set by the login form, or an
// Authorization header), unless allow_unauthenticated says otherwise explicitly.
struct StatusAccess {
  std::filesystem::path token_file;   // empty: no token
  bool allow_unauthenticated = false;
};

// A node's link to the site's broker (docs/site.md): an HMD node's `sky.source: {kind: mqtt, ...}`,
// a sky node's `link:`.
struct LinkSettings {
  sky_link::MqttSettings mqtt;   // the broker (host, port), credentials, TLS
  std::string topic;             // the site's topic root; empty: skylit/<the site's name>
  std::string node;              // this node's name under ROOT/nodes; empty: the host name
};

struct SkySettings {
  // With `source: {kind: mqtt, ...}` (an HMD node): the skies a sky node publishes, instead of a
  // camera of its own; calibration, response, rate, sun and smoothing are then the sky node's.
  std::optional<LinkSettings> link;
  std::filesystem::path calibration;
  capture::SourceConfig source;
  std::string response = "srgb";      // srgb | linear | a response file (skylit-sky response)
  double rate = 1.0;                  // estimates per second at most; 0: every frame
  bool sun = true;                    // sun separation (auto)
  // sky.sun_colour: daylight (a sun whose colour is impossible for daylight gets a clear sky's,
  // sky::SkyEstimateOptions::correct_sun_colour) or measured.
  bool correct_sun_colour = true;
  // sky.clipped_sun_energy: measured (a clipped sun's pixels: a lower bound), clear_sky (the sun
  // of a clear-sky model fitted to the unclipped sky; sky::SkyEstimateOptions) or shadow_contrast
  // (an HMD node's: the ground in and out of a real shadow, photometric.estimate.shadowed_region).
  sky::ClippedSunEnergy clipped_sun_energy = sky::ClippedSunEnergy::Measured;
  // sky.bracket: exposure times (s) of an exposure bracket taken for every sky (a source that can
  // bracket: libcamera, sky-sim) and merged to one radiance frame; empty: single frames.
  std::vector<double> bracket;
  double smoothing = 0.0;             // seconds
  double stale_after = 30.0;          // seconds
  // Separated sources at most (sky::SkyEstimateOptions::max_sources): 1, the sun alone; more,
  // the sun and lamps, each with its own shadow map and term in the blend. An HMD node takes at
  // most this many of the sources its sky node publishes (and draws their shadow maps).
  int max_sources = 1;
};

struct CameraSettings {
  std::filesystem::path calibration;
  // A stereo camera instead (camera.stereo: skylit-calib stereo's file): its frames side by side,
  // the left camera's on the left (a `pair` source makes them from two cameras). The left camera
  // is the HMD camera for poses, tracking and the photometric match; in display.mode stereo each
  // eye shows its own camera. Empty: one camera (calibration).
  std::filesystem::path stereo;
  capture::SourceConfig source;
};

// Where the shadow ratios are blended: on the CPU (on the sky thread, right after S) or on the GPU
// (on the render thread); auto picks the CPU when the GL renderer is a software one.
enum class BlendDevice { Auto, Cpu, Gpu };
std::string blend_device_name(BlendDevice device);  // "auto", "cpu", "gpu"

struct BlendSettings {
  BlendDevice device = BlendDevice::Auto;
  int threads = 2;                    // CPU blend threads, the sky thread included (0: all hardware threads)
  // blend.storage (GPU blend): half floats, 8-bit, or EAC R11 blocks.
  blend::BasisStorage storage = blend::BasisStorage::Half;
  // blend.basis: full (every layer), lean (the layers that hold a shadow and one of ones, T
  // within 1e-3; docs/baker.md) or pca (each plane's PCA form, K + 1 layers, docs/bake-format.md;
  // the bake must have one: skylit-bake compress) or cropped (lean with each shadowed layer
  // cropped to the rectangle it shadows: the CPU blend reads only the rectangles, the GPU blend
  // holds them in an atlas of pages; any storage).
  blend::BasisForm basis = blend::BasisForm::Full;
  double skip_threshold = 0.0;
  double change_threshold = 0.002;
  // Blend only the planes the current view can see (render::plane_in_view); a plane that comes
  // back into view is blended for the current sky before it is drawn. false: every plane, every sky.
  bool cull_planes = true;
};

// What the service shows when the pose is lost and when it returns (docs/live.md, "Tracking lost").
struct TrackingSettings {
  double fade_s = 0.3;   // seconds from full opacity to none, and back; 0: at once
};

struct PhotometricSettings {
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  // Estimated from a reference region of a real plane instead, when set.
  std::optional<std::string> plane;
  std::array<double, 4> region{0, 1, 0, 1};       // s0, s1, t0, t1 on the plane
  Eigen::Vector3d albedo = Eigen::Vector3d::Constant(0.2);
  int every = 30;                                 // frames between estimates
  // Ground of the same plane and material in a real shadow (sky.clipped_sun_energy:
  // shadow_contrast), and the sky it still sees: its brightness over the region's under an
  // overcast sky (render::ShadowContrastOptions::sky_visibility).
  std::optional<std::array<double, 4>> shadowed_region;
  double shadowed_sky_visibility = 1.0;
};

struct OutputSettings {
  std::filesystem::path record;   // empty: none
  std::optional<double> record_fps;  // a recorded video's frame rate; none: the HMD camera's
  bool window = false;
};

// How the building is rendered (render::CompositorOptions).
struct RenderSettings {
  // The pinhole render's resolution against the frame's (render::LensRemapOptions::render_scale):
  // the building's fill cost goes as its square (docs/live.md, "Rendering and compositing").
  double scale = 1.0;
  // The ground's light on the building (render::CompositorOptions::ground_albedo; docs/method.md,
  // "Light from the ground"): on with render.ground_light, the bake's ground layer needed; the
  // ground's albedo, RGB (default: photometric.estimate.albedo, 0.2 unless the config gives it).
  bool ground_light = false;
  // The bake's light map (skylit-bake --light-map), when it has one: on a chart, the building's
  // sky and ground light from its texels instead of its corners. false: the corners alone.
  bool light_map = true;
  // Its form: "auto" (the PCA form where the bake has one, else the full), "full" or "pca" (the
  // bake's PCA form needed).
  std::string light_map_form = "auto";
  // How its values are held for the building's sums: "float", or "half" (half the memory and
  // half what a sum reads; render::LightMapPrecision).
  render::LightMapPrecision light_map_precision = render::LightMapPrecision::Float;
  std::optional<Eigen::Vector3d> ground_albedo;
};

// The HMD display (docs/hmd.md): a profile, the monitor to fill, one render or one per eye.
struct DisplaySettings {
  std::filesystem::path profile;
  std::string monitor;   // empty: a window
  bool stereo = false;
};

// The config file:
//
//   site: sample_site.yaml              # the site the bake was made for
//   bake: ../build/demo/bake            # the bake folder (skylit-bake's output)
//   preset: balanced                    # optional: fast | balanced | accurate (presets.yaml beside
//                                       # this file, else config/presets.yaml; docs/presets.md) sets
//                                       # sky.sun, sky.smoothing and blend.basis, storage,
//                                       # skip_threshold, change_threshold; keys given here override it
//   sky:
//     calibration: sky_camera.yaml
//     source: {kind: sky-sim, ...}      # capture::SourceConfig (docs/live.md, "Frame sources"), or
//                                       # {kind: mqtt, broker: HOST:PORT, ...}: a sky node's skies
//                                       # (LinkSettings, docs/site.md; calibration not needed)
//     response: srgb | linear | FILE    # 8/16-bit frames: how codes become radiance (default srgb)
//     rate: 1                           # sky estimates per second at most (0: every frame)
//     sun: auto | off
//     max_sources: 1                    # separated sources (the sun, lamps): 1 … 32, a shadow map each
//     smoothing: 0                      # seconds, time constant of S's smoothing (0: off)
//     bracket: [0.0005, 0.004, 0.032]   # exposure times (s) merged per sky (libcamera, sky-sim)
//     stale_after: 30                   # seconds without a new sky before it is flagged stale
//   camera:
//     calibration: hmd_camera.yaml      # or stereo: stereo.yaml (a camera per eye, frames side by side)
//     source: {kind: images, ...}
//   pose: {kind: fixed | track | markers, ...}  # track::PoseConfig; markers: the tracker is fed
//                                       # every HMD camera frame (docs/tracking.md)
//   imu: {kind: hid | replay, ...}      # optional, with pose.kind markers: track::ImuConfig, fused
//                                       # with the tracker's poses (docs/imu.md)
//   fusion: {camera_timeout: 0.2, ...}  # optional, with pose.kind markers: track::FusionSettings
//   tracking:
//     fade_s: 0.3                       # seconds: the building fades out when the pose is lost,
//                                       # and in again from 0 at the pose that returns (0: no fade)
//   blend:                              # or just `blend: auto | cpu | gpu`
//     device: auto | cpu | gpu          # where T is blended (auto: cpu on a software GL renderer)
//     threads: 2                        # cpu: blend threads (0: all hardware threads)
//     storage: half | unorm8 | eac      # gpu: how the basis is stored
//     basis: full | lean | pca | cropped  # every layer; only those that hold a shadow; the PCA
//                                       # form; lean with each layer cropped to what it shadows
//     skip_threshold: 0                 # T units (docs/live.md, "GPU blend"); both devices
//     change_threshold: 0.002
//     cull_planes: true                 # blend only the planes the current view can see
//   render:
//     scale: 0.75                       # the building's render resolution against the frame's
//   photometric:
//     scale: [1, 1, 1]                  # camera linear value per unit radiance; or
//     estimate: {plane: ground, region: [s0, s1, t0, t1], albedo: [0.2, 0.2, 0.2], every: 30,
//                shadowed_region: [s0, s1, t0, t1], shadowed_sky_visibility: 1}  # shadow_contrast
//   output:
//     record: out.mp4                   # .mp4/.avi: a video; otherwise a folder of PNG frames; or
//     record: {path: out.mp4, fps: 15}  # a video's rate (default: the HMD camera's frame rate)
//     window: false                     # a window on the display (overridden by --headless)
//   status:
//     listen: 127.0.0.1:8080            # omit for no HTTP status (and console)
//     token_file: console.token         # off loopback: the console's token (docs/console.md)
//     allow_unauthenticated: false      # off loopback without a token: true only on purpose
//   display:                            # the HMD display (docs/hmd.md); opens the window
//     profile: hmd/generic.yaml         # an HMD profile (config/hmd/)
//     monitor: HDMI-1                   # full screen on this monitor; omit for a window
//     mode: stereo                      # stereo (a render per eye) or mono (default)
struct LiveConfig {
  std::filesystem::path file;
  std::filesystem::path site;
  std::filesystem::path bake;
  std::string preset;                        // empty: none
  std::filesystem::path presets_file;        // where `preset` was looked up
  SkySettings sky;
  CameraSettings camera;
  track::PoseConfig pose;
  // With pose.kind markers: the tracker's poses are fused (track::PoseFusion) when either is set;
  // the IMU's gyro joins them when `imu` is. Without both the tracker's poses are used as they are.
  std::optional<track::ImuConfig> imu;
  std::optional<track::FusionSettings> fusion;
  TrackingSettings tracking;
  BlendSettings blend;
  RenderSettings render;
  PhotometricSettings photometric;
  OutputSettings output;
  std::optional<std::string> status_listen;  // "ADDR:PORT"
  StatusAccess status_access;
  std::optional<DisplaySettings> display;    // set: the window shows the HMD display
};

// A preset's live settings (the `live:` section of config/presets.yaml, docs/presets.md): what a
// config's `preset: NAME` sets before its own keys, which override them.
struct LivePreset {
  std::string name;
  blend::BasisForm basis = blend::BasisForm::Full;          // blend.basis
  blend::BasisStorage storage = blend::BasisStorage::Half;  // blend.storage
  double skip_threshold = 0.0;                              // blend.skip_threshold, T units
  double change_threshold = 0.002;                          // blend.change_threshold, T units
  double smoothing = 0.0;                                   // sky.smoothing, seconds
  bool sun = true;                                          // sky.sun: auto (true) | off
  double render_scale = 1.0;                                // render.scale, (0, 1]
  bool ground_light = false;                                // render.ground_light
  render::LightMapPrecision light_map_precision = render::LightMapPrecision::Float;  // render.light_map_precision
};

// The live section of preset `name`, checked against its bake section (the PCA form needs
// bake.pca_components). InputError (file, line, field, fix) for anything wrong.
LivePreset load_live_preset(const PresetsFile& presets, const std::string& name);

// The presets a config file's `preset` is looked up in: presets.yaml in its folder when there is
// one, else skylit::default_presets_file() (share/skylit/presets.yaml beside the programs).
std::filesystem::path presets_file_for(const std::filesystem::path& config_file);

// InputError naming the file, line, column and field, with the fix, for anything wrong.
LiveConfig load_live_config(const std::filesystem::path& file);

// skylit-sky-node's configuration (docs/site.md): the sky stage of a skylit-live config and the
// broker it publishes to.
//
//   site: sample_site.yaml
//   bake: ../build/demo/bake     # what the skies are computed for: the dome (ν, basis, layers)
//   preset: balanced             # optional, as skylit-live's: sky.sun and sky.smoothing
//   sky: {calibration: ..., source: ..., response: ..., rate: 1, sun: auto, smoothing: 0}
//   link: {broker: 127.0.0.1:1883, topic: skylit/sample-gate, node: sky, username: ..., password_file: ...,
//          tls: {ca_file: ..., cert_file: ..., key_file: ...}, keepalive_s: 10}
//   status: {listen: 127.0.0.1:8090}
struct SkyNodeConfig {
  std::filesystem::path file;
  std::filesystem::path site;
  std::filesystem::path bake;
  std::string preset;
  SkySettings sky;
  LinkSettings link;
  std::optional<std::string> status_listen;
  StatusAccess status_access;
};
SkyNodeConfig load_sky_node_config(const std::filesystem::path& file);

// A site's name on the link (the sky's identity, the default topic root): its file's name
// without the extension, e.g. "sample_site".
std::string site_name_of(const std::filesystem::path& site_file);

}  // namespace skylit::live
