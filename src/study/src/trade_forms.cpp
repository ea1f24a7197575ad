// The forms a basis is measured in by the trade table: 8-bit layers, upsampled planes, the
// shadow edges of T, and a bake's size on disk.
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

namespace fs = std::filesystem;

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


}  // namespace skylit::study::trade
