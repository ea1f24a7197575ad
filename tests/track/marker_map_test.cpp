// The marker map's YAML: reading, writing back, and the errors a user gets.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "marker_scene.hpp"
#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/track/marker_map.hpp"

namespace marker_map_test {  // named, not anonymous: the test program is one unity build

using namespace skylit::track;
namespace fs = std::filesystem;
using skylit::test::TempDir;

std::string error_of(const fs::path& file) {
  try {
    load_marker_map(file);
  } catch (const skylit::InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(MarkerMap, ReadsQuaternionsMatricesAndTheDefaultSize) {
  TempDir dir("skylit_markers_");
  const fs::path file = dir.write("tags.yaml",
                                  "family: tag36h11\n"
                                  "size: 0.2\n"
                                  "tags:\n"
                                  "  - id: 3\n"
                                  "    position: [1, 2, 0]\n"
                                  "    orientation: [1, 0, 0, 0]\n"
                                  "  - id: 4\n"
                                  "    size: 0.15\n"
                                  "    position: [0, 3, 1.5]\n"
                                  "    R: [1, 0, 0,  0, 0, -1,  0, 1, 0]   # on a wall facing south\n");
  const MarkerMap map = load_marker_map(file);
  EXPECT_EQ(map.family, "tag36h11");
  ASSERT_EQ(map.tags.size(), 2u);
  EXPECT_EQ(map.tags[0].id, 3);
  EXPECT_DOUBLE_EQ(map.tags[0].size, 0.2);
  EXPECT_DOUBLE_EQ(map.tags[1].size, 0.15);
  ASSERT_NE(map.find(4), nullptr);
  EXPECT_EQ(map.find(5), nullptr);
  // The wall tag: corner 0 (bottom-left seen from the south) is west and low, corner 2 east and high.
  const auto corners = tag_corners_in_site(*map.find(4));
  EXPECT_LT((corners[0] - Vec3(-0.075, 3, 1.425)).norm(), 1e-12);
  EXPECT_LT((corners[1] - Vec3(0.075, 3, 1.425)).norm(), 1e-12);
  EXPECT_LT((corners[2] - Vec3(0.075, 3, 1.575)).norm(), 1e-12);
  EXPECT_LT((corners[3] - Vec3(-0.075, 3, 1.575)).norm(), 1e-12);
  EXPECT_LT(((map.find(4)->R_site_from_tag * Vec3::UnitZ()) - Vec3(0, -1, 0)).norm(), 1e-12) << "faces south";
}

TEST(MarkerMap, WritesWhatItReadsBack) {
  TempDir dir("skylit_markers_");
  MarkerMap map = marker_scene::wall_of_four();
  map.tags[2].R_site_from_tag = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized())) * map.tags[2].R_site_from_tag;
  map.tags[3].size = 0.123456789;
  const fs::path file = dir.path() / "written.yaml";
  save_marker_map(map, file);
  const MarkerMap back = load_marker_map(file);
  EXPECT_EQ(back.family, map.family);
  ASSERT_EQ(back.tags.size(), map.tags.size());
  for (std::size_t i = 0; i < map.tags.size(); ++i) {
    EXPECT_EQ(back.tags[i].id, map.tags[i].id);
    EXPECT_DOUBLE_EQ(back.tags[i].size, map.tags[i].size);
    EXPECT_LT((back.tags[i].t_site_from_tag - map.tags[i].t_site_from_tag).norm(), 1e-15);
    EXPECT_LT(back.tags[i].R_site_from_tag.angularDistance(map.tags[i].R_site_from_tag), 1e-12);
  }
  MarkerMap duplicate = map;
  duplicate.tags[1].id = duplicate.tags[0].id;
  EXPECT_THROW(save_marker_map(duplicate, file), skylit::InputError);
  EXPECT_EQ(load_marker_map(file).tags[1].id, 1) << "a refused save leaves the file as it was";
}

struct BadMap {
  const char* name;
  std::string yaml;
  std::string expected;
};

class MarkerMapErrors : public ::testing::TestWithParam<BadMap> {};

TEST_P(MarkerMapErrors, NameTheFileLineFieldAndFix) {
  TempDir dir("skylit_markers_");
  const fs::path file = dir.write("tags.yaml", GetParam().yaml);
  const std::string message = error_of(file);
  EXPECT_NE(message.find(file.string()), std::string::npos) << message;
  EXPECT_NE(message.find(GetParam().expected), std::string::npos) << message;
  EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
}

const std::string kTag = "  - id: 1\n    size: 0.2\n    position: [0, 0, 0]\n    orientation: [1, 0, 0, 0]\n";

INSTANTIATE_TEST_SUITE_P(
    Cases, MarkerMapErrors,
    ::testing::Values(
        BadMap{"UnknownFamily", "family: tag36h12\ntags:\n" + kTag, "tags.yaml:1:9: field 'family': unknown AprilTag family 'tag36h12'. Fix: did you mean 'tag36h11'?"},
        BadMap{"NoFamily", "tags:\n" + kTag, "field 'family': required field is missing"},
        BadMap{"UnknownField", "family: tag36h11\ntags:\n" + kTag + "    colour: black\n", "tags.yaml:7:5: field 'tags[0].colour': unknown field"},
        BadMap{"IdOutsideFamily", "family: tag16h5\ntags:\n  - id: 40\n    size: 0.2\n    position: [0, 0, 0]\n    orientation: [1, 0, 0, 0]\n",
               "tags.yaml:3:9: field 'tags[0].id': 40 is outside 0..29. Fix: use an id of family tag16h5"},
        BadMap{"DuplicateId", "family: tag36h11\ntags:\n" + kTag + kTag, "tags.yaml:7:9: field 'tags[1].id': id 1 is already used at line 3"},
        BadMap{"NoSize", "family: tag36h11\ntags:\n  - id: 1\n    position: [0, 0, 0]\n    orientation: [1, 0, 0, 0]\n",
               "field 'tags[0].size': required field is missing (and no map-wide 'size' is given)"},
        BadMap{"NegativeSize", "family: tag36h11\ntags:\n  - id: 1\n    size: -0.2\n    position: [0, 0, 0]\n    orientation: [1, 0, 0, 0]\n",
               "tags.yaml:4:11: field 'tags[0].size': must be positive"},
        BadMap{"NotUnit", "family: tag36h11\ntags:\n  - id: 1\n    size: 0.2\n    position: [0, 0, 0]\n    orientation: [1, 1, 0, 0]\n",
               "field 'tags[0].orientation': the quaternion's length is 1.414"},
        BadMap{"Mirror", "family: tag36h11\ntags:\n  - id: 1\n    size: 0.2\n    position: [0, 0, 0]\n    R: [-1, 0, 0, 0, 1, 0, 0, 0, 1]\n",
               "field 'tags[0].R': not a rotation (its determinant is negative: a mirror)"},
        BadMap{"Both", "family: tag36h11\ntags:\n" + kTag + "    R: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n", "both orientation and R are given"},
        BadMap{"Neither", "family: tag36h11\ntags:\n  - id: 1\n    size: 0.2\n    position: [0, 0, 0]\n", "neither orientation nor R is given"},
        BadMap{"ShortPosition", "family: tag36h11\ntags:\n  - id: 1\n    size: 0.2\n    position: [0, 0]\n    orientation: [1, 0, 0, 0]\n",
               "tags.yaml:5:15: field 'tags[0].position': expected a list of 3 numbers"},
        BadMap{"NoTags", "family: tag36h11\ntags: []\n", "field 'tags': the list is empty"},
        BadMap{"Syntax", "family: [tag36h11\n", "YAML syntax error"}),
    [](const ::testing::TestParamInfo<BadMap>& param_info) { return param_info.param.name; });

TEST(MarkerMap, MissingFileIsNamed) {
  const std::string message = error_of("/nonexistent/tags.yaml");
  EXPECT_NE(message.find("/nonexistent/tags.yaml"), std::string::npos) << message;
  EXPECT_NE(message.find("does not exist"), std::string::npos) << message;
}

}  // namespace
