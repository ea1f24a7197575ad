// skylit-bench trade: the trade table of the sky stage (issue 6). Sweeps a grid of settings — the
// bake's (dome frequency ν, basis faces/corners, samples per face, plane resolution), the stored
// form (full, lean, cropped, PCA with K components; 16- or 8-bit layers) and the live service's (sun
// separation, S threshold = blend.skip_threshold, ΔS threshold = blend.change_threshold,
// smoothing) — over the sample site and real equirect skies, and reports per setting:
//
//   error of T against the dense reference (study::dense_reference): RMS, p99, max of |T − T_ref|
//     over every texel, plane and channel of every sky; for sunny skies (a sun in the equirect),
//     the shadow-edge displacement (docs/trade.md: the mean distance between the 0.5 level lines
//     of T and T_ref, metres on the plane, and the visual angle it subtends from the benchmark
//     visitor 18 m away, degrees);
//   bake time, bake size on disk, GPU memory (the layer textures as the GPU blend holds them:
//     four layers per RGBA slice, 2 or 1 byte per value);
//   per-frame blend time (the live CPU blend, every plane at --timing-scale, median of
//     --blend-repeats) and whole-frame time (the compositor at 640×480 on the headless GL
//     context, draw + glFinish, median of --frame-repeats, plus the blend: a frame with a new
//     sky), wall and process CPU time; the plot and the front use --clock (cpu: CPU time over
//     --cores, which other processes' load does not change; wall).
//
// With --sequence, also a sky sequence (an analytic clear sky over time with a passing cloud, one
// sky per second, a dense reference per frame: study::sequence_reference) run through the live
// path per setting — smoother (τ) → blend weights → CpuBlender with the change threshold, kept
// from frame to frame — for the error the ΔS threshold and the smoothing add and the share of
// frames that re-blend (docs/trade.md, "The sky sequence").
//
// Writes OUT/trade.json, OUT/trade.md and OUT/trade.svg (RMS against whole-frame time, the
// Pareto front marked). Bakes are cached in OUT/bakes (a bake is reused when its folder holds a
// readable manifest and trade_bake.json).
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

#include <CLI/CLI.hpp>
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
#include "skylit/camera/lens.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "command_line.hpp"

namespace {

namespace fs = std::filesystem;
using namespace skylit;
using study::Clock;
using study::median;
using study::seconds_since;

// ---------------------------------------------------------------------------------------------
// The grid.

struct BakeKey {
  int frequency = 2;
  geom::DomeBasis basis = geom::DomeBasis::Faces;
  int samples = 16;
  int texel_scale = 8;
  auto tie() const { return std::tie(frequency, basis, samples, texel_scale); }
  bool operator<(const BakeKey& o) const { return tie() < o.tie(); }
  std::string name() const {
    return "nu" + std::to_string(frequency) + "_" + std::string(geom::basis_name(basis)) + "_k" + std::to_string(samples) +
           "_s" + std::to_string(texel_scale);
  }
};

struct Form {
  blend::BasisForm form = blend::BasisForm::Full;
  int components = 0;  // Pca
  int tile = 0;        // Pca: clustered, tiles of this many texels of the bake's planes (0: none)
  std::string name() const {
    if (form == blend::BasisForm::Pca) {
      return "pca" + std::to_string(components) + (tile > 0 ? "t" + std::to_string(tile) : "");
    }
    return form == blend::BasisForm::Lean ? "lean" : form == blend::BasisForm::Cropped ? "cropped" : "full";
  }
};

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

struct Setting {
  BakeKey bake;
  Form form;
  int bits = 16;
  bool sun = true;
  double skip_threshold = 0;
  double change_threshold = 0.002;
  double smoothing = 0;
  double render_scale = 1.0;
  std::string label() const {
    char text[160];
    std::snprintf(text, sizeof text, "%s %s %db%s S%g", bake.name().c_str(), form.name().c_str(), bits,
                  sun ? " sun" : " nosun", skip_threshold);
    std::string s = text;
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

struct Result {
  Setting setting;
  std::optional<SequenceResult> sequence;
  study::Errors error;
  std::map<std::string, double> rms_per_sky;
  std::optional<double> edge_m, edge_deg;  // sunny skies only
  double bake_seconds = 0;
  std::uint64_t bake_bytes = 0;
  std::uint64_t gpu_bytes = 0;
  int layers = 0;               // stored layers per plane, summed over planes
  int skipped_layers = 0;       // by the S threshold, summed over planes (first sky)
  double blend_ms = 0;
  double blend_cpu_ms = 0;      // process CPU time per blend
  double frame_ms = 0;
  double frame_cpu_ms = 0;      // process CPU time per frame (llvmpipe's threads included)
  double whole_frame_ms = 0;      // wall: frame_ms + blend_ms
  double whole_frame_cpu_ms = 0;  // process CPU time: frame_cpu_ms + blend_cpu_ms
  double cost_ms = 0;             // what the plot and the Pareto front use (--clock)
  bool pareto = false;
};

std::uint64_t directory_bytes(const fs::path& dir) {
  std::uint64_t bytes = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) bytes += entry.file_size();
  }
  return bytes;
}

// 8-bit layers as the GPU blend stores them (gpu_blend.cpp): per layer, B ≈ top · round(255 B / top) / 255.
// A cropped basis stays cropped: the GPU blend's pages hold the fill (as a half) outside each
// rectangle and quantise it with the rectangle, so the top is over the rectangle and the fill
// (where the rectangle leaves texels to it), and the fill is quantised as the texels it covers.
void quantise_to_unorm8(blend::BasisImages& basis) {
  const std::size_t texels = basis.texel_count();
  std::vector<float> values;
  for (int layer = 0; layer < basis.layers; ++layer) {
    blend::LayerCrop* crop = basis.cropped() ? &basis.crops.at(static_cast<std::size_t>(layer)) : nullptr;
    const std::size_t offset = crop ? crop->offset : static_cast<std::size_t>(layer) * texels;
    const std::size_t count = crop ? static_cast<std::size_t>(crop->cols) * static_cast<std::size_t>(crop->rows) : texels;
    const std::span<std::uint16_t> halves(basis.half.data() + offset, count);
    values.resize(count);
    blend::halves_to_floats(halves, values);
    float top = 0.0f;
    for (float v : values) top = std::max(top, v);
    const bool has_fill = crop && count < texels;
    const float fill = has_fill ? blend::half_to_float(blend::float_to_half(crop->fill)) : 0.0f;
    if (has_fill) top = std::max(top, fill);
    if (top <= 0.0f) continue;
    const auto quantised = [top](float v) { return top * std::round(std::clamp(v / top * 255.0f, 0.0f, 255.0f)) / 255.0f; };
    for (std::size_t k = 0; k < count; ++k) halves[k] = blend::float_to_half(quantised(values[k]));
    if (has_fill) crop->fill = blend::half_to_float(blend::float_to_half(quantised(fill)));
  }
}

// The same basis at width × height texels, nearest texel: the blend's cost depends on the texels
// and the layers, not on their values, so a coarse bake upsampled times the blend of a fine one.
// A tiled basis (clustered PCA) is scaled by a whole factor, its tiles with it, so that every
// texel keeps its tile. A cropped basis stays cropped: each rectangle scaled with the plane (its
// values nearest texel, as a whole layer's), the fills kept.
blend::BasisImages upsampled(const blend::BasisImages& b, int width, int height) {
  if (b.cropped()) {
    blend::BasisImages out = b;
    out.width = width;
    out.height = height;
    out.half.clear();
    const auto scaled = [](int at, int to, int from) { return static_cast<int>(static_cast<std::int64_t>(at) * to / from); };
    const auto scaled_up = [](int at, int to, int from) {
      return static_cast<int>((static_cast<std::int64_t>(at) * to + from - 1) / from);
    };
    for (int layer = 0; layer < b.layers; ++layer) {
      const blend::LayerCrop& c = b.crops[static_cast<std::size_t>(layer)];
      blend::LayerCrop& f = out.crops[static_cast<std::size_t>(layer)];
      f.col = scaled(c.col, width, b.width);
      f.row = scaled(c.row, height, b.height);
      f.cols = c.cols > 0 && c.rows > 0 ? scaled_up(c.col + c.cols, width, b.width) - f.col : 0;
      f.rows = c.cols > 0 && c.rows > 0 ? scaled_up(c.row + c.rows, height, b.height) - f.row : 0;
      f.offset = out.half.size();
      for (int row = f.row; row < f.row + f.rows; ++row) {
        for (int col = f.col; col < f.col + f.cols; ++col) {
          // Nearest texel of the coarse layer: a fine texel at the rectangle's edge may fall
          // just outside the coarse rectangle, where the layer is its fill.
          out.half.push_back(blend::float_to_half(b.value(layer, col * b.width / width, row * b.height / height)));
        }
      }
    }
    return out;
  }
  if (b.tile > 0) {
    const int factor = std::max(1, static_cast<int>(std::lround(static_cast<double>(width) / b.width)));
    width = b.width * factor;
    height = b.height * factor;
  }
  blend::BasisImages out = b;
  if (b.tile > 0) out.tile = b.tile * (width / b.width);
  out.width = width;
  out.height = height;
  out.half.assign(static_cast<std::size_t>(b.layers) * width * height, 0);
  for (int layer = 0; layer < b.layers; ++layer) {
    for (int row = 0; row < height; ++row) {
      const std::size_t from = (static_cast<std::size_t>(layer) * b.height + row * b.height / height) * b.width;
      const std::size_t to = (static_cast<std::size_t>(layer) * height + row) * width;
      for (int col = 0; col < width; ++col) out.half[to + col] = b.half[from + static_cast<std::size_t>(col * b.width / width)];
    }
  }
  return out;
}

std::vector<float> upsampled(const std::vector<float>& v, int w, int h, int width, int height) {
  if (v.empty()) return v;
  std::vector<float> out(static_cast<std::size_t>(width) * height);
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      out[static_cast<std::size_t>(row) * width + col] = v[static_cast<std::size_t>(row * h / height) * w + col * w / width];
    }
  }
  return out;
}

double cpu_ms_since(std::clock_t t) { return 1000.0 * static_cast<double>(std::clock() - t) / CLOCKS_PER_SEC; }

// ---------------------------------------------------------------------------------------------
// Shadow-edge displacement: the level line of T's luminance at the middle of T_ref's range on the
// plane ((p5 + p95) / 2, planes whose range is under 0.2 have no edge), as the texels where it
// passes between a texel and its right or lower neighbour; the mean over both lines of each
// point's distance to the other line, in metres on the plane. Returns (sum of distances, count).
std::vector<std::pair<double, double>> edge_points(const std::vector<double>& y, const geom::Plane& plane, double level) {
  std::vector<std::pair<double, double>> points;
  const double du = plane.u.norm() / plane.width, dv = plane.v.norm() / plane.height;
  for (int row = 0; row < plane.height; ++row) {
    for (int col = 0; col < plane.width; ++col) {
      const double a = y[static_cast<std::size_t>(row) * plane.width + col] - level;
      if (col + 1 < plane.width) {
        const double b = y[static_cast<std::size_t>(row) * plane.width + col + 1] - level;
        if ((a < 0) != (b < 0)) points.emplace_back((col + 0.5 + a / (a - b)) * du, (row + 0.5) * dv);
      }
      if (row + 1 < plane.height) {
        const double b = y[static_cast<std::size_t>(row + 1) * plane.width + col] - level;
        if ((a < 0) != (b < 0)) points.emplace_back((col + 0.5) * du, (row + 0.5 + a / (a - b)) * dv);
      }
    }
  }
  return points;
}

std::pair<double, int> edge_displacement(const std::vector<float>& T, const std::vector<Eigen::Vector3d>& reference,
                                         const geom::Plane& plane) {
  std::vector<double> y(reference.size()), y_ref(reference.size());
  for (std::size_t x = 0; x < reference.size(); ++x) {
    y_ref[x] = study::luminance(reference[x]);
    y[x] = study::luminance(Eigen::Vector3d(T[3 * x], T[3 * x + 1], T[3 * x + 2]));
  }
  std::vector<double> sorted = y_ref;
  std::sort(sorted.begin(), sorted.end());
  const double p5 = sorted[sorted.size() / 20], p95 = sorted[sorted.size() * 19 / 20];
  if (p95 - p5 < 0.2) return {0.0, 0};
  const double level = (p5 + p95) / 2;
  const auto a = edge_points(y_ref, plane, level), b = edge_points(y, plane, level);
  if (a.empty()) return {0.0, 0};
  if (b.empty()) return {std::hypot(plane.u.norm(), plane.v.norm()) * static_cast<double>(a.size()), static_cast<int>(a.size())};
  const auto nearest_sum = [](const auto& from, const auto& to) {
    double sum = 0;
    for (const auto& p : from) {
      double best = 1e30;
      for (const auto& q : to) best = std::min(best, std::hypot(p.first - q.first, p.second - q.second));
      sum += best;
    }
    return sum;
  };
  return {nearest_sum(a, b) + nearest_sum(b, a), static_cast<int>(a.size() + b.size())};
}

// ---------------------------------------------------------------------------------------------
// Outputs.

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
  return {{"label", r.setting.label()},
          {"frequency", r.setting.bake.frequency},
          {"basis", std::string(geom::basis_name(r.setting.bake.basis))},
          {"samples", r.setting.bake.samples},
          {"texel_scale", r.setting.bake.texel_scale},
          {"form", r.setting.form.name()},
          {"bits", r.setting.bits},
          {"sun_separation", r.setting.sun},
          {"skip_threshold", r.setting.skip_threshold},
          {"change_threshold", r.setting.change_threshold},
          {"smoothing", r.setting.smoothing},
          {"render_scale", r.setting.render_scale},
          {"rms", r.error.rms},
          {"p99", r.error.p99},
          {"max", r.error.max},
          {"rms_per_sky", per_sky},
          {"edge_displacement_m", r.edge_m ? nlohmann::json(*r.edge_m) : nlohmann::json(nullptr)},
          {"edge_displacement_deg", r.edge_deg ? nlohmann::json(*r.edge_deg) : nlohmann::json(nullptr)},
          {"bake_seconds", r.bake_seconds},
          {"bake_bytes", r.bake_bytes},
          {"gpu_bytes", r.gpu_bytes},
          {"layers", r.layers},
          {"skipped_layers", r.skipped_layers},
          {"blend_ms", r.blend_ms},
          {"blend_cpu_ms", r.blend_cpu_ms},
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
      "| # | ν | basis | K | texel scale | form | bits | sun | S thr. | ΔS thr. | smoothing s | render scale | RMS | p99 | max | edge (m / °) | bake s | "
      "bake MB | GPU MB | blend ms wall / CPU | frame ms wall / CPU | cost ms (frames/s) | Pareto |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  int k = 0;
  for (const Result& r : results) {
    const Setting& s = r.setting;
    char edge[48] = "—";
    if (r.edge_m) std::snprintf(edge, sizeof edge, "%.3f / %.3f", *r.edge_m, *r.edge_deg);
    char row[512];
    std::snprintf(row, sizeof row,
                  "| %d | %d | %s | %d | 1/%d | %s | %d | %s | %g | %g | %g | %g | %.4f | %.4f | %.4f | %s | %.1f | %.2f | %.1f | %.1f / %.1f | "
                  "%.1f / %.1f | %.1f (%.0f) | %s |\n",
                  k++, s.bake.frequency, std::string(geom::basis_name(s.bake.basis)).c_str(), s.bake.samples,
                  s.bake.texel_scale, s.form.name().c_str(), s.bits, s.sun ? "on" : "off", s.skip_threshold, s.change_threshold, s.smoothing, s.render_scale, r.error.rms,
                  r.error.p99, r.error.max, edge, r.bake_seconds, static_cast<double>(r.bake_bytes) / 1e6,
                  static_cast<double>(r.gpu_bytes) / 1e6, r.blend_ms, r.blend_cpu_ms, r.frame_ms, r.frame_cpu_ms, r.cost_ms,
                  1000.0 / r.cost_ms,
                  r.pareto ? "**yes**" : "");
    md += row;
  }
  if (!results.empty() && results.front().sequence) {
    md += "\nSky sequence (--sequence): error of T against each frame's reference, mean over the frames (worst "
          "frame); still: a fresh blend of each frame's own estimate; re-blends: share of frames × planes blended.\n\n"
          "| # | setting | ΔS thr. | smoothing s | RMS mean (worst) | p99 mean (worst) | max | still RMS mean | still max | "
          "re-blends |\n|---|---|---|---|---|---|---|---|---|---|\n";
    k = 0;
    for (const Result& r : results) {
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

// ---------------------------------------------------------------------------------------------
// The sweep.

struct TradeOptions {
  std::string site_file = "config/sample_site.yaml";
  std::string sky_calib = "config/sky_camera.yaml";
  std::string hmd_calib = "config/hmd_camera.yaml";
  std::string skies_dir = "data/hdri";
  std::vector<std::string> skies;       // stems; empty: every .exr
  std::string out_dir = "build/trade";
  std::vector<int> frequencies{2, 4};
  std::vector<std::string> bases{"faces", "corners"};
  std::vector<int> samples{4, 16};
  std::vector<int> texel_scales{8};
  std::vector<std::string> forms{"full", "lean", "pca8"};
  std::vector<int> bits{16, 8};
  std::vector<std::string> sun{"on", "off"};
  std::vector<double> skip_thresholds{0.0, 0.005};
  std::vector<double> change_thresholds{0.002};
  std::vector<double> smoothings{0.0};
  std::vector<double> render_scales{1.0};
  int frame_width = 640, frame_height = 480;
  int blend_repeats = 9, frame_repeats = 30;
  int supersample = 2, reference_supersample = 4;
  int threads = 2;
  int timing_scale = 1;
  // The whole-frame time the plot and the Pareto front use: "cpu", the process CPU time per frame
  // (compositor + blend) over `cores` (the wall time on an idle machine whose cores share the work
  // evenly; it does not change with other processes' load), or "wall", as measured.
  std::string clock = "cpu";
  int cores = 2;   // blend timing and GPU memory at the site's resolution divided by this
  // Seconds between sky changes: the service blends once per new sky (on the sky thread), not
  // per frame, so the blend's CPU time is spread over the frames between; 0 counts it in every
  // frame (the worst frame: the one whose sky changed, on one thread).
  double sky_interval = 0.0;
  bool quick = false;
  // The sky sequence (--sequence): measures the change threshold and the smoothing.
  bool sequence = false;
  int sequence_frames = 60;
  std::string sequence_start = "2026-11-23T05:00:00Z";
  double sequence_lat = 34.68, sequence_lon = 135.84;
  double sequence_cloud = 0.65;
  int sequence_equirect = 128;
};

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
          const BakeKey key{f, *basis, k, scale};
          for (const std::string& form_text : o.forms) {
            const Form form = parse_form(form_text);
            for (int bits : o.bits) {
              if (bits != 8 && bits != 16) throw InputError("option --bits: 16 or 8");
              if (bits == 8 && form.form == blend::BasisForm::Pca) continue;
              for (const std::string& sun : o.sun) {
                if (sun != "on" && sun != "off") throw InputError("option --sun: on, off");
                for (double skip : o.skip_thresholds) {
                  for (double change : o.change_thresholds) {
                    for (double smoothing : o.smoothings) {
                      for (double render_scale : o.render_scales) {
                        settings.push_back({key, form, bits, sun == "on", skip, change, smoothing, render_scale});
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
    d.mesh = scene::load_model(d.site.model, d.site.up, d.site.scale);
    for (const auto& p : full_site.planes) d.full_planes.push_back(p);
    sites.emplace(s, std::move(d));
  }
  return sites;
}

// The bakes' folders, and the seconds each took when made (a PCA form: its compression only).
struct Bakes {
  std::map<BakeKey, fs::path> dirs;
  std::map<BakeKey, double> seconds;
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
      baker::compress_bake(copy, pca, nullptr);
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

// By (plane resolution divisor, sky): T per plane and texel.
using References = std::map<std::pair<int, std::size_t>, std::vector<std::vector<Eigen::Vector3d>>>;

// The dense reference per resolution and sky.
References make_references(const TradeOptions& o, const std::vector<SkyData>& skies, const std::set<int>& scales,
                           const Sites& sites) {
  References references;
  for (int s : scales) {
    for (std::size_t i = 0; i < skies.size(); ++i) {
      const study::DenseReference ref =
          study::dense_reference(skies[i].equirect, sites.at(s).site, sites.at(s).mesh, o.reference_supersample);
      std::printf("reference 1/%d %s: %.1f s\n", s, skies[i].name.c_str(), ref.seconds);
      std::fflush(stdout);
      references[{s, i}] = ref.planes;
    }
  }
  return references;
}

using EstimatorKey = std::tuple<int, geom::DomeBasis, bool>;

// The sky estimators per (ν, basis, sun separation), each with its dome (which it keeps by
// reference), made when first asked for.
struct Estimators {
  explicit Estimators(const camera::CameraCalibration& c) : calibration(c) {}
  const sky::SkyEstimator& estimator_for(const Setting& s) {
    auto& estimator = by_key[{s.bake.frequency, s.bake.basis, s.sun}];
    if (!estimator) {
      auto& dome = domes[s.bake.frequency];
      if (!dome) dome = std::make_unique<geom::Dome>(s.bake.frequency);
      sky::SkyEstimateOptions sky_options;
      sky_options.sun_mode = s.sun ? sky::SunMode::Auto : sky::SunMode::Off;
      sky_options.table.basis = s.bake.basis;
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
  const EstimatorKey key{s.bake.frequency, s.bake.basis, s.sun};
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

// One compositor per (bake, sun map, render scale), all made first and then timed a frame each
// in turn, round after round, so that a change of the machine's load falls on all alike.
struct FrameRig {
  std::unique_ptr<render::SunShadowMap> shadow_map;
  std::vector<gpu::Texture> ratios;
  std::vector<GLuint> names;
  std::vector<Eigen::Vector3d> sky_radiance;
  std::unique_ptr<render::Compositor> compositor;
  cv::Mat image;
  render::CompositeInput input;
  std::vector<double> wall, cpu;
};
using FrameKey = std::tuple<BakeKey, bool, double>;
using FrameTimes = std::map<FrameKey, std::pair<double, double>>;  // median wall and CPU ms

// The compositor's frame time per (bake, sun map, render scale), on the GL context current.
FrameTimes time_frames(const TradeOptions& o, const Grid& grid, const Sites& sites, const Bakes& made) {
  const std::map<BakeKey, fs::path>& bakes = made.dirs;
  const camera::CameraCalibration hmd = study::scaled_camera(o.hmd_calib, o.frame_width, o.frame_height);
  const double az = 140 * std::numbers::pi / 180, el = 35 * std::numbers::pi / 180;
  const blend::SunLight bench_sun{Eigen::Vector3d(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)),
                                   Eigen::Vector3d::Constant(3.0)};
  std::map<FrameKey, std::unique_ptr<FrameRig>> frame_rigs;
  for (const Setting& s : grid.settings) {
    auto& rig = frame_rigs[std::make_tuple(s.bake, s.sun, s.render_scale)];
    if (rig) continue;
    rig = std::make_unique<FrameRig>();
    const SiteData& site = sites.at(s.bake.texel_scale);
    const fs::path dir = bakes.at(s.bake);
    const bake_format::Manifest manifest = bake_format::read_manifest(dir);
    std::vector<std::size_t> shape;
    const std::vector<float> transfer = bake_format::read_npy(dir / manifest.transfer_file, &shape);
    std::vector<geom::Plane> planes;
    for (const auto& record : manifest.planes) planes.push_back(record.plane);
    if (s.sun) {
      rig->shadow_map = std::make_unique<render::SunShadowMap>(site.mesh, planes);
      rig->shadow_map->update(bench_sun.direction, 0.0047);
    }
    for (const auto& plane : planes) {
      const std::vector<float> T(static_cast<std::size_t>(plane.width) * plane.height * 3, 0.8f);
      rig->ratios.push_back(render::upload_shadow_ratio(T, plane.width, plane.height));
      rig->names.push_back(rig->ratios.back().get());
    }
    render::CompositorOptions options;
    options.lens.render_scale = s.render_scale;
    rig->compositor = std::make_unique<render::Compositor>(site.site, site.mesh, manifest, transfer, hmd, options);
    rig->image = cv::Mat(hmd.image_height, hmd.image_width, CV_8UC3);
    cv::randu(rig->image, cv::Scalar::all(0), cv::Scalar::all(256));
    rig->sky_radiance.assign(manifest.layer_count(), Eigen::Vector3d(0.3, 0.4, 0.6));
    rig->input.camera = rig->image;
    rig->input.pose = study::visitor_pose();
    rig->input.sky = rig->sky_radiance;
    if (s.sun) rig->input.sun = bench_sun;
    rig->input.shadow_ratios = rig->names;
    rig->input.sun_shadow = rig->shadow_map.get();
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
  for (auto& [key, rig] : frame_rigs) frame_ms[key] = {median(rig->wall), median(rig->cpu)};
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
};

// Also the bake's cost in `r`: its time, size on disk and stored layers.
SettingBake load_setting_bake(const Bakes& made, Result& r) {
  const Setting& s = r.setting;
  const bool pca = s.form.form == blend::BasisForm::Pca;
  const fs::path bake_dir = pca ? made.pca_dirs.at({s.bake, s.form.components, s.form.tile}) : made.dirs.at(s.bake);
  SettingBake bake{bake_format::read_manifest(bake_dir), {}};
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
  const std::vector<float> fine_visibility = upsampled(visibility, basis.width, basis.height, fine.width, fine.height);
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
  std::vector<double> times, cpu;
  for (int rep = 0; rep <= o.blend_repeats; ++rep) {
    const auto t = Clock::now();
    const std::clock_t c = std::clock();
    timed.blend(rep % 2 ? nudged : w, fine_visibility, 1, &bench.workers);
    if (rep > 0) {  // the first: allocations
      times.push_back(1000.0 * seconds_since(t));
      cpu.push_back(cpu_ms_since(c));
    }
  }
  r.skipped_layers += timed.skipped_layers();
  r.blend_ms += median(times);
  r.blend_cpu_ms += median(cpu);
}

// T for every sky against the reference (the errors, and on sunny skies the shadow edge's
// displacement); the blend's time on the first sky.
void evaluate_skies(const Bench& bench, const SettingBake& bake, const sky::SkyEstimator& estimator, Result& r) {
  const Setting& s = r.setting;
  const std::vector<SkyData>& skies = bench.skies;
  const bake_format::Manifest& manifest = bake.manifest;
  const std::vector<blend::BasisImages>& basis = bake.basis;
  const SiteData& site = bench.sites.at(s.bake.texel_scale);
  std::vector<double> diffs;
  double edge_sum = 0;
  int edge_count = 0;
  for (std::size_t i = 0; i < skies.size(); ++i) {
    const sky::SkyEstimate estimate = estimator.estimate(skies[i].frame);
    const std::vector<Eigen::Vector3d> S = sky::layer_radiances(estimate.luminance);
    std::optional<blend::SunLight> sun;
    if (estimate.sun) sun = blend::SunLight{estimate.sun->direction, estimate.sun->energy};
    const auto& reference = bench.references.at({s.bake.texel_scale, i});
    std::vector<double> sky_diffs;
    for (std::size_t j = 0; j < basis.size(); ++j) {
      std::vector<float> visibility;
      if (sun) {
        visibility.resize(basis[j].texel_count());
        baker::area_light_visibility(site.mesh, manifest.planes[j].plane, estimate.sun->disc_directions,
                                     estimate.sun->disc_weights, visibility);
      }
      const blend::BlendWeights w = blend::blend_weights(basis[j], S, sun);
      blend::CpuBlender ratios(basis[j], s.skip_threshold, 0.0);
      ratios.blend(w, visibility, 1, &bench.workers);
      const std::vector<float>& rgba = *ratios.rgba();
      std::vector<float> T(basis[j].texel_count() * 3);
      for (std::size_t x = 0; x < basis[j].texel_count(); ++x) std::copy_n(rgba.data() + 4 * x, 3, T.data() + 3 * x);
      for (std::size_t x = 0; x < basis[j].texel_count(); ++x) {
        for (int ch = 0; ch < 3; ++ch) sky_diffs.push_back(std::abs(T[3 * x + static_cast<std::size_t>(ch)] - reference[j][x][ch]));
      }
      if (skies[i].sunny) {
        const auto [sum, count] = edge_displacement(T, reference[j], manifest.planes[j].plane);
        edge_sum += sum;
        edge_count += count;
      }
      if (i == 0) time_blend(bench, j, basis[j], visibility, w, r);
    }
    r.rms_per_sky[skies[i].name] = study::errors_of(sky_diffs).rms;
    diffs.insert(diffs.end(), sky_diffs.begin(), sky_diffs.end());
  }
  r.error = study::errors_of(std::move(diffs));
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
  const auto& estimates = bench.sequence_inputs.estimates.at({s.bake.frequency, s.bake.basis, s.sun});
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
  std::tie(r.frame_ms, r.frame_cpu_ms) = frame_ms.at(std::make_tuple(s.bake, s.sun, s.render_scale));
  r.whole_frame_ms = r.frame_ms + r.blend_ms;
  r.whole_frame_cpu_ms = r.frame_cpu_ms + r.blend_cpu_ms;
  if (o.sky_interval <= 0.0) {
    r.cost_ms = o.clock == "wall" ? r.whole_frame_ms : r.whole_frame_cpu_ms / o.cores;
  } else {
    // The frame rate the cores sustain with a blend every sky_interval: per second,
    // fps · frame + blend / interval of work, `cores` seconds of it at most (CPU), or the
    // frame's wall time plus its share of the blend's (wall).
    const double frame = o.clock == "wall" ? r.frame_ms : r.frame_cpu_ms / o.cores;
    const double blend_per_s = (o.clock == "wall" ? r.blend_ms : r.blend_cpu_ms / o.cores) / o.sky_interval;
    r.cost_ms = frame / std::max(1.0 - blend_per_s / 1000.0, 1e-3);
  }
}

// Setting `index` of `count`: T for every sky against the reference, the blend's time on the
// first sky, the sequence (--sequence) and the frame's cost; its line of progress.
Result evaluate_setting(const Bench& bench, const Setting& s, int index, std::size_t count) {
  const auto t_setting = Clock::now();
  Result r;
  r.setting = s;
  const SettingBake bake = load_setting_bake(bench.bakes, r);
  const sky::SkyEstimator* estimator = &bench.estimators.estimator_for(s);
  evaluate_skies(bench, bake, *estimator, r);
  if (bench.run.o.sequence) r.sequence = run_sequence(bench, bake, s);
  add_frame_cost(bench.run.o, bench.frame_ms, r);
  std::printf("[%d/%zu] %-44s RMS %.4f p99 %.4f max %.4f | blend %.2f ms frame %.2f ms (%.1f s)\n", index, count,
              s.label().c_str(), r.error.rms, r.error.p99, r.error.max, r.blend_ms, r.frame_ms, seconds_since(t_setting));
  if (r.sequence) {
    std::printf("    sequence: RMS %.4f (worst %.4f, still %.4f) max %.4f, re-blends %.0f%%\n", mean_of(r.sequence->rms),
                max_of(r.sequence->rms), mean_of(r.sequence->still_rms), max_of(r.sequence->max), 100.0 * blend_fraction(*r.sequence));
  }
  std::fflush(stdout);
  return r;
}

// trade.json: the run's settings, every setting's result and the Pareto front (indices).
nlohmann::json trade_json(const Run& run, const std::vector<SkyData>& skies, const std::vector<Result>& results) {
  const TradeOptions& o = run.o;
  const study::SequenceOptions& sequence = run.sequence;
  nlohmann::json settings_json = nlohmann::json::array();
  nlohmann::json front = nlohmann::json::array();
  for (std::size_t k = 0; k < results.size(); ++k) {
    settings_json.push_back(to_json(results[k]));
    if (results[k].pareto) front.push_back(k);
  }
  nlohmann::json sky_names = nlohmann::json::array();
  for (const SkyData& d : skies) sky_names.push_back({{"name", d.name}, {"sunny", d.sunny}});
  return nlohmann::json{{"frame", {{"width", o.frame_width}, {"height", o.frame_height}}},
                        {"skies", sky_names},
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
                        {"seconds", seconds_since(run.start)}};
}

// The Pareto front marked; OUT/trade.json, trade.md and trade.svg; the table printed.
void write_outputs(const Run& run, const std::vector<SkyData>& skies, std::vector<Result>& results) {
  const TradeOptions& o = run.o;
  const fs::path& out = run.out;
  mark_pareto(results);
  write_file_atomic(out / "trade.json", trade_json(run, skies, results).dump(2) + "\n");
  const std::string md = markdown_table(results);
  write_file_atomic(out / "trade.md", md);
  char title[160];
  std::snprintf(title, sizeof title, "skylit-bench trade: %zu settings, %zu skies, %d×%d", results.size(), skies.size(),
                o.frame_width, o.frame_height);
  std::string x_label = o.clock == "wall"
                            ? "frame time, ms (log): compositor + CPU blend, wall"
                            : "frame time, ms (log): process CPU time of compositor + CPU blend / " + std::to_string(o.cores) + " cores";
  if (o.sky_interval > 0.0) {
    char every[64];
    std::snprintf(every, sizeof every, ", a blend every %g s", o.sky_interval);
    x_label += every;
  } else {
    x_label += ", a blend every frame";
  }
  write_file_atomic(out / "trade.svg", svg_plot(results, title, x_label));
  std::printf("\n%s\nwrote %s, %s, %s (%.0f s)\n", md.c_str(), (out / "trade.json").c_str(), (out / "trade.md").c_str(),
              (out / "trade.svg").c_str(), seconds_since(run.start));
}

int run_trade(TradeOptions o) {
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
  const References references = make_references(o, skies, grid.scales, sites);
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

  write_outputs(run, skies, results);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"skylit-bench: measurements of the sky stage", "skylit-bench"};
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
  trade->add_option("--forms", o.forms, "full, lean, cropped, pcaK, pcaKtN (clustered PCA, tiles of N texels)")->delimiter(',')->capture_default_str();
  trade->add_option("--bits", o.bits, "layer bit depth: 16 (half), 8 (unorm8; not with PCA)")->delimiter(',')->capture_default_str();
  trade->add_option("--sun", o.sun, "sun separation: on, off")->delimiter(',')->capture_default_str();
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
    return run_trade(o);
  } catch (const InputError& e) {
    std::fprintf(stderr, "skylit-bench: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-bench: internal error: %s\n", e.what());
    return 3;
  }
}
