// Board specifications from the command line: grids, sizes and dictionaries, with errors that
// name the option and say what to write.
#include <string>

#include <gtest/gtest.h>

#include "skylit/base/error.hpp"
#include "skylit/calib/board.hpp"

namespace {

using skylit::calib::BoardSpec;

std::string error_of(const auto& call) {
  try {
    call();
  } catch (const skylit::InputError& e) {
    return e.what();
  }
  return {};
}

TEST(CalibBoard, ParsesGrids) {
  EXPECT_EQ(skylit::calib::parse_grid("9x6", "--board", 3), cv::Size(9, 6));
  EXPECT_EQ(skylit::calib::parse_grid("5X7", "--charuco", 3), cv::Size(5, 7));
  EXPECT_EQ(skylit::calib::parse_grid("9×6", "--board", 3), cv::Size(9, 6));
  for (const char* bad : {"9", "9x", "x6", "9x6x2", "9,6", "a x b", "9.5x6", ""}) {
    const std::string message = error_of([&] { skylit::calib::parse_grid(bad, "--board", 3); });
    EXPECT_NE(message.find("--board"), std::string::npos) << bad;
    EXPECT_NE(message.find("COLSxROWS"), std::string::npos) << message;
  }
  EXPECT_NE(error_of([] { skylit::calib::parse_grid("2x6", "--board", 3); }).find("too small"), std::string::npos);
}

TEST(CalibBoard, ValidatesSizesAndDictionaries) {
  BoardSpec spec;
  spec.square_m = 0;
  EXPECT_NE(error_of([&] { skylit::calib::validate(spec); }).find("--square"), std::string::npos);
  spec.square_m = 25;  // millimetres by mistake
  EXPECT_NE(error_of([&] { skylit::calib::validate(spec); }).find("metres"), std::string::npos);
  spec.square_m = 0.04;
  spec.kind = BoardSpec::Kind::Charuco;
  spec.grid = {5, 7};
  spec.marker_m = 0.05;  // larger than the square
  EXPECT_NE(error_of([&] { skylit::calib::validate(spec); }).find("--marker"), std::string::npos);
  spec.marker_m = 0.03;
  spec.dictionary = "DICT_9X9_1";
  const std::string unknown = error_of([&] { skylit::calib::validate(spec); });
  EXPECT_NE(unknown.find("--dict"), std::string::npos);
  EXPECT_NE(unknown.find("DICT_5X5_100"), std::string::npos) << "lists the names: " << unknown;
  spec.dictionary = "5x5_100";  // prefix and case optional
  EXPECT_EQ(error_of([&] { skylit::calib::validate(spec); }), "");
  spec.grid = {20, 20};  // 200 markers
  spec.dictionary = "DICT_4X4_50";
  EXPECT_NE(error_of([&] { skylit::calib::validate(spec); }).find("the board needs 200"), std::string::npos);
  EXPECT_EQ(skylit::calib::dictionary_names().size(), 21u);
}

TEST(CalibBoard, ChessboardCornersAreRowByRowInMetres) {
  BoardSpec spec;
  spec.grid = {4, 3};
  spec.square_m = 0.05;
  const skylit::calib::BoardDetector detector(spec);
  ASSERT_EQ(detector.corners().size(), 12u);
  EXPECT_FLOAT_EQ(detector.corners()[1].x, 0.05f);
  EXPECT_FLOAT_EQ(detector.corners()[4].y, 0.05f);
  EXPECT_FLOAT_EQ(detector.corners()[11].x, 0.15f);
  EXPECT_FLOAT_EQ(detector.corners()[11].y, 0.10f);
}

}  // namespace
