#pragma once
// Calibration targets and where their corners are in a photo: a chessboard (its inner corners)
// or a ChArUco board (a chessboard with ArUco markers in its white squares, so that a board
// partly out of the frame still gives corners that know which ones they are). Corners are
// refined to sub-pixel positions.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

namespace skylit::calib {

struct BoardSpec {
  enum class Kind { Chessboard, Charuco };
  Kind kind = Kind::Chessboard;
  // Chessboard: inner corners per row × per column (9x6 for a board of 10 × 7 squares).
  // ChArUco: squares per row × per column, as OpenCV and board generators count them.
  cv::Size grid{9, 6};
  double square_m = 0.025;                 // side of one square, metres
  double marker_m = 0;                     // ChArUco: side of one marker, metres (less than square_m)
  std::string dictionary = "DICT_4X4_50";  // ChArUco: an OpenCV predefined dictionary
};

// "9x6" (or "9X6", "9×6") → {9, 6}. InputError naming `option` and the expected form unless
// both numbers are integers ≥ `min_each`.
cv::Size parse_grid(const std::string& text, const std::string& option, int min_each);

// InputError naming the option (--board, --charuco, --square, --marker, --dict) for a grid that
// is too small, a length that is not positive, a marker not smaller than its square, an unknown
// dictionary or one with fewer markers than the board needs.
void validate(const BoardSpec& spec);

// The names --dict accepts ("DICT_4X4_50", also without the prefix, any case).
std::vector<std::string> dictionary_names();

// One photo's corners: board coordinates (metres, z = 0) and their image positions.
struct BoardView {
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
};

struct BoardDetection {
  std::optional<BoardView> view;
  std::string reason;  // why there is no view ("no chessboard of 9x6 inner corners found", ...)
};

class BoardDetector {
 public:
  explicit BoardDetector(const BoardSpec& spec);  // validate()s the spec
  ~BoardDetector();
  BoardDetector(const BoardDetector&) = delete;
  BoardDetector& operator=(const BoardDetector&) = delete;

  // `image`: 8-bit gray or BGR. A chessboard is found whole or not at all; a ChArUco view needs
  // at least min_charuco_corners() corners, not all on one line.
  BoardDetection detect(const cv::Mat& image) const;

  // Every corner of the board, in board coordinates (metres, z = 0).
  const std::vector<cv::Point3f>& corners() const { return corners_; }
  const BoardSpec& spec() const { return spec_; }
  static int min_charuco_corners() { return 8; }

 private:
  struct Charuco;  // hides OpenCV's aruco types
  BoardDetection detect_chessboard(const cv::Mat& gray) const;
  BoardDetection detect_charuco(const cv::Mat& gray) const;

  BoardSpec spec_;
  std::vector<cv::Point3f> corners_;
  std::unique_ptr<Charuco> charuco_;
};

// Refines corners in place (cv::cornerSubPix) with a window that stays inside one square: half
// of it at most 0.4 × the smallest distance between neighbouring corners, from 2 to 11 pixels.
void refine_corners(const cv::Mat& gray, std::vector<cv::Point2f>& corners, double corner_spacing_px);

}  // namespace skylit::calib
