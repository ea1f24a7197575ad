// The corners basis in the baker: per-sample weights in both engines (one pass, three layers),
// and a corners bake of a box scene against a faces bake of the same scene.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include <Eigen/Geometry>

#include "box_scene.hpp"
#include "../support/box_site.hpp"
#include "../support/suite_setup.hpp"
#include "skylit/base/error.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/geom/dome_basis.hpp"
#include "skylit/bake_format/arrays.hpp"

namespace skylit::baker {
namespace {

namespace fs = std::filesystem;

// A box on the ground, a ground plane around it and a plane on its south face facing south.
scene::Mesh box_mesh() { return test::mesh_of({{{-1.0, -1.0, 0.0}, {1.0, 1.0, 2.0}}}); }

std::vector<geom::Plane> box_planes() {
  geom::Plane ground;
  ground.name = "ground";
  ground.origin = {-5.0, -5.0, 0.01};
  ground.u = {10.0, 0.0, 0.0};
  ground.v = {0.0, 10.0, 0.0};
  ground.width = ground.height = 40;
  geom::Plane wall;
  wall.name = "south";
  wall.origin = {-1.0, -1.01, 0.0};
  wall.u = {2.0, 0.0, 0.0};
  wall.v = {0.0, 0.0, 2.0};
  wall.width = wall.height = 16;
  return {ground, wall};
}

// f_k by the contract's formula, from one single-direction pass per sample (f = V then).
std::vector<double> expected_fractions(VisibilityEngine& engine, int plane, const geom::Plane& p,
                                       const std::vector<Vec3>& directions, const std::vector<SampleWeights>& weights) {
  const std::size_t texels = static_cast<std::size_t>(p.width) * static_cast<std::size_t>(p.height);
  std::vector<double> num(3 * texels, 0.0), den(3, 0.0), count(texels, 0.0);
  for (std::size_t s = 0; s < directions.size(); ++s) {
    std::vector<float> v(texels);
    engine.set_directions(std::span<const Vec3>(&directions[s], 1));
    engine.plane_fractions(plane, v);
    const double c = std::max(0.0, p.normal().dot(directions[s]));
    for (std::size_t k = 0; k < 3; ++k) {
      den[k] += weights[s][k] * c;
      for (std::size_t t = 0; t < texels; ++t) num[k * texels + t] += weights[s][k] * c * v[t];
    }
    for (std::size_t t = 0; t < texels; ++t) count[t] += v[t];
  }
  for (std::size_t k = 0; k < 3; ++k) {
    for (std::size_t t = 0; t < texels; ++t) {
      num[k * texels + t] = den[k] > 0 ? num[k * texels + t] / den[k] : count[t] / static_cast<double>(directions.size());
    }
  }
  return num;
}

TEST(WeightedDirections, BothEnginesGiveEveryLayerInOnePass) {
  const scene::Mesh mesh = box_mesh();
  const std::vector<geom::Plane> planes = box_planes();
  auto raytrace = make_raytrace_engine(mesh, planes, {});
  RasterOptions raster_options;
  raster_options.shadow_map_resolution = 1024;
  raster_options.shader_dir = fs::path(SKYLIT_SOURCE_DIR) / "shaders";
  auto raster = make_raster_engine(mesh, planes, raster_options);
  const geom::Dome dome(2);
  const geom::CornerWeights corners(dome);
  // The lowest southern face (the box shadows the ground with it), and one that the south wall's
  // horizon cuts (some samples behind the wall).
  int low_south = -1, straddling = -1;
  for (int i = 0; i < dome.face_count(); ++i) {
    const Vec3& c = dome.face(i).centre;
    if (c.y() < 0.0 && (low_south < 0 || c.z() < dome.face(low_south).centre.z())) low_south = i;
    double lo = 1, hi = -1;
    for (const Vec3& d : face_sample_directions(dome, i, 16)) {
      lo = std::min(lo, -d.y());
      hi = std::max(hi, -d.y());
    }
    if (straddling < 0 && lo < 0.0 && hi > 0.0 && c.z() > 0.2) straddling = i;
  }
  ASSERT_GE(low_south, 0);
  ASSERT_GE(straddling, 0);
  for (const int face : {low_south, straddling}) {
    SCOPED_TRACE("face " + std::to_string(face));
    const std::vector<Vec3> directions = face_sample_directions(dome, face, 16);
    std::vector<SampleWeights> weights;
    for (const Vec3& d : directions) {
      const auto l = corners(face, d);
      weights.push_back({static_cast<float>(l[0]), static_cast<float>(l[1]), static_cast<float>(l[2])});
    }
    for (int j = 0; j < 2; ++j) {
      const geom::Plane& p = planes[static_cast<std::size_t>(j)];
      const std::size_t texels = static_cast<std::size_t>(p.width * p.height);
      const std::vector<double> expected = expected_fractions(*raytrace, j, p, directions, weights);
      raytrace->set_weighted_directions(directions, weights, 3);
      EXPECT_EQ(raytrace->layers(), 3);
      std::vector<float> f(3 * texels, -1.0f);
      raytrace->plane_fractions(j, f);
      raster->set_weighted_directions(directions, weights, 3);
      std::vector<float> g(3 * texels, -1.0f);
      raster->plane_fractions(j, g);
      double raster_mean = 0;
      for (std::size_t t = 0; t < f.size(); ++t) {
        ASSERT_NEAR(f[t], expected[t], 1e-6) << "plane " << j << " value " << t;
        raster_mean += std::abs(g[t] - f[t]);
        ASSERT_GE(g[t], 0.0f);
        ASSERT_LE(g[t], 1.0f);
      }
      // Shadow maps differ from rays only at shadow edges (EngineAgreement's bound).
      EXPECT_LT(raster_mean / static_cast<double>(f.size()), 0.005) << "plane " << j;
    }
    // Vertices: three layers each, the two engines agreeing as for the planes.
    std::vector<float> fv(3 * mesh.vertex_count()), gv(3 * mesh.vertex_count());
    raytrace->vertex_fractions(fv);
    raster->vertex_fractions(gv);
    double mean = 0;
    for (std::size_t v = 0; v < fv.size(); ++v) mean += std::abs(fv[v] - gv[v]);
    EXPECT_LT(mean / static_cast<double>(fv.size()), 0.01);
  }
  // One layer of weight 1 is the faces contract: the same fractions as set_directions.
  const std::vector<Vec3> directions = face_sample_directions(dome, 26, 16);
  std::vector<float> plain(1600), weighted(1600);
  raytrace->set_directions(directions);
  EXPECT_EQ(raytrace->layers(), 1);
  raytrace->plane_fractions(0, plain);
  raytrace->set_weighted_directions(directions, std::vector<SampleWeights>(16, SampleWeights{1.0f, 0.0f, 0.0f}), 1);
  raytrace->plane_fractions(0, weighted);
  EXPECT_EQ(plain, weighted);
  EXPECT_THROW(raytrace->set_weighted_directions(directions, std::vector<SampleWeights>(3), 3), std::invalid_argument);
  EXPECT_THROW(raster->set_weighted_directions(directions, {}, 4), std::invalid_argument);
}

class CornersBake : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new skylit::test::TempDir("skylit-corners-bake-");
    skylit::test::write_box_site(dir_->path(), "dome:\n  frequency: 2\n  basis: corners\n"
                                        "planes:\n"
                                        "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                        "    v: [0, 12, 0]\n    resolution: [48, 48]\n"
                                        "  - name: south\n    origin: [-1, -1.01, 0]\n    u: [2, 0, 0]\n"
                                        "    v: [0, 0, 2]\n    resolution: [8, 8]\n");
    std::FILE* quiet = std::fopen("/dev/null", "w");
    BakeOptions options;
    options.site_file = *dir_ / "site.yaml";
    options.samples = 16;
    options.method = "raytrace";
    options.previews = false;
    setup_.run([&] {
      options.out_dir = *dir_ / "corners";  // the site's basis
      run_bake(options, quiet);
      options.out_dir = *dir_ / "faces";
      options.basis = geom::DomeBasis::Faces;  // --basis overrides the site
      run_bake(options, quiet);
    });
    std::fclose(quiet);
  }
  void SetUp() override { setup_.require(); }
  static void TearDownTestSuite() {
    delete dir_;
  }
  static skylit::test::TempDir* dir_;
  static inline skylit::test::SuiteSetup setup_;
};
skylit::test::TempDir* CornersBake::dir_ = nullptr;

TEST_F(CornersBake, TheManifestAndTheFilesHaveThreeLayersPerFace) {
  const bake_format::VerifyReport corners = bake_format::verify(*dir_ / "corners");
  ASSERT_TRUE(corners.ok) << (corners.problems.empty() ? "" : corners.problems.front());
  const bake_format::VerifyReport faces = bake_format::verify(*dir_ / "faces");
  ASSERT_TRUE(faces.ok);
  EXPECT_EQ(corners.manifest.plan.basis, geom::DomeBasis::Corners);
  EXPECT_EQ(faces.manifest.plan.basis, geom::DomeBasis::Faces);
  EXPECT_EQ(corners.manifest.layer_count(), 120U);
  std::vector<std::size_t> shape;
  bake_format::read_npy(*dir_ / "corners" / "transfer.npy", &shape);
  EXPECT_EQ(shape, (std::vector<std::size_t>{corners.manifest.plan.vertex_count, 120}));
  // A per layer: the three corners of a face add up to the face's exact A.
  for (std::size_t j = 0; j < 2; ++j) {
    const auto& a3 = corners.manifest.planes[j].unoccluded;
    const auto& a1 = faces.manifest.planes[j].unoccluded;
    for (std::size_t i = 0; i < 40; ++i) {
      EXPECT_NEAR(a3[3 * i] + a3[3 * i + 1] + a3[3 * i + 2], a1[i], 1e-14);
    }
  }
}

TEST_F(CornersBake, AnUnoccludedTexelHoldsAAndTheCornersAddUpToTheFace) {
  const bake_format::Manifest corners = bake_format::read_manifest(*dir_ / "corners");
  const bake_format::Manifest faces = bake_format::read_manifest(*dir_ / "faces");
  for (std::size_t j = 0; j < 2; ++j) {
    SCOPED_TRACE(corners.planes[j].plane.name);
    const bake_format::ImageStack b3 = bake_format::read_exr_stack(*dir_ / "corners" / corners.planes[j].file);
    const bake_format::ImageStack b1 = bake_format::read_exr_stack(*dir_ / "faces" / faces.planes[j].file);
    const std::size_t texels = static_cast<std::size_t>(b1.width * b1.height);
    double sum_diff = 0, total_a = 0, worst = 0;
    for (int i = 0; i < 40; ++i) {
      const double a = faces.planes[j].unoccluded[static_cast<std::size_t>(i)];
      total_a += a;
      for (std::size_t t = 0; t < texels; ++t) {
        double sum = 0;
        for (int k = 0; k < 3; ++k) {
          const double ak = corners.planes[j].unoccluded[static_cast<std::size_t>(3 * i + k)];
          const double b = b3.layer(3 * i + k)[t];
          ASSERT_LE(b, ak * (1 + 1e-3) + 1e-7);
          sum += b;
        }
        const double diff = std::abs(sum - b1.layer(i)[t]);
        sum_diff += diff;
        worst = std::max(worst, diff / a);
      }
    }
    // Σ_k B_{f,k} is the faces bake's B_f up to how well the 16 samples' weights estimate each
    // corner's share of A (the same directions in both bakes).
    EXPECT_LT(sum_diff / static_cast<double>(texels) / total_a, 2e-3);  // measured 4e-4
    EXPECT_LT(worst, 0.06);  // measured 0.025
  }
  // The south plane faces away from the box behind it: every texel sees all of its half of the
  // sky, so B = A in every layer, to half-float rounding.
  const bake_format::ImageStack south = bake_format::read_exr_stack(*dir_ / "corners" / corners.planes[1].file);
  int lit_layers = 0;
  for (int l = 0; l < 120; ++l) {
    const double a = corners.planes[1].unoccluded[static_cast<std::size_t>(l)];
    lit_layers += a > 0.0;
    for (float b : south.layer(l)) ASSERT_NEAR(b, a, 5e-4 * a + 1e-8) << "layer " << l;
  }
  EXPECT_GT(lit_layers, 30);
}

// The box's vertices see all of their half of the sky (a convex box), so this checks the split of
// A between the corners for vertex normals, the faces cut by their horizon included.
TEST_F(CornersBake, TransferVectorsSplitTheFacesTransfer) {
  std::vector<std::size_t> shape3, shape1;
  const std::vector<float> t3 = bake_format::read_npy(*dir_ / "corners" / "transfer.npy", &shape3);
  const std::vector<float> t1 = bake_format::read_npy(*dir_ / "faces" / "transfer.npy", &shape1);
  const std::size_t vertices = shape1.at(0);
  ASSERT_EQ(shape1, (std::vector<std::size_t>{vertices, 40}));
  ASSERT_EQ(shape3, (std::vector<std::size_t>{vertices, 120}));
  double diff = 0, total = 0;
  for (std::size_t v = 0; v < vertices; ++v) {
    for (std::size_t i = 0; i < 40; ++i) {
      const double sum = t3[v * 120 + 3 * i] + t3[v * 120 + 3 * i + 1] + t3[v * 120 + 3 * i + 2];
      diff += std::abs(sum - t1[v * 40 + i]);
      total += t1[v * 40 + i];
    }
  }
  EXPECT_GT(total, 0.0);
  EXPECT_LT(diff / total, 1e-5);
}

TEST_F(CornersBake, FewerThanThreeSamplesAreRefused) {
  BakeOptions options;
  options.site_file = *dir_ / "site.yaml";
  options.out_dir = *dir_ / "refused";
  options.samples = 1;
  options.method = "raytrace";
  std::FILE* quiet = std::fopen("/dev/null", "w");
  try {
    run_bake(options, quiet);
    ADD_FAILURE() << "a corners bake with one sample per face was accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("--samples"), std::string::npos) << message;
    EXPECT_NE(message.find("dome.basis: corners"), std::string::npos) << message;
    EXPECT_NE(message.find("at least 3"), std::string::npos) << message;
  }
  options.basis = geom::DomeBasis::Faces;  // the paper's face centre is fine with faces
  EXPECT_NO_THROW(run_bake(options, quiet));
  std::fclose(quiet);
}

}  // namespace
}  // namespace skylit::baker
