// The marker survey on a site with known tags: from rendered photos (detector and all) and from
// projected corners with pixel noise; tags that cannot be placed are reported, not guessed.
#include "skylit/calib/marker_survey.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "skylit/base/error.hpp"
#include "skylit/track/marker_render.hpp"
#include "skylit/track/tag_detector.hpp"
#include "skylit/camera/lens.hpp"
#include "synthetic_markers.hpp"

namespace {

namespace calib = skylit::calib;
namespace track = skylit::track;
using skylit::calib_test::position_error_m;
using skylit::calib_test::rotation_error_deg;

calib::MarkerSurveyOptions twenty_cm_tags() {
  calib::MarkerSurveyOptions options;
  options.default_size = 0.20;
  options.origin_id = 0;
  return options;
}

std::vector<calib::MarkerPhoto> projected_photos(const track::MarkerMap& site, double noise_px, unsigned seed = 7) {
  std::mt19937 random(seed);
  std::vector<calib::MarkerPhoto> photos;
  int k = 0;
  for (const track::Pose& pose : skylit::calib_test::survey_viewpoints()) {
    photos.push_back({"view" + std::to_string(k++) + ".png",
                      skylit::calib_test::project_tags(site, skylit::calib_test::survey_camera(), pose, noise_px, random)});
  }
  return photos;
}

// Every true tag is in the map within the tolerances; the worst errors are returned for the log.
std::pair<double, double> expect_map_matches(const track::MarkerMap& truth, const calib::MarkerSurvey& survey, double max_m,
                                             double max_deg) {
  double worst_m = 0, worst_deg = 0;
  for (const track::MarkerTag& expected : truth.tags) {
    const track::MarkerTag* found = survey.map.find(expected.id);
    EXPECT_NE(found, nullptr) << "tag " << expected.id << " is not in the map";
    if (!found) continue;
    const double m = position_error_m(*found, expected), deg = rotation_error_deg(*found, expected);
    EXPECT_LE(m, max_m) << "tag " << expected.id;
    EXPECT_LE(deg, max_deg) << "tag " << expected.id;
    EXPECT_DOUBLE_EQ(found->size, expected.size);
    worst_m = std::max(worst_m, m);
    worst_deg = std::max(worst_deg, deg);
  }
  return {worst_m, worst_deg};
}

TEST(MarkerSurvey, RecoversTheSiteFromRenderedPhotos) {
  const track::MarkerMap site = skylit::calib_test::survey_site();
  const skylit::camera::CameraCalibration camera = skylit::calib_test::survey_camera();
  const skylit::camera::Lens lens(camera);
  track::TagDetectorOptions detector_options;
  detector_options.decimation = 1.0;
  track::TagDetector detector(detector_options);
  track::MarkerRenderOptions render;
  render.supersampling = 3;
  std::vector<calib::MarkerPhoto> photos;
  int k = 0;
  for (const track::Pose& pose : skylit::calib_test::survey_viewpoints()) {
    render.seed = static_cast<std::uint64_t>(k + 1);
    const cv::Mat frame = track::render_markers(site, lens, pose, render);
    photos.push_back({"view" + std::to_string(k++) + ".png", detector.detect(frame)});
  }
  const calib::MarkerSurvey survey = calib::survey_markers(photos, camera, twenty_cm_tags());
  ASSERT_EQ(survey.map.tags.size(), site.tags.size());
  EXPECT_TRUE(survey.left_out.empty());
  for (const calib::SurveyedPhoto& p : survey.photos) EXPECT_TRUE(p.posed) << p.name << ": " << p.reason;
  // 20 cm tags photographed from about 3 m: 1 cm and 0.5° are what an installer needs.
  const auto [worst_m, worst_deg] = expect_map_matches(site, survey, 0.01, 0.5);
  std::printf("rendered photos: worst tag position error %.2f mm, rotation %.3f°, RMS %.3f px, %d iterations\n",
              1000 * worst_m, worst_deg, survey.rms_px, survey.iterations);
  // The detector's corners are good to about 0.1 px; the chained poses alone leave 0.3 px.
  EXPECT_LT(survey.rms_px, 0.25);
  for (const calib::SurveyedTag& t : survey.tags) {
    EXPECT_GE(t.photos, 2) << "tag " << t.id;
    EXPECT_LT(t.rms_px, 0.35) << "tag " << t.id;
  }
  const track::MarkerTag* origin = survey.map.find(0);
  ASSERT_NE(origin, nullptr);
  EXPECT_EQ(origin->t_site_from_tag, Eigen::Vector3d::Zero()) << "the origin stays where it was put";
  const cv::Mat plan = calib::draw_marker_survey(survey, twenty_cm_tags());
  EXPECT_FALSE(plan.empty());
}

TEST(MarkerSurvey, RecoversTheSiteFromNoisyCorners) {
  const track::MarkerMap site = skylit::calib_test::survey_site();
  const calib::MarkerSurvey survey =
      calib::survey_markers(projected_photos(site, 0.2), skylit::calib_test::survey_camera(), twenty_cm_tags());
  ASSERT_EQ(survey.map.tags.size(), site.tags.size());
  const auto [worst_m, worst_deg] = expect_map_matches(site, survey, 0.01, 0.5);
  std::printf("0.2 px corner noise: worst tag position error %.2f mm, rotation %.3f°, RMS %.3f px\n", 1000 * worst_m,
              worst_deg, survey.rms_px);
  EXPECT_NEAR(survey.rms_px, 0.2 * std::sqrt(2.0), 0.05) << "the residual is the noise (0.2 px along each axis)";
  for (std::size_t k = 0; k < survey.tags.size(); ++k) {
    const calib::SurveyedTag& t = survey.tags[k];
    std::printf("  tag %d: error %.2f mm %.3f°, stated 1σ %.2f mm %.3f°, %d photos, spread %.0f°\n", t.id,
                1000 * position_error_m(survey.map.tags[k], site.tags[k]), rotation_error_deg(survey.map.tags[k], site.tags[k]),
                1000 * t.sigma_position_m, t.sigma_rotation_deg, t.photos, t.view_spread_deg);
    if (t.origin) continue;
    // The fit's own uncertainty is stated, small and not zero.
    EXPECT_GT(t.sigma_position_m, 1e-5) << "tag " << t.id;
    EXPECT_LT(t.sigma_position_m, 0.01) << "tag " << t.id;
    EXPECT_LT(position_error_m(survey.map.tags[k], site.tags[k]), 3 * t.sigma_position_m) << "tag " << t.id;
  }
}

TEST(MarkerSurvey, AMisdetectedCornerDoesNotPullTheMap) {
  // Two detections have a corner 12 px from where it is (a shadow, a scratch): the Huber loss
  // counts those corners linearly, not squared, so the map stays within 1 cm and 0.5°, and the
  // photos with them are the ones reported.
  const track::MarkerMap site = skylit::calib_test::survey_site();
  std::vector<calib::MarkerPhoto> photos = projected_photos(site, 0.2, 21);
  photos[2].detections.at(1).corners[3] += Eigen::Vector2d(12, 0);
  photos[5].detections.at(0).corners[0] += Eigen::Vector2d(-7, 9.5);
  const calib::MarkerSurvey survey = calib::survey_markers(photos, skylit::calib_test::survey_camera(), twenty_cm_tags());
  ASSERT_EQ(survey.map.tags.size(), site.tags.size());
  const auto [worst_m, worst_deg] = expect_map_matches(site, survey, 0.01, 0.5);
  std::printf("2 misdetected corners: worst tag position error %.2f mm, rotation %.3f°\n", 1000 * worst_m, worst_deg);
  std::vector<std::pair<double, std::string>> by_error;
  for (const calib::SurveyedPhoto& p : survey.photos) by_error.emplace_back(p.rms_px, p.name);
  std::sort(by_error.rbegin(), by_error.rend());
  EXPECT_EQ(std::set<std::string>({by_error[0].second, by_error[1].second}), std::set<std::string>({"view2.png", "view5.png"}));
}

TEST(MarkerSurvey, OriginPoseMovesTheWholeMap) {
  const track::MarkerMap site = skylit::calib_test::survey_site();
  calib::MarkerSurveyOptions options = twenty_cm_tags();
  // The origin tag on a surveyed point 10 m east, turned 90° (its top edge west).
  const Eigen::Matrix3d R = skylit::calib_test::yaw(90);
  const Eigen::Vector3d t(10, 2, 0.5);
  options.origin_pose.R_site_from_tag = Eigen::Quaterniond(R);
  options.origin_pose.t_site_from_tag = t;
  const calib::MarkerSurvey survey =
      calib::survey_markers(projected_photos(site, 0.1), skylit::calib_test::survey_camera(), options);
  track::MarkerMap moved = site;
  for (track::MarkerTag& tag : moved.tags) {
    tag.t_site_from_tag = R * tag.t_site_from_tag + t;
    tag.R_site_from_tag = Eigen::Quaterniond(R) * tag.R_site_from_tag;
  }
  expect_map_matches(moved, survey, 0.005, 0.3);
}

TEST(MarkerSurvey, ReportsTagsThatCannotBePlaced) {
  track::MarkerMap site = skylit::calib_test::survey_site();
  std::vector<calib::MarkerPhoto> photos = projected_photos(site, 0.2);
  // Tag 8 in the first photo only; tag 7 in two photos that show no other tag.
  track::MarkerMap extra;
  extra.tags = {skylit::calib_test::tag_at(8, {0.4, 0.3, 0}, Eigen::Matrix3d::Identity())};
  std::mt19937 random(3);
  const std::vector<track::TagDetection> eight = skylit::calib_test::project_tags(
      extra, skylit::calib_test::survey_camera(), skylit::calib_test::survey_viewpoints()[0], 0.2, random);
  ASSERT_EQ(eight.size(), 1u);
  photos[0].detections.push_back(eight[0]);
  std::vector<track::TagDetection> seven = eight;
  seven[0].id = 7;
  photos.push_back({"far1.png", seven});
  photos.push_back({"far2.png", seven});
  photos.push_back({"nothing.png", {}});
  // Tag 3 twice in the second photo: both copies are dropped from it, the map still has tag 3.
  photos[1].detections.push_back(photos[1].detections.front());
  photos[1].detections.back().id = 3;
  photos[1].detections.back().corners[0].x() += 40;

  const calib::MarkerSurvey survey = calib::survey_markers(photos, skylit::calib_test::survey_camera(), twenty_cm_tags());
  EXPECT_EQ(survey.map.tags.size(), site.tags.size());
  EXPECT_EQ(survey.map.find(7), nullptr);
  EXPECT_EQ(survey.map.find(8), nullptr);
  ASSERT_EQ(survey.left_out.size(), 2u);
  EXPECT_EQ(survey.left_out[0].id, 7);
  EXPECT_NE(survey.left_out[0].reason.find("never seen together with a mapped tag"), std::string::npos) << survey.left_out[0].reason;
  EXPECT_EQ(survey.left_out[1].id, 8);
  EXPECT_NE(survey.left_out[1].reason.find("seen in 1 posed photo(s), fewer than 2"), std::string::npos) << survey.left_out[1].reason;
  EXPECT_FALSE(survey.photos[8].posed);
  EXPECT_EQ(survey.photos[8].reason, "tags 7 only, none of them mapped");
  EXPECT_EQ(survey.photos[10].reason, "no tag36h11 tags found");
  const bool advised = std::any_of(survey.advice.begin(), survey.advice.end(), [](const std::string& a) {
    return a.find("tag 7 is not mapped") != std::string::npos;
  });
  EXPECT_TRUE(advised);
  const bool duplicate_advised = std::any_of(survey.advice.begin(), survey.advice.end(), [](const std::string& a) {
    return a.find("tag 3 is seen 2 times in view1.png") != std::string::npos;
  });
  EXPECT_TRUE(duplicate_advised);
  EXPECT_EQ(std::count(survey.photos[1].tags.begin(), survey.photos[1].tags.end(), 3), 0);
  expect_map_matches(site, survey, 0.01, 0.5);
}

TEST(MarkerSurvey, RefusesWhenTheDataCannotMakeAMap) {
  const track::MarkerMap site = skylit::calib_test::survey_site();
  const skylit::camera::CameraCalibration camera = skylit::calib_test::survey_camera();
  std::vector<calib::MarkerPhoto> photos = projected_photos(site, 0.2);
  calib::MarkerSurveyOptions options = twenty_cm_tags();
  options.origin_id = 42;
  try {
    calib::survey_markers(photos, camera, options);
    ADD_FAILURE() << "an origin in no photo";
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the origin tag 42 is in none of the 8 photo(s) (tags seen: 0, 1, 2, 3, 4, 5)"),
              std::string::npos)
        << e.what();
  }
  photos.resize(1);
  try {
    calib::survey_markers(photos, camera, twenty_cm_tags());
    ADD_FAILURE() << "one photo";
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("too few views: 1 of 1 photo(s)"), std::string::npos) << e.what();
  }
  options = twenty_cm_tags();
  options.default_size = -1;
  EXPECT_THROW(calib::survey_markers(photos, camera, options), skylit::InputError);
}

}  // namespace
