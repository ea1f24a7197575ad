#include "skylit/scene/sample_site.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <optional>
#include <tuple>

#include <Eigen/Geometry>

namespace skylit::scene {
namespace {

namespace fs = std::filesystem;
using geom::Vec3;

const fs::path kSourceDir = SKYLIT_SOURCE_DIR;
const fs::path kCommittedModel = kSourceDir / "data/models/gate.glb";
const fs::path kCommittedSite = kSourceDir / "config/sample_site.yaml";

Vec3 vertex(const Mesh& mesh, std::size_t t, int corner) {
  return mesh.positions[mesh.indices[3 * t + static_cast<std::size_t>(corner)]].cast<double>();
}

const geom::Plane& plane_named(const Site& site, const std::string& name) {
  const auto it = std::find_if(site.planes.begin(), site.planes.end(),
                               [&](const geom::Plane& p) { return p.name == name; });
  if (it == site.planes.end()) throw std::runtime_error("no plane " + name);
  return *it;
}

std::uint32_t material_named(const Mesh& mesh, const std::string& name) {
  for (std::size_t m = 0; m < mesh.materials.size(); ++m) {
    if (mesh.materials[m].name == name) return static_cast<std::uint32_t>(m);
  }
  throw std::runtime_error("no material " + name);
}

// Whether the triangle passes through the interior of the plane's rectangle (touching its edges,
// or lying within `eps` metres of its plane, does not count).
bool crosses_rectangle(const geom::Plane& plane, const Vec3& a, const Vec3& b, const Vec3& c) {
  constexpr double eps = 1e-6;
  const Vec3 n = plane.normal();
  const std::array<Vec3, 3> p = {a, b, c};
  std::array<double, 3> d{};
  for (int k = 0; k < 3; ++k) d[static_cast<std::size_t>(k)] = n.dot(p[static_cast<std::size_t>(k)] - plane.origin);
  if (*std::min_element(d.begin(), d.end()) > -eps || *std::max_element(d.begin(), d.end()) < eps) {
    return false;
  }
  // The segment where the triangle meets the plane, in rectangle coordinates (s, t) ∈ [0, 1]².
  Eigen::Matrix<double, 3, 2> basis;
  basis << plane.u, plane.v;
  std::vector<Eigen::Vector2d> ends;
  for (std::size_t k = 0; k < 3; ++k) {
    const std::size_t next = (k + 1) % 3;
    if ((d[k] < 0) != (d[next] < 0)) {
      const Vec3 x = p[k] + (p[next] - p[k]) * (d[k] / (d[k] - d[next]));
      ends.push_back(basis.colPivHouseholderQr().solve(x - plane.origin));
    }
  }
  if (ends.size() < 2) return false;
  // Liang–Barsky clip of the segment to the rectangle shrunk by a hair.
  const double lo = 1e-6, hi = 1.0 - 1e-6;
  double t0 = 0.0, t1 = 1.0;
  const Eigen::Vector2d delta = ends[1] - ends[0];
  for (int axis = 0; axis < 2; ++axis) {
    for (double bound : {lo, hi}) {
      const double start = ends[0][axis];
      const double q = bound == lo ? start - lo : hi - start;
      const double r = bound == lo ? -delta[axis] : delta[axis];
      if (r == 0.0) {
        if (q < 0.0) return false;
      } else {
        const double t = q / r;
        if (r < 0.0) {
          t0 = std::max(t0, t);
        } else {
          t1 = std::min(t1, t);
        }
      }
    }
  }
  return t0 < t1;
}

TEST(SampleGate, IsAClosedOutwardSolidOfAFewThousandTriangles) {
  const Mesh mesh = make_sample_gate();
  EXPECT_GT(mesh.triangle_count(), 1000u);
  EXPECT_LT(mesh.triangle_count(), 4000u);
  ASSERT_EQ(mesh.normals.size(), mesh.positions.size());
  ASSERT_EQ(mesh.triangle_material.size(), mesh.triangle_count());

  // Flat shading: each stored normal is its triangle's geometric normal (so winding and normal
  // agree), and the triangles are sorted by material (so the glTF round trip keeps the order).
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3 n = (vertex(mesh, t, 1) - vertex(mesh, t, 0))
                       .cross(vertex(mesh, t, 2) - vertex(mesh, t, 0))
                       .normalized();
    for (int c = 0; c < 3; ++c) {
      const Vec3 stored = mesh.normals[mesh.indices[3 * t + static_cast<std::size_t>(c)]].cast<double>();
      ASSERT_LT((stored - n).norm(), 1e-5) << "triangle " << t;
    }
    if (t > 0) {
      ASSERT_LE(mesh.triangle_material[t - 1], mesh.triangle_material[t]);
    }
  }

  // Closed: every directed edge is matched by its reverse (positions quantised to 0.1 mm).
  using Key = std::array<long long, 6>;
  auto quantised = [](const Vec3& p) {
    return std::array<long long, 3>{std::llround(p.x() * 1e4), std::llround(p.y() * 1e4),
                                    std::llround(p.z() * 1e4)};
  };
  std::map<Key, int> edges;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    for (int c = 0; c < 3; ++c) {
      const auto a = quantised(vertex(mesh, t, c));
      const auto b = quantised(vertex(mesh, t, (c + 1) % 3));
      ++edges[{a[0], a[1], a[2], b[0], b[1], b[2]}];
      --edges[{b[0], b[1], b[2], a[0], a[1], a[2]}];
    }
  }
  for (const auto& [edge, balance] : edges) ASSERT_EQ(balance, 0) << "an open edge";

  // Outward: each connected solid (triangles sharing quantised corners) has a positive volume.
  std::map<std::array<long long, 3>, std::size_t> corner_ids;
  std::vector<std::size_t> parent;
  auto find = [&](std::size_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<std::size_t> triangle_corner(mesh.triangle_count());
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    std::array<std::size_t, 3> ids{};
    for (int c = 0; c < 3; ++c) {
      const auto [it, inserted] = corner_ids.emplace(quantised(vertex(mesh, t, c)), parent.size());
      if (inserted) parent.push_back(parent.size());
      ids[static_cast<std::size_t>(c)] = it->second;
    }
    parent[find(ids[1])] = find(ids[0]);
    parent[find(ids[2])] = find(ids[0]);
    triangle_corner[t] = ids[0];
  }
  std::map<std::size_t, double> volume;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    volume[find(triangle_corner[t])] +=
        vertex(mesh, t, 0).dot(vertex(mesh, t, 1).cross(vertex(mesh, t, 2))) / 6.0;
  }
  EXPECT_GT(volume.size(), 50u);  // pillars, bases, beams, roofs, walls
  for (const auto& [solid, v] : volume) EXPECT_GT(v, 1e-3) << "a solid is inside out";

  // Dimensions: centred, long axis x, ridge at 8.5 m, standing on z = 0.
  const Eigen::Vector3f low = mesh.bounds_min();
  const Eigen::Vector3f high = mesh.bounds_max();
  EXPECT_NEAR(low.x(), -high.x(), 1e-5);
  EXPECT_NEAR(low.y(), -high.y(), 1e-5);
  EXPECT_GT(high.x() - low.x(), 2.0f * (high.y() - low.y()));
  EXPECT_NEAR(low.z(), 0.0f, 1e-6);
  EXPECT_NEAR(high.z(), 8.5f, 1e-5);
  EXPECT_EQ(mesh.materials.size(), 4u);
}

TEST(SampleGate, CommittedGlbMatchesTheCode) {
  const Mesh code = make_sample_gate();
  const Mesh file = load_model(kCommittedModel, UpAxis::Y, 1.0);
  EXPECT_LT(fs::file_size(kCommittedModel), 1u << 20);
  ASSERT_EQ(file.vertex_count(), code.vertex_count())
      << "data/models/gate.glb is stale: run skylit-sample-site from the repository root";
  for (std::size_t k = 0; k < code.vertex_count(); ++k) {
    ASSERT_LE((file.positions[k] - code.positions[k]).norm(), 1e-5f) << "vertex " << k;
    ASSERT_LE((file.normals[k] - code.normals[k]).norm(), 1e-5f) << "vertex " << k;
  }
  EXPECT_EQ(file.indices, code.indices);
  EXPECT_EQ(file.triangle_material, code.triangle_material);
  ASSERT_EQ(file.materials.size(), code.materials.size());
  for (std::size_t m = 0; m < code.materials.size(); ++m) {
    EXPECT_EQ(file.materials[m].name, code.materials[m].name);
    EXPECT_TRUE(file.materials[m].base_colour.isApprox(code.materials[m].base_colour, 1e-6f));
  }
}

TEST(SampleSite, CommittedYamlMatchesTheCode) {
  const Site code = make_sample_site("../data/models/gate.glb");
  const Site file = load_site(kCommittedSite);
  EXPECT_EQ(file.model, (kCommittedSite.parent_path() / "../data/models/gate.glb").lexically_normal());
  EXPECT_TRUE(fs::equivalent(file.model, kCommittedModel));
  EXPECT_EQ(file.up, code.up);
  EXPECT_EQ(file.up, UpAxis::Y);
  EXPECT_EQ(file.scale, code.scale);
  EXPECT_EQ(file.dome_frequency, code.dome_frequency);
  ASSERT_EQ(file.planes.size(), code.planes.size());
  for (std::size_t k = 0; k < code.planes.size(); ++k) {
    SCOPED_TRACE(code.planes[k].name);
    EXPECT_EQ(file.planes[k].name, code.planes[k].name);
    EXPECT_EQ(file.planes[k].origin, code.planes[k].origin);
    EXPECT_EQ(file.planes[k].u, code.planes[k].u);
    EXPECT_EQ(file.planes[k].v, code.planes[k].v);
    EXPECT_EQ(file.planes[k].width, code.planes[k].width);
    EXPECT_EQ(file.planes[k].height, code.planes[k].height);
    EXPECT_EQ(file.surface_of(k), code.surface_of(k));
  }
  EXPECT_EQ(file.plane_surfaces.size(), file.planes.size());
  // And the model it names loads.
  EXPECT_EQ(load_site_model(file).triangle_count(),
            make_sample_gate().triangle_count());
}

TEST(SampleSite, PlanesHaveSquareTexelsAndTheExpectedFrames) {
  const Site site = make_sample_site("gate.glb");
  EXPECT_EQ(site.dome_frequency, 2);
  ASSERT_EQ(site.planes.size(), 3u);
  for (const geom::Plane& plane : site.planes) {
    SCOPED_TRACE(plane.name);
    const double texel_u = plane.u.norm() / plane.width;
    const double texel_v = plane.v.norm() / plane.height;
    EXPECT_NEAR(texel_u / texel_v, 1.0, 0.02);
    EXPECT_LT(texel_u, 0.07);  // a few centimetres: shadows of 25 cm pillars stay sharp
    EXPECT_NEAR(plane.u.dot(plane.v), 0.0, 1e-12);  // rectangles
  }
  EXPECT_LT((plane_named(site, "ground").normal() - Vec3(0, 0, 1)).norm(), 1e-12);
  // The ground is real (the camera sees it); the wall and the roof belong to the gate.
  EXPECT_EQ(site.surface_of(0), PlaneSurface::Real);
  EXPECT_EQ(site.surface_of(1), PlaneSurface::Virtual);
  EXPECT_EQ(site.surface_of(2), PlaneSurface::Virtual);
  EXPECT_LT((plane_named(site, "wall").normal() - Vec3(0, -1, 0)).norm(), 1e-12);
  const Vec3 roof_normal = plane_named(site, "roof").normal();
  EXPECT_LT(roof_normal.y(), -0.5);  // up and south
  EXPECT_GT(roof_normal.z(), 0.5);
}

TEST(SampleSite, GroundCoversTheBuildingWithMargin) {
  const Mesh mesh = make_sample_gate();
  const geom::Plane& ground = plane_named(make_sample_site("gate.glb"), "ground");
  const Eigen::Vector3d low = mesh.bounds_min().cast<double>();
  const Eigen::Vector3d high = mesh.bounds_max().cast<double>();
  EXPECT_DOUBLE_EQ(ground.origin.z(), low.z() + 0.01);
  EXPECT_LE(ground.origin.x(), low.x() - 6.0);
  EXPECT_LE(ground.origin.y(), low.y() - 6.0);
  EXPECT_GE(ground.origin.x() + ground.u.x(), high.x() + 6.0);
  EXPECT_GE(ground.origin.y() + ground.v.y(), high.y() + 6.0);
  // The ground plane only cuts what stands on the ground (bases, the walls), 1 cm above z = 0.
  std::size_t cut = 0;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    if (!crosses_rectangle(ground, vertex(mesh, t, 0), vertex(mesh, t, 1), vertex(mesh, t, 2))) {
      continue;
    }
    ++cut;
    const double bottom = std::min({vertex(mesh, t, 0).z(), vertex(mesh, t, 1).z(), vertex(mesh, t, 2).z()});
    EXPECT_EQ(bottom, 0.0) << "triangle " << t << " crosses the ground plane in the air";
  }
  EXPECT_GT(cut, 0u);  // the test can see crossings
}

TEST(SampleSite, WallPlaneIsOneCentimetreInFrontOfTheWallAndClearOfEverything) {
  const Mesh mesh = make_sample_gate();
  const geom::Plane& wall = plane_named(make_sample_site("gate.glb"), "wall");
  const Vec3 n = wall.normal();
  const std::uint32_t plaster = material_named(mesh, "white plaster");

  // The plaster faces that look the same way as the plane and lie behind it.
  double covered_area = 0.0;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    if (mesh.triangle_material[t] != plaster) continue;
    const Vec3 a = vertex(mesh, t, 0), b = vertex(mesh, t, 1), c = vertex(mesh, t, 2);
    const Vec3 face = (b - a).cross(c - a);
    if (face.normalized().dot(n) < 1.0 - 1e-9) continue;
    const double distance = -n.dot(a - wall.origin);
    if (distance < 0.0 || distance > 0.1) continue;  // the other corridor's wall is elsewhere
    const Vec3 centre = (a + b + c) / 3.0;
    const double s = (centre - wall.origin).dot(wall.u) / wall.u.squaredNorm();
    if (s < 0.0 || s > 1.0) continue;
    for (const Vec3& p : {a, b, c}) EXPECT_NEAR(-n.dot(p - wall.origin), 0.01, 0.001);
    covered_area += face.norm() / 2.0;
  }
  // The wall face behind the plane has the plane's full area (the plane is no larger).
  EXPECT_NEAR(covered_area, wall.area(), 1e-3);

  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    ASSERT_FALSE(crosses_rectangle(wall, vertex(mesh, t, 0), vertex(mesh, t, 1), vertex(mesh, t, 2)))
        << "triangle " << t << " (material " << mesh.triangle_material[t] << ") passes through "
        << "the wall plane";
  }
}

TEST(SampleSite, RoofPlaneIsParallelToTheSouthSlopeOneCentimetreAbove) {
  const Mesh mesh = make_sample_gate();
  const geom::Plane& roof = plane_named(make_sample_site("gate.glb"), "roof");
  const Vec3 n = roof.normal();
  const std::uint32_t tiles = material_named(mesh, "dark grey roof tiles");

  double slope_area = 0.0;
  double highest = 0.0;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    if (mesh.triangle_material[t] != tiles) continue;
    const Vec3 a = vertex(mesh, t, 0), b = vertex(mesh, t, 1), c = vertex(mesh, t, 2);
    highest = std::max({highest, a.z(), b.z(), c.z()});
    const Vec3 face = (b - a).cross(c - a);
    if (std::acos(std::min(1.0, face.normalized().dot(n))) > 1e-6) continue;  // parallel only
    for (const Vec3& p : {a, b, c}) EXPECT_NEAR(-n.dot(p - roof.origin), 0.01, 1e-4);
    slope_area += face.norm() / 2.0;
  }
  EXPECT_NEAR(highest, 8.5, 1e-5);  // the gate's ridge, not a corridor's
  // The south slope is a trapezoid 13 m at the eave, 4 m at the ridge, 5.58 m up the slope.
  EXPECT_NEAR(slope_area, (13.0 + 4.0) / 2.0 * std::hypot(4.5, 3.3), 1e-3);

  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    ASSERT_FALSE(crosses_rectangle(roof, vertex(mesh, t, 0), vertex(mesh, t, 1), vertex(mesh, t, 2)))
        << "triangle " << t << " passes through the roof plane";
  }
}

TEST(SampleSite, IntersectionTestSeesPlanesThroughGeometry) {
  // Guards the checks above: a wall plane moved 30 cm south runs through the corridor pillars, a
  // roof plane moved 30 cm down runs through the roof.
  const Mesh mesh = make_sample_gate();
  geom::Plane moved = plane_named(make_sample_site("gate.glb"), "wall");
  moved.origin.y() -= 0.3;
  bool any = false;
  for (std::size_t t = 0; t < mesh.triangle_count() && !any; ++t) {
    any = crosses_rectangle(moved, vertex(mesh, t, 0), vertex(mesh, t, 1), vertex(mesh, t, 2));
  }
  EXPECT_TRUE(any);

  geom::Plane sunk = plane_named(make_sample_site("gate.glb"), "roof");
  sunk.origin -= 0.3 * sunk.normal();  // into the roof solid
  any = false;
  for (std::size_t t = 0; t < mesh.triangle_count() && !any; ++t) {
    any = crosses_rectangle(sunk, vertex(mesh, t, 0), vertex(mesh, t, 1), vertex(mesh, t, 2));
  }
  EXPECT_TRUE(any);
}

}  // namespace
}  // namespace skylit::scene
