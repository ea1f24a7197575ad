// The trade table written out: JSON, a Markdown table, and an SVG plot of error against frame
// time with the Pareto front marked.
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
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/sky/sky_smoothing.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/study/study.hpp"
#include "trade_rows.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/bake_format/arrays.hpp"

namespace skylit::study::trade {

Form parse_form(const std::string& text) {
  if (text == "full") return {blend::BasisForm::Full, 0, 0};
  if (text == "lean") return {blend::BasisForm::Lean, 0, 0};
  if (text == "cropped") return {blend::BasisForm::Cropped, 0, 0};
  // pcaK or pcaKtN (clustered: tiles of N texels).
  int k = 0, tile = 0, used = 0;
  if (std::sscanf(text.c_str(), "pca%d%n", &k, &used) == 1 && k > 0) {
    if (static_cast<std::size_t>(used) == text.size()) return {blend::BasisForm::Pca, k, 0};
    int more = 0;
    if (std::sscanf(text.c_str() + used, "t%d%n", &tile, &more) == 1 && tile >= 2 &&
        static_cast<std::size_t>(used + more) == text.size()) {
      return {blend::BasisForm::Pca, k, tile};
    }
  }
  throw InputError("option --forms: got '" + text +
                   "'. Fix: full, lean, cropped, pcaK (e.g. pca8) or pcaKtN (clustered PCA, tiles of N texels of the bake's "
                   "planes, N >= 2; e.g. pca16t8)");
}

void mark_pareto(std::vector<Result>& results) {
  for (Result& r : results) {
    r.pareto = std::none_of(results.begin(), results.end(), [&](const Result& o) {
      return o.cost_ms <= r.cost_ms && o.error.rms <= r.error.rms && (o.cost_ms < r.cost_ms || o.error.rms < r.error.rms);
    });
  }
}

std::string svg_plot(const std::vector<Result>& results, const std::string& title, const std::string& x_label) {
  const double W = 960, H = 640, left = 80, right = 300, top = 50, bottom = 70;
  double x0 = 1e30, x1 = 0, y0 = 1e30, y1 = 0;
  for (const Result& r : results) {
    x0 = std::min(x0, r.cost_ms);
    x1 = std::max(x1, r.cost_ms);
    y0 = std::min(y0, std::max(r.error.rms, 1e-5));
    y1 = std::max(y1, std::max(r.error.rms, 1e-5));
  }
  // Log axes, a little margin, whole decades of error marked.
  const double lx0 = std::log10(x0) - 0.05, lx1 = std::log10(x1) + 0.05;
  const double ly0 = std::log10(y0) - 0.1, ly1 = std::log10(y1) + 0.1;
  const auto px = [&](double ms) { return left + (std::log10(ms) - lx0) / std::max(lx1 - lx0, 1e-9) * (W - left - right); };
  const auto py = [&](double e) {
    return H - bottom - (std::log10(std::max(e, 1e-5)) - ly0) / std::max(ly1 - ly0, 1e-9) * (H - top - bottom);
  };
  std::ostringstream s;
  s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H
    << "\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  s << "<text x=\"" << left << "\" y=\"24\" font-size=\"15\">" << title << "</text>\n";
  s << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << W - left - right << "\" height=\"" << H - top - bottom
    << "\" fill=\"none\" stroke=\"#888\"/>\n";
  for (double tick : {0.5, 1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0, 70.0, 100.0, 150.0, 200.0, 300.0, 500.0, 1000.0}) {
    if (std::log10(tick) < lx0 || std::log10(tick) > lx1) continue;
    s << "<line x1=\"" << px(tick) << "\" x2=\"" << px(tick) << "\" y1=\"" << top << "\" y2=\"" << H - bottom
      << "\" stroke=\"#eee\"/><text x=\"" << px(tick) << "\" y=\"" << H - bottom + 16 << "\" text-anchor=\"middle\">" << tick
      << "</text>\n";
  }
  for (double tick : {0.0001, 0.0002, 0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5}) {
    if (std::log10(tick) < ly0 || std::log10(tick) > ly1) continue;
    s << "<line x1=\"" << left << "\" x2=\"" << W - right << "\" y1=\"" << py(tick) << "\" y2=\"" << py(tick)
      << "\" stroke=\"" << (tick == 0.01 ? "#c88" : "#eee") << "\"/><text x=\"" << left - 6 << "\" y=\"" << py(tick) + 4
      << "\" text-anchor=\"end\">" << tick << "</text>\n";
  }
  if (1000.0 / 60 >= x0 && 1000.0 / 60 <= x1 * 1.2) {
    s << "<line x1=\"" << px(1000.0 / 60) << "\" x2=\"" << px(1000.0 / 60) << "\" y1=\"" << top << "\" y2=\"" << H - bottom
      << "\" stroke=\"#c88\" stroke-dasharray=\"4 3\"/><text x=\"" << px(1000.0 / 60) + 3 << "\" y=\"" << top + 12
      << "\" fill=\"#a44\">60 frames/s</text>\n";
  }
  s << "<text x=\"" << (left + W - right) / 2 << "\" y=\"" << H - 30
    << "\" text-anchor=\"middle\">" << x_label << "</text>\n";
  s << "<text transform=\"translate(22," << (top + H - bottom) / 2
    << ") rotate(-90)\" text-anchor=\"middle\">RMS |T − T_ref| (log)</text>\n";
  std::vector<const Result*> front;
  for (const Result& r : results) {
    if (r.pareto) front.push_back(&r);
  }
  std::sort(front.begin(), front.end(), [](const Result* a, const Result* b) { return a->cost_ms < b->cost_ms; });
  if (!front.empty()) {
    s << "<polyline fill=\"none\" stroke=\"#d33\" stroke-width=\"1.5\" points=\"";
    for (const Result* r : front) s << px(r->cost_ms) << "," << py(r->error.rms) << " ";
    s << "\"/>\n";
  }
  int k = 0;
  for (const Result& r : results) {
    const double x = px(r.cost_ms), y = py(r.error.rms);
    s << "<circle cx=\"" << x << "\" cy=\"" << y << "\" r=\"" << (r.pareto ? 5 : 3) << "\" fill=\""
      << (r.pareto ? "#d33" : "#58a") << "\"><title>" << r.setting.label() << "</title></circle>";
    s << "<text x=\"" << x + 6 << "\" y=\"" << y - 4 << "\" font-size=\"8\" fill=\"#555\">" << k << "</text>\n";
    ++k;
  }
  // The legend: the front's points, number and label (every point's label is its tooltip, and its
  // number is its row in trade.md).
  s << "<text x=\"" << W - right + 10 << "\" y=\"" << top + 10 << "\" font-weight=\"bold\">Pareto front (# = row of trade.md)</text>\n";
  k = 0;
  int shown = 0;
  for (const Result& r : results) {
    if (r.pareto && shown < 40) {
      s << "<text x=\"" << W - right + 10 << "\" y=\"" << top + 26 + 12 * shown << "\" font-size=\"10\" fill=\"#d33\">" << k
        << ": " << r.setting.label() << "</text>\n";
      ++shown;
    }
    ++k;
  }
  s << "</svg>\n";
  return s.str();
}

double mean_of(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}
double max_of(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); }
double blend_fraction(const SequenceResult& q) {
  double runs = 0;
  for (int b : q.blended) runs += b;
  return q.blended.empty() || q.planes == 0 ? 0.0 : runs / (static_cast<double>(q.blended.size()) * q.planes);
}

nlohmann::json sequence_json(const Result& r) {
  if (!r.sequence) return nullptr;
  const SequenceResult& q = *r.sequence;
  return {{"rms", mean_of(q.rms)},
          {"rms_worst", max_of(q.rms)},
          {"p99", mean_of(q.p99)},
          {"p99_worst", max_of(q.p99)},
          {"max", max_of(q.max)},
          {"still_rms", mean_of(q.still_rms)},
          {"still_max", max_of(q.still_max)},
          {"blend_fraction", blend_fraction(q)},
          {"sun_redraws", q.sun_redraws},
          {"frames",
           {{"rms", q.rms}, {"p99", q.p99}, {"max", q.max}, {"still_rms", q.still_rms}, {"still_max", q.still_max},
            {"blended_planes", q.blended}, {"planes", q.planes}}}};
}

nlohmann::json to_json(const Result& r) {
  nlohmann::json per_sky = nlohmann::json::object();
  for (const auto& [sky, rms] : r.rms_per_sky) per_sky[sky] = rms;
  nlohmann::json inside_per_sky = nlohmann::json::object();
  for (const auto& [sky, e] : r.building_inside_per_sky) inside_per_sky[sky] = {{"rms", e.rms}, {"p99", e.p99}, {"max", e.max}};
  return {{"label", r.setting.label()},
          {"frequency", r.setting.bake.frequency},
          {"basis", std::string(geom::basis_name(r.setting.bake.basis))},
          {"samples", r.setting.bake.samples},
          {"texel_scale", r.setting.bake.texel_scale},
          {"refine", r.setting.bake.refine},
          {"vertex_fit", r.setting.bake.vertex_fit},
          {"light_map", r.setting.bake.light_map},
          {"vertices", r.vertices},
          {"form", r.setting.form.name()},
          {"bits", r.setting.bits},
          {"live", r.live ? nlohmann::json{{"frames_per_second", r.live->frames_per_second},
                                            {"frame_p50_ms", r.live->frame_p50_ms}, {"frame_p99_ms", r.live->frame_p99_ms},
                                            {"composited", r.live->composited}, {"dropped", r.live->dropped},
                                            {"camera_frames", r.live->camera_frames}, {"seconds", r.live->seconds},
                                            {"blend_device", r.live->device}}
                          : nlohmann::json(nullptr)},
          {"sun_separation", r.setting.sun},
          {"sources", r.setting.sun ? r.setting.sources : 0},
          {"skip_threshold", r.setting.skip_threshold},
          {"change_threshold", r.setting.change_threshold},
          {"smoothing", r.setting.smoothing},
          {"render_scale", r.setting.render_scale},
          {"rms", r.error.rms},
          {"p99", r.error.p99},
          {"max", r.error.max},
          {"rms_per_sky", per_sky},
          {"building", {{"rms", r.building.rms}, {"p99", r.building.p99}, {"max", r.building.max},
                        {"without_ground_layer", {{"rms", r.building_no_ground.rms}, {"p99", r.building_no_ground.p99}}},
                        {"inside_triangles_by_area",
                         {{"rms", r.building_inside.rms}, {"p99", r.building_inside.p99}, {"max", r.building_inside.max}}},
                        {"inside_triangles_by_area_per_sky", inside_per_sky},
                        {"of", "the horizontal irradiance"}}},
          {"edge_displacement_m", r.edge_m ? nlohmann::json(*r.edge_m) : nlohmann::json(nullptr)},
          {"edge_displacement_deg", r.edge_deg ? nlohmann::json(*r.edge_deg) : nlohmann::json(nullptr)},
          {"bake_seconds", r.bake_seconds},
          {"bake_bytes", r.bake_bytes},
          {"gpu_bytes", r.gpu_bytes},
          {"layers", r.layers},
          {"skipped_layers", r.skipped_layers},
          {"blend_ms", r.blend_ms},
          {"blend_cpu_ms", r.blend_cpu_ms},
          {"building_sum_ms", r.building_sum_ms},
          {"building_sum_cpu_ms", r.building_sum_cpu_ms},
          {"frame_ms", r.frame_ms},
          {"frame_cpu_ms", r.frame_cpu_ms},
          {"whole_frame_ms", r.whole_frame_ms},
          {"whole_frame_cpu_ms", r.whole_frame_cpu_ms},
          {"cost_ms", r.cost_ms},
          {"frames_per_second", 1000.0 / r.cost_ms},
          {"pareto", r.pareto},
          {"sequence", sequence_json(r)}};
}

std::string markdown_table(const std::vector<Result>& results) {
  std::string md =
      "| # | ν | basis | K | texel scale | refine (vertices) | vertex fit | light map (m) | form | bits | sun | S thr. | ΔS thr. | smoothing s | render scale | RMS | p99 | max | edge (m / °) | "
      "building RMS / p99 (without the ground layer) | inside the triangles, by area: RMS / p99 | bake s | "
      "bake MB | GPU MB | blend ms wall / CPU | building's sum ms wall / CPU | frame ms wall / CPU | cost ms (frames/s) | service frames/s (p50 ms, dropped) | Pareto |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  int k = 0;
  for (const Result& r : results) {
    const Setting& s = r.setting;
    char edge[48] = "—";
    const std::string sun = !s.sun ? "off" : s.sources > 1 ? "on+" + std::to_string(s.sources - 1) : "on";
    if (r.edge_m) std::snprintf(edge, sizeof edge, "%.3f / %.3f", *r.edge_m, *r.edge_deg);
    char service[96] = "—";
    if (r.live) {
      std::snprintf(service, sizeof service, "%.1f (%.1f, %.0f%%)", r.live->frames_per_second, r.live->frame_p50_ms,
                    r.live->camera_frames > 0 ? 100.0 * static_cast<double>(r.live->dropped) / static_cast<double>(r.live->camera_frames)
                                              : 0.0);
    }
    char building[96];
    std::snprintf(building, sizeof building, "%.4f / %.4f (%.4f / %.4f)", r.building.rms, r.building.p99, r.building_no_ground.rms,
                  r.building_no_ground.p99);
    char refine[48];
    if (s.bake.refine > 0) {
      std::snprintf(refine, sizeof refine, "%g (%zu)", s.bake.refine, r.vertices);
    } else {
      std::snprintf(refine, sizeof refine, "— (%zu)", r.vertices);
    }
    char light_map[32] = "—";
    if (s.bake.light_map > 0) std::snprintf(light_map, sizeof light_map, "%g", s.bake.light_map);
    char inside[64];
    std::snprintf(inside, sizeof inside, "%.4f / %.4f", r.building_inside.rms, r.building_inside.p99);
    char row[896];
    std::snprintf(row, sizeof row,
                  "| %d | %d | %s | %d | 1/%d | %s | %s | %s | %s | %d | %s | %g | %g | %g | %g | %.4f | %.4f | %.4f | %s | %s | %s | %.1f | %.2f | %.1f | "
                  "%.1f / %.1f | %.1f / %.1f | %.1f / %.1f | %.1f (%.0f) | %s | %s |\n",
                  k++, s.bake.frequency, std::string(geom::basis_name(s.bake.basis)).c_str(), s.bake.samples,
                  s.bake.texel_scale, refine, s.bake.vertex_fit > 0 ? (std::to_string(s.bake.vertex_fit) + "²").c_str() : "—",
                  light_map, s.form.name().c_str(), s.bits, sun.c_str(), s.skip_threshold, s.change_threshold, s.smoothing, s.render_scale, r.error.rms,
                  r.error.p99, r.error.max, edge, building, inside, r.bake_seconds, static_cast<double>(r.bake_bytes) / 1e6,
                  static_cast<double>(r.gpu_bytes) / 1e6, r.blend_ms, r.blend_cpu_ms, r.building_sum_ms, r.building_sum_cpu_ms,
                  r.frame_ms, r.frame_cpu_ms, r.cost_ms,
                  1000.0 / r.cost_ms, service,
                  r.pareto ? "**yes**" : "");
    md += row;
  }
  // The building inside its triangles, each sky alone (the setting's rows above pool them).
  if (!results.empty() && !results.front().building_inside_per_sky.empty()) {
    md += "\nThe building inside its triangles, by area, each sky alone: RMS / p99 of |E − E_ref| / E_h.\n\n| # | setting |";
    std::string rule = "|---|---|";
    for (const auto& [sky, e] : results.front().building_inside_per_sky) {
      md += " " + sky + " |";
      rule += "---|";
    }
    md += "\n" + rule + "\n";
    int row_index = 0;
    for (const Result& r : results) {
      md += "| " + std::to_string(row_index++) + " | " + r.setting.label() + " |";
      for (const auto& [sky, e] : r.building_inside_per_sky) {
        char cell[64];
        std::snprintf(cell, sizeof cell, " %.4f / %.4f |", e.rms, e.p99);
        md += cell;
      }
      md += "\n";
    }
  }
  if (std::any_of(results.begin(), results.end(), [](const Result& r) { return r.sequence.has_value(); })) {
    md += "\nSky sequence (--sequence): error of T against each frame's reference, mean over the frames (worst "
          "frame); still: a fresh blend of each frame's own estimate; re-blends: share of frames × planes blended.\n\n"
          "| # | setting | ΔS thr. | smoothing s | RMS mean (worst) | p99 mean (worst) | max | still RMS mean | still max | "
          "re-blends |\n|---|---|---|---|---|---|---|---|---|---|\n";
    k = 0;
    for (const Result& r : results) {
      if (!r.sequence) continue;  // several sources: the sequence follows the sun alone
      const SequenceResult& q = *r.sequence;
      char row[512];
      std::snprintf(row, sizeof row, "| %d | %s | %g | %g | %.4f (%.4f) | %.4f (%.4f) | %.4f | %.4f | %.4f | %.0f%% |\n", k++,
                    r.setting.label().c_str(), r.setting.change_threshold, r.setting.smoothing, mean_of(q.rms), max_of(q.rms),
                    mean_of(q.p99), max_of(q.p99), max_of(q.max), mean_of(q.still_rms), max_of(q.still_max),
                    100.0 * blend_fraction(q));
      md += row;
    }
  }
  return md;
}

namespace {

// trade.json: the run's settings, every setting's result and the Pareto front (indices).
nlohmann::json trade_json(const TradeOptions& o, const SequenceOptions& sequence, const std::vector<SkyName>& skies,
                          Clock::time_point start, const std::vector<Result>& results) {
  nlohmann::json settings_json = nlohmann::json::array();
  nlohmann::json front = nlohmann::json::array();
  for (std::size_t k = 0; k < results.size(); ++k) {
    settings_json.push_back(to_json(results[k]));
    if (results[k].pareto) front.push_back(k);
  }
  nlohmann::json sky_names = nlohmann::json::array();
  for (const SkyName& d : skies) sky_names.push_back({{"name", d.name}, {"sunny", d.sunny}});
  return nlohmann::json{{"frame", {{"width", o.frame_width}, {"height", o.frame_height}}},
                        {"skies", sky_names},
                        {"light_map_components", o.light_map_components},
                        {"light_map_precision", render::light_map_precision_name(o.light_map_precision)},
                        {"blend_threads", o.threads},
                        {"timing_scale", o.timing_scale},
                        {"reference_supersample", o.reference_supersample},
                        {"clock", o.clock},
                        {"cores", o.cores},
                        {"load_1min_at_end", [] {
                           double load[1] = {0};
                           return getloadavg(load, 1) == 1 ? load[0] : -1.0;
                         }()},
                        {"sequence", o.sequence ? nlohmann::json{{"frames", sequence.frames},
                                                                  {"interval_s", sequence.interval_s},
                                                                  {"start", o.sequence_start},
                                                                  {"latitude_deg", sequence.latitude_deg},
                                                                  {"longitude_deg", sequence.longitude_deg},
                                                                  {"cloud", sequence.cloud},
                                                                  {"equirect_width", o.sequence_equirect}}
                                               : nlohmann::json(nullptr)},
                        {"settings", settings_json},
                        {"pareto", front},
                        {"seconds", seconds_since(start)}};
}

}  // namespace

void write_outputs(const TradeOptions& o, const SequenceOptions& sequence, const std::vector<SkyName>& skies,
                   Clock::time_point start, std::vector<Result>& results) {
  const std::filesystem::path out(o.out_dir);
  mark_pareto(results);
  write_file_atomic(out / "trade.json", trade_json(o, sequence, skies, start, results).dump(2) + "\n");
  const std::string md = markdown_table(results);
  write_file_atomic(out / "trade.md", md);
  char title[160];
  std::snprintf(title, sizeof title, "skylit-bench trade: %zu settings, %zu skies, %d×%d", results.size(), skies.size(),
                o.frame_width, o.frame_height);
  std::string x_label = o.clock == "wall"
                            ? "frame time, ms (log): compositor + CPU blend + the building's sum, wall"
                            : "frame time, ms (log): process CPU time of compositor + CPU blend + the building's sum / " + std::to_string(o.cores) + " cores";
  if (o.sky_interval > 0.0) {
    char every[64];
    std::snprintf(every, sizeof every, ", a new sky every %g s", o.sky_interval);
    x_label += every;
  } else {
    x_label += ", a new sky every frame";
  }
  write_file_atomic(out / "trade.svg", svg_plot(results, title, x_label));
  std::printf("\n%s\nwrote %s, %s, %s (%.0f s)\n", md.c_str(), (out / "trade.json").c_str(), (out / "trade.md").c_str(),
              (out / "trade.svg").c_str(), seconds_since(start));
}


}  // namespace skylit::study::trade
