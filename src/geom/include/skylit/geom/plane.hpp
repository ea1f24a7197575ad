#pragma once
// A shadowing plane: a rectangle in the site frame with a texel grid on it.
#include <string>

#include "skylit/geom/spherical.hpp"

namespace skylit::geom {

struct Plane {
  std::string name;
  Vec3 origin = Vec3::Zero();  // one corner, metres, site frame
  Vec3 u = Vec3::Zero();       // edge vectors; columns run along u, rows along v
  Vec3 v = Vec3::Zero();
  int width = 0;               // texels along u
  int height = 0;              // texels along v

  Vec3 normal() const { return u.cross(v).normalized(); }
  double area() const { return u.cross(v).norm(); }
  // Centre of texel (col, row): origin + (col+0.5)/W·u + (row+0.5)/H·v.
  Vec3 texel_centre(int col, int row) const {
    return origin + ((col + 0.5) / width) * u + ((row + 0.5) / height) * v;
  }
};

// Where x lies against a plane: (s, t) in its rectangle's coordinates (x's projection is
// origin + s·u + t·v; inside for s, t in [0, 1]) and its signed distance along the normal.
struct PlanePoint {
  double s = 0, t = 0, distance = 0;
};
inline PlanePoint locate_on_plane(const Plane& p, const Vec3& x) {
  const Vec3 n = p.normal(), offset = x - p.origin;
  // The dual basis of (u, v) within the plane.
  const Vec3 s_axis = p.v.cross(n) / p.u.dot(p.v.cross(n)), t_axis = n.cross(p.u) / p.v.dot(n.cross(p.u));
  return {offset.dot(s_axis), offset.dot(t_axis), offset.dot(n)};
}

}  // namespace skylit::geom
