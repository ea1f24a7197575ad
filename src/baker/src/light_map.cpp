// The building's light map: charts over the flat regions, packed into one atlas (light_map.hpp).
#include "skylit/baker/light_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include "flat_regions.hpp"
#include "skylit/base/error.hpp"

namespace skylit::baker {
namespace light_map_detail {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
constexpr int kMaxAtlasSide = 16384;

// The point of triangle (a, b, c) nearest p, as barycentric weights (Ericson, Real-Time
// Collision Detection, 5.1.5), in the plane of the chart.
Vec3 nearest_barycentric(const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c) {
  const Vec2 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return {1, 0, 0};
  const Vec2 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Vec2 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denominator = 1.0 / (va + vb + vc);
  const double v = vb * denominator, w = vc * denominator;
  return {1 - v - w, v, w};
}

// A texel of a chart while it is laid out: the nearest point of the region to its centre.
struct TexelHit {
  double distance = std::numeric_limits<double>::infinity();
  std::size_t triangle = 0;
  Vec3 weights = Vec3::Zero();
};

}  // namespace light_map_detail

void validate_light_map_options(const LightMapOptions& o) {
  if (!(o.texel >= 0.005) || !std::isfinite(o.texel)) {
    throw InputError("--light-map: must be a texel size of at least 0.005 m. Fix: give e.g. --light-map 0.1");
  }
  if (!(o.min_area >= 0.0) || !std::isfinite(o.min_area)) {
    throw InputError("--light-map-min-area: must be m² ≥ 0. Fix: give e.g. --light-map-min-area 1");
  }
  if (o.min_across < 0 || o.min_across > 1024) {
    throw InputError("--light-map-min-across: must be 0 (off) to 1024 texels. Fix: give e.g. --light-map-min-across 6");
  }
}

LightMapPoints lay_out_light_map(const scene::Mesh& mesh, const LightMapOptions& options) {
  using light_map_detail::Vec2, light_map_detail::Vec3, light_map_detail::TexelHit, light_map_detail::kMaxAtlasSide, light_map_detail::nearest_barycentric;
  validate_light_map_options(options);
  const FlatFaces faces = flat_faces(mesh);
  const std::vector<FlatRegion> regions = flat_regions(mesh, faces);
  const auto corner = [&](std::size_t t, std::size_t k) -> Vec3 { return mesh.positions[mesh.indices[3 * t + k]].cast<double>(); };

  LightMapPoints out;
  bake_format::LightMapLayout& layout = out.layout;
  layout.texel = options.texel;
  layout.triangle_chart.assign(mesh.triangle_count(), -1);

  // Charts before packing: texels in chart coordinates, each with its point on the region.
  struct Chart {
    bake_format::LightMapChart frame;
    std::vector<TexelHit> texels;  // width × height, rows of width
  };
  std::vector<Chart> charts;
  for (const FlatRegion& r : regions) {
    if (r.area < options.min_area || !(r.normal.norm() > 0.0)) continue;
    const Vec3 n = r.normal;
    // u along the ground for a wall, along x for a roof or a floor; v = n × u, so that u × v = n.
    Vec3 u = std::abs(n.z()) < 0.9 ? Vec3(Vec3::UnitZ().cross(n)) : Vec3(Vec3::UnitX() - n.x() * n);
    u.normalize();
    const Vec3 v = n.cross(u);
    const Vec3 anchor = corner(r.triangles.front(), 0);
    double s0 = 1e300, s1 = -1e300, t0 = 1e300, t1 = -1e300, offset = 0.0;
    for (const std::size_t t : r.triangles) {
      for (std::size_t k = 0; k < 3; ++k) {
        const Vec3 d = corner(t, k) - anchor;
        s0 = std::min(s0, d.dot(u)), s1 = std::max(s1, d.dot(u));
        t0 = std::min(t0, d.dot(v)), t1 = std::max(t1, d.dot(v));
        offset += d.dot(n) / (3.0 * static_cast<double>(r.triangles.size()));
      }
    }
    // Across a narrow region, texels fine enough to have min_across of them (its light changes
    // fastest there, near the parts it meets); along it, the chart's texel.
    const auto texel_over = [&](double extent) {
      const double texel = options.texel;
      return options.min_across > 0 && extent < options.min_across * texel ? std::max(0.25 * texel, extent / options.min_across) : texel;
    };
    Chart chart;
    chart.frame.texel_u = texel_over(s1 - s0);
    chart.frame.texel_v = texel_over(t1 - t0);
    const double tu = chart.frame.texel_u, tv = chart.frame.texel_v;
    // Texel 0's centre half a texel before the region's first edge and one texel more than the
    // region spans: a bilinear lookup anywhere on the region reads texels of this chart only.
    chart.frame.width = static_cast<int>(std::floor((s1 - s0) / tu + 0.5)) + 2;
    chart.frame.height = static_cast<int>(std::floor((t1 - t0) / tv + 0.5)) + 2;
    if (chart.frame.width > kMaxAtlasSide || chart.frame.height > kMaxAtlasSide) {
      throw InputError("--light-map: a flat region of " + std::to_string(r.area) + " m² would be " + std::to_string(chart.frame.width) +
                       "×" + std::to_string(chart.frame.height) + " texels of " + std::to_string(options.texel) +
                       " m, more than the atlas's " + std::to_string(kMaxAtlasSide) + " along a side. Fix: give a larger texel");
    }
    const double so = s0 - 0.5 * tu, to = t0 - 0.5 * tv;
    chart.frame.origin = anchor + so * u + to * v + offset * n;
    chart.frame.u = u;
    chart.frame.v = v;
    chart.texels.assign(static_cast<std::size_t>(chart.frame.width) * static_cast<std::size_t>(chart.frame.height), TexelHit{});
    // Each triangle's nearest point to the texel centres around it (in metres): a lookup less than
    // a texel away along both axes reads a texel, so those within the texel's diagonal are the
    // ones it needs.
    const double reach = std::hypot(tu, tv);
    for (const std::size_t t : r.triangles) {
      std::array<Vec2, 3> p;
      for (std::size_t k = 0; k < 3; ++k) {
        const Vec3 d = corner(t, k) - anchor;
        p[k] = Vec2(d.dot(u) - so, d.dot(v) - to);
      }
      const int i0 = std::max(0, static_cast<int>(std::floor(std::min({p[0].x(), p[1].x(), p[2].x()}) / tu - 1.5)));
      const int i1 = std::min(chart.frame.width - 1, static_cast<int>(std::ceil(std::max({p[0].x(), p[1].x(), p[2].x()}) / tu + 1.5)));
      const int j0 = std::max(0, static_cast<int>(std::floor(std::min({p[0].y(), p[1].y(), p[2].y()}) / tv - 1.5)));
      const int j1 = std::min(chart.frame.height - 1, static_cast<int>(std::ceil(std::max({p[0].y(), p[1].y(), p[2].y()}) / tv + 1.5)));
      for (int j = j0; j <= j1; ++j) {
        for (int i = i0; i <= i1; ++i) {
          const Vec2 centre(i * tu, j * tv);
          const Vec3 w = nearest_barycentric(centre, p[0], p[1], p[2]);
          const double distance = (centre - (w[0] * p[0] + w[1] * p[1] + w[2] * p[2])).norm();
          TexelHit& hit = chart.texels[static_cast<std::size_t>(j) * static_cast<std::size_t>(chart.frame.width) + static_cast<std::size_t>(i)];
          if (distance <= reach && distance < hit.distance) hit = {distance, t, w};
        }
      }
    }
    for (const std::size_t t : r.triangles) layout.triangle_chart[t] = static_cast<std::int32_t>(charts.size());
    charts.push_back(std::move(chart));
  }

  // Shelves, tallest charts first, in an atlas about as wide as it is tall.
  std::vector<std::size_t> order(charts.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return charts[a].frame.height != charts[b].frame.height ? charts[a].frame.height > charts[b].frame.height
                                                            : charts[a].frame.width > charts[b].frame.width;
  });
  double total = 0.0;
  int widest = 1;
  for (const Chart& c : charts) {
    total += static_cast<double>(c.frame.width) * c.frame.height;
    widest = std::max(widest, c.frame.width);
  }
  const int width = std::min(kMaxAtlasSide, std::max(widest, static_cast<int>(std::ceil(std::sqrt(1.1 * total) / 64.0)) * 64));
  int x = 0, y = 0, shelf = 0;
  for (const std::size_t c : order) {
    bake_format::LightMapChart& f = charts[c].frame;
    if (x + f.width > width) {
      x = 0;
      y += shelf;
      shelf = 0;
    }
    f.x = x;
    f.y = y;
    x += f.width;
    shelf = std::max(shelf, f.height);
  }
  layout.width = charts.empty() ? 1 : width;
  layout.height = std::max(1, y + shelf);
  if (layout.height > kMaxAtlasSide) {
    throw InputError("--light-map: the model's flat regions need an atlas of " + std::to_string(layout.width) + "×" +
                     std::to_string(layout.height) + " texels of " + std::to_string(options.texel) + " m, more than " +
                     std::to_string(kMaxAtlasSide) + " along a side. Fix: give a larger texel or a larger --light-map-min-area");
  }

  // The texels a lookup reads, in atlas order, each at its region's point nearest its centre.
  struct Traced {
    std::uint32_t index;
    Eigen::Vector3f position, normal;
  };
  std::vector<Traced> traced;
  for (const Chart& chart : charts) {
    const bake_format::LightMapChart& f = chart.frame;
    for (int j = 0; j < f.height; ++j) {
      for (int i = 0; i < f.width; ++i) {
        const TexelHit& hit = chart.texels[static_cast<std::size_t>(j) * static_cast<std::size_t>(f.width) + static_cast<std::size_t>(i)];
        if (!std::isfinite(hit.distance)) continue;
        Vec3 point = Vec3::Zero();
        for (std::size_t k = 0; k < 3; ++k) point += hit.weights[static_cast<Eigen::Index>(k)] * corner(hit.triangle, k);
        const double texel = std::min(f.texel_u, f.texel_v);
        if (hit.distance > 1e-6 * texel) {  // not rounding inside a triangle
          // Off the region: its nearest point lies on an edge; a little into the triangle, so that
          // the point is on the face and not on the part the edge meets.
          const Vec3 centroid = (corner(hit.triangle, 0) + corner(hit.triangle, 1) + corner(hit.triangle, 2)) / 3.0;
          const double inward = (centroid - point).norm();
          if (inward > 0.0) point += std::min(0.05 * texel, 0.5 * inward) * (centroid - point) / inward;
        }
        traced.push_back({static_cast<std::uint32_t>((f.y + j) * layout.width + f.x + i), point.cast<float>(),
                          faces.normal[hit.triangle].cast<float>()});
      }
    }
  }
  std::sort(traced.begin(), traced.end(), [](const Traced& a, const Traced& b) { return a.index < b.index; });
  for (const Traced& t : traced) {
    layout.texels.push_back(t.index);
    out.positions.push_back(t.position);
    out.normals.push_back(t.normal);
  }
  for (Chart& c : charts) layout.charts.push_back(c.frame);
  return out;
}

void fill_unseen_texels(const bake_format::LightMapLayout& layout, std::size_t layers, std::vector<float>& values,
                        std::vector<float>* also, int rounds) {
  const std::size_t texels = layout.texels.size();
  const auto atlas = static_cast<std::size_t>(layout.width) * static_cast<std::size_t>(layout.height);
  // Per atlas texel: its traced texel (or none) and its chart.
  constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> traced_at(atlas, kNone);
  for (std::size_t k = 0; k < texels; ++k) traced_at[layout.texels[k]] = static_cast<std::uint32_t>(k);
  std::vector<std::uint32_t> chart_at(atlas, kNone);
  for (std::size_t c = 0; c < layout.charts.size(); ++c) {
    const bake_format::LightMapChart& f = layout.charts[c];
    for (int j = 0; j < f.height; ++j) {
      for (int i = 0; i < f.width; ++i) chart_at[static_cast<std::size_t>((f.y + j) * layout.width + f.x + i)] = static_cast<std::uint32_t>(c);
    }
  }
  const auto all_zero = [&](const std::vector<float>& a, std::size_t k) {
    return std::all_of(a.begin() + static_cast<std::ptrdiff_t>(k * layers), a.begin() + static_cast<std::ptrdiff_t>((k + 1) * layers),
                       [](float x) { return x == 0.0f; });
  };
  std::vector<char> seen(texels);
  for (std::size_t k = 0; k < texels; ++k) seen[k] = !(all_zero(values, k) && (also == nullptr || all_zero(*also, k)));
  for (int round = 0; round < rounds; ++round) {
    std::vector<std::size_t> filled;
    for (std::size_t k = 0; k < texels; ++k) {
      if (seen[k]) continue;
      const auto at = static_cast<int>(layout.texels[k]);
      const int row = at / layout.width, column = at % layout.width;
      std::vector<std::size_t> from;
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          const int r = row + dj, c = column + di;
          if ((di == 0 && dj == 0) || r < 0 || c < 0 || r >= layout.height || c >= layout.width) continue;
          const auto n = static_cast<std::size_t>(r * layout.width + c);
          if (chart_at[n] != chart_at[static_cast<std::size_t>(at)] || traced_at[n] == kNone || !seen[traced_at[n]]) continue;
          from.push_back(traced_at[n]);
        }
      }
      if (from.empty()) continue;
      for (std::vector<float>* a : {&values, also}) {
        if (a == nullptr) continue;
        for (std::size_t l = 0; l < layers; ++l) {
          float sum = 0.0f;
          for (const std::size_t f : from) sum += (*a)[f * layers + l];
          (*a)[k * layers + l] = sum / static_cast<float>(from.size());
        }
      }
      filled.push_back(k);
    }
    if (filled.empty()) break;
    for (const std::size_t k : filled) seen[k] = 1;
  }
}

}  // namespace skylit::baker
