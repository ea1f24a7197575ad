#pragma once
// The class-I geodesic dome over the upper hemisphere (site frame, z up).
#include <array>
#include <vector>

#include "skylit/geom/spherical.hpp"

namespace skylit::geom {

// A face is the spherical triangle spanned by its three vertices (great-arc edges).
struct DomeFace {
  std::array<int, 3> vertex;     // into Dome::vertices(), counter-clockwise seen from outside
  Vec3 centre;                   // unit direction of the vertex mean
  double solid_angle;            // steradians, exact (spherical excess)
  // Face across edge (vertex[0],vertex[1]), (vertex[1],vertex[2]), (vertex[2],vertex[0]);
  // -1 across the horizon.
  std::array<int, 3> neighbour;
};

// An icosahedron with a vertex at the zenith; every face is cut into ν² triangles and the grid
// points are projected onto the unit sphere. For even ν the horizon lies on edges, so the upper
// hemisphere holds exactly 10ν² faces (ν=2 → 40, 4 → 160, 6 → 360, 8 → 640).
class Dome {
 public:
  // Throws std::invalid_argument unless frequency is even and ≥ 2 (and ≤ 64).
  explicit Dome(int frequency);

  int frequency() const { return frequency_; }
  int face_count() const { return static_cast<int>(faces_.size()); }
  const std::vector<Vec3>& vertices() const { return vertices_; }
  const std::vector<DomeFace>& faces() const { return faces_; }
  const DomeFace& face(int i) const { return faces_.at(static_cast<std::size_t>(i)); }
  SphericalTriangle triangle(int i) const;

  // The one face that contains `direction` (need not be unit length). Every direction with
  // z ≥ 0 lands in exactly one face, edges, vertices and the horizon included (ties are broken
  // the same way every time). Returns -1 for z < 0, a zero vector or a non-finite one.
  int face_of(const Vec3& direction) const;

 private:
  int frequency_;
  std::vector<Vec3> vertices_;
  std::vector<DomeFace> faces_;
  // Lookup: a direction's ray hits one flat icosahedron face (the one maximizing d·normal, by
  // convexity), and the dome faces are the radial projections of that face's ν² flat grid
  // triangles, so the barycentric coordinates of the hit point name the cell directly.
  struct IcoFace {
    Vec3 normal;                         // outward unit normal of the flat icosahedron face
    std::array<Vec3, 3> opposite_edge;   // corner[k+1] × corner[k+2]: d·it ∝ barycentric k
    std::vector<int> cell_face;          // cell 2·(i·ν + j) + (0 up, 1 down) → dome face or -1
    std::vector<int> faces;              // dome faces inside it (upper hemisphere only)
  };
  std::vector<IcoFace> ico_faces_;
  std::vector<std::array<Vec3, 3>> edge_normal_;  // per dome face: inward unit normals of its edges
  // Rounding fallback at the horizon: the face of `ico` whose triangle holds `unit` most deeply.
  int most_inside_face(const IcoFace& ico, const Vec3& unit) const;
  SphericalTriangle triangle_of(const DomeFace& f) const;
};

}  // namespace skylit::geom
