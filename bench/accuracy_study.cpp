// The accuracy study of the sky stage: shadow ratios from the dome (at several settings) against
// a dense reference that integrates every pixel of a real equirectangular HDR sky with Embree
// visibility against the site model, no dome.
//
//   T_ref(x) = Σ_p L_p Ω_p max(0, n·ω_p) V(x, ω_p) / Σ_p L_p Ω_p max(0, n·ω_p)   (per channel)
//
// The dome path is the one the live service runs: the sky rendered into the sample sky camera
// (fisheye), luminance parameters, the sun separated or not, the bake's basis images blended.
//
//   accuracy_study [--skies DIR] [--site SITE.yaml] [--calib CALIB.yaml] [--texel-scale 8]
//                  [--out DIR] [--configs paper,area,area+sun,area64+sun,nu4,nu8,nu4-corners,nu4-quadratics64,corners,corners-nosun,corners64,area+oracle,corners+oracle,corners64+oracle]
//                  [--sky NAME] [--pictures] [--sun-disc-factor F] [--sun-halo DEG] [--sun-min-contrast C]
//                  [--sun-max-core DEG] [--reference-supersample N] [--sources N] [--pca K,K,...] [--gpu]
// With --pca, each configuration's bake is also compressed to K principal components (a copy per
// K, skylit-bake compress) and blended with the same sky: its error against the reference and
// against the uncompressed blend are printed in a second table (and JSON, "pca").
// Diagnoses of the separated sun (bench/RESULTS.md "Separated sources"): the configurations
// corners64+oracle-light, -dome, -energy, -point, -corepoint, corners64+fill, corners64+sources.
// The quadratics basis: quadratics, quadratics64, quadratics64+sources.
// The reference integrates bright pixels and their neighbours as 4×4 bilinear sub-directions by
// default (--reference-supersample 4): the continuous sky the fisheye frames are rendered from,
// not a few 0.7° pixels acting as point suns (1, the point-sampled reference).
// Prints a Markdown table (RMS, 99th percentile and max of |T − T_ref| over every texel of every
// plane and every channel) and writes the same as JSON to DIR/accuracy.json. The building too
// (study/building_light.hpp): per model vertex, E from the transfer vectors and the separated
// sources against E_ref from the same lights with the model's self-occlusion, |E − E_ref| as a
// share of the sky's horizontal irradiance, in a second table. With --gpu, also the live GPU
// path (study/gpu_path.hpp: every separated source's shadow map, the GPU blend, the building lit
// through the maps) in a third table, beside the CPU path's ray-cast visibility.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "skylit/bake_format/model.hpp"
#include "skylit/bake_format/pca.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/base/files.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/render/photometric.hpp"
#include "skylit/study/building_light.hpp"
#include "skylit/study/gpu_path.hpp"
#include "skylit/study/study.hpp"

namespace {

namespace fs = std::filesystem;
using namespace skylit::study;

struct Config {
  std::string name;
  int frequency;
  int samples;
  bool sun;
  skylit::geom::DomeBasis basis = skylit::geom::DomeBasis::Faces;
  // The sun taken from the equirect instead of detected in the fisheye (a diagnosis, not a
  // setting): its pixels within kOracleRadius of the peak, above the background around them,
  // are the area light, exactly where the reference has them; the fisheye shows the background
  // in their place.
  bool oracle_sun = false;
  // Diagnoses that take one part from the oracle and the rest from the live path:
  //   OracleLight: the oracle's area light, the dome from the live frame less the detected disc;
  //   OracleDome: the detected sun, the dome from the oracle's frame (sun replaced by background);
  //   OracleEnergy: the detected disc's shape, scaled to the oracle's energy, the live dome.
  //   OraclePoint: the oracle with its whole light at its centroid (a point sun);
  //   OracleCorePoint: the oracle with the pixels within 1° of its peak merged into one direction;
  //   Sources: the product path with SkyEstimateOptions::max_sources = --sources (the sun's test,
  //   then lamps, each found disc replaced by its background before looking for the next), each
  //   its own separated term in blend_cpu_sources (skylit-shade --sources N; the live path has one);
  //   FillDome: the detected sun, the dome from the frame with the disc's pixels set to the
  //   sun's background instead of left out.
  enum class Mix { None, OracleLight, OracleDome, OracleEnergy, OraclePoint, OracleCorePoint, Sources, FillDome } mix = Mix::None;
};

const std::vector<Config> kConfigs{
    {"paper", 2, 1, false},     // ν=2, face centre, no sun separation (paper 003)
    {"area", 2, 16, false},     // ν=2, faces as area lights
    {"area+sun", 2, 16, true},  // ν=2, area lights, sun separated
    {"area64+sun", 2, 64, true},  // ν=2, denser visibility sampling per face
    {"nu4", 4, 16, true},
    {"nu8", 8, 16, true},
    {"nu4-corners", 4, 16, true, skylit::geom::DomeBasis::Corners},             // the balanced preset's bake
    {"nu4-quadratics64", 4, 64, true, skylit::geom::DomeBasis::Quadratics},     // the accurate preset's
    {"nu4-corners+sources", 4, 16, true, skylit::geom::DomeBasis::Corners, false, Config::Mix::Sources},
    // What the balanced dome leaves: a finer dome, denser visibility
    {"nu6-corners", 6, 16, true, skylit::geom::DomeBasis::Corners},
    {"nu8-corners", 8, 16, true, skylit::geom::DomeBasis::Corners},
    {"nu4-corners64", 4, 64, true, skylit::geom::DomeBasis::Corners},
    // ν=2, three linear hats per face (120 layers), area lights
    {"corners", 2, 16, true, skylit::geom::DomeBasis::Corners},
    {"corners-nosun", 2, 16, false, skylit::geom::DomeBasis::Corners},
    {"corners64", 2, 64, true, skylit::geom::DomeBasis::Corners},  // denser visibility sampling
    {"area+oracle", 2, 16, true, skylit::geom::DomeBasis::Faces, true},
    {"corners+oracle", 2, 16, true, skylit::geom::DomeBasis::Corners, true},
    {"corners64+oracle", 2, 64, true, skylit::geom::DomeBasis::Corners, true},
    {"corners64+oracle-light", 2, 64, true, skylit::geom::DomeBasis::Corners, false, Config::Mix::OracleLight},
    {"corners64+oracle-dome", 2, 64, true, skylit::geom::DomeBasis::Corners, false, Config::Mix::OracleDome},
    {"corners64+oracle-energy", 2, 64, true, skylit::geom::DomeBasis::Corners, false, Config::Mix::OracleEnergy},
    {"corners64+oracle-point", 2, 64, true, skylit::geom::DomeBasis::Corners, true, Config::Mix::OraclePoint},
    {"corners64+oracle-corepoint", 2, 64, true, skylit::geom::DomeBasis::Corners, true, Config::Mix::OracleCorePoint},
    {"corners64+fill", 2, 64, true, skylit::geom::DomeBasis::Corners, false, Config::Mix::FillDome},
    {"corners64+sources", 2, 64, true, skylit::geom::DomeBasis::Corners, false, Config::Mix::Sources},
    // ν=2, six quadratic Bernstein functions per face (240 layers)
    {"quadratics", 2, 16, true, skylit::geom::DomeBasis::Quadratics},
    {"quadratics64", 2, 64, true, skylit::geom::DomeBasis::Quadratics},
    {"quadratics64+sources", 2, 64, true, skylit::geom::DomeBasis::Quadratics, false, Config::Mix::Sources},
};

// sky.clipped_sun_energy: shadow_contrast, as an HMD node measures it: real ground under the
// equirect's sky in and out of a post's shadow (the oracle's disc hidden), seen by an 8-bit
// camera, against the dome's D_sky on the bake's ground plane. Taken when it says more than the
// clipped pixels, as the live path does.
void apply_ground_contrast(skylit::sky::SkyEstimate& estimate, const cv::Mat& equirect, const EquirectSun& oracle,
                           const skylit::bake_format::Manifest& manifest, const std::string& sky_name) {
  const auto ground = std::find_if(manifest.planes.begin(), manifest.planes.end(),
                                   [](const auto& record) { return record.plane.normal().z() > 0.999; });
  if (ground == manifest.planes.end()) {
    std::fprintf(stderr, "%s: shadow contrast: the bake has no horizontal plane\n", sky_name.c_str());
    return;
  }
  const GroundView view = real_ground_view(equirect, oracle.peak, kOracleRadiusDeg);
  const std::vector<Eigen::Vector3d> S = skylit::sky::layer_radiances(estimate.luminance);
  const Eigen::Vector3d sky_irradiance = skylit::render::plane_irradiance(*ground, S, std::nullopt);
  skylit::sky::Sun& sun = *estimate.sun;
  const skylit::render::ShadowContrast contrast = skylit::render::estimate_sun_from_shadow_contrast(
      view.linear, view.lit, view.shadowed, sky_irradiance, sun.direction.normalized().z());
  std::fprintf(stderr, "%s: shadow contrast: %s, sun %.4g (measured %.4g, oracle %.4g, luminance), confidence %.2f\n",
               sky_name.c_str(), contrast.ok ? "ok" : contrast.problem.c_str(), luminance(contrast.sun_energy),
               luminance(sun.energy), luminance(oracle.energy), contrast.confidence);
  if (!contrast.ok || !(luminance(contrast.sun_energy) > luminance(sun.energy))) return;
  sun.measured_energy = sun.energy;
  sun.energy = contrast.sun_energy;
  sun.energy_estimator = "shadow_contrast";
  sun.energy_confidence = contrast.confidence;
  if (!estimate.sources.empty()) estimate.sources.front() = sun;  // sources[0] is the sun
}

// One bake per (ν, K, basis).
using BakeKey = std::tuple<int, int, skylit::geom::DomeBasis>;
BakeKey key_of(const Config& c) { return {c.frequency, c.samples, c.basis}; }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"accuracy_study: dome shadow ratios against a dense per-pixel reference on real skies"};
  std::string skies_dir = "data/hdri", site_file = "config/sample_site.yaml", calib_file = "config/sky_camera.yaml";
  std::string out_dir = "build/accuracy", config_list;
  int texel_scale = 8, supersample = 2;
  app.add_option("--skies", skies_dir, "folder of equirectangular .exr skies")->capture_default_str();
  app.add_option("--site", site_file)->capture_default_str();
  app.add_option("--calib", calib_file, "sky camera the skies are rendered into")->capture_default_str();
  app.add_option("--texel-scale", texel_scale, "divide every plane's resolution by this")->capture_default_str();
  app.add_option("--supersample", supersample, "fisheye rendering: sub-pixels per axis")->capture_default_str();
  app.add_option("--out", out_dir, "bakes and results")->capture_default_str();
  app.add_option("--configs", config_list,
                 "comma-separated subset of paper,area,area+sun,area64+sun,nu4,nu8,nu4-corners,nu6-corners,nu8-corners,"
                 "nu4-corners64,nu4-quadratics64,corners,corners-nosun,corners64,"
                 "area+oracle,corners+oracle,corners64+oracle and the diagnoses corners64+oracle-light,"
                 "corners64+oracle-dome,corners64+oracle-energy,corners64+oracle-point,corners64+oracle-corepoint,"
                 "corners64+fill,corners64+sources; quadratics,quadratics64,quadratics64+sources");
  std::string only_sky;
  bool dump = false;
  bool reuse_bakes = false;
  app.add_flag("--reuse-bakes", reuse_bakes,
               "a configuration whose bake directory under --out already holds a finished bake uses it as it is "
               "(its settings are not checked: for a rerun of the same study on other skies)");
  int reference_supersample = 4;
  app.add_option("--reference-supersample", reference_supersample,
                 "reference: bright pixels and their neighbours as N×N bilinear sub-directions (1: one point per pixel)")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  int source_count = 3;
  app.add_option("--sources", source_count, "corners64+sources, quadratics64+sources: how many compact sources to separate")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  skylit::sky::SunOptions sun_options;
  app.add_option("--sun-disc-factor", sun_options.disc_factor, "sun detector: disc pixels above background × this")
      ->capture_default_str();
  app.add_option("--sun-halo", sun_options.halo_radius_deg, "sun detector: disc radius limit, degrees")
      ->capture_default_str();
  app.add_option("--sun-min-contrast", sun_options.min_contrast, "sun detector: peak / background for a sun")
      ->capture_default_str();
  app.add_option("--sun-max-core", sun_options.max_angular_radius_deg, "sun detector: widest core, degrees")
      ->capture_default_str();
  std::vector<int> pca_components;
  app.add_option("--pca", pca_components, "also blend each bake compressed to these numbers of principal components")
      ->delimiter(',');
  double pca_correlation = 0.0;
  int pca_tile = 0;
  app.add_option("--pca-tile", pca_tile,
                 "--pca: clustered PCA, each tile of N×N texels its own K components (0: the whole plane)")
      ->check(CLI::Range(0, 4096));
  app.add_option("--pca-sky-correlation", pca_correlation, "--pca: the sky prior's correlation angle, degrees (0: none)");
  app.add_flag("--pictures", dump, "write T | reference | 5×|difference| per sky, setting and plane as PNG");
  app.add_option("--sky", only_sky, "only this sky (file stem, e.g. park)");
  double ground_albedo = 0.0;
  app.add_option("--ground-albedo", ground_albedo,
                 "a lambertian ground (z = 0) of this albedo in the building's reference, and the bake's ground layer "
                 "in its estimate (0: neither)")
      ->check(CLI::Range(0.0, 1.0));
  double max_edge = -1;
  app.add_option("--max-edge", max_edge, "the site's scene.max_edge for this study, metres (default: the site's own)");
  double eight_bit = 0.0;
  app.add_option("--eight-bit", eight_bit,
                 "each sky as one auto-exposed 8-bit sRGB frame, its sky's median at this share of full scale (0.18: "
                 "middle grey; 0: the HDR frame)")
      ->check(CLI::Range(0.0, 1.0));
  int bracket_frames = 1;
  app.add_option("--bracket", bracket_frames,
                 "--eight-bit: an exposure bracket of this many 8-bit frames, each 1/30 of the one before, merged "
                 "(sky.bracket); 1: one frame")
      ->check(CLI::Range(1, 8));
  bool expected_sun = false;
  app.add_flag("--expected-sun", expected_sun,
               "the sun's direction as a site's location and a frame's time would give it (the equirect's own sun): a "
               "clipped blob there is the sun");
  std::string clipped_energy = "measured";
  app.add_option("--clipped-sun-energy", clipped_energy,
                 "a clipped sun's energy: clear_sky, shadow_contrast (an HMD camera's 8-bit view of real ground in "
                 "and out of a post's shadow under the equirect's sky) or measured")
      ->capture_default_str();
  skylit::baker::RefineOptions refine;
  app.add_option("--refine", refine.tolerance, "every bake splits the model where its light changes (skylit-bake --refine)");
  app.add_option("--refine-rounds", refine.rounds, "--refine: rounds of splits at most")->capture_default_str();
  app.add_option("--refine-min-edge", refine.min_edge, "--refine: metres, no edge shorter than twice this is split")
      ->capture_default_str();
  skylit::baker::LightMapOptions light_map_options{0.0, 0.1, 10};  // texel 0: none
  app.add_option("--light-map", light_map_options.texel,
                 "every bake has a light map of this texel (m) over the model's flat regions (skylit-bake --light-map); "
                 "the building inside the triangles is then shown from it where it covers them");
  app.add_option("--light-map-min-area", light_map_options.min_area, "m², with --light-map (skylit-bake --light-map-min-area)");
  app.add_option("--light-map-min-across", light_map_options.min_across, "texels, with --light-map (skylit-bake --light-map-min-across)");
  skylit::bake_format::LightMapPcaOptions light_map_pca{0, 0.0, true};  // components 0: the full form
  app.add_option("--light-map-components", light_map_pca.components,
                 "with --light-map: the light map's PCA form, K components per chart, in place of the full form "
                 "(skylit-bake --light-map-components); 0: the full form");
  app.add_option("--light-map-sky-correlation", light_map_pca.sky_correlation_deg,
                 "degrees, with --light-map-components (skylit-bake --light-map-sky-correlation)");
  skylit::render::LightMapPrecision light_map_precision = skylit::render::LightMapPrecision::Float;
  app.add_option("--light-map-precision", light_map_precision,
                 "with --light-map: the light map's values as the compositor holds them (render.light_map_precision): "
                 "float, or half (each rounded to the nearest half float)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, skylit::render::LightMapPrecision>{
          {"float", skylit::render::LightMapPrecision::Float}, {"half", skylit::render::LightMapPrecision::Half}}));
  double inside_spacing = 0.0;
  app.add_option("--inside-spacing", inside_spacing,
                 "metres: the points inside the triangles about this far apart or closer, a large triangle split into smaller ones "
                 "first, so that the figures inside the triangles compare models tessellated differently (0: four "
                 "points per triangle)")
      ->check(CLI::Range(0.0, 100.0));
  int vertex_fit = 0;
  app.add_option("--vertex-fit", vertex_fit,
                 "every bake fits its vertices to the light at N² points inside each triangle (skylit-bake --vertex-fit)")
      ->check(CLI::Range(0, 16));
  bool gpu_path_too = false;
  app.add_flag("--gpu", gpu_path_too, "also the live GPU path: shadow maps per source, GPU blend (OpenGL ES, EGL)");
  std::string gpu_radius = "shadow";
  app.add_option("--gpu-radius", gpu_radius,
                 "--gpu: each lamp's disc for its map: shadow (Sun::shadow_radius, as the live service), core "
                 "(the detector's core radius)")
      ->check(CLI::IsMember({"shadow", "core"}))
      ->capture_default_str();
  skylit::render::SunShadowOptions gpu_maps;
  app.add_option("--gpu-map-resolution", gpu_maps.resolution, "--gpu: texels along each side of the shadow maps")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  std::optional<skylit::gpu::HeadlessContext> gl;
  if (gpu_path_too) gl.emplace();

  std::vector<Config> configs;
  for (const Config& c : kConfigs) {
    if (config_list.empty() || ("," + config_list + ",").find("," + c.name + ",") != std::string::npos) configs.push_back(c);
  }
  fs::create_directories(out_dir);
  const fs::path site_path = coarse_site(site_file, texel_scale, out_dir);
  if (max_edge >= 0) {  // the study's own split of the model, written into its site
    skylit::scene::Site split = skylit::scene::load_site(site_path);
    split.max_edge = max_edge;
    skylit::write_file_atomic(site_path, skylit::scene::site_to_yaml(split));
  }
  const skylit::scene::Site site = skylit::scene::load_site(site_path);
  skylit::scene::Mesh mesh = skylit::scene::load_site_model(site);
  const skylit::camera::CameraCalibration calibration = skylit::camera::load_calibration(calib_file);
  const skylit::camera::Lens lens(calibration);
  // The pixels that see the sky, which an auto-exposing camera meters (--eight-bit).
  cv::Mat sky_pixels(calibration.image_height, calibration.image_width, CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < sky_pixels.rows; ++y) {
    for (int x = 0; x < sky_pixels.cols; ++x) {
      const auto d = lens.pixel_to_site(Eigen::Vector2d(x, y));
      if (d && d->z() >= 0.0) sky_pixels.at<std::uint8_t>(y, x) = 255;
    }
  }

  // One bake per (ν, K, basis), ray-traced: the CPU reference engine.
  std::map<BakeKey, fs::path> bakes;
  std::map<BakeKey, double> bake_seconds;
  for (const Config& c : configs) {
    const BakeKey key = key_of(c);
    if (bakes.count(key)) continue;
    const fs::path dir = fs::path(out_dir) / ("bake_nu" + std::to_string(c.frequency) + "_k" + std::to_string(c.samples) +
                                              (c.basis == skylit::geom::DomeBasis::Faces ? std::string()
                                                                                         : "_" + std::string(skylit::geom::basis_name(c.basis))));
    skylit::baker::BakeOptions options;
    options.site_file = site_path;
    options.out_dir = dir;
    options.frequency = c.frequency;
    options.samples = c.samples;
    options.basis = c.basis;
    options.method = "raytrace";
    options.force = true;
    options.previews = false;
    options.refine = refine;
    options.vertex_fit = vertex_fit;
    if (light_map_options.texel > 0.0) options.light_map = light_map_options;
    if (light_map_options.texel > 0.0 && light_map_pca.components > 0) options.light_map_pca = light_map_pca;
    const auto t = Clock::now();
    if (reuse_bakes && fs::exists(dir / "manifest.json")) {
      std::fprintf(stderr, "reusing the bake in %s (--reuse-bakes: its settings are taken on trust)\n", dir.c_str());
    } else {
      skylit::baker::run_bake(options, stderr);
    }
    bake_seconds[key] = seconds_since(t);
    bakes[key] = dir;
  }
  // Refined bakes share one model: the refinement depends on the model alone, not the dome.
  if (refine.tolerance > 0.0 && !bakes.empty()) {
    const fs::path& first = bakes.begin()->second;
    mesh = skylit::bake_format::load_baked_model(site, first, skylit::bake_format::read_manifest(first));
    std::fprintf(stderr, "accuracy_study: the refined model has %zu vertices, %zu triangles\n", mesh.vertex_count(),
                 mesh.triangle_count());
  }
  // The PCA forms: a copy of each bake per K, compressed as skylit-bake compress does it (with
  // --pca-tile, clustered).
  std::map<std::pair<BakeKey, int>, fs::path> pca_bakes;
  for (const auto& [key, dir] : bakes) {
    for (const int k : pca_components) {
      const fs::path copy = dir.string() + "_pca" + std::to_string(k) + (pca_tile > 0 ? "_tile" + std::to_string(pca_tile) : "");
      fs::remove_all(copy);
      fs::copy(dir, copy, fs::copy_options::recursive);
      skylit::bake_format::PcaOptions pca;
      pca.components = k;
      pca.sky_correlation_deg = pca_correlation;
      pca.tile = pca_tile;
      skylit::baker::compress_bake(copy, pca, std::nullopt, stderr);
      pca_bakes[{key, k}] = copy;
    }
  }
  nlohmann::json pca_results = nlohmann::json::array();
  std::vector<std::string> pca_rows;

  std::vector<fs::path> skies;
  for (const auto& entry : fs::directory_iterator(skies_dir)) {
    if (entry.path().extension() == ".exr" && (only_sky.empty() || entry.path().stem() == only_sky)) {
      skies.push_back(entry.path());
    }
  }
  std::sort(skies.begin(), skies.end());

  nlohmann::json results = nlohmann::json::array();
  std::vector<std::string> sun_notes;
  struct BuildingRow {
    std::string sky, config;
    Errors errors;
    std::string worst;  // where the largest error is
    Errors planes;      // the building's planes' texels
    Errors inside;      // points inside the triangles, E interpolated from the vertices
    Errors inside_by_area;  // the same, each point weighted by the surface it stands for
    // With --ground-albedo: the estimate without the ground layer, and the reference's ground
    // taken as uniformly lit (E_h) against the shadowed one, both against the reference.
    std::optional<Errors> no_ground, uniform_ground;
    // Inside the triangles by area: the sky's layers interpolated against the same sky traced at
    // the points; the whole with the sky so traced against the reference; the ground's layer
    // against the reference's ground; the whole as the compositor shows it (study::building_terms_inside).
    std::array<Errors, 4> terms;
  };
  std::vector<BuildingRow> building_rows;
  struct GpuRow {
    std::string sky, config;
    std::size_t sources = 0;
    Errors cpu, disc, gpu, building, inside_by_area;  // the last: as the compositor shows it, the sun per point
    double gpu_vs_cpu = 0;  // max |T_gpu − T_cpu|
    double shadow_ms = 0, blend_ms = 0;
  };
  std::vector<GpuRow> gpu_rows;
  std::printf("| sky | configuration | ν | K | basis | sun | RMS | p99 | max | sun found |\n"
              "|---|---|---|---|---|---|---|---|---|---|\n");
  for (const fs::path& sky_file : skies) {
    // Lossy HDR captures hold negative (and, in general, non-finite) pixels. Both paths see the
    // same sky: cleaned once here, so that resampling the artefacts into the fisheye does not
    // count as error of the dome.
    const cv::Mat equirect = read_clean_sky(sky_file);
    // Reference weights: every pixel above the horizon, radiance × solid angle (bad pixels as 0);
    // with --reference-supersample N, the pixels near a bright one as N×N sub-directions
    // (study::dense_reference).
    // The lights once, for the planes' reference and the building's.
    const EquirectLights sky_lights = equirect_lights(equirect, reference_supersample);
    const DenseReference dense = dense_reference(sky_lights, site, mesh);
    if (dense.supersampled > 0) {
      std::fprintf(stderr, "%s: reference: %zu pixels near bright ones as %d² sub-directions\n",
                   sky_file.stem().c_str(), dense.supersampled, reference_supersample);
    }
    const std::vector<std::vector<Eigen::Vector3d>>& reference = dense.planes;
    const double reference_seconds = dense.seconds;
    // The building's reference: the same lights at every model vertex, the model's own occlusion.
    const Eigen::Vector3d horizontal = horizontal_irradiance(sky_lights);
    const auto building_start = Clock::now();
    std::vector<Eigen::Vector3d> building_ref = building_reference(sky_lights, site, mesh);
    // And inside the triangles, where the compositor interpolates the vertices' E.
    const TrianglePoints inside_points = triangle_points(mesh, inside_spacing);
    if (inside_spacing > 0) {
      std::fprintf(stderr, "%s: %zu points inside the model's triangles (about %g m apart)\n", sky_file.stem().c_str(),
                   inside_points.positions.size(), inside_spacing);
    } else {
      std::fprintf(stderr, "%s: %zu points inside the model's triangles (four per triangle)\n", sky_file.stem().c_str(),
                   inside_points.positions.size());
    }
    std::vector<Eigen::Vector3d> inside_ref = building_reference_at(sky_lights, site, mesh, inside_points);
    const std::vector<Eigen::Vector3d> sky_vertex_ref = building_ref, sky_inside_ref = inside_ref;  // before the ground's
    std::vector<Eigen::Vector3d> ground_inside_ref(inside_ref.size(), Eigen::Vector3d::Zero());
    // The ground's light: lit as the dense reference lights the site's horizontal plane at the
    // ground (the model's shadow on it), and uniformly (E_h) for what that assumption costs.
    std::vector<Eigen::Vector3d> uniform_ground_ref;
    if (ground_albedo > 0.0) {
      const GroundReferenceOptions ground = site_ground(site, dense, Eigen::Vector3d::Constant(ground_albedo));
      GroundReferenceOptions uniformly = ground;
      uniformly.shadow_plane = nullptr;
      const std::vector<Eigen::Vector3d> uniform = ground_reference(sky_lights, site, mesh, uniformly);
      const std::vector<Eigen::Vector3d> shadowed = ground_reference(sky_lights, site, mesh, ground);
      const std::vector<Eigen::Vector3d> shadowed_inside = ground_reference_at(sky_lights, site, mesh, inside_points, ground);
      uniform_ground_ref = building_ref;
      for (std::size_t v = 0; v < building_ref.size(); ++v) {
        uniform_ground_ref[v] += uniform[v];
        building_ref[v] += shadowed[v];
      }
      for (std::size_t k = 0; k < inside_ref.size(); ++k) {
        if (!inside_ref[k].isZero(0)) inside_ref[k] += shadowed_inside[k];  // enclosed points stay out
        ground_inside_ref[k] = shadowed_inside[k];
      }
    }
    const double building_reference_seconds = seconds_since(building_start);

    skylit::sky::RadianceFrame frame{skylit::sky::render_fisheye(lens, equirect, {.supersample = supersample}), cv::Mat()};
    if (eight_bit > 0.0) {
      // One frame of an 8-bit camera that meters its sky: what most sites buy.
      const double scale = skylit::sky::auto_exposure_scale(frame.radiance, sky_pixels, eight_bit);
      std::vector<cv::Mat> bracket;
      std::vector<skylit::sky::Exposure> exposures;
      for (int k = 0; k < bracket_frames; ++k) {
        const double scale_k = scale * std::pow(1.0 / 30.0, k);
        bracket.push_back(skylit::sky::to_8bit(frame.radiance, scale_k));
        exposures.push_back(skylit::sky::Exposure{scale_k, 1.0});
      }
      frame = bracket_frames == 1
                  ? skylit::sky::linearise(bracket.front(), skylit::sky::ResponseCurve::srgb(8), exposures.front())
                  : skylit::sky::merge_bracket(bracket, exposures, skylit::sky::ResponseCurve::srgb(8));
      std::fprintf(stderr, "%s: 8-bit at %.0f%% of full scale, %d frame(s): %d pixels clipped\n", sky_file.stem().c_str(),
                   100.0 * eight_bit, bracket_frames,
                   cv::countNonZero(frame.clipped));
    }
    // The oracle's frame: the sun's pixels replaced by the background around them.
    const EquirectSun oracle = equirect_sun(equirect);
    skylit::sky::RadianceFrame oracle_frame;
    if (oracle.found) {
      cv::Mat without_sun = equirect.clone();
      for (const auto& [row, col] : oracle.pixels) {
        const cv::Vec3f l = without_sun.at<cv::Vec3f>(row, col);
        for (int ch = 0; ch < 3; ++ch) {
          without_sun.at<cv::Vec3f>(row, col)[ch] = std::min(l[ch], static_cast<float>(oracle.background[2 - ch]));
        }
      }
      oracle_frame = {skylit::sky::render_fisheye(lens, without_sun, {.supersample = supersample}), cv::Mat()};
    }
    bool noted = false;
    for (const Config& c : configs) {
      const fs::path bake_dir = bakes.at(key_of(c));
      const skylit::bake_format::Manifest manifest = skylit::bake_format::read_manifest(bake_dir);
      const skylit::geom::Dome dome(c.frequency);
      const bool use_oracle = c.oracle_sun && oracle.found;
      skylit::sky::SkyEstimateOptions sky_options;
      sky_options.sun_mode = c.sun && !use_oracle ? skylit::sky::SunMode::Auto : skylit::sky::SunMode::Off;
      sky_options.table.basis = c.basis;
      sky_options.sun = sun_options;
      // The reference is the same capture: its sun is taken as it is, whatever its colour.
      sky_options.correct_sun_colour = false;
      sky_options.clipped_sun_energy = skylit::sky::parse_clipped_sun_energy(clipped_energy, "--clipped-sun-energy");
      if (c.mix == Config::Mix::Sources) {
        sky_options.max_sources = source_count;  // the product path: the sun test, then lamps
        sky_options.lamp = skylit::sky::lamp_options(sun_options);
      }
      const skylit::sky::SkyEstimator estimator(calibration, dome, sky_options);
      const std::optional<Vec3> expected =
          expected_sun && oracle.found ? std::optional<Vec3>(oracle.centroid) : std::nullopt;
      skylit::sky::SkyEstimate estimate = estimator.estimate(use_oracle ? oracle_frame : frame, expected);
      if (sky_options.clipped_sun_energy == skylit::sky::ClippedSunEnergy::ShadowContrast && estimate.sun &&
          estimate.sun->clipped && oracle.found) {
        apply_ground_contrast(estimate, equirect, oracle, manifest, sky_file.stem().string());
      }
      const bool mixed = c.mix != Config::Mix::None && oracle.found && estimate.sun;
      if (mixed && c.mix == Config::Mix::OracleDome) {
        estimate.luminance = skylit::sky::compute_luminance(estimator.table(), dome, oracle_frame.radiance,
                                                            oracle_frame.clipped, cv::Mat(), sky_options.luminance);
      }
      if (c.mix == Config::Mix::FillDome && estimate.sun) {
        cv::Mat filled = frame.radiance.clone();
        const Eigen::Vector3d& bg = estimate.sun->background;
        filled.setTo(cv::Vec3f(static_cast<float>(bg.z()), static_cast<float>(bg.y()), static_cast<float>(bg.x())),
                     skylit::sky::SunDetector(lens, cv::Mat(), sun_options).detect(frame.radiance, frame.clipped).mask);
        estimate.luminance = skylit::sky::compute_luminance(estimator.table(), dome, filled, frame.clipped, cv::Mat(),
                                                            sky_options.luminance);
      }
      // Several separated sources (SkyEstimateOptions::max_sources): found one after the other, all
      // taken out of the dome, each its own term in the blend below.
      std::vector<skylit::sky::Sun> sources;
      const bool first_is_sun = estimate.sun.has_value();  // sources[0] is the sun (the live path's disc rule differs)
      if (c.mix == Config::Mix::Sources) {
        sources = estimate.sources;
        estimate.sun.reset();
        estimate.sun_reason = std::to_string(sources.size()) + " source(s)";
      }
      const std::vector<Eigen::Vector3d> S = skylit::sky::layer_radiances(estimate.luminance);
      std::optional<skylit::blend::SunLight> sun;
      std::vector<Vec3> disc_directions;
      std::vector<double> disc_weights;
      if (use_oracle) {
        sun = skylit::blend::SunLight{oracle.centroid, oracle.energy};
        disc_directions = oracle.directions;
        disc_weights = oracle.weights;
        if (c.mix == Config::Mix::OraclePoint) {
          disc_directions = {oracle.centroid};
          disc_weights = {1.0};
        } else if (c.mix == Config::Mix::OracleCorePoint) {
          disc_directions.clear();
          disc_weights.clear();
          Vec3 core = Vec3::Zero();
          double core_weight = 0;
          for (std::size_t k = 0; k < oracle.directions.size(); ++k) {
            if (degrees_between(oracle.directions[k], oracle.peak) <= 1.0) {
              core += oracle.weights[k] * oracle.directions[k];
              core_weight += oracle.weights[k];
            } else {
              disc_directions.push_back(oracle.directions[k]);
              disc_weights.push_back(oracle.weights[k]);
            }
          }
          disc_directions.push_back(core.normalized());
          disc_weights.push_back(core_weight);
        }
      } else if (mixed && c.mix == Config::Mix::OracleLight) {
        sun = skylit::blend::SunLight{oracle.centroid, oracle.energy};
        disc_directions = oracle.directions;
        disc_weights = oracle.weights;
      } else if (estimate.sun) {
        sun = skylit::blend::SunLight{estimate.sun->direction,
                                       mixed && c.mix == Config::Mix::OracleEnergy ? oracle.energy : estimate.sun->energy};
        disc_directions = estimate.sun->disc_directions;
        disc_weights = estimate.sun->disc_weights;
      }
      // The building: the bake's transfer vectors times S, and each separated source through its
      // disc's visibility from the vertex.
      std::vector<SourceLight> building_sources;
      for (const skylit::sky::Sun& source : sources) {
        building_sources.push_back({source.direction, source.energy, source.disc_directions, source.disc_weights});
      }
      if (sources.empty() && sun) building_sources.push_back({sun->direction, sun->energy, disc_directions, disc_weights});
      std::vector<std::size_t> transfer_shape;
      const std::vector<float> transfer = skylit::bake_format::read_npy(bake_dir / manifest.transfer_file, &transfer_shape);
      std::optional<Errors> no_ground, uniform_ground;
      std::vector<float> ground_transfer;
      skylit::blend::GroundLight ground;
      if (ground_albedo > 0.0) {
        if (!manifest.ground) throw std::runtime_error(bake_dir.string() + ": the bake has no ground layer");
        no_ground = building_errors(building_estimate(transfer, S, building_sources, site, mesh), building_ref, horizontal);
        uniform_ground = building_errors(uniform_ground_ref, building_ref, horizontal);
        ground_transfer = skylit::bake_format::read_npy(bake_dir / manifest.ground->file, &transfer_shape);
        std::vector<skylit::blend::SunLight> lights;
        for (const SourceLight& source : building_sources) lights.push_back({source.direction, source.energy});
        const skylit::blend::GroundLayers layers(manifest.plan.frequency, manifest.plan.basis, manifest.ground->horizontal_unoccluded);
        ground.transfer = ground_transfer;
        ground.coefficients = layers.coefficients(S, lights);
        ground.albedo = Eigen::Vector3d::Constant(ground_albedo);
      }
      const std::vector<Eigen::Vector3d> building_E = building_estimate(transfer, S, building_sources, site, mesh, ground);
      const Errors building = building_errors(building_E, building_ref, horizontal);
      // Points no ray of the reference leaves lie inside other solids (a plinth's top under its
      // column): nobody sees them, and they are left out.
      // The compositor takes the sun per pixel (its shadow map at the fragment), the rest from the
      // vertices: the sun's term at the points themselves, the other terms interpolated.
      // Where a virtual plane covers a point, its T_j D_j replaces the vertices' sky and sources, as
      // in the compositor: filled in after the planes' blend below.
      InsideTerms split = building_terms_inside(inside_points, transfer, S, building_sources, estimate.sun.has_value(),
                                                site, mesh, ground);
      // With a light map, the sky and the ground from its texels where it covers a triangle.
      std::optional<skylit::bake_format::LightMapArrays> texel_map;
      // The PCA form's t̂ as the compositor sums them (negative ones too, the sum clamped at 0).
      skylit::bake_format::LightMapValues texel_values = skylit::bake_format::LightMapValues::Full;
      skylit::blend::GroundLight texel_ground;
      InsideTerms vertex_sky;
      if (manifest.light_map) {
        // The PCA form as the compositor sums it: the same sum over its t̂.
        const bool pca = manifest.light_map->pca.has_value();
        texel_map = skylit::bake_format::read_light_map(bake_dir, manifest,
                                                        pca ? skylit::bake_format::LightMapForm::Pca : skylit::bake_format::LightMapForm::Full);
        skylit::study::hold_light_map(*texel_map, light_map_precision);
        if (pca) {
          texel_values = skylit::bake_format::LightMapValues::Reconstructed;
          texel_map->transfer = skylit::bake_format::expand_light_map(texel_map->layout, texel_map->pca->sky);
          if (manifest.ground) texel_map->ground = skylit::bake_format::expand_light_map(texel_map->layout, texel_map->pca->ground);
        }
        texel_ground = ground;
        texel_ground.transfer = ground.transfer.empty() ? std::span<const float>() : std::span<const float>(texel_map->ground);
        vertex_sky = building_terms_inside(inside_points, transfer, S, {}, false, site, mesh);
        use_light_map(inside_points, texel_map->layout, texel_map->transfer, S, texel_ground, vertex_sky.sky, split, texel_values);
      }
      std::vector<std::size_t> inside_seen;
      std::vector<double> inside_areas;
      for (std::size_t k = 0; k < inside_ref.size(); ++k) {
        if (inside_ref[k].isZero(0)) continue;
        inside_seen.push_back(k);
        inside_areas.push_back(inside_points.areas[k]);
      }
      // Term by term: the sky's interpolation against the dome's sky traced at the points
      // themselves, and what is left with the sky so traced (the dome and the separation).
      std::array<Errors, 4> terms;
      {
        const EquirectLights dome_lights = dome_sky_lights(c.frequency, c.basis, S, 4096);
        const std::vector<Eigen::Vector3d> sky_at_points = building_reference_at(dome_lights, site, mesh, inside_points);
        if (manifest.ground) {
          // How well the 4096 directions integrate the dome's sky: on an unoccluded horizontal
          // surface they should give Σ_l S_l h_l, the layers' own integral.
          Eigen::Vector3d traced = Eigen::Vector3d::Zero(), exact = Eigen::Vector3d::Zero();
          for (std::size_t k = 0; k < dome_lights.directions.size(); ++k) traced += std::max(0.0, dome_lights.directions[k].z()) * dome_lights.weights[k];
          for (std::size_t i = 0; i < S.size(); ++i) exact += manifest.ground->horizontal_unoccluded[i] * S[i];
          std::fprintf(stderr, "%s %s: the split's 4096 directions give a horizontal irradiance of %.4g against the layers' %.4g "
                       "(%.4f of E_h apart)\n", sky_file.stem().c_str(), c.name.c_str(), luminance(traced), luminance(exact),
                       std::abs(luminance(traced) - luminance(exact)) / luminance(horizontal));
        }
        std::array<std::vector<Eigen::Vector3d>, 3> est, ref;
        for (const std::size_t k : inside_seen) {
          est[0].push_back(split.sky[k]), ref[0].push_back(sky_at_points[k]);
          est[1].push_back(sky_at_points[k] + split.sun[k] + split.ground[k]), ref[1].push_back(inside_ref[k]);
          est[2].push_back(split.ground[k]), ref[2].push_back(ground_inside_ref[k]);
        }
        for (std::size_t t = 0; t < 3; ++t) terms[t] = building_errors(est[t], ref[t], horizontal, inside_areas);
      }
      Errors inside, inside_by_area;  // after the planes' blend
      const std::size_t worst = worst_vertex(building_E, building_ref, horizontal);
      char where[320];
      std::snprintf(where, sizeof where, "vertex %zu at (%.2f, %.2f, %.2f) m, normal (%.2f, %.2f, %.2f): E %.4g, E_ref %.4g (luminance), E_h %.4g",
                    worst, mesh.positions[worst].x(), mesh.positions[worst].y(), mesh.positions[worst].z(), mesh.normals[worst].x(),
                    mesh.normals[worst].y(), mesh.normals[worst].z(), luminance(building_E[worst]), luminance(building_ref[worst]),
                    luminance(horizontal));
      building_rows.push_back({sky_file.stem().string(), c.name, building, where, Errors{}, inside, inside_by_area, no_ground, uniform_ground, terms});
      if (estimate.sun && oracle.found && !noted) {
        // The detected sun against the equirect's: where, how wide, how much energy.
        noted = true;
        const skylit::sky::Sun& d = *estimate.sun;
        Vec3 cells = Vec3::Zero();
        for (std::size_t k = 0; k < d.disc_directions.size(); ++k) cells += d.disc_weights[k] * d.disc_directions[k];
        char line[768];
        std::snprintf(line, sizeof line,
                      "%s: detected sun %.2f° from the equirect's peak pixel (%.2f° from the oracle's energy "
                      "centroid; its cells' centroid %.2f° from the oracle's), core radius %.2f°, %d pixels in %zu "
                      "cells; energy (luminance) detected %.4g, "
                      "equirect above background within 1°/2°/4°/6° of the peak %.4g/%.4g/%.4g/%.4g; equirect "
                      "pixel %.2f°; located by %s, energy %s (confidence %.2f), oracle's energy %.4g",
                      sky_file.stem().c_str(), degrees_between(d.direction, oracle.peak),
                      degrees_between(d.direction, oracle.centroid), degrees_between(cells.normalized(), oracle.centroid),
                      d.angular_radius * 180.0 / M_PI, d.pixel_count,
                      d.disc_directions.size(), luminance(d.energy), oracle.energy_within(1.0, equirect),
                      oracle.energy_within(2.0, equirect), oracle.energy_within(4.0, equirect),
                      oracle.energy_within(6.0, equirect), 360.0 / equirect.cols, d.located_by.c_str(),
                      d.energy_estimator.c_str(), d.energy_confidence, luminance(oracle.energy));
        sun_notes.emplace_back(line);
        // Energy by distance from the oracle's centroid, detected against oracle: where they differ.
        const std::vector<double> edges{0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 180.0};
        std::vector<double> detected_bins(edges.size(), 0.0), oracle_bins(edges.size(), 0.0);
        const auto bin_of = [&](const Vec3& dir) {
          const double a = degrees_between(dir, oracle.centroid);
          return static_cast<std::size_t>(std::lower_bound(edges.begin(), edges.end(), a) - edges.begin());
        };
        for (std::size_t k = 0; k < d.disc_directions.size(); ++k) {
          detected_bins[bin_of(d.disc_directions[k])] += d.disc_weights[k] * luminance(d.energy);
        }
        for (std::size_t k = 0; k < oracle.directions.size(); ++k) {
          oracle_bins[bin_of(oracle.directions[k])] += oracle.weights[k] * luminance(oracle.energy);
        }
        std::string bins = sky_file.stem().string() + ": sun energy by distance from the oracle's centroid (up to °: detected / oracle):";
        for (std::size_t b = 0; b < edges.size(); ++b) {
          char cell[96];
          std::snprintf(cell, sizeof cell, " %.2f: %.4f / %.4f;", edges[b], detected_bins[b], oracle_bins[b]);
          bins += cell;
        }
        sun_notes.push_back(bins);
      }

      std::vector<double> diffs, building_plane_diffs;
      std::vector<skylit::geom::Plane> bake_planes;  // the bake's planes, its T and D_j
      for (const auto& record : manifest.planes) bake_planes.push_back(record.plane);
      std::vector<std::vector<float>> plane_T;
      std::vector<Eigen::Vector3d> plane_D;
      std::vector<std::vector<float>> cpu_ratios;  // T of each plane, for the GPU path's comparison
      std::vector<std::vector<std::vector<float>>> ray_visibility;  // [plane][source]: the CPU path's V
      nlohmann::json per_plane;
      // Per K: |T_pca − T_full| and |T_pca − T_ref| over every texel and channel.
      std::map<int, std::vector<double>> pca_vs_full, pca_vs_reference;
      for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
        const skylit::blend::BasisImages basis = skylit::blend::load_basis(bake_dir, manifest, static_cast<int>(j));
        std::vector<float> visibility;
        if (sun) {
          visibility.resize(basis.texel_count());
          skylit::baker::area_light_visibility(mesh, manifest.planes[j].plane, disc_directions, disc_weights,
                                               visibility);
        }
        const auto w = skylit::blend::blend_weights(basis, S, sun);
        Eigen::Vector3d denominator = w.denominator;  // D_j: what the compositor multiplies T by on the building
        std::vector<float> T(basis.texel_count() * 3);
        skylit::blend::blend_cpu(basis, w, w.sun.isZero() ? std::span<const float>() : std::span<const float>(visibility), T);
        std::vector<skylit::blend::SunLight> lights;
        std::vector<std::vector<float>> source_visibility(sources.size());
        std::vector<std::span<const float>> views;
        if (!sources.empty()) {
          // The CPU blend with every source: T = (Σ S B + Σ_k E_k c_k V_k) / (Σ S A + Σ_k E_k c_k).
          const Vec3 normal = manifest.planes[j].plane.normal();
          for (std::size_t k = 0; k < sources.size(); ++k) {
            lights.push_back({sources[k].direction, sources[k].energy});
            if (normal.dot(sources[k].direction) < -1e-6) continue;  // faces away: zero weight, no V needed
            source_visibility[k].resize(basis.texel_count());
            skylit::baker::area_light_visibility(mesh, manifest.planes[j].plane, sources[k].disc_directions,
                                                 sources[k].disc_weights, source_visibility[k]);
          }
          for (const auto& v : source_visibility) views.emplace_back(v);
          const auto ws = skylit::blend::blend_weights_sources(basis, S, lights);
          denominator = ws.denominator;
          skylit::blend::blend_cpu_sources(basis, ws, views, T);
        }
        {
          for (const int k : pca_components) {
            const skylit::blend::BasisImages pca =
                skylit::blend::load_basis(pca_bakes.at({key_of(c), k}), skylit::bake_format::read_manifest(pca_bakes.at({key_of(c), k})),
                                           static_cast<int>(j), skylit::blend::BasisForm::Pca);
            std::vector<float> T_pca(T.size());
            if (sources.empty()) {
              const auto pw = skylit::blend::blend_weights(pca, S, sun);
              skylit::blend::blend_cpu(pca, pw, pw.sun.isZero(0) ? std::span<const float>() : std::span<const float>(visibility),
                                        T_pca);
            } else {
              skylit::blend::blend_cpu_sources(pca, skylit::blend::blend_weights_sources(pca, S, lights), views, T_pca);
            }
            for (std::size_t x = 0; x < basis.texel_count(); ++x) {
              for (int ch = 0; ch < 3; ++ch) {
                const std::size_t at = x * 3 + static_cast<std::size_t>(ch);
                pca_vs_full[k].push_back(std::abs(static_cast<double>(T_pca[at]) - T[at]));
                pca_vs_reference[k].push_back(std::abs(T_pca[at] - reference[j][x][ch]));
              }
            }
          }
        }
        plane_T.push_back(T);
        plane_D.push_back(denominator);
        if (gpu_path_too) {
          cpu_ratios.push_back(T);
          ray_visibility.push_back(sources.empty() ? std::vector<std::vector<float>>{visibility} : source_visibility);
        }
        std::vector<double> plane_diffs;
        for (std::size_t x = 0; x < basis.texel_count(); ++x) {
          for (int ch = 0; ch < 3; ++ch) {
            plane_diffs.push_back(std::abs(T[x * 3 + static_cast<std::size_t>(ch)] - reference[j][x][ch]));
          }
        }
        diffs.insert(diffs.end(), plane_diffs.begin(), plane_diffs.end());
        // A virtual plane covers the building: its texels get E = T D_j (the compositor), against
        // E_ref = T_ref Σ L Ω max(0, n·ω), as a share of E_h like the vertices.
        const auto site_plane = std::find_if(site.planes.begin(), site.planes.end(),
                                             [&](const skylit::geom::Plane& p) { return p.name == basis.name; });
        if (site_plane != site.planes.end() &&
            site.surface_of(static_cast<std::size_t>(site_plane - site.planes.begin())) == skylit::scene::PlaneSurface::Virtual) {
          for (std::size_t x = 0; x < basis.texel_count(); ++x) {
            for (int ch = 0; ch < 3; ++ch) {
              if (horizontal[ch] <= 0) continue;
              const double e = T[x * 3 + static_cast<std::size_t>(ch)] * denominator[ch];
              const double e_ref = reference[j][x][ch] * dense.totals[j][ch];
              building_plane_diffs.push_back(std::abs(e - e_ref) / horizontal[ch]);
            }
          }
        }
        if (dump) {
          // Picture per plane: T, the reference, and max over channels of |T − T_ref| × 5 (green), side by side.
          const int width = basis.width, h = basis.height;
          cv::Mat picture(h, 3 * width + 8, CV_8UC3, cv::Scalar(40, 40, 40));
          for (int row = 0; row < h; ++row) {
            for (int col = 0; col < width; ++col) {
              const std::size_t x = static_cast<std::size_t>(row) * width + col;
              for (int ch = 0; ch < 3; ++ch) {
                const double value = T[x * 3 + static_cast<std::size_t>(ch)], r = reference[j][x][ch];
                picture.at<cv::Vec3b>(row, col)[2 - ch] = cv::saturate_cast<uchar>(255 * value);
                picture.at<cv::Vec3b>(row, width + 4 + col)[2 - ch] = cv::saturate_cast<uchar>(255 * r);
              }
              double d = 0;
              for (int ch = 0; ch < 3; ++ch) d = std::max(d, std::abs(T[x * 3 + static_cast<std::size_t>(ch)] - reference[j][x][ch]));
              picture.at<cv::Vec3b>(row, 2 * width + 8 + col) = cv::Vec3b(0, cv::saturate_cast<uchar>(5 * 255 * d), 0);
            }
          }
          cv::Mat big;
          cv::resize(picture, big, {}, 4, 4, cv::INTER_NEAREST);
          cv::imwrite((fs::path(out_dir) / (sky_file.stem().string() + "_" + c.name + "_" + basis.name + ".png")).string(), big);
        }
        const Errors pe = errors_of(std::move(plane_diffs));
        per_plane[basis.name] = {{"rms", pe.rms}, {"p99", pe.p99}, {"max", pe.max}};
      }
      const Errors e = errors_of(std::move(diffs));
      nlohmann::json gpu_json;
      if (gpu_path_too && (c.mix == Config::Mix::None || c.mix == Config::Mix::Sources) && !use_oracle) {
        // The live GPU path: the sun's disc at least the real sun's, the lamps as found.
        std::vector<skylit::blend::SunLight> lights;
        std::vector<double> radii;
        // As the live service draws them: the sun's disc at least the real sun's, each lamp's
        // shadow radius (--gpu-radius core: its core radius, the diagnosis).
        for (std::size_t k = 0; k < sources.size(); ++k) {
          lights.push_back({sources[k].direction, sources[k].energy});
          if (k == 0 && first_is_sun) {
            radii.push_back(std::max(sources[k].angular_radius, 0.0047));
          } else {
            radii.push_back(gpu_radius == "shadow" && sources[k].shadow_radius > 0 ? sources[k].shadow_radius
                                                                                    : sources[k].angular_radius);
          }
        }
        if (sources.empty() && estimate.sun) {
          lights.push_back(*sun);
          radii.push_back(std::max(estimate.sun->angular_radius, 0.0047));
        }
        const GpuPathResult g = gpu_path(bake_dir, manifest, mesh, transfer, S, lights, radii, gpu_maps, {}, ground, &inside_points);
        std::vector<double> gpu_diffs;
        double vs_cpu = 0;
        for (std::size_t j = 0; j < g.ratios.size(); ++j) {
          for (std::size_t x = 0; x < g.ratios[j].size() / 3; ++x) {
            for (int ch = 0; ch < 3; ++ch) {
              const std::size_t at = x * 3 + static_cast<std::size_t>(ch);
              gpu_diffs.push_back(std::abs(g.ratios[j][at] - reference[j][x][ch]));
              vs_cpu = std::max(vs_cpu, static_cast<double>(std::abs(g.ratios[j][at] - cpu_ratios[j][at])));
            }
          }
        }
        const Errors ge = errors_of(std::move(gpu_diffs));
        // Each source's V from its map against the ray-cast light the CPU path uses (the detector's
        // pixels) and against a uniform disc of the same radius (what the map models).
        std::vector<std::vector<std::vector<float>>> uniform_visibility(g.visibility.size(),
                                                                        std::vector<std::vector<float>>(lights.size()));
        for (std::size_t k = 0; k < lights.size(); ++k) {
          double to_pixels = 0, to_disc = 0, disc_to_pixels = 0;
          std::size_t count = 0;
          const Vec3& w = lights[k].direction;
          const Vec3 a = (std::abs(w.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX()).cross(w).normalized();
          const Vec3 b = w.cross(a);
          std::vector<Vec3> disc;
          for (int q = 0; q < 256; ++q) {
            const double r = radii[k] * std::sqrt((q + 0.5) / 256), phi = q * std::numbers::pi * (3.0 - std::sqrt(5.0));
            disc.push_back((w + std::tan(r) * (std::cos(phi) * a + std::sin(phi) * b)).normalized());
          }
          const std::vector<double> disc_weights_uniform(disc.size(), 1.0 / static_cast<double>(disc.size()));
          for (std::size_t j = 0; j < g.visibility.size(); ++j) {
            const std::vector<float>& ray = ray_visibility[j][k];
            if (ray.empty()) continue;
            std::vector<float> uniform(ray.size());
            skylit::baker::area_light_visibility(mesh, manifest.planes[j].plane, disc, disc_weights_uniform, uniform);
            for (std::size_t x = 0; x < ray.size(); ++x) {
              to_pixels += std::abs(static_cast<double>(g.visibility[j][k][x]) - ray[x]);
              to_disc += std::abs(static_cast<double>(g.visibility[j][k][x]) - uniform[x]);
              disc_to_pixels += std::abs(static_cast<double>(uniform[x]) - ray[x]);
              ++count;
            }
            uniform_visibility[j][k] = std::move(uniform);
          }
          const double n = std::max<double>(static_cast<double>(count), 1.0);
          // At the model's vertices that face the source: the map's V against the ray-cast light.
          std::vector<float> vertex_ray(mesh.vertex_count());
          if (sources.empty()) {
            skylit::baker::area_light_vertex_visibility(mesh, site.planes, disc_directions, disc_weights, vertex_ray);
          } else {
            skylit::baker::area_light_vertex_visibility(mesh, site.planes, sources[k].disc_directions, sources[k].disc_weights, vertex_ray);
          }
          double vertex_sum = 0, vertex_signed = 0;
          std::size_t facing = 0;
          for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
            if (mesh.normals[v].cast<double>().dot(w) <= 0) continue;
            vertex_sum += std::abs(static_cast<double>(g.vertex_visibility[k][v]) - vertex_ray[v]);
            vertex_signed += static_cast<double>(g.vertex_visibility[k][v]) - vertex_ray[v];
            ++facing;
          }
          std::fprintf(stderr, "%s %s source %zu: vertices facing it: mean |V_map − V_ray| %.4f, mean V_map − V_ray %.4f over %zu\n",
                       sky_file.stem().c_str(), c.name.c_str(), k, vertex_sum / std::max<double>(static_cast<double>(facing), 1.0),
                       vertex_signed / std::max<double>(static_cast<double>(facing), 1.0), facing);
          std::fprintf(stderr, "%s %s source %zu: elevation %.1f°, radius %.2f°, E %.4g: mean |V_map − V_pixels| %.4f, "
                       "|V_map − V_disc| %.4f, |V_disc − V_pixels| %.4f over %zu texels\n",
                       sky_file.stem().c_str(), c.name.c_str(), k, std::asin(std::clamp(w.z(), -1.0, 1.0)) * 180 / std::numbers::pi,
                       radii[k] * 180 / std::numbers::pi, luminance(lights[k].energy), to_pixels / n, to_disc / n,
                       disc_to_pixels / n, count);
        }
        // The CPU blend with each source as the uniform disc the maps model, ray-cast: what the disc
        // model alone costs, the maps' approximation left out.
        std::vector<double> disc_diffs;
        for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
          const skylit::blend::BasisImages basis = skylit::blend::load_basis(bake_dir, manifest, static_cast<int>(j));
          const std::vector<std::span<const float>> views(uniform_visibility[j].begin(), uniform_visibility[j].end());
          std::vector<float> T_disc(basis.texel_count() * 3);
          skylit::blend::blend_cpu_sources(basis, skylit::blend::blend_weights_sources(basis, S, lights), views, T_disc);
          for (std::size_t x = 0; x < basis.texel_count(); ++x) {
            for (int ch = 0; ch < 3; ++ch) disc_diffs.push_back(std::abs(T_disc[x * 3 + static_cast<std::size_t>(ch)] - reference[j][x][ch]));
          }
        }
        const Errors disc_model = errors_of(std::move(disc_diffs));
        const Errors gb = building_errors(g.building, building_ref, horizontal);
        // Inside the triangles as the compositor shows it: the sun per point from its map, the
        // virtual planes' T from the GPU blend.
        InsideTerms gpu_split = gpu_terms_inside(inside_points, transfer, S, lights, first_is_sun || sources.empty(), mesh, g, ground);
        if (texel_map) use_light_map(inside_points, texel_map->layout, texel_map->transfer, S, texel_ground, vertex_sky.sky, gpu_split, texel_values);
        const std::vector<Eigen::Vector3d> gpu_all = shown_inside(inside_points, gpu_split, virtual_shading(site, bake_planes, g.ratios, plane_D));
        std::vector<Eigen::Vector3d> gpu_shown, gpu_ref;
        for (const std::size_t k : inside_seen) gpu_shown.push_back(gpu_all[k]), gpu_ref.push_back(inside_ref[k]);
        const Errors gi = building_errors(gpu_shown, gpu_ref, horizontal, inside_areas);
        gpu_rows.push_back({sky_file.stem().string(), c.name, lights.size(), e, disc_model, ge, gb, gi, vs_cpu, g.shadow_ms, g.blend_ms});
        gpu_json = {{"sources", lights.size()}, {"rms", ge.rms}, {"p99", ge.p99}, {"max", ge.max}, {"vs_cpu_max", vs_cpu},
                    {"disc_model", {{"rms", disc_model.rms}, {"p99", disc_model.p99}, {"max", disc_model.max}}},
                    {"building", {{"rms", gb.rms}, {"p99", gb.p99}, {"max", gb.max}}},
                    {"building_inside_triangles_by_area", {{"rms", gi.rms}, {"p99", gi.p99}}},
                    {"shadow_ms", g.shadow_ms}, {"blend_ms", g.blend_ms}};
      }
      const Errors building_planes = errors_of(std::move(building_plane_diffs));
      building_rows.back().planes = building_planes;
      {
        const std::vector<Eigen::Vector3d> inside_all = shown_inside(inside_points, split, virtual_shading(site, bake_planes, plane_T, plane_D));
        std::vector<Eigen::Vector3d> shown, seen_ref;
        for (const std::size_t k : inside_seen) {
          shown.push_back(inside_all[k]);
          seen_ref.push_back(inside_ref[k]);
        }
        inside = building_errors(shown, seen_ref, horizontal);
        inside_by_area = building_errors(shown, seen_ref, horizontal, inside_areas);
        // Negative coefficients (corners, quadratics: a fit's undershoot beside a bright spot) as
        // the blend keeps them and as the compositor's building counted them before
        // (render::BuildingIrradiance: as 0): their share of the horizontal irradiance, and the
        // building as shown with them taken as 0.
        {
          std::vector<Eigen::Vector3d> zeroed(S.begin(), S.end());
          Eigen::Vector3d negative = Eigen::Vector3d::Zero();
          int channels = 0;
          for (std::size_t i = 0; i < zeroed.size(); ++i) {
            for (int ch = 0; ch < 3; ++ch) {
              if (zeroed[i][ch] >= 0.0) continue;
              ++channels;
              if (manifest.ground) negative[ch] += zeroed[i][ch] * manifest.ground->horizontal_unoccluded[i];
              zeroed[i][ch] = 0.0;
            }
          }
          if (channels > 0) {
            skylit::blend::GroundLight zeroed_ground = ground;
            if (!ground.transfer.empty()) {
              std::vector<skylit::blend::SunLight> lights;
              for (const SourceLight& source : building_sources) lights.push_back({source.direction, source.energy});
              const skylit::blend::GroundLayers layers(manifest.plan.frequency, manifest.plan.basis, manifest.ground->horizontal_unoccluded);
              zeroed_ground.coefficients = layers.coefficients(zeroed, lights);
            }
            InsideTerms zeroed_split = building_terms_inside(inside_points, transfer, zeroed, building_sources, estimate.sun.has_value(),
                                                             site, mesh, zeroed_ground);
            if (texel_map) {
              skylit::blend::GroundLight zeroed_texel_ground = zeroed_ground;
              zeroed_texel_ground.transfer = texel_ground.transfer;
              const InsideTerms zeroed_vertex_sky = building_terms_inside(inside_points, transfer, zeroed, {}, false, site, mesh);
              use_light_map(inside_points, texel_map->layout, texel_map->transfer, zeroed, zeroed_texel_ground, zeroed_vertex_sky.sky,
                            zeroed_split, texel_values);
            }
            const std::vector<Eigen::Vector3d> zeroed_all =
                shown_inside(inside_points, zeroed_split, virtual_shading(site, bake_planes, plane_T, plane_D));
            std::vector<Eigen::Vector3d> zeroed_shown;
            for (const std::size_t k : inside_seen) zeroed_shown.push_back(zeroed_all[k]);
            const Errors zeroed_errors = building_errors(zeroed_shown, seen_ref, horizontal, inside_areas);
            std::fprintf(stderr,
                         "%s %s: %d negative S channels of %zu, their horizontal irradiance %.4f of E_h; the building inside its "
                         "triangles with them as 0: RMS %.4f, p99 %.4f by area (%.4f, %.4f as they are)\n",
                         sky_file.stem().c_str(), c.name.c_str(), channels, 3 * S.size(), luminance(negative) / luminance(horizontal),
                         zeroed_errors.rms, zeroed_errors.p99, inside_by_area.rms, inside_by_area.p99);
          } else {
            std::fprintf(stderr, "%s %s: no negative S channel\n", sky_file.stem().c_str(), c.name.c_str());
          }
        }
        if (texel_map) {
          // Where the error lies: the triangles the light map covers, and the rest (their vertices).
          std::array<std::vector<Eigen::Vector3d>, 2> part_shown, part_ref;
          std::array<std::vector<double>, 2> part_areas;
          for (std::size_t i = 0; i < inside_seen.size(); ++i) {
            const std::size_t part = texel_map->layout.triangle_chart[inside_points.triangles[inside_seen[i]]] >= 0 ? 0 : 1;
            part_shown[part].push_back(shown[i]);
            part_ref[part].push_back(seen_ref[i]);
            part_areas[part].push_back(inside_areas[i]);
          }
          double total_area = 0;
          for (const double a : inside_areas) total_area += a;
          for (std::size_t part = 0; part < 2; ++part) {
            if (part_shown[part].empty()) continue;
            const Errors part_errors = building_errors(part_shown[part], part_ref[part], horizontal, part_areas[part]);
            double area = 0;
            for (const double a : part_areas[part]) area += a;
            std::fprintf(stderr, "%s %s: inside the triangles %s: RMS %.4f, p99 %.4f by area over %.1f m² (%.1f%% of the area)\n",
                         sky_file.stem().c_str(), c.name.c_str(), part == 0 ? "the light map covers" : "it does not cover", part_errors.rms,
                         part_errors.p99, area, 100.0 * area / std::max(total_area, 1e-12));
          }
        }
        terms[3] = inside_by_area;
        building_rows.back().inside = inside;
        building_rows.back().inside_by_area = inside_by_area;
        building_rows.back().terms = terms;
      }
      const std::string found = !c.sun                                         ? "-"
                                : c.mix == Config::Mix::Sources                ? std::to_string(sources.size()) + " sources"
                                : use_oracle                                   ? "oracle"
                                : estimate.sun                                 ? "yes"
                                                                               : "no";
      const std::string basis_name(skylit::geom::basis_name(c.basis));
      std::printf("| %s | %s | %d | %d | %s | %s | %.4f | %.4f | %.4f | %s |\n", sky_file.stem().c_str(),
                  c.name.c_str(), c.frequency, c.samples, basis_name.c_str(), c.sun ? "separated" : "off", e.rms, e.p99,
                  e.max,
                  found.c_str());
      std::fflush(stdout);
      for (const int k : pca_components) {
        if (!pca_vs_full.count(k)) continue;
        const Errors full = errors_of(pca_vs_full[k]);
        const Errors ref = errors_of(pca_vs_reference[k]);
        char row[256];
        std::snprintf(row, sizeof row, "| %s | %s | %d of %zu | %.4f / %.4f / %.4f | %.4f / %.4f / %.4f | %.4f |",
                      sky_file.stem().c_str(), c.name.c_str(), k, manifest.layer_count(), full.rms, full.p99, full.max,
                      ref.rms, ref.p99, ref.max, e.rms);
        pca_rows.push_back(row);
        pca_results.push_back({{"sky", sky_file.stem().string()}, {"config", c.name}, {"components", k},
                               {"layers", manifest.layer_count()},
                               {"vs_full", {{"rms", full.rms}, {"p99", full.p99}, {"max", full.max}}},
                               {"vs_reference", {{"rms", ref.rms}, {"p99", ref.p99}, {"max", ref.max}}}});
      }
      results.push_back({{"sky", sky_file.stem().string()}, {"config", c.name}, {"frequency", c.frequency},
                         {"samples", c.samples}, {"basis", basis_name}, {"sun_separation", c.sun},
                         {"sun_found", estimate.sun.has_value()},
                         {"corners_from_mean", estimate.luminance.corners_from_mean},
                         {"sun_reason", estimate.sun_reason}, {"rms", e.rms}, {"p99", e.p99}, {"max", e.max},
                         {"planes", per_plane}, {"reference_seconds", reference_seconds},
                         {"building_planes", {{"rms", building_planes.rms}, {"p99", building_planes.p99}, {"max", building_planes.max}}},
                         {"building_inside_triangles", {{"rms", inside.rms}, {"p99", inside.p99}, {"max", inside.max},
                                                        {"points", inside_points.positions.size()},
                                                        {"by_area", {{"rms", inside_by_area.rms}, {"p99", inside_by_area.p99}, {"max", inside_by_area.max}}},
                                                        {"seen", inside_seen.size()}}},
                         {"building", {{"rms", building.rms}, {"p99", building.p99}, {"max", building.max},
                                       {"of", "the horizontal irradiance"}, {"vertices", mesh.vertex_count()},
                                       {"reference_seconds", building_reference_seconds}}},
                         {"building_ground", no_ground ? nlohmann::json{{"albedo", ground_albedo},
                                                                        {"without_layer_rms", no_ground->rms},
                                                                        {"without_layer_p99", no_ground->p99},
                                                                        {"uniform_ground_reference_rms", uniform_ground->rms}}
                                                       : nlohmann::json()},
                         {"gpu_path", gpu_json},
                         {"bake_seconds", bake_seconds.at(key_of(c))}});
    }
  }
  std::printf("\nThe building: |E − E_ref| per vertex and channel, as a share of the sky's horizontal irradiance\n\n"
              "| sky | configuration | vertices | vertices: RMS | p99 | max | inside the triangles: RMS / p99 / max | by area: RMS / p99 | virtual planes' texels: RMS / p99 / max | the vertices' max at |\n"
              "|---|---|---|---|---|---|---|---|---|---|\n");
  for (const BuildingRow& row : building_rows) {
    std::printf("| %s | %s | %zu | %.4f | %.4f | %.4f | %.4f / %.4f / %.4f | %.4f / %.4f | %.4f / %.4f / %.4f | %s |\n", row.sky.c_str(), row.config.c_str(),
                mesh.vertex_count(), row.errors.rms, row.errors.p99, row.errors.max, row.inside.rms, row.inside.p99, row.inside.max,
                row.inside_by_area.rms, row.inside_by_area.p99, row.planes.rms,
                row.planes.p99, row.planes.max, row.worst.c_str());
  }
  if (ground_albedo > 0.0) {
    std::printf("\nThe ground's light (albedo %.2f, the reference's ground shadowed by the model): the building's "
                "RMS / p99 with the ground layer, without it, and the reference's ground lit uniformly (E_h) against "
                "the shadowed one\n\n| sky | configuration | with the layer | without | uniform ground |\n|---|---|---|---|---|\n",
                ground_albedo);
    for (const BuildingRow& row : building_rows) {
      std::printf("| %s | %s | %.4f / %.4f | %.4f / %.4f | %.4f / %.4f |\n", row.sky.c_str(), row.config.c_str(), row.errors.rms,
                  row.errors.p99, row.no_ground->rms, row.no_ground->p99, row.uniform_ground->rms, row.uniform_ground->p99);
    }
  }
  std::printf("\nThe building inside the triangles, by area, RMS / p99: where its error comes from. The sky's layers "
              "interpolated from the vertices against the same layers traced at the points (the interpolation); the "
              "building with its sky traced at the points against the reference (the dome and the sources: what no "
              "vertex value can mend); the ground's layer against the reference's ground; the building as shown\n\n"
              "| sky | configuration | sky: interpolation | sky at the points: the rest | ground | as shown |\n|---|---|---|---|---|---|\n");
  for (const BuildingRow& row : building_rows) {
    const auto& t = row.terms;
    std::printf("| %s | %s | %.4f / %.4f | %.4f / %.4f | %.4f / %.4f | %.4f / %.4f |\n", row.sky.c_str(), row.config.c_str(), t[0].rms,
                t[0].p99, t[1].rms, t[1].p99, t[2].rms, t[2].p99, t[3].rms, t[3].p99);
  }
  if (!gpu_rows.empty()) {
    std::printf("\nThe live GPU path (every source's shadow map, the GPU blend, half-float T) against the CPU path's "
                "ray-cast visibility; the building at its vertices through the maps' vertex visibility, and inside the triangles "
                "as the compositor shows it (the sun per point from its map; llvmpipe times)\n\n"
                "| sky | configuration | sources | CPU path: RMS / p99 / max | CPU, uniform discs ray-cast: RMS / p99 / max | "
                "GPU path: RMS / p99 / max | max |T_gpu − T_cpu| | building (GPU), vertices: RMS / p99 / max | "
                "inside the triangles, by area: RMS / p99 | maps, ms | blend, ms |\n"
                "|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const GpuRow& r : gpu_rows) {
      std::printf("| %s | %s | %zu | %.4f / %.4f / %.4f | %.4f / %.4f / %.4f | %.4f / %.4f / %.4f | %.4f | %.4f / %.4f / %.4f | "
                  "%.4f / %.4f | %.1f | %.1f |\n",
                  r.sky.c_str(), r.config.c_str(), r.sources, r.cpu.rms, r.cpu.p99, r.cpu.max, r.disc.rms, r.disc.p99, r.disc.max,
                  r.gpu.rms, r.gpu.p99, r.gpu.max, r.gpu_vs_cpu, r.building.rms, r.building.p99, r.building.max,
                  r.inside_by_area.rms, r.inside_by_area.p99, r.shadow_ms, r.blend_ms);
    }
  }
  if (!pca_rows.empty()) {
    std::printf("\n| sky | configuration | K | vs full: RMS / p99 / max | vs reference: RMS / p99 / max | full vs reference RMS |\n"
                "|---|---|---|---|---|---|\n");
    for (const std::string& row : pca_rows) std::printf("%s\n", row.c_str());
  }
  skylit::write_file_atomic(fs::path(out_dir) / "accuracy.json",
                            nlohmann::json{{"configs", results}, {"pca", pca_results}}.dump(2) + "\n");
  if (!sun_notes.empty()) std::printf("\n");
  for (const std::string& note : sun_notes) std::printf("%s\n", note.c_str());
  std::printf("\ntexels: planes of %s at 1/%d resolution; skies rendered into %s (%d² sub-pixels)\n", site_file.c_str(),
              texel_scale, calib_file.c_str(), supersample);
  return 0;
}
