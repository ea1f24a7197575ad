// skylit-bench trade's sweep (study/trade.hpp): bakes, references, per-setting measurements.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "skylit/blend/cpu_blender.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/blend/workers.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/sky/sky_smoothing.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/study/building_light.hpp"
#include "skylit/study/study.hpp"
#include "skylit/study/trade.hpp"
#include "trade_rows.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/model.hpp"

namespace skylit::study {
namespace trade {
namespace {

namespace fs = std::filesystem;
using study::Clock;
using study::median;
using study::seconds_since;


struct SkyData {
  std::string name;
  cv::Mat equirect;
  sky::RadianceFrame frame;
  bool sunny = false;  // a sun in the equirect (study::equirect_sun)
};

// The input files, given or the defaults (relative to the repository root), before any work.
void check_inputs(const TradeOptions& o) {
  const auto need = [](bool present, const char* option, const std::string& path, const char* what) {
    if (!present) {
      throw InputError(std::string("option ") + option + ": '" + path + "' is not " + what +
                       ". Fix: pass " + option + ", or run from the repository root for the default");
    }
  };
  std::error_code ec;
  need(fs::is_regular_file(o.site_file, ec), "--site", o.site_file, "a file");
  need(fs::is_regular_file(o.sky_calib, ec), "--calib", o.sky_calib, "a file");
  need(fs::is_regular_file(o.hmd_calib, ec), "--hmd-camera", o.hmd_calib, "a file");
  need(fs::is_directory(o.skies_dir, ec), "--skies", o.skies_dir, "a folder");
}

// The run as a whole: its options, output folder, sky sequence and start.
struct Run {
  const TradeOptions& o;
  fs::path out;
  study::SequenceOptions sequence;
  Clock::time_point start;
};

// The sky sequence's settings (--sequence), checked before any work.
study::SequenceOptions sequence_options(const TradeOptions& o) {
  study::SequenceOptions sequence;
  sequence.frames = o.sequence_frames;
  try {
    sequence.start = sky::parse_utc(o.sequence_start);
  } catch (const InputError& e) {
    throw InputError("option --sequence-start: " + std::string(e.what()));
  }
  sequence.latitude_deg = o.sequence_lat;
  sequence.longitude_deg = o.sequence_lon;
  sequence.cloud = o.sequence_cloud;
  return sequence;
}

// Skies: the .exr files of --skies (those --sky names, when given), sorted.
std::vector<fs::path> list_skies(const TradeOptions& o) {
  std::vector<fs::path> sky_files;
  for (const auto& entry : fs::directory_iterator(o.skies_dir)) {
    const std::string stem = entry.path().stem().string();
    if (entry.path().extension() != ".exr") continue;
    if (!o.skies.empty() && std::find(o.skies.begin(), o.skies.end(), stem) == o.skies.end()) continue;
    sky_files.push_back(entry.path());
  }
  std::sort(sky_files.begin(), sky_files.end());
  if (sky_files.empty()) throw InputError("no .exr skies in " + o.skies_dir + ". Fix: --skies DIR, --sky NAME,NAME");
  return sky_files;
}

using PcaKey = std::tuple<BakeKey, int, int>;  // bake, K, tile

struct Grid {
  std::vector<Setting> settings;
  std::set<BakeKey> bake_keys;
  std::set<PcaKey> pca_keys;
  std::set<int> scales;  // the bakes' plane resolution divisors
};

// The grid, and the settings it cannot have (corners with fewer than 3 samples; 8-bit PCA).
Grid make_grid(const TradeOptions& o) {
  Grid grid;
  std::vector<Setting>& settings = grid.settings;
  std::set<BakeKey>& bake_keys = grid.bake_keys;
  std::set<PcaKey>& pca_keys = grid.pca_keys;
  for (int f : o.frequencies) {
    for (const std::string& b : o.bases) {
      const auto basis = geom::parse_basis(b);
      if (!basis) throw InputError("option --bases: got '" + b + "'. Fix: faces, corners or quadratics");
      for (int k : o.samples) {
        if (k < baker::min_samples_per_face(*basis)) continue;
        for (int scale : o.texel_scales) {
        for (double refine : o.refines) {
        for (int vertex_fit : o.vertex_fits) {
        for (double light_map : o.light_maps) {
          const BakeKey key{f, *basis, k, scale, refine, vertex_fit, light_map};
          for (const std::string& form_text : o.forms) {
            const Form form = parse_form(form_text);
            for (int bits : o.bits) {
              if (bits != 8 && bits != 16) throw InputError("option --bits: 16 or 8");
              if (bits == 8 && form.form == blend::BasisForm::Pca) continue;
              for (const std::string& sun : o.sun) {
                if (sun != "on" && sun != "off") throw InputError("option --sun: on, off");
                for (int sources : sun == "on" ? o.sources : std::vector<int>{1}) {
                if (sources < 1 || sources > blend::kMaxGpuSources) {
                  throw InputError("option --sources: " + std::to_string(sources) + ". Fix: 1 … " +
                                   std::to_string(blend::kMaxGpuSources));
                }
                for (double skip : o.skip_thresholds) {
                  for (double change : o.change_thresholds) {
                    for (double smoothing : o.smoothings) {
                      for (double render_scale : o.render_scales) {
                        settings.push_back({key, form, bits, sun == "on", sources, skip, change, smoothing, render_scale});
                        bake_keys.insert(key);
                        if (form.form == blend::BasisForm::Pca) pca_keys.insert({key, form.components, form.tile});
                      }
                    }
                  }
                }
                }
              }
            }
          }
        }
        }
        }
        }
      }
    }
  }
  for (const BakeKey& k : bake_keys) grid.scales.insert(k.texel_scale);
  return grid;
}

// The grid's size, and how long it may take.
void print_plan(const Grid& grid, const std::vector<fs::path>& sky_files) {
  const std::set<int>& scales = grid.scales;
  std::printf("skylit-bench trade: %zu settings, %zu bakes (+%zu PCA forms), %zu skies, plane resolution 1/%s\n",
              grid.settings.size(), grid.bake_keys.size(), grid.pca_keys.size(), sky_files.size(),
              [&] {
                std::string t;
                for (int s : scales) t += (t.empty() ? "" : ",") + std::to_string(s);
                return t;
              }()
                  .c_str());
  // A rough estimate from the default sweep (2 cores, loaded): a ray-traced bake at 1/8 resolution
  // with K=16 takes about 1.5 s per 40 layers; the reference about 10 s per sky; each setting and
  // sky about 0.4 s; each setting's timing about 1.5 s.
  double estimate_s = 0;
  for (const BakeKey& k : grid.bake_keys) {
    const double layers = 10.0 * k.frequency * k.frequency * geom::layers_per_face(k.basis);
    estimate_s += 1.5 * layers / 40.0 * k.samples / 16.0 * 64.0 / (k.texel_scale * k.texel_scale);
  }
  for (int s : scales) estimate_s += 10.0 * static_cast<double>(sky_files.size()) * 64.0 / (s * s);
  estimate_s += static_cast<double>(grid.settings.size()) * (0.4 * static_cast<double>(sky_files.size()) + 1.5);
  std::printf("estimate: about %.0f min without cached bakes\n", estimate_s / 60.0);
  std::fflush(stdout);
}

struct SiteData {
  fs::path file;
  scene::Site site;
  scene::Mesh mesh;
  std::vector<geom::Plane> full_planes;  // the site's own resolution
};
using Sites = std::map<int, SiteData>;  // by plane resolution divisor

// Sites at each resolution.
Sites load_sites(const Run& run, const std::set<int>& scales) {
  const TradeOptions& o = run.o;
  const scene::Site full_site = scene::load_site(o.site_file);
  Sites sites;
  for (int s : scales) {
    const fs::path dir = run.out / ("site_s" + std::to_string(s));
    fs::create_directories(dir);
    SiteData d;
    d.file = study::coarse_site(o.site_file, s, dir);
    d.site = scene::load_site(d.file);
    d.mesh = scene::load_site_model(d.site);
    for (const auto& p : full_site.planes) d.full_planes.push_back(p);
    sites.emplace(s, std::move(d));
  }
  return sites;
}

// The bakes' folders, and the seconds each took when made (a PCA form: its compression only).
struct Bakes {
  std::map<BakeKey, fs::path> dirs;
  std::map<BakeKey, double> seconds;
  std::map<BakeKey, scene::Mesh> meshes;  // the model each was baked on (refined or not)
  std::map<PcaKey, fs::path> pca_dirs;
  std::map<PcaKey, double> pca_seconds;
};

// Bakes, cached in OUT/bakes.
void make_bakes(const Run& run, const Grid& grid, const Sites& sites, Bakes& made) {
  const std::set<BakeKey>& bake_keys = grid.bake_keys;
  std::map<BakeKey, fs::path>& bakes = made.dirs;
  std::map<BakeKey, double>& bake_seconds = made.seconds;
  int done = 0;
  for (const BakeKey& key : bake_keys) {
    const fs::path dir = run.out / "bakes" / key.name();
    const fs::path stamp = dir / "trade_bake.json";
    ++done;
    bool cached = false;
    if (fs::exists(stamp)) {
      try {
        (void)bake_format::read_manifest(dir);
        bake_seconds[key] = nlohmann::json::parse(read_file(stamp)).at("seconds").get<double>();
        cached = true;
      } catch (const std::exception&) {
        cached = false;
      }
    }
    if (!cached) {
      std::printf("bake %d/%zu: %s ...\n", done, bake_keys.size(), key.name().c_str());
      std::fflush(stdout);
      baker::BakeOptions options;
      options.site_file = sites.at(key.texel_scale).file;
      options.out_dir = dir;
      options.frequency = key.frequency;
      options.samples = key.samples;
      options.basis = key.basis;
      options.method = "raytrace";
      options.refine.tolerance = key.refine;
      options.vertex_fit = key.vertex_fit;
      if (key.light_map > 0) options.light_map = baker::LightMapOptions{key.light_map, run.o.light_map_min_area, run.o.light_map_min_across};
      if (key.light_map > 0 && run.o.light_map_components > 0) options.light_map_pca = bake_format::LightMapPcaOptions{run.o.light_map_components, 0.0, true};
      options.force = true;
      options.previews = false;
      const auto t = Clock::now();
      baker::run_bake(options, nullptr);
      bake_seconds[key] = seconds_since(t);
      write_file_atomic(stamp, nlohmann::json{{"seconds", bake_seconds[key]}}.dump() + "\n");
      std::printf("bake %d/%zu: %s %.1f s\n", done, bake_keys.size(), key.name().c_str(), bake_seconds[key]);
    } else {
      std::printf("bake %d/%zu: %s cached (%.1f s when made)\n", done, bake_keys.size(), key.name().c_str(), bake_seconds[key]);
    }
    std::fflush(stdout);
    bakes[key] = dir;
    const SiteData& site = sites.at(key.texel_scale);
    made.meshes[key] = key.refine > 0 ? bake_format::load_baked_model(site.site, dir, bake_format::read_manifest(dir)) : site.mesh;
  }
}

// PCA forms: a copy of the bake per K, compressed as skylit-bake compress does it.
void make_pca_forms(const Grid& grid, Bakes& made) {
  const std::map<BakeKey, fs::path>& bakes = made.dirs;
  std::map<PcaKey, fs::path>& pca_bakes = made.pca_dirs;
  std::map<PcaKey, double>& pca_seconds = made.pca_seconds;
  for (const auto& [key, k, tile] : grid.pca_keys) {
    const fs::path copy = bakes.at(key).string() + "_pca" + std::to_string(k) + (tile > 0 ? "t" + std::to_string(tile) : "");
    const fs::path stamp = copy / "trade_pca.json";
    bool cached = false;
    if (fs::exists(stamp)) {
      try {
        (void)bake_format::read_manifest(copy);
        pca_seconds[{key, k, tile}] = nlohmann::json::parse(read_file(stamp)).at("seconds").get<double>();
        cached = true;
      } catch (const std::exception&) {
        cached = false;
      }
    }
    if (!cached) {
      fs::remove_all(copy);
      fs::copy(bakes.at(key), copy, fs::copy_options::recursive);
      fs::remove(copy / "trade_bake.json");
      bake_format::PcaOptions pca;
      pca.components = k;
      pca.tile = tile;
      const auto t = Clock::now();
      baker::compress_bake(copy, pca, std::nullopt, nullptr);
      pca_seconds[{key, k, tile}] = seconds_since(t);
      write_file_atomic(stamp, nlohmann::json{{"seconds", pca_seconds[{key, k, tile}]}}.dump() + "\n");
      std::printf("PCA %s K=%d tile %d: %.1f s\n", key.name().c_str(), k, tile, pca_seconds[{key, k, tile}]);
      std::fflush(stdout);
    }
    pca_bakes[{key, k, tile}] = copy;
  }
}

// Skies: the fisheye frame the live path sees, whether the equirect has a sun.
std::vector<SkyData> render_skies(const TradeOptions& o, const camera::Lens& lens, const std::vector<fs::path>& sky_files) {
  std::vector<SkyData> skies;
  for (const fs::path& file : sky_files) {
    SkyData d;
    d.name = file.stem().string();
    d.equirect = study::read_clean_sky(file);
    d.frame = {sky::render_fisheye(lens, d.equirect, {.supersample = o.supersample}), cv::Mat()};
    d.sunny = study::equirect_sun(d.equirect).found;
    skies.push_back(std::move(d));
  }
  return skies;
}

// The building's reference on one model (the site's, or a refined one), the ground of
// --ground-albedo included: E_ref per vertex and at the points inside its triangles (zero at
// enclosed points, which no ray leaves: they are left out).
struct BuildingReference {
  std::vector<Eigen::Vector3d> vertices;
  study::TrianglePoints points;
  std::vector<Eigen::Vector3d> inside;
};

BuildingReference building_reference(const TradeOptions& o, const study::EquirectLights& lights,
                                     const study::DenseReference& dense, const scene::Site& site, const scene::Mesh& mesh) {
  BuildingReference ref{study::building_reference(lights, site, mesh), study::triangle_points(mesh), {}};
  ref.inside = study::building_reference_at(lights, site, mesh, ref.points);
  if (o.ground_albedo > 0.0) {
    const study::GroundReferenceOptions ground = study::site_ground(site, dense, Eigen::Vector3d::Constant(o.ground_albedo));
    const std::vector<Eigen::Vector3d> at_vertices = study::ground_reference(lights, site, mesh, ground);
    for (std::size_t v = 0; v < at_vertices.size(); ++v) ref.vertices[v] += at_vertices[v];
    const std::vector<Eigen::Vector3d> inside = study::ground_reference_at(lights, site, mesh, ref.points, ground);
    for (std::size_t k = 0; k < inside.size(); ++k) {
      if (!ref.inside[k].isZero(0)) ref.inside[k] += inside[k];
    }
  }
  return ref;
}

// By (plane resolution divisor, sky): T per plane and texel; the building's reference per
// refinement; E_h.
struct Reference {
  std::vector<std::vector<Eigen::Vector3d>> planes;
  std::map<double, BuildingReference> building;  // by BakeKey::refine
  Eigen::Vector3d horizontal;
};
using References = std::map<std::pair<int, std::size_t>, Reference>;

// The dense reference per resolution and sky, the building's on every model the bakes use.
References make_references(const TradeOptions& o, const std::vector<SkyData>& skies, const std::set<int>& scales,
                           const Sites& sites, const Bakes& bakes) {
  References references;
  for (int s : scales) {
    const SiteData& site = sites.at(s);
    std::map<double, const scene::Mesh*> models;
    for (const auto& [key, mesh] : bakes.meshes) {
      if (key.texel_scale == s) models.emplace(key.refine, &mesh);
    }
    for (std::size_t i = 0; i < skies.size(); ++i) {
      const auto t = Clock::now();
      const study::EquirectLights lights = study::equirect_lights(skies[i].equirect, o.reference_supersample);
      study::DenseReference dense = study::dense_reference(lights, site.site, site.mesh);
      Reference& ref = references[{s, i}];
      for (const auto& [refine, mesh] : models) ref.building[refine] = building_reference(o, lights, dense, site.site, *mesh);
      ref.horizontal = study::horizontal_irradiance(lights);
      ref.planes = std::move(dense.planes);
      std::printf("reference 1/%d %s: %.1f s\n", s, skies[i].name.c_str(), seconds_since(t));
      std::fflush(stdout);
    }
  }
  return references;
}

using EstimatorKey = std::tuple<int, geom::DomeBasis, bool, int>;

// The sky estimators per (ν, basis, sun separation, sources), each with its dome (which it keeps
// by reference), made when first asked for.
struct Estimators {
  explicit Estimators(const camera::CameraCalibration& c) : calibration(c) {}
  const sky::SkyEstimator& estimator_for(const Setting& s) {
    auto& estimator = by_key[{s.bake.frequency, s.bake.basis, s.sun, s.sources}];
    if (!estimator) {
      auto& dome = domes[s.bake.frequency];
      if (!dome) dome = std::make_unique<geom::Dome>(s.bake.frequency);
      sky::SkyEstimateOptions sky_options;
      sky_options.sun_mode = s.sun ? sky::SunMode::Auto : sky::SunMode::Off;
      sky_options.table.basis = s.bake.basis;
      sky_options.max_sources = s.sources;
      // The reference is the same capture: its sun is taken as it is, whatever its colour.
      sky_options.correct_sun_colour = false;
      estimator = std::make_unique<sky::SkyEstimator>(calibration, *dome, sky_options);
    }
    return *estimator;
  }

  const camera::CameraCalibration& calibration;
  std::map<int, std::unique_ptr<geom::Dome>> domes;
  std::map<EstimatorKey, std::unique_ptr<sky::SkyEstimator>> by_key;
};

// The sun's visibility over the sequence per (estimator, resolution), as the service keeps it:
// recomputed (a new revision) only when the estimated sun moved by more than 0.1 of its angular
// radius (service.cpp, sun_moved), the disc of that frame's estimate as an area light.
struct SunTrack {
  std::vector<std::uint64_t> revision;                                   // per frame
  std::vector<std::shared_ptr<const std::vector<std::vector<float>>>> visibility;  // per frame: per plane
};

// The sky sequence (--sequence): a clear sky over time with a passing cloud; its reference per
// resolution, per estimator the estimate of every frame, and the sun's tracks (made when first
// asked for).
struct SequenceInputs {
  std::map<int, study::SequenceReference> references;
  std::map<EstimatorKey, std::vector<sky::SkyEstimate>> estimates;
  std::map<std::pair<EstimatorKey, int>, SunTrack> sun_tracks;
};

// The sequence's references, and its estimates (the frames are rendered once).
SequenceInputs prepare_sequence(const Run& run, const camera::Lens& lens, const Grid& grid, const Sites& sites,
                                Estimators& estimators) {
  const TradeOptions& o = run.o;
  const study::SequenceOptions& sequence = run.sequence;
  SequenceInputs inputs;
  std::map<int, study::SequenceReference>& sequence_references = inputs.references;
  std::map<EstimatorKey, std::vector<sky::SkyEstimate>>& sequence_estimates = inputs.estimates;
  const auto t = Clock::now();
  for (int s : grid.scales) {
    sequence_references[s] = study::sequence_reference(sequence, sites.at(s).site, sites.at(s).mesh, o.sequence_equirect);
    std::printf("sequence reference 1/%d: %d frames, %.1f s\n", s, sequence.frames, sequence_references[s].seconds);
    std::fflush(stdout);
  }
  for (const Setting& s : grid.settings) (void)estimators.estimator_for(s);
  for (int k = 0; k < sequence.frames; ++k) {
    const sky::RadianceFrame frame{sky::render_fisheye(lens, study::sequence_sky(sequence, k), {.supersample = o.supersample}),
                                   cv::Mat()};
    for (const auto& [key, estimator] : estimators.by_key) sequence_estimates[key].push_back(estimator->estimate(frame));
  }
  std::printf("sequence: %d skies rendered and estimated (%zu estimators), %.1f s\n", sequence.frames, estimators.by_key.size(),
              seconds_since(t));
  std::fflush(stdout);
  return inputs;
}

const SunTrack& sun_track(SequenceInputs& inputs, const Sites& sites, const Setting& s, const bake_format::Manifest& manifest) {
  const EstimatorKey key{s.bake.frequency, s.bake.basis, s.sun, s.sources};
  SunTrack& track = inputs.sun_tracks[{key, s.bake.texel_scale}];
  if (!track.revision.empty()) return track;
  const scene::Mesh& mesh = sites.at(s.bake.texel_scale).mesh;
  std::uint64_t revision = 0;
  std::optional<Eigen::Vector3d> drawn_for;
  std::shared_ptr<const std::vector<std::vector<float>>> visibility;
  for (const sky::SkyEstimate& e : inputs.estimates.at(key)) {
    if (e.sun && (!drawn_for || drawn_for->dot(e.sun->direction) < std::cos(std::max(1e-4, 0.1 * e.sun->angular_radius)))) {
      auto planes = std::make_shared<std::vector<std::vector<float>>>();
      for (const auto& record : manifest.planes) {
        planes->emplace_back(static_cast<std::size_t>(record.plane.width) * record.plane.height);
        baker::area_light_visibility(mesh, record.plane, e.sun->disc_directions, e.sun->disc_weights, planes->back());
      }
      visibility = std::move(planes);
      drawn_for = e.sun->direction;
      ++revision;
    }
    track.revision.push_back(revision);
    track.visibility.push_back(visibility);
  }
  return track;
}

// One compositor per (bake, sun map, sources, render scale), all made first and then timed a frame each
// in turn, round after round, so that a change of the machine's load falls on all alike.
struct FrameRig {
  std::unique_ptr<render::SunShadowMap> shadow_map;
  std::vector<blend::SunLight> lamps;               // sources after the sun
  std::vector<std::vector<float>> lamp_visibility;  // at the vertices, from their maps
  std::vector<gpu::Texture> ratios;
  std::vector<GLuint> names;
  std::vector<Eigen::Vector3d> sky_radiance;
  std::unique_ptr<render::Compositor> compositor;
  cv::Mat image;
  render::CompositeInput input;
  std::vector<double> wall, cpu;
};
using FrameKey = std::tuple<BakeKey, bool, int, double>;
// Medians, ms: a frame (wall, process CPU), and the building's light summed for a new sky
// (BuildingIrradiance::sum: on the service's sky thread, once per sky, as the blend).
struct FrameTime {
  double wall = 0, cpu = 0;
  double sum_wall = 0, sum_cpu = 0;
};
using FrameTimes = std::map<FrameKey, FrameTime>;

// The compositor's frame time per (bake, sun map, sources, render scale), on the GL context
// current. N sources: the bench sun and N − 1 lamps of 2° spread over the sky, each drawn into the
// map and lighting the building per vertex (the frame's share of what a lamp costs; their maps
// are the sky thread's, drawn when they move).
FrameTimes time_frames(const TradeOptions& o, const Grid& grid, const Sites& sites, const Bakes& made) {
  const std::map<BakeKey, fs::path>& bakes = made.dirs;
  const camera::CameraCalibration hmd = study::scaled_camera(o.hmd_calib, o.frame_width, o.frame_height);
  const double az = 140 * std::numbers::pi / 180, el = 35 * std::numbers::pi / 180;
  const blend::SunLight bench_sun{Eigen::Vector3d(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)),
                                   Eigen::Vector3d::Constant(3.0)};
  std::map<FrameKey, std::unique_ptr<FrameRig>> frame_rigs;
  for (const Setting& s : grid.settings) {
    auto& rig = frame_rigs[std::make_tuple(s.bake, s.sun, s.sources, s.render_scale)];
    if (rig) continue;
    rig = std::make_unique<FrameRig>();
    const SiteData& site = sites.at(s.bake.texel_scale);
    const scene::Mesh& mesh = made.meshes.at(s.bake);
    const fs::path dir = bakes.at(s.bake);
    const bake_format::Manifest manifest = bake_format::read_manifest(dir);
    std::vector<std::size_t> shape;
    const std::vector<float> transfer = bake_format::read_npy(dir / manifest.transfer_file, &shape);
    std::vector<geom::Plane> planes;
    for (const auto& record : manifest.planes) planes.push_back(record.plane);
    render::CompositorOptions options;
    options.lens.render_scale = s.render_scale;
    if (manifest.light_map) options.light_map = bake_format::read_light_map(dir, manifest, bake_format::smallest_light_map_form(manifest));
    options.light_map_precision = o.light_map_precision;
    // The ground's light as the error measures it (and the presets use it): its layer summed too.
    if (o.ground_albedo > 0.0 && manifest.ground) {
      options.ground_albedo = Eigen::Vector3d::Constant(o.ground_albedo);
      options.ground_transfer = bake_format::read_npy(dir / manifest.ground->file, &shape);
    }
    if (s.sun) {
      render::SunShadowOptions map_options;
      map_options.max_sources = s.sources;
      rig->shadow_map = std::make_unique<render::SunShadowMap>(mesh, planes, map_options);
      const BenchSources sources = bench_sources(bench_sun.direction, s.sources, Eigen::Vector3d::Constant(0.2));
      rig->lamps = sources.lamps;
      rig->shadow_map->update(sources.discs);
      for (int k = 1; k < s.sources; ++k) rig->lamp_visibility.push_back(rig->shadow_map->read_vertex_visibility(k));
    }
    for (const auto& plane : planes) {
      const std::vector<float> T(static_cast<std::size_t>(plane.width) * plane.height * 3, 0.8f);
      rig->ratios.push_back(render::upload_shadow_ratio(T, plane.width, plane.height));
      rig->names.push_back(rig->ratios.back().get());
    }
    rig->compositor = std::make_unique<render::Compositor>(site.site, mesh, manifest, transfer, hmd, options);
    rig->image = cv::Mat(hmd.image_height, hmd.image_width, CV_8UC3);
    cv::randu(rig->image, cv::Scalar::all(0), cv::Scalar::all(256));
    rig->sky_radiance.assign(manifest.layer_count(), Eigen::Vector3d(0.3, 0.4, 0.6));
    rig->input.camera = rig->image;
    rig->input.pose = study::visitor_pose();
    rig->input.sky = rig->sky_radiance;
    if (s.sun) rig->input.sun = bench_sun;
    rig->input.shadow_ratios = rig->names;
    rig->input.sun_shadow = rig->shadow_map.get();
    rig->input.lamps = rig->lamps;
    rig->input.lamp_vertex_visibility = rig->lamp_visibility;
    rig->compositor->composite(rig->input);  // warm-up: first-use allocations in the driver
  }
  std::printf("timing %zu compositors × %d frames ...\n", frame_rigs.size(), o.frame_repeats);
  std::fflush(stdout);
  for (int round = 0; round < o.frame_repeats; ++round) {
    for (auto& [key, rig] : frame_rigs) {
      const auto t = Clock::now();
      const std::clock_t c = std::clock();
      rig->compositor->draw(rig->input);
      glFinish();
      rig->wall.push_back(1000.0 * seconds_since(t));
      rig->cpu.push_back(cpu_ms_since(c));
    }
  }
  FrameTimes frame_ms;
  for (auto& [key, rig] : frame_rigs) {
    std::vector<double> sum_wall, sum_cpu;
    const std::shared_ptr<const render::BuildingIrradiance> building = rig->compositor->building_irradiance();
    for (int round = 0; round < std::max(3, o.frame_repeats / 6); ++round) {
      const auto t = Clock::now();
      const std::clock_t c = std::clock();
      const render::SkyIrradiance sums = building->sum(rig->sky_radiance, rig->input.sun, rig->lamps);
      sum_wall.push_back(1000.0 * seconds_since(t));
      sum_cpu.push_back(cpu_ms_since(c));
    }
    frame_ms[key] = {median(rig->wall), median(rig->cpu), median(sum_wall), median(sum_cpu)};
  }
  frame_rigs.clear();
  return frame_ms;
}

// What every setting is measured against, made once per run.
struct Bench {
  const Run& run;
  const Sites& sites;
  const Bakes& bakes;
  const std::vector<SkyData>& skies;
  const References& references;
  Estimators& estimators;
  SequenceInputs& sequence_inputs;
  const FrameTimes& frame_ms;
  blend::BlendWorkers& workers;
};

// A setting's bake as the blend reads it: every plane's basis in the setting's form and bits.
struct SettingBake {
  bake_format::Manifest manifest;
  std::vector<blend::BasisImages> basis;
  std::vector<float> transfer, ground_transfer;  // the latter empty without a ground layer
  std::optional<bake_format::LightMapArrays> light_map;
};

// Also the bake's cost in `r`: its time, size on disk and stored layers.
SettingBake load_setting_bake(const TradeOptions& o, const Bakes& made, Result& r) {
  const Setting& s = r.setting;
  const bool pca = s.form.form == blend::BasisForm::Pca;
  const fs::path bake_dir = pca ? made.pca_dirs.at({s.bake, s.form.components, s.form.tile}) : made.dirs.at(s.bake);
  SettingBake bake{bake_format::read_manifest(bake_dir), {}, {}, {}, {}};
  std::vector<std::size_t> shape;
  bake.transfer = bake_format::read_npy(bake_dir / bake.manifest.transfer_file, &shape);
  if (bake.manifest.ground) bake.ground_transfer = bake_format::read_npy(bake_dir / bake.manifest.ground->file, &shape);
  if (bake.manifest.light_map) bake.light_map = study::light_map_as_shown(bake_dir, bake.manifest, o.light_map_precision);
  r.bake_seconds = made.seconds.at(s.bake) + (pca ? made.pca_seconds.at({s.bake, s.form.components, s.form.tile}) : 0.0);
  r.bake_bytes = directory_bytes(bake_dir);
  std::vector<blend::BasisImages>& basis = bake.basis;
  for (std::size_t j = 0; j < bake.manifest.planes.size(); ++j) {
    basis.push_back(blend::load_basis(bake_dir, bake.manifest, static_cast<int>(j), s.form.form));
    if (s.bits == 8) quantise_to_unorm8(basis.back());
    r.layers += basis.back().layers;
  }
  return bake;
}

// The blend's time at the timing resolution: weights alternating by 1e-4 so that the change
// threshold (0) never keeps the last T; every plane, as the live service blends them. Adds the
// plane's share of the blend time, skipped layers and GPU memory to `r`.
void time_blend(const Bench& bench, std::size_t j, const blend::BasisImages& basis, const std::vector<float>& visibility,
                const blend::BlendWeights& w, Result& r) {
  const TradeOptions& o = bench.run.o;
  const Setting& s = r.setting;
  const geom::Plane& full = bench.sites.at(s.bake.texel_scale).full_planes[j];
  const int width = std::max(4, full.width / o.timing_scale), height = std::max(4, full.height / o.timing_scale);
  const blend::BasisImages fine = upsampled(basis, width, height);
  // Every source's V (one plane's texels after another's), each upsampled.
  std::vector<float> fine_visibility;
  for (std::size_t at = 0; at < visibility.size(); at += basis.texel_count()) {
    const std::vector<float> layer(visibility.begin() + static_cast<std::ptrdiff_t>(at),
                                   visibility.begin() + static_cast<std::ptrdiff_t>(at + basis.texel_count()));
    const std::vector<float> fine_layer = upsampled(layer, basis.width, basis.height, fine.width, fine.height);
    fine_visibility.insert(fine_visibility.end(), fine_layer.begin(), fine_layer.end());
  }
  // What the GPU blend allocates for the plane at this resolution (packed layers): whole
  // layers, or a cropped basis's pages (upsampled keeps it cropped).
  blend::GpuBlendOptions gpu_options;
  gpu_options.storage = s.bits == 8 ? blend::BasisStorage::Unorm8 : blend::BasisStorage::Half;
  gpu_options.pack_layers = true;
  r.gpu_bytes += static_cast<std::uint64_t>(blend::gpu_basis_bytes(fine, gpu_options));
  blend::CpuBlender timed(fine, s.skip_threshold, 0.0);
  blend::BlendWeights nudged = w;
  for (auto& f : nudged.face) f *= 1.0001f;
  nudged.sun *= 1.0001f;
  for (auto& source : nudged.sources) source *= 1.0001f;
  std::vector<double> times, cpu;
  for (int rep = 0; rep <= o.blend_repeats; ++rep) {
    const auto t = Clock::now();
    const std::clock_t c = std::clock();
    timed.blend_sources(rep % 2 ? nudged : w, fine_visibility, 1, &bench.workers);
    if (rep > 0) {  // the first: allocations
      times.push_back(1000.0 * seconds_since(t));
      cpu.push_back(cpu_ms_since(c));
    }
  }
  r.skipped_layers += timed.skipped_layers();
  r.blend_ms += median(times);
  r.blend_cpu_ms += median(cpu);
}

// |E − E_ref| / E_h per point and channel (study::building_errors), each with its weight: 1 at
// the vertices; inside the triangles (areas given) the point's area, leaving out points whose
// reference is zero (enclosed: no ray leaves them).
struct BuildingDiffs {
  std::vector<double> diffs, weights;
  void append(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
              const Eigen::Vector3d& horizontal, std::span<const double> areas = {}) {
    for (std::size_t v = 0; v < estimate.size(); ++v) {
      if (!areas.empty() && reference[v].isZero(0)) continue;
      for (int c = 0; c < 3; ++c) {
        if (!(horizontal[c] > 0)) continue;
        diffs.push_back(std::abs(estimate[v][c] - reference[v][c]) / horizontal[c]);
        weights.push_back(areas.empty() ? 1.0 : areas[v]);
      }
    }
  }
  void append(const BuildingDiffs& other) {
    diffs.insert(diffs.end(), other.diffs.begin(), other.diffs.end());
    weights.insert(weights.end(), other.weights.begin(), other.weights.end());
  }
  study::Errors errors() const { return study::errors_of(diffs, weights); }
};

// T for every sky against the reference (the errors, and on sunny skies the shadow edge's
// displacement), the building's errors; the blend's time on the first sky.
void evaluate_skies(const Bench& bench, const SettingBake& bake, const sky::SkyEstimator& estimator, Result& r) {
  const Setting& s = r.setting;
  const std::vector<SkyData>& skies = bench.skies;
  const bake_format::Manifest& manifest = bake.manifest;
  const std::vector<blend::BasisImages>& basis = bake.basis;
  const SiteData& site = bench.sites.at(s.bake.texel_scale);
  const scene::Mesh& mesh = bench.bakes.meshes.at(s.bake);
  std::vector<double> diffs;
  BuildingDiffs building_diffs, building_no_ground_diffs, building_inside_diffs;
  double edge_sum = 0;
  int edge_count = 0;
  for (std::size_t i = 0; i < skies.size(); ++i) {
    const sky::SkyEstimate estimate = estimator.estimate(skies[i].frame);
    const std::vector<Eigen::Vector3d> S = sky::layer_radiances(estimate.luminance);
    // Every separated source (the sun alone with sources 1), each an area light of its disc's pixels.
    std::vector<sky::Sun> separated = estimate.sources;
    if (separated.empty() && estimate.sun) separated.push_back(*estimate.sun);
    std::vector<blend::SunLight> lights;
    for (const sky::Sun& source : separated) lights.push_back({source.direction, source.energy});
    const Reference& sky_reference = bench.references.at({s.bake.texel_scale, i});
    const auto& reference = sky_reference.planes;
    // The building: its transfer vectors and each source's disc ray-cast from the vertices, with
    // and without the ground layer.
    std::vector<study::SourceLight> sources;
    for (const sky::Sun& source : separated) {
      sources.push_back({source.direction, source.energy, source.disc_directions, source.disc_weights});
    }
    const BuildingReference& building_reference = sky_reference.building.at(s.bake.refine);
    const Eigen::Vector3d& horizontal = sky_reference.horizontal;
    building_no_ground_diffs.append(study::building_estimate(bake.transfer, S, sources, site.site, mesh),
                                    building_reference.vertices, horizontal);
    blend::GroundLight ground;
    if (!bake.ground_transfer.empty() && bench.run.o.ground_albedo > 0.0) {
      const blend::GroundLayers layers(manifest.plan.frequency, manifest.plan.basis, manifest.ground->horizontal_unoccluded);
      ground = {bake.ground_transfer, layers.coefficients(S, lights), Eigen::Vector3d::Constant(bench.run.o.ground_albedo)};
    }
    building_diffs.append(study::building_estimate(bake.transfer, S, sources, site.site, mesh, ground), building_reference.vertices,
                          horizontal);
    // Inside the triangles, the compositor's way: a virtual plane's T_j D_j where one covers a point.
    study::InsideTerms inside_terms = study::building_terms_inside(building_reference.points, bake.transfer, S, sources,
                                                                   estimate.sun.has_value(), site.site, mesh, ground);
    if (bake.light_map) {
      // The sky and the ground from the light map where it covers a triangle.
      blend::GroundLight texel_ground = ground;
      texel_ground.transfer = ground.transfer.empty() ? std::span<const float>() : std::span<const float>(bake.light_map->ground);
      const study::InsideTerms vertex_sky = study::building_terms_inside(building_reference.points, bake.transfer, S, {}, false, site.site, mesh);
      study::use_light_map(building_reference.points, bake.light_map->layout, bake.light_map->transfer, S, texel_ground, vertex_sky.sky,
                           inside_terms, bake.light_map->pca ? bake_format::LightMapValues::Reconstructed : bake_format::LightMapValues::Full);
    }
    std::vector<std::vector<float>> plane_T(basis.size());
    std::vector<Eigen::Vector3d> plane_D(basis.size(), Eigen::Vector3d::Zero());
    std::vector<double> sky_diffs;
    for (std::size_t j = 0; j < basis.size(); ++j) {
      std::vector<float> visibility;  // V of each source, one after another
      for (const sky::Sun& source : separated) {
        std::vector<float> layer(basis[j].texel_count());
        baker::area_light_visibility(site.mesh, manifest.planes[j].plane, source.disc_directions, source.disc_weights, layer);
        visibility.insert(visibility.end(), layer.begin(), layer.end());
      }
      const blend::BlendWeights w = blend::blend_weights_sources(basis[j], S, lights);
      blend::CpuBlender ratios(basis[j], s.skip_threshold, 0.0);
      ratios.blend_sources(w, visibility, 1, &bench.workers);
      const std::vector<float>& rgba = *ratios.rgba();
      std::vector<float> T(basis[j].texel_count() * 3);
      for (std::size_t x = 0; x < basis[j].texel_count(); ++x) std::copy_n(rgba.data() + 4 * x, 3, T.data() + 3 * x);
      plane_D[j] = w.denominator;
      for (std::size_t x = 0; x < basis[j].texel_count(); ++x) {
        for (int ch = 0; ch < 3; ++ch) sky_diffs.push_back(std::abs(T[3 * x + static_cast<std::size_t>(ch)] - reference[j][x][ch]));
      }
      if (skies[i].sunny) {
        const auto [sum, count] = edge_displacement(T, reference[j], manifest.planes[j].plane);
        edge_sum += sum;
        edge_count += count;
      }
      if (i == 0) time_blend(bench, j, basis[j], visibility, w, r);
      plane_T[j] = std::move(T);
    }
    std::vector<geom::Plane> bake_planes;
    for (const auto& record : manifest.planes) bake_planes.push_back(record.plane);
    const std::vector<Eigen::Vector3d> shown =
        study::shown_inside(building_reference.points, inside_terms, study::virtual_shading(site.site, bake_planes, plane_T, plane_D));
    BuildingDiffs sky_inside;
    sky_inside.append(shown, building_reference.inside, horizontal, building_reference.points.areas);
    r.building_inside_per_sky[skies[i].name] = sky_inside.errors();
    building_inside_diffs.append(sky_inside);
    r.rms_per_sky[skies[i].name] = study::errors_of(sky_diffs).rms;
    diffs.insert(diffs.end(), sky_diffs.begin(), sky_diffs.end());
  }
  r.error = study::errors_of(std::move(diffs));
  r.building = building_diffs.errors();
  r.building_no_ground = building_no_ground_diffs.errors();
  r.building_inside = building_inside_diffs.errors();
  r.vertices = mesh.vertex_count();
  if (edge_count > 0) {
    r.edge_m = edge_sum / edge_count;
    r.edge_deg = std::atan2(*r.edge_m, study::kVisitorDistance) * 180.0 / std::numbers::pi;
  }
}

// The sequence: the live path (smoother → blend weights → CpuBlender with the change threshold,
// one per plane, kept from frame to frame as the service keeps them) and the still-sky path (a
// fresh blend of the frame's own estimate), both against the reference.
SequenceResult run_sequence(const Bench& bench, const SettingBake& bake, const Setting& s) {
  const study::SequenceOptions& sequence = bench.run.sequence;
  const std::vector<blend::BasisImages>& basis = bake.basis;
  blend::BlendWorkers& workers = bench.workers;
  const auto& estimates = bench.sequence_inputs.estimates.at({s.bake.frequency, s.bake.basis, s.sun, s.sources});
  const SunTrack& track = sun_track(bench.sequence_inputs, bench.sites, s, bake.manifest);
  const auto& reference = bench.sequence_inputs.references.at(s.bake.texel_scale).frames;
  SequenceResult q;
  q.planes = static_cast<int>(basis.size());
  q.sun_redraws = track.revision.empty() ? 0 : static_cast<int>(track.revision.back());
  sky::SkySmoother smoother(s.smoothing);
  std::vector<std::unique_ptr<blend::CpuBlender>> kept;
  for (const auto& b : basis) kept.push_back(std::make_unique<blend::CpuBlender>(b, s.skip_threshold, s.change_threshold));
  const auto sun_of = [](const sky::SkyEstimate& e) {
    return e.sun ? std::optional<blend::SunLight>(blend::SunLight{e.sun->direction, e.sun->energy}) : std::nullopt;
  };
  for (std::size_t k = 0; k < estimates.size(); ++k) {
    const sky::SkyEstimate smoothed = smoother.smooth(study::sequence_time(sequence, static_cast<int>(k)), estimates[k]);
    const std::vector<Eigen::Vector3d> S_live = sky::layer_radiances(smoothed.luminance);
    const std::vector<Eigen::Vector3d> S_still = sky::layer_radiances(estimates[k].luminance);
    const std::optional<blend::SunLight> sun_live = sun_of(smoothed), sun_still = sun_of(estimates[k]);
    std::vector<double> live_diffs, still_diffs;
    int blended = 0;
    for (std::size_t j = 0; j < basis.size(); ++j) {
      const std::span<const float> visibility =
          track.visibility[k] ? std::span<const float>((*track.visibility[k])[j]) : std::span<const float>();
      blended += kept[j]->blend(blend::blend_weights(basis[j], S_live, sun_live), visibility, track.revision[k], &workers) ? 1 : 0;
      blend::CpuBlender fresh(basis[j], s.skip_threshold, 0.0);
      fresh.blend(blend::blend_weights(basis[j], S_still, sun_still), visibility, track.revision[k], &workers);
      const std::vector<float>& live_rgba = *kept[j]->rgba();
      const std::vector<float>& still_rgba = *fresh.rgba();
      for (std::size_t x = 0; x < basis[j].texel_count(); ++x) {
        for (std::size_t ch = 0; ch < 3; ++ch) {
          live_diffs.push_back(std::abs(live_rgba[4 * x + ch] - reference[k][j][x][static_cast<int>(ch)]));
          still_diffs.push_back(std::abs(still_rgba[4 * x + ch] - reference[k][j][x][static_cast<int>(ch)]));
        }
      }
    }
    const study::Errors live_error = study::errors_of(std::move(live_diffs)), still_error = study::errors_of(std::move(still_diffs));
    q.rms.push_back(live_error.rms);
    q.p99.push_back(live_error.p99);
    q.max.push_back(live_error.max);
    q.still_rms.push_back(still_error.rms);
    q.still_max.push_back(still_error.max);
    q.blended.push_back(blended);
  }
  return q;
}

// The whole frame's time (compositor + blend), and the cost the plot and the front use.
void add_frame_cost(const TradeOptions& o, const FrameTimes& frame_ms, Result& r) {
  const Setting& s = r.setting;
  const FrameTime& time = frame_ms.at(std::make_tuple(s.bake, s.sun, s.sources, s.render_scale));
  r.frame_ms = time.wall;
  r.frame_cpu_ms = time.cpu;
  r.building_sum_ms = time.sum_wall;
  r.building_sum_cpu_ms = time.sum_cpu;
  // What a new sky costs: the planes' blend and the building's sum, both on the sky thread.
  const double sky_ms = r.blend_ms + r.building_sum_ms, sky_cpu_ms = r.blend_cpu_ms + r.building_sum_cpu_ms;
  r.whole_frame_ms = r.frame_ms + sky_ms;
  r.whole_frame_cpu_ms = r.frame_cpu_ms + sky_cpu_ms;
  if (o.sky_interval <= 0.0) {
    r.cost_ms = o.clock == "wall" ? r.whole_frame_ms : r.whole_frame_cpu_ms / o.cores;
  } else {
    // The frame rate the cores sustain with a blend every sky_interval: per second,
    // fps · frame + blend / interval of work, `cores` seconds of it at most (CPU), or the
    // frame's wall time plus its share of the blend's (wall).
    const double frame = o.clock == "wall" ? r.frame_ms : r.frame_cpu_ms / o.cores;
    const double blend_per_s = (o.clock == "wall" ? sky_ms : sky_cpu_ms / o.cores) / o.sky_interval;
    r.cost_ms = frame / std::max(1.0 - blend_per_s / 1000.0, 1e-3);
  }
}

// Setting `index` of `count`: T for every sky against the reference, the blend's time on the
// first sky, the sequence (--sequence) and the frame's cost; its line of progress.
Result evaluate_setting(const Bench& bench, const Setting& s, int index, std::size_t count) {
  const auto t_setting = Clock::now();
  Result r;
  r.setting = s;
  const SettingBake bake = load_setting_bake(bench.run.o, bench.bakes, r);
  const sky::SkyEstimator* estimator = &bench.estimators.estimator_for(s);
  evaluate_skies(bench, bake, *estimator, r);
  // The sequence follows the sun alone (the sky simulator has no lamps).
  if (bench.run.o.sequence && s.sources == 1) r.sequence = run_sequence(bench, bake, s);
  add_frame_cost(bench.run.o, bench.frame_ms, r);
  const TradeOptions& o = bench.run.o;
  if (o.live_seconds > 0) {
    const bool pca = s.form.form == blend::BasisForm::Pca;
    const fs::path bake_dir = pca ? bench.bakes.pca_dirs.at({s.bake, s.form.components, s.form.tile}) : bench.bakes.dirs.at(s.bake);
    r.live = run_live(o, s, bench.sites.at(s.bake.texel_scale).file, bake_dir);
  }
  std::printf("[%d/%zu] %-44s RMS %.4f p99 %.4f max %.4f | building %.4f (%.4f without the ground), inside %.4f | blend %.2f ms "
              "frame %.2f ms (%.1f s)\n",
              index, count, s.label().c_str(), r.error.rms, r.error.p99, r.error.max, r.building.rms, r.building_no_ground.rms,
              r.building_inside.rms, r.blend_ms, r.frame_ms, seconds_since(t_setting));
  if (r.live) {
    std::printf("    service: %.1f frames/s, frame p50 %.1f ms p99 %.1f ms, %lld of %lld camera frames dropped (blend on the %s)\n",
                r.live->frames_per_second, r.live->frame_p50_ms, r.live->frame_p99_ms, static_cast<long long>(r.live->dropped),
                static_cast<long long>(r.live->camera_frames), r.live->device.c_str());
  }
  if (r.sequence) {
    std::printf("    sequence: RMS %.4f (worst %.4f, still %.4f) max %.4f, re-blends %.0f%%\n", mean_of(r.sequence->rms),
                max_of(r.sequence->rms), mean_of(r.sequence->still_rms), max_of(r.sequence->max), 100.0 * blend_fraction(*r.sequence));
  }
  std::fflush(stdout);
  return r;
}

}  // namespace
}  // namespace trade

int run_trade(TradeOptions o) {
  using namespace trade;
  const auto start = Clock::now();
  check_inputs(o);
  const study::SequenceOptions sequence = sequence_options(o);
  fs::create_directories(o.out_dir);
  const Run run{o, fs::path(o.out_dir), sequence, start};

  const std::vector<fs::path> sky_files = list_skies(o);
  const Grid grid = make_grid(o);
  print_plan(grid, sky_files);
  const Sites sites = load_sites(run, grid.scales);
  Bakes bakes;
  make_bakes(run, grid, sites, bakes);
  make_pca_forms(grid, bakes);

  const camera::CameraCalibration calibration = camera::load_calibration(o.sky_calib);
  const camera::Lens lens(calibration);
  const std::vector<SkyData> skies = render_skies(o, lens, sky_files);
  const References references = make_references(o, skies, grid.scales, sites, bakes);
  Estimators estimators(calibration);
  SequenceInputs sequence_inputs;
  if (o.sequence) sequence_inputs = prepare_sequence(run, lens, grid, sites, estimators);

  // The headless GL context stays current to the end, as the frame timing left it.
  gpu::HeadlessContext context;
  const FrameTimes frame_ms = time_frames(o, grid, sites, bakes);

  // Per setting: T for every sky against the reference; the blend's time on the first sky.
  blend::BlendWorkers workers(o.threads);
  const Bench bench{run, sites, bakes, skies, references, estimators, sequence_inputs, frame_ms, workers};
  std::vector<Result> results;
  int index = 0;
  for (const Setting& s : grid.settings) results.push_back(evaluate_setting(bench, s, ++index, grid.settings.size()));

  std::vector<SkyName> sky_names;
  for (const SkyData& d : skies) sky_names.push_back({d.name, d.sunny});
  write_outputs(o, sequence, sky_names, start, results);
  return 0;
}

}  // namespace skylit::study
