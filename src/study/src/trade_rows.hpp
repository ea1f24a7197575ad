#pragma once
// The trade table's rows (private to the study module): the grid's settings, the measured results,
// the forms a basis is measured in, and how the table is written.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/blend/basis.hpp"
#include "skylit/blend/forms.hpp"
#include "skylit/geom/plane.hpp"
#include "skylit/study/study.hpp"

namespace skylit::study::trade {

struct BakeKey {
  int frequency = 2;
  geom::DomeBasis basis = geom::DomeBasis::Faces;
  int samples = 16;
  int texel_scale = 8;
  double refine = 0;  // skylit-bake --refine (0: the model as it is)
  int vertex_fit = 0;  // skylit-bake --vertex-fit (0: each vertex's own light)
  double light_map = 0;  // skylit-bake --light-map (0: none)
  auto tie() const { return std::tie(frequency, basis, samples, texel_scale, refine, vertex_fit, light_map); }
  bool operator<(const BakeKey& o) const { return tie() < o.tie(); }
  std::string name() const {
    std::string text = "nu" + std::to_string(frequency) + "_" + std::string(geom::basis_name(basis)) + "_k" +
                       std::to_string(samples) + "_s" + std::to_string(texel_scale);
    if (refine > 0) {
      char tolerance[32];
      std::snprintf(tolerance, sizeof tolerance, "_r%g", refine);
      text += tolerance;
    }
    if (vertex_fit > 0) text += "_f" + std::to_string(vertex_fit);
    if (light_map > 0) {
      char texel[32];
      std::snprintf(texel, sizeof texel, "_lm%g", light_map);
      text += texel;
    }
    return text;
  }
};

struct Form {
  blend::BasisForm form = blend::BasisForm::Full;
  int components = 0;  // Pca
  int tile = 0;        // Pca: clustered, tiles of this many texels of the bake's planes (0: none)
  std::string name() const {
    if (form == blend::BasisForm::Pca) {
      // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on "literal" + string here.
      std::string text = "pca";
      text += std::to_string(components);
      if (tile > 0) {
        text += 't';
        text += std::to_string(tile);
      }
      return text;
    }
    return form == blend::BasisForm::Lean ? "lean" : form == blend::BasisForm::Cropped ? "cropped" : "full";
  }
};

Form parse_form(const std::string& text);

struct Setting {
  BakeKey bake;
  Form form;
  int bits = 16;
  bool sun = true;
  int sources = 1;  // separated sources at most (sun on): sky.max_sources
  double skip_threshold = 0;
  double change_threshold = 0.002;
  double smoothing = 0;
  double render_scale = 1.0;
  std::string label() const {
    char text[160];
    std::snprintf(text, sizeof text, "%s %s %db%s S%g", bake.name().c_str(), form.name().c_str(), bits,
                  sun ? " sun" : " nosun", skip_threshold);
    std::string s = text;
    if (sun && sources > 1) s.insert(s.find(" sun") + 4, "+" + std::to_string(sources - 1));  // lamps besides the sun
    char live[64];
    std::snprintf(live, sizeof live, " dS%g", change_threshold);
    s += live;
    if (smoothing > 0.0) {
      std::snprintf(live, sizeof live, " tau%g", smoothing);
      s += live;
    }
    if (render_scale != 1.0) s += " r" + std::to_string(static_cast<int>(std::lround(render_scale * 100)));
    return s;
  }
};

// The setting on the sky sequence (--sequence): per frame, the errors of the live path's T
// (smoother, change threshold) and of a fresh blend of the frame's own estimate (the still-sky
// path), against the frame's reference; and how many planes re-blended.
struct SequenceResult {
  std::vector<double> rms, p99, max, still_rms, still_max;
  std::vector<int> blended;  // planes whose blend ran, per frame
  int planes = 0;
  int sun_redraws = 0;       // frames whose sun visibility was recomputed (the sun moved): they re-blend
};

// The service's own frames for a setting (--live-seconds): skylit-live itself on the setting's
// bake, a 60 Hz camera in, composites out, the sky changing; from its final /status.
struct LiveRun {
  double frames_per_second = 0;  // composited, over the run (frame_rate)
  double frame_p50_ms = 0, frame_p99_ms = 0;
  std::int64_t composited = 0;
  std::int64_t dropped = 0;      // camera frames replaced before the renderer took them
  std::int64_t camera_frames = 0;
  double seconds = 0;            // the run's wall time
  std::string device;            // blend.device as resolved (cpu, gpu)
};

struct Result {
  Setting setting;
  std::optional<LiveRun> live;
  std::optional<SequenceResult> sequence;
  study::Errors error;
  std::map<std::string, double> rms_per_sky;
  std::optional<double> edge_m, edge_deg;  // sunny skies only
  // The building's irradiance per vertex against its reference, a share of E_h (every sky): with
  // the bake's ground layer (render.ground_light) and without it.
  study::Errors building, building_no_ground;
  // The same inside the triangles (study::triangle_points), by area, what the compositor shows:
  // the sun per point as its map gives it, the rest interpolated from the vertices; ground layer
  // as `building`.
  study::Errors building_inside;
  std::map<std::string, study::Errors> building_inside_per_sky;  // the same, each sky alone
  std::size_t vertices = 0;  // the bake's model (more with refine)
  double bake_seconds = 0;
  std::uint64_t bake_bytes = 0;
  std::uint64_t gpu_bytes = 0;
  int layers = 0;               // stored layers per plane, summed over planes
  int skipped_layers = 0;       // by the S threshold, summed over planes (first sky)
  double blend_ms = 0;
  double blend_cpu_ms = 0;      // process CPU time per blend
  double building_sum_ms = 0;      // the building's light for a new sky (sky thread), wall
  double building_sum_cpu_ms = 0;  // its process CPU time
  double frame_ms = 0;
  double frame_cpu_ms = 0;      // process CPU time per frame (llvmpipe's threads included)
  double whole_frame_ms = 0;      // wall: frame_ms + blend_ms + building_sum_ms (a frame with a new sky)
  double whole_frame_cpu_ms = 0;  // process CPU time: frame_cpu_ms + blend_cpu_ms + building_sum_cpu_ms
  double cost_ms = 0;             // what the plot and the Pareto front use (--clock)
  bool pareto = false;
};

// ---- the forms a basis is measured in (trade_forms.cpp) ----

std::uint64_t directory_bytes(const std::filesystem::path& dir);
void quantise_to_unorm8(blend::BasisImages& basis);
blend::BasisImages upsampled(const blend::BasisImages& b, int width, int height);
std::vector<float> upsampled(const std::vector<float>& v, int w, int h, int width, int height);
double cpu_ms_since(std::clock_t t);
std::vector<std::pair<double, double>> edge_points(const std::vector<double>& y, const geom::Plane& plane, double level);
std::pair<double, int> edge_displacement(const std::vector<float>& T, const std::vector<Eigen::Vector3d>& reference,
                                         const geom::Plane& plane);

// ---- the service's own frames (trade_live.cpp) ----

// Runs o.live_program (skylit-live) headless on the setting's bake for o.live_seconds of 60 Hz
// camera frames (random images of the frame size, the visitor's pose), the sky a clear day from
// the sky simulator at o.sequence_lat/lon changing every o.sky_interval seconds, the building lit
// by the ground (o.ground_albedo, where the bake has a ground layer) and its light map held at
// o.light_map_precision, everything written under o.out_dir/live. std::runtime_error naming the
// log when it fails.
LiveRun run_live(const TradeOptions& o, const Setting& s, const std::filesystem::path& site_file, const std::filesystem::path& bake_dir);

// ---- what is written (trade_report.cpp) ----

void mark_pareto(std::vector<Result>& results);
std::string svg_plot(const std::vector<Result>& results, const std::string& title, const std::string& x_label);
double mean_of(const std::vector<double>& v);
double max_of(const std::vector<double>& v);
double blend_fraction(const SequenceResult& q);
nlohmann::json sequence_json(const Result& r);
nlohmann::json to_json(const Result& r);
std::string markdown_table(const std::vector<Result>& results);
// A sky of the run as the outputs name it.
struct SkyName {
  std::string name;
  bool sunny = false;  // a sun in the equirect (study::equirect_sun)
};
// The Pareto front marked; o.out_dir/trade.json, trade.md and trade.svg written (the run's
// settings, every setting's result, the front; its time from `start`); the table printed.
void write_outputs(const TradeOptions& o, const SequenceOptions& sequence, const std::vector<SkyName>& skies,
                   Clock::time_point start, std::vector<Result>& results);

}  // namespace skylit::study::trade
