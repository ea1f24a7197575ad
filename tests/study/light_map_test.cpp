// The building with a light map, as the compositor shows it (study::use_light_map), against the
// dense reference at points inside the triangles: the slab under a 2 × 2 × 3 m cube has its
// corners in the open, so that its vertices spread their light over the cube's shadow, where the
// light map's texels each see the cube themselves.
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>

#include "../baker/box_scene.hpp"
#include "../support/quiet_bake.hpp"
#include "../support/temp_dir.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/light_map.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/baker/vertex_fit.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/study/building_light.hpp"

namespace skylit::study_light_map_test {
namespace {

namespace study = skylit::study;
using Eigen::Vector3d;

TEST(StudyLightMap, TheSlabsTexelsCarryTheCubesShadowWhereItsCornersOnlyInterpolate) {
  const skylit::test::TempDir dir("study_light_map");
  const std::filesystem::path site_file = skylit::baker::test::write_cube_on_slab_site(dir.path());
  skylit::test::quiet_bake(site_file, dir.path() / "bake", 16, [](skylit::baker::BakeOptions& o) {
    o.light_map = skylit::baker::LightMapOptions{0.25, 1.0, 0};
  });
  const skylit::scene::Site site = skylit::scene::load_site(site_file);
  const skylit::scene::Mesh mesh = skylit::scene::load_site_model(site);
  const skylit::bake_format::Manifest m = skylit::bake_format::read_manifest(dir.path() / "bake");
  const skylit::bake_format::LightMapLayout layout = skylit::bake_format::read_light_map_layout(dir.path() / "bake", m);
  std::vector<std::size_t> shape;
  const std::vector<float> transfer = skylit::bake_format::read_npy(dir.path() / "bake" / m.transfer_file, &shape);
  const std::vector<float> texels = skylit::bake_format::read_npy(dir.path() / "bake" / m.light_map->transfer_file, &shape);
  // A sky brighter towards the zenith: each face's layer its own radiance.
  std::vector<Vector3d> S;
  for (const skylit::bake_format::FaceRecord& f : m.faces) S.push_back(Vector3d(1.0, 0.9, 0.8) * (0.3 + f.direction.z()));

  // 36 points in each of the slab's two triangles.
  const skylit::baker::FitPoints fit = skylit::baker::fit_points(mesh, 6);
  study::TrianglePoints points;
  for (std::size_t k = 0; k < fit.positions.size(); ++k) {
    const auto triangle = static_cast<std::uint32_t>(k / 36);
    if (mesh.positions[mesh.indices[3 * triangle]].z() != 0.0f || fit.normals[k].z() < 0.99f) continue;  // the slab's
    points.positions.push_back(fit.positions[k]);
    points.normals.push_back(fit.normals[k]);
    points.corners.push_back(fit.corners[k]);
    points.weights.push_back(Vector3d(fit.weights[k][0], fit.weights[k][1], fit.weights[k][2]));
    points.areas.push_back(fit.areas[k]);
    points.triangles.push_back(triangle);
  }
  ASSERT_EQ(points.positions.size(), 72u);
  const study::EquirectLights dome = study::dome_sky_lights(m.plan.frequency, m.plan.basis, S, 4096);
  const std::vector<Vector3d> reference = study::building_reference_at(dome, site, mesh, points);
  const Vector3d horizontal = study::horizontal_irradiance(dome);
  study::InsideTerms shown = study::building_terms_inside(points, transfer, S, {}, false, site, mesh);
  const std::vector<Vector3d> vertices = shown.sky;
  study::use_light_map(points, layout, texels, S, {}, vertices, shown);
  // Points inside the cube see nothing: nobody looks there.
  std::vector<Vector3d> seen_reference, seen_vertices, seen_map;
  for (std::size_t k = 0; k < points.positions.size(); ++k) {
    if (reference[k].isZero(0)) continue;
    seen_reference.push_back(reference[k]);
    seen_vertices.push_back(vertices[k]);
    seen_map.push_back(shown.sky[k]);
  }
  const study::Errors by_vertices = study::building_errors(seen_vertices, seen_reference, horizontal);
  const study::Errors by_map = study::building_errors(seen_map, seen_reference, horizontal);
  std::printf("measured: the slab at %zu points outside the cube: RMS %.4f, max %.4f of E_h from its corners; RMS %.4f, max %.4f "
              "from the light map's 0.25 m texels\n", seen_reference.size(), by_vertices.rms, by_vertices.max, by_map.rms, by_map.max);
  EXPECT_GT(by_vertices.rms, 0.05);
  EXPECT_LT(by_map.rms, 0.02);
  EXPECT_LT(by_map.max, 0.5 * by_vertices.max);
  // The layout's triangles must be the points' model's.
  study::TrianglePoints stray = points;
  stray.triangles[0] = static_cast<std::uint32_t>(mesh.triangle_count());
  EXPECT_THROW(study::use_light_map(stray, layout, texels, S, {}, vertices, shown), std::invalid_argument);
}

}  // namespace
}  // namespace skylit::study_light_map_test
