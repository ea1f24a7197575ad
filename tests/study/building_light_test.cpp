// The building's light against analytic cases: a 2 m cube on the ground under a uniform sky
// (every face unoccluded: π L on its top, π L / 2 on its sides, 0 underneath), through the dense
// reference and through a real bake's transfer vectors, and a separated sun on each face.
#include "skylit/study/building_light.hpp"

#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "../support/box_site.hpp"
#include "../support/quiet_bake.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/scene/site.hpp"

namespace {

namespace study = skylit::study;
using Eigen::Vector3d;

constexpr double kPi = std::numbers::pi;
const Vector3d kRadiance(1.0, 0.5, 0.25);

// What a vertex of the cube receives from the uniform upper hemisphere: ∫ L max(0, n·ω) dω.
Vector3d uniform_sky_irradiance(const Eigen::Vector3f& normal) {
  if (normal.z() > 0.5) return kPi * kRadiance;
  if (normal.z() < -0.5) return Vector3d::Zero();
  return kPi / 2 * kRadiance;
}

class BuildingLight : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new skylit::test::TempDir("building_light");
    skylit::test::write_box_site(dir_->path(), "dome:\n  frequency: 2\nplanes:\n"
                                               "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                               "    v: [0, 12, 0]\n    resolution: [8, 8]\n");
    skylit::test::quiet_bake(dir_->path() / "site.yaml", dir_->path() / "bake", 16);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static skylit::scene::Site site() { return skylit::scene::load_site(dir_->path() / "site.yaml"); }
  static std::vector<float> transfer(std::size_t* layers) {
    const skylit::bake_format::Manifest manifest = skylit::bake_format::read_manifest(dir_->path() / "bake");
    std::vector<std::size_t> shape;
    std::vector<float> t = skylit::bake_format::read_npy(dir_->path() / "bake" / manifest.transfer_file, &shape);
    *layers = shape.at(1);
    return t;
  }
  static skylit::test::TempDir* dir_;
};
skylit::test::TempDir* BuildingLight::dir_ = nullptr;

TEST_F(BuildingLight, TheReferenceIntegratesAUniformSkyOverEachFace) {
  const skylit::scene::Site s = site();
  const skylit::scene::Mesh mesh = skylit::scene::load_model(s.model, s.up, s.scale);
  cv::Mat equirect(128, 256, CV_32FC3, cv::Scalar(kRadiance.z(), kRadiance.y(), kRadiance.x()));
  const study::EquirectLights lights = study::equirect_lights(equirect, 1);
  const Vector3d horizontal = study::horizontal_irradiance(lights);
  // The equirect's rows as a midpoint rule in elevation: within 1e-4 of π L.
  EXPECT_LT((horizontal - kPi * kRadiance).norm(), 1e-4 * kPi);
  const std::vector<Vector3d> reference = study::building_reference(lights, s, mesh);
  ASSERT_EQ(reference.size(), mesh.vertex_count());
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    EXPECT_LT((reference[v] - uniform_sky_irradiance(mesh.normals[v])).norm(), 5e-3 * kPi) << "vertex " << v;
  }
}

TEST_F(BuildingLight, TheTransferVectorsGiveTheSameLightAndEachSourceItsCosine) {
  const skylit::scene::Site s = site();
  const skylit::scene::Mesh mesh = skylit::scene::load_model(s.model, s.up, s.scale);
  std::size_t layers = 0;
  const std::vector<float> t = transfer(&layers);
  const std::vector<Vector3d> S(layers, kRadiance);
  // No source: Σ S_i t_{v,i} = L × the face's unoccluded projected solid angle.
  const std::vector<Vector3d> sky_only = study::building_estimate(t, S, {}, s, mesh);
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    EXPECT_LT((sky_only[v] - uniform_sky_irradiance(mesh.normals[v])).norm(), 1e-4 * kPi) << "vertex " << v;
  }
  // A sun 30° up in the east (its disc two cells): the east face and the top get E cos, the
  // others nothing; nothing of the cube shades its own faces.
  study::SourceLight sun;
  sun.direction = Vector3d(std::cos(kPi / 6), 0, std::sin(kPi / 6));
  sun.energy = Vector3d(8, 7, 6);
  sun.disc_directions = {sun.direction, Vector3d(std::cos(kPi / 6), 0.005, std::sin(kPi / 6)).normalized()};
  sun.disc_weights = {0.5, 0.5};
  const std::vector<Vector3d> with_sun = study::building_estimate(t, S, std::vector{sun}, s, mesh);
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const double facing = std::max(0.0, mesh.normals[v].cast<double>().dot(sun.direction));
    EXPECT_LT((with_sun[v] - sky_only[v] - facing * sun.energy).norm(), 1e-5) << "vertex " << v;
  }
  // A sun on the horizon in the east: only the east face (facing it squarely) is lit by it; the
  // top sees it edge-on. The errors are a share of E_h.
  sun.direction = Vector3d(1, 0, 0);
  sun.disc_directions = {sun.direction};
  sun.disc_weights = {1.0};
  const std::vector<Vector3d> horizon = study::building_estimate(t, S, std::vector{sun}, s, mesh);
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const bool east = mesh.normals[v].x() > 0.5;
    EXPECT_LT((horizon[v] - sky_only[v] - (east ? sun.energy : Vector3d::Zero())).norm(), 1e-5) << "vertex " << v;
  }
  const study::Errors e = study::building_errors(horizon, sky_only, kPi * kRadiance);
  EXPECT_NEAR(e.max, 6.0 / (kPi * 0.25), 1e-5) << "the east face's blue: 6 against π × 0.25, each channel against its own";
  const study::Errors half = study::building_errors(sky_only, std::vector<Vector3d>(sky_only.size(), Vector3d::Zero()),
                                                    kPi * kRadiance);
  EXPECT_NEAR(half.max, 1.0, 1e-4) << "the top's error against nothing is the whole horizontal irradiance";
  EXPECT_THROW(study::building_estimate(std::vector<float>(3), S, {}, s, mesh), std::invalid_argument);
}

}  // namespace
