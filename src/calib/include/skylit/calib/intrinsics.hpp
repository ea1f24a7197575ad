#pragma once
// Camera intrinsics from photos of a board: OpenCV's fisheye model (Kannala–Brandt, k1..k4, for
// the sky camera) or its pinhole model (k1, k2, p1, p2, k3, for an HMD camera), the quality
// figures an installer needs (RMS and per-view reprojection errors, how much of the image the
// board covered), the photos that were not used and why, and advice when the data are not good
// enough. The result is the calibration schema of skylit/sky/calibration.hpp.
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "skylit/calib/board.hpp"
#include "skylit/camera/calibration.hpp"

namespace skylit::calib {

struct NamedView {
  std::string name;  // the photo's file name (messages, reports)
  BoardView view;
};

struct RejectedView {
  std::string name;
  std::string reason;
};

// The boards found in a set of photos.
struct BoardPhotos {
  cv::Size image_size;                 // the size most readable photos have; every view has it
  std::vector<NamedView> views;        // in the photos' order
  std::vector<RejectedView> rejected;  // unreadable, another size, no board
  cv::Mat first_image;                 // the first readable photo of that size (the coverage image's background)
};

// Reads each photo and finds the board. Never throws for a bad photo: it goes to `rejected`, and
// so does a photo of another size than most photos have (a stray picture among the board's).
BoardPhotos detect_boards(std::span<const std::filesystem::path> photos, const BoardDetector& detector);

struct IntrinsicsOptions {
  camera::LensModel model = camera::LensModel::Fisheye;
  int min_views = 3;           // fewer usable views: InputError (the calibration is not attempted)
  int recommended_views = 10;  // fewer: advice
  double min_coverage = 0.5;   // of the image the lens sees (θ < 90°): advice below
  double max_rms_px = 1.0;     // advice above
  // A view whose error exceeds max(outlier_factor × median, outlier_floor_px) is dropped and the
  // calibration run again without it (a blurred photo, a board that moved or bent).
  double outlier_factor = 3.0;
  double outlier_floor_px = 1.0;
};

struct IntrinsicsResult {
  // R_site_from_camera identity (sky-orientation sets it), rms and per_view_errors (pixels, in
  // the order of `used`).
  camera::CameraCalibration calibration;
  std::vector<NamedView> used;         // in the photos' order
  std::vector<RejectedView> rejected;  // not found, another size, ill-conditioned, outliers
  double coverage = 0;                 // fraction of the image the lens sees covered by boards
  std::vector<std::string> advice;     // what to do when the data are not good enough
};

// Calibrates from the views (all of `image_size`); `rejected` lists photos already left out,
// for the report. InputError saying what to do when fewer than min_views views are usable (or
// remain after the ill-conditioned ones are dropped), naming the photos that were left out.
IntrinsicsResult calibrate_intrinsics(std::vector<NamedView> views, std::vector<RejectedView> rejected, cv::Size image_size,
                                      const IntrinsicsOptions& options);

// Fraction of the pixels the lens sees (unprojecting to θ < 90°) that lie inside the convex
// hull of some view's corners.
double board_coverage(const camera::CameraCalibration& calibration, std::span<const NamedView> views);

// All corners of all used views on one frame (`background`, dimmed; black when empty), each
// view in its own colour, the image border, the lens's 90° circle for a fisheye, and the
// coverage and RMS written on it. CV_8UC3.
cv::Mat draw_coverage(const IntrinsicsResult& result, const cv::Mat& background);

// The calibration schema's YAML with comments naming the photos, the board and how to set
// R_site_from_camera. `summary`: what made it ("skylit-calib fisheye, chessboard 9x6, 0.025 m").
std::string intrinsics_yaml(const IntrinsicsResult& result, const std::string& summary);

}  // namespace skylit::calib
