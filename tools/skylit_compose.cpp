// skylit-compose: one composite frame, to look at: a bake, a sky frame (or an equirect HDR to
// film with the sky camera), an HMD camera frame (or an equirect to film with the HMD camera) and
// a pose in, the PNG the HMD would show out. Runs the live path's GPU stages: the sky estimate,
// the GPU blend with the sun's shadow map, and the compositor.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

// GCC 12 inlines CLI11's string splitting into this file at -O3 and then warns about a null
// dereference inside libstdc++'s string move that cannot happen (a known false positive).
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/model.hpp"
#include "skylit/base/error.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/image_io.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "command_line.hpp"

namespace {

namespace fs = std::filesystem;
using skylit::InputError;
using Eigen::Vector3d;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string site;
  std::string bake_dir;
  std::string sky_calib;
  std::string sky;
  std::string sky_equirect;
  std::string hmd_calib;
  std::string camera;
  std::string camera_equirect;
  double camera_exposure = 0;           // 0: the median luminance of the filmed equirect becomes 0.18
  std::vector<double> position;         // with look_at: the pose; else the HMD calibration's
  std::vector<double> look_at;
  std::vector<double> scale;            // photometric k: one value or r, g, b
  std::vector<double> reference_region; // plane, s0, s1, t0, t1
  std::vector<double> reference_albedo{0.2, 0.2, 0.2};
  double azimuth_offset_deg = 0;        // turns both equirects about the zenith
  double render_scale = 1.0;
  std::string shader_dir;
  std::string output;
};

Vector3d three(const std::vector<double>& values, const std::string& option) {
  if (values.size() == 1) return Vector3d::Constant(values[0]);
  if (values.size() == 3) return Vector3d(values[0], values[1], values[2]);
  throw InputError(std::string("option ").append(option).append(": expected one number or three (r, g, b)"));
}

skylit::render::CameraPose pose_from(const Options& o, const skylit::camera::CameraCalibration& hmd) {
  skylit::render::CameraPose pose;
  if (o.position.empty()) {
    pose.R_site_from_camera = hmd.R_site_from_camera;
    pose.t_site_from_camera = hmd.t_site_from_camera;
    return pose;
  }
  if (o.position.size() != 3 || o.look_at.size() != 3) {
    throw InputError("options --position and --look-at: give both, three numbers each (site metres)");
  }
  const Vector3d position(o.position[0], o.position[1], o.position[2]);
  const Vector3d forward = (Vector3d(o.look_at[0], o.look_at[1], o.look_at[2]) - position).normalized();
  const Vector3d right = forward.cross(Vector3d::UnitZ()).normalized();
  if (!right.allFinite()) throw InputError("option --look-at: the camera cannot look straight up or down");
  pose.R_site_from_camera.col(0) = right;                   // OpenCV camera: x right,
  pose.R_site_from_camera.col(1) = forward.cross(right);    // y down,
  pose.R_site_from_camera.col(2) = forward;                 // z forward
  pose.t_site_from_camera = position;
  return pose;
}

cv::Mat film_equirect(const std::string& file, const skylit::camera::Lens& lens, double azimuth_offset_deg) {
  const cv::Mat equirect = skylit::sky::read_sky_image(file);
  cv::Mat radiance;
  equirect.convertTo(radiance, CV_32FC3, equirect.depth() == CV_8U ? 1.0 / 255.0 : 1.0);
  skylit::sky::RenderOptions options;
  options.supersample = 2;
  options.azimuth_offset = azimuth_offset_deg * 3.14159265358979323846 / 180.0;
  return skylit::sky::render_fisheye(lens, radiance, options);
}

int run(const Options& o) {
  const skylit::scene::Site site = skylit::scene::load_site(o.site);
  const skylit::bake_format::Manifest manifest = skylit::bake_format::read_manifest(o.bake_dir);
  const skylit::scene::Mesh mesh = skylit::bake_format::load_baked_model(site, o.bake_dir, manifest);
  std::vector<std::size_t> shape;
  const std::vector<float> transfer = skylit::bake_format::read_npy(fs::path(o.bake_dir) / manifest.transfer_file, &shape);

  // The sky: S and the sun.
  const skylit::camera::CameraCalibration sky_calibration = skylit::camera::load_calibration(o.sky_calib);
  const skylit::geom::Dome dome(manifest.plan.frequency);
  skylit::sky::SkyEstimateOptions estimate_options;
  estimate_options.table.basis = manifest.plan.basis;
  const skylit::sky::SkyEstimator estimator(sky_calibration, dome, estimate_options);
  skylit::sky::RadianceFrame sky_frame;
  if (!o.sky_equirect.empty()) {
    sky_frame.radiance = film_equirect(o.sky_equirect, estimator.lens(), o.azimuth_offset_deg);
  } else {
    const cv::Mat frame = skylit::sky::read_sky_image(o.sky);
    sky_frame = skylit::sky::linearise(frame, skylit::sky::ResponseCurve::srgb(frame.depth() == CV_16U ? 16 : 8), {});
  }
  const skylit::sky::SkyEstimate estimate = estimator.estimate(sky_frame);
  const std::vector<Vector3d> S = skylit::sky::layer_radiances(estimate.luminance);
  std::optional<skylit::blend::SunLight> sun;
  if (estimate.sun) sun = skylit::blend::SunLight{estimate.sun->direction, estimate.sun->energy};
  std::printf("sky: %s", estimate.sun_reason.c_str());
  if (sun) {
    std::printf(" at azimuth %.1f°, elevation %.1f°", std::atan2(sun->direction.x(), sun->direction.y()) * 180 / 3.14159265,
                std::asin(sun->direction.z()) * 180 / 3.14159265);
    if (estimate.sun->colour_corrected) std::printf(", its colour impossible for daylight and taken as a clear sky's sun's");
  }
  std::printf("\n");

  // The HMD frame and pose.
  skylit::camera::CameraCalibration hmd = skylit::camera::load_calibration(o.hmd_calib);
  const skylit::render::CameraPose pose = pose_from(o, hmd);
  cv::Mat camera;
  if (!o.camera_equirect.empty()) {
    skylit::camera::CameraCalibration posed = hmd;
    posed.R_site_from_camera = pose.R_site_from_camera;
    const cv::Mat radiance = film_equirect(o.camera_equirect, skylit::camera::Lens(posed), o.azimuth_offset_deg);
    double exposure = o.camera_exposure;
    if (exposure <= 0) {  // as an auto-exposing camera would: the median luminance to 18% grey
      cv::Mat grey;
      cv::transform(radiance, grey, cv::Matx13f(0.0722f, 0.7152f, 0.2126f));
      std::vector<float> values(grey.begin<float>(), grey.end<float>());
      std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2), values.end());
      exposure = values[values.size() / 2] > 0 ? 0.18 / values[values.size() / 2] : 1.0;
    }
    camera = skylit::sky::to_8bit(radiance, exposure);
  } else {
    camera = skylit::sky::read_sky_image(o.camera);
  }

  const skylit::gpu::HeadlessContext context;
  std::printf("GPU: %s\n", context.description().c_str());
  skylit::render::SunShadowOptions shadow_options;
  shadow_options.shader_dir = o.shader_dir;
  std::vector<skylit::geom::Plane> planes;
  for (const auto& record : manifest.planes) planes.push_back(record.plane);
  skylit::render::SunShadowMap shadow_map(mesh, planes, shadow_options);
  if (sun) shadow_map.update(sun->direction, estimate.sun->angular_radius);
  std::vector<std::unique_ptr<skylit::blend::GpuBlender>> blenders;
  std::vector<GLuint> ratios;
  skylit::blend::GpuBlendOptions blend_options;
  blend_options.shader_dir = o.shader_dir;
  for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
    const skylit::blend::BasisImages basis = skylit::blend::load_basis(o.bake_dir, manifest, static_cast<int>(j));
    blenders.push_back(std::make_unique<skylit::blend::GpuBlender>(basis, blend_options));
    const skylit::blend::BlendWeights weights = skylit::blend::blend_weights(basis, S, sun);
    blenders.back()->blend(weights, weights.sun.isZero(0) ? nullptr : &shadow_map.visibility(static_cast<int>(j)));
    ratios.push_back(blenders.back()->shadow_ratio_texture());
  }

  skylit::render::CompositorOptions options;
  options.shader_dir = o.shader_dir;
  options.lens.render_scale = o.render_scale;
  skylit::render::Compositor compositor(site, mesh, manifest, transfer, hmd, options);
  skylit::render::PhotometricMatch match;
  if (!o.scale.empty()) match.scale = three(o.scale, "--scale");
  if (!o.reference_region.empty()) {
    if (o.reference_region.size() != 5) throw InputError("option --reference-region: expected plane, s0, s1, t0, t1");
    const int plane = static_cast<int>(o.reference_region[0]);
    const cv::Mat region = compositor.region_mask(plane, o.reference_region[1], o.reference_region[2],
                                                  o.reference_region[3], o.reference_region[4], pose);
    const skylit::sky::RadianceFrame frame = skylit::sky::linearise(camera, skylit::sky::ResponseCurve::srgb(8), {});
    const skylit::render::PhotometricEstimate found = skylit::render::estimate_photometric_match(
        frame.radiance, region,
        skylit::render::plane_irradiance(manifest.planes.at(static_cast<std::size_t>(plane)), S, sun),
        three(o.reference_albedo, "--reference-albedo"));
    if (!found.ok) throw InputError("option --reference-region: " + found.problem);
    match = found.match;
    std::printf("photometric match: k = (%.4g, %.4g, %.4g) from %lld pixels (spread %.3f)\n", match.scale.x(),
                match.scale.y(), match.scale.z(), static_cast<long long>(found.pixels_used), found.spread.maxCoeff());
  }

  skylit::render::CompositeInput input;
  input.camera = camera;
  input.pose = pose;
  input.sky = S;
  input.sun = sun;
  input.shadow_ratios = ratios;
  input.sun_shadow = sun ? &shadow_map : nullptr;
  input.photometric = match;
  auto start = Clock::now();
  cv::Mat composite = compositor.composite(input);
  const double first_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  start = Clock::now();
  composite = compositor.composite(input);
  const double second_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  std::printf("composite: %d×%d in %.1f ms (first frame), %.1f ms (second), upload and read-back included\n",
              composite.cols, composite.rows, first_ms, second_ms);
  skylit::sky::write_image(o.output, composite);
  const fs::path camera_file = fs::path(o.output).replace_extension("").string() + "_camera.png";
  skylit::sky::write_image(camera_file, camera.depth() == CV_8U ? camera : skylit::sky::tone_map(camera));
  std::printf("wrote %s and %s\n", o.output.c_str(), camera_file.string().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"skylit-compose: one composite frame (bake + sky + HMD camera frame + pose → PNG)", "skylit-compose"};
  skylit::tools::add_version_flag(app);
  bool quiet = false;
  skylit::tools::add_quiet_flag(app, quiet);
  Options o;
  app.add_option("--site", o.site, "site YAML (model and plane surfaces)")->required()->check(CLI::ExistingFile);
  app.add_option("--bake", o.bake_dir, "bake directory (from skylit-bake)")->required()->check(CLI::ExistingDirectory);
  app.add_option("--sky-calib", o.sky_calib, "sky-camera calibration")->required()->check(CLI::ExistingFile);
  auto* sky = app.add_option("--sky", o.sky, "sky-camera frame (float EXR/HDR linear, or 8-bit sRGB)")
                  ->check(CLI::ExistingFile);
  app.add_option("--sky-equirect", o.sky_equirect, "equirect HDR to film with the sky camera instead")
      ->excludes(sky)
      ->check(CLI::ExistingFile);
  app.add_option("--hmd-calib", o.hmd_calib, "HMD camera calibration (its R/t are the pose unless --position)")
      ->required()
      ->check(CLI::ExistingFile);
  auto* camera = app.add_option("--camera", o.camera, "HMD camera frame (8-bit sRGB or float linear)")
                     ->check(CLI::ExistingFile);
  app.add_option("--camera-equirect", o.camera_equirect, "equirect to film with the HMD camera instead")
      ->excludes(camera)
      ->check(CLI::ExistingFile);
  app.add_option("--camera-exposure", o.camera_exposure, "exposure for --camera-equirect (0: auto)");
  app.add_option("--position", o.position, "camera position x y z (site metres)")->expected(3);
  app.add_option("--look-at", o.look_at, "point the camera looks at, x y z")->expected(3);
  app.add_option("--scale", o.scale, "photometric scale k: one number or r g b")->expected(1, 3);
  app.add_option("--reference-region", o.reference_region, "estimate k from plane P's rectangle: P s0 s1 t0 t1")
      ->expected(5);
  app.add_option("--reference-albedo", o.reference_albedo, "albedo of the reference region: one number or r g b")
      ->expected(1, 3);
  app.add_option("--azimuth-offset", o.azimuth_offset_deg, "turn the equirects about the zenith, degrees");
  app.add_option("--render-scale", o.render_scale, "building render resolution / the camera's")->capture_default_str();
  app.add_option("--shader-dir", o.shader_dir, "shader directory (default: search)");
  app.add_option("-o,--output", o.output, "output PNG")->required();
  if (const auto status = skylit::tools::parse_command_line(app, argc, argv)) return *status;
  if (quiet) skylit::tools::quiet_stdout();
  try {
    if (o.sky.empty() && o.sky_equirect.empty()) throw InputError("give --sky or --sky-equirect");
    if (o.camera.empty() && o.camera_equirect.empty()) throw InputError("give --camera or --camera-equirect");
    return run(o);
  } catch (const InputError& e) {
    std::fprintf(stderr, "skylit-compose: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-compose: internal error: %s\n", e.what());
    return 1;
  }
}
