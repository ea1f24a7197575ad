#include "skylit/sky/luminance.hpp"

#include <algorithm>
#include <cmath>
#include <string>

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

  Luminance result;
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
  if (result.unseen_faces > 0) fill_unseen(dome, known, weight, result);
  return result;
}

}  // namespace skylit::sky
