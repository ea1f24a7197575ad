// Shadow ratios on the CPU: the weights of a sky, the fast blend (threads over blocks of
// texels, kernels in kernel.cpp) and the double-precision reference.
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <thread>

#include "kernel.hpp"
#include "skylit/blend/workers.hpp"
#include "skylit/base/error.hpp"

namespace skylit::blend {
namespace {

constexpr const char* kChannel[3] = {"r", "g", "b"};

[[noreturn]] void bad_input(const std::string& field, const std::string& problem, const std::string& fix) {
  throw InputError(input_message({}, -1, -1, field, problem, fix));
}

std::string describe(double x) {
  if (std::isnan(x)) return "NaN";
  if (std::isinf(x)) return x > 0 ? "+inf" : "-inf";
  return std::to_string(x);
}

// A basis must hold what its header says before any loop trusts its sizes.
void check_basis(const BasisImages& basis) {
  const std::string field = "basis '" + basis.name + "'";
  check_basis_storage(basis);
  if (basis.tile < 0 || (basis.tile > 0 && !basis.compressed())) {
    bad_input(field + ".tile", std::to_string(basis.tile) + (basis.tile < 0 ? " is negative" : " without a projection"),
              "load the basis with load_basis");
  }
  const Eigen::Index projected = static_cast<Eigen::Index>(basis.tile_count()) * basis.layers;
  if (basis.compressed() && basis.projection.cols() != projected) {
    bad_input(field + ".projection",
              std::to_string(basis.projection.cols()) + " columns for " + std::to_string(basis.layers) +
                  " stored layers in " + std::to_string(basis.tile_count()) + " tile(s)",
              "load the basis with load_basis");
  }
  if (basis.compressed() && !basis.projection.allFinite()) {
    bad_input(field + ".projection", "holds a value that is not finite", "re-compress the bake (skylit-bake compress)");
  }
  if (basis.unoccluded.size() != static_cast<std::size_t>(basis.source_layers())) {
    bad_input(field + ".unoccluded",
              std::to_string(basis.unoccluded.size()) + " values for " + std::to_string(basis.source_layers()) +
                  " layers",
              "give one A per layer (load_basis copies them from the manifest)");
  }
  for (std::size_t i = 0; i < basis.unoccluded.size(); ++i) {
    const double a = basis.unoccluded[i];
    if (!std::isfinite(a) || a < 0.0) {
      bad_input(field + ".unoccluded[" + std::to_string(i) + "]", "value " + describe(a) + " is not a finite A >= 0",
                "re-bake; A is a solid angle");
    }
  }
  if (!basis.normal.allFinite() || basis.normal.norm() < 0.5) {
    bad_input(field + ".normal", "not a unit vector", "use the plane normal from the manifest");
  }
}

void check_options(const BlendOptions& options) {
  if (!std::isfinite(options.min_denominator) || options.min_denominator < 0.0) {
    bad_input("min_denominator", "value " + describe(options.min_denominator) + " is not finite and >= 0",
              "use a small positive number such as 1e-12");
  }
  if (options.threads < 0) {
    bad_input("threads", "value " + std::to_string(options.threads) + " is negative",
              "use 0 for all hardware threads, or a positive count");
  }
}

void check_rgb(const Eigen::Vector3d& value, const std::string& field, const std::string& fix) {
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(value[c]) || value[c] < 0.0) {
      bad_input(field + "." + kChannel[c], "value " + describe(value[c]) + " is not finite and >= 0", fix);
    }
  }
}

// E·max(0, n·ω) per channel: a separated source's irradiance on the plane. `field` names it in
// errors ("sun", "sources[2]").
Eigen::Vector3d source_on_plane(const BasisImages& basis, const SunLight& sun, const std::string& field) {
  check_rgb(sun.energy, field + ".energy", "pass the sun's irradiance, linear RGB, 0 when it is hidden");
  const Vec3& d = sun.direction;
  if (!d.allFinite() || d.norm() < 1e-9) {
    // Appended piecewise: GCC 12 warns falsely (-Wrestrict) on "(" + std::string.
    std::string problem = "(";
    problem += describe(d.x()) + ", " + describe(d.y()) + ", " + describe(d.z());
    problem += ") is not a direction";
    bad_input(field + ".direction", problem, "pass a unit vector towards the sun, site frame, or no sun");
  }
  const double cosine = std::max(0.0, basis.normal.normalized().dot(d.normalized()));
  return sun.energy * cosine;
}

// E_sun·max(0, n·ω_sun) per channel: the sun's irradiance on the plane (zero without a sun).
Eigen::Vector3d sun_on_plane(const BasisImages& basis, const std::optional<SunLight>& sun) {
  if (!sun) return Eigen::Vector3d::Zero();
  return source_on_plane(basis, *sun, "sun");
}

std::string source_field(std::size_t k) { return "sources[" + std::to_string(k) + "]"; }

void check_sizes(const BasisImages& basis, std::span<const float> sun_visibility, std::size_t out_size,
                 bool sun_term) {
  const std::size_t texels = basis.texel_count();
  if (out_size != 3 * texels) {
    bad_input("out", "has " + std::to_string(out_size) + " values; plane '" + basis.name + "' needs " +
                         std::to_string(3 * texels) + " (3 per texel)",
              "size it width x height x 3");
  }
  if (!sun_visibility.empty() && sun_visibility.size() != texels) {
    bad_input("sun_visibility", "has " + std::to_string(sun_visibility.size()) + " values; plane '" + basis.name +
                                    "' has " + std::to_string(texels) + " texels",
              "give one V per texel, or none");
  }
  if (sun_term && sun_visibility.empty()) {
    bad_input("sun_visibility", "is empty but the sun lights plane '" + basis.name + "'",
              "give one V in [0, 1] per texel (all 1 when nothing shadows the sun), or blend without the sun");
  }
}

[[noreturn]] void bad_visibility(const std::string& field = "sun_visibility") {
  bad_input(field, "holds a value outside [0, 1] or NaN",
            "give the visible fraction of the sun per texel, 0 to 1");
}

void set_source_weights(BlendWeights& w, const std::vector<Eigen::Vector3d>& terms, const Eigen::Vector3d& inverse) {
  for (const Eigen::Vector3d& term : terms) w.sources.push_back(term.cwiseProduct(inverse).cast<float>());
  w.sun = w.sources.empty() ? Eigen::Vector3f::Zero() : w.sources.front();
}

}  // namespace

bool blend_simd_available() { return detail::cpu_has_avx2_f16c_fma(); }

float BasisImages::value(int layer, int col, int row) const {
  if (!cropped()) {
    return half_to_float(half[static_cast<std::size_t>(layer) * texel_count() +
                              static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(col)]);
  }
  const LayerCrop& c = crops[static_cast<std::size_t>(layer)];
  if (!c.contains(col, row)) return c.fill;
  return half_to_float(half[c.offset + static_cast<std::size_t>(row - c.row) * static_cast<std::size_t>(c.cols) +
                            static_cast<std::size_t>(col - c.col)]);
}

void check_basis_storage(const BasisImages& basis) {
  const std::string field = "basis '" + basis.name + "'";
  if (basis.width < 0 || basis.height < 0 || basis.layers < 0) {
    bad_input(field, "negative size " + std::to_string(basis.width) + "x" + std::to_string(basis.height) + "x" +
                         std::to_string(basis.layers),
              "load the basis with load_basis");
  }
  if (basis.cropped()) {
    if (basis.crops.size() != static_cast<std::size_t>(basis.layers) || basis.tile > 0) {
      bad_input(field + ".crops", std::to_string(basis.crops.size()) + " rectangles for " + std::to_string(basis.layers) +
                                      " layers" + (basis.tile > 0 ? " of a tiled basis" : ""),
                "load the basis with load_basis(…, BasisForm::Cropped)");
    }
    std::size_t expected = 0;
    for (const LayerCrop& c : basis.crops) {
      const bool inside = c.col >= 0 && c.row >= 0 && c.cols >= 0 && c.rows >= 0 && c.col + c.cols <= basis.width &&
                          c.row + c.rows <= basis.height;
      if (!inside || c.offset != expected || !std::isfinite(c.fill)) {
        bad_input(field + ".crops", "a rectangle lies outside the plane, out of order or with a fill that is not finite",
                  "load the basis with load_basis(…, BasisForm::Cropped)");
      }
      expected += static_cast<std::size_t>(c.cols) * static_cast<std::size_t>(c.rows);
    }
    if (basis.half.size() != expected) {
      bad_input(field, "holds " + std::to_string(basis.half.size()) + " values for rectangles of " +
                           std::to_string(expected) + " texels",
                "load the basis with load_basis(…, BasisForm::Cropped)");
    }
  } else if (basis.half.size() != basis.texel_count() * static_cast<std::size_t>(basis.layers)) {
    bad_input(field, "holds " + std::to_string(basis.half.size()) + " values for " + std::to_string(basis.layers) +
                         " layers of " + std::to_string(basis.width) + "x" + std::to_string(basis.height),
              "load the basis with load_basis");
  }
}

BasisImages uncropped(const BasisImages& basis) {
  if (!basis.cropped()) return basis;
  BasisImages out = basis;
  out.crops.clear();
  out.half.assign(basis.texel_count() * static_cast<std::size_t>(basis.layers), 0);
  for (int k = 0; k < basis.layers; ++k) {
    const LayerCrop& c = basis.crops[static_cast<std::size_t>(k)];
    std::uint16_t* layer = out.half.data() + static_cast<std::size_t>(k) * basis.texel_count();
    std::fill_n(layer, basis.texel_count(), float_to_half(c.fill));
    for (int r = 0; r < c.rows; ++r) {
      std::copy_n(basis.half.data() + c.offset + static_cast<std::size_t>(r) * static_cast<std::size_t>(c.cols), c.cols,
                  layer + static_cast<std::size_t>(c.row + r) * static_cast<std::size_t>(basis.width) + static_cast<std::size_t>(c.col));
    }
  }
  return out;
}


namespace {

// The weights for separated terms already on the plane (E_k c_k per source, in order).
BlendWeights weights_for_terms(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                               const std::vector<Eigen::Vector3d>& terms, const BlendOptions& options) {
  const std::size_t layers = static_cast<std::size_t>(basis.source_layers());
  if (S.size() != layers) {
    bad_input("S", std::to_string(S.size()) + " luminance values for the " + std::to_string(layers) +
                       " layers of plane '" + basis.name + "'",
              "give one RGB value per dome face of the bake");
  }
  for (std::size_t i = 0; i < layers; ++i) {
    if (basis.layers_per_face > 1) {
      // Corner coefficients of a linear fit may be negative, never non-finite.
      if (!S[i].allFinite()) {
        bad_input("S[" + std::to_string(i) + "]", "is not finite",
                  "luminance parameters are finite; check the sky camera and its calibration");
      }
      continue;
    }
    check_rgb(S[i], "S[" + std::to_string(i) + "]",
              "luminance parameters are linear radiances >= 0; check the sky camera and its calibration");
  }

  BlendWeights w;
  for (const Eigen::Vector3d& term : terms) w.denominator += term;
  for (std::size_t i = 0; i < layers; ++i) w.denominator += S[i] * basis.unoccluded[i];

  Eigen::Vector3d inverse = Eigen::Vector3d::Zero();  // 1/D, 0 for a channel without light
  for (int c = 0; c < 3; ++c) {
    w.no_light[static_cast<std::size_t>(c)] = !(w.denominator[c] > options.min_denominator);
    if (!w.no_light[static_cast<std::size_t>(c)]) inverse[c] = 1.0 / w.denominator[c];
  }
  if (basis.compressed()) {
    // u_k = Σ_l w_l projection(l, k), in double: the weights of the mean and eigen-images (of
    // every tile, for a tiled basis).
    const Eigen::Index columns = basis.projection.cols();
    Eigen::MatrixXd w_rows = Eigen::MatrixXd::Zero(3, static_cast<Eigen::Index>(layers));
    for (std::size_t i = 0; i < layers; ++i) {
      if (basis.unoccluded[i] == 0.0) continue;
      w_rows.col(static_cast<Eigen::Index>(i)) = S[i].cwiseProduct(inverse);
    }
    const Eigen::MatrixXd projected = w_rows * basis.projection.cast<double>();  // 3 × columns
    std::vector<Eigen::Vector3d> u(static_cast<std::size_t>(columns));
    for (Eigen::Index k = 0; k < columns; ++k) u[static_cast<std::size_t>(k)] = projected.col(k);
    w.face.assign(u.size(), Eigen::Vector3f::Zero());
    for (std::size_t k = 0; k < u.size(); ++k) {
      w.face[k] = u[k].cast<float>();
      // Exactly zero: Eigen's isZero() without a precision treats |w| ≤ 1e-5 as zero, and an
      // eigen-image's weight may be that small and still move T by as much.
      if (!w.face[k].isZero(0)) w.active.push_back(static_cast<int>(k));
    }
    set_source_weights(w, terms, inverse);
    return w;
  }
  w.face.assign(layers, Eigen::Vector3f::Zero());
  for (std::size_t i = 0; i < layers; ++i) {
    // A face the plane cannot see (A = 0, hence B = 0) costs nothing, whatever its S.
    if (basis.unoccluded[i] == 0.0) continue;
    w.face[i] = S[i].cwiseProduct(inverse).cast<float>();
    if (!w.face[i].isZero(0)) w.active.push_back(static_cast<int>(i));
  }
  set_source_weights(w, terms, inverse);
  return w;
}

}  // namespace

BlendWeights blend_weights(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                           const std::optional<SunLight>& sun, const BlendOptions& options) {
  check_basis(basis);
  check_options(options);
  std::vector<Eigen::Vector3d> terms;
  if (sun) terms.push_back(sun_on_plane(basis, sun));
  return weights_for_terms(basis, S, terms, options);
}

BlendWeights blend_weights_sources(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                                   std::span<const SunLight> sources, const BlendOptions& options) {
  check_basis(basis);
  check_options(options);
  std::vector<Eigen::Vector3d> terms;
  for (std::size_t k = 0; k < sources.size(); ++k) terms.push_back(source_on_plane(basis, sources[k], source_field(k)));
  return weights_for_terms(basis, S, terms, options);
}

namespace {

// Checks shared by blend_cpu and blend_cpu_sources: the weights fit the basis.
void check_weights(const BasisImages& basis, const BlendWeights& weights, const BlendOptions& options) {
  check_basis(basis);
  check_options(options);
  const std::size_t layers = static_cast<std::size_t>(basis.layers) * static_cast<std::size_t>(basis.tile_count());
  if (weights.face.size() != layers) {
    bad_input("weights.face", std::to_string(weights.face.size()) + " weights for the " + std::to_string(layers) +
                                  " layers of plane '" + basis.name + "'",
              "compute the weights with blend_weights for this basis");
  }
  int previous = -1;
  for (const int i : weights.active) {
    if (i <= previous || static_cast<std::size_t>(i) >= layers) {
      bad_input("weights.active", "layer " + std::to_string(i) + " is out of order or out of range",
                "compute the weights with blend_weights for this basis");
    }
    previous = i;
  }
  if (!weights.sun.allFinite()) {
    bad_input("weights.sun", "is not finite", "compute the weights with blend_weights");
  }
}

// The threads' statistics as one BlendStats; InputError naming `visibility_field` when a thread
// met a V outside [0, 1].
BlendStats merged_stats(const std::vector<detail::RangeStats>& stats, const std::string& visibility_field) {
  detail::RangeStats total;
  for (const detail::RangeStats& s : stats) {
    total.max_t = std::max(total.max_t, s.max_t);
    total.min_t = std::min(total.min_t, s.min_t);
    total.clamped += s.clamped;
    total.bad_visibility |= s.bad_visibility;
  }
  if (total.bad_visibility) bad_visibility(visibility_field);
  BlendStats result;
  result.max_above_one = std::max(0.0f, total.max_t - 1.0f);
  result.max_below_zero = std::max(0.0f, -total.min_t);
  result.clamped = total.clamped;
  return result;
}

// The cropped form's blend, a band of rows at a time (their accumulators stay in L2): each
// active layer adds its fill everywhere (summed once into the band's start value), then
// w·(B − fill) over its rectangle's span of each row, four layers per pass where their spans
// overlap (detail::add_spans_avx2); then the separated terms, the channels without light, the
// clamp. Bands go to threads; per texel the
// layers are summed in the same order whatever the split.
BlendStats run_cropped(const BasisImages& basis, const detail::BlendJob& job, const BlendOptions& options,
                       const std::string& visibility_field) {
  const auto width = static_cast<std::size_t>(basis.width);
  const std::size_t active = job.active.size();
  float base[3] = {0.0f, 0.0f, 0.0f};
  for (std::size_t a = 0; a < active; ++a) {
    const float fill = basis.crops[static_cast<std::size_t>(job.active[a])].fill;
    for (int c = 0; c < 3; ++c) base[c] += job.weights[3 * a + static_cast<std::size_t>(c)] * fill;
  }
  const auto add_spans = options.use_simd && detail::cpu_has_avx2_f16c_fma() ? detail::add_spans_avx2 : detail::add_spans_portable;
  // Rows per band: accumulators for 32 Ki texels (384 KiB, in L2), so that each layer's part of
  // a band is a long sequential run (2 Ki and 8 Ki texels measured 1.5× and 1.25× slower).
  const std::size_t band = std::max<std::size_t>(1, std::size_t{32768} / std::max<std::size_t>(width, 1));
  const auto rows = static_cast<std::size_t>(basis.height);
  const std::size_t chunks = (rows + band - 1) / band;
  std::optional<BlendWorkers> own;
  BlendWorkers* workers = options.workers;
  if (!workers) {
    const std::size_t wanted = options.threads > 0 ? static_cast<std::size_t>(options.threads)
                                                   : std::max(1u, std::thread::hardware_concurrency());
    workers = &own.emplace(static_cast<int>(std::max<std::size_t>(1, std::min(wanted, std::max<std::size_t>(chunks, 1)))));
  }
  std::vector<detail::RangeStats> stats(static_cast<std::size_t>(workers->size()));
  workers->run(chunks, [&](std::size_t chunk, int worker) {
    detail::RangeStats& s = stats[static_cast<std::size_t>(worker)];
    const std::size_t y0 = chunk * band, y1 = std::min(rows, y0 + band), count = (y1 - y0) * width;
    std::vector<float> acc(3 * count);
    float* r = acc.data();
    float* g = r + count;
    float* b = g + count;
    std::fill_n(r, count, base[0]);
    std::fill_n(g, count, base[1]);
    std::fill_n(b, count, base[2]);
    // Four active layers at a time (in order), row by row through the band: each layer's rows
    // are stored back to back, so four sequential runs of halves that the memory's prefetchers
    // follow. A row is cut where any of the four spans starts or ends, and each piece adds the
    // layers that cover it in one pass (the accumulators loaded and stored once per pass).
    for (std::size_t a0 = 0; a0 < active; a0 += 4) {
      for (std::size_t y = y0; y < y1; ++y) {
        struct Span {
          std::size_t begin, end;
          const std::uint16_t* values;  // at `begin`
          float fill;
          const float* weights;
        };
        Span spans[4];
        int n = 0;
        std::size_t cuts[8];
        int cut_count = 0;
        for (std::size_t a = a0; a < std::min(active, a0 + 4); ++a) {
          const LayerCrop& c = basis.crops[static_cast<std::size_t>(job.active[a])];
          if (static_cast<int>(y) < c.row || static_cast<int>(y) >= c.row + c.rows || c.cols == 0) continue;
          const auto cols = static_cast<std::size_t>(c.cols);
          spans[n] = Span{static_cast<std::size_t>(c.col), static_cast<std::size_t>(c.col) + cols,
                          job.half + c.offset + (y - static_cast<std::size_t>(c.row)) * cols, c.fill, &job.weights[3 * a]};
          cuts[cut_count++] = spans[n].begin;
          cuts[cut_count++] = spans[n].end;
          ++n;
        }
        if (n == 0) continue;
        for (int k = 1; k < cut_count; ++k) {  // insertion sort of at most 8 (std::sort trips GCC 12's -Warray-bounds)
          const std::size_t v = cuts[k];
          int at = k;
          for (; at > 0 && cuts[at - 1] > v; --at) cuts[at] = cuts[at - 1];
          cuts[at] = v;
        }
        for (int k = 0; k + 1 < cut_count; ++k) {
          const std::size_t p = cuts[k], q = cuts[k + 1];
          if (p == q) continue;
          const std::uint16_t* from[4];
          float fills[4];
          float w[12];
          int m = 0;
          for (int j = 0; j < n; ++j) {
            if (spans[j].begin > p || spans[j].end < q) continue;
            from[m] = spans[j].values + (p - spans[j].begin);
            fills[m] = spans[j].fill;
            std::copy_n(spans[j].weights, 3, w + 3 * m);
            ++m;
          }
          if (m == 0) continue;
          const std::size_t at = (y - y0) * width + p;
          add_spans(from, fills, w, m, q - p, r + at, g + at, b + at);
        }
      }
    }
    for (std::size_t k = 0; k < job.source_visibility.size(); ++k) {
      const float* v = job.source_visibility[k] + y0 * width;
      const float* ws = job.source_weights.data() + 3 * k;
      for (std::size_t x = 0; x < count; ++x) {
        s.bad_visibility |= !(v[x] >= 0.0f && v[x] <= 1.0f);
        r[x] += ws[0] * v[x];
        g[x] += ws[1] * v[x];
        b[x] += ws[2] * v[x];
      }
    }
    float* to = job.out + 3 * y0 * width;
    for (std::size_t x = 0; x < count; ++x) {
      for (int c = 0; c < 3; ++c) {
        const float t = job.no_light[c] ? 1.0f : acc[static_cast<std::size_t>(c) * count + x];
        s.max_t = t > s.max_t ? t : s.max_t;  // NaN compares false: ignored
        s.min_t = t < s.min_t ? t : s.min_t;
        s.clamped += static_cast<std::int64_t>((t > 1.0f) | !(t >= 0.0f));
        to[3 * x + static_cast<std::size_t>(c)] = t > 1.0f ? 1.0f : (t >= 0.0f ? t : 0.0f);
      }
    }
  });
  return merged_stats(stats, visibility_field);
}

// The threaded blend: the active layers, then each separated term (V_k, w_k: 3 floats each).
BlendStats run_blend(const BasisImages& basis, const BlendWeights& weights,
                     std::span<const float* const> source_visibility, std::span<const float> source_weights,
                     std::span<float> out, const BlendOptions& options, const std::string& visibility_field) {
  // One job per tile (one for an untiled basis): its active layers and their weights.
  const int tiles = basis.tile_count();
  const auto layers = static_cast<std::size_t>(basis.layers);
  std::vector<std::vector<int>> active(static_cast<std::size_t>(tiles));
  std::vector<std::vector<float>> packed(static_cast<std::size_t>(tiles));  // w_r, w_g, w_b per active layer
  for (const int i : weights.active) {
    const std::size_t t = static_cast<std::size_t>(i) / layers;
    const Eigen::Vector3f& wi = weights.face[static_cast<std::size_t>(i)];
    active[t].push_back(static_cast<int>(static_cast<std::size_t>(i) % layers));
    packed[t].insert(packed[t].end(), {wi.x(), wi.y(), wi.z()});
  }
  std::vector<detail::BlendJob> jobs(static_cast<std::size_t>(tiles));
  for (std::size_t t = 0; t < jobs.size(); ++t) {
    detail::BlendJob& job = jobs[t];
    job.half = basis.half.data();
    job.layer_stride = basis.texel_count();
    job.active = active[t];
    job.weights = packed[t];
    job.source_visibility = source_visibility;
    job.source_weights = source_weights;
    for (int c = 0; c < 3; ++c) job.no_light[c] = weights.no_light[static_cast<std::size_t>(c)];
    job.out = out.data();
  }

  if (basis.cropped()) return run_cropped(basis, jobs[0], options, visibility_field);
  const auto kernel = options.use_simd && detail::cpu_has_avx2_f16c_fma() ? detail::blend_range_avx2
                                                                          : detail::blend_range_portable;
  // Threads claim chunks of a few blocks from a shared counter: a thread that the OS sets aside
  // (a busy machine) holds up one chunk, not a fixed share of the plane. Within a chunk the
  // kernel prefetches across blocks. A texel's sum never depends on who computes it, so the
  // results are identical for any thread count. A tiled basis is split by tile instead, each
  // tile's rows summed with its own weights.
  const std::size_t texels = basis.texel_count();
  const std::size_t chunk = detail::kChunkBlocks * detail::kBlockTexels;
  const std::size_t chunks = basis.tile > 0 ? static_cast<std::size_t>(basis.tiles_y()) : (texels + chunk - 1) / chunk;
  std::optional<BlendWorkers> own;
  BlendWorkers* workers = options.workers;
  if (!workers) {
    const std::size_t wanted = options.threads > 0 ? static_cast<std::size_t>(options.threads)
                                                   : std::max(1u, std::thread::hardware_concurrency());
    workers = &own.emplace(static_cast<int>(std::max<std::size_t>(1, std::min(wanted, chunks))));
  }
  std::vector<detail::RangeStats> stats(static_cast<std::size_t>(workers->size()));
  if (basis.tile > 0) {
    const auto width = static_cast<std::size_t>(basis.width);
    const auto tile = static_cast<std::size_t>(basis.tile);
    const auto tiles_x = static_cast<std::size_t>(basis.tiles_x());
    // A row of tiles per unit of work, row by row across its tiles: each layer is then read
    // along its rows, not down a tile's column of short runs (64² tiles on a 512² plane: 2.3×
    // the untiled time instead of 3.7×).
    workers->run(chunks, [&](std::size_t ty, int worker) {
      const std::size_t y0 = ty * tile, y1 = std::min(static_cast<std::size_t>(basis.height), y0 + tile);
      for (std::size_t y = y0; y < y1; ++y) {
        for (std::size_t tx = 0; tx < tiles_x; ++tx) {
          const std::size_t x0 = tx * tile, x1 = std::min(width, x0 + tile);
          kernel(jobs[ty * tiles_x + tx], y * width + x0, y * width + x1, stats[static_cast<std::size_t>(worker)]);
        }
      }
    });
  } else {
    workers->run(chunks, [&](std::size_t c, int worker) {
      kernel(jobs[0], c * chunk, std::min(texels, (c + 1) * chunk), stats[static_cast<std::size_t>(worker)]);
    });
  }

  return merged_stats(stats, visibility_field);
}

// Σ_i S_i B_i per texel and channel (RGB interleaved) over every stored layer, in double: the
// reference blends' dome term. A layer's coefficient is S itself, or for a PCA basis
// Σ_l S_l projection(l, k).
std::vector<double> dome_sums(const BasisImages& basis, std::span<const Eigen::Vector3d> S) {
  const std::size_t texels = basis.texel_count();
  const auto layers = static_cast<std::size_t>(basis.layers);
  // coefficient[t · layers + i]: stored layer i within tile t.
  std::vector<Eigen::Vector3d> coefficient(layers * static_cast<std::size_t>(basis.tile_count()), Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < coefficient.size(); ++i) {
    if (!basis.compressed()) {
      coefficient[i] = S[i];
      continue;
    }
    for (std::size_t l = 0; l < S.size(); ++l) {
      coefficient[i] += S[l] * static_cast<double>(basis.projection(static_cast<Eigen::Index>(l), static_cast<Eigen::Index>(i)));
    }
  }
  std::vector<double> sum(3 * texels, 0.0);
  const auto width = static_cast<std::size_t>(std::max(basis.width, 1));
  for (std::size_t i = 0; i < layers; ++i) {
    for (std::size_t k = 0; k < texels; ++k) {
      const double b = basis.value(static_cast<int>(i), static_cast<int>(k % width), static_cast<int>(k / width));
      const auto tile = static_cast<std::size_t>(basis.tile_of(static_cast<int>(k % width), static_cast<int>(k / width)));
      const Eigen::Vector3d& a = coefficient[tile * layers + i];
      for (int c = 0; c < 3; ++c) sum[3 * k + static_cast<std::size_t>(c)] += a[c] * b;
    }
  }
  return sum;
}

}  // namespace

BlendStats blend_cpu(const BasisImages& basis, const BlendWeights& weights, std::span<const float> sun_visibility,
                     std::span<float> out, const BlendOptions& options) {
  check_weights(basis, weights, options);
  if (weights.sources.size() > 1) {
    bad_input("weights.sources", std::to_string(weights.sources.size()) + " separated sources for one visibility image",
              "blend several sources with blend_cpu_sources, one V per source");
  }
  check_sizes(basis, sun_visibility, out.size(), !weights.sun.isZero(0));
  // Without a sun weight V changes nothing: skip reading it.
  std::vector<const float*> visibility;
  std::vector<float> source_weights;
  if (!sun_visibility.empty() && !weights.sun.isZero(0)) {
    visibility.push_back(sun_visibility.data());
    source_weights = {weights.sun.x(), weights.sun.y(), weights.sun.z()};
  }
  return run_blend(basis, weights, visibility, source_weights, out, options, "sun_visibility");
}

BlendStats blend_cpu_sources(const BasisImages& basis, const BlendWeights& weights,
                             std::span<const std::span<const float>> source_visibility, std::span<float> out,
                             const BlendOptions& options) {
  check_weights(basis, weights, options);
  const std::vector<Eigen::Vector3f> sources = separated_terms(weights);
  const std::size_t texels = basis.texel_count();
  if (out.size() != 3 * texels) {
    bad_input("out", "has " + std::to_string(out.size()) + " values; plane '" + basis.name + "' needs " +
                         std::to_string(3 * texels) + " (3 per texel)",
              "size it width x height x 3");
  }
  const bool all_zero = std::all_of(sources.begin(), sources.end(), [](const Eigen::Vector3f& w) { return w.isZero(0); });
  if (source_visibility.size() != sources.size() && !(source_visibility.empty() && all_zero)) {
    bad_input("source_visibility", std::to_string(source_visibility.size()) + " visibility image(s) for " +
                                       std::to_string(sources.size()) + " separated source(s)",
              "give one V per source, in the order of the SunLights the weights were computed for");
  }
  std::vector<const float*> visibility;
  std::vector<float> source_weights;
  for (std::size_t k = 0; k < sources.size(); ++k) {
    const std::string field = "source_visibility[" + std::to_string(k) + "]";
    if (!sources[k].allFinite()) bad_input("weights.sources[" + std::to_string(k) + "]", "is not finite",
                                           "compute the weights with blend_weights_sources");
    // Without a weight V changes nothing: skip reading it.
    if (sources[k].isZero(0)) continue;
    const std::span<const float> v = source_visibility[k];
    if (v.size() != texels) {
      bad_input(field, "has " + std::to_string(v.size()) + " values; plane '" + basis.name + "' has " +
                           std::to_string(texels) + " texels and source " + std::to_string(k) + " lights it",
                "give one V in [0, 1] per texel (all 1 when nothing shadows the source)");
    }
    visibility.push_back(v.data());
    source_weights.insert(source_weights.end(), {sources[k].x(), sources[k].y(), sources[k].z()});
  }
  return run_blend(basis, weights, visibility, source_weights, out, options, "source_visibility");
}

void blend_reference(const BasisImages& basis, std::span<const Eigen::Vector3d> S, const std::optional<SunLight>& sun,
                     std::span<const float> sun_visibility, std::span<double> out, const BlendOptions& options) {
  // blend_weights checks the inputs and finds D and the channels without light; the sums below
  // use S directly, over every layer.
  const BlendWeights weights = blend_weights(basis, S, sun, options);
  const Eigen::Vector3d sun_term = sun_on_plane(basis, sun);
  check_sizes(basis, sun_visibility, out.size(), !weights.sun.isZero(0));
  for (const float v : sun_visibility) {
    if (!(v >= 0.0f && v <= 1.0f)) bad_visibility();
  }
  const std::size_t texels = basis.texel_count();
  const std::vector<double> sum = dome_sums(basis, S);
  for (std::size_t k = 0; k < texels; ++k) {
    const double v = sun_visibility.empty() ? 0.0 : sun_visibility[k];
    for (int c = 0; c < 3; ++c) {
      const std::size_t at = 3 * k + static_cast<std::size_t>(c);
      if (weights.no_light[static_cast<std::size_t>(c)]) {
        out[at] = 1.0;
        continue;
      }
      const double t = (sum[at] + sun_term[c] * v) / weights.denominator[c];
      out[at] = t > 1.0 ? 1.0 : (t >= 0.0 ? t : 0.0);
    }
  }
}

void blend_reference_sources(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                             std::span<const SunLight> sources,
                             std::span<const std::span<const float>> source_visibility, std::span<double> out,
                             const BlendOptions& options) {
  const BlendWeights weights = blend_weights_sources(basis, S, sources, options);
  const std::size_t texels = basis.texel_count();
  if (out.size() != 3 * texels) {
    bad_input("out", "has " + std::to_string(out.size()) + " values; plane '" + basis.name + "' needs " +
                         std::to_string(3 * texels) + " (3 per texel)",
              "size it width x height x 3");
  }
  if (source_visibility.size() != sources.size()) {
    bad_input("source_visibility", std::to_string(source_visibility.size()) + " visibility image(s) for " +
                                       std::to_string(sources.size()) + " separated source(s)",
              "give one V per source");
  }
  std::vector<Eigen::Vector3d> terms;
  for (std::size_t k = 0; k < sources.size(); ++k) {
    terms.push_back(source_on_plane(basis, sources[k], source_field(k)));
    const std::span<const float> v = source_visibility[k];
    if (v.empty() && terms.back().isZero(0)) continue;
    if (v.size() != texels) {
      bad_input("source_visibility[" + std::to_string(k) + "]",
                "has " + std::to_string(v.size()) + " values for " + std::to_string(texels) + " texels",
                "give one V in [0, 1] per texel");
    }
    for (const float x : v) {
      if (!(x >= 0.0f && x <= 1.0f)) bad_visibility("source_visibility[" + std::to_string(k) + "]");
    }
  }
  const std::vector<double> sum = dome_sums(basis, S);
  for (std::size_t k = 0; k < texels; ++k) {
    for (int c = 0; c < 3; ++c) {
      const std::size_t at = 3 * k + static_cast<std::size_t>(c);
      if (weights.no_light[static_cast<std::size_t>(c)]) {
        out[at] = 1.0;
        continue;
      }
      double numerator = sum[at];
      for (std::size_t s = 0; s < terms.size(); ++s) {
        if (!source_visibility[s].empty()) numerator += terms[s][c] * source_visibility[s][k];
      }
      const double t = numerator / weights.denominator[c];
      out[at] = t > 1.0 ? 1.0 : (t >= 0.0 ? t : 0.0);
    }
  }
}

}  // namespace skylit::blend
