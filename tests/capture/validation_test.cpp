// Frame checks shared by every backend: malformed frames are dropped and counted by reason.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "capture_test_support.hpp"

namespace {

using namespace skylit::capture;
using skylit::capture::testing::grey;
using skylit::capture::testing::ready;
using skylit::capture::testing::ScriptedSource;

TEST(CheckFrame, AcceptsEightSixteenBitAndFloatWithOneOrThreeChannels) {
  for (const int type : {CV_8UC1, CV_8UC3, CV_16UC1, CV_16UC3, CV_32FC1, CV_32FC3}) {
    FrameChecks checks;
    EXPECT_EQ(check_frame(cv::Mat::zeros(2, 3, type), checks), FrameProblem::None) << type;
    EXPECT_EQ(checks.size, cv::Size(3, 2));
    EXPECT_EQ(checks.type, type);
  }
  for (const int type : {CV_8UC4, CV_8UC2, CV_64FC3, CV_16SC1, CV_32SC3}) {
    FrameChecks checks;
    EXPECT_EQ(check_frame(cv::Mat::zeros(2, 3, type), checks), FrameProblem::Type) << type;
    EXPECT_FALSE(checks.size.has_value()) << "a refused frame must not set the expected size";
  }
}

TEST(CheckFrame, AllNaNIsRefusedButSomeNaNIsKept) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  FrameChecks checks;
  cv::Mat all_nan(4, 4, CV_32FC3, cv::Scalar::all(nan));
  EXPECT_EQ(check_frame(all_nan, checks), FrameProblem::AllNaN);
  all_nan.at<cv::Vec3f>(3, 3)[2] = 1.0f;  // one finite value is something to measure
  EXPECT_EQ(check_frame(all_nan, checks), FrameProblem::None);
  cv::Mat infinite(4, 4, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  EXPECT_EQ(check_frame(infinite, checks = {}), FrameProblem::AllNaN);
}

TEST(CheckFrame, ExpectedSizeAndTypeFromTheConfigWin) {
  FrameChecks checks;
  checks.size = cv::Size(8, 8);
  checks.type = CV_32FC3;
  EXPECT_EQ(check_frame(cv::Mat::zeros(8, 8, CV_8UC3), checks), FrameProblem::Type);
  EXPECT_EQ(check_frame(cv::Mat::zeros(4, 8, CV_32FC3), checks), FrameProblem::Size);
  EXPECT_EQ(check_frame(cv::Mat(), checks), FrameProblem::Empty);
  EXPECT_EQ(check_frame(cv::Mat::zeros(8, 8, CV_32FC3), checks), FrameProblem::None);
}

TEST(FrameSource, DropsAndCountsMalformedFramesAndLocksToTheFirstGoodOne) {
  ScriptedSource source;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  source.script = {ready(grey(4, 3, 10), 0.0),
                   ready(cv::Mat(), 0.1),                                   // empty
                   ready(grey(5, 3, 10), 0.2),                              // wrong size
                   ready(cv::Mat::zeros(3, 4, CV_8UC4), 0.3),               // refused type
                   ready(cv::Mat::zeros(3, 4, CV_16UC3), 0.4),              // not the first frame's type
                   ready(cv::Mat(3, 4, CV_32FC3, cv::Scalar::all(nan)), 0.5),  // wrong type before NaN
                   ready(grey(4, 3, 20), 0.6)};
  FrameResult first = source.next(1.0);
  ASSERT_EQ(first.status, FrameStatus::Ready);
  EXPECT_EQ(first.frame.source, "scripted");
  FrameResult second = source.next(1.0);  // drains the five bad frames
  ASSERT_EQ(second.status, FrameStatus::Ready);
  EXPECT_DOUBLE_EQ(second.frame.timestamp, 0.6);
  EXPECT_EQ(second.frame.image.at<cv::Vec3b>(0, 0)[0], 20);
  EXPECT_EQ(source.next(0.0).status, FrameStatus::NotYet);

  const FrameCounts counts = source.counts();
  EXPECT_EQ(counts.delivered, 2);
  EXPECT_EQ(counts.dropped_empty, 1);
  EXPECT_EQ(counts.dropped_size, 1);
  EXPECT_EQ(counts.dropped_type, 3);
  EXPECT_EQ(counts.dropped_all_nan, 0);
  EXPECT_EQ(counts.dropped(), 5);
}

TEST(FrameSource, CountsAllNaNFramesOfAFloatStream) {
  ScriptedSource source;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  source.script = {ready(cv::Mat(2, 2, CV_32FC3, cv::Scalar::all(nan))), ready(cv::Mat::zeros(2, 2, CV_32FC3)),
                   ready(cv::Mat(2, 2, CV_32FC3, cv::Scalar::all(nan)))};
  EXPECT_EQ(source.next(1.0).status, FrameStatus::Ready);
  EXPECT_EQ(source.next(1.0).status, FrameStatus::NotYet);
  EXPECT_EQ(source.counts().dropped_all_nan, 2);
  EXPECT_EQ(source.counts().delivered, 1);
}

TEST(FrameSource, ANameReplacesTheDescriptionInFrames) {
  ScriptedSource source;
  source.set_name("sky");
  source.script = {ready(grey(2, 2, 1))};
  EXPECT_EQ(source.next(0).frame.source, "sky");
  EXPECT_EQ(source.describe(), "scripted");
}

TEST(FrameSource, NoBracketAndNoControlsByDefault) {
  struct Plain final : FrameSource {
    std::string describe() const override { return "plain"; }
    FrameResult read(double) override { return {FrameStatus::EndOfStream, {}}; }
  } plain;
  const double times[] = {0.001, 0.01};
  EXPECT_FALSE(plain.bracket(times, 1.0).has_value());
  EXPECT_FALSE(plain.set_exposure_time(0.01));
  EXPECT_FALSE(plain.set_gain(2.0));
  EXPECT_EQ(plain.next(0).status, FrameStatus::EndOfStream);
}

}  // namespace
