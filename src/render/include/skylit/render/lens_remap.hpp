#pragma once
// The HMD camera's lens, for drawing the building: the building is rendered with an ideal
// pinhole camera, and the render is then distorted to the real lens through a table that gives,
// for every camera pixel, the ray the calibrated lens model says it sees (built once on the CPU,
// with camera::Lens). The camera's own pixels are never resampled: what the user sees of the real
// world stays exactly as the camera recorded it (docs/live.md, "Rendering and compositing").
#include <optional>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "skylit/camera/lens.hpp"

namespace skylit::render {

// An ideal pinhole camera in the camera frame (OpenCV: x right, y down, z forward), pixel centres
// at integer coordinates.
struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;

  // Pixel (x, y) of a camera-frame point or direction; nullopt at or behind the camera (z ≤ 0).
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& camera_point) const;
};

struct LensRemapOptions {
  double render_scale = 1.0;     // the pinhole's focal length over the HMD camera's fx, fy: the
                                 // building's texels go as its square (0.75: 44% fewer, its pass
                                 // about a third cheaper, a little softer; bench/RESULTS.md)
  double max_angle_deg = 75.0;   // rays farther than this from the optical axis get no building
                                 // (a pinhole image grows as tan θ; fisheye corners beyond this
                                 // show the camera image alone)
  int max_size = 4096;           // the pinhole image's longest side; the focal length shrinks
                                 // to fit when the lens's field of view needs more
};

struct LensRemap {
  // Per camera pixel (x, y), seen at its centre: the unit camera-frame direction of its ray in
  // channels 0..2 and 1 in channel 3; all 0 where the lens model cannot unproject the pixel or
  // its ray is beyond max_angle_deg. CV_32FC4, the calibration's size.
  cv::Mat rays;
  PinholeCamera pinhole;         // its image holds every valid ray, with a texel of margin
  int valid_pixels = 0;
};

// Throws InputError (naming the calibration's file) when no pixel of the image can be unprojected.
LensRemap make_lens_remap(const camera::Lens& lens, const LensRemapOptions& options = {});

}  // namespace skylit::render
