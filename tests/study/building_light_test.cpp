// The building's light against analytic cases: a 2 m cube on the ground under a uniform sky
// (every face unoccluded: π L on its top, π L / 2 on its sides, 0 underneath), through the dense
// reference and through a real bake's transfer vectors, and a separated sun on each face.
#include "skylit/study/building_light.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "../support/box_site.hpp"
#include "../support/quiet_bake.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
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
  const skylit::scene::Mesh mesh = skylit::scene::load_site_model(s);
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

// Inside the triangles: four points per triangle with their face's normal, each lit by the
// uniform sky as its face is, in the reference and in E interpolated from the vertices alike.
TEST_F(BuildingLight, InsideTheTrianglesTheCubesFacesAreLitAsAtTheirVertices) {
  const skylit::scene::Site s = site();
  const skylit::scene::Mesh mesh = skylit::scene::load_site_model(s);
  const study::TrianglePoints points = study::triangle_points(mesh);
  ASSERT_EQ(points.positions.size(), 4 * mesh.triangle_count());
  for (std::size_t k = 0; k < points.weights.size(); ++k) EXPECT_NEAR(points.weights[k].sum(), 1.0, 1e-12);
  cv::Mat equirect(128, 256, CV_32FC3, cv::Scalar(kRadiance.z(), kRadiance.y(), kRadiance.x()));
  const study::EquirectLights lights = study::equirect_lights(equirect, 1);
  const std::vector<Vector3d> reference = study::building_reference_at(lights, s, mesh, points);
  const std::vector<Vector3d> interpolated = study::interpolated_at(points, study::building_reference(lights, s, mesh));
  ASSERT_EQ(reference.size(), points.positions.size());
  for (std::size_t k = 0; k < points.positions.size(); ++k) {
    const Vector3d expected = uniform_sky_irradiance(points.normals[k]);
    EXPECT_LT((reference[k] - expected).norm(), 5e-3 * kPi) << "point " << k;
    EXPECT_LT((interpolated[k] - expected).norm(), 5e-3 * kPi) << "point " << k;
  }
  const study::Errors inside = study::building_errors(interpolated, reference, study::horizontal_irradiance(lights));
  EXPECT_LT(inside.max, 5e-3);
}

// With a spacing, a large triangle is split into m² equal ones first: the points' areas still sum
// to each triangle's area, every point lies inside its triangle, and their barycentric centroid
// is the triangle's (the split is symmetric).
TEST_F(BuildingLight, PointsAtASpacingCoverEachTriangleEvenly) {
  const skylit::scene::Mesh mesh = skylit::scene::load_site_model(site());
  const study::TrianglePoints coarse = study::triangle_points(mesh);
  for (const double spacing : {0.25, 0.7}) {
    SCOPED_TRACE(spacing);
    const study::TrianglePoints points = study::triangle_points(mesh, spacing);
    std::vector<double> area(mesh.triangle_count(), 0.0);
    std::vector<Vector3d> centroid(mesh.triangle_count(), Vector3d::Zero());
    std::vector<std::size_t> count(mesh.triangle_count(), 0);
    for (std::size_t k = 0; k < points.positions.size(); ++k) {
      const std::uint32_t t = points.triangles[k];
      area[t] += points.areas[k];
      centroid[t] += points.weights[k];
      ++count[t];
      EXPECT_NEAR(points.weights[k].sum(), 1.0, 1e-12);
      EXPECT_GT(points.weights[k].minCoeff(), 0.0) << "point " << k << " lies inside its triangle";
    }
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
      const Eigen::Vector3f a = mesh.positions[mesh.indices[3 * t]], b = mesh.positions[mesh.indices[3 * t + 1]],
                            c = mesh.positions[mesh.indices[3 * t + 2]];
      const double triangle_area = 0.5 * (b - a).cross(c - a).norm();
      const auto m = static_cast<std::size_t>(std::max(1.0, std::ceil(std::sqrt(2.0 * triangle_area) / spacing - 1e-9)));
      EXPECT_EQ(count[t], 4 * m * m) << "triangle " << t;
      EXPECT_NEAR(area[t], triangle_area, 1e-5) << "triangle " << t;
      EXPECT_LT((centroid[t] / static_cast<double>(count[t]) - Vector3d::Constant(1.0 / 3.0)).norm(), 1e-9) << "triangle " << t;
    }
    EXPECT_GT(points.positions.size(), coarse.positions.size());
  }
}

TEST_F(BuildingLight, TheTransferVectorsGiveTheSameLightAndEachSourceItsCosine) {
  const skylit::scene::Site s = site();
  const skylit::scene::Mesh mesh = skylit::scene::load_site_model(s);
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
  // The same at points inside the triangles, per point as the compositor takes the sun.
  const study::TrianglePoints points = study::triangle_points(mesh);
  const std::vector<Vector3d> at_points = study::source_term_at(points, sun, s, mesh);
  ASSERT_EQ(at_points.size(), points.positions.size());
  for (std::size_t k = 0; k < at_points.size(); ++k) {
    const double facing = std::max(0.0, points.normals[k].cast<double>().dot(sun.direction));
    EXPECT_LT((at_points[k] - facing * sun.energy).norm(), 1e-9) << "point " << k;
  }
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

// The dome's own sky traced at a point is the transfer sum there: a sky that differs per layer
// (each layer its own radiance), at the cube's vertices, within 1% of E_h (4096 directions
// against the bake's quadrature).
TEST_F(BuildingLight, TheDomesOwnSkyTracedAtAVertexIsItsTransferSum) {
  const skylit::scene::Site s = site();
  const skylit::scene::Mesh mesh = skylit::scene::load_site_model(s);
  std::size_t layers = 0;
  const std::vector<float> t = transfer(&layers);
  std::vector<Vector3d> S(layers);
  for (std::size_t l = 0; l < layers; ++l) S[l] = kRadiance * (1.0 + 0.1 * static_cast<double>(l));
  const study::EquirectLights dome = study::dome_sky_lights(s.dome_frequency, s.dome_basis, S, 4096);
  const std::vector<Vector3d> traced = study::building_reference(dome, s, mesh);
  const std::vector<Vector3d> summed = study::building_estimate(t, S, {}, s, mesh);
  const study::Errors e = study::building_errors(traced, summed, study::horizontal_irradiance(dome));
  EXPECT_LT(e.max, 0.01);
  EXPECT_THROW(study::dome_sky_lights(s.dome_frequency, s.dome_basis, std::vector<Vector3d>(layers + 1), 64), std::invalid_argument);
}

// The ground's light (albedo ρ, RGB) on the cube: the bake's ground layer against the reference's
// ground, which takes the irradiance at each ground point from the dense reference of a fine
// ground plane (the cube's shadow on it), under the uniform sky and with a sun 35° up in the east.
// The cube's underside lies on the ground it covers: no ground light in either.
TEST_F(BuildingLight, TheGroundLayerLightsTheCubeAsTheReferencesGroundDoes) {
  const skylit::scene::Site s = site();
  const skylit::scene::Mesh mesh = skylit::scene::load_site_model(s);
  const skylit::bake_format::Manifest manifest = skylit::bake_format::read_manifest(dir_->path() / "bake");
  ASSERT_TRUE(manifest.ground.has_value()) << "skylit-bake makes the ground layer by default";
  std::size_t layers = 0;
  const std::vector<float> t = transfer(&layers);
  std::vector<std::size_t> shape;
  const std::vector<float> tg = skylit::bake_format::read_npy(dir_->path() / "bake" / manifest.ground->file, &shape);
  ASSERT_EQ(tg.size(), t.size());
  const skylit::blend::GroundLayers ground_layers(manifest.plan.frequency, manifest.plan.basis, manifest.ground->horizontal_unoccluded);
  const Vector3d albedo(0.2, 0.3, 0.4);
  skylit::scene::Site fine = s;
  fine.planes = {s.planes.front()};
  fine.planes.front().origin.z() = 0.0;
  fine.planes.front().width = fine.planes.front().height = 120;  // 10 cm texels

  cv::Mat equirect(128, 256, CV_32FC3, cv::Scalar(kRadiance.z(), kRadiance.y(), kRadiance.x()));
  study::EquirectLights lights = study::equirect_lights(equirect, 1);
  const std::vector<Vector3d> S(layers, kRadiance);
  study::SourceLight sun;
  sun.direction = Vector3d(std::cos(35 * kPi / 180), 0, std::sin(35 * kPi / 180));
  sun.energy = Vector3d(6, 6, 6);
  sun.disc_directions = {sun.direction};
  sun.disc_weights = {1.0};
  for (const bool with_sun : {false, true}) {
    if (with_sun) {
      lights.directions.push_back(sun.direction);
      lights.weights.push_back(sun.energy);
    }
    const study::DenseReference dense = study::dense_reference(lights, fine, mesh);
    study::GroundReferenceOptions options;
    options.albedo = albedo;
    options.shadow_plane = &fine.planes.front();
    options.shadow_ratio = dense.planes.front();
    const std::vector<Vector3d> reference = study::ground_reference(lights, s, mesh, options);
    const std::vector<study::SourceLight> sources = with_sun ? std::vector{sun} : std::vector<study::SourceLight>{};
    std::vector<skylit::blend::SunLight> source_lights;
    for (const study::SourceLight& l : sources) source_lights.push_back({l.direction, l.energy});
    skylit::blend::GroundLight ground{tg, ground_layers.coefficients(S, source_lights), albedo};
    const std::vector<Vector3d> without = study::building_estimate(t, S, sources, s, mesh);
    const std::vector<Vector3d> with = study::building_estimate(t, S, sources, s, mesh, ground);
    const Vector3d horizontal = study::horizontal_irradiance(lights);
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
      const Vector3d estimate = with[v] - without[v];
      const Eigen::Vector3f& n = mesh.normals[v];
      if (n.z() < -0.5f) {
        EXPECT_EQ(estimate, Vector3d::Zero()) << "the underside, vertex " << v;
        EXPECT_EQ(reference[v], Vector3d::Zero()) << "the underside, vertex " << v;
      } else if (n.z() > 0.5f) {
        EXPECT_EQ(estimate, Vector3d::Zero()) << "the top faces away from the ground, vertex " << v;
      } else {
        // A side sees half the ground; the cube's shadow there takes some of its light.
        const Vector3d unshadowed = albedo.cwiseProduct(horizontal) / kPi * (kPi / 2);
        EXPECT_LT(reference[v].x(), unshadowed.x()) << "vertex " << v;
        // At the foot (z = 0) a vertex's view of the ground shrinks to the line it stands on,
        // where the ground's light jumps from the cube's dark footprint to the open ground: the
        // bake's grid (0.5 m) and the reference's texels (0.1 m) take that limit differently.
        // Above it, the sun's shadow on the ground is as sharp as the ν = 2 dome's faces.
        const bool foot = mesh.positions[v].z() < 0.01f;
        // With the sun the cube's shadow edge runs through the foot's corners, where neither
        // takes that limit exactly: the feet are held to the sky alone. Tolerances as shares of
        // what the ground reflects, ρ E_h.
        if (foot && with_sun) continue;
        const double tolerance = foot ? 0.05 : (with_sun ? 0.04 : 0.01);
        for (int c = 0; c < 3; ++c) {
          EXPECT_NEAR(estimate[c], reference[v][c], tolerance * albedo[c] * horizontal[c])
              << (with_sun ? "with the sun, " : "") << "vertex " << v << " at " << mesh.positions[v].transpose()
              << " normal " << n.transpose() << " channel " << c;
        }
      }
    }
  }
}

// The extremes: a sun behind another block (the cube's east face in its shadow) and a model
// vertex inside a wall (a small cube buried in the block): the shadowed face gets no sun, the
// buried vertices no light at all, in the estimate and the reference alike.
TEST(BuildingLightExtremes, ASourceBehindABlockAndVerticesInsideAWall) {
  skylit::test::TempDir dir("building_extremes");
  const auto cube = [](std::ofstream& obj, int first, const Vector3d& lo, const Vector3d& hi) {
    for (int k = 0; k < 8; ++k) {
      obj << "v " << (k & 1 ? hi.x() : lo.x()) << " " << (k & 2 ? hi.y() : lo.y()) << " " << (k & 4 ? hi.z() : lo.z()) << "\n";
    }
    // Faces counter-clockwise seen from outside (vertex k: bit 0 x, bit 1 y, bit 2 z).
    const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : faces) obj << "f " << first + f[0] << " " << first + f[1] << " " << first + f[2] << " " << first + f[3] << "\n";
  };
  {
    std::ofstream obj(dir.path() / "blocks.obj");
    cube(obj, 1, {-1, -1, 0}, {1, 1, 2});            // the building
    cube(obj, 9, {2, -3, 0}, {2.5, 3, 4});           // a block 1 m east of it, 4 m tall
    cube(obj, 17, {2.1, -0.2, 1}, {2.4, 0.2, 1.4});  // buried in the block
  }
  std::ofstream(dir.path() / "site.yaml") << "scene:\n  model: blocks.obj\n  up: z\n  scale: 1\ndome:\n  frequency: 2\nplanes:\n"
                                             "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                             "    v: [0, 12, 0]\n    resolution: [8, 8]\n";
  skylit::test::quiet_bake(dir.path() / "site.yaml", dir.path() / "bake", 16);
  const skylit::scene::Site s = skylit::scene::load_site(dir.path() / "site.yaml");
  const skylit::scene::Mesh mesh = skylit::scene::load_site_model(s);
  const skylit::bake_format::Manifest manifest = skylit::bake_format::read_manifest(dir.path() / "bake");
  std::vector<std::size_t> shape;
  const std::vector<float> t = skylit::bake_format::read_npy(dir.path() / "bake" / manifest.transfer_file, &shape);
  const std::vector<Vector3d> S(shape.at(1), kRadiance);
  study::SourceLight sun;
  sun.direction = Vector3d(std::cos(kPi / 9), 0, std::sin(kPi / 9));  // 20° up in the east
  sun.energy = Vector3d(5, 5, 5);
  sun.disc_directions = {sun.direction};
  sun.disc_weights = {1.0};
  const std::vector<Vector3d> sky_only = study::building_estimate(t, S, {}, s, mesh);
  const std::vector<Vector3d> with_sun = study::building_estimate(t, S, std::vector{sun}, s, mesh);
  cv::Mat equirect(128, 256, CV_32FC3, cv::Scalar(kRadiance.z(), kRadiance.y(), kRadiance.x()));
  const std::vector<Vector3d> reference = study::building_reference(study::equirect_lights(equirect, 1), s, mesh);
  int shaded = 0, buried = 0;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const Eigen::Vector3f& p = mesh.positions[v];
    if (p.x() > 2.05f && p.x() < 2.45f && p.z() > 0.95f && p.z() < 1.45f) {
      ++buried;
      EXPECT_EQ(with_sun[v], Vector3d::Zero()) << "a vertex inside the block gets no light: " << p.transpose();
      EXPECT_EQ(reference[v], Vector3d::Zero()) << p.transpose();
    } else if (p.x() == 1.0f && mesh.normals[v].x() > 0.5f) {
      ++shaded;
      EXPECT_LT((with_sun[v] - sky_only[v]).norm(), 1e-9) << "the east face is in the block's shadow: " << p.transpose();
      // The block hides part of its sky; the reference and the transfer agree on how much.
      EXPECT_LT(reference[v].x(), 0.9 * kPi / 2 * kRadiance.x()) << p.transpose();
      EXPECT_NEAR(sky_only[v].x(), reference[v].x(), 0.05 * kPi * kRadiance.x()) << p.transpose();
    }
  }
  // As the OBJ loader gives them: a quad's two triangles keep their own corners (6 per face).
  EXPECT_EQ(shaded, 6);
  EXPECT_EQ(buried, 36);
}

// The compositor's rule for a virtual plane covering a fragment, at the study's points: within
// 5 cm, the normal within 15°, inside the rectangle, the nearest plane; T read bilinearly.
TEST(PlaneCover, PointsTakeTheNearestCoveringPlaneAndItsBilinearRatio) {
  skylit::geom::Plane wall{"wall", Vector3d(0, 0, 0), Vector3d(4, 0, 0), Vector3d(0, 0, 2), 2, 1};  // normal −y
  skylit::geom::Plane nearer = wall;
  nearer.origin.y() = -0.04;
  nearer.u.x() = 1;  // covers x in [0, 1] only
  study::TrianglePoints points;
  const auto add = [&](Eigen::Vector3f p, Eigen::Vector3f n) {
    points.positions.push_back(p);
    points.normals.push_back(n.normalized());
  };
  const Eigen::Vector3f facing(0, -1, 0);
  add({1.0f, -0.01f, 1.0f}, facing);                     // on the wall
  add({0.5f, -0.03f, 1.0f}, facing);                     // nearer to the narrow plane
  add({2.0f, -0.06f, 1.0f}, facing);                     // 6 cm off the wall
  add({5.0f, 0.0f, 1.0f}, facing);                       // beyond its edge
  add({1.0f, 0.0f, 1.0f}, Eigen::Vector3f(0, -1, 0.3));  // turned 16.7°
  add({1.0f, 0.0f, 1.0f}, Eigen::Vector3f(0, -1, 0.25)); // turned 14.0°
  const std::vector<study::PlaneCover> cover = study::covering_planes(points, std::vector{wall, nearer});
  ASSERT_EQ(cover.size(), 6u);
  EXPECT_EQ(cover[0].plane, 0);
  EXPECT_NEAR(cover[0].s, 0.25, 1e-6);
  EXPECT_NEAR(cover[0].t, 0.5, 1e-6);
  EXPECT_EQ(cover[1].plane, 1);
  EXPECT_EQ(cover[2].plane, -1);
  EXPECT_EQ(cover[3].plane, -1);
  EXPECT_EQ(cover[4].plane, -1);
  EXPECT_EQ(cover[5].plane, 0);
  // Two texels, 0.2 and 0.6 (and a NaN in blue, read as 1): at their centres, between them, and
  // clamped beyond.
  const std::vector<float> T{0.2f, 0.2f, std::nanf(""), 0.6f, 0.6f, 0.6f};
  EXPECT_NEAR(study::bilinear_ratio(T, 2, 1, 0.25, 0.5).x(), 0.2, 1e-6);
  EXPECT_NEAR(study::bilinear_ratio(T, 2, 1, 0.5, 0.5).x(), 0.4, 1e-6);
  EXPECT_NEAR(study::bilinear_ratio(T, 2, 1, 1.0, 0.5).x(), 0.6, 1e-6);
  EXPECT_NEAR(study::bilinear_ratio(T, 2, 1, 0.0, 0.0).z(), 1.0, 1e-6);
  EXPECT_THROW(study::bilinear_ratio(T, 2, 2, 0.5, 0.5), std::invalid_argument);
  // shown_inside: the covered point takes T D plus its ground term, the others their terms' sum.
  study::InsideTerms terms;
  for (std::size_t k = 0; k < points.positions.size(); ++k) {
    terms.sky.push_back(Vector3d::Constant(1.0));
    terms.sun.push_back(Vector3d::Constant(2.0));
    terms.ground.push_back(Vector3d::Constant(0.5));
  }
  const Vector3d D(10, 20, 30);
  const std::vector<study::PlaneShading> shading{{wall, T, D}};
  const std::vector<Vector3d> shown = study::shown_inside(points, terms, shading);
  const Vector3d covered = study::bilinear_ratio(T, 2, 1, 0.25, 0.5).cwiseProduct(D) + Vector3d::Constant(0.5);
  EXPECT_LT((shown[0] - covered).norm(), 1e-9);
  EXPECT_LT((shown[2] - Vector3d::Constant(3.5)).norm(), 1e-12);
}

}  // namespace
