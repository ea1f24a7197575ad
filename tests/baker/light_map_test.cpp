// baker::lay_out_light_map and a bake with a light map: charts over the flat faces, every lookup
// on a face reading its own chart's traced texels, texels off the faces moved onto them, texels
// inside another part filled from their neighbours; the bake's texels see what a vertex at their
// place would see.
#include "skylit/baker/light_map.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "../support/quiet_bake.hpp"
#include "../support/temp_dir.hpp"
#include "box_scene.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/light_map.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/base/error.hpp"
#include "skylit/scene/site.hpp"

namespace skylit::baker {
namespace light_map_test {  // named: the test program is one unity build

using Eigen::Vector2d;
using Eigen::Vector3d;

// The chart whose rectangle holds atlas texel `index`, or −1.
int chart_at(const bake_format::LightMapLayout& l, std::uint32_t index) {
  const int column = static_cast<int>(index) % l.width, row = static_cast<int>(index) / l.width;
  for (std::size_t c = 0; c < l.charts.size(); ++c) {
    const bake_format::LightMapChart& f = l.charts[c];
    if (column >= f.x && column < f.x + f.width && row >= f.y && row < f.y + f.height) return static_cast<int>(c);
  }
  return -1;
}

// Lookups anywhere on the faces (66 points per triangle) read four traced texels of their own
// chart; the count checked.
int lookups_read_their_charts_traced_texels(const scene::Mesh& mesh, const bake_format::LightMapLayout& l) {
  const std::set<std::uint32_t> traced(l.texels.begin(), l.texels.end());
  int lookups = 0;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const int c = l.triangle_chart[t];
    if (c < 0) continue;
    for (int i = 0; i <= 10; ++i) {
      for (int j = 0; i + j <= 10; ++j) {
        const double b0 = i / 10.0, b1 = j / 10.0, b2 = 1.0 - b0 - b1;
        const Vector3d p = b0 * mesh.positions[mesh.indices[3 * t]].cast<double>() + b1 * mesh.positions[mesh.indices[3 * t + 1]].cast<double>() +
                           b2 * mesh.positions[mesh.indices[3 * t + 2]].cast<double>();
        const Vector2d a = l.atlas_coordinates(c, p);
        const int x0 = static_cast<int>(std::floor(a.x() - 0.5)), y0 = static_cast<int>(std::floor(a.y() - 0.5));
        for (const auto& [dx, dy] : {std::pair{0, 0}, {1, 0}, {0, 1}, {1, 1}}) {
          const auto index = static_cast<std::uint32_t>((y0 + dy) * l.width + x0 + dx);
          EXPECT_EQ(chart_at(l, index), c) << "triangle " << t << " reads another chart at " << a.transpose();
          EXPECT_TRUE(traced.count(index)) << "triangle " << t << " reads an untraced texel at " << a.transpose();
        }
        ++lookups;
      }
    }
  }
  return lookups;
}

TEST(LightMap, ChartsCoverTheFlatFacesAndEveryLookupOnThemReadsItsOwnChartsTracedTexels) {
  skylit::test::TempDir dir("skylit-light-map-");
  const scene::Mesh mesh = scene::load_site_model(scene::load_site(test::write_cube_on_slab_site(dir.path())));
  const LightMapPoints lm = lay_out_light_map(mesh, {0.25, 1.0, 0});
  const bake_format::LightMapLayout& l = lm.layout;
  // The slab, the cube's four sides and its top: six flat regions of at least 1 m².
  ASSERT_EQ(l.charts.size(), 6u);
  ASSERT_EQ(l.triangle_chart.size(), mesh.triangle_count());
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) EXPECT_GE(l.triangle_chart[t], 0) << "triangle " << t;
  // The slab spans 12 m: 48 texels and one beyond each edge.
  const auto slab = static_cast<std::size_t>(l.triangle_chart[0]);
  EXPECT_EQ(l.charts[slab].width, 50);
  EXPECT_EQ(l.charts[slab].height, 50);
  // Charts inside the atlas and apart.
  std::vector<int> owner(static_cast<std::size_t>(l.width) * static_cast<std::size_t>(l.height), -1);
  for (std::size_t c = 0; c < l.charts.size(); ++c) {
    const bake_format::LightMapChart& f = l.charts[c];
    ASSERT_LE(f.x + f.width, l.width);
    ASSERT_LE(f.y + f.height, l.height);
    for (int j = 0; j < f.height; ++j) {
      for (int i = 0; i < f.width; ++i) {
        int& o = owner[static_cast<std::size_t>((f.y + j) * l.width + f.x + i)];
        EXPECT_EQ(o, -1) << "charts " << o << " and " << c << " overlap";
        o = static_cast<int>(c);
      }
    }
  }
  // Traced texels in atlas order, each on its chart's faces: in the chart's plane, and no farther
  // from its texel centre than a lookup reaches.
  ASSERT_EQ(lm.positions.size(), l.texels.size());
  EXPECT_TRUE(std::is_sorted(l.texels.begin(), l.texels.end()));
  std::size_t moved = 0;
  for (std::size_t k = 0; k < l.texels.size(); ++k) {
    const int c = chart_at(l, l.texels[k]);
    ASSERT_GE(c, 0);
    const bake_format::LightMapChart& f = l.charts[static_cast<std::size_t>(c)];
    const Vector3d p = lm.positions[k].cast<double>();
    EXPECT_NEAR((p - f.origin).dot(f.u.cross(f.v)), 0.0, 1e-4) << "texel " << k;
    const Vector2d a = l.atlas_coordinates(c, p);
    const Vector2d centre(l.texels[k] % static_cast<std::uint32_t>(l.width) + 0.5, l.texels[k] / static_cast<std::uint32_t>(l.width) + 0.5);
    EXPECT_LE((a - centre).norm(), std::sqrt(2.0) + 1e-6) << "texel " << k;
    if ((a - centre).norm() > 1e-3) ++moved;
    EXPECT_NEAR(lm.normals[k].cast<double>().dot(f.u.cross(f.v)), 1.0, 1e-6);
  }
  // The ring of texels around each chart, and no other: the slab's 50² − 48², each side's
  // 10 × 14 − 8 × 12, the top's 10² − 8².
  EXPECT_EQ(moved, 196u + 4 * 44u + 36u) << "the texels beyond the faces' edges are moved onto them, the others stay";
  const int lookups = lookups_read_their_charts_traced_texels(mesh, l);
  std::printf("measured: %zu charts in a %d×%d atlas, %zu texels traced (%zu moved onto the faces), %d lookups checked\n",
              l.charts.size(), l.width, l.height, l.texels.size(), moved, lookups);
  // With min_across 10 texels, the cube's 2 m sides take 0.2 m texels across (10 of them) and
  // 0.25 m up its 3 m; its top 0.2 m both ways; the slab keeps 0.25 m.
  const LightMapPoints fine = lay_out_light_map(mesh, {0.25, 1.0, 10});
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const bake_format::LightMapChart& f = fine.layout.charts[static_cast<std::size_t>(fine.layout.triangle_chart[t])];
    const bool side = t >= 2 && t < 10;
    EXPECT_DOUBLE_EQ(std::max(f.texel_u, f.texel_v), t < 2 || side ? 0.25 : 0.2) << "triangle " << t;
    EXPECT_DOUBLE_EQ(std::min(f.texel_u, f.texel_v), t < 2 ? 0.25 : 0.2) << "triangle " << t;
  }
  EXPECT_GT(lookups_read_their_charts_traced_texels(mesh, fine.layout), 0);
  EXPECT_THROW(lay_out_light_map(mesh, {0.25, 1.0, -1}), InputError);
  // A smaller region than min_area stays with its vertices: with 10 m², only the slab.
  const LightMapPoints slab_only = lay_out_light_map(mesh, {0.25, 10.0, 0});
  EXPECT_EQ(slab_only.layout.charts.size(), 1u);
  EXPECT_EQ(std::count(slab_only.layout.triangle_chart.begin(), slab_only.layout.triangle_chart.end(), -1),
            static_cast<std::ptrdiff_t>(mesh.triangle_count() - 2));
  const LightMapPoints none = lay_out_light_map(mesh, {0.25, 1000.0, 0});
  EXPECT_TRUE(none.layout.charts.empty());
  EXPECT_TRUE(none.layout.texels.empty());
  EXPECT_THROW(lay_out_light_map(mesh, {0.0, 1.0, 0}), InputError);
  EXPECT_THROW(lay_out_light_map(mesh, {0.25, -1.0, 0}), InputError);
  EXPECT_THROW(lay_out_light_map(mesh, {0.0005, 1.0, 0}), InputError) << "a texel the atlas cannot hold";
}

TEST(LightMap, TexelsThatSawNothingTakeTheMeanOfTheirChartNeighboursThatDid) {
  // Two 3 × 3 charts side by side; the first's middle texel saw nothing.
  bake_format::LightMapLayout l;
  l.texel = 0.1;
  l.width = 6;
  l.height = 3;
  l.charts = {{0, 0, 3, 3, Vector3d::Zero(), Vector3d::UnitX(), Vector3d::UnitY()},
              {3, 0, 3, 3, Vector3d::Zero(), Vector3d::UnitX(), Vector3d::UnitY()}};
  for (std::uint32_t k = 0; k < 18; ++k) l.texels.push_back(k);
  const std::size_t layers = 2;
  std::vector<float> values(18 * layers), ground(18 * layers, 0.0f);
  for (std::size_t k = 0; k < 18; ++k) {
    values[k * layers] = static_cast<float>(k);
    values[k * layers + 1] = 100.0f + static_cast<float>(k);
  }
  const std::size_t middle = 1 * 6 + 1;
  values[middle * layers] = values[middle * layers + 1] = 0.0f;
  // Texel 2 (the first chart's right column) has its neighbours 3, 9 in the second chart: not read.
  fill_unseen_texels(l, layers, values, &ground);
  // The first chart's other texels: 0, 1, 2, 6, 8, 12, 13, 14.
  const float mean = (0 + 1 + 2 + 6 + 8 + 12 + 13 + 14) / 8.0f;
  EXPECT_FLOAT_EQ(values[middle * layers], mean);
  EXPECT_FLOAT_EQ(values[middle * layers + 1], 100.0f + mean);
  // A texel with light in `also` (the ground's, on a ceiling) saw something: kept.
  values[middle * layers] = values[middle * layers + 1] = 0.0f;
  ground[middle * layers] = 1.0f;
  fill_unseen_texels(l, layers, values, &ground);
  EXPECT_EQ(values[middle * layers], 0.0f);
}

TEST(LightMap, ABakesTexelsSeeWhatAVertexThereSees) {
  skylit::test::TempDir dir("skylit-light-map-bake-");
  const std::filesystem::path site_file = test::write_cube_on_slab_site(dir.path());
  skylit::test::quiet_bake(site_file, dir.path() / "bake", 4, [](BakeOptions& o) { o.light_map = LightMapOptions{0.25, 1.0, 0}; });
  const bake_format::VerifyReport report = bake_format::verify(dir.path() / "bake");
  EXPECT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems.front());
  const bake_format::Manifest m = bake_format::read_manifest(dir.path() / "bake");
  ASSERT_TRUE(m.light_map.has_value());
  EXPECT_FALSE(m.light_map->ground_file.empty()) << "the ground layer's transfer to the texels too";
  const bake_format::LightMapLayout l = bake_format::read_light_map_layout(dir.path() / "bake", m);
  const scene::Mesh mesh = scene::load_site_model(scene::load_site(site_file));
  const LightMapPoints expected = lay_out_light_map(mesh, {0.25, 1.0, 0});
  EXPECT_EQ(l.texels, expected.layout.texels);
  EXPECT_EQ(l.triangle_chart, expected.layout.triangle_chart);
  EXPECT_EQ(m.plan.light_map.texels, l.texels.size());
  std::vector<std::size_t> shape;
  const std::vector<float> transfer = bake_format::read_npy(dir.path() / "bake" / m.transfer_file, &shape);
  const std::vector<float> texels = bake_format::read_npy(dir.path() / "bake" / m.light_map->transfer_file, &shape);
  const std::size_t layers = m.layer_count();
  ASSERT_EQ(shape, (std::vector<std::size_t>{l.texels.size(), layers}));
  // The cube's top sees the whole sky from every point, its corners too: each texel's transfer is
  // a corner vertex's ((−1, −1, 3), normal up).
  std::size_t corner = mesh.vertex_count(), top_triangle = mesh.triangle_count();
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    if ((mesh.positions[v] - Eigen::Vector3f(-1, -1, 3)).norm() < 1e-6f && mesh.normals[v].z() > 0.99f) corner = v;
  }
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    if (mesh.positions[mesh.indices[3 * t]].z() == 3.0f && mesh.positions[mesh.indices[3 * t + 1]].z() == 3.0f &&
        mesh.positions[mesh.indices[3 * t + 2]].z() == 3.0f) {
      top_triangle = t;
    }
  }
  ASSERT_LT(corner, mesh.vertex_count());
  ASSERT_LT(top_triangle, mesh.triangle_count());
  const int top = l.triangle_chart[top_triangle];
  double worst = 0.0, slab_foot = 1e9, top_sum = 0.0;
  for (std::size_t j = 0; j < layers; ++j) top_sum += transfer[corner * layers + j];
  for (std::size_t k = 0; k < l.texels.size(); ++k) {
    const int c = chart_at(l, l.texels[k]);
    double sum = 0.0;
    for (std::size_t j = 0; j < layers; ++j) sum += texels[k * layers + j];
    if (c == top) {
      for (std::size_t j = 0; j < layers; ++j) worst = std::max(worst, std::abs(double(texels[k * layers + j]) - transfer[corner * layers + j]));
    } else if (c == l.triangle_chart[0]) {
      slab_foot = std::min(slab_foot, sum);
    }
  }
  std::printf("measured: the top's texels within %.2g sr of its corner's transfer; the slab's darkest texel %.3f of the top's light\n", worst,
              slab_foot / top_sum);
  EXPECT_LT(worst, 1e-6);
  // The slab's texels at the cube's foot see half the sky or less, where its corners see all of it.
  EXPECT_LT(slab_foot, 0.6 * top_sum);
}

TEST(LightMap, ItsPcaFormFromTheBakeAndFromCompressComeBackWithinTheirStatedError) {
  skylit::test::TempDir dir("skylit-light-map-pca-bake-");
  const std::filesystem::path site_file = test::write_cube_on_slab_site(dir.path());
  const std::filesystem::path bake = dir.path() / "bake";
  skylit::test::quiet_bake(site_file, bake, 4, [](BakeOptions& o) {
    o.light_map = LightMapOptions{0.25, 1.0, 0};
    o.light_map_pca = bake_format::LightMapPcaOptions{4, 45.0, true};
  });
  const bake_format::VerifyReport report = bake_format::verify(bake);
  EXPECT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems.front());
  const bake_format::Manifest m = bake_format::read_manifest(bake);
  ASSERT_TRUE(m.light_map && m.light_map->pca);
  EXPECT_EQ(m.light_map->pca->components, 4);
  EXPECT_FALSE(m.light_map->pca->ground_weights_file.empty()) << "the ground's transfer compressed too";
  const bake_format::LightMapArrays full = bake_format::read_light_map(bake, m);
  const bake_format::LightMapArrays pca = bake_format::read_light_map(bake, m, bake_format::LightMapForm::Pca);
  EXPECT_TRUE(pca.transfer.empty());
  ASSERT_TRUE(pca.pca.has_value());
  const std::vector<float> sky = bake_format::expand_light_map(pca.layout, pca.pca->sky);
  const std::vector<float> ground = bake_format::expand_light_map(pca.layout, pca.pca->ground);
  double worst = 0.0, worst_ground = 0.0;
  for (std::size_t i = 0; i < sky.size(); ++i) {
    worst = std::max(worst, std::abs(double(sky[i]) - full.transfer[i]));
    worst_ground = std::max(worst_ground, std::abs(double(ground[i]) - full.ground[i]));
  }
  EXPECT_NEAR(worst, m.light_map->pca->max_error, 1e-6);
  EXPECT_NEAR(worst_ground, m.light_map->pca->ground_max_error, 1e-6);
  // Single layers may be far off (a face's shadow edge is one of 480); what a sky sees is their
  // sum over smooth radiance. A uniform sky of radiance 1 (E_h = π) and one brighter towards the
  // zenith, per texel, as shares of E_h.
  const std::size_t layers = m.layer_count(), per_face = static_cast<std::size_t>(m.plan.layers_per_face());
  for (const bool zenith : {false, true}) {
    double squares = 0.0, largest = 0.0;
    std::vector<double> S(layers);
    for (std::size_t l = 0; l < layers; ++l) S[l] = zenith ? 2.0 * m.faces[l / per_face].direction.z() : 1.0;
    const double horizontal = zenith ? 4.0 * 3.14159265358979 / 3.0 : 3.14159265358979;  // ∫ 2 cos²θ dω, ∫ cos θ dω
    const std::size_t texels = pca.layout.texels.size();
    for (std::size_t x = 0; x < texels; ++x) {
      double e = 0.0;
      for (std::size_t l = 0; l < layers; ++l) e += S[l] * (double(sky[x * layers + l]) - std::max(0.0f, full.transfer[x * layers + l]));
      squares += e * e;
      largest = std::max(largest, std::abs(e));
    }
    const double rms = std::sqrt(squares / static_cast<double>(texels)) / horizontal;
    std::printf("measured: K = 4 per chart, a %s sky: E within %.4f of E_h (RMS %.4f); single values within %.3g sr\n",
                zenith ? "zenith-bright" : "uniform", largest / horizontal, rms, worst);
    EXPECT_LT(rms, 0.01);
  }
  // compress adds the same form to a finished bake (here: replaces it), and the bake verifies.
  baker::compress_bake(bake, std::nullopt, bake_format::LightMapPcaOptions{4, 45.0, true}, nullptr);
  EXPECT_TRUE(bake_format::verify(bake).ok);
  const bake_format::Manifest again = bake_format::read_manifest(bake);
  ASSERT_TRUE(again.light_map && again.light_map->pca);
  const bake_format::LightMapArrays recompressed = bake_format::read_light_map(bake, again, bake_format::LightMapForm::Pca);
  EXPECT_EQ(recompressed.pca->sky.vectors, pca.pca->sky.vectors);
  EXPECT_EQ(recompressed.pca->sky.weights, pca.pca->sky.weights);
  EXPECT_EQ(again.files.size(), m.files.size()) << "the old form's files replaced, not listed twice";
  // The options are checked before any work.
  BakeOptions no_map;
  no_map.site_file = site_file;
  no_map.out_dir = dir.path() / "none";
  no_map.light_map_pca = bake_format::LightMapPcaOptions{4, 45.0, true};
  EXPECT_THROW(run_bake(no_map, nullptr), InputError);
  EXPECT_THROW(baker::compress_bake(bake, std::nullopt, bake_format::LightMapPcaOptions{0, 45.0, true}, nullptr), InputError);
  EXPECT_THROW(baker::compress_bake(bake, std::nullopt, std::nullopt, nullptr), InputError);
}

// The bytes of the files a bake lists.
std::uintmax_t listed_bytes(const std::filesystem::path& bake, const bake_format::Manifest& m) {
  std::uintmax_t bytes = 0;
  for (const bake_format::FileRecord& f : m.files) bytes += std::filesystem::file_size(bake / f.path);
  return bytes;
}

TEST(LightMap, APcaOnlyBakeLeavesTheFullFormOutAndServesTheSamePcaForm) {
  skylit::test::TempDir dir("skylit-light-map-pca-only-");
  const std::filesystem::path site_file = test::write_cube_on_slab_site(dir.path());
  const std::filesystem::path both = dir.path() / "both", only = dir.path() / "only";
  for (const auto& [out, keep] : {std::pair{both, true}, std::pair{only, false}}) {
    skylit::test::quiet_bake(site_file, out, 4, [keep = keep](BakeOptions& o) {
      o.light_map = LightMapOptions{0.25, 1.0, 0};
      o.light_map_pca = bake_format::LightMapPcaOptions{4, 0.0, keep};
    });
  }
  const bake_format::VerifyReport report = bake_format::verify(only);
  EXPECT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems.front());
  const bake_format::Manifest kept = bake_format::read_manifest(both), m = bake_format::read_manifest(only);
  ASSERT_TRUE(m.light_map && m.light_map->pca);
  EXPECT_FALSE(m.light_map->has_full_form());
  EXPECT_TRUE(m.light_map->ground_file.empty());
  for (const std::string name : {"light_map_transfer.npy", "light_map_ground.npy"}) {
    EXPECT_FALSE(std::filesystem::exists(only / name)) << name;
    EXPECT_TRUE(std::filesystem::exists(both / name)) << name;
  }
  EXPECT_EQ(bake_format::smallest_light_map_form(m), bake_format::LightMapForm::Pca);
  const bake_format::LightMapArrays a = bake_format::read_light_map(both, kept, bake_format::LightMapForm::Pca);
  const bake_format::LightMapArrays b = bake_format::read_light_map(only, m, bake_format::LightMapForm::Pca);
  EXPECT_EQ(a.pca->sky.weights, b.pca->sky.weights);
  EXPECT_EQ(a.pca->sky.vectors, b.pca->sky.vectors);
  EXPECT_EQ(a.pca->ground.vectors, b.pca->ground.vectors);
  const std::uintmax_t with_full = listed_bytes(both, kept), without = listed_bytes(only, m);
  std::printf("measured: the bake %ju bytes with the full form, %ju without\n", with_full, without);
  EXPECT_LT(without, with_full);
  // Asking for the full form, or for compress to fit another K, says what the bake holds and what to do.
  try {
    (void)bake_format::read_light_map(only, m);
    ADD_FAILURE() << "the full form of a PCA-only bake was read";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("light_map.transfer"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("--light-map-pca-only"), std::string::npos) << error.what();
  }
  try {
    baker::compress_bake(only, std::nullopt, bake_format::LightMapPcaOptions{8, 0.0, false}, nullptr);
    ADD_FAILURE() << "compress fitted a PCA-only bake";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("--light-map-pca-only"), std::string::npos) << error.what();
  }
  // compress drops the full form of a finished bake when asked, keeping the same PCA form.
  baker::compress_bake(both, std::nullopt, bake_format::LightMapPcaOptions{4, 0.0, false}, nullptr);
  EXPECT_TRUE(bake_format::verify(both).ok);
  const bake_format::Manifest dropped = bake_format::read_manifest(both);
  EXPECT_FALSE(dropped.light_map->has_full_form());
  EXPECT_FALSE(std::filesystem::exists(both / "light_map_transfer.npy"));
  EXPECT_FALSE(std::filesystem::exists(both / "light_map_ground.npy"));
  EXPECT_EQ(bake_format::read_light_map(both, dropped, bake_format::LightMapForm::Pca).pca->sky.weights, b.pca->sky.weights);
  EXPECT_EQ(listed_bytes(both, dropped), without);
}

}  // namespace light_map_test
}  // namespace skylit::baker
