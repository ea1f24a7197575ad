// skylit-bench: measurements of the sky stage. `trade`: the trade table (study/trade.hpp,
// docs/trade.md).
#include <filesystem>
#include <cstdio>
#include <exception>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "command_line.hpp"
#include "skylit/base/error.hpp"
#include "skylit/study/trade.hpp"

using namespace skylit;
using study::TradeOptions;
using study::run_trade;

int main(int argc, char** argv) {
  CLI::App app{"skylit-bench: measurements of the sky stage", "skylit-bench"};
  tools::add_version_flag(app);
  bool quiet = false;
  tools::add_quiet_flag(app, quiet);
  app.fallthrough();  // -q after the subcommand too, as a user types it
  app.require_subcommand(1);
  TradeOptions o;
  auto* trade = app.add_subcommand("trade", "the trade table: error against cost over a grid of settings (docs/trade.md)");
  trade->add_option("--site", o.site_file)->capture_default_str();
  trade->add_option("--calib", o.sky_calib, "sky camera the skies are rendered into")->capture_default_str();
  trade->add_option("--hmd-camera", o.hmd_calib, "HMD camera of the composited frame")->capture_default_str();
  trade->add_option("--skies", o.skies_dir, "folder of equirectangular .exr skies")->capture_default_str();
  trade->add_option("--sky", o.skies, "only these skies (file stems)")->delimiter(',');
  trade->add_option("--out", o.out_dir, "bakes (cached) and results")->capture_default_str();
  trade->add_option("--frequencies", o.frequencies, "dome frequencies ν")->delimiter(',')->capture_default_str();
  trade->add_option("--bases", o.bases, "faces, corners, quadratics")->delimiter(',')->capture_default_str();
  trade->add_option("--samples", o.samples, "samples per face")->delimiter(',')->capture_default_str();
  trade->add_option("--texel-scales", o.texel_scales, "plane resolution divisors (1: the site's)")->delimiter(',')->capture_default_str();
  trade->add_option("--refine", o.refines,
                    "skylit-bake --refine per bake: split the model where its light changes by more than this share of "
                    "E_h (0: the model as it is)")
      ->delimiter(',')
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  trade->add_option("--vertex-fits", o.vertex_fits,
                    "skylit-bake --vertex-fit per bake: each vertex's transfer fitted to the light at N² points inside its "
                    "triangles (0: its own light)")
      ->delimiter(',')
      ->check(CLI::Range(0, 16))
      ->capture_default_str();
  trade->add_option("--light-maps", o.light_maps,
                    "skylit-bake --light-map per bake: a light map of this texel (m) over the model's flat regions, the "
                    "building inside the triangles shown from it where it covers them (0: none)")
      ->delimiter(',')
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  trade->add_option("--light-map-min-area", o.light_map_min_area, "m², with --light-maps (skylit-bake --light-map-min-area)")
      ->capture_default_str();
  trade->add_option("--light-map-min-across", o.light_map_min_across, "texels, with --light-maps (skylit-bake --light-map-min-across)")
      ->capture_default_str();
  trade->add_option("--light-map-components", o.light_map_components,
                    "with --light-maps: each light map also in its PCA form of K components per chart, which the frame "
                    "and the error then use (skylit-bake --light-map-components); 0: the full form")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  trade->add_option("--light-map-precision", o.light_map_precision,
                    "with --light-maps: how the compositor holds the light map's values (render.light_map_precision): float, "
                    "or half (each rounded to the nearest half float), in the error, the frame and the service alike")
      ->transform(CLI::CheckedTransformer(std::map<std::string, skylit::render::LightMapPrecision>{
          {"float", skylit::render::LightMapPrecision::Float}, {"half", skylit::render::LightMapPrecision::Half}}));
  trade->add_option("--forms", o.forms, "full, lean, cropped, pcaK, pcaKtN (clustered PCA, tiles of N texels)")->delimiter(',')->capture_default_str();
  trade->add_option("--bits", o.bits, "layer bit depth: 16 (half), 8 (unorm8; not with PCA)")->delimiter(',')->capture_default_str();
  trade->add_option("--sun", o.sun, "sun separation: on, off")->delimiter(',')->capture_default_str();
  trade->add_option("--live-seconds", o.live_seconds,
                    "also run skylit-live on each setting's bake for this long (a 60 Hz camera, the sky changing every "
                    "--sky-interval seconds) and report its own frame rate")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  trade->add_option("--sources", o.sources,
                    "separated sources at most with the sun on (sky.max_sources): 1, the sun alone; N, the sun and lamps")
      ->delimiter(',')
      ->capture_default_str();
  trade->add_option("--ground-albedo", o.ground_albedo,
                    "the building's reference has a lambertian ground of this albedo; its error is given with the bake's "
                    "ground layer (render.ground_light) and without (0: no ground)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  trade->add_option("--skip-thresholds", o.skip_thresholds, "S threshold (blend.skip_threshold), T units")
      ->delimiter(',')
      ->capture_default_str();
  trade->add_option("--change-thresholds", o.change_thresholds,
                    "ΔS threshold (blend.change_threshold), T units: measured on the sky sequence (--sequence); a still "
                    "sky is blended once")
      ->delimiter(',')
      ->capture_default_str();
  trade->add_option("--smoothings", o.smoothings, "sky.smoothing, seconds: measured on the sky sequence (--sequence); no "
                    "effect on a still sky")
      ->delimiter(',')
      ->capture_default_str();
  trade->add_option("--render-scales", o.render_scales, "the compositor's render scale")->delimiter(',')->capture_default_str();
  trade->add_option("--frame-width", o.frame_width)->capture_default_str();
  trade->add_option("--frame-height", o.frame_height)->capture_default_str();
  trade->add_option("--blend-repeats", o.blend_repeats, "blend timings per setting (median)")->check(CLI::Range(1, 1000))->capture_default_str();
  trade->add_option("--frame-repeats", o.frame_repeats, "frame timings per setting (median)")->check(CLI::Range(1, 1000))->capture_default_str();
  trade->add_option("--supersample", o.supersample, "fisheye rendering: sub-pixels per axis")->capture_default_str();
  trade->add_option("--reference-supersample", o.reference_supersample, "reference: N×N sub-directions near bright pixels")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  trade->add_option("--threads", o.threads, "CPU blend threads")->capture_default_str();
  trade->add_option("--timing-scale", o.timing_scale,
                    "blend time and GPU memory for planes at the site's resolution divided by this (the swept bake "
                    "upsampled)")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  trade->add_option("--clock", o.clock,
                    "whole-frame time: cpu (process CPU time over --cores: unaffected by other load) or wall")
      ->check(CLI::IsMember({"cpu", "wall"}))
      ->capture_default_str();
  trade->add_option("--sky-interval", o.sky_interval,
                    "seconds between sky changes: the blend's time spread over the frames between (0: a blend in every "
                    "frame, the worst frame)")
      ->check(CLI::Range(0.0, 3600.0))
      ->capture_default_str();
  trade->add_option("--cores", o.cores, "--clock cpu: the cores the work spreads over")->check(CLI::Range(1, 1024))->capture_default_str();
  trade->add_flag("--sequence", o.sequence,
                  "also run every setting over a sky sequence (a clear sky over time with a passing cloud, 1 sky per "
                  "second) against each frame's reference: the change threshold's and the smoothing's error and re-blends");
  trade->add_option("--sequence-frames", o.sequence_frames, "skies in the sequence, 1 s apart")
      ->check(CLI::Range(2, 3600))
      ->capture_default_str();
  trade->add_option("--sequence-start", o.sequence_start, "UTC of the first sky (YYYY-MM-DDTHH:MM:SSZ)")->capture_default_str();
  trade->add_option("--sequence-lat", o.sequence_lat, "latitude of the sequence's sun, degrees north")
      ->check(CLI::Range(-90.0, 90.0))
      ->capture_default_str();
  trade->add_option("--sequence-lon", o.sequence_lon, "longitude of the sequence's sun, degrees east")
      ->check(CLI::Range(-180.0, 180.0))
      ->capture_default_str();
  trade->add_option("--sequence-cloud", o.sequence_cloud,
                    "depth of the passing cloud: the sun dimmed to 1 − this at the middle of the sequence")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  trade->add_option("--sequence-equirect", o.sequence_equirect, "width of the equirect of the sequence's reference (sky part)")
      ->check(CLI::Range(16, 2048))
      ->capture_default_str();
  trade->add_flag("--quick", o.quick,
                  "a small grid (ν 2, faces and corners, K 8, planes at 1/16, full and pca4, 16 bits, sun on, S 0; "
                  "park and city) in a few minutes; explicit options still apply");
  if (const auto status = tools::parse_command_line(app, argc, argv)) return *status;
  if (quiet) tools::quiet_stdout();
  try {
    if (o.quick) {
      const auto unless_given = [&](const char* name, auto& field, auto value) {
        if (trade->count(name) == 0) field = value;
      };
      unless_given("--frequencies", o.frequencies, std::vector<int>{2});
      unless_given("--bases", o.bases, std::vector<std::string>{"faces", "corners"});
      unless_given("--samples", o.samples, std::vector<int>{8});
      unless_given("--texel-scales", o.texel_scales, std::vector<int>{16});
      unless_given("--forms", o.forms, std::vector<std::string>{"full", "pca4"});
      unless_given("--bits", o.bits, std::vector<int>{16});
      unless_given("--sun", o.sun, std::vector<std::string>{"on"});
      unless_given("--skip-thresholds", o.skip_thresholds, std::vector<double>{0.0});
      unless_given("--sky", o.skies, std::vector<std::string>{"city", "park"});
      unless_given("--frame-repeats", o.frame_repeats, 10);
      unless_given("--blend-repeats", o.blend_repeats, 5);
    }
    // skylit-live beside this program (the build tree's bin/, or an installation's).
    std::error_code no_proc;
    const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", no_proc);
    if (!no_proc && std::filesystem::exists(self.parent_path() / "skylit-live")) o.live_program = (self.parent_path() / "skylit-live").string();
    return run_trade(o);
  } catch (const InputError& e) {
    std::fprintf(stderr, "skylit-bench: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-bench: internal error: %s\n", e.what());
    return 3;
  }
}
