#pragma once
// A stereo camera (a camera per eye) from pairs of board photos taken at the same moment: each
// camera's intrinsics from all its photos, then the right camera's pose relative to the left
// over every corner of every pair with the board in both photos, the rectified pair to check by
// eye, and what to do when the data are not good enough. The result is camera::StereoCalibration.
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "skylit/calib/board.hpp"
#include "skylit/calib/intrinsics.hpp"
#include "skylit/camera/stereo_calibration.hpp"

namespace skylit::calib {

// One pair of photos, as given (the k-th left photo with the k-th right one).
struct PhotoPair {
  std::filesystem::path left_file, right_file;
  std::optional<BoardView> left, right;  // the board, when found (in a photo of its camera's size)
  std::string left_reason, right_reason;  // why not
  std::string name() const;               // "left01.jpg + right01.jpg"
};

struct StereoPhotos {
  BoardPhotos left, right;        // each camera's boards (the intrinsics use every one)
  std::vector<PhotoPair> pairs;   // in the order given
};

// Reads each photo and finds the board. InputError for unequal counts or two photos of one
// camera with the same file name (the reports name photos by file name); a bad photo is not an
// error: its pair says why.
StereoPhotos detect_stereo_boards(std::span<const std::filesystem::path> left_photos,
                                  std::span<const std::filesystem::path> right_photos, const BoardDetector& detector);

struct StereoOptions {
  // Each camera's model (an HMD's cameras: pinhole unless told otherwise) and limits.
  IntrinsicsOptions left{camera::LensModel::Pinhole}, right{camera::LensModel::Pinhole};
  int min_pairs = 3;              // fewer usable pairs: InputError
  int recommended_pairs = 10;     // fewer: advice
  double max_rms_px = 1.0;        // advice above
  // A pair whose error exceeds max(outlier_factor × median, outlier_floor_px) is dropped and the
  // pose refined again without it.
  double outlier_factor = 3.0;
  double outlier_floor_px = 1.0;
};

struct UsedPair {
  std::size_t index = 0;  // in StereoPhotos::pairs
  std::string name;
  double rms_px = 0;      // over the pair's corners in both photos
};

struct RejectedPair {
  std::string name;
  std::string reason;
};

struct StereoResult {
  camera::StereoCalibration calibration;  // rms and per_pair_errors in the order of `used`
  IntrinsicsResult left, right;           // each camera's own calibration, its views and advice
  std::vector<UsedPair> used;             // in the photos' order
  std::vector<RejectedPair> rejected;     // the board in one photo only or in neither, outliers
  double rectified_row_error_px = 0;      // mean |y_left − y_right| of the used corners after rectification
  double rectified_row_error_p95_px = 0;  // 95% of the corners are within this
  int iterations = 0;                     // of the joint refinement
  std::vector<std::string> advice;
};

// Calibrates both cameras and their relative pose. InputError saying what to do when either
// camera's intrinsics fail (intrinsics' errors, naming the camera) or fewer than min_pairs pairs
// have the board in both photos.
StereoResult calibrate_stereo(const StereoPhotos& photos, const StereoOptions& options);

// The rectified pair side by side (left, right) with horizontal lines: a corner seen by both
// cameras lies on the same row in both halves. `pair`: one of result.used; the images are its
// photos. CV_8UC3.
cv::Mat draw_rectification(const StereoResult& result, const PhotoPair& pair, const cv::Mat& left_image,
                           const cv::Mat& right_image);

// The stereo schema's YAML with comments naming the pairs, the board and the pairs not used.
// `summary`: what made it ("skylit-calib stereo, chessboard 9x6, 0.025 m").
std::string stereo_yaml(const StereoResult& result, const StereoPhotos& photos, const std::string& summary);

}  // namespace skylit::calib
