// verify(): a good bake passes; each kind of damage is reported naming the file and the fix.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "bake_fixtures.hpp"
#include "skylit/base/files.hpp"
#include "skylit/bake_format/parts.hpp"

namespace skylit::bake_format {
namespace verify_test {  // named, not anonymous: the test program is one unity build

using nlohmann::json;
namespace fs = std::filesystem;
using test::TempDir;

std::string all(const VerifyReport& r) {
  std::string s;
  for (const std::string& p : r.problems) s += p + "\n";
  return s;
}

// True when one problem line mentions every word.
bool reported(const VerifyReport& r, std::initializer_list<std::string> words) {
  for (const std::string& p : r.problems) {
    bool every = true;
    for (const std::string& w : words) every = every && p.find(w) != std::string::npos;
    if (every) return true;
  }
  return false;
}

json load(const fs::path& file) { return json::parse(read_file(file)); }
void save(const fs::path& file, const json& j) { write_file_atomic(file, j.dump(2)); }

class Verify : public ::testing::Test {
 protected:
  void SetUp() override { manifest_ = test::write_synthetic_bake(dir_.path()); }
  TempDir dir_;
  Manifest manifest_;
};

TEST_F(Verify, AGoodBakePasses) {
  const VerifyReport r = verify(dir_.path());
  EXPECT_TRUE(r.ok) << all(r);
  EXPECT_TRUE(r.problems.empty());
  EXPECT_EQ(r.manifest.faces.size(), 40U);
  EXPECT_EQ(r.manifest.files.size(), 4U);
  EXPECT_EQ(r.manifest.planes[0].file, "planes/ground.exr");
  // The files read back as written.
  const ImageStack wall = read_exr_stack(dir_ / "planes/wall.exr");
  EXPECT_EQ(wall.width, 5);
  EXPECT_EQ(wall.height, 4);
  EXPECT_NEAR(wall.layer(17)[9], test::sample_basis(1, 17, 9), 1e-3 * test::sample_basis(1, 17, 9));
}

TEST_F(Verify, TheGroundLayerIsCheckedLikeTheTransfer) {
  Manifest m = read_manifest(dir_.path());
  const std::size_t vertices = m.plan.vertex_count, layers = m.layer_count();
  m.plan.ground_samples = 64;
  m.ground = Manifest::Ground{"ground_transfer.npy", std::vector<double>(layers, 0.05)};
  const std::size_t good[] = {vertices, layers};
  write_npy(dir_ / "ground_transfer.npy", std::vector<float>(vertices * layers, 0.5f), good);
  m.files.push_back({"ground_transfer.npy", 0, ""});
  write_manifest(dir_.path(), m);
  VerifyReport r = verify(dir_.path());
  EXPECT_TRUE(r.ok) << all(r);
  ASSERT_TRUE(r.manifest.ground.has_value());

  const std::size_t bad[] = {vertices, layers - 1};
  write_npy(dir_ / "ground_transfer.npy", std::vector<float>(vertices * (layers - 1), 0.5f), bad);
  m.ground->horizontal_unoccluded[7] = -1.0;
  write_manifest(dir_.path(), m);
  r = verify(dir_.path());
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"ground_transfer.npy", "shape"})) << all(r);
  EXPECT_TRUE(reported(r, {"ground.horizontal_unoccluded[7]", "Fix: re-bake"})) << all(r);
}

TEST_F(Verify, AFlippedByteInAnImageIsNamed) {
  const fs::path exr = dir_ / "planes/ground.exr";
  test::flip_byte(exr, fs::file_size(exr) / 2);
  const VerifyReport r = verify(dir_.path());
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"planes/ground.exr: SHA-256 differs from the manifest", "Fix: re-bake, or restore"}))
      << all(r);
  EXPECT_FALSE(reported(r, {"wall"})) << all(r);
}

TEST_F(Verify, ATruncatedArrayIsNamed) {
  fs::resize_file(dir_ / "transfer.npy", fs::file_size(dir_ / "transfer.npy") - 4);
  const VerifyReport r = verify(dir_.path());
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"transfer.npy", "truncated", "Fix"})) << all(r);
}

TEST_F(Verify, AMissingFileIsNamed) {
  fs::remove(dir_ / "planes/wall.exr");
  const VerifyReport r = verify(dir_.path());
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"planes/wall.exr: missing", "Fix"})) << all(r);
  EXPECT_EQ(r.problems.size(), 1U) << all(r);
}

TEST_F(Verify, AnotherSchemaVersionIsNamed) {
  json j = load(dir_ / "manifest.json");
  j["schema_version"] = 3;
  save(dir_ / "manifest.json", j);
  const VerifyReport r = verify(dir_.path());
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"schema version 3", "reads version 1", "Fix: re-bake"})) << all(r);
}

TEST_F(Verify, AWrongFaceCountIsNamed) {
  json j = load(dir_ / "manifest.json");
  j["dome"]["faces"].erase(39);
  j["transfer"]["shape"][1] = 39;
  for (json& p : j["planes"]) p["unoccluded"].erase(39);
  save(dir_ / "manifest.json", j);
  const VerifyReport r = verify(dir_.path());
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"39 faces", "10·ν² = 40"})) << all(r);
  // The data files still have 40 layers and columns: both are named too.
  EXPECT_TRUE(reported(r, {"planes/ground.exr", "40 layers"})) << all(r);
  EXPECT_TRUE(reported(r, {"transfer.npy", "shape (3, 40)", "(3, 39)"})) << all(r);
}

TEST_F(Verify, ImagesAndArraysOfTheWrongShapeAreNamed) {
  // Replace the wall image by a well-formed one of another size, and re-hash so only the shape is wrong.
  ImageStack small;
  small.width = 4;
  small.height = 4;
  small.layers = 40;
  small.data.assign(4 * 4 * 40, 0.5f);
  std::vector<std::string> names;
  for (int i = 0; i < 40; ++i) names.push_back(face_layer_name(i));
  write_exr_stack(dir_ / "planes/wall.exr", small, names);
  const std::size_t shape[] = {3, 7};
  write_npy(dir_ / "vertices.npy", std::vector<float>(21, 1.0f), shape);
  write_manifest(dir_.path(), manifest_);
  const VerifyReport r = verify(dir_.path());
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"planes/wall.exr: image is 4x4, the manifest says 5x4"})) << all(r);
  EXPECT_TRUE(reported(r, {"vertices.npy: shape (3, 7), expected (3, 6)"})) << all(r);
  EXPECT_EQ(r.problems.size(), 2U) << all(r);
}

TEST_F(Verify, BadUnoccludedValuesAreNamed) {
  json j = load(dir_ / "manifest.json");
  j["planes"][0]["unoccluded"][5] = -0.01;
  j["planes"][1]["unoccluded"][6] = nullptr;  // how JSON holds a NaN
  save(dir_ / "manifest.json", j);
  VerifyReport r = verify(dir_.path());
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"plane 'ground'", "unoccluded[5]"})) << all(r);
  EXPECT_TRUE(reported(r, {"plane 'wall'", "unoccluded[6]"})) << all(r);

  j = load(dir_ / "manifest.json");
  j["planes"][0]["unoccluded"][5] = 0.01;
  j["planes"][1]["unoccluded"][6] = 0.01;
  j["planes"][1]["unoccluded"].push_back(0.01);
  save(dir_ / "manifest.json", j);
  r = verify(dir_.path());
  EXPECT_TRUE(reported(r, {"plane 'wall'", "41 unoccluded values for 40 faces"})) << all(r);
  EXPECT_EQ(r.problems.size(), 1U) << all(r);
}

TEST_F(Verify, PathsOutsideTheBakeAreRefused) {
  json j = load(dir_ / "manifest.json");
  j["files"][0]["path"] = "../../etc/passwd";
  save(dir_ / "manifest.json", j);
  const VerifyReport r = verify(dir_.path());
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"../../etc/passwd", "not a path inside"})) << all(r);
}

TEST(VerifyIncomplete, NoManifestWithPartsSaysIncomplete) {
  TempDir dir;
  const PartStore parts(dir / "parts");
  Plan plan = test::sample_plan();
  parts.write_plan(plan);
  for (int face : {0, 3, 5}) {
    FacePart part;
    part.face = face;
    for (const geom::Plane& p : plan.planes) {
      part.plane_fractions.emplace_back(static_cast<std::size_t>(p.width * p.height), 1.0f);
    }
    part.vertex_fractions.assign(plan.vertex_count, 0.5f);
    parts.write(part);
  }
  VerifyReport r = verify(dir.path());
  EXPECT_FALSE(r.ok);
  ASSERT_EQ(r.problems.size(), 1U) << all(r);
  EXPECT_NE(r.problems[0].find("incomplete (3 of 40 face parts in parts/)"), std::string::npos) << all(r);
  EXPECT_NE(r.problems[0].find("--resume"), std::string::npos) << all(r);

  fs::remove_all(dir / "parts");
  r = verify(dir.path());
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"manifest.json: missing", "not a finished bake"})) << all(r);
  r = verify(dir / "nowhere");
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(reported(r, {"nowhere", "no such directory"})) << all(r);
}

}  // namespace
}  // namespace skylit::bake_format
