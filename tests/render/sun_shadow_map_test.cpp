// SunShadowMap against the ray-traced area light (baker::area_light_visibility, Embree): on a
// scene of boxes the sun's shadow lands where the geometry puts it, the penumbra is about as
// wide as the disc makes it, the blend takes the visibility as blend::blend_cpu does, and another
// shader can sample the map through shaders/sun_shadow.glsl. Measured figures are printed
// ("measured:" lines).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../baker/box_scene.hpp"
#include "shadow_scene.hpp"
#include "../support/gl_suite.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/gpu/shader.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/scene/mesh.hpp"
#include "skylit/scene/site.hpp"

namespace skylit::render {
namespace {

using baker::test::Box;
using baker::test::direction;
using baker::test::mesh_of;
using geom::Vec3;
using test::disc_samples;
using test::ground_plane;

constexpr double kDeg = std::numbers::pi / 180.0;

class SunShadow : public skylit::test::GlSuite {};

// A 2 m cube and a 4 m pole on the ground, and a 12 m ground plane (12.5 cm texels) just above it.
scene::Mesh site_mesh() { return mesh_of({Box{{-1, -1, 0}, {1, 1, 2}}, Box{{2.5, -3.2, 0}, {2.8, -2.9, 4}}}); }

struct Agreement {
  double away_from_edges = 0;  // fraction of the texels away from penumbra edges that agree
  int away_count = 0;
  double mean_error = 0;       // over every texel
  int penumbra_reference = 0;  // texels with 0.05 < V < 0.95
  int penumbra_gpu = 0;
  int shadowed = 0;            // texels with V_ref = 0
};

// Texels whose reference V is 0 or 1 and whose neighbours within 2 texels all share it are
// "away from penumbra edges"; there the GPU agrees when it is within 0.1 of the reference.
Agreement compare(const geom::Plane& plane, const std::vector<float>& reference, const std::vector<float>& gpu) {
  Agreement a;
  const int width = plane.width;
  const int height = plane.height;
  const auto at = [&](int col, int row) { return reference[static_cast<std::size_t>(row) * width + col]; };
  int agree = 0;
  double error = 0;
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      const std::size_t k = static_cast<std::size_t>(row) * width + col;
      const float v = reference[k];
      error += std::abs(v - gpu[k]);
      a.penumbra_reference += (v > 0.05f && v < 0.95f) ? 1 : 0;
      a.penumbra_gpu += (gpu[k] > 0.05f && gpu[k] < 0.95f) ? 1 : 0;
      a.shadowed += v == 0.0f ? 1 : 0;
      if (v != 0.0f && v != 1.0f) continue;
      bool uniform = true;
      for (int dr = -2; dr <= 2 && uniform; ++dr) {
        for (int dc = -2; dc <= 2 && uniform; ++dc) {
          const int c = std::clamp(col + dc, 0, width - 1);
          const int r = std::clamp(row + dr, 0, height - 1);
          uniform = at(c, r) == v;
        }
      }
      if (!uniform) continue;
      ++a.away_count;
      agree += std::abs(gpu[k] - v) <= 0.1f ? 1 : 0;
    }
  }
  a.away_from_edges = a.away_count > 0 ? static_cast<double>(agree) / a.away_count : 0.0;
  a.mean_error = error / static_cast<double>(reference.size());
  return a;
}

struct SunCase {
  const char* name;
  double elevation_deg;
  double azimuth_deg;
  double radius_deg;
};

TEST_F(SunShadow, ShadowLandsWhereTheRayTracerPutsIt) {
  const scene::Mesh mesh = site_mesh();
  const geom::Plane plane = ground_plane();
  const std::vector<geom::Plane> planes{plane};
  SunShadowOptions options;
  options.resolution = 1024;
  SunShadowMap map(mesh, planes, options);
  for (const SunCase& sun : {SunCase{"real sun (0.27°), 40° south-east", 40, 135, 0.27},
                             SunCase{"hazy sun (2°), 25° west", 25, 270, 2.0},
                             SunCase{"real sun, 70° north", 70, 10, 0.27}}) {
    SCOPED_TRACE(sun.name);
    const Vec3 centre = direction(sun.elevation_deg, sun.azimuth_deg);
    map.update(centre, sun.radius_deg * kDeg);
    const std::vector<float> gpu = map.read_visibility(0);
    std::vector<Vec3> directions;
    std::vector<double> weights;
    disc_samples(centre, sun.radius_deg * kDeg, 256, directions, weights);
    std::vector<float> reference(gpu.size());
    baker::area_light_visibility(mesh, plane, directions, weights, reference);
    const Agreement a = compare(plane, reference, gpu);
    std::printf("measured: %s: %.2f %% of %d texels away from penumbra edges agree within 0.1; mean |dV| %.4f over all "
                "%zu; penumbra texels (0.05 < V < 0.95) %d ray-traced, %d GPU; %d in full shadow\n",
                sun.name, 100.0 * a.away_from_edges, a.away_count, a.mean_error, gpu.size(), a.penumbra_reference,
                a.penumbra_gpu, a.shadowed);
    EXPECT_GT(a.shadowed, 100) << "the scene must cast a real shadow for the test to mean anything";
    EXPECT_GE(a.away_from_edges, 0.98);
    EXPECT_LE(a.mean_error, 0.03);
    if (sun.radius_deg > 1.0) {
      // A wide disc: the penumbra band is several texels wide, and about as wide on the GPU.
      EXPECT_GT(a.penumbra_reference, 100);
      EXPECT_GT(a.penumbra_gpu, a.penumbra_reference / 2);
      EXPECT_LT(a.penumbra_gpu, a.penumbra_reference * 2);
    }
  }
}

// The sample site under a high sun (up to the midsummer noon of the demo, 78.75°, where the
// map's frame switches its helper axis): the map's visibility of the real ground plane agrees
// with the ray tracer away from penumbra edges, with the default options of the live service.
TEST_F(SunShadow, SampleSiteGroundUnderAHighSun) {
  const scene::Site site = scene::load_site(SKYLIT_SOURCE_DIR "/config/sample_site.yaml");
  const scene::Mesh mesh = scene::load_site_model(site);
  const std::vector<geom::Plane> planes{site.planes.at(0)};
  ASSERT_EQ(planes[0].name, "ground");
  SunShadowMap map(mesh, planes, SunShadowOptions{});
  for (const SunCase& sun : {SunCase{"50° south", 50, 181.7, 0.27}, SunCase{"64° (helper axis switch)", 64.2, 181.7, 0.27},
                             SunCase{"demo noon, 78.75°", 78.75, 181.7, 0.27}, SunCase{"88° south-west", 88, 225, 0.27}}) {
    SCOPED_TRACE(sun.name);
    const Vec3 centre = direction(sun.elevation_deg, sun.azimuth_deg);
    map.update(centre, sun.radius_deg * kDeg);
    const std::vector<float> gpu = map.read_visibility(0);
    std::vector<Vec3> directions;
    std::vector<double> weights;
    disc_samples(centre, sun.radius_deg * kDeg, 64, directions, weights);
    std::vector<float> reference(gpu.size());
    baker::area_light_visibility(mesh, planes[0], directions, weights, reference);
    const Agreement a = compare(planes[0], reference, gpu);
    std::printf("measured: sample site, %s: %.2f %% of %d texels away from penumbra edges agree within 0.1; mean |dV| "
                "%.4f; %d in full shadow\n",
                sun.name, 100.0 * a.away_from_edges, a.away_count, a.mean_error, a.shadowed);
    EXPECT_GT(a.shadowed, 1000);
    EXPECT_GE(a.away_from_edges, 0.995);
    EXPECT_LE(a.mean_error, 0.01);
  }
}

TEST_F(SunShadow, EveryUpdateBumpsTheRevisionAndTheMapCoversTheSite) {
  const scene::Mesh mesh = site_mesh();
  const std::vector<geom::Plane> planes{ground_plane()};
  SunShadowOptions options;
  options.resolution = 256;
  SunShadowMap map(mesh, planes, options);
  map.update(direction(50, 200), 0.0047);
  const std::uint64_t first = map.visibility(0).revision;
  map.update(direction(50, 201), 0.0047);
  EXPECT_GT(map.visibility(0).revision, first);
  EXPECT_EQ(map.visibility(0).width, 96);
  const SunShadowSampling s = map.sampling();
  EXPECT_NE(s.depth_texture, 0u);
  EXPECT_NEAR(s.direction.cast<double>().dot(direction(50, 201)), 1.0, 1e-6);
  // Every corner of the site lands inside the map; the cube's top is nearer the sun than the
  // ground below it.
  for (const Vec3& p : {Vec3(-6, -6, 0.01), Vec3(6, 6, 0.01), Vec3(-6, 6, 0), Vec3(2.8, -2.9, 4)}) {
    const Eigen::Vector4f q = s.shadow_from_world * Eigen::Vector4f(float(p.x()), float(p.y()), float(p.z()), 1.0f);
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_GT(q[axis], 0.0f);
      EXPECT_LT(q[axis], 1.0f);
    }
  }
  const Eigen::Vector4f top = s.shadow_from_world * Eigen::Vector4f(0, 0, 2, 1);
  const Eigen::Vector4f ground = s.shadow_from_world * Eigen::Vector4f(0, 0, 0, 1);
  EXPECT_LT(top.z(), ground.z());
  EXPECT_NEAR(s.texel_m * 256.0, std::sqrt(12.0 * 12.0 * 2.0), 6.0);  // about the site's width across
  EXPECT_GT(s.depth_range_m, 4.0);
}

TEST_F(SunShadow, BlendWithTheMapsVisibilityMatchesTheCpu) {
  const scene::Mesh mesh = site_mesh();
  const geom::Plane plane = ground_plane();
  const std::vector<geom::Plane> planes{plane};
  SunShadowOptions options;
  options.resolution = 512;
  SunShadowMap map(mesh, planes, options);
  const Vec3 sun_direction = direction(35, 160);
  map.update(sun_direction, 0.0047);
  const std::vector<float> V = map.read_visibility(0);

  // An open sky (B = A) on 40 faces, so that the sun's shadow is all there is.
  const blend::BasisImages basis = test::open_sky_basis(plane);
  const std::vector<Eigen::Vector3d> S(40, Eigen::Vector3d(0.4, 0.6, 1.0));
  const blend::BlendWeights w = blend::blend_weights(basis, S, blend::SunLight{sun_direction, Eigen::Vector3d(20, 18, 15)});
  std::vector<float> expected(3 * basis.texel_count());
  blend::blend_cpu(basis, w, V, expected);

  blend::GpuBlendOptions blend_options;
  blend_options.output = blend::ShadowRatioFormat::Float;
  blend::GpuBlender blender(basis, blend_options);
  ASSERT_TRUE(blender.blend(w, &map.visibility(0)));
  const std::vector<float> T = blender.read_back();
  double worst = 0;
  float darkest = 1;
  for (std::size_t k = 0; k < T.size(); ++k) {
    worst = std::max(worst, std::abs(static_cast<double>(T[k]) - expected[k]));
    darkest = std::min(darkest, T[k]);
  }
  std::printf("measured: blend with the shadow map's V: max |T_gpu - T_cpu| = %.3g\n", worst);
  EXPECT_LE(worst, 1e-5);
  EXPECT_LT(darkest, 0.5f) << "the sun's shadow shows in T";
  // A new sun position: the revision changes, so even a generous change threshold blends again.
  map.update(direction(36, 165), 0.0047);
  EXPECT_TRUE(blender.blend(w, &map.visibility(0)));
}

// What the compositor does: a fragment shader with the library appended, sampling the map at
// world points, through bind().
TEST_F(SunShadow, AnotherShaderSamplesTheMapThroughTheLibrary) {
  const scene::Mesh mesh = site_mesh();
  const std::vector<geom::Plane> planes{ground_plane()};
  SunShadowOptions options;
  options.resolution = 512;
  SunShadowMap map(mesh, planes, options);
  const Vec3 sun_direction = direction(45, 180);  // from the south: the cube's shadow falls north
  map.update(sun_direction, 0.0047);

  const std::filesystem::path dir = gpu::find_shader_dir();
  const std::vector<gpu::ShaderSource> sources{
      {GL_VERTEX_SHADER, "point.vert",
       "#version 310 es\nvoid main() { gl_Position = vec4(float(gl_VertexID & 1) * 4.0 - 1.0, "
       "float(gl_VertexID >> 1) * 4.0 - 1.0, 0.0, 1.0); }\n"},
      {GL_FRAGMENT_SHADER, "point.frag + sun_shadow.glsl",
       "#version 310 es\nprecision highp float;\nuniform vec3 point;\nout vec4 colour;\n"
       "float sun_visibility(vec3 world_position);\n"
       "void main() { colour = vec4(sun_visibility(point), 0.0, 0.0, 1.0); }\n" +
           read_file(dir / "sun_shadow.glsl")}};
  const gpu::Program program = gpu::link_program(sources);
  glUseProgram(program.get());
  map.bind(program.get(), 3);

  const gpu::Renderbuffer colour = gpu::make_renderbuffer();
  glBindRenderbuffer(GL_RENDERBUFFER, colour.get());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA32F, 1, 1);
  const gpu::Framebuffer framebuffer = gpu::make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.get());
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour.get());
  gpu::check_framebuffer_complete(GL_FRAMEBUFFER, "test target");
  glViewport(0, 0, 1, 1);
  const gpu::VertexArray empty = gpu::make_vertex_array();
  glBindVertexArray(empty.get());
  const auto visibility_at = [&](const Vec3& p) {
    glUniform3f(glGetUniformLocation(program.get(), "point"), float(p.x()), float(p.y()), float(p.z()));
    glDrawArrays(GL_TRIANGLES, 0, 3);
    float rgba[4] = {-1, -1, -1, -1};
    glReadPixels(0, 0, 1, 1, GL_RGBA, GL_FLOAT, rgba);
    gpu::check_gl_error("sampling the map");
    return rgba[0];
  };
  EXPECT_EQ(visibility_at(Vec3(0, 2.5, 0.01)), 0.0f) << "north of the cube, in its shadow";
  EXPECT_EQ(visibility_at(Vec3(0, -3.0, 0.01)), 1.0f) << "south of the cube, in the sun";
  EXPECT_EQ(visibility_at(Vec3(0, 0, 2.0)), 1.0f) << "the cube's own sunlit top does not shadow itself";
  EXPECT_EQ(visibility_at(Vec3(0, 1.0, 1.0)), 0.0f) << "the cube's north face, turned from the sun";
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

TEST_F(SunShadow, BadInputsAreInputErrors) {
  const scene::Mesh mesh = site_mesh();
  const std::vector<geom::Plane> planes{ground_plane()};
  SunShadowOptions options;
  options.resolution = 8;
  EXPECT_THROW(SunShadowMap(mesh, planes, options), InputError);
  options.resolution = 64;
  SunShadowMap map(mesh, planes, options);
  EXPECT_THROW(map.update(Vec3::Zero(), 0.0047), InputError);
  EXPECT_THROW(map.update(Vec3(0, 0, 1), -0.1), InputError);
  EXPECT_THROW(map.update(Vec3(0, 0, std::nan("")), 0.0047), InputError);
  EXPECT_THROW(map.visibility(1), InputError);
  scene::Mesh broken = mesh;
  broken.indices.push_back(100000);
  broken.indices.push_back(0);
  broken.indices.push_back(1);
  EXPECT_THROW(SunShadowMap(broken, planes, options), InputError);
}

}  // namespace
}  // namespace skylit::render
