#include "skylit/baker/bake_job.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <set>
#include <span>
#include <sstream>

#include <spdlog/spdlog.h>

#include "skylit/bake_format/footprint.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/progress.hpp"
#include "skylit/baker/ground_transfer.hpp"
#include "skylit/baker/vertex_fit.hpp"
#include "skylit/bake_format/light_map.hpp"
#include "skylit/baker/preview.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/geom/spherical.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/bake_format/parts.hpp"
#include "skylit/bake_format/arrays.hpp"

namespace skylit::baker {
namespace fs = std::filesystem;

namespace {

constexpr const char* kGenerator = "skylit-bake 0.1.0";
constexpr int kMaxSamples = 1024;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

double peak_memory_mib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

std::string cli_error(const std::string& option, const std::string& problem, const std::string& fix) {
  return "option " + option + ": " + problem + ". Fix: " + fix;
}

void check_light_map_pca_input(const bake_format::LightMapPcaOptions& options) {
  try {
    bake_format::check_light_map_pca_options(options);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string(e.what()) + ". Fix: give --light-map-components K (1 to 4096) and --light-map-sky-correlation "
                     "of 0 (every layer alike) or an angle in degrees");
  }
}

void validate_options(const BakeOptions& o) {
  if (o.frequency && (*o.frequency < 2 || *o.frequency > 64 || *o.frequency % 2 != 0)) {
    throw InputError(cli_error("--frequency", "got " + std::to_string(*o.frequency),
                               "use an even dome frequency from 2 to 64 (2 → 40 faces, 4 → 160, 8 → 640)"));
  }
  if (o.samples < 1 || o.samples > kMaxSamples) {
    throw InputError(cli_error("--samples", "got " + std::to_string(o.samples),
                               "use 1 (face centre) up to " + std::to_string(kMaxSamples)));
  }
  if (o.method != "auto" && o.method != "raster" && o.method != "raytrace") {
    throw InputError(cli_error("--method", "unknown method '" + o.method + "'", "use auto, raster or raytrace"));
  }
  if (o.resolution) {
    const auto [w, h] = *o.resolution;
    if (w < 1 || h < 1 || w > scene::kMaxPlaneResolution || h > scene::kMaxPlaneResolution) {
      throw InputError(cli_error("--resolution", "got " + std::to_string(w) + "x" + std::to_string(h),
                                 "use WxH with each side from 1 to " +
                                     std::to_string(scene::kMaxPlaneResolution)));
    }
  }
  if (o.shadow_map_resolution != 0 && (o.shadow_map_resolution < 64 || o.shadow_map_resolution > 16384)) {
    throw InputError(cli_error("--shadow-map", "got " + std::to_string(o.shadow_map_resolution),
                               "use 64 to 16384 texels, or leave it out to choose from the planes"));
  }
  validate_refine_options(o.refine);
  if (o.vertex_fit < 0 || o.vertex_fit > 16) {
    throw InputError(cli_error("--vertex-fit", "got " + std::to_string(o.vertex_fit),
                               "use 0 (each vertex's own light) or 1 to 16 points per triangle side, e.g. 3"));
  }
  if (o.light_map) validate_light_map_options(*o.light_map);
  if (o.light_map_pca) {
    if (!o.light_map) {
      throw InputError(cli_error("--light-map-components", "given without --light-map", "give --light-map TEXEL too, or leave it out"));
    }
    check_light_map_pca_input(*o.light_map_pca);
  }
  if (o.resume && o.force) {
    throw InputError(cli_error("--resume/--force", "both given",
                               "use --resume to continue an interrupted bake, --force to start over"));
  }
}

// Shadow-map texels about half the finest plane texel, within what GPUs take comfortably.
int auto_shadow_map_resolution(const scene::Mesh& mesh, const std::vector<geom::Plane>& planes) {
  Eigen::Vector3d lo = mesh.bounds_min().cast<double>();
  Eigen::Vector3d hi = mesh.bounds_max().cast<double>();
  double finest = std::numeric_limits<double>::infinity();
  for (const geom::Plane& p : planes) {
    const std::array<geom::Vec3, 4> corners{p.origin, p.origin + p.u, p.origin + p.v,
                                            p.origin + p.u + p.v};
    for (const geom::Vec3& c : corners) {
      lo = lo.cwiseMin(c);
      hi = hi.cwiseMax(c);
    }
    finest = std::min({finest, p.u.norm() / p.width, p.v.norm() / p.height});
  }
  const double wanted = 2.0 * (hi - lo).norm() / finest;
  int resolution = 1024;
  while (resolution < wanted && resolution < 8192) resolution *= 2;
  return resolution;
}

std::vector<int> faces_of_shard(int face_count, const std::optional<Shard>& shard) {
  std::vector<int> faces;
  for (int i = 0; i < face_count; ++i) {
    if (!shard || i % shard->count == shard->index) faces.push_back(i);
  }
  return faces;
}

bake_format::Plan make_plan(const BakeOptions& o, const scene::Site& site, const scene::Mesh& mesh) {
  bake_format::Plan plan;
  // Absolute paths: shards of one bake may run from different working directories.
  plan.site_file = fs::absolute(o.site_file).lexically_normal().string();
  plan.site_sha256 = sha256_file(o.site_file);
  plan.model_file = fs::absolute(site.model).lexically_normal().string();
  plan.model_sha256 = sha256_file(site.model);
  plan.frequency = o.frequency.value_or(site.dome_frequency);
  plan.basis = o.basis.value_or(site.dome_basis);
  plan.samples = o.samples;
  plan.method = o.method;
  plan.preset = o.preset;
  plan.ground_samples = o.ground_samples;
  plan.vertex_fit = o.vertex_fit;
  if (o.refine.tolerance > 0.0) plan.refine = {o.refine.tolerance, o.refine.rounds, o.refine.min_edge};
  plan.planes = site.planes;
  if (o.resolution) {
    for (geom::Plane& p : plan.planes) std::tie(p.width, p.height) = *o.resolution;
  }
  plan.shadow_map_resolution =
      o.method == "raster"
          ? (o.shadow_map_resolution ? o.shadow_map_resolution : auto_shadow_map_resolution(mesh, plan.planes))
          : 0;
  plan.vertex_count = mesh.vertex_count();
  plan.triangle_count = mesh.triangle_count();
  return plan;
}

std::unique_ptr<VisibilityEngine> make_engine(const bake_format::Plan& plan, const scene::Mesh& mesh,
                                              const fs::path& shader_dir, int threads) {
  if (plan.method == "raytrace") {
    RaytraceOptions options;
    options.threads = threads;
    return make_raytrace_engine(mesh, plan.planes, options);
  }
  RasterOptions options;
  options.shadow_map_resolution = plan.shadow_map_resolution;
  options.shader_dir = shader_dir;
  return make_raster_engine(mesh, plan.planes, options);
}

// Prepares out_dir for a new, resumed or forced bake; returns the faces already done.
std::set<int> prepare_output(const BakeOptions& o, const bake_format::Plan& plan, const bake_format::PartStore& parts,
                             int face_count) {
  ensure_writable_directory(o.out_dir);
  const fs::path manifest = o.out_dir / "manifest.json";
  const std::optional<bake_format::Plan> existing_plan = fs::exists(parts.dir() / "plan.json")
                                                      ? parts.read_plan()
                                                      : std::nullopt;
  if (fs::exists(manifest) && !o.force) {
    throw InputError("output directory '" + o.out_dir.string() +
                     "' already holds a finished bake. Fix: pass --force to replace it, or choose "
                     "another directory with -o");
  }
  if (o.force) {
    // Invalidate first: from here on the directory is never a bake that verify accepts until
    // the new manifest is written.
    fs::remove(manifest);
    fs::remove_all(parts.dir());
  } else if (existing_plan && !o.resume && !o.shard) {
    throw InputError("output directory '" + o.out_dir.string() +
                     "' holds an interrupted bake. Fix: pass --resume to continue it, or --force "
                     "to start over");
  }
  fs::create_directories(parts.dir());
  std::set<int> done;
  if (existing_plan && fs::exists(parts.dir() / "plan.json")) {
    if (!(*existing_plan == plan)) {
      throw InputError("the interrupted bake in '" + o.out_dir.string() +
                       "' was planned differently: " + existing_plan->difference(plan) +
                       ". Fix: rerun with the same site and options, or pass --force to start over");
    }
    for (int i = 0; i < face_count; ++i) {
      if (parts.has(i, plan)) done.insert(i);
    }
  } else {
    parts.write_plan(plan);
  }
  return done;
}

// A basis with fewer directions per face than it has functions is refused: say where the basis
// came from.
void check_basis_samples(const BakeOptions& o, const bake_format::Plan& plan) {
  const int needed = min_samples_per_face(plan.basis);
  if (plan.samples >= needed) return;
  const std::string name(geom::basis_name(plan.basis));
  const std::string source = o.basis ? "--basis " + name : "dome.basis: " + name + " in " + o.site_file.string();
  throw InputError(cli_error("--samples", "got " + std::to_string(plan.samples) + " with " + source,
                             "the " + name + " basis resolves " + std::to_string(needed) +
                                 " functions per face and needs at least " + std::to_string(needed) +
                                 " samples per face: pass --samples " +
                                 std::to_string(plan.basis == geom::DomeBasis::Quadratics ? 64 : 16) +
                                 " (or --basis faces)"));
}

bake_format::Manifest manifest_for(const bake_format::Plan& plan, const geom::Dome& dome) {
  bake_format::Manifest m;
  m.generator = kGenerator;
  m.created_utc = utc_now();
  m.plan = plan;
  for (int i = 0; i < dome.face_count(); ++i) {
    const geom::DomeFace& f = dome.face(i);
    bake_format::FaceRecord r;
    r.index = i;
    r.direction = f.centre;
    r.solid_angle = f.solid_angle;
    for (int k = 0; k < 3; ++k) r.vertices[static_cast<std::size_t>(k)] = dome.vertices()[static_cast<std::size_t>(f.vertex[static_cast<std::size_t>(k)])];
    r.neighbours = f.neighbour;
    m.faces.push_back(r);
  }
  const std::vector<geom::FaceQuadrature> quadratures = face_quadratures(dome, plan.basis);
  for (const geom::Plane& p : plan.planes) {
    bake_format::PlaneRecord r;
    r.plane = p;
    r.file = "planes/" + p.name + ".exr";
    r.unoccluded = layer_cosine_integrals(dome, plan.basis, quadratures, p.normal());
    m.planes.push_back(std::move(r));
  }
  return m;
}

// What of the plane's basis a blend needs (bake/footprint.hpp): said, so that a site's planes
// can be placed and sized for what they shadow.
void log_footprint(const bake_format::PlaneRecord& record, const bake_format::ImageStack& stack, std::FILE* log) {
  if (!log) return;
  const bake_format::PlaneFootprint f = bake_format::analyse_footprint(stack, record.unoccluded);
  constexpr double kMiB = 1024.0 * 1024.0;
  const double layer_mib = static_cast<double>(f.texels) * 2.0 / kMiB;  // half floats
  const double cropped = f.shadowed > 0 ? static_cast<double>(f.shadowed_texels) /
                                              (static_cast<double>(f.shadowed) * static_cast<double>(f.texels))
                                        : 0.0;
  std::fprintf(log,
               "skylit-bake: plane '%s': %d of %d layers hold a shadow (%d the plane cannot see, %d unshadowed): the "
               "lean form blends %d layers, %.1f MiB instead of %.1f MiB; the cropped form (each shadowed layer cut to the "
               "rectangle it shadows) keeps %.0f%% of their texels, %.1f MiB\n",
               record.plane.name.c_str(), f.shadowed, stack.layers, f.dark, f.unshadowed, f.needed_layers(),
               layer_mib * f.needed_layers(), layer_mib * stack.layers, 100.0 * cropped,
               static_cast<double>(f.shadowed_texels) * 2.0 / kMiB + (f.unshadowed > 0 ? layer_mib : 0.0));
}

// Each layer's direction: its face's centre (the sky prior's).
std::vector<Vec3> layer_directions(const bake_format::Manifest& manifest) {
  std::vector<Vec3> directions;
  const std::size_t per_face = static_cast<std::size_t>(manifest.plan.layers_per_face());
  for (std::size_t l = 0; l < manifest.layer_count(); ++l) directions.push_back(manifest.faces[l / per_face].direction);
  return directions;
}

// Options checked before any work, so that a typo does not cost a bake.
void check_pca_input(const std::optional<bake_format::PcaOptions>& options) {
  if (!options) return;
  try {
    bake_format::check_pca_options(*options);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string(e.what()) + ". Fix: give --pca-components K (>= 1), --pca-variance F (0 < F <= 1) "
                     "or --pca-max-error E (> 0), and --pca-tile N of 0 (the whole plane) or at least 2 texels");
  }
}

// Writes the PCA form of one plane beside its full image (planes/<name>.pca.exr, .pca.npy) and
// records it; the files still need listing in the manifest.
void write_pca_form(const fs::path& out_dir, const bake_format::Manifest& manifest, bake_format::PlaneRecord& record,
                    const bake_format::ImageStack& stack, const bake_format::PcaOptions& options, std::FILE* log) {
  const auto start = std::chrono::steady_clock::now();
  const std::vector<Vec3> directions = layer_directions(manifest);
  const bake_format::PcaBasis pca = bake_format::compress_pca(stack, record.unoccluded, options, directions);
  bake_format::PcaRecord r;
  const fs::path stem = fs::path(record.file).replace_extension();
  r.file = stem.string() + ".pca.exr";
  r.coefficients = stem.string() + ".pca.npy";
  r.components = pca.components;
  r.max_error = pca.max_error;
  r.rms_error = pca.rms_error;
  r.variance_kept = pca.variance_kept;
  r.sky_correlation_deg = options.sky_correlation_deg;
  r.tile = pca.tile;
  bake_format::write_exr_stack(out_dir / r.file, pca.images, bake_format::pca_layer_names(pca.components));
  const auto n = static_cast<std::size_t>(pca.source_layers), k = static_cast<std::size_t>(pca.components);
  if (pca.tile > 0) {
    const std::size_t shape[] = {static_cast<std::size_t>(pca.tile_count()), n, k};
    bake_format::write_npy(out_dir / r.coefficients, pca.coefficients, shape);
  } else {
    const std::size_t shape[] = {n, k};
    bake_format::write_npy(out_dir / r.coefficients, pca.coefficients, shape);
  }
  if (log) {
    const std::string tiles = pca.tile > 0 ? " in each of " + std::to_string(pca.tile_count()) + " tiles of " +
                                                 std::to_string(pca.tile) + "x" + std::to_string(pca.tile) + " texels"
                                           : "";
    std::fprintf(log,
                 "skylit-bake: plane '%s': PCA keeps K = %d component(s) of %d layers%s (%.2f%% of the variance), "
                 "so the blend reads %d layers instead of %d; |T - T_full| <= %.4f (RMS %.5f of the fractions), in %.1f s\n",
                 record.plane.name.c_str(), pca.components, pca.source_layers, tiles.c_str(), 100.0 * pca.variance_kept,
                 pca.components + 1, pca.source_layers, pca.max_error, pca.rms_error, seconds_since(start));
  }
  record.pca = std::move(r);
}

// Writes the light map's PCA form beside its full form and records it in the manifest, with its
// files listed (their sizes and hashes still to be filled in).
void write_light_map_pca_form(const fs::path& out_dir, bake_format::Manifest& manifest, const bake_format::LightMapLayout& layout,
                              std::span<const float> transfer, std::span<const float> ground,
                              const bake_format::LightMapPcaOptions& options, std::FILE* log) {
  const auto start = std::chrono::steady_clock::now();
  const std::vector<Vec3> directions = layer_directions(manifest);
  bake_format::LightMapPca pca;
  pca.sky = bake_format::compress_light_map(layout, transfer, manifest.layer_count(), options, directions);
  bake_format::Manifest::LightMap::Pca record;
  record.components = options.components;
  record.sky_correlation_deg = options.sky_correlation_deg;
  record.rms_error = pca.sky.rms_error;
  record.max_error = pca.sky.max_error;
  if (!ground.empty()) {
    bake_format::LightMapPcaOptions plain = options;
    plain.sky_correlation_deg = 0.0;
    pca.ground = bake_format::compress_light_map(layout, ground, manifest.layer_count(), plain);
    record.ground_weights_file = "light_map_pca_ground_weights.npy";
    record.ground_vectors_file = "light_map_pca_ground_vectors.npy";
    record.ground_rms_error = pca.ground.rms_error;
    record.ground_max_error = pca.ground.max_error;
  }
  bake_format::write_light_map_pca(out_dir, record, pca);
  std::set<std::string> names{record.weights_file, record.vectors_file};
  if (!ground.empty()) names.insert({record.ground_weights_file, record.ground_vectors_file});
  std::erase_if(manifest.files, [&](const bake_format::FileRecord& f) { return names.count(f.path) > 0; });
  for (const std::string& name : names) manifest.files.push_back({name, 0, ""});
  if (log) {
    const std::size_t full = layout.texels.size() * manifest.layer_count(), kept =
        layout.texels.size() * static_cast<std::size_t>(options.components) + layout.charts.size() * static_cast<std::size_t>(options.components + 1) * manifest.layer_count();
    constexpr double kMiB = 1024.0 * 1024.0;
    std::fprintf(log,
                 "skylit-bake: light map: PCA keeps K = %d component(s) per chart of %zu layers, %.1f MiB instead of %.1f MiB%s; "
                 "|t - t_full| RMS %.2g sr (%.2f%% of t's RMS), max %.2g sr",
                 options.components, manifest.layer_count(), 4.0 * static_cast<double>(kept) / kMiB, 4.0 * static_cast<double>(full) / kMiB,
                 ground.empty() ? "" : " (each of the sky's and the ground's)", pca.sky.rms_error,
                 pca.sky.rms_value > 0.0 ? 100.0 * pca.sky.rms_error / pca.sky.rms_value : 0.0, pca.sky.max_error);
    if (!ground.empty()) {
      std::fprintf(log, "; the ground's RMS %.2g sr (%.2f%%)", pca.ground.rms_error,
                   pca.ground.rms_value > 0.0 ? 100.0 * pca.ground.rms_error / pca.ground.rms_value : 0.0);
    }
    std::fprintf(log, ", in %.1f s\n", seconds_since(start));
  }
  manifest.light_map->pca = std::move(record);
}

// The site and its model as baked: refined when asked, and with the vertex fit's points.
struct LoadedSite {
  scene::Site site;
  scene::Mesh mesh;
  scene::Refinement refinement;
  FitPoints fit;                          // empty without --vertex-fit
  std::optional<LightMapPoints> light_map;
  std::optional<scene::Mesh> fit_mesh;    // the model with the fit's points and the light map's texels as vertices
  // What the engines trace: the model's vertices, then the fit's points, then the light map's texels.
  const scene::Mesh& traced() const { return fit_mesh ? *fit_mesh : mesh; }
  std::size_t first_texel() const { return mesh.vertex_count() + fit.positions.size(); }
};

// Assembles the final files from the parts, writes the manifest last, then removes the parts.
std::uint64_t finalize(const fs::path& out_dir, bake_format::Manifest manifest, const LoadedSite& loaded,
                       const geom::Dome& dome, bool previews, const std::optional<bake_format::PcaOptions>& pca,
                       const std::optional<bake_format::LightMapPcaOptions>& light_map_pca, std::FILE* log) {
  const scene::Mesh& mesh = loaded.mesh;
  const scene::Mesh& traced = loaded.traced();
  const scene::Refinement& refinement = loaded.refinement;
  const auto start = std::chrono::steady_clock::now();
  const bake_format::PartStore parts(out_dir / "parts");
  const bake_format::Plan& plan = manifest.plan;
  const int n = dome.face_count();
  const int per_face = plan.layers_per_face();
  const std::size_t layers = static_cast<std::size_t>(n) * static_cast<std::size_t>(per_face);
  fs::create_directories(out_dir / "planes");
  if (previews) fs::create_directories(out_dir / "preview");

  const std::vector<std::string> layer_names = bake_format::layer_names(plan.basis, n);

  // Per-vertex transfer t_{v,l} = A_l(n_v) · f_{v,l}, filled while the parts are read; A_l(n_v)
  // of every vertex first (one row per vertex, as transfer.npy), and of the fit's points after them.
  const std::size_t vertex_count = mesh.vertex_count(), traced_count = traced.vertex_count();
  std::vector<float> transfer(traced_count * layers, 0.0f);
  const std::vector<geom::FaceQuadrature> quadratures = face_quadratures(dome, plan.basis);
  std::vector<float> vertex_unoccluded(traced_count * layers);  // float: the fit's points make it large
  for (std::size_t v = 0; v < traced_count; ++v) {
    const std::vector<double> a = layer_cosine_integrals(dome, plan.basis, quadratures, traced.normals[v].cast<double>());
    std::transform(a.begin(), a.end(), vertex_unoccluded.begin() + static_cast<std::ptrdiff_t>(v * layers),
                   [](double x) { return static_cast<float>(x); });
  }
  const auto add_vertex_fractions = [&](int face, const bake_format::FacePart& part) {
    for (int k = 0; k < per_face; ++k) {
      const std::size_t l = static_cast<std::size_t>(face * per_face + k);
      const float* f = part.vertex_fractions.data() + static_cast<std::size_t>(k) * traced_count;
      for (std::size_t v = 0; v < traced_count; ++v) {
        transfer[v * layers + l] = vertex_unoccluded[v * layers + l] * f[v];
      }
    }
  };

  Progress progress("assemble", static_cast<std::int64_t>(plan.planes.size()) * n, log);
  for (std::size_t j = 0; j < plan.planes.size(); ++j) {
    const geom::Plane& p = plan.planes[j];
    bake_format::ImageStack stack;
    stack.width = p.width;
    stack.height = p.height;
    stack.layers = static_cast<int>(layers);
    stack.data.assign(static_cast<std::size_t>(p.width) * p.height * layers, 0.0f);
    for (int i = 0; i < n; ++i) {
      const bake_format::FacePart part = parts.read(i, plan);
      const std::vector<float>& f = part.plane_fractions.at(j);
      for (int k = 0; k < per_face; ++k) {
        const int l = i * per_face + k;
        const double a = manifest.planes[j].unoccluded[static_cast<std::size_t>(l)];
        std::span<float> layer = stack.layer(l);
        const float* fk = f.data() + static_cast<std::size_t>(k) * layer.size();
        for (std::size_t t = 0; t < layer.size(); ++t) layer[t] = static_cast<float>(a * fk[t]);
      }
      if (j == 0) add_vertex_fractions(i, part);
      progress.advance();
    }
    const fs::path file = out_dir / manifest.planes[j].file;
    bake_format::write_exr_stack(file, stack, layer_names);
    log_footprint(manifest.planes[j], stack, log);
    if (previews) write_plane_previews(out_dir / "preview", manifest, static_cast<int>(j), stack);
    manifest.files.push_back({manifest.planes[j].file, 0, ""});
    if (pca) {
      write_pca_form(out_dir, manifest, manifest.planes[j], stack, *pca, log);
      manifest.files.push_back({manifest.planes[j].pca->file, 0, ""});
      manifest.files.push_back({manifest.planes[j].pca->coefficients, 0, ""});
    }
  }
  if (plan.planes.empty()) {
    // Transfer vectors still need every face's vertex fractions.
    for (int i = 0; i < n; ++i) add_vertex_fractions(i, parts.read(i, plan));
  }
  progress.finish();
  // The light map's texels follow the vertices and the fit's points.
  const std::size_t first_texel = loaded.first_texel();
  std::vector<float> texel_transfer;
  if (loaded.light_map) texel_transfer.assign(transfer.begin() + static_cast<std::ptrdiff_t>(first_texel * layers), transfer.end());
  if (plan.vertex_fit > 0) {
    // Each vertex's transfer fitted to the light at the points inside its triangles, within
    // [0, A_l(n_v)] (vertex_fit.hpp).
    const auto fit_start = std::chrono::steady_clock::now();
    transfer = fit_vertex_values(mesh, loaded.fit, std::span<const float>(transfer).first(first_texel * layers), layers,
                                 std::span<const float>(vertex_unoccluded).first(vertex_count * layers));
    if (log != nullptr) {
      std::fprintf(log, "vertex fit: %zu vertices fitted to the light at %zu points inside their triangles (%d² each) in %.1f s\n",
                   vertex_count, loaded.fit.positions.size(), plan.vertex_fit, seconds_since(fit_start));
    }
  } else {
    transfer.resize(vertex_count * layers);
  }

  const std::size_t transfer_shape[] = {vertex_count, layers};
  bake_format::write_npy(out_dir / manifest.transfer_file, transfer, transfer_shape);
  std::vector<float> vertices;
  vertices.reserve(vertex_count * 6);
  for (std::size_t v = 0; v < vertex_count; ++v) {
    for (int k = 0; k < 3; ++k) vertices.push_back(mesh.positions[v][k]);
    for (int k = 0; k < 3; ++k) vertices.push_back(mesh.normals[v][k]);
  }
  const std::size_t vertices_shape[] = {vertex_count, 6};
  bake_format::write_npy(out_dir / manifest.vertices_file, vertices, vertices_shape);
  manifest.files.push_back({manifest.transfer_file, 0, ""});
  manifest.files.push_back({manifest.vertices_file, 0, ""});
  if (plan.refine.tolerance > 0.0) {
    bake_format::Manifest::Refinement record;
    std::vector<std::uint32_t> edges;
    for (const std::vector<scene::Edge>& round : refinement.rounds) {
      record.round_sizes.push_back(round.size());
      for (const scene::Edge& e : round) edges.insert(edges.end(), {e.first, e.second});
    }
    const std::size_t shape[] = {edges.size() / 2, 2};
    bake_format::write_npy_u32(out_dir / record.file, edges, shape);
    manifest.files.push_back({record.file, 0, ""});
    manifest.refinement = std::move(record);
  }
  std::vector<float> texel_ground;  // the light map's, with a ground layer
  if (plan.ground_samples > 0) {
    // The ground layer: the ground's irradiance per layer with the model's shadow, on a grid,
    // and its transfer to every vertex (ground_transfer.hpp), with A_l(z).
    const auto ground_start = std::chrono::steady_clock::now();
    const GroundGrid grid = bake_ground_grid(mesh, dome, plan.basis, plan.samples);
    bake_format::Manifest::Ground ground;
    std::vector<float> ground_values = ground_transfer(traced, plan.planes, grid, plan.ground_samples);
    if (loaded.light_map) texel_ground.assign(ground_values.begin() + static_cast<std::ptrdiff_t>(first_texel * layers), ground_values.end());
    if (plan.vertex_fit > 0) {
      ground_values = fit_vertex_values(mesh, loaded.fit, std::span<const float>(ground_values).first(first_texel * layers), layers);
    } else {
      ground_values.resize(vertex_count * layers);
    }
    ground.horizontal_unoccluded = grid.unoccluded;
    const std::size_t ground_shape[] = {vertex_count, layers};
    bake_format::write_npy(out_dir / ground.file, ground_values, ground_shape);
    manifest.files.push_back({ground.file, 0, ""});
    if (log != nullptr) {
      std::fprintf(log, "ground: its light per layer on %d×%d points (%.2f m apart), its transfer to %zu vertices from %d "
                   "directions each, in %.1f s\n", grid.plane.width, grid.plane.height, grid.plane.u.x() / grid.plane.width,
                   vertex_count, plan.ground_samples, seconds_since(ground_start));
    }
    manifest.ground = std::move(ground);
  }
  if (loaded.light_map) {
    // The light map: its layout, and its texels' transfer with those inside another part filled
    // from their neighbours (light_map.hpp).
    const bake_format::LightMapLayout& layout = loaded.light_map->layout;
    bake_format::Manifest::LightMap record;
    record.width = layout.width;
    record.height = layout.height;
    record.chart_count = layout.charts.size();
    const bool full_form = !light_map_pca || light_map_pca->keep_full_form;
    if (!full_form) record.transfer_file.clear();
    if (full_form && plan.ground_samples > 0) record.ground_file = "light_map_ground.npy";
    fill_unseen_texels(layout, layers, texel_transfer, plan.ground_samples > 0 ? &texel_ground : nullptr);
    bake_format::write_light_map_layout(out_dir, record, layout);
    for (const std::string* file : {&record.charts_file, &record.triangles_file, &record.texels_file}) {
      manifest.files.push_back({*file, 0, ""});
    }
    if (full_form) {
      const std::size_t shape[] = {layout.texels.size(), layers};
      bake_format::write_npy(out_dir / record.transfer_file, texel_transfer, shape);
      manifest.files.push_back({record.transfer_file, 0, ""});
      if (!record.ground_file.empty()) {
        bake_format::write_npy(out_dir / record.ground_file, texel_ground, shape);
        manifest.files.push_back({record.ground_file, 0, ""});
      }
    }
    manifest.light_map = std::move(record);
    if (light_map_pca) write_light_map_pca_form(out_dir, manifest, layout, texel_transfer, texel_ground, *light_map_pca, log);
  }

  manifest.finalize_seconds = seconds_since(start);
  bake_format::write_manifest(out_dir, manifest);
  fs::remove_all(parts.dir());

  std::uint64_t bytes = 0;
  for (const bake_format::FileRecord& f : manifest.files) bytes += fs::file_size(out_dir / f.path);
  return bytes;
}

// The site and its model, refined where the light changes when `refine` asks: deterministic, so
// every shard and a merge refine alike (their plans' vertex counts must agree).
LoadedSite load(const fs::path& site_file, const RefineOptions& refine, int vertex_fit, const std::optional<LightMapOptions>& light_map,
                int threads, std::FILE* log) {
  LoadedSite loaded{scene::load_site(site_file), {}, {}, {}, {}, {}};
  loaded.mesh = scene::load_site_model(loaded.site);
  if (refine.tolerance > 0.0) {
    const auto start = std::chrono::steady_clock::now();
    RefineOptions options = refine;
    options.threads = threads;
    const std::size_t before = loaded.mesh.vertex_count();
    loaded.refinement = refine_where_light_changes(loaded.mesh, loaded.site.planes, options, log);
    if (log) {
      std::fprintf(log, "refine: %zu → %zu vertices (%zu edges split in %zu rounds, tolerance %g, min edge %g m) in %.1f s\n",
                   before, loaded.mesh.vertex_count(), loaded.refinement.split_count(), loaded.refinement.rounds.size(),
                   refine.tolerance, refine.min_edge, seconds_since(start));
    }
  }
  if (vertex_fit > 0) loaded.fit = fit_points(loaded.mesh, vertex_fit);
  std::vector<Eigen::Vector3f> positions = loaded.fit.positions, normals = loaded.fit.normals;
  if (light_map) {
    const auto start = std::chrono::steady_clock::now();
    loaded.light_map = lay_out_light_map(loaded.mesh, *light_map);
    const bake_format::LightMapLayout& l = loaded.light_map->layout;
    positions.insert(positions.end(), loaded.light_map->positions.begin(), loaded.light_map->positions.end());
    normals.insert(normals.end(), loaded.light_map->normals.begin(), loaded.light_map->normals.end());
    if (log) {
      const auto charted = static_cast<std::size_t>(std::count_if(l.triangle_chart.begin(), l.triangle_chart.end(), [](std::int32_t c) { return c >= 0; }));
      const auto finer = static_cast<std::size_t>(std::count_if(l.charts.begin(), l.charts.end(), [&](const auto& c) { return std::min(c.texel_u, c.texel_v) < l.texel; }));
      std::fprintf(log, "light map: %zu chart(s) over %zu of %zu triangles (flat regions of at least %g m²), %zu texels of %g m (finer on "
                   "%zu narrow charts) to trace in a %d×%d atlas, laid out in %.1f s\n", l.charts.size(), charted, l.triangle_chart.size(),
                   light_map->min_area, l.texels.size(), l.texel, finer, l.width, l.height, seconds_since(start));
    }
  }
  if (!positions.empty()) loaded.fit_mesh = with_points(loaded.mesh, positions, normals);
  return loaded;
}

RefineOptions refine_options_of(const bake_format::Plan& plan) {
  RefineOptions options;
  options.tolerance = plan.refine.tolerance;
  if (plan.refine.tolerance > 0.0) {
    options.rounds = plan.refine.rounds;
    options.min_edge = plan.refine.min_edge;
  }
  return options;
}

void log_summary(std::FILE* log, const bake_format::Plan& plan, const BakeSummary& s, const fs::path& dir) {
  if (!log) return;
  std::fprintf(log,
               "skylit-bake: %s — %zu plane(s), dome ν=%d (%d faces, %s basis), %d sample(s)/face, %s; "
               "%d face(s) baked, %d resumed, in %s; %.1f MiB written; peak memory %.0f MiB\n",
               s.complete ? "bake complete" : "shard done", plan.planes.size(), plan.frequency,
               s.faces_total, std::string(geom::basis_name(plan.basis)).c_str(), plan.samples, plan.method.c_str(), s.faces_baked, s.faces_skipped,
               format_duration(s.seconds).c_str(), static_cast<double>(s.bytes_written) / (1024.0 * 1024.0),
               peak_memory_mib());
  if (s.complete) {
    std::fprintf(log, "skylit-bake: %s (previews in %s)\n", dir.string().c_str(),
                 (dir / "preview").string().c_str());
  }
}

}  // namespace

std::vector<geom::Vec3> face_sample_directions(const geom::Dome& dome, int face, int samples) {
  if (samples == 1) return {dome.face(face).centre};
  return geom::stratified_samples(dome.triangle(face), samples, static_cast<std::uint64_t>(face));
}

void trace_face(VisibilityEngine& engine, const geom::Dome& dome, const geom::CornerWeights& corner_weights,
                geom::DomeBasis basis, int face, int samples, const std::function<void(std::size_t first, std::size_t count)>& traced) {
  const std::vector<geom::Vec3> directions = face_sample_directions(dome, face, samples);
  // Corners and quadratics: each sample weighs the face's functions at its barycentric
  // coordinates in the face.
  std::vector<geom::LayerValues> values;
  if (basis != geom::DomeBasis::Faces) {
    for (const geom::Vec3& d : directions) values.push_back(geom::layer_values(basis, corner_weights(face, d)));
  }
  const auto per_face = static_cast<std::size_t>(geom::layers_per_face(basis));
  for (std::size_t first = 0; first < per_face; first += kEngineLayers) {
    const std::size_t count = std::min(kEngineLayers, per_face - first);
    std::vector<SampleWeights> weights;
    for (const geom::LayerValues& v : values) {
      SampleWeights w{0.0f, 0.0f, 0.0f};
      for (std::size_t k = 0; k < count; ++k) w[k] = static_cast<float>(v[first + k]);
      weights.push_back(w);
    }
    engine.set_weighted_directions(directions, weights, static_cast<int>(count));
    traced(first, count);
  }
}

std::vector<geom::FaceQuadrature> face_quadratures(const geom::Dome& dome, geom::DomeBasis basis) {
  std::vector<geom::FaceQuadrature> quadratures;
  if (basis == geom::DomeBasis::Faces) return quadratures;
  for (int i = 0; i < dome.face_count(); ++i) {
    quadratures.push_back(geom::face_quadrature(dome, i, geom::kDefaultQuadratureSubdivisions, basis));
  }
  return quadratures;
}

std::vector<double> layer_cosine_integrals(const geom::Dome& dome, geom::DomeBasis basis,
                                           const std::vector<geom::FaceQuadrature>& quadratures, const geom::Vec3& n) {
  std::vector<double> a;
  a.reserve(static_cast<std::size_t>(dome.face_count() * geom::layers_per_face(basis)));
  for (int i = 0; i < dome.face_count(); ++i) {
    if (basis == geom::DomeBasis::Faces) {
      a.push_back(geom::cosine_integral(dome.triangle(i), n));
    } else {
      const std::vector<double> layers =
          geom::layer_cosine_integrals(dome, i, quadratures.at(static_cast<std::size_t>(i)), n);
      a.insert(a.end(), layers.begin(), layers.end());
    }
  }
  return a;
}

Shard parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  const auto fail = [&] {
    return InputError(cli_error("--shard", "got '" + text + "'",
                                "write I/N with 0 ≤ I < N, e.g. --shard 0/4 for the first of four slices"));
  };
  if (slash == std::string::npos) throw fail();
  Shard shard;
  try {
    std::size_t used_i = 0, used_n = 0;
    shard.index = std::stoi(text.substr(0, slash), &used_i);
    shard.count = std::stoi(text.substr(slash + 1), &used_n);
    if (used_i != slash || used_n != text.size() - slash - 1) throw fail();
  } catch (const std::logic_error&) {
    throw fail();
  }
  if (shard.count < 1 || shard.index < 0 || shard.index >= shard.count) throw fail();
  return shard;
}

std::optional<Shard> shard_from_environment() {
  const auto env_int = [](const char* name) -> std::optional<int> {
    const char* value = std::getenv(name);
    if (!value || !*value) return std::nullopt;
    char* end = nullptr;
    const long parsed = std::strtol(value, &end, 10);
    if (*end != '\0') {
      throw InputError(std::string("environment variable ") + name + "='" + value +
                       "' is not an integer. Fix: unset it or set it to the task index");
    }
    return static_cast<int>(parsed);
  };
  if (const auto id = env_int("SLURM_ARRAY_TASK_ID")) {
    const auto count = env_int("SLURM_ARRAY_TASK_COUNT");
    if (!count) {
      throw InputError("SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not. Fix: run as a "
                       "Slurm job array (sbatch --array=0-N), or pass --shard I/N");
    }
    const int first = env_int("SLURM_ARRAY_TASK_MIN").value_or(0);
    return parse_shard(std::to_string(*id - first) + "/" + std::to_string(*count));
  }
  if (const auto index = env_int("JOB_COMPLETION_INDEX")) {
    const auto count = env_int("SKYLIT_SHARD_COUNT");
    if (!count) {
      throw InputError("JOB_COMPLETION_INDEX is set but SKYLIT_SHARD_COUNT is not. Fix: set "
                       "SKYLIT_SHARD_COUNT to the Job's .spec.completions, or pass --shard I/N");
    }
    return parse_shard(std::to_string(*index) + "/" + std::to_string(*count));
  }
  return std::nullopt;
}

std::string resolve_method(const BakeOptions& options) {
  if (options.method != "auto") return options.method;
  if (!options.force) {
    // A resumed bake, or another shard into the same folder, must run the engine its plan names.
    const bake_format::PartStore parts(options.out_dir / "parts");
    if (fs::exists(parts.dir() / "plan.json")) {
      if (const std::optional<bake_format::Plan> plan = parts.read_plan()) {
        spdlog::info("method auto: {}, the engine of the interrupted bake in {}", plan->method,
                     options.out_dir.string());
        return plan->method;
      }
    }
  }
  const EngineChoice choice = choose_engine();
  spdlog::info("method auto: {}", choice.reason);
  return choice.method;
}

BakeSummary run_bake(const BakeOptions& given, std::FILE* log) {
  const auto start = std::chrono::steady_clock::now();
  validate_options(given);
  check_pca_input(given.pca);
  const LoadedSite loaded = load(given.site_file, given.refine, given.vertex_fit, given.light_map, given.threads, log);
  BakeOptions options = given;
  options.method = resolve_method(given);
  bake_format::Plan plan = make_plan(options, loaded.site, loaded.mesh);
  if (loaded.light_map) {
    plan.light_map = {given.light_map->texel, given.light_map->min_area, given.light_map->min_across, loaded.light_map->layout.texels.size()};
  }
  check_basis_samples(options, plan);
  const geom::Dome dome(plan.frequency);
  const bake_format::PartStore parts(options.out_dir / "parts");
  const std::set<int> done = prepare_output(options, plan, parts, dome.face_count());

  std::vector<int> todo;
  const std::vector<int> shard_faces = faces_of_shard(dome.face_count(), options.shard);
  BakeSummary summary;
  summary.faces_total = dome.face_count();
  for (int i : shard_faces) {
    if (done.count(i)) {
      ++summary.faces_skipped;
    } else {
      todo.push_back(i);
    }
  }

  if (!todo.empty()) {
    auto engine = make_engine(plan, loaded.traced(), options.shader_dir, options.threads);
    summary.engine_description = engine->name();
    spdlog::info("engine: {}; {} face(s) to bake{}", engine->name(), todo.size(),
                 options.shard ? fmt::format(" (shard {}/{})", options.shard->index, options.shard->count) : "");
    Progress progress("bake", static_cast<std::int64_t>(todo.size()), log);
    const geom::CornerWeights corner_weights(dome);
    const auto per_face = static_cast<std::size_t>(plan.layers_per_face());
    for (int i : todo) {
      bake_format::FacePart part;
      part.face = i;
      for (std::size_t j = 0; j < plan.planes.size(); ++j) {
        part.plane_fractions.emplace_back(per_face * static_cast<std::size_t>(plan.planes[j].width) *
                                          static_cast<std::size_t>(plan.planes[j].height));
      }
      part.vertex_fractions.resize(per_face * loaded.traced().vertex_count());
      trace_face(*engine, dome, corner_weights, plan.basis, i, plan.samples, [&](std::size_t first, std::size_t count) {
        for (std::size_t j = 0; j < plan.planes.size(); ++j) {
          const std::size_t texels =
              static_cast<std::size_t>(plan.planes[j].width) * static_cast<std::size_t>(plan.planes[j].height);
          std::span<float> out(part.plane_fractions[j]);
          engine->plane_fractions(static_cast<int>(j), out.subspan(first * texels, count * texels));
        }
        const std::size_t vertices = loaded.traced().vertex_count();
        std::span<float> out(part.vertex_fractions);
        engine->vertex_fractions(out.subspan(first * vertices, count * vertices));
      });
      parts.write(part);
      ++summary.faces_baked;
      progress.advance();
    }
    progress.finish();
  }

  const bool whole = !options.shard || options.shard->count == 1;
  if (whole) {
    bake_format::Manifest manifest = manifest_for(plan, dome);
    manifest.bake_seconds = seconds_since(start);
    summary.bytes_written =
        finalize(options.out_dir, manifest, loaded, dome, options.previews, options.pca, options.light_map_pca, log);
    summary.complete = true;
  }
  summary.seconds = seconds_since(start);
  log_summary(log, plan, summary, options.out_dir);
  if (!whole && log) {
    std::fprintf(log, "skylit-bake: join the shards with: skylit-bake merge DIR... -o OUT_DIR\n");
  }
  return summary;
}

BakeSummary merge_bakes(const std::vector<fs::path>& shard_dirs, const fs::path& out_dir, bool previews,
                        std::FILE* log, const std::optional<bake_format::PcaOptions>& pca,
                        const std::optional<bake_format::LightMapPcaOptions>& light_map_pca) {
  const auto start = std::chrono::steady_clock::now();
  check_pca_input(pca);
  if (light_map_pca) check_light_map_pca_input(*light_map_pca);
  if (shard_dirs.empty()) {
    throw InputError("merge needs at least one shard directory. Fix: skylit-bake merge DIR... -o OUT_DIR");
  }
  std::optional<bake_format::Plan> plan;
  for (const fs::path& dir : shard_dirs) {
    const bake_format::PartStore store(dir / "parts");
    const std::optional<bake_format::Plan> shard_plan = store.read_plan();
    if (!shard_plan) {
      throw InputError("'" + dir.string() + "' holds no bake parts (no parts/plan.json). Fix: name the "
                       "directories that skylit-bake --shard wrote");
    }
    if (!plan) {
      plan = shard_plan;
    } else if (!(*plan == *shard_plan)) {
      throw InputError("'" + dir.string() + "' was baked from a different plan than '" + shard_dirs[0].string() +
                       "': " + plan->difference(*shard_plan) + ". Fix: bake every shard with the same site and options");
    }
  }
  const geom::Dome dome(plan->frequency);
  ensure_writable_directory(out_dir);
  if (fs::exists(out_dir / "manifest.json")) {
    throw InputError("output directory '" + out_dir.string() +
                     "' already holds a finished bake. Fix: choose another directory with -o");
  }
  const bake_format::PartStore out_parts(out_dir / "parts");
  fs::create_directories(out_parts.dir());
  if (const auto existing = out_parts.read_plan(); existing && !(*existing == *plan)) {
    throw InputError("'" + out_dir.string() + "' holds parts of a different bake: " + existing->difference(*plan) +
                     ". Fix: choose another directory with -o");
  }
  out_parts.write_plan(*plan);

  std::vector<int> missing;
  for (int i = 0; i < dome.face_count(); ++i) {
    if (out_parts.has(i, *plan)) continue;
    bool found = false;
    for (const fs::path& dir : shard_dirs) {
      const bake_format::PartStore store(dir / "parts");
      if (store.has(i, *plan)) {
        if (fs::weakly_canonical(store.dir()) != fs::weakly_canonical(out_parts.dir())) {
          out_parts.write(store.read(i, *plan));  // read checks the checksum
        }
        found = true;
        break;
      }
    }
    if (!found) missing.push_back(i);
  }
  if (!missing.empty()) {
    std::ostringstream list;
    for (std::size_t k = 0; k < missing.size() && k < 20; ++k) list << (k ? ", " : "") << missing[k];
    if (missing.size() > 20) list << ", … (" << missing.size() << " in all)";
    throw InputError("merge: " + std::to_string(missing.size()) + " of " + std::to_string(dome.face_count()) +
                     " faces are in none of the shards (faces " + list.str() +
                     "). Fix: run the missing shards (skylit-bake SITE -o DIR --shard I/N) and merge again");
  }

  const std::optional<LightMapOptions> light_map =
      plan->light_map.texel > 0.0
          ? std::optional<LightMapOptions>(LightMapOptions{plan->light_map.texel, plan->light_map.min_area, plan->light_map.min_across})
          : std::nullopt;
  const LoadedSite loaded = load(plan->site_file, refine_options_of(*plan), plan->vertex_fit, light_map, 0, log);
  if (sha256_file(loaded.site.model) != plan->model_sha256 || loaded.mesh.vertex_count() != plan->vertex_count ||
      loaded.mesh.triangle_count() != plan->triangle_count) {
    throw InputError("the model '" + loaded.site.model.string() +
                     "' changed since the shards were baked. Fix: re-bake the shards");
  }
  if (light_map_pca && !loaded.light_map) {
    throw InputError("merge: --light-map-components was given but the shards were baked without a light map. Fix: leave it out");
  }
  bake_format::Manifest manifest = manifest_for(*plan, dome);
  BakeSummary summary;
  summary.faces_total = dome.face_count();
  summary.faces_skipped = dome.face_count();
  summary.bytes_written = finalize(out_dir, manifest, loaded, dome, previews, pca, light_map_pca, log);
  summary.complete = true;
  summary.seconds = seconds_since(start);
  log_summary(log, *plan, summary, out_dir);
  return summary;
}

void compress_bake(const fs::path& bake_dir, const std::optional<bake_format::PcaOptions>& options,
                   const std::optional<bake_format::LightMapPcaOptions>& light_map_pca, std::FILE* log) {
  if (!options && !light_map_pca) {
    throw InputError("compress needs --pca-components K, --pca-variance F or --pca-max-error E (the planes), or "
                     "--light-map-components K (the light map)");
  }
  check_pca_input(options);
  if (light_map_pca) check_light_map_pca_input(*light_map_pca);
  const bake_format::VerifyReport report = bake_format::verify(bake_dir);
  if (!report.ok) {
    std::string problems;
    for (const std::string& p : report.problems) problems += "\n  " + p;
    throw InputError(bake_dir.string() + " is not a verified bake:" + problems);
  }
  bake_format::Manifest manifest = report.manifest;
  if (light_map_pca && !manifest.light_map) {
    throw InputError(bake_dir.string() + " has no light map to compress. Fix: bake it with --light-map TEXEL, or leave out "
                     "--light-map-components");
  }
  if (light_map_pca && !manifest.light_map->has_full_form()) {
    throw InputError(bake_dir.string() + " keeps only its light map's PCA form (K = " + std::to_string(manifest.light_map->pca->components) +
                     "; it was baked with --light-map-pca-only), so there is nothing to fit another K to. Fix: bake again "
                     "with --light-map-components K, or without --light-map-pca-only to compress it later");
  }
  std::vector<fs::path> dropped;  // the light map's full form, with --light-map-pca-only
  for (bake_format::PlaneRecord& record : manifest.planes) {
    if (!options) break;
    if (record.pca) {
      const std::set<std::string> old{record.pca->file, record.pca->coefficients};
      std::erase_if(manifest.files, [&](const bake_format::FileRecord& f) { return old.count(f.path) > 0; });
    }
    const bake_format::ImageStack stack = bake_format::read_exr_stack(bake_dir / record.file);
    write_pca_form(bake_dir, manifest, record, stack, *options, log);
    manifest.files.push_back({record.pca->file, 0, ""});
    manifest.files.push_back({record.pca->coefficients, 0, ""});
  }
  if (light_map_pca) {
    if (const auto& old = manifest.light_map->pca) {
      const std::set<std::string> names{old->weights_file, old->vectors_file, old->ground_weights_file, old->ground_vectors_file};
      std::erase_if(manifest.files, [&](const bake_format::FileRecord& f) { return names.count(f.path) > 0; });
    }
    const bake_format::LightMapArrays full = bake_format::read_light_map(bake_dir, manifest);
    write_light_map_pca_form(bake_dir, manifest, full.layout, full.transfer, full.ground, *light_map_pca, log);
    if (!light_map_pca->keep_full_form) {
      for (std::string* file : {&manifest.light_map->transfer_file, &manifest.light_map->ground_file}) {
        if (file->empty()) continue;
        std::erase_if(manifest.files, [&](const bake_format::FileRecord& f) { return f.path == *file; });
        dropped.push_back(bake_dir / *file);
        file->clear();
      }
    }
  }
  // The manifest first: a crash between leaves files it does not list, never a list without files.
  bake_format::write_manifest(bake_dir, manifest);
  for (const fs::path& file : dropped) fs::remove(file);
  if (log && !dropped.empty()) {
    std::fprintf(log, "skylit-bake: removed the light map's full form (%zu file(s)); the bake keeps its PCA form\n", dropped.size());
  }
}

}  // namespace skylit::baker
