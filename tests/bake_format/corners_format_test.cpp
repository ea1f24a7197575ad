// The corners basis in the bake format: the basis in plan and manifest, three layers per face
// (face_NNN_k), A and transfer columns per layer, verify's counts, version-2 parts, and old bakes
// (no basis field, version-1 parts) still read as faces.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "bake_fixtures.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/bake_format/parts.hpp"

namespace skylit::bake_format {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;
using test::TempDir;

std::string all(const VerifyReport& r) {
  std::string s;
  for (const std::string& p : r.problems) s += p + "\n";
  return s;
}

json load(const fs::path& file) { return json::parse(read_file(file)); }

TEST(CornersFormat, LayerNames) {
  EXPECT_EQ(layer_name(geom::DomeBasis::Faces, 22), "face_022");
  EXPECT_EQ(layer_name(geom::DomeBasis::Corners, 22), "face_007_1");
  EXPECT_EQ(layer_name(geom::DomeBasis::Corners, 3 * 1000 + 2), "face_1000_2");
  const std::vector<std::string> names = layer_names(geom::DomeBasis::Corners, 2);
  EXPECT_EQ(names, (std::vector<std::string>{"face_000_0", "face_000_1", "face_000_2", "face_001_0", "face_001_1",
                                             "face_001_2"}));
}

TEST(CornersFormat, ThePlanRecordsTheBasisAndOldPlansAreFaces) {
  Plan plan = test::sample_plan();
  plan.basis = geom::DomeBasis::Corners;
  const json j = to_json(plan);
  EXPECT_EQ(j.at("basis"), "corners");
  const Plan back = plan_from_json(j, "plan.json");
  EXPECT_EQ(back.basis, geom::DomeBasis::Corners);
  EXPECT_EQ(back.layers_per_face(), 3);
  EXPECT_TRUE(back == plan);

  const Plan faces = test::sample_plan();
  EXPECT_FALSE(faces == plan);
  EXPECT_NE(faces.difference(plan).find("basis: 'faces' vs 'corners'"), std::string::npos) << faces.difference(plan);

  json old = to_json(faces);
  old.erase("basis");  // written before the corners basis existed
  EXPECT_EQ(plan_from_json(old, "plan.json").basis, geom::DomeBasis::Faces);

  json bad = j;
  bad["basis"] = "vertices";
  try {
    plan_from_json(bad, "/b/parts/plan.json");
    FAIL() << "an unknown basis was accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("/b/parts/plan.json"), std::string::npos) << message;
    EXPECT_NE(message.find("basis"), std::string::npos) << message;
    EXPECT_NE(message.find("'corners'"), std::string::npos) << message;
  }
}

TEST(CornersFormat, ACornersBakeRoundTripsAndVerifies) {
  TempDir dir;
  const Manifest written = test::write_synthetic_bake(dir.path(), geom::DomeBasis::Corners);
  const VerifyReport r = verify(dir.path());
  ASSERT_TRUE(r.ok) << all(r);
  const Manifest& m = r.manifest;
  EXPECT_EQ(m.plan.basis, geom::DomeBasis::Corners);
  EXPECT_EQ(m.faces.size(), 40U);
  EXPECT_EQ(m.layer_count(), 120U);
  EXPECT_EQ(m.planes[0].unoccluded, written.planes[0].unoccluded);
  const json j = load(dir / "manifest.json");
  EXPECT_EQ(j["dome"]["basis"], "corners");
  EXPECT_EQ(j["plan"]["basis"], "corners");
  EXPECT_EQ(j["transfer"]["shape"], json::array({3, 120}));
  std::vector<std::string> names;
  const ImageStack wall = read_exr_stack(dir / "planes/wall.exr", &names);
  EXPECT_EQ(wall.layers, 120);
  EXPECT_EQ(names[22], "face_007_1");
  EXPECT_NEAR(wall.layer(22)[9], test::sample_basis(1, 22, 9), 1e-3 * test::sample_basis(1, 22, 9));
}

TEST(CornersFormat, VerifyCountsLayersPerFace) {
  TempDir dir;
  test::write_synthetic_bake(dir.path(), geom::DomeBasis::Corners);
  // The same images and arrays claimed as a faces bake: 120 layers for 40 faces is wrong.
  json j = load(dir / "manifest.json");
  j["plan"]["basis"] = "faces";
  j["dome"]["basis"] = "faces";
  j["transfer"]["shape"] = json::array({3, 40});
  for (auto& p : j["planes"]) p["unoccluded"] = std::vector<double>(p["unoccluded"].begin(), p["unoccluded"].begin() + 40);
  write_file_atomic(dir / "manifest.json", j.dump(2));
  VerifyReport r = verify(dir.path());
  EXPECT_FALSE(r.ok);
  const std::string problems = all(r);
  EXPECT_NE(problems.find("planes/ground.exr: 120 layers, the dome has 40 faces"), std::string::npos) << problems;
  EXPECT_NE(problems.find("transfer.npy: shape (3, 120), expected (3, 40)"), std::string::npos) << problems;

  // A corners manifest over a faces bake's files: too few layers, named with the basis.
  TempDir faces_dir;
  test::write_synthetic_bake(faces_dir.path());
  j = load(faces_dir / "manifest.json");
  j["plan"]["basis"] = "corners";
  j["dome"]["basis"] = "corners";
  j["transfer"]["shape"] = json::array({3, 120});
  for (auto& p : j["planes"]) {
    std::vector<double> a;
    for (double x : p["unoccluded"]) a.insert(a.end(), {x / 3, x / 3, x / 3});
    p["unoccluded"] = a;
  }
  write_file_atomic(faces_dir / "manifest.json", j.dump(2));
  r = verify(faces_dir.path());
  EXPECT_FALSE(r.ok);
  EXPECT_NE(all(r).find("40 layers, the dome has 40 faces and the corners basis 3 layers per face (120)"),
            std::string::npos)
      << all(r);

  // dome.basis and plan.basis must agree.
  j["dome"]["basis"] = "faces";
  write_file_atomic(faces_dir / "manifest.json", j.dump(2));
  r = verify(faces_dir.path());
  EXPECT_NE(all(r).find("dome.basis"), std::string::npos) << all(r);
}

TEST(CornersFormat, OldBakesWithoutABasisReadAsFaces) {
  TempDir dir;
  test::write_synthetic_bake(dir.path());
  json j = load(dir / "manifest.json");
  j["plan"].erase("basis");
  j["dome"].erase("basis");
  write_file_atomic(dir / "manifest.json", j.dump(2));
  const VerifyReport r = verify(dir.path());
  EXPECT_TRUE(r.ok) << all(r);
  EXPECT_EQ(r.manifest.plan.basis, geom::DomeBasis::Faces);
  EXPECT_EQ(r.manifest.layer_count(), 40U);
}

FacePart corners_part(const Plan& plan, int face) {
  FacePart part;
  part.face = face;
  for (std::size_t j = 0; j < plan.planes.size(); ++j) {
    const geom::Plane& p = plan.planes[j];
    std::vector<float> f(3 * static_cast<std::size_t>(p.width * p.height));
    for (std::size_t t = 0; t < f.size(); ++t) f[t] = static_cast<float>((t * 37 + j * 11 + face) % 101) / 100.0f;
    part.plane_fractions.push_back(std::move(f));
  }
  for (std::size_t v = 0; v < 3 * plan.vertex_count; ++v) part.vertex_fractions.push_back(0.125f * v + 0.001f * face);
  return part;
}

std::uint32_t version_of(const fs::path& part) {
  const std::string bytes = read_file(part);
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + 8, 4);
  return version;
}

TEST(CornersFormat, PartsCarryThreeLayersAndFacesPartsKeepVersionOne) {
  TempDir dir;
  Plan plan = test::sample_plan();
  plan.basis = geom::DomeBasis::Corners;
  const PartStore store(dir / "parts");
  store.write_plan(plan);
  const FacePart part = corners_part(plan, 5);
  store.write(part);
  EXPECT_EQ(version_of(store.path_of(5)), 2U);
  EXPECT_TRUE(store.has(5, plan));
  const FacePart back = store.read(5, plan);
  EXPECT_EQ(back.plane_fractions, part.plane_fractions);
  EXPECT_EQ(back.vertex_fractions, part.vertex_fractions);
  // Header 76 + 4 (layer count), payload 3 × (48 + 20 + 3) floats.
  EXPECT_EQ(fs::file_size(store.path_of(5)), 80U + 3 * (48 + 20 + 3) * 4);

  // One layer's worth of fractions is refused; a faces plan does not take a corners part.
  FacePart short_part = part;
  short_part.vertex_fractions.resize(plan.vertex_count);
  EXPECT_THROW(store.write(short_part), std::invalid_argument);
  Plan faces = plan;
  faces.basis = geom::DomeBasis::Faces;
  EXPECT_FALSE(store.has(5, faces));
  EXPECT_THROW(store.read(5, faces), InputError);

  // A faces bake writes the version-1 parts of earlier bakers, which a corners plan refuses.
  TempDir faces_dir;
  const PartStore faces_store(faces_dir / "parts");
  faces_store.write_plan(faces);
  FacePart one;
  one.face = 5;
  for (const geom::Plane& p : faces.planes) one.plane_fractions.emplace_back(static_cast<std::size_t>(p.width * p.height), 0.5f);
  one.vertex_fractions.assign(faces.vertex_count, 0.25f);
  faces_store.write(one);
  EXPECT_EQ(version_of(faces_store.path_of(5)), 1U);
  EXPECT_TRUE(faces_store.has(5, faces));
  EXPECT_FALSE(faces_store.has(5, plan));
  try {
    faces_store.read(5, plan);
    FAIL() << "a one-layer part was read for a corners plan";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("1 layer(s) per face, the plan's corners basis has 3"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace skylit::bake_format
