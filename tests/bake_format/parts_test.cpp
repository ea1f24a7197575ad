// PartStore: checksummed per-face parts that only the same plan may resume or merge.
#include <gtest/gtest.h>

#include "bake_fixtures.hpp"
#include "skylit/base/error.hpp"
#include "skylit/bake_format/parts.hpp"

namespace skylit::bake_format {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

FacePart make_part(const Plan& plan, int face) {
  FacePart part;
  part.face = face;
  for (std::size_t j = 0; j < plan.planes.size(); ++j) {
    const geom::Plane& p = plan.planes[j];
    std::vector<float> f(static_cast<std::size_t>(p.width * p.height));
    for (std::size_t t = 0; t < f.size(); ++t) f[t] = static_cast<float>((t * 37 + j * 11 + face) % 101) / 100.0f;
    part.plane_fractions.push_back(std::move(f));
  }
  for (std::size_t v = 0; v < plan.vertex_count; ++v) part.vertex_fractions.push_back(0.125f * v + 0.001f * face);
  return part;
}

TEST(PartStore, WriteHasReadRoundTrip) {
  TempDir dir;
  const PartStore store(dir / "parts");
  const Plan plan = test::sample_plan();
  EXPECT_FALSE(store.read_plan().has_value());
  store.write_plan(plan);
  const std::optional<Plan> stored = store.read_plan();
  ASSERT_TRUE(stored.has_value());
  EXPECT_TRUE(*stored == plan) << plan.difference(*stored);

  EXPECT_FALSE(store.has(12, plan));
  const FacePart part = make_part(plan, 12);
  store.write(part);
  EXPECT_EQ(store.path_of(12), dir / "parts" / "face_012.part");
  EXPECT_TRUE(fs::exists(store.path_of(12)));
  EXPECT_TRUE(store.has(12, plan));
  EXPECT_FALSE(store.has(13, plan));

  const FacePart back = store.read(12, plan);
  EXPECT_EQ(back.face, 12);
  EXPECT_EQ(back.plane_fractions, part.plane_fractions);  // exact: float32 stored as is
  EXPECT_EQ(back.vertex_fractions, part.vertex_fractions);

  // Size: header (8 magic + 4 version + 4 face + 4 count + 2×8 resolutions + 8 vertices + 32 hash)
  // plus the payload (8×6 + 5×4 texels + 3 vertices, float32).
  EXPECT_EQ(fs::file_size(store.path_of(12)), 76U + (48 + 20 + 3) * 4);
  // No temporary files are left beside the parts.
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir / "parts")) ++entries;
  EXPECT_EQ(entries, 2);  // plan.json, face_012.part
}

TEST(PartStore, AnotherPlanDoesNotHaveThePart) {
  TempDir dir;
  const PartStore store(dir / "parts");
  const Plan plan = test::sample_plan();
  store.write_plan(plan);
  store.write(make_part(plan, 3));
  ASSERT_TRUE(store.has(3, plan));

  Plan finer = plan;
  finer.planes[1].width = 10;
  EXPECT_FALSE(store.has(3, finer));
  EXPECT_THROW(store.read(3, finer), InputError);
  Plan fewer_vertices = plan;
  fewer_vertices.vertex_count = 2;
  EXPECT_FALSE(store.has(3, fewer_vertices));
  Plan one_plane = plan;
  one_plane.planes.pop_back();
  EXPECT_FALSE(store.has(3, one_plane));

  // A part moved to another face's name is not that face.
  fs::copy_file(store.path_of(3), store.path_of(4));
  EXPECT_FALSE(store.has(4, plan));
  EXPECT_THROW(store.read(4, plan), InputError);

  // A truncated part is not complete (has() does not hash, but it checks the size).
  fs::resize_file(store.path_of(3), fs::file_size(store.path_of(3)) - 1);
  EXPECT_FALSE(store.has(3, plan));
}

TEST(PartStore, CorruptPayloadIsDetectedOnRead) {
  TempDir dir;
  const PartStore store(dir / "parts");
  const Plan plan = test::sample_plan();
  store.write_plan(plan);
  store.write(make_part(plan, 12));
  test::flip_byte(store.path_of(12), fs::file_size(store.path_of(12)) - 5);
  EXPECT_TRUE(store.has(12, plan));  // cheap check: sizes only
  try {
    store.read(12, plan);
    FAIL() << "a corrupt part was read";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              (dir / "parts" / "face_012.part").string() +
                  " is corrupt (checksum mismatch). Fix: delete it and rerun with --resume");
  }
}

TEST(PartStore, WriteRefusesPartsThatDoNotFitThePlan) {
  TempDir dir;
  const PartStore store(dir / "parts");
  const Plan plan = test::sample_plan();
  EXPECT_THROW(store.write(make_part(plan, 0)), std::logic_error);  // no plan.json yet
  store.write_plan(plan);
  FacePart part = make_part(plan, 0);
  part.plane_fractions[0].pop_back();
  EXPECT_THROW(store.write(part), std::invalid_argument);
  EXPECT_FALSE(fs::exists(store.path_of(0)));
}

}  // namespace
}  // namespace skylit::bake_format
