// baker::fit_vertex_values (least-squares vertex values): the points tile every triangle; a
// linear light is kept exactly; a vertex dark at a contact takes the light of its face; points
// that see nothing are left out; the bounds hold. A bake with --vertex-fit records it, and its
// building, interpolated across the triangles, misses the light there less than the vertices'
// own values do.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <optional>
#include <stdexcept>

#include <gtest/gtest.h>

#include "../support/box_site.hpp"
#include "box_scene.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/baker/refine.hpp"
#include "skylit/baker/vertex_fit.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/base/error.hpp"

namespace skylit::baker {
namespace vertex_fit_test {  // named: the test program is one unity build

// A 2 m square in z = 0 as two triangles, facing up.
scene::Mesh square() {
  scene::Mesh mesh;
  mesh.positions = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}};
  mesh.normals.assign(4, Eigen::Vector3f::UnitZ());
  mesh.indices = {0, 1, 2, 0, 2, 3};
  return mesh;
}

// Values at the traced vertices (the mesh's, then the points') from a function of position.
template <typename F>
std::vector<float> traced_from(const scene::Mesh& mesh, const FitPoints& points, std::size_t layers, F f) {
  std::vector<float> out;
  const scene::Mesh traced = with_points(mesh, points.positions, points.normals);
  for (const Eigen::Vector3f& p : traced.positions) {
    for (std::size_t l = 0; l < layers; ++l) out.push_back(static_cast<float>((l + 1) * f(p)));
  }
  return out;
}

TEST(FitPoints, EveryTriangleHasNSquaredPointsInsideThatShareItsArea) {
  const scene::Mesh mesh = square();
  for (int n : {1, 2, 3, 5}) {
    const FitPoints points = fit_points(mesh, n);
    ASSERT_EQ(points.positions.size(), 2u * static_cast<std::size_t>(n * n));
    double area = 0;
    for (std::size_t p = 0; p < points.positions.size(); ++p) {
      area += points.areas[p];
      const auto& w = points.weights[p];
      EXPECT_NEAR(w[0] + w[1] + w[2], 1.0, 1e-12);
      for (double b : w) EXPECT_GT(b, 0.0);
      EXPECT_NEAR(points.normals[p].z(), 1.0f, 1e-6f);
    }
    EXPECT_NEAR(area, 4.0, 1e-9) << n;
  }
  // n = 3 shares no point with the four the accuracy study measures at (the centroid and the
  // points halfway to each corner), so that a fit is never measured where it was made.
  for (const auto& w : fit_points(mesh, 3).weights) {
    EXPECT_GT(std::abs(w[0] - 1.0 / 3.0) + std::abs(w[1] - 1.0 / 3.0), 1e-3);
    EXPECT_GT(std::abs(w[0] - 2.0 / 3.0) + std::abs(w[1] - 1.0 / 6.0), 1e-3);
  }
  EXPECT_THROW(fit_points(mesh, 0), std::invalid_argument);
}

TEST(FitVertexValues, ALinearLightIsKeptExactly) {
  const scene::Mesh mesh = square();
  const FitPoints points = fit_points(mesh, 3);
  const auto linear = [](const Eigen::Vector3f& p) { return 1.0 + 0.3 * p.x() - 0.2 * p.y(); };
  const std::vector<float> traced = traced_from(mesh, points, 2, linear);
  const std::vector<float> fitted = fit_vertex_values(mesh, points, traced, 2);
  ASSERT_EQ(fitted.size(), 8u);
  for (std::size_t v = 0; v < 4; ++v) {
    for (std::size_t l = 0; l < 2; ++l) EXPECT_NEAR(fitted[v * 2 + l], (l + 1) * linear(mesh.positions[v]), 1e-5) << v << " " << l;
  }
}

TEST(FitVertexValues, AVertexDarkAtAContactTakesTheLightOfItsFace) {
  // Vertex 0 stands where a wall meets the square: dark itself, while its triangles are lit all
  // the way to it. The interpolation from its own value darkens a third of the square; the fit
  // lights it as its face is lit (μ = 0.01 keeps it within 5% of 1, and its
  // neighbours make up for that by about 1%).
  const scene::Mesh mesh = square();
  const FitPoints points = fit_points(mesh, 3);
  std::vector<float> traced = traced_from(mesh, points, 1, [](const Eigen::Vector3f&) { return 1.0; });
  traced[0] = 0.0f;
  const std::vector<float> fitted = fit_vertex_values(mesh, points, traced, 1);
  EXPECT_GT(fitted[0], 0.95f);
  for (std::size_t v = 1; v < 4; ++v) EXPECT_NEAR(fitted[v], 1.0f, 0.02f);
}

TEST(FitVertexValues, PointsThatSeeNothingAreLeftOutAndTheBoundsHold) {
  // The second triangle (0, 2, 3) lies under a solid: its points see nothing. They do not pull
  // vertex 3, which only that triangle informs, to 0: it keeps its own value.
  const scene::Mesh mesh = square();
  const FitPoints points = fit_points(mesh, 3);
  std::vector<float> traced = traced_from(mesh, points, 1, [](const Eigen::Vector3f&) { return 0.8; });
  for (std::size_t p = 9; p < 18; ++p) traced[4 + p] = 0.0f;
  const std::vector<float> fitted = fit_vertex_values(mesh, points, traced, 1);
  for (std::size_t v = 0; v < 4; ++v) EXPECT_NEAR(fitted[v], 0.8f, 1e-4f) << v;
  // A light that overshoots is held within [0, upper].
  const auto steep = [](const Eigen::Vector3f& p) { return p.x() < 1.0f ? 0.0 : 1.0; };
  const std::vector<float> upper(4, 0.9f);
  for (float x : fit_vertex_values(mesh, points, traced_from(mesh, points, 1, steep), 1, upper)) {
    EXPECT_GE(x, 0.0f);
    EXPECT_LE(x, 0.9f);
  }
  EXPECT_THROW(fit_vertex_values(mesh, points, std::vector<float>(5, 1.0f), 1), std::invalid_argument);
  EXPECT_THROW(fit_vertex_values(mesh, points, traced, 1, std::vector<float>(3, 1.0f)), std::invalid_argument);
}

// E under a uniform sky of radiance 1 (E_h = π) at the points: the reference, ray-traced.
std::vector<double> uniform_sky_at(const scene::Mesh& mesh, const FitPoints& points) {
  std::vector<Vec3> directions;
  for (const Vec3& d : sphere_directions(4096)) {
    if (d.z() > 0) directions.push_back(d);
  }
  const std::vector<Eigen::Vector3d> weights(directions.size(), Eigen::Vector3d::Constant(4.0 * std::numbers::pi / 4096.0));
  const scene::Mesh traced = with_points(mesh, points.positions, points.normals);
  std::vector<Eigen::Vector3d> E(traced.vertex_count());
  weighted_vertex_irradiance(traced, {}, directions, weights, E);
  std::vector<double> out;
  for (std::size_t p = 0; p < points.positions.size(); ++p) out.push_back(E[mesh.vertex_count() + p].x());
  return out;
}

TEST(VertexFitBake, TheBuildingBetweenItsVerticesIsLitAsItIsNotAsItsCorners) {
  skylit::test::TempDir dir("skylit-vertex-fit-");
  // A 3 m cube on a 12 m slab: the slab's two triangles have their corners in the open, while the
  // cube darkens the slab around its foot.
  test::write_cube_on_slab_site(dir.path());
  const auto bake = [&](int vertex_fit, const char* name, std::optional<Shard> shard = std::nullopt) {
    BakeOptions options;
    options.shard = shard;
    options.site_file = dir.path() / "site.yaml";
    options.out_dir = dir.path() / name;
    options.samples = 16;
    options.method = "raytrace";
    options.previews = false;
    options.ground_samples = 16;
    options.vertex_fit = vertex_fit;
    std::FILE* quiet = std::fopen("/dev/null", "w");
    run_bake(options, quiet);
    std::fclose(quiet);
    if (shard) return std::vector<float>();
    const bake_format::VerifyReport report = bake_format::verify(options.out_dir);
    EXPECT_TRUE(report.ok) << report.problems.front();
    EXPECT_EQ(report.manifest.plan.vertex_fit, vertex_fit);
    std::vector<std::size_t> shape;
    return bake_format::read_npy(options.out_dir / report.manifest.transfer_file, &shape);
  };
  const std::vector<float> own = bake(0, "own"), fitted = bake(3, "fitted");
  ASSERT_EQ(own.size(), fitted.size());
  // A job array's shards hold the points' light too, and their merge fits the same values.
  bake(3, "shard0", Shard{0, 2});
  bake(3, "shard1", Shard{1, 2});
  std::FILE* quiet = std::fopen("/dev/null", "w");
  merge_bakes({dir.path() / "shard0", dir.path() / "shard1"}, dir.path() / "merged", false, quiet);
  std::fclose(quiet);
  std::vector<std::size_t> shape;
  EXPECT_EQ(bake_format::read_npy(dir.path() / "merged" / "transfer.npy", &shape), fitted);

  // Measured at the study's points (the centroids of each triangle's four halves), not at the
  // fit's own: E interpolated from the vertices' Σ_l t_l (a uniform sky, faces basis: S_l = 1).
  const scene::Mesh mesh = scene::load_site_model(scene::load_site(dir.path() / "site.yaml"));
  const FitPoints probes = fit_points(mesh, 2);
  const std::vector<double> reference = uniform_sky_at(mesh, probes);
  const std::size_t layers = own.size() / mesh.vertex_count();
  const auto miss = [&](const std::vector<float>& transfer) {
    double sum = 0, area = 0;
    for (std::size_t p = 0; p < reference.size(); ++p) {
      if (reference[p] == 0.0) continue;  // under the cube
      double E = 0;
      for (int c = 0; c < 3; ++c) {
        const std::size_t v = probes.corners[p][static_cast<std::size_t>(c)];
        for (std::size_t l = 0; l < layers; ++l) E += probes.weights[p][static_cast<std::size_t>(c)] * transfer[v * layers + l];
      }
      const double e = (E - reference[p]) / std::numbers::pi;
      sum += probes.areas[p] * e * e;
      area += probes.areas[p];
    }
    return std::sqrt(sum / area);
  };
  const double own_miss = miss(own), fitted_miss = miss(fitted);
  std::printf("measured: inside the triangles, by area, %.4f of E_h from the vertices' own light, %.4f fitted\n", own_miss,
              fitted_miss);
  EXPECT_LT(fitted_miss, 0.7 * own_miss);
}

TEST(VertexFitBake, OutOfRangeIsRefusedNamingTheOption) {
  BakeOptions options;
  options.site_file = "unused.yaml";
  options.out_dir = "unused";
  options.vertex_fit = 17;
  try {
    run_bake(options, nullptr);
    FAIL() << "--vertex-fit 17 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--vertex-fit"), std::string::npos) << e.what();
  }
}

}  // namespace vertex_fit_test
}  // namespace skylit::baker
