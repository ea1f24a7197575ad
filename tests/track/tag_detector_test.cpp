// AprilTag detection on synthetic frames: corner convention and order, grey and BGR, families.
#include <cmath>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "marker_scene.hpp"
#include "skylit/track/marker_render.hpp"
#include "skylit/track/tag_detector.hpp"
#include "skylit/camera/lens.hpp"

namespace {

using namespace skylit::track;
using namespace marker_scene;

// One tag of 20 cm 1 m ahead, seen a little from the side and rolled: ~200 px wide.
struct CloseTag {
  MarkerMap map;
  skylit::camera::Lens lens{hmd_camera()};
  Pose camera = head(Vec3(0.25, 2.0, 1.55), Vec3(0.0, 3.0, 1.6), 12);
  CloseTag() {
    map.family = "tag36h11";
    map.tags = {wall_tag(7, 0.0, 1.6)};
  }
  Eigen::Vector2d true_corner(int k) const {
    const Vec3 site = tag_corners_in_site(map.tags[0])[static_cast<std::size_t>(k)];
    const Vec3 camera_point = camera.R_site_from_camera.conjugate() * (site - camera.t_site_from_camera);
    return *lens.project(camera_point);
  }
};

TEST(TagDetector, CornersAreInOpenCvsPixelConventionAndTheMapsOrder) {
  CloseTag scene;
  MarkerRenderOptions render;
  render.noise_sigma = 0;
  const cv::Mat frame = render_markers(scene.map, scene.lens, scene.camera, render);
  for (const double decimation : {1.0, 2.0}) {
    TagDetectorOptions options;
    options.decimation = decimation;
    TagDetector detector(options);
    const std::vector<TagDetection> found = detector.detect(frame);
    ASSERT_EQ(found.size(), 1u) << "decimation " << decimation;
    EXPECT_EQ(found[0].id, 7);
    EXPECT_EQ(found[0].hamming, 0);
    EXPECT_GT(found[0].decision_margin, 50);
    Eigen::Vector2d mean_offset = Eigen::Vector2d::Zero();
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d offset = found[0].corners[static_cast<std::size_t>(k)] - scene.true_corner(k);
      // A corner in the wrong order would be ~200 px off; the wrong pixel convention 0.7 px.
      EXPECT_LT(offset.norm(), 0.3) << "corner " << k << " at decimation " << decimation;
      mean_offset += offset / 4;
    }
    EXPECT_LT(mean_offset.norm(), 0.15) << "no half-pixel shift at decimation " << decimation;
    const Vec3 centre = scene.camera.R_site_from_camera.conjugate() * (scene.map.tags[0].t_site_from_tag - scene.camera.t_site_from_camera);
    EXPECT_LT((found[0].center - *scene.lens.project(centre)).norm(), 0.5);
  }
}

TEST(TagDetector, ReadsBgrFramesAsGrey) {
  CloseTag scene;
  const cv::Mat grey = render_markers(scene.map, scene.lens, scene.camera);
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  TagDetector detector;
  const auto from_grey = detector.detect(grey);
  const auto from_bgr = detector.detect(bgr);
  ASSERT_EQ(from_grey.size(), 1u);
  ASSERT_EQ(from_bgr.size(), 1u);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_LT((from_grey[0].corners[k] - from_bgr[0].corners[k]).norm(), 1e-9);
  cv::Mat wrong(720, 1280, CV_16UC1, cv::Scalar(0));
  EXPECT_THROW(detector.detect(wrong), std::invalid_argument);
  EXPECT_TRUE(detector.detect(cv::Mat()).empty());
}

TEST(TagDetector, BlurWithoutDecimationLeavesTheCallersFrameAlone) {
  CloseTag scene;
  const cv::Mat frame = render_markers(scene.map, scene.lens, scene.camera);
  const cv::Mat before = frame.clone();
  TagDetectorOptions options;
  options.decimation = 1;
  options.blur_sigma = 0.8;
  TagDetector detector(options);
  EXPECT_EQ(detector.detect(frame).size(), 1u);
  EXPECT_EQ(cv::norm(frame, before, cv::NORM_INF), 0.0);
}

TEST(TagDetector, FindsNothingOfAnotherFamily) {
  CloseTag scene;
  const cv::Mat frame = render_markers(scene.map, scene.lens, scene.camera);
  for (const char* family : {"tag25h9", "tag16h5"}) {
    TagDetectorOptions options;
    options.family = family;
    EXPECT_TRUE(TagDetector(options).detect(frame).empty()) << family;
    // Without the margin filter, small families decode bits of noise: never with a real margin.
    options.min_decision_margin = 0;
    for (const TagDetection& d : TagDetector(options).detect(frame)) {
      EXPECT_LT(d.decision_margin, 5) << family << " id " << d.id;
    }
  }
}

TEST(TagDetector, DetectsOtherFamilies) {
  for (const char* family : {"tag25h9", "tagStandard41h12"}) {
    CloseTag scene;
    scene.map.family = family;
    const cv::Mat frame = render_markers(scene.map, scene.lens, scene.camera);
    TagDetectorOptions options;
    options.family = family;
    options.max_hamming = 1;
    TagDetector detector(options);
    const auto found = detector.detect(frame);
    ASSERT_EQ(found.size(), 1u) << family;
    EXPECT_EQ(found[0].id, 7);
    for (int k = 0; k < 4; ++k) {
      EXPECT_LT((found[0].corners[static_cast<std::size_t>(k)] - scene.true_corner(k)).norm(), 0.5) << family << " corner " << k;
    }
  }
}

TEST(TagDetector, RefusesUnknownFamiliesBadOptionsAndHugeDecodeTables) {
  TagDetectorOptions options;
  options.family = "tag36h12";
  try {
    TagDetector detector(options);
    FAIL() << "an unknown family was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tag36h11"), std::string::npos) << "lists the known families: " << e.what();
  }
  options = {};
  options.decimation = 0.5;
  EXPECT_THROW(TagDetector{options}, std::invalid_argument);
  options = {};
  options.threads = 0;
  EXPECT_THROW(TagDetector{options}, std::invalid_argument);
  options = {};
  options.family = "tagStandard52h13";  // 48714 codes of 52 bits: gigabytes at max_hamming 2
  try {
    TagDetector detector(options);
    FAIL() << "a decode table of gigabytes was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("use max_hamming 1"), std::string::npos) << e.what();
  }
}

TEST(TagFamilies, LayoutAndPatternOfTag36h11) {
  const TagFamilyLayout layout = tag_family_layout("tag36h11");
  EXPECT_EQ(layout.width_at_border, 8);
  EXPECT_EQ(layout.total_width, 10);
  EXPECT_EQ(layout.ncodes, 587);
  const std::vector<unsigned char> cells = tag_pattern("tag36h11", 0);
  ASSERT_EQ(cells.size(), 100u);
  // A white border cell, then the black border square.
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(cells[static_cast<std::size_t>(i)], 255) << "top white row";
    EXPECT_EQ(cells[static_cast<std::size_t>(90 + i)], 255) << "bottom white row";
  }
  for (int i = 1; i < 9; ++i) {
    EXPECT_EQ(cells[static_cast<std::size_t>(10 + i)], 0) << "top black row";
    EXPECT_EQ(cells[static_cast<std::size_t>(10 * i + 1)], 0) << "left black column";
  }
  EXPECT_THROW(tag_pattern("tag36h11", 587), std::out_of_range);
  EXPECT_EQ(tag_families().front(), "tag36h11");
}

}  // namespace
