// The ground's light: its irradiance per layer on a grid, and its transfer to the vertices.
#include "skylit/baker/ground_transfer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "skylit/baker/bake_job.hpp"

namespace skylit::baker {

std::vector<Vec3> ground_directions(int samples) {
  if (samples < 1) throw std::invalid_argument("ground_directions: at least one sample");
  const double golden_angle = std::numbers::pi * (3.0 - std::sqrt(5.0));
  std::vector<Vec3> out;
  out.reserve(static_cast<std::size_t>(samples));
  for (int k = 0; k < samples; ++k) {
    const double z = -(k + 0.5) / samples;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden_angle * k;
    out.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return out;
}

double unoccluded_ground_transfer(const Vec3& normal) {
  return 0.5 * std::numbers::pi * (1.0 - std::clamp(normal.z(), -1.0, 1.0));
}

void GroundGrid::add_at(double x, double y, double weight, std::span<double> out) const {
  const std::size_t n = layers();
  const Vec3 d = Vec3(x, y, 0.0) - plane.origin;
  // Texel centres at (col + ½) / W: the position in texel units, from the first centre.
  const double u = d.x() / plane.u.x() * plane.width - 0.5, v = d.y() / plane.v.y() * plane.height - 0.5;
  const double fu = std::floor(u), fv = std::floor(v);
  const double tu = u - fu, tv = v - fv;
  // The four texels around the point; one the model stands on (covered: no layer lights it) does
  // not lend its darkness to a point the vertex sees, which lies beside the model, not under it.
  std::array<const float*, 4> texel{};
  std::array<double, 4> share{};
  double total = 0.0;
  for (int k = 0; k < 4; ++k) {
    const int col = static_cast<int>(fu) + (k & 1), row = static_cast<int>(fv) + (k >> 1);
    const double w = ((k & 1) ? tu : 1.0 - tu) * ((k >> 1) ? tv : 1.0 - tv);
    if (w == 0.0) continue;
    if (col >= 0 && col < plane.width && row >= 0 && row < plane.height) {
      const std::size_t index = static_cast<std::size_t>(row) * static_cast<std::size_t>(plane.width) + static_cast<std::size_t>(col);
      if (covered[index]) continue;
      texel[static_cast<std::size_t>(k)] = irradiance.data() + index * n;
    }
    share[static_cast<std::size_t>(k)] = w;
    total += w;
  }
  if (!(total > 0.0)) return;  // all four covered: ground enclosed by the model
  for (std::size_t k = 0; k < 4; ++k) {
    if (share[k] == 0.0) continue;
    const double w = weight * share[k] / total;
    const float* b = texel[k];
    if (b == nullptr) {
      for (std::size_t l = 0; l < n; ++l) out[l] += w * unoccluded[l];  // past the grid: unshadowed
    } else {
      for (std::size_t l = 0; l < n; ++l) out[l] += w * b[l];
    }
  }
}

GroundGrid bake_ground_grid(const scene::Mesh& mesh, const geom::Dome& dome, geom::DomeBasis basis, int samples,
                            double spacing, int max_side, const RaytraceOptions& options) {
  if (!(spacing > 0.0) || max_side < 1) throw std::invalid_argument("bake_ground_grid: spacing > 0 and max_side >= 1");
  Eigen::Vector3f low = Eigen::Vector3f::Constant(0.0f), high = Eigen::Vector3f::Constant(0.0f);
  if (!mesh.positions.empty()) {
    low = high = mesh.positions.front();
    for (const Eigen::Vector3f& p : mesh.positions) {
      low = low.cwiseMin(p);
      high = high.cwiseMax(p);
    }
  }
  const double margin = 2.0 * std::max(0.0f, high.z()) + spacing;
  const double x0 = low.x() - margin, y0 = low.y() - margin;
  const double width_m = high.x() - low.x() + 2.0 * margin, height_m = high.y() - low.y() + 2.0 * margin;
  const double step = std::max(spacing, std::max(width_m, height_m) / max_side);
  GroundGrid grid;
  grid.plane.name = "ground_grid";
  grid.plane.width = std::max(1, static_cast<int>(std::ceil(width_m / step)));
  grid.plane.height = std::max(1, static_cast<int>(std::ceil(height_m / step)));
  grid.plane.origin = Vec3(x0, y0, 0.0);
  grid.plane.u = Vec3(grid.plane.width * step, 0.0, 0.0);
  grid.plane.v = Vec3(0.0, grid.plane.height * step, 0.0);

  const int per_face = geom::layers_per_face(basis);
  const std::size_t layers = static_cast<std::size_t>(dome.face_count() * per_face);
  const std::vector<geom::FaceQuadrature> quadratures = face_quadratures(dome, basis);
  grid.unoccluded = layer_cosine_integrals(dome, basis, quadratures, Vec3::UnitZ());
  const std::size_t texels = static_cast<std::size_t>(grid.plane.width) * static_cast<std::size_t>(grid.plane.height);
  grid.irradiance.assign(texels * layers, 0.0f);

  const std::vector<geom::Plane> planes{grid.plane};
  const std::unique_ptr<VisibilityEngine> engine = make_raytrace_engine(mesh, planes, options);
  const geom::CornerWeights corner_weights(dome);
  std::vector<float> fractions(kEngineLayers * texels);
  for (int i = 0; i < dome.face_count(); ++i) {
    trace_face(*engine, dome, corner_weights, basis, i, samples, [&](std::size_t first, std::size_t count) {
      engine->plane_fractions(0, std::span<float>(fractions.data(), count * texels));
      for (std::size_t k = 0; k < count; ++k) {
        const std::size_t l = static_cast<std::size_t>(i * per_face) + first + k;
        for (std::size_t t = 0; t < texels; ++t) {
          grid.irradiance[t * layers + l] = static_cast<float>(grid.unoccluded[l] * fractions[k * texels + t]);
        }
      }
    });
  }
  grid.covered.assign(texels, 0);
  for (std::size_t t = 0; t < texels; ++t) {
    const float* b = grid.irradiance.data() + t * layers;
    grid.covered[t] = std::all_of(b, b + layers, [](float x) { return x == 0.0f; }) ? 1 : 0;
  }
  return grid;
}

std::vector<float> ground_transfer(const scene::Mesh& mesh, std::span<const geom::Plane> planes, const GroundGrid& grid,
                                   int ground_samples, const RaytraceOptions& options) {
  const std::vector<Vec3> directions = ground_directions(ground_samples);
  const std::size_t layers = grid.layers();
  std::vector<double> sums(mesh.vertex_count() * layers, 0.0);
  ground_hits(mesh, planes, directions,
              [&](std::size_t vertex, std::size_t, double cosine, double x, double y) {
                grid.add_at(x, y, cosine, std::span<double>(sums.data() + vertex * layers, layers));
              },
              options);
  std::vector<float> out(sums.size(), 0.0f);
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const Vec3 n = mesh.normals[v].cast<double>();
    double facing = 0.0;
    for (const Vec3& d : directions) facing += std::max(0.0, n.dot(d));
    // No sample in front of a normal that looks almost straight up: its sliver of ground is left out.
    if (!(facing > 0.0)) continue;
    const double scale = unoccluded_ground_transfer(n) / facing / std::numbers::pi;
    for (std::size_t l = 0; l < layers; ++l) out[v * layers + l] = static_cast<float>(scale * sums[v * layers + l]);
  }
  return out;
}

}  // namespace skylit::baker
