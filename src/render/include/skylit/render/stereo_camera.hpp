#pragma once
// A stereo camera on the HMD (a camera per eye): both cameras' poses from the tracked one's and
// the stereo calibration, and the HMD frame that composites each eye from its own camera image
// and pose, through its own camera's Compositor and its own lens mesh (docs/hmd.md).
#include <array>
#include <span>

#include "skylit/camera/stereo_calibration.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/render/hmd_distortion.hpp"

namespace skylit::render {

// The poses of the left (0) and right (1) cameras, given the pose of camera `tracked_camera`
// (the one the head pose is for: the left one unless the tracker watches the right). With
// x_right = R_right_from_left x_left + t_right_from_left (camera::StereoCalibration):
//   R_site_from_right = R_site_from_left R_right_from_leftᵀ
//   t_site_from_right = t_site_from_left − R_site_from_right t_right_from_left
// and the inverse from the right camera's pose. std::invalid_argument for a camera not 0 or 1.
std::array<CameraPose, 2> stereo_camera_poses(const CameraPose& tracked_pose, const camera::StereoCalibration& stereo,
                                              int tracked_camera = 0);

// One HMD frame from a stereo camera: eye e's composite is drawn by eye_compositors[e] (the
// Compositor made with camera e's calibration: StereoCalibration::left, ::right) from
// eye_inputs[e] (camera e's image at its calibration's size, where a half of one side-by-side
// frame will do, capture::split_side_by_side; its pose from stereo_camera_poses; the sky, sun,
// shadow-ratio textures and sun shadow map the same for both eyes, the same objects if need be),
// then drawn through eye e's distortion mesh into its viewport of hmd.panel_texture(). The real world gets its parallax
// from the two cameras, the building and its shadows theirs from the two poses, so the shadow
// lies on the same ground point in both eyes. A single-layout profile shows the left camera's
// composite (the right is not drawn). No read-back, no wait for the GPU. std::invalid_argument
// unless there are two compositors (not null) and two inputs.
void draw_hmd_frame(std::span<Compositor* const> eye_compositors, HmdDistortion& hmd,
                    std::span<const CompositeInput> eye_inputs);

}  // namespace skylit::render
