// scene::subdivide and the site's scene.max_edge: every edge at most the limit, the surface and
// its normals kept, the model's own vertices first and unchanged, a shared edge split once; and
// the field read, written back and refused when negative.
#include <cmath>
#include <map>
#include <set>
#include <utility>

#include <gtest/gtest.h>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/scene/site.hpp"

namespace skylit::scene {
namespace {

// A 4 m × 3 m quad of two triangles on the ground, facing up, with texture coordinates.
Mesh ground_quad() {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {4, 0, 0}, {4, 3, 0}, {0, 3, 0}};
  mesh.normals.assign(4, Eigen::Vector3f::UnitZ());
  mesh.texcoords = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  mesh.indices = {0, 1, 2, 0, 2, 3};
  mesh.triangle_material = {0, 0};
  mesh.materials.push_back({});
  return mesh;
}

double surface_area(const Mesh& mesh) {
  double sum = 0;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Eigen::Vector3f& a = mesh.positions[mesh.indices[3 * t]];
    const Eigen::Vector3f& b = mesh.positions[mesh.indices[3 * t + 1]];
    const Eigen::Vector3f& c = mesh.positions[mesh.indices[3 * t + 2]];
    sum += 0.5 * static_cast<double>((b - a).cross(c - a).norm());
  }
  return sum;
}

TEST(Subdivide, EveryEdgeWithinTheLimitTheSurfaceKeptAndSharedEdgesSplitOnce) {
  const Mesh original = ground_quad();
  Mesh mesh = original;
  subdivide(mesh, 1.0);
  EXPECT_GT(mesh.triangle_count(), original.triangle_count());
  EXPECT_EQ(mesh.triangle_material.size(), mesh.triangle_count());
  EXPECT_EQ(mesh.normals.size(), mesh.positions.size());
  EXPECT_EQ(mesh.texcoords.size(), mesh.positions.size());
  EXPECT_NEAR(surface_area(mesh), 12.0, 1e-5);
  for (std::size_t v = 0; v < original.vertex_count(); ++v) EXPECT_EQ(mesh.positions[v], original.positions[v]);
  std::set<std::pair<float, float>> seen;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    EXPECT_TRUE(seen.insert({mesh.positions[v].x(), mesh.positions[v].y()}).second) << "vertex " << v << " made twice";
    EXPECT_NEAR(mesh.normals[v].z(), 1.0f, 1e-6f);
    // Texture coordinates follow the positions (u = x / 4, v = y / 3 on this quad).
    EXPECT_NEAR(mesh.texcoords[v].x(), mesh.positions[v].x() / 4.0f, 1e-6f);
    EXPECT_NEAR(mesh.texcoords[v].y(), mesh.positions[v].y() / 3.0f, 1e-6f);
  }
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    for (int e = 0; e < 3; ++e) {
      const Eigen::Vector3f& a = mesh.positions[mesh.indices[3 * t + static_cast<std::size_t>(e)]];
      const Eigen::Vector3f& b = mesh.positions[mesh.indices[3 * t + static_cast<std::size_t>((e + 1) % 3)]];
      EXPECT_LE((a - b).norm(), 1.0f + 1e-6f);
    }
    // Winding kept: every triangle still faces up.
    const Eigen::Vector3f& a = mesh.positions[mesh.indices[3 * t]];
    const Eigen::Vector3f& b = mesh.positions[mesh.indices[3 * t + 1]];
    const Eigen::Vector3f& c = mesh.positions[mesh.indices[3 * t + 2]];
    EXPECT_GT((b - a).cross(c - a).z(), 0.0f);
  }
}

TEST(Subdivide, NoLimitOrAShortEnoughMeshLeavesItAsItIs) {
  const Mesh original = ground_quad();
  for (const double limit : {0.0, -1.0, std::nan(""), 10.0}) {
    Mesh mesh = original;
    subdivide(mesh, limit);
    EXPECT_EQ(mesh.indices, original.indices) << limit;
    EXPECT_EQ(mesh.vertex_count(), original.vertex_count()) << limit;
  }
}

TEST(Subdivide, TheSiteSaysHowLongAnEdgeMayBe) {
  const test::TempDir dir;
  const std::string plane = "planes:\n  - name: ground\n    origin: [-1, -1, 0.01]\n    u: [2, 0, 0]\n    v: [0, 2, 0]\n"
                            "    resolution: [8, 8]\n";
  dir.write("models/quad.obj", "v 0 0 0\nv 4 0 0\nv 4 3 0\nv 0 3 0\nf 1 2 3\nf 1 3 4\n");
  const auto file = dir.write("site.yaml", "scene:\n  model: models/quad.obj\n  max_edge: 0.5\ndome:\n  frequency: 2\n" + plane);
  const Site site = load_site(file);
  EXPECT_DOUBLE_EQ(site.max_edge, 0.5);
  EXPECT_NE(site_to_yaml(site).find("max_edge: 0.5"), std::string::npos) << site_to_yaml(site);
  const Mesh mesh = load_site_model(site);
  EXPECT_GT(mesh.vertex_count(), 4u);
  EXPECT_NEAR(surface_area(mesh), 12.0, 1e-4);
  const auto bad = dir.write("bad.yaml", "scene:\n  model: models/quad.obj\n  max_edge: -1\ndome:\n  frequency: 2\n" + plane);
  const std::string message = test::error_of([&] { (void)load_site(bad); });
  EXPECT_NE(message.find("field 'scene.max_edge'"), std::string::npos) << message;
}

}  // namespace
}  // namespace skylit::scene
