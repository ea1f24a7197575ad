// Least-squares vertex values (vertex_fit.hpp): one sparse normal matrix for every layer.
#include "skylit/baker/vertex_fit.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

namespace skylit::baker {

FitPoints fit_points(const scene::Mesh& mesh, int n) {
  if (n < 1) throw std::invalid_argument("fit_points: n must be at least 1, got " + std::to_string(n));
  FitPoints points;
  const std::size_t per_triangle = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  points.positions.reserve(mesh.triangle_count() * per_triangle);
  const double step = 1.0 / n;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const std::array<std::uint32_t, 3> c{mesh.indices[3 * t], mesh.indices[3 * t + 1], mesh.indices[3 * t + 2]};
    const Eigen::Vector3f &p0 = mesh.positions[c[0]], &p1 = mesh.positions[c[1]], &p2 = mesh.positions[c[2]];
    const double area = 0.5 * static_cast<double>((p1 - p0).cross(p2 - p0).norm());
    const auto add = [&](double b1, double b2) {  // barycentric of corners 1 and 2
      const std::array<double, 3> w{1.0 - b1 - b2, b1, b2};
      Eigen::Vector3f position = Eigen::Vector3f::Zero(), normal = Eigen::Vector3f::Zero();
      for (int k = 0; k < 3; ++k) {
        position += static_cast<float>(w[static_cast<std::size_t>(k)]) * mesh.positions[c[static_cast<std::size_t>(k)]];
        normal += static_cast<float>(w[static_cast<std::size_t>(k)]) * mesh.normals[c[static_cast<std::size_t>(k)]];
      }
      const float length = normal.norm();
      points.positions.push_back(position);
      points.normals.push_back(length > 0 ? Eigen::Vector3f(normal / length) : mesh.normals[c[0]]);
      points.corners.push_back(c);
      points.weights.push_back(w);
      points.areas.push_back(area / static_cast<double>(per_triangle));
    };
    // The sub-triangles of cell (i, j): the upright one (i, j), (i+1, j), (i, j+1), and below the
    // diagonal the inverted one (i+1, j), (i+1, j+1), (i, j+1); their centroids.
    for (int i = 0; i < n; ++i) {
      for (int j = 0; i + j < n; ++j) {
        add((i + 1.0 / 3.0) * step, (j + 1.0 / 3.0) * step);
        if (i + j + 1 < n) add((i + 2.0 / 3.0) * step, (j + 2.0 / 3.0) * step);
      }
    }
  }
  return points;
}

scene::Mesh with_points(const scene::Mesh& mesh, std::span<const Eigen::Vector3f> positions,
                        std::span<const Eigen::Vector3f> normals) {
  scene::Mesh out = mesh;
  out.positions.insert(out.positions.end(), positions.begin(), positions.end());
  out.normals.insert(out.normals.end(), normals.begin(), normals.end());
  out.texcoords.clear();
  return out;
}

std::vector<float> fit_vertex_values(const scene::Mesh& mesh, const FitPoints& points, std::span<const float> traced,
                                     std::size_t layers, std::span<const float> upper, const VertexFitOptions& options) {
  const std::size_t vertices = mesh.vertex_count(), count = points.positions.size();
  if (layers == 0 || traced.size() != (vertices + count) * layers || (!upper.empty() && upper.size() != vertices * layers) ||
      points.corners.size() != count || points.weights.size() != count || points.areas.size() != count) {
    throw std::invalid_argument("fit_vertex_values: " + std::to_string(traced.size()) + " traced values for " +
                                std::to_string(vertices) + " vertices and " + std::to_string(count) + " points of " +
                                std::to_string(layers) + " layers");
  }
  if (!(options.mu > 0.0)) throw std::invalid_argument("fit_vertex_values: mu must be > 0");
  // m_v: a third of the area of the vertex's triangles (a vertex no triangle uses gets a small
  // weight, which keeps it at its own value).
  std::vector<double> vertex_area(vertices, 0.0);
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Eigen::Vector3f &p0 = mesh.positions[mesh.indices[3 * t]], &p1 = mesh.positions[mesh.indices[3 * t + 1]],
                          &p2 = mesh.positions[mesh.indices[3 * t + 2]];
    const double third = static_cast<double>((p1 - p0).cross(p2 - p0).norm()) / 6.0;
    for (int k = 0; k < 3; ++k) vertex_area[mesh.indices[3 * t + static_cast<std::size_t>(k)]] += third;
  }
  double largest = 0;
  for (double a : vertex_area) largest = std::max(largest, a);
  const double floor = std::max(1e-12, 1e-9 * largest);

  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(vertices + 9 * count);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(vertices), static_cast<Eigen::Index>(layers));
  for (std::size_t v = 0; v < vertices; ++v) {
    const double m = options.mu * std::max(vertex_area[v], floor);
    entries.emplace_back(static_cast<int>(v), static_cast<int>(v), m);
    for (std::size_t l = 0; l < layers; ++l) rhs(static_cast<Eigen::Index>(v), static_cast<Eigen::Index>(l)) += m * traced[v * layers + l];
  }
  for (std::size_t p = 0; p < count; ++p) {
    const float* f = traced.data() + (vertices + p) * layers;
    if (std::all_of(f, f + layers, [](float x) { return x == 0.0f; })) continue;
    const double a = points.areas[p];
    for (int i = 0; i < 3; ++i) {
      const auto vi = points.corners[p][static_cast<std::size_t>(i)];
      const double bi = points.weights[p][static_cast<std::size_t>(i)];
      for (int j = 0; j < 3; ++j) {
        entries.emplace_back(static_cast<int>(vi), static_cast<int>(points.corners[p][static_cast<std::size_t>(j)]),
                             a * bi * points.weights[p][static_cast<std::size_t>(j)]);
      }
      for (std::size_t l = 0; l < layers; ++l) rhs(static_cast<Eigen::Index>(vi), static_cast<Eigen::Index>(l)) += a * bi * f[l];
    }
  }
  Eigen::SparseMatrix<double> normal(static_cast<Eigen::Index>(vertices), static_cast<Eigen::Index>(vertices));
  normal.setFromTriplets(entries.begin(), entries.end());
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(normal);
  if (solver.info() != Eigen::Success) throw std::runtime_error("fit_vertex_values: the normal matrix did not factorise");
  const Eigen::MatrixXd x = solver.solve(rhs);

  std::vector<float> out(vertices * layers);
  for (std::size_t v = 0; v < vertices; ++v) {
    for (std::size_t l = 0; l < layers; ++l) {
      double value = std::max(0.0, x(static_cast<Eigen::Index>(v), static_cast<Eigen::Index>(l)));
      if (!upper.empty()) value = std::min(value, static_cast<double>(upper[v * layers + l]));
      out[v * layers + l] = static_cast<float>(value);
    }
  }
  return out;
}

}  // namespace skylit::baker
