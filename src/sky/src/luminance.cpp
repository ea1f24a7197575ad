#include "skylit/sky/luminance.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>

#include <Eigen/LU>

#include "lane_shuffle.hpp"
#include "skylit/base/error.hpp"

#if defined(__x86_64__) || defined(__i386__)
#define SKYLIT_SKY_X86 1
#else
#define SKYLIT_SKY_X86 0
#endif

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

// What a run must keep to (a table from elsewhere must not read outside the frame, the dome or
// the weights), read from the table once per pass.
struct RunLimits {
  std::int64_t width, height, step;
  std::uint64_t faces, weights;

  RunLimits(const SkyTable& table, std::size_t face_count)
      : width(table.image_width), height(table.image_height), step(table.step), faces(face_count),
        weights(table.weights.size()) {}

  [[gnu::always_inline]] void check(const PixelRun& run) const {
    const std::int64_t last = std::int64_t{run.col_begin} + (run.count - std::int64_t{1}) * step;
    if (run.row < 0 || run.row >= height || run.col_begin < 0 || run.count < 0 || (run.count > 0 && last >= width) ||
        run.face < 0 || static_cast<std::uint64_t>(run.face) >= faces ||
        std::uint64_t{run.weight_offset} + static_cast<std::uint64_t>(run.count) > weights) [[unlikely]] {
      reject_input("table", "a run lies outside the frame, the dome or the weights",
                   "rebuild the sky table with build_sky_table for this calibration and dome");
    }
  }
};

// Sums of one face over the frame.
struct Sums {
  double r = 0, g = 0, b = 0, weight = 0, clipped = 0;
  std::int64_t nan = 0, inf = 0, negative = 0, clipped_pixels = 0;
  bool excluded = false;
  // Corners basis: Σ w λ0 L and Σ w λ1 L (R G B), and the hats' mass over excluded samples.
  Eigen::Vector3d corner0 = Eigen::Vector3d::Zero(), corner1 = Eigen::Vector3d::Zero();
  Eigen::Matrix3d excluded_mass = Eigen::Matrix3d::Zero();
  // Quadratics basis: Σ w φ_k L (row k, R G B) and the functions' mass over excluded samples.
  Eigen::Matrix<double, 6, 3> quadratic = Eigen::Matrix<double, 6, 3>::Zero();
  Eigen::Matrix<double, 6, 6> quadratic_excluded_mass = Eigen::Matrix<double, 6, 6>::Zero();
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

// ---- the corners and quadratics bases ----
//
// Per sample the products w·L, w·λ0·L and w·λ1·L (R G B), for quadratics also w·λ0²·L, w·λ1²·L
// and w·λ0·λ1·L (the six Bernstein functions' sums follow from these at the flush), in float
// vectors of kWidth lanes
// (GCC's vector extension: four lanes on SSE2 or NEON, eight where the CPU has AVX2 and FMA),
// kWidth samples per vector in structure-of-arrays form: one vector per channel, no lane wasted.
// The pass runs in the table's row-major order (the frame streams through the cache); a face's
// vector sums stay in memory between its runs (FaceLanes) and go to the face's double sums after
// about kFlushAdditions · kWidth samples. A run thus costs its samples and a load and a store of
// its face's sums, not a reduction of every vector (at ν = 8 a run is 26 samples on average, and
// that reduction cost as much as the samples). The λ stay in units of kCornerWeightUnit until
// the flush. Σ w takes no lane: for the samples that no mask touches it is the table's
// face_solid_angle less the weight of the runs that a mask touches.

static_assert(std::endian::native == std::endian::little, "λ0 is the low half of each 32-bit pair");

// Float sums of at most this many additions per lane (plus one run) before they go to double,
// as short as the longest runs' sums were when each run was summed alone.
constexpr std::int32_t kFlushAdditions = 128;
constexpr int kMaxWidth = 8;

template <int kWidth>
struct Vec;
template <>
struct Vec<4> {
  using Float = float __attribute__((vector_size(16)));
  using Int = std::int32_t __attribute__((vector_size(16)));
  using Bits = std::uint32_t __attribute__((vector_size(16)));
  static constexpr Int kLane{0, 1, 2, 3};
  // Within each group of four lanes: blends (index ≥ kWidth picks from the second operand), then
  // a permutation; see load_group.
  static constexpr Int kBlue0{0, 1, 6, 3}, kBlue1{0, 5, 2, 3}, kBlue2{0, 3, 2, 1};
  static constexpr Int kGreen0{4, 1, 2, 7}, kGreen1{0, 1, 6, 3}, kGreen2{1, 0, 3, 2};
  static constexpr Int kRed0{0, 5, 2, 3}, kRed1{4, 1, 2, 7}, kRed2{2, 1, 0, 3};
};
template <>
struct Vec<8> {
  using Float = float __attribute__((vector_size(32)));
  using Int = std::int32_t __attribute__((vector_size(32)));
  using Bits = std::uint32_t __attribute__((vector_size(32)));
  static constexpr Int kLane{0, 1, 2, 3, 4, 5, 6, 7};
  static constexpr Int kBlue0{0, 1, 10, 3, 4, 5, 14, 7}, kBlue1{0, 9, 2, 3, 4, 13, 6, 7},
      kBlue2{0, 3, 2, 1, 4, 7, 6, 5};
  static constexpr Int kGreen0{8, 1, 2, 11, 12, 5, 6, 15}, kGreen1{0, 1, 10, 3, 4, 5, 14, 7},
      kGreen2{1, 0, 3, 2, 5, 4, 7, 6};
  static constexpr Int kRed0{0, 9, 2, 3, 4, 13, 6, 7}, kRed1{8, 1, 2, 11, 12, 5, 6, 15},
      kRed2{2, 1, 0, 3, 6, 5, 4, 7};
};

// A face's float sums between flushes, lane by lane (the portable pass fills the first four).
// Corners: w·L, w·λ0·L, w·λ1·L, each B G R. Quadratics add w·λ0²·L, w·λ1²·L and w·λ0·λ1·L: with
// λ2 = 1 − λ0 − λ1 these monomials give the six Bernstein functions' sums exactly (flush_into).
// λ stay in units of kCornerWeightUnit until the flush.
template <bool kQuadratic>
struct FaceLanes {
  static constexpr int kRows = kQuadratic ? 18 : 9;
  alignas(32) float sum[kRows][kMaxWidth] = {};
  alignas(32) float lowest[kMaxWidth] = {};  // the smallest value seen: the test for negatives
  std::int32_t samples = 0;

  // Into the double sums; false (and nothing added) when a value was NaN, infinite or negative
  // or a float sum overflowed: the face is then summed again value by value.
  bool flush_into(Sums& sums) const {
    double total[kRows];
    for (int k = 0; k < kRows; ++k) {
      double t = 0;
      for (const float v : sum[k]) t += v;
      total[k] = t;
    }
    double all = 0;
    for (const double t : total) all += t;
    if (!std::isfinite(all) || *std::min_element(std::begin(lowest), std::end(lowest)) < 0.0f) return false;
    sums.b += total[0];
    sums.g += total[1];
    sums.r += total[2];
    if constexpr (kQuadratic) {
      // φ = λ0², λ1², λ2², 2λ0λ1, 2λ1λ2, 2λ2λ0 (geom::layer_values) with λ2 = 1 − λ0 − λ1, from
      // the monomials' sums; channel c (R G B) is lane row 2 − c.
      constexpr double u = kCornerWeightUnit, u2 = kCornerWeightUnit * kCornerWeightUnit;
      for (int c = 0; c < 3; ++c) {
        const int lane = 2 - c;
        const double m = total[lane], m0 = u * total[3 + lane], m1 = u * total[6 + lane];
        const double m00 = u2 * total[9 + lane], m11 = u2 * total[12 + lane], m01 = u2 * total[15 + lane];
        sums.quadratic(0, c) += m00;
        sums.quadratic(1, c) += m11;
        sums.quadratic(2, c) += m - 2.0 * (m0 + m1) + m00 + 2.0 * m01 + m11;
        sums.quadratic(3, c) += 2.0 * m01;
        sums.quadratic(4, c) += 2.0 * (m1 - m01 - m11);
        sums.quadratic(5, c) += 2.0 * (m0 - m00 - m01);
      }
    } else {
      sums.corner0 += kCornerWeightUnit * Eigen::Vector3d(total[5], total[4], total[3]);
      sums.corner1 += kCornerWeightUnit * Eigen::Vector3d(total[8], total[7], total[6]);
    }
    return true;
  }
};

// Where a run's samples lie, and where the arrays end (how far a vector load past the run's last
// sample may reach).
struct RunData {
  const float* pixel;
  const float* weights;
  const std::uint16_t* lambda;
  std::int32_t count;
};
struct DataEnds {
  const float* frame;
  const float* weights;
  const std::uint16_t* lambda;
};

// (By reference: an AVX vector returned by value from a function compiled without AVX would
// change the ABI.)
template <class Vector>
[[gnu::always_inline]] inline void load_vector(Vector& v, const void* p) {
  std::memcpy(&v, p, sizeof v);
}
template <class Vector>
[[gnu::always_inline]] inline void store_vector(float* p, const Vector& v) {
  std::memcpy(p, &v, sizeof v);
}

// One face's sums in registers while a run is added.
template <int kWidth, bool kQuadratic>
struct FittedLanes {
  using V = Vec<kWidth>;
  using Float = typename V::Float;
  using Int = typename V::Int;
  using Bits = typename V::Bits;
  // Named, not an array: the compiler keeps them in registers (an array of vectors it kept on
  // the stack, with copies in and out for every run).
  Float sum_b, sum_g, sum_r;  // w·L
  Float c0_b, c0_g, c0_r;     // w·λ0·L
  Float c1_b, c1_g, c1_r;     // w·λ1·L
  // Quadratics only (unused, and dropped by the compiler, for corners):
  Float q00_b, q00_g, q00_r;  // w·λ0²·L
  Float q11_b, q11_g, q11_r;  // w·λ1²·L
  Float q01_b, q01_g, q01_r;  // w·λ0·λ1·L
  Float lowest;

  [[gnu::always_inline]] explicit FittedLanes(const FaceLanes<kQuadratic>& f) {
    load_vector(sum_b, f.sum[0]);
    load_vector(sum_g, f.sum[1]);
    load_vector(sum_r, f.sum[2]);
    load_vector(c0_b, f.sum[3]);
    load_vector(c0_g, f.sum[4]);
    load_vector(c0_r, f.sum[5]);
    load_vector(c1_b, f.sum[6]);
    load_vector(c1_g, f.sum[7]);
    load_vector(c1_r, f.sum[8]);
    if constexpr (kQuadratic) {
      load_vector(q00_b, f.sum[9]);
      load_vector(q00_g, f.sum[10]);
      load_vector(q00_r, f.sum[11]);
      load_vector(q11_b, f.sum[12]);
      load_vector(q11_g, f.sum[13]);
      load_vector(q11_r, f.sum[14]);
      load_vector(q01_b, f.sum[15]);
      load_vector(q01_g, f.sum[16]);
      load_vector(q01_r, f.sum[17]);
    }
    load_vector(lowest, f.lowest);
  }
  [[gnu::always_inline]] void store(FaceLanes<kQuadratic>& f) const {
    store_vector(f.sum[0], sum_b);
    store_vector(f.sum[1], sum_g);
    store_vector(f.sum[2], sum_r);
    store_vector(f.sum[3], c0_b);
    store_vector(f.sum[4], c0_g);
    store_vector(f.sum[5], c0_r);
    store_vector(f.sum[6], c1_b);
    store_vector(f.sum[7], c1_g);
    store_vector(f.sum[8], c1_r);
    if constexpr (kQuadratic) {
      store_vector(f.sum[9], q00_b);
      store_vector(f.sum[10], q00_g);
      store_vector(f.sum[11], q00_r);
      store_vector(f.sum[12], q11_b);
      store_vector(f.sum[13], q11_g);
      store_vector(f.sum[14], q11_r);
      store_vector(f.sum[15], q01_b);
      store_vector(f.sum[16], q01_g);
      store_vector(f.sum[17], q01_r);
    }
    store_vector(f.lowest, lowest);
  }

  // kWidth consecutive samples at step 1 (B G R B G R ...) as one vector per channel. Per group
  // of four samples x = B0 G0 R0 B1, y = G1 R1 B2 G2, z = R2 B3 G3 R3 (with eight lanes the
  // second group, samples 4..7, in the upper half); two blends and a permutation within each
  // group make each channel.
  [[gnu::always_inline]] static void load_group(const float* p, Float& b, Float& g, Float& r) {
    Float x, y, z;
    if constexpr (kWidth == 4) {
      load_vector(x, p);
      load_vector(y, p + 4);
      load_vector(z, p + 8);
    } else {
      typename Vec<4>::Float half[6];
      for (int k = 0; k < 6; ++k) load_vector(half[k], p + 4 * k);
      x = __builtin_shufflevector(half[0], half[3], 0, 1, 2, 3, 4, 5, 6, 7);
      y = __builtin_shufflevector(half[1], half[4], 0, 1, 2, 3, 4, 5, 6, 7);
      z = __builtin_shufflevector(half[2], half[5], 0, 1, 2, 3, 4, 5, 6, 7);
    }
    b = SKYLIT_SHUFFLE(SKYLIT_SHUFFLE(SKYLIT_SHUFFLE(x, y, V::kBlue0), z, V::kBlue1), V::kBlue2);
    g = SKYLIT_SHUFFLE(SKYLIT_SHUFFLE(SKYLIT_SHUFFLE(x, y, V::kGreen0), z, V::kGreen1), V::kGreen2);
    r = SKYLIT_SHUFFLE(SKYLIT_SHUFFLE(SKYLIT_SHUFFLE(x, y, V::kRed0), z, V::kRed1), V::kRed2);
  }

  // kWidth samples `stride` floats apart, of which the first `live` count (the other lanes are
  // zero, whatever lies there: a NaN beyond the run never reaches a sum).
  template <bool kContiguous>
  [[gnu::always_inline]] void add(const float* pixel, std::ptrdiff_t stride, const float* weights,
                                  const std::uint16_t* lambda, std::int32_t live) {
    Float b, g, r, w;
    Bits pairs;  // per sample λ1 << 16 | λ0
    if constexpr (kContiguous) {
      load_group(pixel, b, g, r);
      load_vector(w, weights);
      load_vector(pairs, lambda);
      if (live < kWidth) {
        const Int on = V::kLane < live;
        const Float zero{};
        b = on ? b : zero;
        g = on ? g : zero;
        r = on ? r : zero;
        w = on ? w : zero;
      }
    } else {
      for (int k = 0; k < kWidth; ++k) {
        b[k] = pixel[k * stride];
        g[k] = pixel[k * stride + 1];
        r[k] = pixel[k * stride + 2];
      }
      load_vector(w, weights);
      load_vector(pairs, lambda);
    }
    const Float l0 = __builtin_convertvector(Int(pairs & 0xffffu), Float);
    const Float l1 = __builtin_convertvector(Int(pairs >> 16), Float);
    const Float w0 = w * l0;
    const Float w1 = w * l1;
    lowest = b < lowest ? b : lowest;
    lowest = g < lowest ? g : lowest;
    lowest = r < lowest ? r : lowest;
    sum_b += w * b;
    sum_g += w * g;
    sum_r += w * r;
    c0_b += w0 * b;
    c0_g += w0 * g;
    c0_r += w0 * r;
    c1_b += w1 * b;
    c1_g += w1 * g;
    c1_r += w1 * r;
    if constexpr (kQuadratic) {
      const Float w00 = w0 * l0, w11 = w1 * l1, w01 = w0 * l1;
      q00_b += w00 * b;
      q00_g += w00 * g;
      q00_r += w00 * r;
      q11_b += w11 * b;
      q11_g += w11 * g;
      q11_r += w11 * r;
      q01_b += w01 * b;
      q01_g += w01 * g;
      q01_r += w01 * r;
    }
  }

  // A run without masks: whole groups of kWidth samples, then the rest in a group whose other
  // lanes are zero. At step 1 that last group reads past the run where the arrays go on (and
  // zeroes those lanes); else it takes a copy of the rest.
  template <bool kContiguous>
  [[gnu::always_inline]] void add_run(const RunData& run, std::ptrdiff_t stride, const DataEnds& ends) {
    std::int32_t k = 0;
    for (; k + kWidth <= run.count; k += kWidth) {
      add<kContiguous>(run.pixel + k * stride, stride, run.weights + k, run.lambda + 2 * k, kWidth);
    }
    const std::int32_t left = run.count - k;
    if (left == 0) return;
    const float* pixel = run.pixel + k * stride;
    const float* weights = run.weights + k;
    const std::uint16_t* lambda = run.lambda + 2 * k;
    if (kContiguous && pixel + 3 * kWidth <= ends.frame && weights + kWidth <= ends.weights &&
        lambda + 2 * kWidth <= ends.lambda) {
      add<true>(pixel, 3, weights, lambda, left);
      return;
    }
    float value[3 * kWidth] = {}, weight[kWidth] = {};
    std::uint16_t pair[2 * kWidth] = {};
    for (std::int32_t j = 0; j < left; ++j) {
      std::memcpy(value + 3 * j, pixel + j * stride, 3 * sizeof(float));
      weight[j] = weights[j];
      pair[2 * j] = lambda[2 * j];
      pair[2 * j + 1] = lambda[2 * j + 1];
    }
    add<true>(value, 3, weight, pair, left);
  }
};

// Whether any of `count` mask bytes `step` apart is set.
[[gnu::always_inline]] inline bool any_set(const std::uint8_t* mask, std::int32_t count, std::ptrdiff_t step) {
  if (step == 1) {  // eight bytes at a time; the last eight overlap the ones before
    if (count < 8) return std::any_of(mask, mask + count, [](std::uint8_t m) { return m != 0; });
    std::uint64_t any = 0, word;
    for (std::int32_t k = 0; k + 8 <= count; k += 8) {
      std::memcpy(&word, mask + k, sizeof word);
      any |= word;
    }
    std::memcpy(&word, mask + count - 8, sizeof word);
    return (any | word) != 0;
  }
  for (std::int32_t k = 0; k < count; ++k) {
    if (mask[k * step] != 0) return true;
  }
  return false;
}

// A sample the mask excludes: its functions' mass, to be taken from the face's.
template <bool kQuadratic>
inline void add_excluded_sample(Sums& sums, double w, double l0, double l1) {
  sums.excluded = true;
  if constexpr (kQuadratic) {
    const geom::LayerValues phi = geom::layer_values(geom::DomeBasis::Quadratics, {l0, l1, 1.0 - l0 - l1});
    const Eigen::Map<const Eigen::Matrix<double, 6, 1>> v(phi.data());
    sums.quadratic_excluded_mass.noalias() += (w * v) * v.transpose();
  } else {
    const Eigen::Vector3d l(l0, l1, 1.0 - l0 - l1);
    sums.excluded_mass.noalias() += w * l * l.transpose();
  }
}

// A sample's value (R G B, sanitised) into the sums of the basis's functions; Σ w L apart.
template <bool kQuadratic>
inline void add_function_sums(Sums& sums, double w, double l0, double l1, const Eigen::Vector3d& rgb) {
  if constexpr (kQuadratic) {
    const geom::LayerValues phi = geom::layer_values(geom::DomeBasis::Quadratics, {l0, l1, 1.0 - l0 - l1});
    const Eigen::Map<const Eigen::Matrix<double, 6, 1>> v(phi.data());
    sums.quadratic.noalias() += (w * v) * rgb.transpose();
  } else {
    sums.corner0 += (w * l0) * rgb;
    sums.corner1 += (w * l1) * rgb;
  }
}

// The careful pass of one run: every value sanitised, double sums straight into `sums`.
template <bool kQuadratic>
void fitted_run_careful(const float* pixel, std::ptrdiff_t stride, const std::uint8_t* clipped,
                        const std::uint8_t* exclude, std::ptrdiff_t mask_stride, const float* weights,
                        const std::uint16_t* lambda, std::int32_t count, Sums& sums) {
  for (std::int32_t k = 0; k < count; ++k) {
    const double w = weights[k];
    const double l0 = lambda[2 * k] * kCornerWeightUnit, l1 = lambda[2 * k + 1] * kCornerWeightUnit;
    if (exclude && exclude[k * mask_stride] != 0) {
      add_excluded_sample<kQuadratic>(sums, w, l0, l1);
      continue;
    }
    float value[3] = {pixel[k * stride], pixel[k * stride + 1], pixel[k * stride + 2]};
    sanitise(value, sums);
    const Eigen::Vector3d rgb(value[2], value[1], value[0]);
    sums.b += w * value[0];
    sums.g += w * value[1];
    sums.r += w * value[2];
    sums.weight += w;
    add_function_sums<kQuadratic>(sums, w, l0, l1, rgb);
    if (clipped && clipped[k * mask_stride] != 0) {
      sums.clipped += w;
      ++sums.clipped_pixels;
    }
  }
}

// A run that a mask touches (few: the sun's disc, clipped pixels): sample by sample, double sums
// straight into `sums`, Σ w included. False, with nothing added, at a NaN, infinite or negative
// value. `clipped` and `exclude` are null where the run has none. `run_weight`: Σ w of all its
// samples (the part of face_solid_angle that the fast sums do not cover).
template <bool kQuadratic>
bool add_masked_fitted_run(const RunData& d, std::ptrdiff_t stride, const std::uint8_t* clipped,
                           const std::uint8_t* exclude, std::ptrdiff_t mask_stride, Sums& sums,
                           double& run_weight) {
  Sums run;
  double all = 0;
  for (std::int32_t k = 0; k < d.count; ++k) {
    const double w = d.weights[k];
    const double l0 = d.lambda[2 * k] * kCornerWeightUnit, l1 = d.lambda[2 * k + 1] * kCornerWeightUnit;
    all += w;
    if (exclude && exclude[k * mask_stride] != 0) {
      add_excluded_sample<kQuadratic>(run, w, l0, l1);
      continue;
    }
    const float* value = d.pixel + k * stride;
    if (!(std::min(value[0], std::min(value[1], value[2])) >= 0.0f) ||
        !std::isfinite(value[0] + value[1] + value[2])) {
      return false;
    }
    const Eigen::Vector3d rgb(value[2], value[1], value[0]);
    run.b += w * value[0];
    run.g += w * value[1];
    run.r += w * value[2];
    run.weight += w;
    add_function_sums<kQuadratic>(run, w, l0, l1, rgb);
    if (clipped && clipped[k * mask_stride] != 0) {
      run.clipped += w;
      ++run.clipped_pixels;
    }
  }
  sums.b += run.b;
  sums.g += run.g;
  sums.r += run.r;
  sums.weight += run.weight;
  sums.corner0 += run.corner0;
  sums.corner1 += run.corner1;
  sums.quadratic += run.quadratic;
  sums.clipped += run.clipped;
  sums.clipped_pixels += run.clipped_pixels;
  if (run.excluded) {
    sums.excluded = true;
    sums.excluded_mass += run.excluded_mass;
    sums.quadratic_excluded_mass += run.quadratic_excluded_mass;
  }
  run_weight = all;
  return true;
}

// What the fitted pass (corners or quadratics) works on. Per face: the double sums, the float
// lane sums, the weight of its runs that a mask touched, and whether it must be summed again
// value by value.
template <bool kQuadratic>
struct FittedPass {
  const SkyTable& table;
  const cv::Mat& radiance;
  const cv::Mat& clipped;  // may be empty
  const cv::Mat& exclude;  // may be empty
  std::vector<Sums>& sums;
  std::vector<FaceLanes<kQuadratic>>& lanes;
  std::vector<double>& masked_weight;
  std::vector<std::uint8_t>& careful;
};

// The fast pass, always inlined: it takes the instruction set of its caller
// (fast_fitted_pass_avx2 or fast_fitted_pass_portable). Returns the samples visited.
template <int kWidth, bool kQuadratic>
[[gnu::always_inline]] inline std::int64_t fast_fitted_pass(const FittedPass<kQuadratic>& p) {
  // Everything the loop reads from the table and the frames in locals: the lane sums' stores
  // (memcpy) may alias anything, and would make the compiler read them again for every run.
  const SkyTable& table = p.table;
  const RunLimits limits(table, p.sums.size());
  const std::ptrdiff_t step = table.step;
  const std::ptrdiff_t stride = 3 * step;
  const std::uint8_t* const frame = p.radiance.data;
  const std::size_t frame_row = p.radiance.step[0];
  const std::uint8_t* const clipped = p.clipped.empty() ? nullptr : p.clipped.data;
  const std::size_t clipped_row = p.clipped.empty() ? 0 : p.clipped.step[0];
  const std::uint8_t* const exclude = p.exclude.empty() ? nullptr : p.exclude.data;
  const std::size_t exclude_row = p.exclude.empty() ? 0 : p.exclude.step[0];
  const float* const weights = table.weights.data();
  const std::uint16_t* const lambda = table.corner_weights.data();
  const DataEnds ends{reinterpret_cast<const float*>(p.radiance.dataend), weights + table.weights.size(),
                      lambda + table.corner_weights.size()};
  Sums* const sums = p.sums.data();
  FaceLanes<kQuadratic>* const face_lanes = p.lanes.data();
  double* const masked_weight = p.masked_weight.data();
  std::uint8_t* const careful = p.careful.data();
  const PixelRun* const runs_end = table.runs.data() + table.runs.size();
  std::int64_t samples = 0;
  for (const PixelRun* run = table.runs.data(); run != runs_end; ++run) {
    limits.check(*run);
    samples += run->count;
    const auto face = static_cast<std::size_t>(run->face);
    if (careful[face]) continue;
    const RunData d{reinterpret_cast<const float*>(frame + std::size_t(run->row) * frame_row) +
                        3 * std::ptrdiff_t{run->col_begin},
                    weights + run->weight_offset, lambda + 2 * std::size_t{run->weight_offset}, run->count};
    // A mask with nothing set along the run (the sun's disc and clipped pixels are small) costs
    // the run nothing: it takes the mask-free path.
    const std::uint8_t* c = clipped ? clipped + std::size_t(run->row) * clipped_row + run->col_begin : nullptr;
    const std::uint8_t* e = exclude ? exclude + std::size_t(run->row) * exclude_row + run->col_begin : nullptr;
    if (c && !any_set(c, run->count, step)) c = nullptr;
    if (e && !any_set(e, run->count, step)) e = nullptr;
    if (c || e) [[unlikely]] {
      double run_weight = 0;
      if (add_masked_fitted_run<kQuadratic>(d, stride, c, e, step, sums[face], run_weight)) {
        masked_weight[face] += run_weight;
      } else {
        careful[face] = 1;
      }
      continue;
    }
    FaceLanes<kQuadratic>& stored = face_lanes[face];
    FittedLanes<kWidth, kQuadratic> lanes(stored);
    if (step == 1) {
      lanes.template add_run<true>(d, stride, ends);
    } else {
      lanes.template add_run<false>(d, stride, ends);
    }
    lanes.store(stored);
    stored.samples += run->count;
    if (stored.samples >= kFlushAdditions * kWidth) {
      if (!stored.flush_into(sums[face])) careful[face] = 1;
      stored = FaceLanes<kQuadratic>{};
    }
  }
  return samples;
}

template <bool kQuadratic>
std::int64_t fast_fitted_pass_portable(const FittedPass<kQuadratic>& p) {
  return fast_fitted_pass<4, kQuadratic>(p);
}

#if SKYLIT_SKY_X86
// Three-operand instructions, single-instruction blends and fused multiply-adds (so the sums
// agree with the portable pass to float rounding, not bit for bit); eight lanes at step 1, four
// where the step skips pixels (the lanes are then filled one by one and the runs are short).
template <bool kQuadratic>
__attribute__((target("avx2,fma"))) std::int64_t fast_fitted_pass_avx2(const FittedPass<kQuadratic>& p) {
  return p.table.step == 1 ? fast_fitted_pass<8, kQuadratic>(p) : fast_fitted_pass<4, kQuadratic>(p);
}
bool cpu_has_avx2_fma() { return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"); }
#endif

// The corners and quadratics passes: the fast pass, then the faces it could not take value by
// value. A face whose fast sums show a NaN, an infinity or a negative value (or overflow) is
// summed again, all of it, in a second pass that visits its runs only.
template <bool kQuadratic>
void accumulate_fitted(const SkyTable& table, const cv::Mat& radiance, const cv::Mat& clipped,
                       const cv::Mat& exclude, bool use_simd, std::vector<Sums>& sums, std::int64_t& samples) {
  const std::size_t n = sums.size();
  std::vector<FaceLanes<kQuadratic>> lanes(n);
  std::vector<double> masked_weight(n, 0.0);
  std::vector<std::uint8_t> careful(n, 0);
  const FittedPass<kQuadratic> pass{table, radiance, clipped, exclude, sums, lanes, masked_weight, careful};
#if SKYLIT_SKY_X86
  samples += use_simd && cpu_has_avx2_fma() ? fast_fitted_pass_avx2(pass) : fast_fitted_pass_portable(pass);
#else
  (void)use_simd;
  samples += fast_fitted_pass_portable(pass);
#endif
  bool any_careful = false;
  for (std::size_t face = 0; face < n; ++face) {
    if (!careful[face] && !lanes[face].flush_into(sums[face])) careful[face] = 1;
    if (careful[face]) {
      sums[face] = Sums{};
      any_careful = true;
    } else {
      sums[face].weight += table.face_solid_angle[face] - masked_weight[face];
    }
  }
  if (!any_careful) return;
  const std::ptrdiff_t step = table.step;
  for (const PixelRun& run : table.runs) {
    const auto face = static_cast<std::size_t>(run.face);
    if (!careful[face]) continue;
    fitted_run_careful<kQuadratic>(
        radiance.ptr<float>(run.row) + 3 * std::ptrdiff_t{run.col_begin}, 3 * step,
        clipped.empty() ? nullptr : clipped.ptr<std::uint8_t>(run.row) + run.col_begin,
        exclude.empty() ? nullptr : exclude.ptr<std::uint8_t>(run.row) + run.col_begin, step,
        table.weights.data() + run.weight_offset, table.corner_weights.data() + 2 * std::size_t{run.weight_offset},
        run.count, sums[face]);
  }
}

// The fit of every seen face's functions: M⁻¹ b with M the table's mass matrix, less the
// excluded samples' when the sun took some. A quadratics face whose (remaining) pixels do not
// pin six functions down gets the linear fit if they pin three; otherwise the face's mean in
// every function, and the flag.
void fit_layers(const SkyTable& table, const std::vector<Sums>& sums, const std::vector<bool>& seen,
                const LuminanceOptions& options, Luminance& result) {
  const bool quadratics = table.basis == geom::DomeBasis::Quadratics;
  const auto layers = static_cast<Eigen::Index>(geom::layers_per_face(table.basis));
  const auto passes = [&](double conditioning) {
    return conditioning >= options.min_corner_conditioning && conditioning > 0.0;
  };
  for (std::size_t i = 0; i < result.faces.size(); ++i) {
    FaceLuminance& face = result.faces[i];
    if (!seen[i]) continue;
    const Sums& s = sums[i];
    Eigen::MatrixXd b(layers, 3);  // row k: Σ w φ_k L (R G B)
    // The table's mass, less the excluded samples' (a copy only where the sun took some).
    Eigen::MatrixXd excluded_mass;
    if (quadratics) {
      b = s.quadratic;
      if (s.excluded) excluded_mass = table.corner_mass[i] - s.quadratic_excluded_mass;
    } else {
      b.row(0) = s.corner0.transpose();
      b.row(1) = s.corner1.transpose();
      b.row(2) = Eigen::Vector3d(s.r, s.g, s.b).transpose() - b.row(0) - b.row(1);
      if (s.excluded) excluded_mass = table.corner_mass[i] - s.excluded_mass;
    }
    const Eigen::MatrixXd& mass = s.excluded ? excluded_mass : table.corner_mass[i];
    const double conditioning =
        s.excluded ? corner_conditioning(mass, table.corner_full_mass[i]) : table.corner_conditioning[i];
    Eigen::MatrixXd fit;
    if (passes(conditioning)) {
      fit = (s.excluded ? Eigen::MatrixXd(mass.inverse()) : table.corner_inverse[i]) * b;
    } else if (quadratics) {
      const Eigen::Matrix<double, 3, 6> to_corner = geom::quadratic_to_corner();
      const Eigen::Matrix3d linear_mass = to_corner * mass * to_corner.transpose();
      const Eigen::Matrix3d linear_full = to_corner * table.corner_full_mass[i] * to_corner.transpose();
      if (passes(corner_conditioning(linear_mass, linear_full))) {
        fit = geom::corner_to_quadratic() * (linear_mass.inverse() * (to_corner * b));
        face.flags |= kFaceFitLinear;
        ++result.linear_fits;
      }
    }
    if (fit.size() == 0) {
      face.flags |= kFaceCornersFromMean;
      ++result.corners_from_mean;
      face.coefficients.assign(static_cast<std::size_t>(layers), face.rgb);
      continue;
    }
    face.coefficients.resize(static_cast<std::size_t>(layers));
    for (Eigen::Index k = 0; k < layers; ++k) face.coefficients[static_cast<std::size_t>(k)] = fit.row(k).transpose();
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
  const bool fitted = table.basis != geom::DomeBasis::Faces;
  if (fitted) {
    const auto layers = static_cast<Eigen::Index>(geom::layers_per_face(table.basis));
    const auto sized = [&](const std::vector<Eigen::MatrixXd>& m) {
      return m.size() == n && std::all_of(m.begin(), m.end(), [&](const Eigen::MatrixXd& x) {
               return x.rows() == layers && x.cols() == layers;
             });
    };
    if (table.corner_weights.size() != 2 * table.weights.size() || !sized(table.corner_mass) ||
        !sized(table.corner_inverse) || !sized(table.corner_full_mass) || table.corner_conditioning.size() != n) {
      reject_input("table",
                   "the " + std::string(geom::basis_name(table.basis)) +
                       " table lacks its barycentric weights or mass matrices",
                   "build the sky table with build_sky_table and basis " + std::string(geom::basis_name(table.basis)));
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
  if (table.basis == geom::DomeBasis::Corners) {
    accumulate_fitted<false>(table, radiance, clipped, exclude, options.use_simd, sums, result.samples);
  } else if (table.basis == geom::DomeBasis::Quadratics) {
    accumulate_fitted<true>(table, radiance, clipped, exclude, options.use_simd, sums, result.samples);
  } else {
    const RunLimits limits(table, n);
    for (const PixelRun& run : table.runs) {
      limits.check(run);
      const float* pixel = radiance.ptr<float>(run.row) + 3 * std::ptrdiff_t{run.col_begin};
      const float* weights = table.weights.data() + run.weight_offset;
      // Absent masks stay null: the templates below never touch them.
      const std::uint8_t* c = has_clipped ? clipped.ptr<std::uint8_t>(run.row) + run.col_begin : nullptr;
      const std::uint8_t* e = has_exclude ? exclude.ptr<std::uint8_t>(run.row) + run.col_begin : nullptr;
      Sums& s = sums[static_cast<std::size_t>(run.face)];
      if (has_clipped && has_exclude) {
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
    for (FaceLuminance& face : result.faces) {
      face.rgb.setZero();
      if (fitted) face.coefficients.assign(static_cast<std::size_t>(geom::layers_per_face(table.basis)), face.rgb);
    }
    return result;
  }
  const std::vector<bool> seen = known;
  if (result.unseen_faces > 0) fill_unseen(dome, known, weight, result);
  if (fitted) {
    fit_layers(table, sums, seen, options, result);
    const auto layers = static_cast<std::size_t>(geom::layers_per_face(table.basis));
    for (std::size_t i = 0; i < n; ++i) {
      if (!seen[i]) result.faces[i].coefficients.assign(layers, result.faces[i].rgb);
    }
  }
  return result;
}

std::vector<Eigen::Vector3d> layer_radiances(const Luminance& luminance) {
  std::vector<Eigen::Vector3d> S;
  const auto layers = static_cast<std::size_t>(geom::layers_per_face(luminance.basis));
  S.reserve(luminance.faces.size() * layers);
  for (const FaceLuminance& face : luminance.faces) {
    if (luminance.basis == geom::DomeBasis::Faces) {
      S.push_back(face.rgb);
    } else {
      S.insert(S.end(), face.coefficients.begin(), face.coefficients.end());
    }
  }
  return S;
}

}  // namespace skylit::sky
