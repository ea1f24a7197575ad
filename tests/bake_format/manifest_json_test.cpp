// Plan and Manifest JSON: every field survives a round trip bit for bit; bad input is named.
#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "bake_fixtures.hpp"
#include "skylit/base/error.hpp"

namespace skylit::bake_format {
namespace {

using nlohmann::json;
using test::sample_plan;
namespace fs = std::filesystem;
using test::TempDir;

Manifest sample_manifest() {
  Manifest m;
  m.generator = "skylit-bake 0.1.0";
  m.created_utc = "2024-06-21T12:34:56Z";
  m.plan = sample_plan();
  m.plan.vertex_count = 2;
  const int n = 40;
  for (int i = 0; i < n; ++i) {
    FaceRecord f;
    f.index = i;
    f.direction = geom::Vec3(std::sin(i + 0.1), std::cos(i * 0.7), 1.0 / (i + 3.0)).normalized();
    f.solid_angle = 2.0 * std::numbers::pi / n * (1.0 + 1e-13 * i);
    f.vertices = {geom::Vec3(1.0 / 3.0, 0.0, 0.0), geom::Vec3(0.0, 1e-17, 1.0), geom::Vec3(-0.1, 0.2, 0.3 * i)};
    f.neighbours = {i, (i + 7) % n, i % 3 == 0 ? -1 : i - 1};
    m.faces.push_back(f);
  }
  for (const geom::Plane& p : m.plan.planes) {
    PlaneRecord r;
    r.plane = p;
    for (int i = 0; i < n; ++i) r.unoccluded.push_back(i == 3 ? 0.0 : std::exp(-i) / 7.0);
    r.file = "planes/" + p.name + ".exr";
    m.planes.push_back(r);
    m.files.push_back({r.file, 123456789012ULL + m.files.size(), std::string(64, 'c')});
  }
  m.transfer_file = "transfer.npy";
  m.vertices_file = "vertices.npy";
  m.files.push_back({m.transfer_file, 320, "0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef"});
  m.bake_seconds = 1234.5678901234567;
  m.finalize_seconds = 0.1;
  return m;
}

// Round trips through text, as a file would.
json reparse(const json& j) { return json::parse(j.dump(2)); }

TEST(PlanJson, RoundTripKeepsEveryFieldExactly) {
  const Plan plan = sample_plan();
  const Plan back = plan_from_json(reparse(to_json(plan)), "plan.json");
  EXPECT_TRUE(back == plan) << plan.difference(back);
  EXPECT_EQ(back.difference(plan), "no differences");
  EXPECT_EQ(back.site_file, plan.site_file);
  EXPECT_EQ(back.model_sha256, plan.model_sha256);
  EXPECT_EQ(back.method, "raytrace");
  EXPECT_EQ(back.samples, 16);
  EXPECT_EQ(back.vertex_count, 3U);
  ASSERT_EQ(back.planes.size(), 2U);
  // Bitwise equal doubles, not merely close.
  EXPECT_EQ(back.planes[0].origin.x(), -10.0 / 3.0);
  EXPECT_EQ(back.planes[0].origin.z(), 1e-300);
  EXPECT_EQ(back.planes[1].origin.y(), -2.5e10);
  EXPECT_EQ(back.planes[1].v.z(), std::numbers::pi);
  EXPECT_EQ(back.planes[1].width, 5);
  EXPECT_EQ(back.planes[1].height, 4);
  // Large counts keep all 64 bits.
  Plan big = plan;
  big.triangle_count = (1ULL << 62) + 1;
  EXPECT_EQ(plan_from_json(reparse(to_json(big)), "plan.json").triangle_count, (1ULL << 62) + 1);
}

TEST(PlanJson, EqualityAndDifferenceCoverEveryField) {
  const Plan a = sample_plan();
  Plan b = a;
  b.samples = 1;
  b.planes[1].width = 64;
  b.planes[1].height = 32;
  EXPECT_FALSE(a == b);
  const std::string d = a.difference(b);
  EXPECT_NE(d.find("samples: 16 vs 1"), std::string::npos) << d;
  EXPECT_NE(d.find("plane 'wall' resolution: 5x4 vs 64x32"), std::string::npos) << d;
  EXPECT_EQ(d.find("frequency"), std::string::npos) << d;

  // One ulp in one coordinate is a different plan.
  Plan c = a;
  c.planes[0].u.y() = std::nextafter(0.0, 1.0);
  EXPECT_FALSE(a == c);
  EXPECT_NE(a.difference(c).find("plane 'ground' u:"), std::string::npos) << a.difference(c);

  const auto differs = [&](auto change, const char* word) {
    Plan x = a;
    change(x);
    EXPECT_FALSE(a == x) << word;
    EXPECT_NE(a.difference(x).find(word), std::string::npos) << a.difference(x);
  };
  differs([](Plan& x) { x.site_file = "other.yaml"; }, "site_file");
  differs([](Plan& x) { x.site_sha256 = "f"; }, "site file contents");
  differs([](Plan& x) { x.model_file = "m.obj"; }, "model_file");
  differs([](Plan& x) { x.model_sha256 = "f"; }, "model file contents");
  differs([](Plan& x) { x.frequency = 4; }, "frequency: 2 vs 4");
  differs([](Plan& x) { x.method = "raster"; }, "method");
  differs([](Plan& x) { x.shadow_map_resolution = 2048; }, "shadow_map_resolution");
  differs([](Plan& x) { x.preset = "balanced"; }, "preset");
  differs([](Plan& x) { x.ground_samples = 256; }, "ground_samples: 0 vs 256");
  differs([](Plan& x) { x.vertex_count = 4; }, "vertex_count");
  differs([](Plan& x) { x.triangle_count = 9; }, "triangle_count");
  differs([](Plan& x) { x.planes.pop_back(); }, "planes: 2 ['ground', 'wall'] vs 1 ['ground']");
  differs([](Plan& x) { x.planes[0].name = "floor"; }, "plane 0 name: 'ground' vs 'floor'");
  differs([](Plan& x) { x.planes[0].origin.x() += 1.0; }, "origin");
  differs([](Plan& x) { x.planes[1].v.x() = 0.5; }, "plane 'wall' v:");
}

TEST(PlanJson, ErrorsNameTheFileAndTheField) {
  json j = to_json(sample_plan());
  j.erase("samples");
  try {
    plan_from_json(j, "/bake/parts/plan.json");
    FAIL() << "a missing field was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/bake/parts/plan.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("samples"), std::string::npos) << e.what();
  }
  j = to_json(sample_plan());
  j["planes"][1]["resolution"] = json::array({5, "four"});
  try {
    plan_from_json(j, "plan.json");
    FAIL() << "a string resolution was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("planes[1].resolution[1]"), std::string::npos) << e.what();
  }
  j = to_json(sample_plan());
  j["method"] = "magic";
  EXPECT_THROW(plan_from_json(j, "plan.json"), InputError);
  j = to_json(sample_plan());
  j["planes"][0]["origin"] = json::array({1.0, 2.0});
  EXPECT_THROW(plan_from_json(j, "plan.json"), InputError);
}

TEST(ManifestJson, RoundTripKeepsEveryField) {
  const Manifest m = sample_manifest();
  const json j = reparse(to_json(m));
  EXPECT_EQ(j["format"], "skylit-bake");
  EXPECT_EQ(j["schema_version"], 1);
  EXPECT_EQ(j["dome"]["frequency"], 2);
  EXPECT_EQ(j["transfer"]["shape"], json::array({2, 40}));
  EXPECT_EQ(j["vertices"]["shape"], json::array({2, 6}));
  EXPECT_EQ(j["planes"][1]["resolution"], json::array({5, 4}));
  // The wall spans +y and +z: its normal is +x.
  EXPECT_EQ(j["planes"][1]["normal"], json::array({1.0, 0.0, 0.0}));

  const Manifest b = manifest_from_json(j, "manifest.json");
  EXPECT_EQ(b.schema_version, 1);
  EXPECT_EQ(b.generator, m.generator);
  EXPECT_EQ(b.created_utc, m.created_utc);
  EXPECT_TRUE(b.plan == m.plan) << m.plan.difference(b.plan);
  ASSERT_EQ(b.faces.size(), m.faces.size());
  for (std::size_t i = 0; i < m.faces.size(); ++i) {
    EXPECT_EQ(b.faces[i].index, m.faces[i].index);
    EXPECT_EQ(b.faces[i].direction, m.faces[i].direction);
    EXPECT_EQ(b.faces[i].solid_angle, m.faces[i].solid_angle);
    for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(b.faces[i].vertices[k], m.faces[i].vertices[k]);
    EXPECT_EQ(b.faces[i].neighbours, m.faces[i].neighbours);
  }
  ASSERT_EQ(b.planes.size(), m.planes.size());
  for (std::size_t j2 = 0; j2 < m.planes.size(); ++j2) {
    EXPECT_EQ(b.planes[j2].plane.name, m.planes[j2].plane.name);
    EXPECT_EQ(b.planes[j2].plane.origin, m.planes[j2].plane.origin);
    EXPECT_EQ(b.planes[j2].plane.u, m.planes[j2].plane.u);
    EXPECT_EQ(b.planes[j2].plane.v, m.planes[j2].plane.v);
    EXPECT_EQ(b.planes[j2].plane.width, m.planes[j2].plane.width);
    EXPECT_EQ(b.planes[j2].plane.height, m.planes[j2].plane.height);
    EXPECT_EQ(b.planes[j2].unoccluded, m.planes[j2].unoccluded);
    EXPECT_EQ(b.planes[j2].file, m.planes[j2].file);
  }
  EXPECT_EQ(b.transfer_file, m.transfer_file);
  EXPECT_EQ(b.vertices_file, m.vertices_file);
  EXPECT_EQ(b.bake_seconds, m.bake_seconds);
  EXPECT_EQ(b.finalize_seconds, m.finalize_seconds);
  ASSERT_EQ(b.files.size(), m.files.size());
  for (std::size_t k = 0; k < m.files.size(); ++k) {
    EXPECT_EQ(b.files[k].path, m.files[k].path);
    EXPECT_EQ(b.files[k].size, m.files[k].size);
    EXPECT_EQ(b.files[k].sha256, m.files[k].sha256);
  }
  // And the JSON itself is a fixed point.
  EXPECT_EQ(to_json(b), j);
}

TEST(ManifestJson, TheLightMapRoundTripsAndMustAgreeWithThePlan) {
  Manifest m = sample_manifest();
  EXPECT_FALSE(manifest_from_json(reparse(to_json(m)), "manifest.json").light_map.has_value());
  m.plan.light_map = {0.1, 1.5, 6, 777};
  m.light_map = Manifest::LightMap{};
  m.light_map->width = 64;
  m.light_map->height = 48;
  m.light_map->chart_count = 5;
  const json j = reparse(to_json(m));
  EXPECT_EQ(j["plan"]["light_map"]["texels"], 777);
  EXPECT_EQ(j["light_map"]["transfer"]["shape"], json::array({777, 40}));
  EXPECT_EQ(j["light_map"]["charts"]["shape"], json::array({5, 15}));
  EXPECT_EQ(j["plan"]["light_map"]["min_across"], 6);
  EXPECT_FALSE(j["light_map"].contains("ground"));
  const Manifest b = manifest_from_json(j, "manifest.json");
  ASSERT_TRUE(b.light_map.has_value());
  EXPECT_EQ(b.plan.light_map, m.plan.light_map);
  EXPECT_EQ(b.light_map->width, 64);
  EXPECT_EQ(b.light_map->chart_count, 5u);
  EXPECT_EQ(to_json(b), j);
  EXPECT_EQ(b.plan.traced_count(), b.plan.vertex_count + 777) << "the parts hold the texels after the vertices";
  // The section and the plan must agree, and its arrays have the plan's texels.
  json without = j;
  without.erase("light_map");
  EXPECT_THROW(manifest_from_json(without, "manifest.json"), InputError);
  json wrong_rows = j;
  wrong_rows["light_map"]["transfer"]["shape"][0] = 776;
  EXPECT_THROW(manifest_from_json(wrong_rows, "manifest.json"), InputError);
  json outside = j;
  outside["light_map"]["texels"]["file"] = "../texels.npy";
  EXPECT_THROW(manifest_from_json(outside, "manifest.json"), InputError);
  json plan_differs = j;
  plan_differs["plan"]["light_map"]["texel"] = 0.2;
  const Manifest c = manifest_from_json(plan_differs, "manifest.json");
  EXPECT_NE(c.plan.difference(b.plan).find("light_map"), std::string::npos);
  // Its PCA form: K components per chart, the shapes from the plan, the charts and K.
  Manifest::LightMap::Pca pca;
  pca.components = 3;
  pca.sky_correlation_deg = 45.0;
  pca.rms_error = 0.25;
  pca.max_error = 1.5;
  m.light_map->pca = pca;
  const json p = reparse(to_json(m));
  EXPECT_EQ(p["light_map"]["pca"]["weights"]["shape"], json::array({777, 3}));
  EXPECT_EQ(p["light_map"]["pca"]["vectors"]["shape"], json::array({5, 4, 40}));
  EXPECT_FALSE(p["light_map"]["pca"].contains("ground_weights"));
  const Manifest d = manifest_from_json(p, "manifest.json");
  ASSERT_TRUE(d.light_map && d.light_map->pca);
  EXPECT_EQ(d.light_map->pca->components, 3);
  EXPECT_EQ(d.light_map->pca->max_error, 1.5);
  EXPECT_EQ(to_json(d), p);
  json wrong_k = p;
  wrong_k["light_map"]["pca"]["vectors"]["shape"][1] = 3;
  EXPECT_THROW(manifest_from_json(wrong_k, "manifest.json"), InputError);
  json with_ground = p;
  with_ground["light_map"]["pca"]["ground_weights"] = p["light_map"]["pca"]["weights"];
  with_ground["light_map"]["pca"]["ground_vectors"] = p["light_map"]["pca"]["vectors"];
  with_ground["light_map"]["pca"]["ground_rms_error"] = 0.0;
  with_ground["light_map"]["pca"]["ground_max_error"] = 0.0;
  EXPECT_THROW(manifest_from_json(with_ground, "manifest.json"), InputError) << "the bake has no ground layer";
  // The PCA form alone (--light-map-pca-only): no transfer entry, and it reads back without one.
  Manifest pca_only = d;
  pca_only.light_map->transfer_file.clear();
  const json q = reparse(to_json(pca_only));
  EXPECT_FALSE(q["light_map"].contains("transfer"));
  const Manifest e = manifest_from_json(q, "manifest.json");
  ASSERT_TRUE(e.light_map && e.light_map->pca);
  EXPECT_FALSE(e.light_map->has_full_form());
  EXPECT_EQ(to_json(e), q);
  json ground_alone = q;
  ground_alone["light_map"]["ground"] = p["light_map"]["transfer"];
  EXPECT_THROW(manifest_from_json(ground_alone, "manifest.json"), InputError) << "the full form's ground without its transfer";
  // Neither form is refused, naming the full form's entry.
  json neither = q;
  neither["light_map"].erase("pca");
  try {
    (void)manifest_from_json(neither, "manifest.json");
    ADD_FAILURE() << "a light map with neither form was accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("light_map.transfer"), std::string::npos) << error.what();
  }
}

TEST(ManifestJson, TheGroundLayerRoundTripsAndOlderManifestsHaveNone) {
  Manifest m = sample_manifest();
  EXPECT_FALSE(manifest_from_json(reparse(to_json(m)), "manifest.json").ground.has_value());
  m.plan.ground_samples = 256;
  m.ground = Manifest::Ground{"ground_transfer.npy", std::vector<double>(m.layer_count())};
  for (std::size_t l = 0; l < m.layer_count(); ++l) m.ground->horizontal_unoccluded[l] = std::exp(-static_cast<double>(l)) / 3.0;
  const json j = reparse(to_json(m));
  EXPECT_EQ(j["plan"]["ground_samples"], 256);
  EXPECT_EQ(j["ground"]["shape"], json::array({2, 40}));
  const Manifest b = manifest_from_json(j, "manifest.json");
  ASSERT_TRUE(b.ground.has_value());
  EXPECT_EQ(b.ground->file, "ground_transfer.npy");
  EXPECT_EQ(b.ground->horizontal_unoccluded, m.ground->horizontal_unoccluded);
  EXPECT_EQ(to_json(b), j);
  // The layer and the plan must agree, and the integrals be one per layer.
  json without = j;
  without.erase("ground");
  EXPECT_THROW(manifest_from_json(without, "manifest.json"), InputError);
  json short_one = j;
  short_one["ground"]["horizontal_unoccluded"].erase(0);
  EXPECT_THROW(manifest_from_json(short_one, "manifest.json"), InputError);
  json outside = j;
  outside["ground"]["file"] = "../ground.npy";
  EXPECT_THROW(manifest_from_json(outside, "manifest.json"), InputError);
}

TEST(ManifestJson, AnotherSchemaVersionSaysWhichAndWhatToDo) {
  json j = to_json(sample_manifest());
  j["schema_version"] = 3;
  try {
    manifest_from_json(j, "/data/bake/manifest.json");
    FAIL() << "schema version 3 was accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "/data/bake/manifest.json was written by schema version 3 of the bake format; this skylit "
                 "reads version 1. Fix: re-bake with this skylit-bake (or use the skylit that wrote it)");
  }
}

TEST(ManifestJson, ForeignOrIncompleteManifestsAreRefused) {
  json j = to_json(sample_manifest());
  j["format"] = "something-else";
  EXPECT_THROW(manifest_from_json(j, "manifest.json"), InputError);
  j = to_json(sample_manifest());
  j.erase("format");
  EXPECT_THROW(manifest_from_json(j, "manifest.json"), InputError);

  j = to_json(sample_manifest());
  j["dome"]["faces"][7].erase("solid_angle");
  try {
    manifest_from_json(j, "/b/manifest.json");
    FAIL() << "a face without solid angle was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/b/manifest.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("dome.faces[7].solid_angle"), std::string::npos) << e.what();
  }
  j = to_json(sample_manifest());
  j["transfer"]["shape"] = json::array({2, 39});  // disagrees with the 40 faces
  EXPECT_THROW(manifest_from_json(j, "manifest.json"), InputError);
  j = to_json(sample_manifest());
  j["files"][0]["size"] = -4;
  EXPECT_THROW(manifest_from_json(j, "manifest.json"), InputError);

  // A file named by the manifest stays inside the bake directory: every loader joins it to it.
  for (const char* escape : {"../../etc/passwd", "/etc/passwd", "planes/../../outside.npy"}) {
    j = to_json(sample_manifest());
    j["transfer"]["file"] = escape;
    try {
      manifest_from_json(j, "/b/manifest.json");
      FAIL() << escape << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("transfer.file"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("outside the bake directory"), std::string::npos) << e.what();
    }
  }
  j = to_json(sample_manifest());
  j["planes"][0]["file"] = "../elsewhere.exr";
  EXPECT_THROW(manifest_from_json(j, "manifest.json"), InputError);
}

TEST(ManifestFile, WriteHashesTheFilesAndReadsBack) {
  TempDir dir;
  Manifest m = sample_manifest();
  m.files.clear();
  {
    std::ofstream(dir / "transfer.npy", std::ios::binary) << "abc";
  }
  m.files.push_back({"transfer.npy", 0, ""});
  write_manifest(dir.path(), m);
  const Manifest back = read_manifest(dir.path());
  ASSERT_EQ(back.files.size(), 1U);
  EXPECT_EQ(back.files[0].size, 3U);
  // SHA-256("abc"), FIPS 180-2 appendix B.1.
  EXPECT_EQ(back.files[0].sha256, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");

  // Bad JSON names the line.
  { std::ofstream(dir / "manifest.json") << "{\n  \"format\": \"skylit-bake\",\n  oops\n}\n"; }
  try {
    read_manifest(dir.path());
    FAIL() << "bad JSON was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("manifest.json:3:"), std::string::npos) << e.what();
  }
  fs::remove(dir / "manifest.json");
  EXPECT_THROW(read_manifest(dir.path()), InputError);
  // A listed file that does not exist cannot be hashed.
  m.files.push_back({"nothing.npy", 0, ""});
  EXPECT_THROW(write_manifest(dir.path(), m), InputError);
  EXPECT_FALSE(fs::exists(dir / "manifest.json"));
}

}  // namespace
}  // namespace skylit::bake_format
