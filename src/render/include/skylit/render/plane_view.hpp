#pragma once
// Whether a shadowing plane can show in a frame: the live service blends T only for the planes
// the current view can see (docs/live.md, "Only the planes in view").
#include "skylit/geom/plane.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/render/lens_remap.hpp"
#include "skylit/camera/calibration.hpp"

namespace skylit::render {

struct PlaneViewOptions {
  // The view's image rectangle grown by this on every side (its pixels): covers the bilinear
  // lookups around each ray's pinhole position and the rounding of the view's bounds.
  double margin_px = 4.0;
  // m: the plane's rectangle taken as a box of ± this along its normal. The compositor lets a
  // building fragment take T_j within CompositorOptions::cover_distance of plane j's rectangle,
  // so such a fragment may show while the rectangle itself does not.
  double thickness = 0.0;
  // m: the view starts this far in front of the camera (the part of the plane behind it is cut off).
  double near = 1e-3;
};

// True when some point of the plane's rectangle (or box, see thickness) within the view's
// frustum may project into the view's image: the box, in the camera frame of `pose`, is clipped
// at z = near and the bounding rectangle of its projection is tested against the image
// rectangle [-0.5, width − 0.5] × [-0.5, height − 0.5] grown by margin_px. False for a plane
// entirely behind the camera (or nearer than `near`) or entirely beside the view.
//
// The test is conservative: it may call a plane that no pixel shows "in view" (it compares
// bounding rectangles, and grows the view by a margin), never the other way round, since a plane
// wrongly left out would be drawn with a T of an older sky.
bool plane_in_view(const geom::Plane& plane, const CameraPose& pose, const PinholeCamera& view,
                   const PlaneViewOptions& options = {});

// The ideal pinhole view that holds every ray the calibration's lens images within
// max_angle_deg of its axis (what the compositor draws: LensRemapOptions::max_angle_deg), with the
// calibration's focal lengths. A pinhole model without distortion: the image itself. A distorting
// lens (barrel, fisheye) images rays whose undistorted projection lies outside its image
// rectangle, so the image rectangle alone would call such planes "out of view": instead the
// border of the image is unprojected through the lens model and the view spans the undistorted
// positions of those rays (radial distortion maps the image's border to the rays' outer bounds),
// capped at max_angle_deg where the border lies beyond it or cannot be unprojected.
// The compositor's own LensRemap::pinhole is the same bound taken over every pixel.
PinholeCamera undistorted_view(const camera::CameraCalibration& calibration, double max_angle_deg = 75.0);

// plane_in_view through undistorted_view(calibration) with the given margin (its pixels).
bool plane_in_view(const geom::Plane& plane, const CameraPose& pose, const camera::CameraCalibration& calibration,
                   double margin_px);

}  // namespace skylit::render
