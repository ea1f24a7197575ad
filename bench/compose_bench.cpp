// The compositor per frame: the sample gate (bake made once, ray-traced) under a clear sky with a
// sun and its shadow map, composited into HMD frames of three sizes as a visitor sees it.
// draw(): the frame on the GPU, glFinish included (what a display waits for); composite(): the
// same plus the read-back (what a recording or a test pays); stages: the frame split by stage
// (CompositorOptions::time_stages) with wall and process CPU time, at two render scales, with and
// without the sun's shadow map. Also the sun shadow map's update (when the sun has moved). On
// llvmpipe these are CPU figures: process CPU time is the work done, wall time depends on what
// else runs on the machine. SKYLIT_COMPOSE_BENCH_DOME=FREQUENCY,BASIS,SAMPLES (e.g. 4,corners,16:
// the balanced preset's bake) bakes that dome instead of the sample site's own (ν=2 faces); the
// number of layers sets the cost of the building's per-vertex sky irradiance. Separated sources
// (sky.max_sources): the shadow maps of N sources, the GPU blend of every plane with N terms, and
// a frame whose building takes N − 1 lamps per vertex, each against N = 1.
// SKYLIT_COMPOSE_BENCH_SITE=FILE bakes that site instead of the sample site (e.g. one with the
// planes of skylit-bake walls: what more virtual planes cost the building's pass).
// SKYLIT_COMPOSE_BENCH_LIGHT_MAP=TEXEL[,MIN_AREA[,MIN_ACROSS[,COMPONENTS]]] bakes a light map too (skylit-bake
// --light-map; with COMPONENTS its PCA form, which the compositor then reads)
// and every compositor draws with it: its sum per new sky, and its lookups in the building's pass.
// SKYLIT_COMPOSE_BENCH_BAKE=DIR reads that finished bake of the site instead of baking one.
#include <algorithm>
#include <array>
#include <cstdio>
#include <ctime>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <numbers>
#include <string>
#include <unistd.h>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/light_map.hpp"
#include "skylit/bake_format/model.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/basis.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/render/hmd_distortion.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/camera/calibration.hpp"
#include "skylit/study/study.hpp"

namespace {

namespace fs = std::filesystem;
using namespace skylit;

struct Scene {
  fs::path dir;
  gpu::HeadlessContext context;
  scene::Site site;
  scene::Mesh mesh;
  bake_format::Manifest manifest;
  bool keep_dir = false;                         // SKYLIT_COMPOSE_BENCH_BAKE: not this bench's to remove
  std::vector<float> transfer, ground_transfer;
  bake_format::LightMapArrays light_map;         // SKYLIT_COMPOSE_BENCH_LIGHT_MAP; no texels: none
  std::vector<Eigen::Vector3d> sky;
  blend::SunLight sun;
  std::vector<gpu::Texture> ratios;
  std::vector<GLuint> ratio_names;
  std::unique_ptr<render::SunShadowMap> shadow_map;

  Scene() {
    dir = fs::temp_directory_path() / ("skylit-compose-bench-" + std::to_string(::getpid()));
    baker::BakeOptions options;
    options.site_file = fs::path(SKYLIT_SOURCE_DIR) / "config/sample_site.yaml";
    // Another site, e.g. one that skylit-bake walls wrote with more virtual planes.
    if (const char* site_file = std::getenv("SKYLIT_COMPOSE_BENCH_SITE"); site_file != nullptr && *site_file != '\0') {
      options.site_file = site_file;
    }
    options.out_dir = dir;
    options.method = "raytrace";
    options.previews = false;
    options.force = true;
    if (const char* dome = std::getenv("SKYLIT_COMPOSE_BENCH_DOME"); dome != nullptr && *dome != '\0') {
      char basis[32] = {};
      int frequency = 0, samples = 0;
      if (std::sscanf(dome, "%d,%31[a-z],%d", &frequency, basis, &samples) != 3 || !geom::parse_basis(basis)) {
        std::fprintf(stderr, "SKYLIT_COMPOSE_BENCH_DOME: expected FREQUENCY,BASIS,SAMPLES, got '%s'\n", dome);
        std::exit(2);
      }
      options.frequency = frequency;
      options.basis = geom::parse_basis(basis);
      options.samples = samples;
    }
    if (const char* refine = std::getenv("SKYLIT_COMPOSE_BENCH_REFINE"); refine != nullptr && *refine != '\0') {
      options.refine.tolerance = std::atof(refine);
    }
    // A light map, TEXEL[,MIN_AREA[,MIN_ACROSS[,COMPONENTS]]] (skylit-bake --light-map, and its PCA
    // form with COMPONENTS > 0): every compositor here draws with it, in its smallest form.
    if (const char* light_map_option = std::getenv("SKYLIT_COMPOSE_BENCH_LIGHT_MAP"); light_map_option != nullptr && *light_map_option != '\0') {
      baker::LightMapOptions l;
      int components = 0;
      if (std::sscanf(light_map_option, "%lf,%lf,%d,%d", &l.texel, &l.min_area, &l.min_across, &components) < 1) {
        std::fprintf(stderr, "SKYLIT_COMPOSE_BENCH_LIGHT_MAP: expected TEXEL[,MIN_AREA[,MIN_ACROSS[,COMPONENTS]]], got '%s'\n", light_map_option);
        std::exit(2);
      }
      options.light_map = l;
      if (components > 0) options.light_map_pca = bake_format::LightMapPcaOptions{components, 0.0, true};
    }
    // A finished bake of that site instead (SKYLIT_COMPOSE_BENCH_BAKE=DIR: one too slow to bake
    // here, e.g. the accurate preset's at 1/8 of its planes' resolution), read and left as it is.
    if (const char* bake_dir = std::getenv("SKYLIT_COMPOSE_BENCH_BAKE"); bake_dir != nullptr && *bake_dir != '\0') {
      dir = bake_dir;
      keep_dir = true;
    } else {
      std::FILE* quiet = std::fopen("/dev/null", "w");
      baker::run_bake(options, quiet);
      std::fclose(quiet);
    }
    manifest = bake_format::read_manifest(dir);
    site = scene::load_site(options.site_file);
    mesh = bake_format::load_baked_model(site, dir, manifest);
    std::vector<std::size_t> shape;
    transfer = bake_format::read_npy(dir / manifest.transfer_file, &shape);
    ground_transfer = bake_format::read_npy(dir / manifest.ground->file, &shape);
    if (manifest.light_map) {
      light_map = bake_format::read_light_map(dir, manifest, bake_format::smallest_light_map_form(manifest));
      std::fprintf(stderr, "compose_bench: a light map of %zu texels (%d×%d atlas) over %zu charts, %s\n", light_map.layout.texels.size(),
                   light_map.layout.width, light_map.layout.height, light_map.layout.charts.size(),
                   light_map.pca ? ("its PCA form of " + std::to_string(light_map.pca->sky.components) + " components").c_str() : "the full form");
    }
    sky.assign(transfer.size() / mesh.vertex_count(), Eigen::Vector3d(0.3, 0.4, 0.6));  // one value per basis layer
    const double az = 140 * std::numbers::pi / 180, el = 35 * std::numbers::pi / 180;
    sun = {Eigen::Vector3d(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)), Eigen::Vector3d::Constant(3.0)};
    std::vector<geom::Plane> planes;
    for (const auto& record : manifest.planes) planes.push_back(record.plane);
    shadow_map = std::make_unique<render::SunShadowMap>(mesh, planes);
    shadow_map->update(sun.direction, 0.0047);
    for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
      const blend::BasisImages basis = blend::load_basis(dir, manifest, static_cast<int>(j));
      const std::vector<float> visibility = shadow_map->read_visibility(static_cast<int>(j));
      std::vector<float> T(basis.texel_count() * 3);
      blend::blend_cpu(basis, blend::blend_weights(basis, sky, sun), visibility, T);
      ratios.push_back(render::upload_shadow_ratio(T, basis.width, basis.height));
      ratio_names.push_back(ratios.back().get());
    }
  }
  ~Scene() {
    std::error_code ignored;
    if (!keep_dir) fs::remove_all(dir, ignored);
  }

  static Scene& get() {
    static Scene scene;
    return scene;
  }
};

// Options with the scene's light map, when it has one.
render::CompositorOptions light_mapped(const Scene& scene) {
  render::CompositorOptions options;
  options.light_map = {scene.light_map.layout, scene.light_map.transfer, {}, scene.light_map.pca};  // the ground added where wanted
  return options;
}

// The sample HMD camera (config/hmd_camera.yaml) scaled to width (same focal length per pixel of
// width), any height.
camera::CameraCalibration camera(int width, int height) {
  return study::scaled_camera(fs::path(SKYLIT_SOURCE_DIR) / "config/hmd_camera.yaml", width, height);
}

// A visitor's view (study::visitor_pose): eye height 1.6 m, 18 m south of the gate's centre,
// looking at its middle (0, 0, 3 m), as the demo's walk (config/demo.yaml) at its midpoint. The
// gate spans the frame; the ground in front of it, lit, and the eaves' shadows on its south face
// are in view.
using study::median;
using study::visitor_pose;

render::CompositeInput frame_input(const Scene& scene, const camera::CameraCalibration& calibration, cv::Mat& image) {
  image = cv::Mat(calibration.image_height, calibration.image_width, CV_8UC3);
  cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(256));
  render::CompositeInput input;
  input.camera = image;
  input.pose = visitor_pose();
  input.sky = scene.sky;
  input.sun = scene.sun;
  input.shadow_ratios = scene.ratio_names;
  input.sun_shadow = scene.shadow_map.get();
  return input;
}

void pinhole_counters(benchmark::State& state, const render::Compositor& compositor) {
  state.counters["pinhole_width"] = compositor.lens_remap().pinhole.width;
  state.counters["pinhole_height"] = compositor.lens_remap().pinhole.height;
  std::array<double, 1> load{};
  if (getloadavg(load.data(), 1) == 1) state.counters["load_1min"] = load[0];
}

// args: width, height, render scale in percent.
void frame(benchmark::State& state, bool read_back) {
  Scene& scene = Scene::get();
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const camera::CameraCalibration calibration = camera(width, height);
  render::CompositorOptions options = light_mapped(scene);
  options.lens.render_scale = static_cast<double>(state.range(2)) / 100.0;
  render::Compositor compositor(scene.site, scene.mesh, scene.manifest, scene.transfer, calibration, options);
  cv::Mat image;
  const render::CompositeInput input = frame_input(scene, calibration, image);
  compositor.composite(input);  // warm-up: first-use allocations in the driver
  for (auto _ : state) {
    if (read_back) {
      benchmark::DoNotOptimize(compositor.composite(input));
    } else {
      compositor.draw(input);
      glFinish();
    }
  }
  pinhole_counters(state, compositor);
  state.counters["Mpixel/s"] =
      benchmark::Counter(static_cast<double>(width) * height * static_cast<double>(state.iterations()) / 1e6,
                         benchmark::Counter::kIsRate);
}

// The frame with read-back split by stage (glFinish after each: CompositorOptions::time_stages);
// counters are the medians over the iterations, in ms. args: width, height, render scale in
// percent, sun shadow map (1) or none (0).
void BM_CompositeStages(benchmark::State& state) {
  Scene& scene = Scene::get();
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const camera::CameraCalibration calibration = camera(width, height);
  render::CompositorOptions options = light_mapped(scene);
  options.lens.render_scale = static_cast<double>(state.range(2)) / 100.0;
  options.time_stages = true;
  render::Compositor compositor(scene.site, scene.mesh, scene.manifest, scene.transfer, calibration, options);
  cv::Mat image;
  render::CompositeInput input = frame_input(scene, calibration, image);
  if (state.range(3) == 0) input.sun_shadow = nullptr;
  compositor.composite(input);
  std::vector<double> stages[4][2];
  std::vector<double> total[2];
  for (auto _ : state) {
    benchmark::DoNotOptimize(compositor.composite(input));
    const render::CompositeTimings& t = compositor.last_timings();
    const std::array<render::CompositeTimings::Stage, 4> each{t.upload, t.building, t.composite, t.read_back};
    double wall = 0, cpu = 0;
    for (std::size_t k = 0; k < each.size(); ++k) {
      stages[k][0].push_back(each[k].wall_ms);
      stages[k][1].push_back(each[k].cpu_ms);
      wall += each[k].wall_ms;
      cpu += each[k].cpu_ms;
    }
    total[0].push_back(wall);
    total[1].push_back(cpu);
  }
  pinhole_counters(state, compositor);
  const std::array<const char*, 4> names{"upload", "building", "composite", "read_back"};
  for (std::size_t k = 0; k < names.size(); ++k) {
    state.counters[std::string(names[k]) + "_ms"] = median(stages[k][0]);
    state.counters[std::string(names[k]) + "_cpu_ms"] = median(stages[k][1]);
  }
  state.counters["frame_ms"] = median(total[0]);
  state.counters["frame_cpu_ms"] = median(total[1]);
}

// A frame that takes a new sky (every frame here; the service takes one a second): the building's
// light (per vertex and per light-map texel) is summed again on the CPU, or (ahead 1) taken
// summed already, as the live service's sky thread sums it for each sky (CompositeInput::
// irradiance: the frame uploads it). args: width, height, render scale in percent, the ground's
// light (render.ground_light: its layer summed too), ahead.
void BM_CompositeDrawNewSky(benchmark::State& state) {
  Scene& scene = Scene::get();
  const camera::CameraCalibration calibration = camera(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  render::CompositorOptions options = light_mapped(scene);
  options.lens.render_scale = static_cast<double>(state.range(2)) / 100.0;
  if (state.range(3) != 0) {
    options.ground_albedo = Eigen::Vector3d::Constant(0.2);
    options.ground_transfer = scene.ground_transfer;
    options.light_map.ground = scene.light_map.ground;
  }
  render::Compositor compositor(scene.site, scene.mesh, scene.manifest, scene.transfer, calibration, options);
  cv::Mat image;
  render::CompositeInput input = frame_input(scene, calibration, image);
  std::vector<Eigen::Vector3d> skies[2] = {scene.sky, scene.sky};
  for (Eigen::Vector3d& value : skies[1]) value *= 1.01;
  std::shared_ptr<const render::SkyIrradiance> sums[2];
  for (int j = 0; j < 2 && state.range(4) != 0; ++j) {
    sums[j] = std::make_shared<const render::SkyIrradiance>(compositor.building_irradiance()->sum(skies[j], input.sun, input.lamps));
  }
  compositor.composite(input);
  int k = 0;
  for (auto _ : state) {
    k ^= 1;
    input.sky = skies[k];
    input.irradiance = sums[k];
    compositor.draw(input);
    glFinish();
  }
  pinhole_counters(state, compositor);
  state.counters["summed_in_frame"] = compositor.last_stats().building_light_summed ? 1 : 0;
}

// The building's light for one sky alone (BuildingIrradiance::sum: per vertex and per light-map
// texel, on every core), as the live service's sky thread sums it. args: the ground's light, the
// light map held in half floats (render.light_map_precision: half).
void BM_BuildingLightSum(benchmark::State& state) {
  Scene& scene = Scene::get();
  const camera::CameraCalibration calibration = camera(640, 480);
  render::CompositorOptions options = light_mapped(scene);
  if (state.range(1) != 0) options.light_map_precision = render::LightMapPrecision::Half;
  if (state.range(0) != 0) {
    options.ground_albedo = Eigen::Vector3d::Constant(0.2);
    options.ground_transfer = scene.ground_transfer;
    options.light_map.ground = scene.light_map.ground;
  }
  const render::Compositor compositor(scene.site, scene.mesh, scene.manifest, scene.transfer, calibration, options);
  const std::shared_ptr<const render::BuildingIrradiance> building = compositor.building_irradiance();
  const std::clock_t cpu_start = std::clock();
  for (auto _ : state) {
    const render::SkyIrradiance sums = building->sum(scene.sky, scene.sun, {});
    benchmark::DoNotOptimize(sums.vertices.data());
  }
  state.counters["process_cpu_ms"] = 1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC /
                                     static_cast<double>(state.iterations());
  state.counters["atlas_texels"] = static_cast<double>(building->atlas_width()) * building->atlas_height();
  state.counters["light_map_mib"] = static_cast<double>(building->light_map_bytes()) / (1 << 20);
}

void BM_CompositeDraw(benchmark::State& state) { frame(state, false); }
void BM_CompositeWithReadBack(benchmark::State& state) { frame(state, true); }

BENCHMARK(BM_CompositeDraw)->Args({640, 480, 100})->Args({640, 480, 60})->Args({1280, 720, 100})->Args({1920, 1080, 100})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CompositeDrawNewSky)
    ->ArgNames({"width", "height", "scale", "ground", "ahead"})
    ->Args({640, 480, 60, 0, 0})
    ->Args({640, 480, 60, 1, 0})
    ->Args({640, 480, 60, 0, 1})
    ->Args({640, 480, 60, 1, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_BuildingLightSum)
    ->ArgNames({"ground", "half"})
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_CompositeWithReadBack)->Args({640, 480, 100})->Args({1280, 720, 100})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CompositeStages)
    ->ArgNames({"w", "h", "scale%", "sun_map"})
    ->Args({640, 480, 100, 1})
    ->Args({640, 480, 100, 0})
    ->Args({640, 480, 75, 1})
    ->Args({640, 480, 60, 1})
    ->Args({1280, 720, 100, 1})
    ->Args({1280, 720, 75, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The sun's shadow map redrawn for a sun moved by 0.2°: depth pass, minimum/maximum pyramid and
// the planes' visibility (sample site: 640×384, 512×224 and 256×110 texels), glFinish included.
void BM_SunShadowUpdate(benchmark::State& state) {
  Scene& scene = Scene::get();
  std::vector<geom::Plane> planes;
  for (const auto& record : scene.manifest.planes) planes.push_back(record.plane);
  render::SunShadowMap map(scene.mesh, planes);
  const Eigen::Vector3d nudged = (scene.sun.direction + Eigen::Vector3d(0.0035, 0.0, 0.0)).normalized();
  map.update(scene.sun.direction, 0.0047);
  glFinish();
  bool flip = false;
  for (auto _ : state) {
    map.update(flip ? scene.sun.direction : nudged, 0.0047);
    glFinish();
    flip = !flip;
  }
}

BENCHMARK(BM_SunShadowUpdate)->Unit(benchmark::kMillisecond)->UseRealTime();

// N separated sources (study::bench_sources: the sun and N − 1 lamps of 2°) and their shadow
// maps over the site's planes, drawn once.
struct SourceMaps {
  SourceMaps(const Scene& scene, int count) : sources(study::bench_sources(scene.sun.direction, count, Eigen::Vector3d::Constant(0.2))) {
    std::vector<geom::Plane> planes;
    for (const auto& record : scene.manifest.planes) planes.push_back(record.plane);
    render::SunShadowOptions options;
    options.max_sources = count;
    map = std::make_unique<render::SunShadowMap>(scene.mesh, planes, options);
    map->update(sources.discs);
    lights.push_back(scene.sun);
    lights.insert(lights.end(), sources.lamps.begin(), sources.lamps.end());
    glFinish();
  }
  study::BenchSources sources;
  std::unique_ptr<render::SunShadowMap> map;
  std::vector<blend::SunLight> lights;  // the sun, then the lamps
};

// Every source's shadow map redrawn (depth pass, pyramid, planes' and vertices' V), glFinish
// included. arg: sources.
void BM_SourceShadowUpdate(benchmark::State& state) {
  const SourceMaps maps(Scene::get(), static_cast<int>(state.range(0)));
  for (auto _ : state) {
    maps.map->update(maps.sources.discs);
    glFinish();
  }
}

// The GPU blend of every plane (half storage, packed, half T) with N separated terms, V from the
// maps, glFinish included. arg: sources.
void BM_SourceBlend(benchmark::State& state) {
  Scene& scene = Scene::get();
  const SourceMaps maps(scene, static_cast<int>(state.range(0)));
  std::vector<blend::BasisImages> bases;
  std::vector<std::unique_ptr<blend::GpuBlender>> blenders;
  std::vector<blend::BlendWeights> weights;
  for (std::size_t j = 0; j < scene.manifest.planes.size(); ++j) {
    bases.push_back(blend::load_basis(scene.dir, scene.manifest, static_cast<int>(j)));
    blenders.push_back(std::make_unique<blend::GpuBlender>(bases.back()));
    weights.push_back(blend::blend_weights_sources(bases.back(), scene.sky, maps.lights));
  }
  glFinish();
  for (auto _ : state) {
    for (std::size_t j = 0; j < blenders.size(); ++j) {
      blenders[j]->invalidate();
      blenders[j]->blend(weights[j], &maps.map->visibility(static_cast<int>(j)));
    }
    glFinish();
  }
}

// A 640×480 frame (draw, glFinish) whose building takes N − 1 lamps per vertex besides the sun,
// summed on the CPU every frame. arg: sources.
void BM_CompositeDrawLamps(benchmark::State& state) {
  Scene& scene = Scene::get();
  const camera::CameraCalibration calibration = camera(640, 480);
  render::Compositor compositor(scene.site, scene.mesh, scene.manifest, scene.transfer, calibration);
  cv::Mat image;
  render::CompositeInput input = frame_input(scene, calibration, image);
  const study::BenchSources sources = study::bench_sources(scene.sun.direction, static_cast<int>(state.range(0)),
                                                          Eigen::Vector3d::Constant(0.2));
  const std::vector<blend::SunLight>& lamps = sources.lamps;
  const std::vector<std::vector<float>> visibility(lamps.size(), std::vector<float>(scene.mesh.vertex_count(), 0.8f));
  input.lamps = lamps;
  input.lamp_vertex_visibility = visibility;
  compositor.composite(input);
  for (auto _ : state) {
    compositor.draw(input);
    glFinish();
  }
  state.counters["vertices"] = static_cast<double>(scene.mesh.vertex_count());
}

BENCHMARK(BM_SourceShadowUpdate)->ArgNames({"sources"})->Arg(1)->Arg(2)->Arg(4)->Arg(16)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SourceBlend)->ArgNames({"sources"})->Arg(1)->Arg(2)->Arg(4)->Arg(16)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CompositeDrawLamps)->ArgNames({"sources"})->Arg(1)->Arg(16)->Unit(benchmark::kMillisecond)->UseRealTime();

// An HMD frame on the generic profile (config/hmd/generic.yaml: 2 × 1920×1080, lens distortion
// per channel through a 40×40 mesh per eye) from a 1920×1080 camera, glFinish included.
// arg 0: the distortion pass alone (both eyes, one texture); 1: mono (one composite, shown to both
// eyes); 2: stereo (a composite per eye).
void BM_HmdFrame(benchmark::State& state) {
  Scene& scene = Scene::get();
  const camera::CameraCalibration calibration = camera(1920, 1080);
  render::Compositor compositor(scene.site, scene.mesh, scene.manifest, scene.transfer, calibration);
  render::HmdDistortion hmd(render::load_hmd_profile(fs::path(SKYLIT_SOURCE_DIR) / "config/hmd/generic.yaml"));
  cv::Mat image;
  const render::CompositeInput input = frame_input(scene, calibration, image);
  compositor.composite(input);
  const GLuint eye_image = compositor.display_texture();
  const auto mode = state.range(0) == 2 ? render::StereoMode::stereo : render::StereoMode::mono;
  glFinish();
  const std::clock_t cpu_start = std::clock();  // process CPU time: llvmpipe's threads included
  for (auto _ : state) {
    if (state.range(0) == 0) {
      hmd.draw(std::span<const GLuint>(&eye_image, 1), 1920, 1080);
    } else {
      render::draw_hmd_frame(compositor, hmd, input, mode);
    }
    glFinish();
  }
  state.counters["process_cpu_ms"] = 1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC /
                                     static_cast<double>(state.iterations());
  std::array<double, 1> load{};
  if (getloadavg(load.data(), 1) == 1) state.counters["load_1min"] = load[0];
}

BENCHMARK(BM_HmdFrame)->ArgNames({"distortion_mono_stereo"})->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
