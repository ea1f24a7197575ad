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

}  // namespace skylit::geom
