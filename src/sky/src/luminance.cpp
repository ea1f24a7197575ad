#include "skylit/sky/luminance.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>

#include <Eigen/LU>

#include "skylit/base/error.hpp"

namespace skylit::sky {
namespace {

std::string describe(const cv::Mat& image) {
  return std::to_string(image.cols) + "×" + std::to_string(image.rows) + " with " +
         std::to_string(image.channels()) + " channel(s) of OpenCV depth " +
         std::to_string(image.depth());
}

[[noreturn]] void reject_input(const std::string& field, const std::string& problem,
                               const std::string& fix) {
  throw InputError(input_message({}, -1, -1, field, problem, fix));
}

void check_mask(const cv::Mat& mask, const SkyTable& table, const std::string& field) {
  if (mask.empty()) return;
  if (mask.type() != CV_8UC1 || mask.cols != table.image_width || mask.rows != table.image_height) {
    reject_input(field,
                 "the mask is " + describe(mask) + "; the sky table is for " +
                     std::to_string(table.image_width) + "×" + std::to_string(table.image_height) +
                     " frames",
                 "give an 8-bit, one-channel mask of the frame's size (or an empty one)");
  }
}

// Sums of one face over the frame.
struct Sums {
  double r = 0, g = 0, b = 0, weight = 0, clipped = 0;
  std::int64_t nan = 0, inf = 0, negative = 0, clipped_pixels = 0;
  bool excluded = false;
  // Corners basis: Σ w λ0 L and Σ w λ1 L (R G B), and the hats' mass over excluded samples.
  Eigen::Vector3d corner0 = Eigen::Vector3d::Zero(), corner1 = Eigen::Vector3d::Zero();
  Eigen::Matrix3d excluded_mass = Eigen::Matrix3d::Zero();
};

struct Accumulator {
  double r = 0, g = 0, b = 0, weight = 0, clipped = 0;
  std::int64_t clipped_pixels = 0;
  float lowest = 0;  // smallest channel value seen (the fast pass's test for negatives)

  void add(const Accumulator& other) {
    r += other.r;
    g += other.g;
    b += other.b;
    weight += other.weight;
    clipped += other.clipped;
    clipped_pixels += other.clipped_pixels;
    lowest = std::min(lowest, other.lowest);
  }
};

// Channel values that are NaN, ±Inf or negative count as 0; the pixel is counted once per kind.
void sanitise(float (&value)[3], Sums& sums) {
  bool nan = false, inf = false, negative = false;
  for (float& v : value) {
    if (std::isnan(v)) {
      nan = true;
      v = 0.0f;
    } else if (std::isinf(v)) {
      inf = true;
      v = 0.0f;
    } else if (v < 0.0f) {
      negative = true;
      v = 0.0f;
    }
  }
  sums.nan += nan;
  sums.inf += inf;
  sums.negative += negative;
}

// Sample k of a run into `a`. The mask pointers are only read (or offset) when the template
// says the mask is there. kCareful sanitises every value (the slow pass); otherwise values are
// taken as they are and `lowest` tracks the smallest one.
template <bool kClipped, bool kExclude, bool kCareful>
inline void add_sample(const float* pixel, const std::uint8_t* clipped, const std::uint8_t* exclude,
                       std::ptrdiff_t mask_offset, float weight, Accumulator& a, Sums& sums) {
  if constexpr (kExclude) {
    if (exclude[mask_offset] != 0) {
      sums.excluded = true;
      return;
    }
  }
  float value[3] = {pixel[0], pixel[1], pixel[2]};
  if constexpr (kCareful) {
    sanitise(value, sums);
  } else {
    a.lowest = std::min(a.lowest, std::min(value[0], std::min(value[1], value[2])));
  }
  const double w = weight;
  a.b += w * value[0];
  a.g += w * value[1];
  a.r += w * value[2];
  a.weight += w;
  if constexpr (kClipped) {
    if (clipped[mask_offset] != 0) {
      a.clipped += w;
      ++a.clipped_pixels;
    }
  }
}

// The samples of one run; two accumulators (even and odd samples) halve the floating-point
// dependency chains.
template <bool kClipped, bool kExclude, bool kCareful>
Accumulator sum_run(const float* pixel, std::ptrdiff_t stride, const std::uint8_t* clipped,
                    const std::uint8_t* exclude, std::ptrdiff_t mask_stride, const float* weights,
                    std::int32_t count, Sums& sums) {
  Accumulator even, odd;
  std::int32_t k = 0;
  for (; k + 1 < count; k += 2) {
    add_sample<kClipped, kExclude, kCareful>(pixel + k * stride, clipped, exclude, k * mask_stride,
                                             weights[k], even, sums);
    add_sample<kClipped, kExclude, kCareful>(pixel + (k + 1) * stride, clipped, exclude,
                                             (k + 1) * mask_stride, weights[k + 1], odd, sums);
  }
  if (k < count) {
    add_sample<kClipped, kExclude, kCareful>(pixel + k * stride, clipped, exclude, k * mask_stride,
                                             weights[k], even, sums);
  }
  even.add(odd);
  return even;
}

// One run: `pixel` at its first sample, `stride` floats (`mask_stride` mask bytes) between
// samples. The fast pass takes the values as they are: a NaN or an infinity makes a sum
// non-finite (finite floats times weights cannot overflow a double) and a negative value shows in
// `lowest`; only then is the run summed again value by value. Templated on which masks are
// present so that the common case (none) tests no mask per sample.
template <bool kClipped, bool kExclude>
void accumulate_run(const float* pixel, std::ptrdiff_t stride, const std::uint8_t* clipped,
                    const std::uint8_t* exclude, std::ptrdiff_t mask_stride, const float* weights,
                    std::int32_t count, Sums& sums) {
  Accumulator run = sum_run<kClipped, kExclude, false>(pixel, stride, clipped, exclude, mask_stride,
                                                       weights, count, sums);
  if (!std::isfinite(run.r + run.g + run.b) || run.lowest < 0.0f) [[unlikely]] {
    run = sum_run<kClipped, kExclude, true>(pixel, stride, clipped, exclude, mask_stride, weights,
                                            count, sums);
  }
  sums.r += run.r;
  sums.g += run.g;
  sums.b += run.b;
  sums.weight += run.weight;
  sums.clipped += run.clipped;
  sums.clipped_pixels += run.clipped_pixels;
}

// ---- the corners basis ----
//
// Per sample three products w·L, w·λ0·L, w·λ1·L and Σ w, on four-float vectors (GCC's vector
// extension: SSE on x86, NEON on ARM): sample by sample (B G R w in the lanes) where masks are
// read or the step skips pixels, four samples at a time otherwise. Float sums along a run (a
// few hundred samples), double across runs.

using Lanes = float __attribute__((vector_size(16)));
using LaneIndex = int __attribute__((vector_size(16)));
using LaneBits = unsigned __attribute__((vector_size(16)));

static_assert(std::endian::native == std::endian::little, "λ0 is the low half of each 32-bit pair");
constexpr float kUnit = static_cast<float>(kCornerWeightUnit);

inline Lanes load_lanes(const float* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// Four consecutive samples of a run at step 1 (12 contiguous floats B G R B G R ...) as one
// vector per channel, the structure-of-arrays form: no lane is wasted, and the whole corners
// pass takes fewer instructions than the faces pass (measured with cachegrind).
struct FourSamples {
  Lanes sum_b{0, 0, 0, 0}, sum_g{0, 0, 0, 0}, sum_r{0, 0, 0, 0}, weight{0, 0, 0, 0};
  Lanes c0_b{0, 0, 0, 0}, c0_g{0, 0, 0, 0}, c0_r{0, 0, 0, 0};
  Lanes c1_b{0, 0, 0, 0}, c1_g{0, 0, 0, 0}, c1_r{0, 0, 0, 0};
  Lanes lowest{0, 0, 0, 0};

  void add(const float* pixel, const float* weights, const std::uint16_t* lambda) {
    const Lanes x = load_lanes(pixel), y = load_lanes(pixel + 4), z = load_lanes(pixel + 8);
    // x = B0 G0 R0 B1, y = G1 R1 B2 G2, z = R2 B3 G3 R3 (indices 4..7 pick from the second).
    const Lanes b = __builtin_shuffle(__builtin_shuffle(x, y, LaneIndex{0, 3, 6, 0}), z, LaneIndex{0, 1, 2, 5});
    const Lanes g = __builtin_shuffle(__builtin_shuffle(x, y, LaneIndex{1, 4, 7, 0}), z, LaneIndex{0, 1, 2, 6});
    const Lanes r = __builtin_shuffle(__builtin_shuffle(x, y, LaneIndex{2, 5, 0, 0}), z, LaneIndex{0, 1, 4, 7});
    LaneBits pairs;  // per sample λ1 << 16 | λ0
    std::memcpy(&pairs, lambda, sizeof pairs);
    const Lanes l0 = __builtin_convertvector(LaneIndex(pairs & 0xffffu), Lanes) * kUnit;
    const Lanes l1 = __builtin_convertvector(LaneIndex(pairs >> 16), Lanes) * kUnit;
    const Lanes w = load_lanes(weights);
    const Lanes w0 = w * l0;
    const Lanes w1 = w * l1;
    lowest = b < lowest ? b : lowest;
    lowest = g < lowest ? g : lowest;
    lowest = r < lowest ? r : lowest;
    weight += w;
    sum_b += w * b;
    sum_g += w * g;
    sum_r += w * r;
    c0_b += w0 * b;
    c0_g += w0 * g;
    c0_r += w0 * r;
    c1_b += w1 * b;
    c1_g += w1 * g;
    c1_r += w1 * r;
  }

  static float total(const Lanes& v) { return (v[0] + v[1]) + (v[2] + v[3]); }
};

// Whether any of `count` mask bytes `step` apart is set.
inline bool any_set(const std::uint8_t* mask, std::int32_t count, std::ptrdiff_t step) {
  if (step == 1) return std::any_of(mask, mask + count, [](std::uint8_t m) { return m != 0; });
  for (std::int32_t k = 0; k < count; ++k) {
    if (mask[k * step] != 0) return true;
  }
  return false;
}

inline void add_excluded_mass(Eigen::Matrix3d& m, double w, double l0, double l1) {
  const Eigen::Vector3d l(l0, l1, 1.0 - l0 - l1);
  m.noalias() += w * l * l.transpose();
}

struct CornerRun {
  Lanes sum{0, 0, 0, 0}, sum0{0, 0, 0, 0}, sum1{0, 0, 0, 0};  // lanes B, G, R, weight
  Lanes lowest{0, 0, 0, 0};
  double clipped = 0;
  std::int64_t clipped_pixels = 0;
  bool excluded = false;
  Eigen::Matrix3d excluded_mass = Eigen::Matrix3d::Zero();

  void add(const CornerRun& o) {
    sum += o.sum;
    sum0 += o.sum0;
    sum1 += o.sum1;
    lowest = o.lowest < lowest ? o.lowest : lowest;
    clipped += o.clipped;
    clipped_pixels += o.clipped_pixels;
    excluded = excluded || o.excluded;
    excluded_mass += o.excluded_mass;
  }
};

template <bool kClipped, bool kExclude>
inline void add_corner_sample(const float* pixel, const std::uint8_t* clipped, const std::uint8_t* exclude,
                              std::ptrdiff_t mask_offset, float weight, const std::uint16_t* lambda, CornerRun& a) {
  if constexpr (kExclude) {
    if (exclude[mask_offset] != 0) {
      a.excluded = true;
      add_excluded_mass(a.excluded_mass, weight, lambda[0] * kCornerWeightUnit, lambda[1] * kCornerWeightUnit);
      return;
    }
  }
  const Lanes value{pixel[0], pixel[1], pixel[2], 1.0f};
  a.lowest = value < a.lowest ? value : a.lowest;
  const Lanes wv = value * weight;
  a.sum += wv;
  a.sum0 += wv * (static_cast<float>(lambda[0]) * kUnit);
  a.sum1 += wv * (static_cast<float>(lambda[1]) * kUnit);
  if constexpr (kClipped) {
    if (clipped[mask_offset] != 0) {
      a.clipped += weight;
      ++a.clipped_pixels;
    }
  }
}

// The careful pass of one run: every value sanitised, double sums straight into `sums`.
void corner_run_careful(const float* pixel, std::ptrdiff_t stride, const std::uint8_t* clipped,
                        const std::uint8_t* exclude, std::ptrdiff_t mask_stride, const float* weights,
                        const std::uint16_t* lambda, std::int32_t count, Sums& sums) {
  for (std::int32_t k = 0; k < count; ++k) {
    const double w = weights[k];
    const double l0 = lambda[2 * k] * kCornerWeightUnit, l1 = lambda[2 * k + 1] * kCornerWeightUnit;
    if (exclude && exclude[k * mask_stride] != 0) {
      sums.excluded = true;
      add_excluded_mass(sums.excluded_mass, w, l0, l1);
      continue;
    }
    float value[3] = {pixel[k * stride], pixel[k * stride + 1], pixel[k * stride + 2]};
    sanitise(value, sums);
    const Eigen::Vector3d rgb(value[2], value[1], value[0]);
    sums.b += w * value[0];
    sums.g += w * value[1];
    sums.r += w * value[2];
    sums.weight += w;
    sums.corner0 += (w * l0) * rgb;
    sums.corner1 += (w * l1) * rgb;
    if (clipped && clipped[k * mask_stride] != 0) {
      sums.clipped += w;
      ++sums.clipped_pixels;
    }
  }
}

template <bool kClipped, bool kExclude>
void accumulate_corner_run(const float* pixel, std::ptrdiff_t stride, const std::uint8_t* clipped,
                           const std::uint8_t* exclude, std::ptrdiff_t mask_stride, const float* weights,
                           const std::uint16_t* lambda, std::int32_t count, Sums& sums) {
  CornerRun even, odd;
  std::int32_t k = 0;
  if constexpr (!kClipped && !kExclude) {
    // The common case (no masks, every pixel): four samples at a time, the rest one by one.
    if (stride == 3 && count >= 4) {
      FourSamples four;
      for (; k + 3 < count; k += 4) four.add(pixel + 3 * k, weights + k, lambda + 2 * k);
      even.sum += Lanes{FourSamples::total(four.sum_b), FourSamples::total(four.sum_g),
                        FourSamples::total(four.sum_r), FourSamples::total(four.weight)};
      even.sum0 += Lanes{FourSamples::total(four.c0_b), FourSamples::total(four.c0_g), FourSamples::total(four.c0_r), 0};
      even.sum1 += Lanes{FourSamples::total(four.c1_b), FourSamples::total(four.c1_g), FourSamples::total(four.c1_r), 0};
      const float lowest = std::min(std::min(four.lowest[0], four.lowest[1]), std::min(four.lowest[2], four.lowest[3]));
      even.lowest = Lanes{lowest, lowest, lowest, 0};
    }
  }
  for (; k + 1 < count; k += 2) {
    add_corner_sample<kClipped, kExclude>(pixel + k * stride, clipped, exclude, k * mask_stride, weights[k],
                                          lambda + 2 * k, even);
    add_corner_sample<kClipped, kExclude>(pixel + (k + 1) * stride, clipped, exclude, (k + 1) * mask_stride,
                                          weights[k + 1], lambda + 2 * (k + 1), odd);
  }
  if (k < count) {
    add_corner_sample<kClipped, kExclude>(pixel + k * stride, clipped, exclude, k * mask_stride, weights[k],
                                          lambda + 2 * k, even);
  }
  even.add(odd);
  const Lanes& s0 = even.sum;
  const bool finite = std::isfinite(s0[0] + s0[1] + s0[2] + s0[3] + even.sum0[0] + even.sum0[1] + even.sum0[2] +
                                    even.sum1[0] + even.sum1[1] + even.sum1[2]);
  if (!finite || even.lowest[0] < 0.0f || even.lowest[1] < 0.0f || even.lowest[2] < 0.0f) [[unlikely]] {
    corner_run_careful(pixel, stride, kClipped ? clipped : nullptr, kExclude ? exclude : nullptr, mask_stride,
                       weights, lambda, count, sums);
    return;
  }
  sums.b += even.sum[0];
  sums.g += even.sum[1];
  sums.r += even.sum[2];
  sums.weight += even.sum[3];
  sums.corner0 += Eigen::Vector3d(even.sum0[2], even.sum0[1], even.sum0[0]);
  sums.corner1 += Eigen::Vector3d(even.sum1[2], even.sum1[1], even.sum1[0]);
  sums.clipped += even.clipped;
  sums.clipped_pixels += even.clipped_pixels;
  if (even.excluded) {
    sums.excluded = true;
    sums.excluded_mass += even.excluded_mass;
  }
}

// The corner fit of every seen face: M⁻¹ b with M the table's mass matrix, less the excluded
// samples' when the sun took some; a face whose (remaining) pixels do not pin three corners down
// gets its mean in all three and the flag.
void fit_corners(const SkyTable& table, const std::vector<Sums>& sums, const std::vector<bool>& seen,
                 const LuminanceOptions& options, Luminance& result) {
  for (std::size_t i = 0; i < result.faces.size(); ++i) {
    FaceLuminance& face = result.faces[i];
    if (!seen[i]) continue;
    const Sums& s = sums[i];
    double conditioning = table.corner_conditioning[i];
    Eigen::Matrix3d inverse = table.corner_inverse[i];
    if (s.excluded) {
      const Eigen::Matrix3d mass = table.corner_mass[i] - s.excluded_mass;
      conditioning = corner_conditioning(mass, table.corner_full_mass[i]);
      inverse = conditioning > 0.0 ? Eigen::Matrix3d(mass.inverse()) : Eigen::Matrix3d::Zero();
    }
    if (!(conditioning >= options.min_corner_conditioning) || !(conditioning > 0.0)) {
      face.flags |= kFaceCornersFromMean;
      ++result.corners_from_mean;
      face.corners = {face.rgb, face.rgb, face.rgb};
      continue;
    }
    Eigen::Matrix3d b;  // row k: Σ w λ_k L (R G B)
    b.row(0) = s.corner0.transpose();
    b.row(1) = s.corner1.transpose();
    b.row(2) = Eigen::Vector3d(s.r, s.g, s.b).transpose() - b.row(0) - b.row(1);
    const Eigen::Matrix3d fit = inverse * b;
    for (std::size_t k = 0; k < 3; ++k) face.corners[k] = fit.row(static_cast<Eigen::Index>(k)).transpose();
  }
}

// Faces under the coverage threshold take, wave by wave, the weighted mean of their neighbours
// that are seen or were filled in an earlier wave. A seen face weighs its coverage; a filled one
// passes on the mean weight of the faces it was filled from, so that real data dominate.
void fill_unseen(const geom::Dome& dome, std::vector<bool>& known, std::vector<double>& weight,
                 Luminance& result) {
  const std::size_t n = result.faces.size();
  std::vector<std::size_t> pending;
  for (std::size_t i = 0; i < n; ++i) {
    if (!known[i]) pending.push_back(i);
  }
  std::vector<std::size_t> filled;
  std::vector<Eigen::Vector3d> value(n);
  std::vector<double> value_weight(n);
  while (!pending.empty()) {
    filled.clear();
    std::vector<std::size_t> still;
    for (const std::size_t i : pending) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double total = 0;
      int sources = 0;
      for (const int j : dome.faces()[i].neighbour) {
        if (j < 0 || !known[static_cast<std::size_t>(j)]) continue;
        const double w = weight[static_cast<std::size_t>(j)];
        sum += w * result.faces[static_cast<std::size_t>(j)].rgb;
        total += w;
        ++sources;
      }
      if (sources == 0 || !(total > 0)) {
        still.push_back(i);
        continue;
      }
      value[i] = sum / total;
      value_weight[i] = total / sources;
      filled.push_back(i);
    }
    if (filled.empty()) break;  // nothing left to fill from (cannot happen on a connected dome)
    for (const std::size_t i : filled) {  // applied after the wave: the order inside it is moot
      result.faces[i].rgb = value[i];
      weight[i] = value_weight[i];
      known[i] = true;
    }
    pending.swap(still);
  }
  for (const std::size_t i : pending) result.faces[i].rgb.setZero();
}

}  // namespace

Luminance compute_luminance(const SkyTable& table, const geom::Dome& dome, const cv::Mat& radiance,
                            const cv::Mat& clipped, const cv::Mat& exclude,
                            const LuminanceOptions& options) {
  const std::size_t n = static_cast<std::size_t>(dome.face_count());
  if (table.face_solid_angle.size() != n) {
    reject_input("table",
                 "the sky table was built for a dome of " +
                     std::to_string(table.face_solid_angle.size()) + " faces, this dome has " +
                     std::to_string(n),
                 "build the sky table with the same dome frequency as the bake");
  }
  if (table.step < 1) {
    reject_input("table.step", "the step is not positive", "rebuild the sky table");
  }
  if (radiance.type() != CV_32FC3 || radiance.cols != table.image_width ||
      radiance.rows != table.image_height) {
    reject_input("radiance",
                 "the frame is " + describe(radiance) + "; expected " +
                     std::to_string(table.image_width) + "×" + std::to_string(table.image_height) +
                     " CV_32FC3 (linear BGR)",
                 "linearise the frame to 32-bit float BGR at the sky camera's calibrated size");
  }
  check_mask(clipped, table, "clipped");
  check_mask(exclude, table, "exclude");
  if (!(options.min_coverage >= 0.0 && options.min_coverage <= 1.0)) {
    reject_input("min_coverage", "the threshold must lie in [0, 1]",
                 "write a fraction of a face's solid angle, e.g. 0.05");
  }
  const bool corners = table.basis == geom::DomeBasis::Corners;
  if (corners) {
    if (table.corner_weights.size() != 2 * table.weights.size() || table.corner_mass.size() != n ||
        table.corner_inverse.size() != n || table.corner_full_mass.size() != n ||
        table.corner_conditioning.size() != n) {
      reject_input("table", "the corners table lacks its barycentric weights or mass matrices",
                   "build the sky table with build_sky_table and basis corners");
    }
    if (!(options.min_corner_conditioning >= 0.0 && options.min_corner_conditioning <= 1.0)) {
      reject_input("min_corner_conditioning", "the threshold must lie in [0, 1]",
                   "write a share of a fully seen face's smallest eigenvalue, e.g. 0.25");
    }
  }

  Luminance result;
  result.basis = table.basis;
  result.faces.resize(n);
  std::vector<Sums> sums(n);
  const std::ptrdiff_t step = table.step;
  const std::ptrdiff_t stride = 3 * step;
  const bool has_clipped = !clipped.empty();
  const bool has_exclude = !exclude.empty();
  const std::size_t weight_count = table.weights.size();
  for (const PixelRun& run : table.runs) {
    // A table from elsewhere must not read outside the frame or the weights.
    const long long last = static_cast<long long>(run.col_begin) + (run.count - 1LL) * step;
    if (run.row < 0 || run.row >= table.image_height || run.col_begin < 0 || run.count < 0 ||
        (run.count > 0 && last >= table.image_width) || run.face < 0 ||
        static_cast<std::size_t>(run.face) >= n ||
        static_cast<std::size_t>(run.weight_offset) + static_cast<std::size_t>(run.count) >
            weight_count) {
      reject_input("table", "a run lies outside the frame, the dome or the weights",
                   "rebuild the sky table with build_sky_table for this calibration and dome");
    }
    const float* pixel = radiance.ptr<float>(run.row) + 3 * std::ptrdiff_t{run.col_begin};
    const float* weights = table.weights.data() + run.weight_offset;
    // Absent masks stay null: the templates below never touch them.
    const std::uint8_t* c =
        has_clipped ? clipped.ptr<std::uint8_t>(run.row) + run.col_begin : nullptr;
    const std::uint8_t* e =
        has_exclude ? exclude.ptr<std::uint8_t>(run.row) + run.col_begin : nullptr;
    Sums& s = sums[static_cast<std::size_t>(run.face)];
    if (corners) {
      const std::uint16_t* lambda = table.corner_weights.data() + 2 * std::size_t{run.weight_offset};
      // A mask with nothing set along the run (the sun's disc and clipped pixels are small) costs
      // the run nothing: it takes the mask-free path, four samples at a time.
      const bool run_clipped = has_clipped && any_set(c, run.count, step);
      const bool run_exclude = has_exclude && any_set(e, run.count, step);
      if (run_clipped && run_exclude) {
        accumulate_corner_run<true, true>(pixel, stride, c, e, step, weights, lambda, run.count, s);
      } else if (run_clipped) {
        accumulate_corner_run<true, false>(pixel, stride, c, e, step, weights, lambda, run.count, s);
      } else if (run_exclude) {
        accumulate_corner_run<false, true>(pixel, stride, c, e, step, weights, lambda, run.count, s);
      } else {
        accumulate_corner_run<false, false>(pixel, stride, c, e, step, weights, lambda, run.count, s);
      }
    } else if (has_clipped && has_exclude) {
      accumulate_run<true, true>(pixel, stride, c, e, step, weights, run.count, s);
    } else if (has_clipped) {
      accumulate_run<true, false>(pixel, stride, c, e, step, weights, run.count, s);
    } else if (has_exclude) {
      accumulate_run<false, true>(pixel, stride, c, e, step, weights, run.count, s);
    } else {
      accumulate_run<false, false>(pixel, stride, c, e, step, weights, run.count, s);
    }
    result.samples += run.count;
  }

  std::vector<bool> known(n, false);
  std::vector<double> weight(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    const Sums& s = sums[i];
    FaceLuminance& face = result.faces[i];
    result.nan_pixels += s.nan;
    result.inf_pixels += s.inf;
    result.negative_pixels += s.negative;
    result.clipped_pixels += s.clipped_pixels;
    face.coverage = s.weight / dome.faces()[i].solid_angle;
    if (s.nan + s.inf + s.negative > 0) face.flags |= kFaceBadPixels;
    if (s.clipped_pixels > 0) face.flags |= kFaceClipped;
    if (s.excluded) face.flags |= kFaceSunRemoved;
    if (s.weight > 0) {
      face.rgb = Eigen::Vector3d(s.r, s.g, s.b) / s.weight;
      face.clipped_fraction = s.clipped / s.weight;
    }
    // A face with no weight at all is unseen whatever the threshold (0/0 has no mean).
    if (s.weight > 0 && face.coverage >= options.min_coverage) {
      known[i] = true;
      weight[i] = face.coverage;
    } else {
      face.flags |= kFaceUnseen;
      ++result.unseen_faces;
    }
  }
  if (result.unseen_faces == static_cast<int>(n)) {
    result.no_face_seen = true;
    for (FaceLuminance& face : result.faces) face.rgb.setZero();
    return result;
  }
  const std::vector<bool> seen = known;
  if (result.unseen_faces > 0) fill_unseen(dome, known, weight, result);
  if (corners) {
    fit_corners(table, sums, seen, options, result);
    for (std::size_t i = 0; i < n; ++i) {
      if (!seen[i]) result.faces[i].corners = {result.faces[i].rgb, result.faces[i].rgb, result.faces[i].rgb};
    }
  }
  return result;
}

std::vector<Eigen::Vector3d> layer_radiances(const Luminance& luminance) {
  std::vector<Eigen::Vector3d> S;
  const bool corners = luminance.basis == geom::DomeBasis::Corners;
  S.reserve(luminance.faces.size() * (corners ? 3 : 1));
  for (const FaceLuminance& face : luminance.faces) {
    if (corners) {
      S.insert(S.end(), face.corners.begin(), face.corners.end());
    } else {
      S.push_back(face.rgb);
    }
  }
  return S;
}

}  // namespace skylit::sky
