// plane_in_view: a plane in front, behind, beside, straddling the near plane, just beyond the
// image within the margin; and undistorted_view, which must hold every ray a distorting lens images.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "skylit/render/plane_view.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::render {
namespace {

// A 640 × 480 pinhole, 90° wide, at the origin looking along +z (the camera frame is the site's).
PinholeCamera test_view() {
  PinholeCamera view;
  view.width = 640;
  view.height = 480;
  view.fx = view.fy = 320.0;
  view.cx = 319.5;
  view.cy = 239.5;
  return view;
}

// A 1 m × 1 m plane facing the camera (normal −z), its corner at `origin`.
geom::Plane square_at(const Eigen::Vector3d& origin, double size = 1.0) {
  geom::Plane plane;
  plane.name = "square";
  plane.origin = origin;
  plane.u = Eigen::Vector3d(size, 0, 0);
  plane.v = Eigen::Vector3d(0, size, 0);
  plane.width = plane.height = 8;
  return plane;
}

PlaneViewOptions with_margin(double margin_px) {
  PlaneViewOptions options;
  options.margin_px = margin_px;
  return options;
}

TEST(PlaneInView, APlaneInFrontIsInView) {
  EXPECT_TRUE(plane_in_view(square_at({-0.5, -0.5, 5.0}), CameraPose{}, test_view(), with_margin(0)));
}

TEST(PlaneInView, APlaneBehindTheCameraIsNot) {
  EXPECT_FALSE(plane_in_view(square_at({-0.5, -0.5, -5.0}), CameraPose{}, test_view(), with_margin(0)));
  // The same plane seen by a camera turned round (180° about y) is in view.
  CameraPose turned;
  turned.R_site_from_camera = Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_TRUE(plane_in_view(square_at({-0.5, -0.5, -5.0}), turned, test_view(), with_margin(0)));
}

TEST(PlaneInView, APlaneBesideTheViewIsNot) {
  // x from 10 to 11 m at 5 m: x/z ≥ 2, the view reaches 1 (at 45°).
  EXPECT_FALSE(plane_in_view(square_at({10.0, -0.5, 5.0}), CameraPose{}, test_view(), with_margin(0)));
  EXPECT_FALSE(plane_in_view(square_at({-0.5, 10.0, 5.0}), CameraPose{}, test_view(), with_margin(0)));
  // A camera moved beside it sees it.
  CameraPose moved;
  moved.t_site_from_camera = Eigen::Vector3d(10.5, 0, 0);
  EXPECT_TRUE(plane_in_view(square_at({10.0, -0.5, 5.0}), moved, test_view(), with_margin(0)));
}

TEST(PlaneInView, APlaneStraddlingTheNearPlaneIsInView) {
  // A floor under the camera from 5 m behind to 5 m in front: its corners behind the camera
  // project nowhere useful, yet the part in front shows at the image's bottom.
  geom::Plane floor;
  floor.name = "floor";
  floor.origin = Eigen::Vector3d(-2.0, 1.5, -5.0);   // y down: 1.5 m below the camera
  floor.u = Eigen::Vector3d(4.0, 0, 0);
  floor.v = Eigen::Vector3d(0, 0, 10.0);
  floor.width = floor.height = 8;
  EXPECT_TRUE(plane_in_view(floor, CameraPose{}, test_view(), with_margin(0)));
  // A wall 1 m to the right from 5 m behind to 5 m in front: it shows at the image's right.
  geom::Plane wall = floor;
  wall.origin = Eigen::Vector3d(1.0, -1.0, -5.0);
  wall.u = Eigen::Vector3d(0, 2.0, 0);
  wall.v = Eigen::Vector3d(0, 0, 10.0);
  EXPECT_TRUE(plane_in_view(wall, CameraPose{}, test_view(), with_margin(0)));
  // A plane through the camera seen edge on (it holds the camera's centre) shows nowhere.
  geom::Plane edge_on = wall;
  edge_on.origin = Eigen::Vector3d(-1.0, 0.0, -5.0);
  edge_on.u = Eigen::Vector3d(2.0, 0, 0);
  EXPECT_TRUE(plane_in_view(edge_on, CameraPose{}, test_view(), with_margin(0)))
      << "the line it projects to crosses the image: conservatively in view";
  // The same floor wholly behind the camera is not.
  floor.origin.z() = -11.0;
  EXPECT_FALSE(plane_in_view(floor, CameraPose{}, test_view(), with_margin(0)));
}

TEST(PlaneInView, APlaneJustBeyondTheImageIsInViewWithinTheMargin) {
  // Left edge 4 pixels beyond the right border: x/z = (640 − 0.5 + 4 − 319.5) / 320.
  const double z = 5.0;
  const double x = (640.0 - 0.5 + 4.0 - 319.5) / 320.0 * z;
  const geom::Plane plane = square_at({x, -0.5, z});
  EXPECT_FALSE(plane_in_view(plane, CameraPose{}, test_view(), with_margin(2.0)));
  EXPECT_TRUE(plane_in_view(plane, CameraPose{}, test_view(), with_margin(6.0)));
}

TEST(PlaneInView, ThicknessCoversFragmentsOffThePlane) {
  // A plane lying along the view's top edge plane, just outside it, whose box of ± 0.2 m reaches in.
  geom::Plane plane;
  plane.name = "ledge";
  plane.origin = Eigen::Vector3d(-0.5, -6.1, 5.0);   // y/z = −1.22: above the view (−0.75)
  plane.u = Eigen::Vector3d(1.0, 0, 0);
  plane.v = Eigen::Vector3d(0, 2.2, 0);             // y to −3.9 at z = 5: y/z = −0.78
  plane.width = plane.height = 8;
  EXPECT_FALSE(plane_in_view(plane, CameraPose{}, test_view(), with_margin(0)));
  PlaneViewOptions thick = with_margin(0);
  thick.thickness = 0.5;   // the box's near face at z = 4.5: y/z = −3.9/4.5 = −0.867; far at 5.5: −0.71
  EXPECT_TRUE(plane_in_view(plane, CameraPose{}, test_view(), thick));
}

TEST(UndistortedView, APinholeWithoutDistortionIsItsImage) {
  camera::CameraCalibration calibration;
  calibration.image_width = 640;
  calibration.image_height = 480;
  calibration.model = camera::LensModel::Pinhole;
  calibration.fx = calibration.fy = 320.0;
  calibration.cx = 319.5;
  calibration.cy = 239.5;
  calibration.D = {0, 0, 0, 0, 0};
  const PinholeCamera view = undistorted_view(calibration);
  EXPECT_EQ(view.width, 640);
  EXPECT_EQ(view.height, 480);
  EXPECT_DOUBLE_EQ(view.cx, 319.5);
}

TEST(UndistortedView, ABarrelLensSeesBeyondItsPinholeRectangle) {
  camera::CameraCalibration calibration;
  calibration.image_width = 640;
  calibration.image_height = 480;
  calibration.model = camera::LensModel::Pinhole;
  calibration.fx = calibration.fy = 320.0;
  calibration.cx = 319.5;
  calibration.cy = 239.5;
  calibration.D = {-0.2, 0.03, 0, 0, 0};
  const PinholeCamera view = undistorted_view(calibration);
  EXPECT_GT(view.width, 640);
  EXPECT_GT(view.height, 480);
  // The ray of the image's right edge, centre row, is inside the view; and a plane at that ray,
  // beyond the undistorted rectangle, is in view through the lens.
  const camera::Lens lens(calibration);
  const std::optional<Eigen::Vector3d> edge = lens.unproject(Eigen::Vector2d(639.0, 239.5));
  ASSERT_TRUE(edge.has_value());
  const double x = edge->x() / edge->z();
  EXPECT_GT(320.0 * x + 319.5, 639.5) << "barrel distortion: the edge's ray lies beyond the pinhole rectangle";
  const geom::Plane plane = square_at({x * 5.0 - 0.01, -0.5, 5.0}, 0.005);
  EXPECT_TRUE(plane_in_view(plane, CameraPose{}, calibration, 0.0));
  // Far beyond it: not.
  EXPECT_FALSE(plane_in_view(square_at({30.0, -0.5, 5.0}), CameraPose{}, calibration, 0.0));
}

}  // namespace
}  // namespace skylit::render
