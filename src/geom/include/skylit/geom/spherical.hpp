#pragma once
// Spherical triangles: solid angle, area-uniform sampling (Arvo) and the exact cosine-weighted
// integral (Lambert's polygon formula, after clipping to the normal's hemisphere).
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross(): used here and by everyone who includes this header

namespace skylit::geom {

using Vec3 = Eigen::Vector3d;

// Three unit vectors, counter-clockwise seen from outside the sphere ((a×b)·c > 0).
struct SphericalTriangle {
  Vec3 a, b, c;
};

// Exact solid angle in steradians (Van Oosterom–Strackee), stable for tiny triangles.
double solid_angle(const SphericalTriangle& t);

// Area-uniform point of the triangle for (u1, u2) in [0,1)² (Arvo 1995).
Vec3 sample_uniform(const SphericalTriangle& t, double u1, double u2);

// `count` area-uniform stratified directions: a jittered rows×cols grid in (u1, u2), rows×cols =
// count with rows the largest divisor of count not above its square root. Deterministic for a
// seed. count ≥ 1. Returned row by row (row r holds u1 in [r/rows, (r+1)/rows)).
std::vector<Vec3> stratified_samples(const SphericalTriangle& t, int count, std::uint64_t seed);

// ∫ max(0, n·ω) dω over the triangle, exactly: the triangle is clipped to the hemisphere n·ω ≥ 0
// and Lambert's formula ½ Σ_e θ_e (n·ĝ_e) is summed over the clipped polygon's edges.
// `n` need not be unit length (the result scales with |n|); zero n gives 0.
double cosine_integral(const SphericalTriangle& t, const Vec3& n);

// The same for a convex spherical polygon given counter-clockwise from outside.
double cosine_integral(std::span<const Vec3> polygon, const Vec3& n);

}  // namespace skylit::geom
