// baker::refine_where_light_changes: a lone slab sees the same sky at every point and is left as
// it is; a pillar on it changes the light across the slab's two triangles, so the slab is split
// there, the interpolation misses less after, the same model refines alike every time, and the
// recorded rounds replay it. A bake with --refine records the refinement, verify checks it, and
// every program loads the refined model (bake_format::load_baked_model), refusing another model.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "../support/box_site.hpp"
#include "box_scene.hpp"
#include "skylit/bake_format/model.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/baker/refine.hpp"
#include "skylit/base/error.hpp"

namespace skylit::baker {
namespace refine_test {  // named: the test program is one unity build

using test::Box;
using test::mesh_of;

// The RMS over the slab's top, weighted by area, of the miss at each triangle's centroid of the
// light interpolated from its corners (the refinement's own measure: a share of a uniform sky's
// E_h). Centroids that see nothing (under the pillar) are left out.
double centroid_miss_rms(const scene::Mesh& mesh) {
  const std::vector<Vec3> directions = sphere_directions(256);
  scene::Mesh probed = mesh;
  std::vector<std::size_t> triangles;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const std::uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
    if (mesh.normals[a].z() < 0.99f) continue;
    probed.positions.push_back((mesh.positions[a] + mesh.positions[b] + mesh.positions[c]) / 3.0f);
    probed.normals.push_back(mesh.normals[a]);
    triangles.push_back(t);
  }
  std::vector<float> views(probed.vertex_count() * directions.size());
  vertex_views(probed, {}, directions, 0.2, views);
  double sum = 0.0, area = 0.0;
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const std::size_t p = mesh.vertex_count() + i;
    double miss = 0.0, seen = 0.0;
    for (std::size_t k = 0; k < directions.size(); ++k) {
      double corners = 0.0;
      for (int e = 0; e < 3; ++e) corners += views[mesh.indices[3 * triangles[i] + e] * directions.size() + k] / 3.0;
      miss += std::abs(views[p * directions.size() + k] - corners) * 4.0 / static_cast<double>(directions.size());
      seen += views[p * directions.size() + k];
    }
    if (seen == 0.0) continue;
    const std::size_t t = triangles[i];
    const Eigen::Vector3f& a = mesh.positions[mesh.indices[3 * t]];
    const double weight = 0.5 * static_cast<double>((mesh.positions[mesh.indices[3 * t + 1]] - a).cross(mesh.positions[mesh.indices[3 * t + 2]] - a).norm());
    sum += weight * miss * miss;
    area += weight;
  }
  return std::sqrt(sum / area);
}

RefineOptions options_at(double tolerance) {
  RefineOptions o;
  o.tolerance = tolerance;
  o.rounds = 4;
  o.min_edge = 0.25;
  return o;
}

TEST(RefineWhereLightChanges, TheSphereDirectionsAreEqualAreaAndUnit) {
  const std::vector<Vec3> d = sphere_directions(1000);
  Vec3 mean = Vec3::Zero();
  for (const Vec3& w : d) {
    EXPECT_NEAR(w.norm(), 1.0, 1e-12);
    mean += w / 1000.0;
  }
  EXPECT_LT(mean.norm(), 1e-3);
}

TEST(RefineWhereLightChanges, ALoneSlabSeesOneSkyEverywhereAndIsLeftAsItIs) {
  scene::Mesh mesh = mesh_of({Box{{-10, -10, 0}, {10, 10, 0.2}}});
  const std::size_t vertices = mesh.vertex_count();
  const scene::Refinement r = refine_where_light_changes(mesh, {}, options_at(0.02));
  EXPECT_TRUE(r.rounds.empty());
  EXPECT_EQ(mesh.vertex_count(), vertices);
}

TEST(RefineWhereLightChanges, APillarOnASlabSplitsTheSlabWhereItsLightChanges) {
  const scene::Mesh original = mesh_of({Box{{-10, -10, 0}, {10, 10, 0.2}}, Box{{-1, -1, 0.2}, {1, 1, 6}}});
  const double before = centroid_miss_rms(original);
  scene::Mesh mesh = original;
  const scene::Refinement r = refine_where_light_changes(mesh, {}, options_at(0.05));
  ASSERT_FALSE(r.rounds.empty());
  EXPECT_GT(mesh.vertex_count(), original.vertex_count());
  const double after = centroid_miss_rms(mesh);
  EXPECT_GT(before, 0.05) << "the slab's corners see open sky, its middle the pillar";
  EXPECT_LT(after, 0.6 * before) << "refined: " << mesh.vertex_count() << " vertices";
  std::printf("centroid miss RMS %.4f -> %.4f, %zu -> %zu vertices\n", before, after, original.vertex_count(), mesh.vertex_count());

  scene::Mesh again = original;
  const scene::Refinement second = refine_where_light_changes(again, {}, options_at(0.05));
  EXPECT_EQ(second.rounds, r.rounds) << "the same model refines alike (every shard of a bake must)";
  scene::Mesh replayed = original;
  scene::apply_refinement(replayed, r);
  EXPECT_EQ(replayed.positions, mesh.positions);
  EXPECT_EQ(replayed.indices, mesh.indices);

  scene::Mesh lax = original;
  EXPECT_TRUE(refine_where_light_changes(lax, {}, options_at(10.0)).rounds.empty()) << "no change is that large";
  scene::Mesh none = original;
  EXPECT_TRUE(refine_where_light_changes(none, {}, options_at(0.0)).rounds.empty()) << "tolerance 0: off";
}

TEST(RefineWhereLightChanges, OptionsOutOfRangeAreRefusedNamingTheOption) {
  RefineOptions o = options_at(-1);
  EXPECT_THROW(validate_refine_options(o), InputError);
  o = options_at(0.05);
  o.rounds = 0;
  try {
    validate_refine_options(o);
    FAIL() << "rounds 0 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--refine-rounds"), std::string::npos) << e.what();
  }
  o = options_at(0.05);
  o.min_edge = 0;
  EXPECT_THROW(validate_refine_options(o), InputError);
}

TEST(RefinedBake, RecordsTheRefinementAndEveryProgramLoadsTheRefinedModel) {
  skylit::test::TempDir dir("skylit-refined-bake-");
  // The cube on a 12 m slab: the slab's top is two triangles whose corners see open sky.
  test::write_cube_on_slab_site(dir.path());
  BakeOptions options;
  options.site_file = dir.path() / "site.yaml";
  options.out_dir = dir.path() / "bake";
  options.samples = 4;
  options.method = "raytrace";
  options.previews = false;
  options.ground_samples = 16;
  options.refine = options_at(0.05);
  std::FILE* quiet = std::fopen("/dev/null", "w");
  run_bake(options, quiet);
  std::fclose(quiet);

  const bake_format::VerifyReport report = bake_format::verify(options.out_dir);
  ASSERT_TRUE(report.ok) << report.problems.front();
  const bake_format::Manifest& m = report.manifest;
  ASSERT_TRUE(m.refinement.has_value());
  EXPECT_EQ(m.plan.refine.tolerance, 0.05);
  EXPECT_FALSE(m.refinement->round_sizes.empty());
  const scene::Site site = scene::load_site(options.site_file);
  const scene::Mesh plain = scene::load_site_model(site);
  const scene::Mesh baked = bake_format::load_baked_model(site, options.out_dir, m);
  EXPECT_GT(baked.vertex_count(), plain.vertex_count());
  EXPECT_EQ(baked.vertex_count(), m.plan.vertex_count);
  EXPECT_EQ(baked.triangle_count(), m.plan.triangle_count);

  // The manifest's record round-trips, and a damaged refinement file is found by verify.
  const bake_format::Manifest back = bake_format::manifest_from_json(bake_format::to_json(m), "manifest.json");
  ASSERT_TRUE(back.refinement.has_value());
  EXPECT_EQ(back.refinement->round_sizes, m.refinement->round_sizes);
  EXPECT_EQ(back.plan.refine, m.plan.refine);

  // Another model under the same name: refused, with the fix.
  std::ofstream(dir.path() / "slab.obj", std::ios::app) << "v 0 0 9\nv 1 0 9\nv 0 1 9\nf 13 14 15\n";
  try {
    bake_format::load_baked_model(site, options.out_dir, m);
    FAIL() << "a changed model was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("re-bake"), std::string::npos) << e.what();
  }
  std::ofstream(options.out_dir / "refinement.npy", std::ios::app) << "x";
  EXPECT_FALSE(bake_format::verify(options.out_dir).ok);
}

}  // namespace refine_test
}  // namespace skylit::baker
