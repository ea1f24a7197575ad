#pragma once
// The knobs of the marker tracker: the AprilTag detector's, the pose solver's and the tracker's.
// Plain values (no library types), so that a config can hold them. Their cost and effect are
// measured in bench/RESULTS.md (Tracking) and explained in docs/tracking.md.
#include <string>

namespace skylit::track {

struct TagDetectorOptions {
  // libapriltag's family name: tag36h11 (default), tag25h9, tag16h5, tag36h10, tagStandard41h12,
  // tagStandard52h13, tagCircle21h7, tagCircle49h12, tagCustom48h12.
  std::string family = "tag36h11";
  // Quads are searched in an image shrunk by this factor (1 = full resolution); the corners are
  // then refined on the full image when refine_edges is on. Faster, but small tags are lost.
  double decimation = 2.0;
  // Gaussian blur (σ, pixels of the decimated image) before the quad search; 0 = none; negative
  // sharpens. On a noisy frame it keeps the noise from breaking into countless small regions
  // (ten times faster at 1.5 grey levels of noise); corners are refined on the unblurred frame.
  double blur_sigma = 0.8;
  // Snap the quad's edges to the strongest gradients of the full-resolution image (sub-pixel
  // corners); almost free and essential with decimation.
  bool refine_edges = true;
  // Tiles (4×4 pixels of the decimated image) whose grey levels span less than this are left
  // out of the quad search (libapriltag's min_white_black_diff): flat, noisy areas then cost
  // nothing. A tag's black-to-white step must exceed it.
  int min_contrast = 10;
  // Sharpening of the sampled bits before decoding (libapriltag's decode_sharpening).
  double decode_sharpening = 0.25;
  // Worker threads of the detector (1 = the calling thread's core only).
  int threads = 1;
  // Bit errors corrected when decoding (0..3). The decode table grows with it: libapriltag
  // builds ncodes · nbits^h entries, so large families refuse 2 or 3 (the constructor says so).
  int max_hamming = 2;
  // Detections whose decision margin (mean distance of the bits from the threshold, grey
  // levels) is below this are dropped; 0 keeps everything libapriltag accepts. A printed tag
  // scores 100 and more even blurred or far; the false detections small families "find" in noise
  // or in other families' tags score under 5.
  double min_decision_margin = 15.0;
};

struct MarkerPoseOptions {
  // A tag whose corners reproject with an RMS error above this (pixels) after the joint solve is
  // an outlier (a tag moved since the map was made, a misdetection): it is dropped and the pose
  // solved again, as long as at least two tags remain that agree.
  double outlier_px = 4.0;
  // The final RMS reprojection error above which the pose is flagged high_error (pixels).
  double max_error_px = 2.0;
  // The ambiguity ratio (RMS error of the best pose over that of the best different pose; 0..1)
  // above which the pose is flagged ambiguous: the data cannot tell the two apart.
  double max_ambiguity = 0.5;
  // Two solutions are different when their rotations differ by more than this (degrees).
  double distinct_deg = 1.0;
  // A single tag whose mean edge in the image is shorter than this (pixels) is flagged
  // single_distant_tag: its pose is poorly determined (tilt, and so position, wander).
  double distant_tag_px = 40.0;
};

// Which cameras of a stereo camera the marker tracker detects tags in and solves from: one
// (half the detection time) or both (a better pose: docs/tracking.md, "Stereo cameras").
enum class StereoCameras { Left, Right, Both };

struct MarkerTrackerOptions {
  TagDetectorOptions detector;
  MarkerPoseOptions pose;
  // pose_at answers with the latest accepted pose for this long after its frame (seconds); later
  // the tracker has lost the markers and answers nothing.
  double max_age = 0.5;
  // Accept ambiguous poses (single tag, both solutions fit) instead of treating them as lost.
  bool accept_ambiguous = false;
  // Accept poses from a single small tag (single_distant_tag): a 20 cm tag at 7 m, 28 px across,
  // puts the camera tens of centimetres off.
  bool accept_single_distant = false;
  // A stereo camera's tracker only (a single camera's ignores it). The pose is the left camera's
  // whichever cameras are used.
  StereoCameras stereo_cameras = StereoCameras::Both;
};

// "left", "right", "both" (the config's values).
const char* to_string(StereoCameras cameras);

}  // namespace skylit::track
