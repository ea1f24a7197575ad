// The building's light summed once per sky (render::BuildingIrradiance): against the CPU
// references per vertex and per light-map texel; summed ahead on another thread, it draws exactly
// the frame the compositor draws summing itself, and a compositor takes only sums made for its
// frame's sky and sources; a stereo HMD's second compositor shares the first's.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "../support/gl_suite.hpp"
#include "compose_fixture.hpp"
#include "skylit/bake_format/light_map.hpp"
#include "skylit/baker/light_map.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/render/building_irradiance.hpp"

namespace skylit::building_irradiance_test {
namespace {

using compose_test::BakedSite;
using compose_test::hmd_camera;
using compose_test::hmd_pose;

class BuildingIrradianceTest : public test::GlSuite {};

// The sample bake with a light map over its flat faces (0.25 m texels) whose texels' transfer is a
// pattern in every layer, for the sky and (another) for the ground, the bake's ground layer, and a
// ground albedo: every part of the sum at work.
struct LitBake {
  baker::LightMapPoints map;
  std::vector<float> map_transfer, map_ground, ground;
  render::CompositorOptions options;

  LitBake() {
    const BakedSite& baked = BakedSite::get();
    map = baker::lay_out_light_map(baked.mesh, {0.25, 1.0, 0});
    const std::size_t layers = baked.manifest.layer_count();
    for (std::size_t k = 0; k < map.layout.texels.size(); ++k) {
      const Eigen::Vector3f& p = map.positions[k];
      for (std::size_t l = 0; l < layers; ++l) {
        map_transfer.push_back(static_cast<float>((1.0 + 0.3 * std::sin(2.5 * p.x() + static_cast<double>(l))) / static_cast<double>(layers)));
        map_ground.push_back(static_cast<float>((0.5 + 0.2 * std::cos(1.5 * p.z() + static_cast<double>(l))) / static_cast<double>(layers)));
      }
    }
    std::vector<std::size_t> shape;
    ground = bake_format::read_npy(baked.dir / "bake" / baked.manifest.ground->file, &shape);
    options.ground_albedo = Eigen::Vector3d(0.3, 0.2, 0.1);
    options.ground_transfer = ground;
    options.light_map = {map.layout, map_transfer, map_ground, std::nullopt};
  }
};

render::Compositor make(const render::CompositorOptions& options) {
  const BakedSite& baked = BakedSite::get();
  return render::Compositor(baked.site, baked.mesh, baked.manifest, baked.transfer, hmd_camera(), options);
}

// A sky that differs on every layer, with a NaN and a negative value the sums count as 0.
std::vector<Eigen::Vector3d> patchy_sky(unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> level(0.05, 1.5);
  std::vector<Eigen::Vector3d> sky(BakedSite::get().manifest.layer_count());
  for (Eigen::Vector3d& S : sky) S = Eigen::Vector3d(level(random), level(random), level(random));
  sky[1].x() = std::nan("");
  sky[2].y() = -0.5;
  return sky;
}

TEST_F(BuildingIrradianceTest, ItsSumsAreTheCpuReferencesPerVertexAndPerTexel) {
  const BakedSite& baked = BakedSite::get();
  const LitBake bake;
  const render::Compositor compositor = make(bake.options);
  const std::shared_ptr<const render::BuildingIrradiance> building = compositor.building_irradiance();
  ASSERT_TRUE(building->ground_light());
  ASSERT_NE(building->light_map_layout(), nullptr);
  const std::vector<Eigen::Vector3d> sky = patchy_sky(1);
  const blend::SunLight sun{Eigen::Vector3d(0.3, -0.5, 0.8).normalized(), Eigen::Vector3d(4.0, 3.0, 2.0)};
  const render::SkyIrradiance sums = building->sum(sky, sun, {});
  const std::vector<Eigen::Vector3d> cleaned = building->cleaned_sky(sky);
  EXPECT_EQ(cleaned[1].x(), 0.0);
  EXPECT_EQ(cleaned[2].y(), 0.0);
  EXPECT_EQ(sums.sky, cleaned);

  // Per vertex: blend::vertex_irradiance with no separated source at the vertices (the
  // compositor adds the sun per pixel) and the ground lit by the sky and the sun.
  const blend::GroundLayers layers(baked.manifest.plan.frequency, baked.manifest.plan.basis, baked.manifest.ground->horizontal_unoccluded);
  const std::vector<Eigen::Vector3d> ground_S = layers.coefficients(cleaned, std::span(&sun, 1));
  EXPECT_EQ(sums.ground, ground_S);
  const std::vector<Eigen::Vector3d> expected = blend::vertex_irradiance(
      baked.transfer, cleaned, baked.mesh.normals, {}, {}, blend::GroundLight{bake.ground, ground_S, bake.options.ground_albedo});
  ASSERT_EQ(sums.vertices.size(), 3 * expected.size());
  double worst = 0.0, peak = 0.0;
  for (std::size_t v = 0; v < expected.size(); ++v) {
    for (int c = 0; c < 3; ++c) {
      worst = std::max(worst, std::abs(sums.vertices[3 * v + static_cast<std::size_t>(c)] - expected[v][c]));
      peak = std::max(peak, expected[v][c]);
    }
  }
  ASSERT_GT(peak, 0.01);
  EXPECT_LT(worst, 1e-5 * peak);

  // Per texel: the sky's atlas and the ground's, as bake_format::light_map_atlas sums them.
  const std::vector<Eigen::Vector3d> sky_atlas = bake_format::light_map_atlas(bake.map.layout, bake.map_transfer, cleaned);
  std::vector<Eigen::Vector3d> reflected;
  for (const Eigen::Vector3d& g : ground_S) reflected.push_back(bake.options.ground_albedo.cwiseProduct(g));
  const std::vector<Eigen::Vector3d> ground_atlas = bake_format::light_map_atlas(bake.map.layout, bake.map_ground, reflected);
  ASSERT_EQ(sums.atlas.size(), 4 * sky_atlas.size());
  double atlas_worst = 0.0, atlas_peak = 0.0;
  for (std::size_t x = 0; x < sky_atlas.size(); ++x) {
    for (int c = 0; c < 3; ++c) {
      const double e = sky_atlas[x][c] + ground_atlas[x][c];
      atlas_worst = std::max(atlas_worst, std::abs(sums.atlas[4 * x + static_cast<std::size_t>(c)] - e));
      atlas_peak = std::max(atlas_peak, e);
    }
  }
  ASSERT_GT(atlas_peak, 0.01);
  EXPECT_LT(atlas_worst, 1e-5 * atlas_peak);

  // A sky of the wrong size is refused, naming the field.
  EXPECT_THROW(building->sum(std::span(sky).first(sky.size() - 1), sun, {}), InputError);
}

TEST_F(BuildingIrradianceTest, ACornersNegativeCoefficientIsKeptAndTheSumsAreClampedAtZero) {
  // A corner's (or quadratic's) coefficient may be negative, a fit's undershoot beside a bright
  // spot, and the blend keeps it: so do the building's sums (they were 0.0043 of E_h from the
  // reference on city where taking them as 0 gave 0.0152: bench/RESULTS.md). A sum below 0 is 0.
  // In a faces basis a negative radiance is bad input: taken as 0 and counted.
  const BakedSite& baked = BakedSite::get();
  bake_format::Manifest corners = baked.manifest;
  corners.plan.basis = geom::DomeBasis::Corners;
  const std::size_t layers = corners.layer_count(), vertices = baked.mesh.vertex_count();
  ASSERT_EQ(layers, 3 * baked.manifest.layer_count());
  std::vector<float> transfer(vertices * layers);
  for (std::size_t v = 0; v < vertices; ++v) {
    for (std::size_t l = 0; l < layers; ++l) transfer[v * layers + l] = static_cast<float>(0.5 + 0.5 * std::sin(0.7 * static_cast<double>(v + 3 * l)));
  }
  // Vertex 0 sees only layer 1, whose coefficient is negative in every channel.
  std::fill_n(transfer.begin(), layers, 0.0f);
  transfer[1] = 1.0f;
  std::vector<Eigen::Vector3d> sky(layers, Eigen::Vector3d(0.4, 0.5, 0.6));
  sky[1] = Eigen::Vector3d(-0.2, -0.1, -0.3);
  sky[4] = Eigen::Vector3d(0.3, -0.05, 0.2);
  sky[7].z() = std::numeric_limits<double>::infinity();
  const render::BuildingIrradiance building(baked.mesh, corners, transfer, Eigen::Vector3d::Zero(), {}, {});
  int replaced = 0;
  const std::vector<Eigen::Vector3d> cleaned = building.cleaned_sky(sky, &replaced);
  EXPECT_EQ(replaced, 1) << "only the infinity";
  EXPECT_EQ(cleaned[1], sky[1]);
  EXPECT_EQ(cleaned[7].z(), 0.0);
  const render::SkyIrradiance sums = building.sum(sky, std::nullopt, {});
  double worst = 0.0;
  int clamped = 0;
  for (std::size_t v = 0; v < vertices; ++v) {
    for (int c = 0; c < 3; ++c) {
      double e = 0.0;
      for (std::size_t l = 0; l < layers; ++l) e += cleaned[l][c] * transfer[v * layers + l];
      clamped += e < 0.0 ? 1 : 0;
      worst = std::max(worst, std::abs(sums.vertices[3 * v + static_cast<std::size_t>(c)] - std::max(e, 0.0)));
    }
  }
  EXPECT_EQ(clamped, 3) << "vertex 0's three channels";
  EXPECT_EQ(sums.vertices[0], 0.0f);
  EXPECT_LT(worst, 1e-4);
  // The faces basis: negative radiances are taken as 0 and counted.
  const render::BuildingIrradiance faces(baked.mesh, baked.manifest, baked.transfer, Eigen::Vector3d::Zero(), {}, {});
  std::vector<Eigen::Vector3d> face_sky(baked.manifest.layer_count(), Eigen::Vector3d::Constant(0.5));
  face_sky[2] = Eigen::Vector3d(-0.2, 0.5, -0.1);
  replaced = 0;
  EXPECT_EQ(faces.cleaned_sky(face_sky, &replaced)[2], Eigen::Vector3d(0.0, 0.5, 0.0));
  EXPECT_EQ(replaced, 2);
  // A plane's unoccluded irradiance D_j keeps a negative coefficient as the blend does, and is 0
  // at least.
  bake_format::PlaneRecord plane = baked.manifest.planes.front();
  plane.unoccluded.assign(layers, 0.0);
  plane.unoccluded[1] = 2.0;
  plane.unoccluded[4] = 1.0;
  EXPECT_TRUE(render::plane_irradiance(plane, cleaned, std::nullopt).isZero(0));
  plane.unoccluded[0] = 1.0;
  EXPECT_TRUE(render::plane_irradiance(plane, cleaned, std::nullopt).isApprox(Eigen::Vector3d(0.4 - 0.4 + 0.3, 0.5 - 0.2 - 0.05, 0.6 - 0.6 + 0.2)));
}

TEST_F(BuildingIrradianceTest, SumsMadeAheadOnAnotherThreadDrawTheFrameTheCompositorSumsItself) {
  const LitBake bake;
  render::Compositor summing = make(bake.options);
  render::Compositor ahead = make(bake.options);
  const cv::Mat camera(240, 320, CV_32FC3, cv::Scalar::all(0.05));
  const std::vector<Eigen::Vector3d> first = patchy_sky(2), second = patchy_sky(3);
  const blend::SunLight lamp{Eigen::Vector3d(-0.5, -0.7, 0.5).normalized(), Eigen::Vector3d(2.0, 1.0, 0.5)};
  const std::vector<std::vector<float>> half{std::vector<float>(BakedSite::get().mesh.vertex_count(), 0.5f)};
  const auto draw = [&](render::Compositor& compositor, const std::vector<Eigen::Vector3d>& sky,
                        std::shared_ptr<const render::SkyIrradiance> sums) {
    render::CompositeInput input;
    input.camera = camera;
    input.pose = hmd_pose(4.0, -8.0, 8.0, 40.0);
    input.sky = sky;
    input.lamps = std::span(&lamp, 1);
    input.lamp_vertex_visibility = half;
    input.irradiance = std::move(sums);
    return compositor.composite(input).clone();
  };
  // Summed on a thread of its own, as the live service's sky thread does.
  std::shared_ptr<const render::SkyIrradiance> first_sums, second_sums;
  std::thread sky_thread([&] {
    first_sums = std::make_shared<const render::SkyIrradiance>(ahead.building_irradiance()->sum(first, std::nullopt, std::span(&lamp, 1)));
    second_sums = std::make_shared<const render::SkyIrradiance>(ahead.building_irradiance()->sum(second, std::nullopt, std::span(&lamp, 1)));
  });
  sky_thread.join();

  const cv::Mat expected_first = draw(summing, first, nullptr);
  EXPECT_TRUE(summing.last_stats().building_light_summed);
  const cv::Mat taken_first = draw(ahead, first, first_sums);
  EXPECT_FALSE(ahead.last_stats().building_light_summed) << "the sums made ahead are taken";
  double peak = 0.0;
  cv::minMaxLoc(expected_first.reshape(1), nullptr, &peak);
  ASSERT_GT(peak, 0.1);
  EXPECT_EQ(cv::norm(taken_first, expected_first, cv::NORM_INF), 0.0);
  // The same sky again: nothing to sum, whatever the input brings.
  draw(ahead, first, nullptr);
  EXPECT_FALSE(ahead.last_stats().building_light_summed);
  // A new sky with the previous sky's sums: not taken, the compositor sums; then its own sums.
  const cv::Mat expected_second = draw(summing, second, nullptr);
  EXPECT_GT(cv::norm(expected_second, expected_first, cv::NORM_INF), 0.01) << "the building changed with the sky";
  EXPECT_EQ(cv::norm(draw(ahead, second, first_sums), expected_second, cv::NORM_INF), 0.0);
  EXPECT_TRUE(ahead.last_stats().building_light_summed);
  EXPECT_EQ(cv::norm(draw(ahead, first, first_sums), expected_first, cv::NORM_INF), 0.0);
  EXPECT_FALSE(ahead.last_stats().building_light_summed);
  // Sums of another compositor's building (even of the same bake) are not taken.
  draw(summing, first, nullptr);
  EXPECT_EQ(cv::norm(draw(summing, second, second_sums), expected_second, cv::NORM_INF), 0.0);
  EXPECT_TRUE(summing.last_stats().building_light_summed);
}

TEST_F(BuildingIrradianceTest, AStereoHmdsSecondCompositorSharesTheFirstsSums) {
  const BakedSite& baked = BakedSite::get();
  const LitBake bake;
  render::Compositor left = make(bake.options);
  render::CompositorOptions shared;
  shared.building_irradiance = left.building_irradiance();
  render::Compositor right = make(shared);
  EXPECT_EQ(right.building_irradiance(), left.building_irradiance());
  const cv::Mat camera(240, 320, CV_32FC3, cv::Scalar::all(0.05));
  const std::vector<Eigen::Vector3d> sky = patchy_sky(4);
  const auto draw = [&](render::Compositor& compositor, std::shared_ptr<const render::SkyIrradiance> sums) {
    render::CompositeInput input;
    input.camera = camera;
    input.pose = hmd_pose(4.0, -8.0, 8.0, 40.0);
    input.sky = sky;
    input.irradiance = std::move(sums);
    return compositor.composite(input).clone();
  };
  const auto sums = std::make_shared<const render::SkyIrradiance>(left.building_irradiance()->sum(sky, std::nullopt, {}));
  const cv::Mat from_left = draw(left, sums);
  EXPECT_FALSE(left.last_stats().building_light_summed);
  EXPECT_EQ(cv::norm(draw(right, sums), from_left, cv::NORM_INF), 0.0);
  EXPECT_FALSE(right.last_stats().building_light_summed) << "one sum serves both eyes";
  render::Compositor own = make(bake.options);
  EXPECT_EQ(cv::norm(draw(own, nullptr), from_left, cv::NORM_INF), 0.0);

  // Sums of another model (a vertex more) are refused at construction.
  scene::Mesh other = baked.mesh;
  other.positions.push_back(Eigen::Vector3f::Zero());
  other.normals.push_back(Eigen::Vector3f::UnitZ());
  std::vector<float> other_transfer = baked.transfer;
  other_transfer.resize(other_transfer.size() + baked.manifest.layer_count(), 0.0f);
  render::CompositorOptions mismatched;
  mismatched.building_irradiance =
      std::make_shared<const render::BuildingIrradiance>(other, baked.manifest, other_transfer, Eigen::Vector3d::Zero(),
                                                         std::span<const float>(), bake_format::LightMapArrays{});
  EXPECT_THROW(make(mismatched), std::invalid_argument);
  // And the building's own inputs are checked as the compositor's were.
  EXPECT_THROW(render::BuildingIrradiance(baked.mesh, baked.manifest, std::span(baked.transfer).first(baked.transfer.size() - 1),
                                          Eigen::Vector3d::Zero(), {}, {}),
               InputError);
  EXPECT_THROW(render::BuildingIrradiance(baked.mesh, baked.manifest, baked.transfer, Eigen::Vector3d(0.2, 1.5, 0.2), bake.ground, {}),
               InputError);
}

TEST_F(BuildingIrradianceTest, HalfFloatsSumTheValuesTheyHoldInHalfTheMemory) {
  // render.light_map_precision: half holds the light map's values (either form) as IEEE half
  // floats: its sums are the float sums of those values rounded to half, within 2^-10 of the
  // float sums (each value within 2^-11 of itself), in half the bytes.
  const BakedSite& baked = BakedSite::get();
  const LitBake bake;
  const std::size_t layers = baked.manifest.layer_count();
  const auto rounded = [](std::vector<float> values) {
    for (float& v : values) v = blend::half_to_float(blend::float_to_half(v));
    return values;
  };
  bake_format::LightMapPca pca{bake_format::compress_light_map(bake.map.layout, bake.map_transfer, layers, {4, 0.0, true}),
                               bake_format::compress_light_map(bake.map.layout, bake.map_ground, layers, {4, 0.0, true})};
  bake_format::LightMapPca pca_rounded = pca;
  for (bake_format::LightMapComponents* c : {&pca_rounded.sky, &pca_rounded.ground}) {
    c->weights = rounded(c->weights);
    c->vectors = rounded(c->vectors);
  }
  const std::vector<Eigen::Vector3d> sky = patchy_sky(7);
  const blend::SunLight sun{Eigen::Vector3d(0.2, 0.4, 0.9).normalized(), Eigen::Vector3d(3.0, 3.0, 2.5)};
  const auto sums = [&](bake_format::LightMapArrays arrays, render::LightMapPrecision precision, std::size_t* bytes) {
    const render::BuildingIrradiance building(baked.mesh, baked.manifest, baked.transfer, bake.options.ground_albedo, bake.ground,
                                              std::move(arrays), precision);
    *bytes = building.light_map_bytes();
    return building.sum(sky, sun, {}).atlas;
  };
  const auto largest_difference = [](const std::vector<float>& a, const std::vector<float>& b, double* peak) {
    double worst = 0.0;
    *peak = 0.0;
    for (std::size_t k = 0; k < a.size(); ++k) {
      worst = std::max(worst, std::abs(static_cast<double>(a[k]) - b[k]));
      *peak = std::max(*peak, std::abs(static_cast<double>(b[k])));
    }
    return worst;
  };
  for (const bool in_pca : {false, true}) {
    SCOPED_TRACE(in_pca ? "the PCA form" : "the full form");
    const bake_format::LightMapArrays original = in_pca ? bake_format::LightMapArrays{bake.map.layout, {}, {}, pca}
                                                        : bake_format::LightMapArrays{bake.map.layout, bake.map_transfer, bake.map_ground, std::nullopt};
    const bake_format::LightMapArrays as_half = in_pca ? bake_format::LightMapArrays{bake.map.layout, {}, {}, pca_rounded}
                                                       : bake_format::LightMapArrays{bake.map.layout, rounded(bake.map_transfer),
                                                                                     rounded(bake.map_ground), std::nullopt};
    std::size_t float_bytes = 0, half_bytes = 0, rounded_bytes = 0;
    const std::vector<float> in_float = sums(original, render::LightMapPrecision::Float, &float_bytes);
    const std::vector<float> in_half = sums(original, render::LightMapPrecision::Half, &half_bytes);
    const std::vector<float> of_rounded = sums(as_half, render::LightMapPrecision::Float, &rounded_bytes);
    ASSERT_EQ(in_half.size(), in_float.size());
    EXPECT_EQ(2 * half_bytes, float_bytes);
    EXPECT_GT(half_bytes, 0u);
    double peak = 0.0;
    const double from_rounded = largest_difference(in_half, of_rounded, &peak);
    ASSERT_GT(peak, 0.01);
    EXPECT_LT(from_rounded, 1e-5 * peak);
    const double from_float = largest_difference(in_half, in_float, &peak);
    EXPECT_LT(from_float, std::ldexp(1.0, -10) * peak);
  }

  // A value a half float cannot hold is refused, naming the setting and the fix.
  std::vector<float> huge = bake.map_transfer;
  huge[5] = 1e6f;
  try {
    render::BuildingIrradiance(baked.mesh, baked.manifest, baked.transfer, Eigen::Vector3d::Zero(), {},
                               bake_format::LightMapArrays{bake.map.layout, huge, {}, std::nullopt}, render::LightMapPrecision::Half);
    ADD_FAILURE() << "a value of 1e6 was held in a half float";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("render.light_map_precision: float"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace skylit::building_irradiance_test
