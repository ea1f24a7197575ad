#pragma once
// The radiance basis over the dome: how the sky's radiance L(ω) is represented face by face.
//
//   faces    one constant per face (the paper's): L ≈ Σ_f S_f 1_f(ω)            1 layer per face
//   corners  discontinuous piecewise linear: per face f three hats λ_{f,k}(ω), the barycentric
//            coordinates of ω in the flat triangle of the face's vertices (gnomonic: taken where
//            the ray meets that triangle), zero outside the face: L ≈ Σ_{f,k} S_{f,k} λ_{f,k}(ω)
//                                                                                3 layers per face
//
// Layer 3f + k of a corners bake belongs to face f and its vertex k (DomeFace::vertex[k]). On a
// face edge a direction has weight only on that edge's two vertices; Σ_k λ_{f,k} = 1 inside
// face f, so a constant sky is reproduced exactly by either basis, and a sky that is linear on a
// face's flat triangle (L = a + b·p, p where the ray meets the triangle) by the corners. A sky
// linear in the unit direction (a + b·ω) is not quite: p = ω/(s·ω) bends by up to 1 − cos of
// the face's radius (the fit misses the vertex values by up to 5% of |b| at ν = 2, 1.3% at ν = 4).
#include <array>
#include <optional>
#include <string_view>
#include <vector>

#include "skylit/geom/dome.hpp"

namespace skylit::geom {

enum class DomeBasis { Faces, Corners };

std::string_view basis_name(DomeBasis basis);                   // "faces" | "corners"
std::optional<DomeBasis> parse_basis(std::string_view name);    // nullopt for anything else
int layers_per_face(DomeBasis basis);                           // 1 | 3

// Barycentric coordinates of directions in the flat triangles of a dome's faces: one 3×3 inverse
// per face, computed once.
class CornerWeights {
 public:
  explicit CornerWeights(const Dome& dome);
  // λ_{face,k}(direction) for k = 0, 1, 2: ≥ 0, summing to 1 (rounding outside the face is
  // clamped to the nearest edge). `direction` need not be unit length.
  std::array<double, 3> operator()(int face, const Vec3& direction) const;

 private:
  std::vector<Eigen::Matrix3d> inverse_;  // per face: [v0 v1 v2]⁻¹
};

// A dense, deterministic quadrature of one face: the face's flat triangle is cut into m² equal
// sub-triangles whose corners are projected onto the sphere; a node is the direction of a flat
// sub-triangle's centroid, its weight the exact solid angle of the spherical sub-triangle
// (Σ weights = Ω_f to rounding) and its hats the node's barycentric coordinates.
struct FaceQuadrature {
  std::vector<Vec3> directions;
  std::vector<double> weights;
  std::vector<std::array<double, 3>> hats;
  // ∫ λ_k ω dω over the face, per k (from the nodes): A_k(n) = n·moment[k] when the whole face
  // lies in front of n.
  std::array<Vec3, 3> moment;
  // ∫ λ_k λ_l dω over the face: the mass matrix of the corners basis on a fully seen face.
  Eigen::Matrix3d mass = Eigen::Matrix3d::Zero();
};

inline constexpr int kDefaultQuadratureSubdivisions = 32;  // 1024 nodes per face

FaceQuadrature face_quadrature(const Dome& dome, int face, int subdivisions = kDefaultQuadratureSubdivisions);

// A_{f,k}(n) = ∫_f λ_{f,k}(ω) max(0, n·ω) dω for k = 0..2. The exact cosine integral of the
// face (Lambert) is split between the corners in the proportions the quadrature gives, so that
// Σ_k A_{f,k} equals the faces basis' A_f exactly (to rounding); each share carries the
// quadrature's error (at most 2.5e-5·Ω_f at m = 32 on the ν = 2 dome, measured against m = 256;
// docs/method.md). A face wholly in front of n costs three dot products, one the horizon of n
// cuts one pass over the nodes.
std::array<double, 3> corner_cosine_integrals(const Dome& dome, int face, const FaceQuadrature& quadrature,
                                              const Vec3& n);

}  // namespace skylit::geom
