// skylit-bake: bakes a site's basis shadow images and transfer vectors, verifies and merges bakes.
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <regex>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "skylit/base/error.hpp"
#include "skylit/base/presets.hpp"
#include "skylit/baker/preset.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/baker/error_budget.hpp"
#include "skylit/baker/wall_planes.hpp"
#include "command_line.hpp"

namespace {

std::pair<int, int> parse_resolution(const std::string& text) {
  static const std::regex pattern(R"((\d{1,6})[xX](\d{1,6}))");
  std::smatch match;
  if (!std::regex_match(text, match, pattern)) {
    throw skylit::InputError("option --resolution: got '" + text +
                             "'. Fix: write WxH, e.g. --resolution 512x256");
  }
  return {std::stoi(match[1]), std::stoi(match[2])};
}

int run_verify(const std::filesystem::path& dir) {
  const skylit::bake_format::VerifyReport report = skylit::bake_format::verify(dir);
  if (report.ok) {
    const auto& m = report.manifest;
    std::printf("%s: OK — schema %d, %s, dome ν=%d (%zu faces, %s basis, %zu layers), %zu plane(s), %zu file(s) "
                "verified\n",
                dir.string().c_str(), m.schema_version, m.generator.c_str(), m.plan.frequency, m.faces.size(),
                std::string(skylit::geom::basis_name(m.plan.basis)).c_str(), m.layer_count(), m.planes.size(),
                m.files.size());
    return 0;
  }
  std::fprintf(stderr, "%s: NOT a valid bake (%zu problem(s)):\n", dir.string().c_str(), report.problems.size());
  for (const std::string& p : report.problems) std::fprintf(stderr, "  - %s\n", p.c_str());
  return 1;
}

// Everything the command line sets: the bake's options and what the subcommands take.
struct CommandLine {
  skylit::baker::BakeOptions options;
  skylit::baker::LightMapOptions light_map{0.0, 0.1, 10};  // texel 0: none
  std::string site, out, resolution, shard, basis;
  int frequency = 0;
  bool quiet = false;
  bool no_previews = false;
  skylit::baker::ErrorBudgetOptions budget;
  std::string preset_name, presets_file = skylit::default_presets_file().string();
  // The PCA form (docs/bake-format.md): K is the smallest count meeting every option given.
  skylit::bake_format::PcaOptions pca;
  CLI::App* verify = nullptr;
  std::string verify_dir;
  CLI::App* merge = nullptr;
  std::vector<std::string> merge_dirs;
  std::string merge_out;
  bool merge_no_previews = false;
  CLI::App* walls = nullptr;
  std::string walls_site, walls_out;
  skylit::baker::WallPlaneOptions walls_options;
  CLI::App* compress = nullptr;
  std::string compress_dir;

  skylit::bake_format::LightMapPcaOptions light_map_pca{0, 0.0, true};  // components 0: none
  std::optional<skylit::bake_format::LightMapPcaOptions> wanted_light_map_pca() const {
    if (light_map_pca.components == 0) {
      if (!light_map_pca.keep_full_form) {
        throw skylit::InputError("option --light-map-pca-only: given without the PCA form. Fix: add --light-map-components K "
                                 "(e.g. 32), or leave it out");
      }
      return std::nullopt;
    }
    return light_map_pca;
  }
  std::optional<skylit::bake_format::PcaOptions> wanted_pca() const {
    if (!pca.components && !pca.variance && !pca.max_error) return std::nullopt;
    return pca;
  }
};

void add_light_map_pca_options(CLI::App& to, skylit::bake_format::LightMapPcaOptions& pca) {
  to.add_option("--light-map-components", pca.components,
                "also store the light map's transfer compressed chart by chart to K components, so that a new sky sums "
                "K + 1 values per texel instead of every layer (docs/baker.md); 0: only the full form")
      ->capture_default_str();
  to.add_option("--light-map-sky-correlation", pca.sky_correlation_deg,
                "degrees: with --light-map-components, the components that matter for skies whose radiance is correlated "
                "over this angle; 0: every layer alike")
      ->capture_default_str();
  to.add_flag_function(
      "--light-map-pca-only,!--light-map-keep-full",
      [&pca](std::int64_t count) { pca.keep_full_form = count < 0; },
      "with --light-map-components: leave the light map's full form out of the bake (most of its size; compress "
      "cannot then fit another K); --light-map-keep-full keeps it where a preset would not");
}

void add_pca_options(CLI::App& to, skylit::bake_format::PcaOptions& pca) {
  to.add_option("--pca-components", pca.components, "also store the basis compressed to at least K principal components");
  to.add_option("--pca-variance", pca.variance, "... keeping at least this fraction of the variance (0 < F <= 1)");
  to.add_option("--pca-max-error", pca.max_error, "... with |T - T_full| at most E for every sky (E > 0)");
  to.add_option("--pca-sky-correlation", pca.sky_correlation_deg,
                "components for skies whose radiance correlates over this many degrees (0: plain PCA)");
  to.add_option("--pca-tile", pca.tile,
                "clustered PCA: each tile of N x N texels gets its own components (0: the whole plane)");
}

void add_bake_options(CLI::App& app, CommandLine& c) {
  app.add_option("site", c.site, "site description (YAML)")->check(CLI::ExistingFile);
  app.add_option("-o,--output", c.out, "bake directory to write");
  app.add_option("--frequency", c.frequency, "dome frequency ν (even; overrides the site's)");
  app.add_option("--basis", c.basis, "radiance basis: faces (one layer per face), corners (three, linear across "
                                     "the face; needs --samples >= 3) or quadratics (six, quadratic across the "
                                     "face; needs --samples >= 6); overrides the site's dome.basis");
  app.add_option("--samples", c.options.samples, "samples per face: 1 = face centre (the paper), K > 1 = area light")
      ->capture_default_str();
  app.add_option("--ground-samples", c.options.ground_samples,
                 "directions per model vertex for the ground's light (the ground layer, docs/method.md); 0: none")
      ->check(CLI::Range(0, 1 << 20))
      ->capture_default_str();
  app.add_option("--refine", c.options.refine.tolerance,
                 "split the model where its light changes across a triangle by more than this share of a uniform "
                 "sky's light (e.g. 0.05; docs/baker.md); 0: the model as it is")
      ->capture_default_str();
  app.add_option("--refine-rounds", c.options.refine.rounds, "rounds of splits at most, with --refine")
      ->check(CLI::Range(1, 12))
      ->capture_default_str();
  app.add_option("--refine-min-edge", c.options.refine.min_edge,
                 "metres: an edge shorter than twice this is not split, with --refine")
      ->capture_default_str();
  app.add_option("--vertex-fit", c.options.vertex_fit,
                 "trace the light at N² points inside every triangle too and fit each vertex's transfer to it, so that "
                 "what is interpolated across a face matches its light (docs/baker.md); 0: each vertex's own light")
      ->check(CLI::Range(0, 16))
      ->capture_default_str();
  app.add_option("--light-map", c.light_map.texel,
                 "metres per texel of a light map over the model's flat regions: where a triangle lies on one, the "
                 "building takes its sky's and ground's light from the map's texels instead of its corners "
                 "(docs/baker.md); 0: none")
      ->capture_default_str();
  app.add_option("--light-map-min-area", c.light_map.min_area, "m²: a flat region smaller than this stays with its vertices, with --light-map")
      ->capture_default_str();
  app.add_option("--light-map-min-across", c.light_map.min_across,
                 "with --light-map: a chart narrower than this many texels takes finer ones, as many across it, down to a "
                 "quarter of the texel; 0: every chart the same")
      ->capture_default_str();
  c.options.method = "auto";
  app.add_option("--method", c.options.method,
                 "auto (raster on a GPU, raytrace where OpenGL ES runs in software), raster (OpenGL ES) or raytrace "
                 "(Embree, the reference)")
      ->capture_default_str();
  app.add_option("--resolution", c.resolution, "set every plane to WxH texels");
  app.add_option("--shard", c.shard, "bake slice I of N (I/N, 0-based); also from SLURM_ARRAY_TASK_ID/COUNT or "
                                     "JOB_COMPLETION_INDEX with SKYLIT_SHARD_COUNT");
  app.add_flag("--resume", c.options.resume, "continue an interrupted bake in the output directory");
  app.add_flag("--force", c.options.force, "replace a bake already in the output directory");
  app.add_option("--shadow-map", c.options.shadow_map_resolution, "raster: shadow-map resolution (default: from the planes)");
  app.add_option("--threads", c.options.threads, "raytrace: threads (default: all cores)");
  app.add_option("--shader-dir", c.options.shader_dir, "where the GLSL shaders are (default: installed or source tree)");
  app.add_option("--error-budget", c.budget.budget,
                 "pick the cheapest dome (frequency, samples) whose shadow ratios stay within this RMS error of a "
                 "denser bake over clear and overcast test skies (docs/baker.md)");
  app.add_option("--latitude", c.budget.latitude_deg, "with --error-budget: the site's latitude for the test skies' sun")
      ->capture_default_str();
  app.add_option("--preset", c.preset_name,
                 "bake with a preset's settings: fast, balanced, accurate (docs/presets.md); --frequency, --basis, "
                 "--samples and --pca-components given too override it");
  app.add_option("--presets", c.presets_file, "the presets file for --preset")->capture_default_str();
  app.add_flag("--no-previews", c.no_previews, "skip the preview contact sheets");
  app.add_flag("-q,--quiet", c.quiet, "only warnings and errors");
  add_pca_options(app, c.pca);
  add_light_map_pca_options(app, c.light_map_pca);
}

void add_subcommands(CLI::App& app, CommandLine& c) {
  c.verify = app.add_subcommand("verify", "check a bake directory: version, files, checksums, shapes");
  c.verify->add_option("bake_dir", c.verify_dir, "bake directory")->required()->check(CLI::ExistingDirectory);

  c.merge = app.add_subcommand("merge", "join the shards of a bake into one finished bake");
  c.merge->add_option("shard_dirs", c.merge_dirs, "shard directories")->required()->check(CLI::ExistingDirectory);
  c.merge->add_option("-o,--output", c.merge_out, "finished bake directory")->required();
  c.merge->add_flag("--no-previews", c.merge_no_previews, "skip the preview contact sheets");
  add_pca_options(*c.merge, c.pca);
  add_light_map_pca_options(*c.merge, c.light_map_pca);

  c.compress = app.add_subcommand("compress", "add (or replace) the PCA form of every plane of a finished bake, or of its light map");
  c.compress->add_option("bake_dir", c.compress_dir, "bake directory")->required()->check(CLI::ExistingDirectory);
  add_pca_options(*c.compress, c.pca);
  add_light_map_pca_options(*c.compress, c.light_map_pca);

  c.walls = app.add_subcommand("walls", "write the site with virtual planes on the flat faces whose vertices cannot carry "
                                         "their light (docs/baker.md)");
  c.walls->add_option("site", c.walls_site, "site YAML")->required()->check(CLI::ExistingFile);
  c.walls->add_option("-o,--output", c.walls_out,
                      "the site with the planes added (YAML); a picture of the vertices' error by flat region beside it (.png)")
      ->required();
  c.walls->add_option("--count", c.walls_options.count, "planes at most (the site's virtual planes and these: at most 8)")
      ->capture_default_str();
  c.walls->add_option("--texel", c.walls_options.texel, "metres per texel")->capture_default_str();
  c.walls->add_option("--refine", c.walls_options.refine.tolerance, "the model refined as skylit-bake --refine will refine it");
  c.walls->add_option("--vertex-fit", c.walls_options.vertex_fit, "its vertices fitted as skylit-bake --vertex-fit will fit them")
      ->check(CLI::Range(0, 16));
  c.walls->add_option("--min-area", c.walls_options.min_area, "m²: smaller flat regions keep their vertices")->capture_default_str();
  c.walls->add_option("--min-error", c.walls_options.min_error,
                      "a region whose vertices' error over test skies is under this (a share of E_h) gets no plane")
      ->capture_default_str();

  // -q after a subcommand too, as a user types it.
  for (CLI::App* sub : {c.verify, c.merge, c.compress, c.walls}) sub->add_flag("-q,--quiet", c.quiet, "only warnings and errors");
}

// --preset fills in what the command line does not give.
void apply_preset(const CLI::App& app, CommandLine& c) {
  const skylit::baker::BakePreset preset =
      skylit::baker::load_bake_preset(skylit::PresetsFile(c.presets_file), c.preset_name);
  if (!app.count("--frequency")) c.frequency = preset.frequency;
  if (!app.count("--basis")) c.basis = std::string(skylit::geom::basis_name(preset.basis));
  if (!app.count("--samples")) c.options.samples = preset.samples;
  if (!c.wanted_pca() && preset.pca_components > 0) {
    c.pca.components = preset.pca_components;
    if (!app.count("--pca-tile")) c.pca.tile = preset.pca_tile;
  }
  if (!app.count("--refine")) c.options.refine.tolerance = preset.refine;
  if (!app.count("--vertex-fit")) c.options.vertex_fit = preset.vertex_fit;
  if (!app.count("--light-map")) c.light_map.texel = preset.light_map;
  if (!app.count("--light-map-min-area")) c.light_map.min_area = preset.light_map_min_area;
  if (!app.count("--light-map-min-across")) c.light_map.min_across = preset.light_map_min_across;
  if (!app.count("--light-map-components")) c.light_map_pca.components = c.light_map.texel > 0 ? preset.light_map_components : 0;
  if (!app.count("--light-map-pca-only")) {  // nor --light-map-keep-full, its other name
    c.light_map_pca.keep_full_form = !preset.light_map_pca_only || c.light_map_pca.components == 0;  // no PCA form: the full form
  }
  c.options.preset = preset.name;
  spdlog::info("preset {} ({}): frequency {}, basis {}, samples {}, PCA components {}{}{}{}{}", preset.name, c.presets_file,
               c.frequency, c.basis, c.options.samples, c.pca.components ? std::to_string(*c.pca.components) : "none",
               c.pca.tile > 0 ? " in tiles of " + std::to_string(c.pca.tile) + " texels" : "",
               c.options.refine.tolerance > 0 ? fmt::format(", refined at {:g}", c.options.refine.tolerance) : "",
               c.options.vertex_fit > 0 ? fmt::format(", vertices fitted to {}² points per triangle", c.options.vertex_fit) : "",
               c.light_map.texel > 0 ? fmt::format(", a light map of {:g} m texels{}", c.light_map.texel,
                                                   c.light_map_pca.components > 0
                                                       ? fmt::format(" and its PCA form of {} components{}", c.light_map_pca.components,
                                                                     c.light_map_pca.keep_full_form ? "" : " only")
                                                       : "")
                                     : "");
}

// A bake of SITE into -o, plain or picked by --error-budget.
int run_bake(const CLI::App& app, CommandLine& c, std::FILE* log) {
  if (c.site.empty() || c.out.empty()) {
    std::fprintf(stderr,
                 "%s\nskylit-bake: error: a bake needs SITE and -o BAKE_DIR (or a subcommand: verify, merge, "
                 "compress, walls)\n",
                 app.help().c_str());
    return 2;
  }
  skylit::baker::BakeOptions& options = c.options;
  options.site_file = c.site;
  options.out_dir = c.out;
  if (!c.preset_name.empty()) apply_preset(app, c);
  options.pca = c.wanted_pca();
  if (c.frequency != 0 || app.count("--frequency")) options.frequency = c.frequency;
  if (app.count("--basis") || !c.preset_name.empty()) {
    options.basis = skylit::geom::parse_basis(c.basis);
    if (!options.basis) {
      throw skylit::InputError("option --basis: got '" + c.basis + "'. Fix: use --basis faces, corners or quadratics");
    }
  }
  if (!c.resolution.empty()) options.resolution = parse_resolution(c.resolution);
  options.shard = c.shard.empty() ? skylit::baker::shard_from_environment()
                                  : std::optional(skylit::baker::parse_shard(c.shard));
  options.previews = !c.no_previews;
  if (c.light_map.texel != 0.0) options.light_map = c.light_map;
  options.light_map_pca = c.wanted_light_map_pca();
  if (app.count("--error-budget")) {
    if (app.count("--samples")) {
      throw skylit::InputError("options --error-budget and --samples: the budget picks the samples. Fix: drop one");
    }
    skylit::baker::run_error_budget_bake(options, c.budget, log);
    return 0;
  }
  if (app.count("--latitude")) {
    throw skylit::InputError("option --latitude only sets the test skies of --error-budget. Fix: drop it, or add "
                             "--error-budget E");
  }
  skylit::baker::run_bake(options, log);
  return 0;
}

int run(const CLI::App& app, CommandLine& c, std::FILE* log) {
  if (*c.verify) return run_verify(c.verify_dir);
  if (*c.merge) {
    std::vector<std::filesystem::path> dirs(c.merge_dirs.begin(), c.merge_dirs.end());
    skylit::baker::merge_bakes(dirs, c.merge_out, !c.merge_no_previews, log, c.wanted_pca(), c.wanted_light_map_pca());
    return 0;
  }
  if (*c.walls) {
    skylit::baker::add_wall_planes(c.walls_site, c.walls_out, c.walls_options, log);
    return 0;
  }
  if (*c.compress) {
    skylit::baker::compress_bake(c.compress_dir, c.wanted_pca(), c.wanted_light_map_pca(), log);
    return 0;
  }
  return run_bake(app, c, log);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"skylit-bake: basis shadow images and transfer vectors for a site",
               "skylit-bake"};
  skylit::tools::add_version_flag(app);
  CommandLine command_line;
  add_bake_options(app, command_line);
  add_subcommands(app, command_line);
  if (const auto status = skylit::tools::parse_command_line(app, argc, argv)) return *status;

  // Progress and summaries go to `log`; -q leaves warnings and errors only.
  std::FILE* const log = command_line.quiet ? nullptr : stderr;
  spdlog::set_level(command_line.quiet ? spdlog::level::warn : spdlog::level::info);
  spdlog::set_pattern("skylit-bake: %^%l%$: %v");
  try {
    return run(app, command_line, log);
  } catch (const skylit::InputError& e) {
    std::fprintf(stderr, "skylit-bake: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-bake: internal error: %s\n", e.what());
    return 3;
  }
}
