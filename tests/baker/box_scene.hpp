#pragma once
// Shared by the engine tests: scenes of axis-aligned boxes, whose shadows are known exactly.
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <vector>

#include "skylit/scene/mesh.hpp"
#include "skylit/geom/spherical.hpp"

namespace skylit::baker::test {

using geom::Vec3;

struct Box {
  Vec3 min;
  Vec3 max;
};

// Appends a box as 12 outward counter-clockwise triangles. Each face has its own four vertices so
// that a vertex carries its face's normal.
inline void add_box(scene::Mesh& mesh, const Box& box) {
  const Vec3& a = box.min;
  const Vec3& b = box.max;
  struct Face {
    Vec3 normal;
    std::array<Vec3, 4> corners;  // counter-clockwise seen from outside
  };
  const std::array<Face, 6> faces{{
      {{1, 0, 0}, {{{b.x(), a.y(), a.z()}, {b.x(), b.y(), a.z()}, {b.x(), b.y(), b.z()}, {b.x(), a.y(), b.z()}}}},
      {{-1, 0, 0}, {{{a.x(), b.y(), a.z()}, {a.x(), a.y(), a.z()}, {a.x(), a.y(), b.z()}, {a.x(), b.y(), b.z()}}}},
      {{0, 1, 0}, {{{b.x(), b.y(), a.z()}, {a.x(), b.y(), a.z()}, {a.x(), b.y(), b.z()}, {b.x(), b.y(), b.z()}}}},
      {{0, -1, 0}, {{{a.x(), a.y(), a.z()}, {b.x(), a.y(), a.z()}, {b.x(), a.y(), b.z()}, {a.x(), a.y(), b.z()}}}},
      {{0, 0, 1}, {{{a.x(), a.y(), b.z()}, {b.x(), a.y(), b.z()}, {b.x(), b.y(), b.z()}, {a.x(), b.y(), b.z()}}}},
      {{0, 0, -1}, {{{a.x(), b.y(), a.z()}, {b.x(), b.y(), a.z()}, {b.x(), a.y(), a.z()}, {a.x(), a.y(), a.z()}}}},
  }};
  for (const Face& face : faces) {
    const auto first = static_cast<std::uint32_t>(mesh.positions.size());
    for (const Vec3& corner : face.corners) {
      mesh.positions.push_back(corner.cast<float>());
      mesh.normals.push_back(face.normal.cast<float>());
    }
    for (std::uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) mesh.indices.push_back(first + i);
    mesh.triangle_material.insert(mesh.triangle_material.end(), {0u, 0u});
  }
  if (mesh.materials.empty()) mesh.materials.push_back({});
}

inline scene::Mesh mesh_of(const std::vector<Box>& boxes) {
  scene::Mesh mesh;
  mesh.materials.push_back({});
  for (const Box& box : boxes) add_box(mesh, box);
  return mesh;
}

// A 2 × 2 × 3 m cube (no bottom) on a 12 m slab of two triangles whose corners see open sky, and
// a site with a ground plane over the slab, written into `dir`: the site file.
inline std::filesystem::path write_cube_on_slab_site(const std::filesystem::path& dir) {
  std::ofstream(dir / "slab.obj") << "v -6 -6 0\nv 6 -6 0\nv 6 6 0\nv -6 6 0\n"
                                     "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                                     "v -1 -1 3\nv 1 -1 3\nv 1 1 3\nv -1 1 3\n"
                                     "f 1 2 3 4\nf 5 6 10 9\nf 6 7 11 10\nf 7 8 12 11\nf 8 5 9 12\nf 9 10 11 12\n";
  std::ofstream(dir / "site.yaml") << "scene:\n  model: slab.obj\n  up: z\n  scale: 1\n"
                                      "dome:\n  frequency: 2\n"
                                      "planes:\n  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                      "    v: [0, 12, 0]\n    resolution: [8, 8]\n";
  return dir / "site.yaml";
}

// Unit direction at elevation/azimuth in degrees; azimuth from north (+y) towards east (+x).
inline Vec3 direction(double elevation_deg, double azimuth_deg) {
  const double el = elevation_deg * std::numbers::pi / 180.0;
  const double az = azimuth_deg * std::numbers::pi / 180.0;
  return {std::cos(el) * std::sin(az), std::cos(el) * std::cos(az), std::sin(el)};
}

}  // namespace skylit::baker::test
