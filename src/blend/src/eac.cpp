// EAC R11 encode and decode (eac.hpp). Only the C++ library here (bench/gpu_standalone.sh).
#include "skylit/blend/eac.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace skylit::blend {
namespace {

// The modifier tables of EAC (OpenGL ES 3.0, table C.12), shared with ETC2's alpha.
constexpr std::array<std::array<int, 8>, 16> kModifiers{{
    {-3, -6, -9, -15, 2, 5, 8, 14},
    {-3, -7, -10, -13, 2, 6, 9, 12},
    {-2, -5, -8, -13, 1, 4, 7, 12},
    {-2, -4, -6, -13, 1, 3, 5, 12},
    {-3, -6, -8, -12, 2, 5, 7, 11},
    {-3, -7, -9, -11, 2, 6, 8, 10},
    {-4, -7, -8, -11, 3, 6, 7, 10},
    {-3, -5, -8, -11, 2, 4, 7, 10},
    {-2, -6, -8, -10, 1, 5, 7, 9},
    {-2, -5, -8, -10, 1, 4, 7, 9},
    {-2, -4, -8, -10, 1, 3, 7, 9},
    {-2, -5, -7, -10, 1, 4, 6, 9},
    {-3, -4, -7, -10, 2, 3, 6, 9},
    {-1, -2, -3, -10, 0, 1, 2, 9},
    {-4, -6, -8, -9, 3, 5, 7, 8},
    {-3, -5, -7, -9, 2, 4, 6, 8},
}};

constexpr int kMax11 = 2047;

int level(int base, int multiplier, int modifier) {
  const int step = multiplier == 0 ? 1 : 8 * multiplier;
  return std::clamp(8 * base + 4 + modifier * step, 0, kMax11);
}

float unorm16_of_11(int v) { return static_cast<float>((v << 5) | (v >> 6)) / 65535.0f; }

struct Block {
  int base = 0;
  int multiplier = 0;
  int table = 0;
  std::array<int, 16> index{};  // texel x * 4 + y (the format's column order)
  double error = std::numeric_limits<double>::infinity();
};

// The nearest of the eight levels for every texel; returns the summed squared error.
double assign(const std::array<double, 16>& v, int base, int multiplier, int table, std::array<int, 16>& index,
              double give_up) {
  std::array<int, 8> levels{};
  for (int j = 0; j < 8; ++j) levels[static_cast<std::size_t>(j)] = level(base, multiplier, kModifiers[static_cast<std::size_t>(table)][static_cast<std::size_t>(j)]);
  double sum = 0.0;
  for (std::size_t p = 0; p < 16; ++p) {
    double best = std::numeric_limits<double>::infinity();
    int best_j = 0;
    for (int j = 0; j < 8; ++j) {
      const double d = v[p] - levels[static_cast<std::size_t>(j)];
      if (d * d < best) {
        best = d * d;
        best_j = j;
      }
    }
    index[p] = best_j;
    sum += best;
    if (sum >= give_up) return sum;
  }
  return sum;
}

// A block whose texels are within half a step on average (RMS): flat blocks, most of a basis
// image, stop at the first table that gets there.
constexpr double kGoodEnough = 16 * 0.25;

Block encode_block(const std::array<double, 16>& v) {
  const auto [lo_it, hi_it] = std::minmax_element(v.begin(), v.end());
  const double lo = *lo_it, hi = *hi_it, mid = 0.5 * (lo + hi);
  Block best;
  std::array<int, 16> index{};
  auto consider = [&](int base, int multiplier, int table) {
    base = std::clamp(base, 0, 255);
    const double e = assign(v, base, multiplier, table, index, best.error);
    if (e < best.error) best = Block{base, multiplier, table, index, e};
  };
  for (int t = 0; t < 16; ++t) {
    const auto& m = kModifiers[static_cast<std::size_t>(t)];
    const int low = *std::min_element(m.begin(), m.end()), high = *std::max_element(m.begin(), m.end());
    // The multipliers whose levels span the block's range, and m = 0 (steps of one) for a block
    // narrower than the coarsest of them.
    // (A block's texels need not reach the table's extremes, so one or two multipliers past
    // the spanning one are tried too.)
    const int spanning = static_cast<int>(std::floor((hi - lo) / (8.0 * (high - low))));
    const int first = std::max(spanning - 1, 1), last = std::min(spanning + 2, 15);
    for (int mult = 0; mult <= last; mult = mult == 0 ? first : mult + 1) {
      const double step = mult == 0 ? 1.0 : 8.0 * mult;
      const int centre = static_cast<int>(std::lround((mid - 4.0 - 0.5 * (low + high) * step) / 8.0));
      for (int b = centre - 2; b <= centre + 2; ++b) consider(b, mult, t);
    }
    if (best.error <= kGoodEnough) break;
  }
  // Refine the base codeword of the winner.
  const Block winner = best;
  for (int b = winner.base - 3; b <= winner.base + 3; ++b) consider(b, winner.multiplier, winner.table);
  return best;
}

void write_block(const Block& b, std::uint8_t* out) {
  std::uint64_t word = (static_cast<std::uint64_t>(b.base) << 56) | (static_cast<std::uint64_t>(b.multiplier) << 52) |
                       (static_cast<std::uint64_t>(b.table) << 48);
  for (int p = 0; p < 16; ++p) word |= static_cast<std::uint64_t>(b.index[static_cast<std::size_t>(p)]) << (45 - 3 * p);
  for (int k = 0; k < 8; ++k) out[k] = static_cast<std::uint8_t>(word >> (56 - 8 * k));
}

void check_size(int width, int height) {
  if (width <= 0 || height <= 0) {
    throw std::invalid_argument("EAC: image size " + std::to_string(width) + "x" + std::to_string(height) + " has no texels");
  }
}

}  // namespace

std::size_t eac_block_count(int width, int height) {
  return static_cast<std::size_t>((width + 3) / 4) * static_cast<std::size_t>((height + 3) / 4);
}

// Blocks a thread must have to be worth starting (one 64² image's worth).
constexpr long kEacBlocksPerThread = 256;

std::vector<std::uint8_t> encode_eac_r11(std::span<const float> values, int width, int height) {
  check_size(width, height);
  if (values.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    throw std::invalid_argument("EAC: " + std::to_string(values.size()) + " values for a " + std::to_string(width) + "x" +
                                std::to_string(height) + " image");
  }
  const int columns = (width + 3) / 4, rows = (height + 3) / 4;
  std::vector<std::uint8_t> blocks(eac_block_count(width, height) * kEacBlockBytes);
  const auto encode_rows = [&](int first, int last) {
    std::array<double, 16> v{};
    for (int by = first; by < last; ++by) {
      for (int bx = 0; bx < columns; ++bx) {
        for (int x = 0; x < 4; ++x) {
          for (int y = 0; y < 4; ++y) {
            const int col = std::min(4 * bx + x, width - 1), row = std::min(4 * by + y, height - 1);
            const float f = values[static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(col)];
            const double clamped = f > 1.0f ? 1.0 : (f >= 0.0f ? static_cast<double>(f) : 0.0);  // NaN → 0
            v[static_cast<std::size_t>(4 * x + y)] = clamped * kMax11;
          }
        }
        write_block(encode_block(v), &blocks[(static_cast<std::size_t>(by) * static_cast<std::size_t>(columns) + static_cast<std::size_t>(bx)) * kEacBlockBytes]);
      }
    }
  };
  // Encoding searches every table per block (about a second per 512² layer of noise on one core)
  // and runs at start-up, so rows of blocks are shared among the hardware threads; small images,
  // where a thread costs more than it saves, stay on the caller's.
  const int threads = static_cast<int>(std::min<long>(std::max(1u, std::thread::hardware_concurrency()),
                                                      static_cast<long>(columns) * rows / kEacBlocksPerThread + 1));
  std::vector<std::jthread> helpers;
  for (int t = 1; t < threads; ++t) helpers.emplace_back(encode_rows, rows * t / threads, rows * (t + 1) / threads);
  encode_rows(0, rows / threads);
  helpers.clear();  // joins
  return blocks;
}

std::vector<float> decode_eac_r11(std::span<const std::uint8_t> blocks, int width, int height) {
  check_size(width, height);
  if (blocks.size() != eac_block_count(width, height) * kEacBlockBytes) {
    throw std::invalid_argument("EAC: " + std::to_string(blocks.size()) + " bytes for a " + std::to_string(width) + "x" +
                                std::to_string(height) + " image");
  }
  const int columns = (width + 3) / 4, rows = (height + 3) / 4;
  std::vector<float> values(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  for (int by = 0; by < rows; ++by) {
    for (int bx = 0; bx < columns; ++bx) {
      const std::uint8_t* in = &blocks[(static_cast<std::size_t>(by) * static_cast<std::size_t>(columns) + static_cast<std::size_t>(bx)) * kEacBlockBytes];
      std::uint64_t word = 0;
      for (int k = 0; k < 8; ++k) word = (word << 8) | in[k];
      const int base = static_cast<int>(word >> 56), multiplier = static_cast<int>((word >> 52) & 15u),
                table = static_cast<int>((word >> 48) & 15u);
      for (int p = 0; p < 16; ++p) {
        const int col = 4 * bx + p / 4, row = 4 * by + p % 4;
        if (col >= width || row >= height) continue;
        const int j = static_cast<int>((word >> (45 - 3 * p)) & 7u);
        values[static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(col)] =
            unorm16_of_11(level(base, multiplier, kModifiers[static_cast<std::size_t>(table)][static_cast<std::size_t>(j)]));
      }
    }
  }
  return values;
}

}  // namespace skylit::blend
