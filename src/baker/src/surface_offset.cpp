// The scene-scaled nudge shared by both visibility engines (see visibility.hpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "skylit/baker/visibility.hpp"

namespace skylit::baker {

namespace {

// Relative to the scene's bounding-box diagonal: far above float rounding of coordinates
// (~1e-7 relative) yet far below any geometric detail that matters for shadows.
constexpr double kRelativeOffset = 1e-4;
// A floor, so that a degenerate scene (one point, an empty mesh and a tiny plane) still moves
// its origins off the surface.
constexpr double kMinimumOffset = 1e-5;

}  // namespace

double surface_offset(const scene::Mesh& mesh, std::span<const geom::Plane> planes) {
  // Computed here rather than with Mesh::bounds_min/max so that planes join the same box.
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  auto include = [&](const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (const auto& position : mesh.positions) include(position.cast<double>());
  for (const geom::Plane& plane : planes) {
    const std::array<Vec3, 4> corners{plane.origin, plane.origin + plane.u, plane.origin + plane.v,
                                      plane.origin + plane.u + plane.v};
    for (const Vec3& corner : corners) include(corner);
  }
  if (!(lo.array() <= hi.array()).all()) return kMinimumOffset;  // nothing at all
  const double diagonal = (hi - lo).norm();
  // A non-finite coordinate makes the diagonal NaN/inf; the floor is the only safe answer.
  if (!std::isfinite(diagonal)) return kMinimumOffset;
  return std::max(kRelativeOffset * diagonal, kMinimumOffset);
}

}  // namespace skylit::baker
