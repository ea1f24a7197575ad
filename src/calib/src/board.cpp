#include "skylit/calib/board.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <string_view>
#include <utility>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "skylit/base/error.hpp"

namespace skylit::calib {
namespace {

struct DictionaryName {
  std::string_view name;
  cv::aruco::PREDEFINED_DICTIONARY_NAME id;
};

constexpr std::array<DictionaryName, 21> kDictionaries{{
    {"DICT_4X4_50", cv::aruco::DICT_4X4_50},
    {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
    {"DICT_4X4_250", cv::aruco::DICT_4X4_250},
    {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
    {"DICT_5X5_50", cv::aruco::DICT_5X5_50},
    {"DICT_5X5_100", cv::aruco::DICT_5X5_100},
    {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
    {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
    {"DICT_6X6_50", cv::aruco::DICT_6X6_50},
    {"DICT_6X6_100", cv::aruco::DICT_6X6_100},
    {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
    {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
    {"DICT_7X7_50", cv::aruco::DICT_7X7_50},
    {"DICT_7X7_100", cv::aruco::DICT_7X7_100},
    {"DICT_7X7_250", cv::aruco::DICT_7X7_250},
    {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
    {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
    {"DICT_APRILTAG_16H5", cv::aruco::DICT_APRILTAG_16h5},
    {"DICT_APRILTAG_25H9", cv::aruco::DICT_APRILTAG_25h9},
    {"DICT_APRILTAG_36H10", cv::aruco::DICT_APRILTAG_36h10},
    {"DICT_APRILTAG_36H11", cv::aruco::DICT_APRILTAG_36h11},
}};

std::string upper(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return text;
}

std::optional<cv::aruco::PREDEFINED_DICTIONARY_NAME> find_dictionary(const std::string& text) {
  std::string name = upper(text);
  if (!name.starts_with("DICT_")) name = "DICT_" + name;
  for (const DictionaryName& d : kDictionaries) {
    if (d.name == name) return d.id;
  }
  return std::nullopt;
}

[[noreturn]] void bad_option(const std::string& option, const std::string& problem, const std::string& fix) {
  throw InputError(input_message("", -1, -1, option, problem, fix));
}

// 'text' (appended: "'" + text trips GCC 12's -Wrestrict).
std::string quoted(const std::string& text) { return std::string(1, '\'').append(text).append(1, '\''); }

std::string grid_text(cv::Size grid) { return std::to_string(grid.width) + "x" + std::to_string(grid.height); }

// The smallest distance between neighbouring corners of a complete cols × rows grid.
double grid_spacing(const std::vector<cv::Point2f>& corners, cv::Size grid) {
  double spacing = std::numeric_limits<double>::infinity();
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      const cv::Point2f& p = corners[static_cast<std::size_t>(r * grid.width + c)];
      if (c + 1 < grid.width)
        spacing = std::min(spacing, cv::norm(p - corners[static_cast<std::size_t>(r * grid.width + c + 1)]));
      if (r + 1 < grid.height)
        spacing = std::min(spacing, cv::norm(p - corners[static_cast<std::size_t>((r + 1) * grid.width + c)]));
    }
  }
  return spacing;
}

}  // namespace

cv::Size parse_grid(const std::string& text, const std::string& option, int min_each) {
  const std::string fix = "write COLSxROWS with two whole numbers ≥ " + std::to_string(min_each) + ", e.g. 9x6";
  // "×" (U+00D7, bytes C3 97) as well as x and X.
  std::string normalised;
  for (std::size_t k = 0; k < text.size(); ++k) {
    if (text[k] == '\xC3' && k + 1 < text.size() && text[k + 1] == '\x97') {
      normalised += 'x';
      ++k;
    } else {
      normalised += text[k];
    }
  }
  const std::size_t cross = normalised.find_first_of("xX");
  if (cross == std::string::npos) bad_option(option, quoted(text) + " is not COLSxROWS", fix);
  const auto whole = [&](std::string_view part) {
    int value = 0;
    const auto [end, error] = std::from_chars(part.data(), part.data() + part.size(), value);
    if (part.empty() || error != std::errc() || end != part.data() + part.size())
      bad_option(option, quoted(text) + " is not COLSxROWS", fix);
    return value;
  };
  const std::string_view all(normalised);
  const cv::Size grid(whole(all.substr(0, cross)), whole(all.substr(cross + 1)));
  if (grid.width < min_each || grid.height < min_each) bad_option(option, quoted(text) + " is too small", fix);
  return grid;
}

std::vector<std::string> dictionary_names() {
  std::vector<std::string> names;
  for (const DictionaryName& d : kDictionaries) names.emplace_back(d.name);
  return names;
}

void validate(const BoardSpec& spec) {
  const bool charuco = spec.kind == BoardSpec::Kind::Charuco;
  const std::string grid_option = charuco ? "--charuco" : "--board";
  const int min_each = 3;
  if (spec.grid.width < min_each || spec.grid.height < min_each) {
    bad_option(grid_option, "the grid " + grid_text(spec.grid) + " is too small",
               charuco ? "give the board's squares per row and column, at least 3x3, e.g. 5x7"
                       : "give the board's inner corners per row and column (squares − 1), at least 3x3, e.g. 9x6");
  }
  if (!(std::isfinite(spec.square_m) && spec.square_m > 0)) {
    bad_option("--square", "the square size must be a positive length",
               "measure one square of the printed board and give it in metres, e.g. --square 0.025");
  }
  if (spec.square_m > 2.0) {
    bad_option("--square", "a square of " + std::to_string(spec.square_m) + " m is implausible",
               "give the size in metres (25 mm is 0.025)");
  }
  if (!charuco) return;
  if (!(std::isfinite(spec.marker_m) && spec.marker_m > 0 && spec.marker_m < spec.square_m)) {
    bad_option("--marker", "the marker size must be positive and smaller than the square",
               "measure one marker's black outline in metres, e.g. --marker 0.03 for 0.04 m squares");
  }
  const auto id = find_dictionary(spec.dictionary);
  if (!id) {
    std::string allowed;
    for (const DictionaryName& d : kDictionaries) {
      if (!allowed.empty()) allowed += ", ";
      allowed += d.name;
    }
    bad_option("--dict", "unknown dictionary '" + spec.dictionary + "'",
               "give the dictionary the board was printed with, one of " + allowed);
  }
  const int markers = spec.grid.width * spec.grid.height / 2;
  const int available = cv::aruco::getPredefinedDictionary(*id)->bytesList.rows;
  if (markers > available) {
    bad_option("--dict",
               spec.dictionary + " has " + std::to_string(available) + " markers, the board needs " + std::to_string(markers),
               "check --charuco (squares, not corners) and --dict against the printed board");
  }
}

void refine_corners(const cv::Mat& gray, std::vector<cv::Point2f>& corners, double corner_spacing_px) {
  if (corners.empty()) return;
  const int half = std::clamp(static_cast<int>(0.4 * corner_spacing_px), 2, 11);
  cv::cornerSubPix(gray, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 0.001));
}

struct BoardDetector::Charuco {
  cv::Ptr<cv::aruco::Dictionary> dictionary;
  cv::Ptr<cv::aruco::CharucoBoard> board;
  cv::Ptr<cv::aruco::DetectorParameters> parameters;
};

BoardDetector::BoardDetector(const BoardSpec& spec) : spec_(spec) {
  validate(spec_);
  if (spec_.kind == BoardSpec::Kind::Chessboard) {
    // Row by row, as cv::findChessboardCorners orders them.
    for (int r = 0; r < spec_.grid.height; ++r) {
      for (int c = 0; c < spec_.grid.width; ++c) {
        corners_.emplace_back(static_cast<float>(c * spec_.square_m), static_cast<float>(r * spec_.square_m), 0.0f);
      }
    }
    return;
  }
  charuco_ = std::make_unique<Charuco>();
  charuco_->dictionary = cv::aruco::getPredefinedDictionary(*find_dictionary(spec_.dictionary));
  charuco_->board = cv::aruco::CharucoBoard::create(spec_.grid.width, spec_.grid.height, static_cast<float>(spec_.square_m),
                                                    static_cast<float>(spec_.marker_m), charuco_->dictionary);
  charuco_->parameters = cv::aruco::DetectorParameters::create();
  corners_ = charuco_->board->chessboardCorners;
}

BoardDetector::~BoardDetector() = default;

BoardDetection BoardDetector::detect(const cv::Mat& image) const {
  if (image.empty()) return {std::nullopt, "the image is empty"};
  cv::Mat gray;
  if (image.channels() == 3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  } else {
    gray = image;
  }
  if (gray.depth() != CV_8U) {
    cv::Mat scaled;
    double lo = 0, hi = 0;
    cv::minMaxLoc(gray, &lo, &hi);
    gray.convertTo(scaled, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0, hi > lo ? -lo * 255.0 / (hi - lo) : 0.0);
    gray = scaled;
  }
  return spec_.kind == BoardSpec::Kind::Chessboard ? detect_chessboard(gray) : detect_charuco(gray);
}

BoardDetection BoardDetector::detect_chessboard(const cv::Mat& gray) const {
  std::vector<cv::Point2f> corners;
  // The classic detector with a global threshold first (fast on a whole board); the
  // sector-based one when it gives up (robust to uneven light, blur and strong distortion, and
  // bounded in time: the classic one with adaptive thresholds can take tens of seconds on a
  // board cut by the image's edge). Both refined to sub-pixel positions the same way.
  const bool found =
      cv::findChessboardCorners(gray, spec_.grid, corners, cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK) ||
      cv::findChessboardCornersSB(gray, spec_.grid, corners, 0);
  if (!found) return {std::nullopt, "no chessboard of " + grid_text(spec_.grid) + " inner corners found"};
  if (corners.size() != corners_.size()) {
    return {std::nullopt, "the chessboard detector returned " + std::to_string(corners.size()) + " corners, not " +
                              std::to_string(corners_.size())};
  }
  refine_corners(gray, corners, grid_spacing(corners, spec_.grid));
  return {BoardView{corners_, corners}, "chessboard found"};
}

BoardDetection BoardDetector::detect_charuco(const cv::Mat& gray) const {
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(gray, charuco_->dictionary, marker_corners, marker_ids, charuco_->parameters);
  if (marker_ids.empty()) return {std::nullopt, "no ArUco markers of " + spec_.dictionary + " found"};
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, charuco_->board, corners, ids);
  if (static_cast<int>(ids.size()) < min_charuco_corners()) {
    return {std::nullopt, std::to_string(marker_ids.size()) + " marker(s) but only " + std::to_string(ids.size()) +
                              " ChArUco corner(s) found (needs " + std::to_string(min_charuco_corners()) + ")"};
  }
  if (cv::aruco::testCharucoCornersCollinear(charuco_->board, ids)) {
    return {std::nullopt, "the ChArUco corners found lie on one line"};
  }
  // Refined again with a window that stays inside the white margin around each corner (the
  // markers' edges would pull a larger one): the margin is (square − marker) / 2 of a square.
  double spacing = std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < corners.size(); ++a) {
    for (std::size_t b = a + 1; b < corners.size(); ++b)
      spacing = std::min(spacing, static_cast<double>(cv::norm(corners[a] - corners[b])));
  }
  const double margin = 0.5 * (spec_.square_m - spec_.marker_m) / spec_.square_m;
  refine_corners(gray, corners, 2.0 * margin * spacing);
  BoardView view;
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const int id = ids[k];
    if (id < 0 || static_cast<std::size_t>(id) >= corners_.size()) continue;
    view.object.push_back(corners_[static_cast<std::size_t>(id)]);
    view.image.push_back(corners[k]);
  }
  return {std::move(view), "ChArUco board found"};
}

}  // namespace skylit::calib
