// The HMD lens in the composite: the pixel-to-ray table agrees with the lens model, its pinhole
// covers every ray, and a known site point drawn by the compositor lands on the pixel the lens
// model projects it to (within 0.5 px), across a strongly distorting lens.
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "compose_fixture.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/render/lens_remap.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::compose_test {
namespace {

TEST(LensRemap, RaysFollowTheLensModelAndThePinholeCoversThem) {
  const camera::CameraCalibration calibration = hmd_camera();
  const camera::Lens lens(calibration);
  const render::LensRemap remap = render::make_lens_remap(lens);
  ASSERT_EQ(remap.rays.cols, 320);
  ASSERT_EQ(remap.rays.rows, 240);
  EXPECT_EQ(remap.valid_pixels, 320 * 240);
  double worst = 0;
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) {
      const cv::Vec4f r = remap.rays.at<cv::Vec4f>(y, x);
      ASSERT_EQ(r[3], 1.0f);
      const Vector3d ray(r[0], r[1], r[2]);
      EXPECT_NEAR(ray.norm(), 1.0, 1e-6);
      const auto pixel = lens.project(ray);
      ASSERT_TRUE(pixel);
      worst = std::max(worst, (*pixel - Eigen::Vector2d(x, y)).norm());
      const auto q = remap.pinhole.project(ray);
      ASSERT_TRUE(q);
      // Bilinear lookups stay inside: one texel of margin on every side.
      ASSERT_GE(q->x(), 0.99);
      ASSERT_GE(q->y(), 0.99);
      ASSERT_LE(q->x(), remap.pinhole.width - 2.01);
      ASSERT_LE(q->y(), remap.pinhole.height - 2.01);
    }
  }
  EXPECT_LT(worst, 1e-3);
  // The barrel lens sees more than its pinhole of the same focal length would.
  EXPECT_GT(remap.pinhole.width, 320);
  EXPECT_DOUBLE_EQ(remap.pinhole.fx, calibration.fx);

  // A narrow max_angle leaves the outer rays out; max_size shrinks the focal length.
  render::LensRemapOptions options;
  options.max_angle_deg = 30.0;
  const render::LensRemap narrow = render::make_lens_remap(lens, options);
  EXPECT_LT(narrow.valid_pixels, 320 * 240);
  EXPECT_GT(narrow.valid_pixels, 0);
  options = {};
  options.max_size = 200;
  const render::LensRemap small = render::make_lens_remap(lens, options);
  EXPECT_LE(std::max(small.pinhole.width, small.pinhole.height), 200);
  EXPECT_LT(small.pinhole.fx, calibration.fx);
}

// Small squares facing the camera at known site points, drawn bright on black.
struct Targets {
  scene::Mesh mesh;
  std::vector<Vector3d> centres;
};

Targets squares_at(const camera::Lens& lens, const render::CameraPose& pose, const std::vector<Eigen::Vector2d>& pixels,
                   double distance, double side) {
  Targets targets;
  targets.mesh.materials = {scene::Material{"white", {1, 1, 1, 1}, -1}};
  for (const Eigen::Vector2d& pixel : pixels) {
    const Vector3d ray = lens.unproject(pixel)->normalized();
    const Vector3d centre = pose.R_site_from_camera * (distance * ray) + pose.t_site_from_camera;
    const Vector3d normal = -(pose.R_site_from_camera * ray);
    const Vector3d a = normal.cross(Vector3d::UnitZ()).normalized() * (side / 2);
    const Vector3d b = normal.cross(a).normalized() * (side / 2);
    const auto first = static_cast<std::uint32_t>(targets.mesh.positions.size());
    const std::array<Vector3d, 4> corners{Vector3d(centre - a - b), Vector3d(centre + a - b), Vector3d(centre + a + b),
                                          Vector3d(centre - a + b)};
    for (const Vector3d& corner : corners) {
      targets.mesh.positions.push_back(corner.cast<float>());
      targets.mesh.normals.push_back(normal.cast<float>());
    }
    for (std::uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) targets.mesh.indices.push_back(first + i);
    targets.mesh.triangle_material.insert(targets.mesh.triangle_material.end(), {0u, 0u});
    targets.centres.push_back(centre);
  }
  return targets;
}

TEST(LensRemap, ASitePointLandsWhereTheLensModelProjectsIt) {
  const gpu::HeadlessContext context;
  const camera::CameraCalibration calibration = hmd_camera();
  const camera::Lens lens(calibration);
  const render::CameraPose pose = hmd_pose();
  std::vector<Eigen::Vector2d> pixels;
  for (double y : {14.0, 60.0, 118.0, 180.0, 226.0}) {
    for (double x : {14.0, 80.0, 161.0, 240.0, 306.0}) pixels.emplace_back(x + 0.3, y - 0.2);
  }
  const Targets targets = squares_at(lens, pose, pixels, 6.0, 0.12);

  // A bake-shaped description of the squares: no planes, a transfer of 0.1 sr on every face.
  const geom::Dome dome(2);
  bake_format::Manifest manifest;
  for (int i = 0; i < dome.face_count(); ++i) {
    bake_format::FaceRecord face;
    face.index = i;
    face.direction = dome.face(i).centre;
    face.solid_angle = dome.face(i).solid_angle;
    for (std::size_t c = 0; c < 3; ++c) face.vertices[c] = dome.vertices()[static_cast<std::size_t>(dome.face(i).vertex[c])];
    manifest.faces.push_back(face);
  }
  manifest.plan.vertex_count = targets.mesh.vertex_count();
  const std::vector<float> transfer(targets.mesh.vertex_count() * manifest.faces.size(), 0.1f);
  scene::Site site;
  render::Compositor compositor(site, targets.mesh, manifest, transfer, calibration);
  const std::vector<Vector3d> S(manifest.faces.size(), Vector3d::Ones());
  render::CompositeInput input;
  input.camera = cv::Mat(240, 320, CV_32FC3, cv::Scalar::all(0));
  input.pose = pose;
  input.sky = S;
  const cv::Mat out = compositor.composite(input);
  save_picture("lens_targets", out * 4.0);

  double worst = 0, worst_undistorted = 0;
  for (std::size_t k = 0; k < pixels.size(); ++k) {
    const Vector3d camera_point = pose.R_site_from_camera.transpose() * (targets.centres[k] - pose.t_site_from_camera);
    const Eigen::Vector2d expected = *lens.project(camera_point);
    // The intensity-weighted centroid of the square's image.
    double sum = 0;
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    for (int y = static_cast<int>(expected.y()) - 10; y <= static_cast<int>(expected.y()) + 10; ++y) {
      for (int x = static_cast<int>(expected.x()) - 10; x <= static_cast<int>(expected.x()) + 10; ++x) {
        if (x < 0 || y < 0 || x >= 320 || y >= 240) continue;
        const double w = out.at<cv::Vec3f>(y, x)[1];
        sum += w;
        centroid += w * Eigen::Vector2d(x, y);
      }
    }
    ASSERT_GT(sum, 0.0) << "target " << k << " not drawn";
    centroid /= sum;
    const double error = (centroid - expected).norm();
    worst = std::max(worst, error);
    // Where an undistorted pinhole would have put it.
    const Eigen::Vector2d pinhole(calibration.fx * camera_point.x() / camera_point.z() + calibration.cx,
                                  calibration.fy * camera_point.y() / camera_point.z() + calibration.cy);
    worst_undistorted = std::max(worst_undistorted, (pinhole - expected).norm());
    EXPECT_LT(error, 0.5) << "target " << k << " at (" << expected.x() << ", " << expected.y() << ")";
  }
  std::printf("measured: %zu targets, worst |centroid − lens projection| %.3f px (an undistorted pinhole: %.1f px)\n",
              pixels.size(), worst, worst_undistorted);
  EXPECT_GT(worst_undistorted, 10.0);  // the lens distorts strongly: the test can tell
}

}  // namespace
}  // namespace skylit::compose_test
