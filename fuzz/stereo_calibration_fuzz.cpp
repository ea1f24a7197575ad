// A stereo camera's calibration (camera::load_stereo_calibration, skylit-calib stereo's file): an
// accepted one must hold two lenses that project and unproject, and a rotation between them.
#include <cmath>

#include <Eigen/Core>

#include "fuzz_target.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/camera/stereo_calibration.hpp"

SKYLIT_FUZZ_TARGET(stereo_calibration) {
  const auto file = skylit::fuzz::write_input("calib/stereo.yaml", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] {
    const skylit::camera::StereoCalibration stereo = skylit::camera::load_stereo_calibration(file);
    const Eigen::Matrix3d& R = stereo.R_right_from_left;
    skylit::fuzz::require((R * R.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-3, "R_right_from_left is a rotation");
    skylit::fuzz::require(std::isfinite(stereo.baseline_m()) && stereo.baseline_m() > 0, "a finite, positive baseline");
    for (const skylit::camera::CameraCalibration* c : {&stereo.left, &stereo.right}) {
      const skylit::camera::Lens lens(*c);
      if (const auto direction = lens.unproject(skylit::camera::Vec2(c->image_width / 2.0, c->image_height / 2.0))) {
        skylit::fuzz::require(std::abs(direction->norm() - 1.0) < 1e-6, "unproject gives a unit direction");
        (void)lens.project(*direction);
      }
    }
  });
  return 0;
}
