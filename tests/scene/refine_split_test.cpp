// scene::split_edges and scene::apply_refinement: a marked edge halves its triangles, two marked
// edges of a triangle close to three (split in four), an edge with the same ends on a neighbour
// face splits with it; the surface, the winding and the model's own vertices are kept; a recorded
// refinement replays exactly, and one of another model is refused.
#include <algorithm>
#include <stdexcept>

#include <gtest/gtest.h>

#include "skylit/scene/site.hpp"

namespace skylit::scene {
namespace refine_split_test {  // named: the test program is one unity build

// A 4 m × 2 m floor of two triangles (0 1 2, 0 2 3), and beside it, along x = 4, a wall facing
// +x whose bottom edge has the floor's corners 1 and 2 as its own vertices 4 and 5.
Mesh floor_and_wall() {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {4, 0, 0}, {4, 2, 0}, {0, 2, 0}, {4, 0, 0}, {4, 2, 0}, {4, 2, 3}, {4, 0, 3}};
  mesh.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {1, 0, 0}, {1, 0, 0}, {1, 0, 0}, {1, 0, 0}};
  mesh.indices = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7};
  mesh.triangle_material = {0, 0, 1, 1};
  mesh.materials.resize(2);
  return mesh;
}

double area_and_winding(const Mesh& mesh, std::size_t t, Eigen::Vector3f* normal) {
  const Eigen::Vector3f& a = mesh.positions[mesh.indices[3 * t]];
  const Eigen::Vector3f& b = mesh.positions[mesh.indices[3 * t + 1]];
  const Eigen::Vector3f& c = mesh.positions[mesh.indices[3 * t + 2]];
  const Eigen::Vector3f cross = (b - a).cross(c - a);
  *normal = cross.normalized();
  return 0.5 * static_cast<double>(cross.norm());
}

void expect_surface_kept(const Mesh& mesh, const Mesh& original) {
  double floor = 0.0, wall = 0.0;
  ASSERT_EQ(mesh.triangle_material.size(), mesh.triangle_count());
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    Eigen::Vector3f n;
    const double area = area_and_winding(mesh, t, &n);
    EXPECT_GT(area, 0.0) << "triangle " << t;
    const Eigen::Vector3f expected = mesh.triangle_material[t] == 0 ? Eigen::Vector3f::UnitZ() : Eigen::Vector3f::UnitX();
    EXPECT_NEAR(n.dot(expected), 1.0f, 1e-5f) << "triangle " << t << " keeps its face's winding";
    (mesh.triangle_material[t] == 0 ? floor : wall) += area;
  }
  EXPECT_NEAR(floor, 8.0, 1e-5);
  EXPECT_NEAR(wall, 6.0, 1e-5);
  for (std::size_t v = 0; v < original.vertex_count(); ++v) EXPECT_EQ(mesh.positions[v], original.positions[v]);
}

TEST(SplitEdges, OneMarkedEdgeHalvesItsTrianglesAndItsTwinOnTheWallSplitsWithIt) {
  const Mesh original = floor_and_wall();
  Mesh mesh = original;
  // The floor's edge 1–2 is the wall's bottom edge 4–5 in space.
  const std::vector<Edge> split = split_edges(mesh, std::vector<Edge>{{2, 1}});
  EXPECT_EQ(split, (std::vector<Edge>{{1, 2}, {4, 5}}));
  ASSERT_EQ(mesh.vertex_count(), 10u);
  EXPECT_EQ(mesh.positions[8], Eigen::Vector3f(4, 1, 0));
  EXPECT_EQ(mesh.positions[9], Eigen::Vector3f(4, 1, 0));
  EXPECT_EQ(mesh.normals[8], Eigen::Vector3f::UnitZ()) << "each midpoint takes its own face's normal";
  EXPECT_EQ(mesh.normals[9], Eigen::Vector3f::UnitX());
  EXPECT_EQ(mesh.triangle_count(), 6u) << "two halved triangles, one untouched on each face";
  expect_surface_kept(mesh, original);
}

TEST(SplitEdges, TwoMarkedEdgesOfATriangleCloseToThree) {
  const Mesh original = floor_and_wall();
  Mesh mesh = original;
  const std::vector<Edge> split = split_edges(mesh, std::vector<Edge>{{0, 1}, {0, 2}});
  // Triangle 0 1 2 has 0–1 and 0–2: its third, 1–2, is split too, and with it the wall's 4–5;
  // triangle 0 2 3 then has one marked edge (0–2) and is halved.
  EXPECT_EQ(split, (std::vector<Edge>{{0, 1}, {0, 2}, {1, 2}, {4, 5}}));
  EXPECT_EQ(mesh.triangle_count(), 4u + 2u + 2u + 1u);
  expect_surface_kept(mesh, original);
  EXPECT_TRUE(split_edges(mesh, {}).empty());
}

TEST(SplitEdges, APairThatIsNoEdgeIsRefused) {
  Mesh mesh = floor_and_wall();
  EXPECT_THROW(split_edges(mesh, std::vector<Edge>{{1, 3}}), std::invalid_argument);
  EXPECT_THROW(split_edges(mesh, std::vector<Edge>{{0, 99}}), std::invalid_argument);
}

TEST(ApplyRefinement, ARecordedRefinementReplaysExactlyAndAnotherModelsIsRefused) {
  Mesh refined = floor_and_wall();
  Refinement refinement;
  refinement.rounds.push_back(split_edges(refined, std::vector<Edge>{{0, 2}}));
  refinement.rounds.push_back(split_edges(refined, std::vector<Edge>{{0, 8}, {6, 7}}));
  EXPECT_EQ(refinement.split_count(), refinement.rounds[0].size() + refinement.rounds[1].size());

  Mesh replayed = floor_and_wall();
  apply_refinement(replayed, refinement);
  EXPECT_EQ(replayed.positions, refined.positions);
  EXPECT_EQ(replayed.normals, refined.normals);
  EXPECT_EQ(replayed.indices, refined.indices);
  EXPECT_EQ(replayed.triangle_material, refined.triangle_material);

  Mesh other = floor_and_wall();
  other.indices = {0, 1, 3, 1, 2, 3, 4, 5, 6, 4, 6, 7};  // the floor's other diagonal
  EXPECT_THROW(apply_refinement(other, refinement), std::invalid_argument);
  // A round that is not closed as split_edges closes it (0–1 and 1–2 of one triangle, no 0–2).
  Refinement open;
  open.rounds.push_back({{0, 1}, {1, 2}});
  Mesh mesh = floor_and_wall();
  EXPECT_THROW(apply_refinement(mesh, open), std::invalid_argument);
}

}  // namespace refine_split_test
}  // namespace skylit::scene
