#pragma once
// A bake from a site description to a verified bake directory: planning, sharding, resuming,
// the per-face work, and the final assembly (see docs/bake-format.md and docs/baker.md).
#include <cstdio>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/pca.hpp"
#include "skylit/baker/light_map.hpp"
#include "skylit/baker/refine.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/geom/dome_basis.hpp"

namespace skylit::baker {

struct Shard {
  int index = 0;  // 0-based
  int count = 1;
};

struct BakeOptions {
  std::filesystem::path site_file;
  std::filesystem::path out_dir;
  std::optional<int> frequency;            // overrides the site's dome.frequency
  std::optional<geom::DomeBasis> basis;    // overrides the site's dome.basis
  int samples = 1;                         // per face: 1 = face centre (the paper), K = stratified;
                                           // the corners basis needs K ≥ 3
  std::string method = "raster";           // raster | raytrace | auto (resolve_method)
  std::optional<std::pair<int, int>> resolution;  // sets every plane to W×H texels
  std::optional<Shard> shard;              // bake only faces i with i % count == index
  bool resume = false;                     // continue an interrupted bake in out_dir
  bool force = false;                      // replace a complete or interrupted bake in out_dir
  int shadow_map_resolution = 0;           // raster; 0 = chosen from the plane texel size
  int threads = 0;                         // raytrace; 0 = all cores
  bool previews = true;
  std::filesystem::path shader_dir;        // empty = default search
  // Also store each plane's basis compressed by principal components (bake/pca.hpp).
  std::optional<bake_format::PcaOptions> pca;
  std::string preset;                      // the preset the settings came from (recorded in the plan)
  // Directions per vertex for the ground's transfer (ground_transfer.hpp); 0: no ground layer.
  int ground_samples = 256;
  // Splits the model where the light changes before the faces are traced (refine.hpp);
  // tolerance 0: the model as the site loads it.
  RefineOptions refine;
  // Least-squares vertex values (vertex_fit.hpp): the light traced at this many² points inside
  // every triangle too, and each vertex's transfer fitted to it; 0: each vertex's own light.
  int vertex_fit = 0;
  // A light map over the model's flat regions (light_map.hpp), traced with the vertices; none:
  // the vertices alone carry the building's light.
  std::optional<LightMapOptions> light_map;
  // Also store the light map's transfer compressed chart by chart (bake_format/light_map.hpp,
  // "The PCA form"); needs light_map.
  std::optional<bake_format::LightMapPcaOptions> light_map_pca;
};

struct BakeSummary {
  bool complete = false;                   // false for a shard: parts written, merge pending
  int faces_baked = 0;                     // by this run
  int faces_skipped = 0;                   // already done (--resume)
  int faces_total = 0;
  double seconds = 0.0;
  std::uint64_t bytes_written = 0;         // data files of the finished bake
  std::string engine_description;
};

// Reads the shard from SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT (SLURM_ARRAY_TASK_MIN
// subtracted) or JOB_COMPLETION_INDEX with SKYLIT_SHARD_COUNT; nullopt when none is set.
std::optional<Shard> shard_from_environment();
Shard parse_shard(const std::string& text);  // "I/N", 0 ≤ I < N; InputError otherwise

// The engine a bake with options.method runs: raster or raytrace as given; for auto, the engine
// of the interrupted bake in out_dir (its plan must match), else choose_engine()'s, saying which
// and why in one info line.
std::string resolve_method(const BakeOptions& options);

// Runs the bake; InputError for anything the user can fix. Progress and the summary go to `log`
// (null: nowhere, for -q), the engine chosen to spdlog; the plan records the engine run.
BakeSummary run_bake(const BakeOptions& options, std::FILE* log = stderr);

// Joins the parts of shard directories (all baked from the same plan) into out_dir and finishes
// the bake there. InputError when plans differ or faces are missing (listing them). `log` may be null.
BakeSummary merge_bakes(const std::vector<std::filesystem::path>& shard_dirs,
                        const std::filesystem::path& out_dir, bool previews,
                        std::FILE* log = stderr, const std::optional<bake_format::PcaOptions>& pca = std::nullopt,
                        const std::optional<bake_format::LightMapPcaOptions>& light_map_pca = std::nullopt);

// Adds (or replaces) the PCA form of every plane of a finished bake (bake/pca.hpp), and of its
// light map with light_map_pca, and rewrites its manifest. InputError for a directory that is not
// a verified bake, for light_map_pca on a bake without a light map, or for neither given. One line
// per plane (and for the light map) on `log` (null: none).
void compress_bake(const std::filesystem::path& bake_dir, const std::optional<bake_format::PcaOptions>& options,
                   const std::optional<bake_format::LightMapPcaOptions>& light_map_pca = std::nullopt, std::FILE* log = stderr);

// The sample directions of dome face `face`: its centre for samples == 1, else stratified.
std::vector<geom::Vec3> face_sample_directions(const geom::Dome& dome, int face, int samples);

// Sets the engine to face `face`'s samples weighted by each of its layers' basis functions, up to
// kEngineLayers layers at a time (a basis with more functions per face is traced in groups, each
// over the same directions), and calls traced(first, count) after each group: the engine then
// gives layers first … first + count − 1 of the face.
void trace_face(VisibilityEngine& engine, const geom::Dome& dome, const geom::CornerWeights& corner_weights,
                geom::DomeBasis basis, int face, int samples, const std::function<void(std::size_t first, std::size_t count)>& traced);

// The fewest samples per face a basis can resolve: one per layer function (1, 3 or 6). One
// direction (the centre) weighs a face's functions alike and cannot tell their visibility apart.
inline int min_samples_per_face(geom::DomeBasis basis) { return geom::layers_per_face(basis); }

// A_{j,l} of every layer of every face for a surface with normal n (faces: the exact cosine
// integral of the face; corners and quadratics: geom::layer_cosine_integrals), layer-major as the
// bake stores them. `quadratures` (one per face, empty for faces) from face_quadratures.
std::vector<geom::FaceQuadrature> face_quadratures(const geom::Dome& dome, geom::DomeBasis basis);
std::vector<double> layer_cosine_integrals(const geom::Dome& dome, geom::DomeBasis basis,
                                           const std::vector<geom::FaceQuadrature>& quadratures, const geom::Vec3& n);

}  // namespace skylit::baker
