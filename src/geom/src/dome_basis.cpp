#include "skylit/geom/dome_basis.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/LU>

namespace skylit::geom {
namespace {

std::array<Vec3, 3> face_vertices(const Dome& dome, int face) {
  const DomeFace& f = dome.face(face);
  std::array<Vec3, 3> v;
  for (std::size_t k = 0; k < 3; ++k) v[k] = dome.vertices()[static_cast<std::size_t>(f.vertex[k])].normalized();
  return v;
}

}  // namespace

std::string_view basis_name(DomeBasis basis) {
  switch (basis) {
    case DomeBasis::Corners: return "corners";
    case DomeBasis::Quadratics: return "quadratics";
    case DomeBasis::Faces: break;
  }
  return "faces";
}

std::optional<DomeBasis> parse_basis(std::string_view name) {
  if (name == "faces") return DomeBasis::Faces;
  if (name == "corners") return DomeBasis::Corners;
  if (name == "quadratics") return DomeBasis::Quadratics;
  return std::nullopt;
}

int layers_per_face(DomeBasis basis) {
  switch (basis) {
    case DomeBasis::Corners: return 3;
    case DomeBasis::Quadratics: return 6;
    case DomeBasis::Faces: break;
  }
  return 1;
}

LayerValues layer_values(DomeBasis basis, const std::array<double, 3>& l) {
  switch (basis) {
    case DomeBasis::Corners: return {l[0], l[1], l[2], 0.0, 0.0, 0.0};
    case DomeBasis::Quadratics:
      return {l[0] * l[0], l[1] * l[1], l[2] * l[2], 2.0 * l[0] * l[1], 2.0 * l[1] * l[2], 2.0 * l[2] * l[0]};
    case DomeBasis::Faces: break;
  }
  return {1.0, 0.0, 0.0, 0.0, 0.0, 0.0};
}

Eigen::Matrix<double, 6, 3> corner_to_quadratic() {
  Eigen::Matrix<double, 6, 3> m;
  m << 1, 0, 0,  //
      0, 1, 0,   //
      0, 0, 1,   //
      0.5, 0.5, 0,  //
      0, 0.5, 0.5,  //
      0.5, 0, 0.5;
  return m;
}

Eigen::Matrix<double, 3, 6> quadratic_to_corner() {
  Eigen::Matrix<double, 3, 6> m;
  m << 1, 0, 0, 0.5, 0, 0.5,  //
      0, 1, 0, 0.5, 0.5, 0,   //
      0, 0, 1, 0, 0.5, 0.5;
  return m;
}

CornerWeights::CornerWeights(const Dome& dome) {
  inverse_.reserve(static_cast<std::size_t>(dome.face_count()));
  for (int f = 0; f < dome.face_count(); ++f) {
    const std::array<Vec3, 3> v = face_vertices(dome, f);
    Eigen::Matrix3d m;
    for (int k = 0; k < 3; ++k) m.col(k) = v[static_cast<std::size_t>(k)];
    inverse_.push_back(m.inverse());  // the vertices of a face are never coplanar with the origin
  }
}

std::array<double, 3> CornerWeights::operator()(int face, const Vec3& direction) const {
  // M⁻¹ d are the coefficients of d in the vertices; scaled to sum 1 they are the barycentric
  // coordinates of the point where the ray meets the flat triangle.
  const Eigen::Vector3d l = inverse_.at(static_cast<std::size_t>(face)) * direction;
  std::array<double, 3> w{std::max(0.0, l[0]), std::max(0.0, l[1]), std::max(0.0, l[2])};
  const double sum = w[0] + w[1] + w[2];
  if (!(sum > 0.0)) return {1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0};  // not a direction of this face at all
  for (double& x : w) x /= sum;
  return w;
}

FaceQuadrature face_quadrature(const Dome& dome, int face, int subdivisions, DomeBasis basis) {
  if (subdivisions < 1) throw std::invalid_argument("face_quadrature: subdivisions must be at least 1");
  const std::array<Vec3, 3> v = face_vertices(dome, face);
  const int m = subdivisions;
  FaceQuadrature q;
  q.basis = basis;
  q.layers = layers_per_face(basis);
  const auto layers = static_cast<std::size_t>(q.layers);
  q.directions.reserve(static_cast<std::size_t>(m * m));
  q.weights.reserve(static_cast<std::size_t>(m * m));
  q.hats.reserve(static_cast<std::size_t>(m * m));
  q.values.reserve(static_cast<std::size_t>(m * m));
  q.moment.assign(layers, Vec3::Zero());
  q.mass = Eigen::MatrixXd::Zero(q.layers, q.layers);
  // Grid point (i, j) of the flat triangle: barycentric (m − i − j, i, j) / m.
  const auto bary = [m](double i, double j) { return Eigen::Vector3d((m - i - j) / m, i / m, j / m); };
  const auto point = [&](const Eigen::Vector3d& b) { return Vec3(b[0] * v[0] + b[1] * v[1] + b[2] * v[2]); };
  const auto add = [&](const std::array<Eigen::Vector3d, 3>& corners) {
    const SphericalTriangle t{point(corners[0]).normalized(), point(corners[1]).normalized(),
                              point(corners[2]).normalized()};
    const Eigen::Vector3d centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
    const Vec3 d = point(centroid).normalized();
    const double w = solid_angle(t);
    const std::array<double, 3> hat{centroid[0], centroid[1], centroid[2]};
    q.directions.push_back(d);
    q.weights.push_back(w);
    q.hats.push_back(hat);
    const LayerValues phi = layer_values(basis, hat);
    q.values.push_back(phi);
    for (std::size_t k = 0; k < layers; ++k) {
      q.moment[k] += w * phi[k] * d;
      for (std::size_t l = 0; l < layers; ++l) {
        q.mass(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(l)) += w * phi[k] * phi[l];
      }
    }
  };
  for (int i = 0; i < m; ++i) {
    for (int j = 0; i + j < m; ++j) {
      add({bary(i, j), bary(i + 1, j), bary(i, j + 1)});
      if (i + j + 2 <= m) add({bary(i + 1, j), bary(i + 1, j + 1), bary(i, j + 1)});
    }
  }
  return q;
}

std::vector<double> layer_cosine_integrals(const Dome& dome, int face, const FaceQuadrature& quadrature,
                                           const Vec3& n) {
  const auto layers = static_cast<std::size_t>(quadrature.layers);
  if (quadrature.moment.size() != layers || quadrature.values.size() != quadrature.directions.size()) {
    throw std::invalid_argument("layer_cosine_integrals: the quadrature is incomplete");
  }
  const double exact = cosine_integral(dome.triangle(face), n);
  std::vector<double> share(layers, 0.0);
  if (exact <= 0.0) return share;
  const std::array<Vec3, 3> v = face_vertices(dome, face);
  if (n.dot(v[0]) >= 0.0 && n.dot(v[1]) >= 0.0 && n.dot(v[2]) >= 0.0) {
    // In front of n everywhere (the face is convex): the cosine is linear, no clipping.
    for (std::size_t k = 0; k < layers; ++k) share[k] = std::max(0.0, n.dot(quadrature.moment[k]));
  } else {
    for (std::size_t q = 0; q < quadrature.directions.size(); ++q) {
      const double c = n.dot(quadrature.directions[q]);
      if (c <= 0.0) continue;
      const double wc = quadrature.weights[q] * c;
      for (std::size_t k = 0; k < layers; ++k) share[k] += wc * quadrature.values[q][k];
    }
  }
  double total = 0.0;
  for (const double x : share) total += x;
  // A sliver in front of n that no node reaches: the layers share it evenly.
  if (!(total > 0.0)) {
    share.assign(layers, exact / static_cast<double>(layers));
    return share;
  }
  for (double& x : share) x *= exact / total;
  return share;
}

}  // namespace skylit::geom
