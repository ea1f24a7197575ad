// SunShadowMap with several separated sources (a sun and lamps): each source's layer is what a
// map drawn for it alone gives, its visibility at the model's vertices agrees with the ray-traced
// area light (baker::area_light_vertex_visibility), the GPU blend sums every source as
// blend::blend_cpu_sources does, and bad counts are InputErrors. "measured:" lines print figures.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "../baker/box_scene.hpp"
#include "../support/gl_suite.hpp"
#include "shadow_scene.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::render {
namespace {

using baker::test::Box;
using baker::test::direction;
using baker::test::mesh_of;
using geom::Vec3;
using test::disc_samples;
using test::ground_plane;
using test::open_sky_basis;

constexpr double kDegrees = std::numbers::pi / 180.0;

class SourceShadows : public skylit::test::GlSuite {};

// A 2 m cube and a 4 m pole, on a ground of 0.25 m quads (vertices to be shadowed), 12 m across.
scene::Mesh lamp_site() {
  scene::Mesh mesh = mesh_of({Box{{-1, -1, 0}, {1, 1, 2}}, Box{{2.5, -3.2, 0}, {2.8, -2.9, 4}}});
  constexpr int kCells = 48;
  const auto first = static_cast<std::uint32_t>(mesh.positions.size());
  for (int row = 0; row <= kCells; ++row) {
    for (int col = 0; col <= kCells; ++col) {
      mesh.positions.emplace_back(-6.0f + 12.0f * col / kCells, -6.0f + 12.0f * row / kCells, 0.0f);
      mesh.normals.emplace_back(0.0f, 0.0f, 1.0f);
    }
  }
  const auto at = [&](int col, int row) { return first + static_cast<std::uint32_t>(row * (kCells + 1) + col); };
  for (int row = 0; row < kCells; ++row) {
    for (int col = 0; col < kCells; ++col) {
      mesh.indices.insert(mesh.indices.end(), {at(col, row), at(col + 1, row), at(col + 1, row + 1), at(col, row),
                                               at(col + 1, row + 1), at(col, row + 1)});
      mesh.triangle_material.insert(mesh.triangle_material.end(), {0u, 0u});
    }
  }
  return mesh;
}

// A sun and two lamps: low and broad, from three sides.
std::vector<ShadowSource> three_sources() {
  return {ShadowSource{direction(40, 135), 0.0047}, ShadowSource{direction(30, 250), 2.0 * kDegrees},
          ShadowSource{direction(55, 20), 4.0 * kDegrees}};
}

SunShadowOptions options_for(int sources) {
  SunShadowOptions options;
  options.resolution = 1024;
  options.max_sources = sources;
  return options;
}

TEST_F(SourceShadows, EachSourceHasItsLayerAsIfDrawnAlone) {
  const scene::Mesh mesh = lamp_site();
  const std::vector<geom::Plane> planes{ground_plane()};
  const std::vector<ShadowSource> sources = three_sources();
  SunShadowMap map(mesh, planes, options_for(3));
  map.update(sources);
  EXPECT_EQ(map.source_count(), 3);
  EXPECT_EQ(map.visibility(0).layers, 3);
  for (std::size_t k = 0; k < sources.size(); ++k) {
    SunShadowMap alone(mesh, planes, options_for(1));
    alone.update(sources[k].direction, sources[k].angular_radius);
    const std::vector<float> expected = alone.read_visibility(0);
    const std::vector<float> layer = map.read_visibility(0, static_cast<int>(k));
    ASSERT_EQ(layer.size(), expected.size());
    int shadowed = 0;
    for (std::size_t t = 0; t < layer.size(); ++t) {
      ASSERT_EQ(layer[t], expected[t]) << "source " << k << ", texel " << t;
      shadowed += layer[t] < 0.5f ? 1 : 0;
    }
    EXPECT_GT(shadowed, 100) << "source " << k << " casts a shadow on the ground";
    EXPECT_EQ(map.read_vertex_visibility(static_cast<int>(k)), alone.read_vertex_visibility(0)) << "source " << k;
    if (k == 0) {
      // The map left for the compositor's per-pixel sun is the sun's.
      EXPECT_TRUE(map.sampling().shadow_from_world.isApprox(alone.sampling().shadow_from_world));
      EXPECT_FLOAT_EQ(map.sampling().tan_angular_radius, alone.sampling().tan_angular_radius);
    }
  }
  // The layers differ: each source's shadow falls on its own side.
  EXPECT_NE(map.read_visibility(0, 1), map.read_visibility(0, 2));
}

TEST_F(SourceShadows, VertexVisibilityAgreesWithTheRayTracer) {
  const scene::Mesh mesh = lamp_site();
  const std::vector<geom::Plane> planes{ground_plane()};
  const std::vector<ShadowSource> sources = three_sources();
  SunShadowMap map(mesh, planes, options_for(3));
  map.update(sources);
  const std::size_t count = mesh.vertex_count();
  for (std::size_t k = 0; k < sources.size(); ++k) {
    const Vec3 w = sources[k].direction.normalized();
    std::vector<Vec3> directions;
    std::vector<double> weights;
    disc_samples(w, sources[k].angular_radius, 256, directions, weights);
    std::vector<float> reference(count);
    baker::area_light_vertex_visibility(mesh, planes, directions, weights, reference);
    const std::vector<float> gpu = map.read_vertex_visibility(static_cast<int>(k));
    ASSERT_EQ(gpu.size(), count);
    // Vertices that face the source and whose reference is plainly lit or in umbra agree.
    int compared = 0, agree = 0, shadowed = 0;
    double error = 0;
    for (std::size_t v = 0; v < count; ++v) {
      if (mesh.normals[v].cast<double>().dot(w) <= 0.05) continue;
      if (reference[v] != 0.0f && reference[v] != 1.0f) continue;
      ++compared;
      shadowed += reference[v] == 0.0f ? 1 : 0;
      error += std::abs(gpu[v] - reference[v]);
      agree += std::abs(gpu[v] - reference[v]) <= 0.1f ? 1 : 0;
    }
    const double share = static_cast<double>(agree) / std::max(compared, 1);
    std::printf("measured: source %zu: %.2f %% of %d lit or umbral vertices agree within 0.1 (%d in umbra), mean |dV| %.4f\n",
                k, 100.0 * share, compared, shadowed, error / std::max(compared, 1));
    EXPECT_GT(shadowed, 20) << "source " << k;
    EXPECT_GE(share, 0.97) << "source " << k;
  }
}

// The extreme of a model vertex inside a wall (a small box buried 0.2 m deep in a thick wall):
// every source's map leaves it dark, as the ray tracer does, whichever side the source is on.
TEST_F(SourceShadows, AVertexInsideAWallIsDarkInEveryMap) {
  scene::Mesh mesh = lamp_site();
  const scene::Mesh walls = mesh_of({Box{{-5, -4, 0}, {-3, 4, 3}}, Box{{-4.8, -0.2, 1}, {-3.2, 0.2, 1.4}}});
  const auto first = static_cast<std::uint32_t>(mesh.positions.size());
  mesh.positions.insert(mesh.positions.end(), walls.positions.begin(), walls.positions.end());
  mesh.normals.insert(mesh.normals.end(), walls.normals.begin(), walls.normals.end());
  for (std::uint32_t index : walls.indices) mesh.indices.push_back(first + index);
  mesh.triangle_material.insert(mesh.triangle_material.end(), walls.triangle_material.begin(), walls.triangle_material.end());
  const std::vector<geom::Plane> planes{ground_plane()};
  const std::vector<ShadowSource> sources = three_sources();
  SunShadowMap map(mesh, planes, options_for(3));
  map.update(sources);
  const std::size_t buried_first = first + 24;  // the second box's 24 vertices
  for (std::size_t k = 0; k < sources.size(); ++k) {
    const std::vector<float> gpu = map.read_vertex_visibility(static_cast<int>(k));
    std::vector<Vec3> directions;
    std::vector<double> weights;
    disc_samples(sources[k].direction, sources[k].angular_radius, 64, directions, weights);
    std::vector<float> reference(mesh.vertex_count());
    baker::area_light_vertex_visibility(mesh, planes, directions, weights, reference);
    int facing = 0;
    for (std::size_t v = buried_first; v < mesh.vertex_count(); ++v) {
      const bool faces_it = mesh.normals[v].cast<double>().dot(sources[k].direction) > 0.05;
      facing += faces_it ? 1 : 0;
      // (A vertex facing away carries no weight: its visibility is 1 by convention.)
      if (faces_it) {
        EXPECT_EQ(reference[v], 0.0f) << "source " << k << ", vertex " << v;
      }
      EXPECT_LE(gpu[v], 0.02f) << "source " << k << ", vertex " << v << " at " << mesh.positions[v].transpose();
    }
    EXPECT_GT(facing, 0) << "some buried faces face source " << k;
  }
}

TEST_F(SourceShadows, BlendSumsEverySourceAsTheCpu) {
  const scene::Mesh mesh = lamp_site();
  const geom::Plane plane = ground_plane();
  const std::vector<geom::Plane> planes{plane};
  const std::vector<ShadowSource> sources = three_sources();
  SunShadowMap map(mesh, planes, options_for(4));  // a spare layer: fewer sources than layers
  map.update(sources);

  // An open sky (B = A) on 40 faces, so that the sources' shadows are all there is.
  const blend::BasisImages basis = open_sky_basis(plane);
  const std::vector<Eigen::Vector3d> S(40, Eigen::Vector3d(0.4, 0.6, 1.0));
  std::vector<blend::SunLight> lights;
  const std::vector<Eigen::Vector3d> energies{{20, 18, 15}, {3, 2.5, 2}, {1.5, 1.5, 1.8}};
  for (std::size_t k = 0; k < sources.size(); ++k) lights.push_back({sources[k].direction, energies[k]});
  const blend::BlendWeights w = blend::blend_weights_sources(basis, S, lights);
  std::vector<std::vector<float>> V;
  for (int k = 0; k < 3; ++k) V.push_back(map.read_visibility(0, k));
  const std::vector<std::span<const float>> V_spans(V.begin(), V.end());
  std::vector<float> expected(3 * basis.texel_count());
  blend::blend_cpu_sources(basis, w, V_spans, expected);

  blend::GpuBlendOptions blend_options;
  blend_options.output = blend::ShadowRatioFormat::Float;
  blend::GpuBlender blender(basis, blend_options);
  ASSERT_TRUE(blender.blend(w, &map.visibility(0)));
  const std::vector<float> T = blender.read_back();
  double worst = 0;
  for (std::size_t t = 0; t < T.size(); ++t) worst = std::max(worst, std::abs(static_cast<double>(T[t]) - expected[t]));
  std::printf("measured: blend of 3 sources with the maps' V: max |T_gpu - T_cpu| = %.3g\n", worst);
  EXPECT_LE(worst, 1e-5);
  // One source fewer lit (a lamp out): still the CPU's sum, and not the three-source result.
  std::vector<blend::SunLight> two(lights.begin(), lights.begin() + 2);
  const blend::BlendWeights w2 = blend::blend_weights_sources(basis, S, two);
  std::vector<float> expected2(3 * basis.texel_count());
  blend::blend_cpu_sources(basis, w2, std::span(V_spans).first(2), expected2);
  ASSERT_TRUE(blender.blend(w2, &map.visibility(0)));
  const std::vector<float> T2 = blender.read_back();
  double worst2 = 0;
  for (std::size_t t = 0; t < T2.size(); ++t) worst2 = std::max(worst2, std::abs(static_cast<double>(T2[t]) - expected2[t]));
  EXPECT_LE(worst2, 1e-5);
  EXPECT_NE(T2, T);
}

// The extremes: a sun on the horizon, a lamp at the zenith (the map's axes switch), a lamp below
// the horizon (behind the ground: it lights nothing there) and a lamp of no size. Every V is a
// number in [0, 1], and the GPU blend still sums as the CPU's.
TEST_F(SourceShadows, SourcesAtTheExtremesStayFiniteAndBlendAsTheCpu) {
  const scene::Mesh mesh = lamp_site();
  const geom::Plane plane = ground_plane();
  const std::vector<geom::Plane> planes{plane};
  const std::vector<ShadowSource> sources{{direction(0.5, 250), 0.0047}, {Vec3::UnitZ(), 3.0 * kDegrees},
                                          {direction(-20, 90), 2.0 * kDegrees}, {direction(45, 45), 0.0}};
  SunShadowMap map(mesh, planes, options_for(4));
  map.update(sources);
  for (int k = 0; k < 4; ++k) {
    for (const std::vector<float>& values : {map.read_visibility(0, k), map.read_vertex_visibility(k)}) {
      for (const float v : values) {
        ASSERT_TRUE(std::isfinite(v)) << "source " << k;
        ASSERT_GE(v, 0.0f) << "source " << k;
        ASSERT_LE(v, 1.0f) << "source " << k;
      }
    }
  }
  // The zenith lamp: the cube's footprint is in its umbra, the open ground lit.
  const std::vector<float> zenith = map.read_visibility(0, 1);
  EXPECT_LT(zenith[static_cast<std::size_t>(48 * 96 + 48)], 0.05f);  // the ground's centre, under the cube
  EXPECT_GT(zenith[static_cast<std::size_t>(5 * 96 + 5)], 0.95f);    // a corner of the ground

  const blend::BasisImages basis = open_sky_basis(plane);
  const std::vector<Eigen::Vector3d> S(40, Eigen::Vector3d(0.4, 0.6, 1.0));
  std::vector<blend::SunLight> lights;
  for (const ShadowSource& source : sources) lights.push_back({source.direction, Eigen::Vector3d(5, 4, 3)});
  const blend::BlendWeights w = blend::blend_weights_sources(basis, S, lights);
  EXPECT_TRUE(w.sources[2].isZero(0)) << "a lamp below the ground lights nothing on it";
  std::vector<std::vector<float>> V;
  for (int k = 0; k < 4; ++k) V.push_back(k == 2 ? std::vector<float>() : map.read_visibility(0, k));
  const std::vector<std::span<const float>> views(V.begin(), V.end());
  std::vector<float> expected(3 * basis.texel_count());
  blend::blend_cpu_sources(basis, w, views, expected);
  blend::GpuBlendOptions blend_options;
  blend_options.output = blend::ShadowRatioFormat::Float;
  blend::GpuBlender blender(basis, blend_options);
  ASSERT_TRUE(blender.blend(w, &map.visibility(0)));
  const std::vector<float> T = blender.read_back();
  double worst = 0;
  for (std::size_t t = 0; t < T.size(); ++t) worst = std::max(worst, std::abs(static_cast<double>(T[t]) - expected[t]));
  EXPECT_LE(worst, 1e-5);
}

TEST_F(SourceShadows, BadCountsAreInputErrors) {
  const scene::Mesh mesh = lamp_site();
  const std::vector<geom::Plane> planes{ground_plane()};
  EXPECT_THROW(SunShadowMap(mesh, planes, options_for(0)), InputError);
  EXPECT_THROW(SunShadowMap(mesh, planes, options_for(blend::kMaxGpuSources + 1)), InputError);
  SunShadowMap map(mesh, planes, options_for(2));
  EXPECT_THROW(map.update(std::vector<ShadowSource>{}), InputError);
  EXPECT_THROW(map.update(three_sources()), InputError);
  std::vector<ShadowSource> bad = three_sources();
  bad.resize(2);
  bad[1].angular_radius = std::nan("");
  EXPECT_THROW(map.update(bad), InputError);
  bad[1] = ShadowSource{Vec3::Zero(), 0.01};
  EXPECT_THROW(map.update(bad), InputError);
  EXPECT_THROW(map.read_visibility(0, 2), InputError);
  EXPECT_THROW(map.read_vertex_visibility(-1), InputError);

  // A blend lit by more sources than the texture has layers.
  const std::vector<ShadowSource> all = three_sources();
  map.update(std::span(all).first(2));
  blend::BasisImages basis;
  basis.name = "ground";
  basis.width = planes[0].width;
  basis.height = planes[0].height;
  basis.layers = 1;
  basis.unoccluded = {1.0};
  basis.half.assign(basis.texel_count(), blend::float_to_half(1.0f));
  basis.normal = planes[0].normal();
  const std::vector<Eigen::Vector3d> S{Eigen::Vector3d(1, 1, 1)};
  std::vector<blend::SunLight> lights;
  for (const ShadowSource& s : all) lights.push_back({s.direction, Eigen::Vector3d(1, 1, 1)});
  blend::GpuBlender blender(basis);
  EXPECT_THROW(blender.blend(blend::blend_weights_sources(basis, S, lights), &map.visibility(0)), InputError);
  EXPECT_NO_THROW(blender.blend(blend::blend_weights_sources(basis, S, std::span(lights).first(2)), &map.visibility(0)));
}

}  // namespace
}  // namespace skylit::render
