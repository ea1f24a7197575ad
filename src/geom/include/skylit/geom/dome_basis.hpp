#pragma once
// The radiance basis over the dome: how the sky's radiance L(ω) is represented face by face.
#include <array>
#include <optional>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "skylit/geom/dome.hpp"

namespace skylit::geom {

// The bases:
//
//   faces    one constant per face (the paper's): L ≈ Σ_f S_f 1_f(ω)            1 layer per face
//   corners  discontinuous piecewise linear: per face f three hats λ_{f,k}(ω), the barycentric
//            coordinates of ω in the flat triangle of the face's vertices (gnomonic: taken where
//            the ray meets that triangle), zero outside the face: L ≈ Σ_{f,k} S_{f,k} λ_{f,k}(ω)
//                                                                                3 layers per face
//   quadratics  discontinuous piecewise quadratic: per face the six quadratic Bernstein
//            polynomials of the same barycentric coordinates, λ_k² (k = 0..2, at the vertices)
//            and 2λ_kλ_l (edges 01, 12, 20): each ≥ 0, together summing to 1     6 layers per face
//
// Layer 3f + k of a corners bake belongs to face f and its vertex k (DomeFace::vertex[k]); layer
// 6f + k of a quadratics bake to face f and function k of quadratic_values. On a
// face edge a direction has weight only on that edge's two vertices; Σ_k λ_{f,k} = 1 inside
// face f, so a constant sky is reproduced exactly by either basis, and a sky that is linear on a
// face's flat triangle (L = a + b·p, p where the ray meets the triangle) by the corners. A sky
// linear in the unit direction (a + b·ω) is not quite: p = ω/(s·ω) bends by up to 1 − cos of
// the face's radius (the fit misses the vertex values by up to 5% of |b| at ν = 2, 1.3% at ν = 4).
enum class DomeBasis { Faces, Corners, Quadratics };

std::string_view basis_name(DomeBasis basis);                   // "faces" | "corners" | "quadratics"
std::optional<DomeBasis> parse_basis(std::string_view name);    // nullopt for anything else
int layers_per_face(DomeBasis basis);                           // 1 | 3 | 6
inline constexpr int kMaxLayersPerFace = 6;
inline constexpr std::string_view kBasisNames = "'faces', 'corners' or 'quadratics'";

// The values of one face's layer functions at barycentric coordinates λ (Σ λ = 1), in layer
// order; layers_per_face(basis) of them are used, the rest are 0. Faces: 1; corners: λ;
// quadratics: λ0², λ1², λ2², 2λ0λ1, 2λ1λ2, 2λ2λ0.
using LayerValues = std::array<double, kMaxLayersPerFace>;
LayerValues layer_values(DomeBasis basis, const std::array<double, 3>& lambda);

// A linear function with vertex values c_k, written in the quadratic Bernstein basis: c_k at the
// vertices, (c_k + c_l)/2 on the edges. corner_to_quadratic (6×3) maps c to those coefficients;
// quadratic_to_corner (3×6) is the hats in the quadratic functions (λ_k = λ_k² + λ_kλ_l + λ_kλ_m),
// so that a corners mass matrix is P M Pᵀ of the quadratics one, over the same directions.
Eigen::Matrix<double, 6, 3> corner_to_quadratic();
Eigen::Matrix<double, 3, 6> quadratic_to_corner();

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
// (Σ weights = Ω_f to rounding), its hats the node's barycentric coordinates and its values
// those of the basis' layer functions there.
struct FaceQuadrature {
  DomeBasis basis = DomeBasis::Corners;
  int layers = 3;  // layers_per_face(basis)
  std::vector<Vec3> directions;
  std::vector<double> weights;
  std::vector<std::array<double, 3>> hats;
  std::vector<LayerValues> values;
  // ∫ φ_k ω dω over the face, per layer k (from the nodes): A_k(n) = n·moment[k] when the whole
  // face lies in front of n.
  std::vector<Vec3> moment;
  // ∫ φ_k φ_l dω over the face: the basis' mass matrix on a fully seen face (layers × layers).
  Eigen::MatrixXd mass;
};

inline constexpr int kDefaultQuadratureSubdivisions = 32;  // 1024 nodes per face

FaceQuadrature face_quadrature(const Dome& dome, int face, int subdivisions = kDefaultQuadratureSubdivisions,
                               DomeBasis basis = DomeBasis::Corners);

// A_{f,k}(n) = ∫_f φ_{f,k}(ω) max(0, n·ω) dω for each layer k of the quadrature's basis. The
// exact cosine integral of the face (Lambert) is split between the layers in the proportions the
// quadrature gives, so that Σ_k A_{f,k} equals the faces basis' A_f exactly (to rounding); each
// share carries the quadrature's error (at most 2.5e-5·Ω_f at m = 32 on the ν = 2 dome for the
// corners, measured against m = 256; docs/method.md). A face wholly in front of n costs one dot
// product per layer, one the horizon of n cuts one pass over the nodes.
std::vector<double> layer_cosine_integrals(const Dome& dome, int face, const FaceQuadrature& quadrature,
                                           const Vec3& n);

}  // namespace skylit::geom
