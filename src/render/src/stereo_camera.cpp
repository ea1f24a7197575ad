// A stereo camera's eyes: their poses from the stereo calibration and the HMD frame composited
// per camera (see stereo_camera.hpp).
#include "skylit/render/stereo_camera.hpp"

#include <cstddef>
#include <stdexcept>
#include <string>

namespace skylit::render {

std::array<CameraPose, 2> stereo_camera_poses(const CameraPose& tracked_pose, const camera::StereoCalibration& stereo,
                                              int tracked_camera) {
  if (tracked_camera != 0 && tracked_camera != 1) {
    throw std::invalid_argument("stereo_camera_poses: camera 0 (left) or 1 (right), not " +
                                std::to_string(tracked_camera));
  }
  const Eigen::Matrix3d& R = stereo.R_right_from_left;
  const Eigen::Vector3d& t = stereo.t_right_from_left;
  std::array<CameraPose, 2> poses{tracked_pose, tracked_pose};
  if (tracked_camera == 0) {
    CameraPose& right = poses[1];
    right.R_site_from_camera = tracked_pose.R_site_from_camera * R.transpose();
    right.t_site_from_camera = tracked_pose.t_site_from_camera - right.R_site_from_camera * t;
  } else {
    // site = R_site_from_right (R x_left + t) + t_site_from_right.
    CameraPose& left = poses[0];
    left.R_site_from_camera = tracked_pose.R_site_from_camera * R;
    left.t_site_from_camera = tracked_pose.t_site_from_camera + tracked_pose.R_site_from_camera * t;
  }
  return poses;
}

void draw_hmd_frame(std::span<Compositor* const> eye_compositors, HmdDistortion& hmd,
                    std::span<const CompositeInput> eye_inputs) {
  if (eye_compositors.size() != 2 || eye_inputs.size() != 2 || eye_compositors[0] == nullptr ||
      eye_compositors[1] == nullptr) {
    throw std::invalid_argument("draw_hmd_frame: a stereo camera frame takes two compositors and two inputs (left, right)");
  }
  hmd.begin_frame();
  // Each compositor keeps its own display texture, so the order of the passes does not matter;
  // an eye is distorted right after its composite, as in the one-camera frame.
  for (int eye = 0; eye < hmd.profile().eye_count(); ++eye) {
    const auto e = static_cast<std::size_t>(eye);
    Compositor& compositor = *eye_compositors[e];
    const CompositeInput& input = eye_inputs[e];
    compositor.draw(input);
    hmd.draw_eye(eye, compositor.display_texture(), input.camera.cols, input.camera.rows);
  }
}

}  // namespace skylit::render
