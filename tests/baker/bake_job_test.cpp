// Unit tests of the bake job's small pieces: shards, sample directions.
#include <cstdlib>

#include <gtest/gtest.h>

#include "skylit/base/error.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/geom/dome.hpp"

namespace skylit::baker {
namespace {

class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) { setenv(name, value, 1); }
  ~ScopedEnv() { unsetenv(name_); }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
};

TEST(Shard, ParsesIOverN) {
  const Shard s = parse_shard("3/8");
  EXPECT_EQ(s.index, 3);
  EXPECT_EQ(s.count, 8);
  for (const char* bad : {"8/8", "-1/4", "1/0", "1", "a/b", "1/4x", "", "/4", "1/"}) {
    EXPECT_THROW(parse_shard(bad), InputError) << bad;
  }
}

TEST(Shard, FromSlurmArrayWithOffset) {
  ScopedEnv id("SLURM_ARRAY_TASK_ID", "5");
  ScopedEnv count("SLURM_ARRAY_TASK_COUNT", "4");
  ScopedEnv first("SLURM_ARRAY_TASK_MIN", "3");
  const auto s = shard_from_environment();
  ASSERT_TRUE(s);
  EXPECT_EQ(s->index, 2);
  EXPECT_EQ(s->count, 4);
}

TEST(Shard, FromKubernetesIndexedJob) {
  ScopedEnv index("JOB_COMPLETION_INDEX", "1");
  EXPECT_THROW(shard_from_environment(), InputError);  // the count must be given too
  ScopedEnv count("SKYLIT_SHARD_COUNT", "3");
  const auto s = shard_from_environment();
  ASSERT_TRUE(s);
  EXPECT_EQ(s->index, 1);
  EXPECT_EQ(s->count, 3);
}

TEST(Shard, NoneWithoutEnvironment) {
  unsetenv("SLURM_ARRAY_TASK_ID");
  unsetenv("JOB_COMPLETION_INDEX");
  EXPECT_FALSE(shard_from_environment());
}

TEST(FaceSampleDirections, CentreForOneSampleStratifiedInsideOtherwise) {
  const geom::Dome dome(4);
  for (int i = 0; i < dome.face_count(); i += 7) {
    const auto one = face_sample_directions(dome, i, 1);
    ASSERT_EQ(one.size(), 1u);
    EXPECT_LT((one[0] - dome.face(i).centre).norm(), 1e-15);
    const auto many = face_sample_directions(dome, i, 16);
    ASSERT_EQ(many.size(), 16u);
    for (const auto& d : many) {
      EXPECT_NEAR(d.norm(), 1.0, 1e-12);
      EXPECT_EQ(dome.face_of(d), i);
    }
    EXPECT_EQ(many, face_sample_directions(dome, i, 16));  // deterministic: shards agree
  }
}

}  // namespace
}  // namespace skylit::baker
