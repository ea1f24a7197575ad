// The study's live GPU path inside the building's triangles: the sun per point from its shadow
// map, as the compositor samples it per fragment, against the ray tracer; the vertices' answer
// when the sun is taken as a lamp. A 2 m cube with a 4 m slab a metre east of it, the sun 45° up
// in the east: the slab shades the cube's top east of its middle (x > 0) and leaves the rest lit.
#include "skylit/study/gpu_path.hpp"

#include <cmath>
#include <fstream>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "../support/gl_suite.hpp"
#include "../support/quiet_bake.hpp"
#include "../support/temp_dir.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/scene/site.hpp"

namespace skylit::gpu_path_test {
namespace {

namespace study = skylit::study;
using Eigen::Vector3d;

class GpuBuildingInside : public skylit::test::GlSuite {};

TEST_F(GpuBuildingInside, TheSunPerPointComesFromItsMapWhereTheVerticesOnlyInterpolate) {
  const skylit::test::TempDir dir("gpu_building_inside");
  std::ofstream(dir.path() / "blocks.obj") << "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nv -1 -1 2\nv 1 -1 2\nv 1 1 2\nv -1 1 2\n"
                                              "v 2 -2 0\nv 3 -2 0\nv 3 2 0\nv 2 2 0\nv 2 -2 4\nv 3 -2 4\nv 3 2 4\nv 2 2 4\n"
                                              "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n"
                                              "f 9 12 11 10\nf 13 14 15 16\nf 9 10 14 13\nf 10 11 15 14\nf 11 12 16 15\nf 12 9 13 16\n";
  std::ofstream(dir.path() / "site.yaml") << "scene:\n  model: blocks.obj\n  up: z\n  scale: 1\ndome:\n  frequency: 2\nplanes:\n"
                                             "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                             "    v: [0, 12, 0]\n    resolution: [8, 8]\n";
  skylit::test::quiet_bake(dir.path() / "site.yaml", dir.path() / "bake");
  const skylit::scene::Site site = skylit::scene::load_site(dir.path() / "site.yaml");
  const skylit::scene::Mesh mesh = skylit::scene::load_site_model(site);
  const skylit::bake_format::Manifest manifest = skylit::bake_format::read_manifest(dir.path() / "bake");
  std::vector<std::size_t> shape;
  const std::vector<float> transfer = skylit::bake_format::read_npy(dir.path() / "bake" / manifest.transfer_file, &shape);
  const std::vector<Vector3d> S(shape.at(1), Vector3d(0.2, 0.25, 0.3));

  const Vector3d w = Vector3d(1, 0, 1).normalized();
  const skylit::blend::SunLight sun{w, Vector3d(8, 7, 6)};
  const std::vector<skylit::blend::SunLight> sources{sun};
  const std::vector<double> radii{0.0047};
  // The study's four points per triangle: the cube's top has two triangles, so its eight points
  // lie on both sides of the shadow's edge.
  const study::TrianglePoints points = study::triangle_points(mesh);
  const study::GpuPathResult g = study::gpu_path(dir.path() / "bake", manifest, mesh, transfer, S, sources, radii, {}, {}, {}, &points);
  ASSERT_EQ(g.point_visibility.size(), 1u);
  ASSERT_EQ(g.point_visibility[0].size(), points.positions.size());
  ASSERT_EQ(g.vertex_visibility[0].size(), mesh.vertex_count());

  // Per point, the map's sun against the ray-cast disc (study::source_term_at).
  study::SourceLight traced{w, sun.energy, {w}, {1.0}};
  const std::vector<Vector3d> ray = study::source_term_at(points, traced, site, mesh);
  const study::InsideTerms per_point = study::gpu_terms_inside(points, transfer, S, sources, true, mesh, g);
  int top_lit = 0, top_shaded = 0, agree = 0;
  for (std::size_t k = 0; k < points.positions.size(); ++k) {
    if ((per_point.sun[k] - ray[k]).norm() <= 0.05 * sun.energy.norm()) ++agree;
    const Eigen::Vector3f& p = points.positions[k];
    if (points.normals[k].z() < 0.9 || std::abs(p.z() - 2.0f) > 1e-3f || std::abs(p.x()) > 1.0f) continue;
    if (p.x() < -0.2f) {
      ++top_lit;
      EXPECT_GT(g.point_visibility[0][k], 0.9f) << "a point of the cube's top west of its middle, x " << p.x();
    } else if (p.x() > 0.2f) {
      ++top_shaded;
      EXPECT_LT(g.point_visibility[0][k], 0.1f) << "a point of the cube's top east of its middle, x " << p.x();
    }
  }
  std::printf("measured: %d of %zu points' sun within 5%% of the ray tracer's; the cube's top: %d lit and %d shaded points\n", agree,
              points.positions.size(), top_lit, top_shaded);
  EXPECT_GE(agree, static_cast<int>(0.95 * static_cast<double>(points.positions.size())));
  EXPECT_GT(top_lit, 0);
  EXPECT_GT(top_shaded, 0);

  // The sun as a lamp, per vertex: no term per point, and the sky term carries it interpolated,
  // so the top's shadow edge becomes a gradient between its lit and shaded corners.
  const study::InsideTerms per_vertex = study::gpu_terms_inside(points, transfer, S, sources, false, mesh, g);
  double differs = 0;
  for (std::size_t k = 0; k < points.positions.size(); ++k) {
    EXPECT_EQ(per_vertex.sun[k], Vector3d::Zero());
    differs = std::max(differs, (per_vertex.sky[k] - per_point.sky[k] - per_point.sun[k]).norm());
  }
  EXPECT_GT(differs, 0.1 * sun.energy.norm()) << "somewhere the interpolated sun misses the per-point one";

  // Without the points gpu_path gives no V there, and the split says so.
  const study::GpuPathResult no_points = study::gpu_path(dir.path() / "bake", manifest, mesh, transfer, S, sources, radii);
  EXPECT_TRUE(no_points.point_visibility.empty());
  EXPECT_THROW(study::gpu_terms_inside(points, transfer, S, sources, true, mesh, no_points), std::invalid_argument);
}

}  // namespace
}  // namespace skylit::gpu_path_test
