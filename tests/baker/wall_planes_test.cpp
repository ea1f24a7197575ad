// baker::find_wall_planes and skylit-bake walls: a large flat face shadowed across its middle gets
// a plane over it, one that a virtual plane covers already does not, nor does an open face; the
// site written with the planes loads, bakes and keeps its model.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "../support/box_site.hpp"
#include "../support/quiet_bake.hpp"
#include "box_scene.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/baker/wall_planes.hpp"
#include "skylit/base/error.hpp"
#include "skylit/scene/site.hpp"

namespace skylit::baker {
namespace wall_planes_test {  // named: the test program is one unity build

// The cube on the slab (box_scene.hpp), its ground plane real: no virtual plane covers the slab.
std::filesystem::path write_site(const std::filesystem::path& dir) {
  const std::filesystem::path site = test::write_cube_on_slab_site(dir);
  std::ofstream(site, std::ios::app) << "    surface: real\n";
  return site;
}

TEST(WallPlanes, AFaceShadowedAcrossItsMiddleGetsAPlaneOverIt) {
  skylit::test::TempDir dir("skylit-walls-");
  const scene::Site site = scene::load_site(write_site(dir.path()));
  const scene::Mesh mesh = scene::load_site_model(site);
  WallPlaneOptions options;
  options.texel = 0.1;
  WallErrorMap map;
  const std::vector<WallPlane> found = find_wall_planes(mesh, site.planes, {}, options, nullptr, &map);
  ASSERT_FALSE(found.empty());
  // The map: per triangle its region's error and the plane over it, as the planes report them.
  ASSERT_EQ(map.error.size(), map.mesh.triangle_count());
  ASSERT_EQ(map.plane.size(), map.mesh.triangle_count());
  for (std::size_t k = 0; k < found.size(); ++k) {
    std::size_t triangles = 0;
    for (std::size_t t = 0; t < map.plane.size(); ++t) {
      if (map.plane[t] != static_cast<int>(k)) continue;
      ++triangles;
      EXPECT_NEAR(map.error[t], found[k].error, 1e-12) << "triangle " << t;
    }
    EXPECT_EQ(triangles, found[k].triangles) << "plane " << k;
  }
  const std::filesystem::path picture = dir.path() / "walls.png";
  write_wall_picture(picture, map, options.min_error);
  std::ifstream png(picture, std::ios::binary);
  char signature[8] = {};
  png.read(signature, 8);
  EXPECT_EQ(std::string(signature + 1, 3), "PNG") << "a PNG picture of the map";
  EXPECT_THROW(write_wall_picture(picture, WallErrorMap{map.mesh, {}, {}}, 0.02), std::invalid_argument);
  // The slab: its two triangles' corners in the open, the cube's shadow across its middle.
  const WallPlane& slab = found.front();
  std::printf("measured: the slab's vertices' error %.4f of E_h (%zu plane(s))\n", slab.error, found.size());
  EXPECT_GT(slab.plane.normal().z(), 0.999);
  EXPECT_NEAR(slab.area, 144.0, 1e-3);
  EXPECT_EQ(slab.triangles, 2u);
  EXPECT_GT(slab.error, 0.05);
  // 1 cm above the slab, over it with a texel of margin, at 0.1 m texels.
  EXPECT_NEAR(slab.plane.origin.z(), 0.01, 1e-6);
  EXPECT_NEAR(slab.plane.u.norm(), 12.2, 1e-4);
  EXPECT_NEAR(slab.plane.v.norm(), 12.2, 1e-4);
  EXPECT_EQ(slab.plane.width, 122);
  EXPECT_EQ(slab.plane.height, 122);
  for (const Eigen::Vector3f& corner : {Eigen::Vector3f(-6, -6, 0), Eigen::Vector3f(6, 6, 0)}) {
    const geom::PlanePoint at = geom::locate_on_plane(slab.plane, corner.cast<double>());
    EXPECT_GT(at.s, 0.0);
    EXPECT_LT(at.s, 1.0);
    EXPECT_GT(at.t, 0.0);
    EXPECT_LT(at.t, 1.0);
    EXPECT_NEAR(at.distance, -0.01, 1e-6);
  }
  // Anything else chosen is a face of the cube (6 m²), fewer than the slab's error.
  for (std::size_t k = 1; k < found.size(); ++k) {
    EXPECT_NEAR(found[k].area, 6.0, 1e-3);
    EXPECT_LE(found[k].error, slab.error);
  }
  // A virtual plane over the slab already: no plane for it.
  for (const WallPlane& w : find_wall_planes(mesh, site.planes, std::vector{slab.plane}, options)) {
    EXPECT_LT(w.plane.normal().z(), 0.999);
  }
  // Faces in the open (the slab alone): nothing varies across them, nothing to add.
  scene::Mesh open = mesh;
  open.indices.resize(6);
  EXPECT_TRUE(find_wall_planes(open, site.planes, {}, options).empty());
  // A region under min_area stays with its vertices.
  options.min_area = 200.0;
  EXPECT_TRUE(find_wall_planes(mesh, site.planes, {}, options).empty());
}

TEST(WallPlanes, OptionsOutOfRangeAreRefusedByName) {
  const scene::Mesh mesh = test::mesh_of({{{0, 0, 0}, {1, 1, 1}}});
  const auto refused = [&](const WallPlaneOptions& o, const char* name) {
    try {
      find_wall_planes(mesh, {}, {}, o);
      ADD_FAILURE() << name << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  WallPlaneOptions o;
  o.count = 0;
  refused(o, "--count");
  o = {};
  o.texel = 0.0;
  refused(o, "--texel");
  o = {};
  o.min_error = -1.0;
  refused(o, "--min-error");
  o = {};
  o.refine.tolerance = -0.1;
  refused(o, "--refine");
}

// skylit-bake walls: the site with its planes, the model's path made relative to the new file, a
// bake of it holding the plane; the site itself is not overwritten.
TEST(WallPlanes, TheSiteWithItsPlanesLoadsAndBakes) {
  skylit::test::TempDir dir("skylit-walls-site-");
  const std::filesystem::path site_file = write_site(dir.path());
  std::filesystem::create_directories(dir.path() / "out");
  const std::filesystem::path out = dir.path() / "out" / "site_walls.yaml";
  WallPlaneOptions options;
  options.texel = 0.25;
  options.count = 1;
  const std::vector<WallPlane> found = add_wall_planes(site_file, out, options, nullptr);
  ASSERT_EQ(found.size(), 1u);
  const scene::Site walls = scene::load_site(out);
  ASSERT_EQ(walls.planes.size(), 2u);
  EXPECT_EQ(walls.planes[1].name, "wall-auto-1");
  EXPECT_EQ(walls.surface_of(1), scene::PlaneSurface::Virtual);
  EXPECT_EQ(walls.surface_of(0), scene::PlaneSurface::Real);
  EXPECT_EQ(walls.planes[1].width, found[0].plane.width);
  EXPECT_EQ(scene::load_site_model(walls).vertex_count(), scene::load_site_model(scene::load_site(site_file)).vertex_count());
  skylit::test::quiet_bake(out, dir.path() / "bake", 1);
  const bake_format::Manifest manifest = bake_format::read_manifest(dir.path() / "bake");
  ASSERT_EQ(manifest.planes.size(), 2u);
  EXPECT_EQ(manifest.planes[1].plane.name, "wall-auto-1");
  EXPECT_THROW(add_wall_planes(site_file, site_file, options, nullptr), InputError);
}

}  // namespace wall_planes_test
}  // namespace skylit::baker
