#include "skylit/geom/spherical.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <stdexcept>

namespace skylit::geom {
namespace {

double clamp_unit(double x) { return std::clamp(x, -1.0, 1.0); }

// Interior angle of the spherical triangle at `at`, between the arcs towards `to1` and `to2`.
double vertex_angle(const Vec3& at, const Vec3& to1, const Vec3& to2) {
  const Vec3 tangent1 = to1 - to1.dot(at) * at;
  const Vec3 tangent2 = to2 - to2.dot(at) * at;
  return std::atan2(tangent1.cross(tangent2).norm(), tangent1.dot(tangent2));
}

// Unit vector along the part of `v` orthogonal to the unit vector `axis`.
Vec3 orthogonal_direction(const Vec3& v, const Vec3& axis) {
  return (v - v.dot(axis) * axis).normalized();
}

// [0,1) from the top 53 bits: the same on every standard library (unlike the distributions).
double unit_double(std::mt19937_64& generator) {
  return static_cast<double>(generator() >> 11) * 0x1.0p-53;
}

}  // namespace

double solid_angle(const SphericalTriangle& t) {
  // Van Oosterom & Strackee (1983): tan(Ω/2) = [a b c] / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|).
  const double la = t.a.norm(), lb = t.b.norm(), lc = t.c.norm();
  const double numerator = t.a.dot(t.b.cross(t.c));
  const double denominator =
      la * lb * lc + t.a.dot(t.b) * lc + t.a.dot(t.c) * lb + t.b.dot(t.c) * la;
  return 2.0 * std::atan2(numerator, denominator);
}

Vec3 sample_uniform(const SphericalTriangle& t, double u1, double u2) {
  // Arvo, "Stratified sampling of spherical triangles", SIGGRAPH 1995, figure 2.
  const Vec3& A = t.a;
  const Vec3& B = t.b;
  const Vec3& C = t.c;
  const double alpha = vertex_angle(A, B, C);
  const double area = solid_angle(t);
  const double sub_area = u1 * area;  // area of the sub-triangle A B Ĉ
  const double s = std::sin(sub_area - alpha);
  const double c = std::cos(sub_area - alpha);
  const double cos_alpha = std::cos(alpha);
  const double sin_alpha = std::sin(alpha);
  const double u = c - cos_alpha;
  const double v = s + sin_alpha * A.dot(B);  // A·B = cos of the arc length AB
  const double q = clamp_unit(((v * c - u * s) * cos_alpha - v) / ((v * s + u * c) * sin_alpha));
  const Vec3 c_hat = q * A + std::sqrt(std::max(0.0, 1.0 - q * q)) * orthogonal_direction(C, A);
  const double z = clamp_unit(1.0 - u2 * (1.0 - c_hat.dot(B)));
  return z * B + std::sqrt(std::max(0.0, 1.0 - z * z)) * orthogonal_direction(c_hat, B);
}

std::vector<Vec3> stratified_samples(const SphericalTriangle& t, int count, std::uint64_t seed) {
  if (count < 1) throw std::invalid_argument("stratified_samples: count must be at least 1");
  int rows = 1;
  for (int r = 1; r * r <= count; ++r) {
    if (count % r == 0) rows = r;
  }
  const int cols = count / rows;
  std::mt19937_64 generator(seed);
  std::vector<Vec3> samples;
  samples.reserve(static_cast<std::size_t>(count));
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double u1 = (r + unit_double(generator)) / rows;
      const double u2 = (c + unit_double(generator)) / cols;
      samples.push_back(sample_uniform(t, u1, u2));
    }
  }
  return samples;
}

double cosine_integral(const SphericalTriangle& t, const Vec3& n) {
  const std::array<Vec3, 3> polygon{t.a, t.b, t.c};
  return cosine_integral(std::span<const Vec3>(polygon), n);
}

double cosine_integral(std::span<const Vec3> polygon, const Vec3& n) {
  if (polygon.size() < 3 || n.squaredNorm() == 0.0) return 0.0;
  // Sutherland–Hodgman against the plane n·x = 0, keeping n·x ≥ 0. Edges are great arcs; an
  // arc crosses the plane where the chord does, so the crossing is the normalized chord point.
  std::vector<Vec3> clipped;
  clipped.reserve(polygon.size() + 2);
  bool any_inside = false;
  for (std::size_t k = 0; k < polygon.size(); ++k) {
    const Vec3& from = polygon[(k + polygon.size() - 1) % polygon.size()];
    const Vec3& to = polygon[k];
    const double d_from = n.dot(from);
    const double d_to = n.dot(to);
    const bool from_inside = d_from >= 0.0;
    const bool to_inside = d_to >= 0.0;
    if (from_inside != to_inside) {
      clipped.push_back(((d_from * to - d_to * from) / (d_from - d_to)).normalized());
    }
    if (to_inside) clipped.push_back(to);
    // A convex polygon with no vertex strictly in front lies behind (or on) the plane: exactly 0.
    any_inside = any_inside || d_to > 0.0;
  }
  if (!any_inside || clipped.size() < 3) return 0.0;
  // Lambert: ½ Σ_e θ_e (n · ĝ_e), ĝ_e the unit normal of the edge's great circle (inwards for a
  // counter-clockwise polygon). θ_e from atan2 stays accurate for tiny edges.
  double sum = 0.0;
  for (std::size_t k = 0; k < clipped.size(); ++k) {
    const Vec3& from = clipped[k];
    const Vec3& to = clipped[(k + 1) % clipped.size()];
    const Vec3 normal = from.cross(to);
    const double sine = normal.norm();
    if (sine == 0.0) continue;  // repeated vertex: a zero-length edge adds nothing
    const double theta = std::atan2(sine, from.dot(to));
    sum += theta * n.dot(normal) / sine;
  }
  return std::max(0.0, 0.5 * sum);
}

}  // namespace skylit::geom
