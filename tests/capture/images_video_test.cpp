// Image sequences (timestamps from a CSV or a frame rate, globs, loops, unreadable files) and
// video files (written with cv::VideoWriter, read back with their timestamps).
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "capture_test_support.hpp"
#include "skylit/base/error.hpp"
#include "skylit/capture/sources.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/solar.hpp"

namespace {

using namespace skylit::capture;
using skylit::InputError;
using skylit::capture::testing::grey;
using skylit::capture::testing::TempDir;
namespace fs = std::filesystem;

void write_png(const fs::path& file, int value) { ASSERT_TRUE(cv::imwrite(file.string(), grey(8, 6, value))); }

std::string error_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

std::vector<Frame> drain(FrameSource& source, std::size_t limit = 100) {
  std::vector<Frame> frames;
  while (frames.size() < limit) {
    FrameResult result = source.next(0.0);
    if (result.status != FrameStatus::Ready) break;
    frames.push_back(std::move(result.frame));
  }
  return frames;
}

// A folder as skylit-sky writes a time-lapse: frame_NNNN.exr and .png, frames.csv naming the EXRs.
fs::path write_time_lapse(const TempDir& dir) {
  for (int k = 0; k < 3; ++k) {
    const std::string stem = "frame_000" + std::to_string(k);
    skylit::sky::write_sky_exr(dir.path() / (stem + ".exr"), cv::Mat(6, 8, CV_32FC3, cv::Scalar::all(1000.0 * (k + 1))));
    write_png(dir.path() / (stem + ".png"), 10 * (k + 1));
  }
  return dir.write("frames.csv",
                   "timestamp,file,sun_azimuth_deg,sun_elevation_deg\n"
                   "2026-06-21T00:00:00Z,frame_0000.exr,93.9,49.8\n"
                   "2026-06-21T00:30:00Z,frame_0001.exr,97.0,55.9\n"
                   "2026-06-21T01:00:00Z,frame_0002.exr,100.8,62.0\n");
}

TEST(ImagesSource, AFolderWithFramesCsvGivesTheListedFramesAtTheirIsoTimes) {
  TempDir dir;
  write_time_lapse(dir);
  ImagesSource source(ImagesSettings{.path = dir.path()});
  ASSERT_EQ(source.size(), 3u);
  const std::vector<Frame> frames = drain(source);
  ASSERT_EQ(frames.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_DOUBLE_EQ(frames[k].timestamp, 1800.0 * k);
    EXPECT_EQ(frames[k].sequence, k);
    ASSERT_TRUE(frames[k].utc.has_value());
    EXPECT_EQ(*frames[k].utc, skylit::sky::parse_utc("2026-06-21T00:00:00Z") + std::chrono::minutes(30 * k));
    ASSERT_EQ(frames[k].image.type(), CV_32FC3) << "the EXRs the CSV lists, not the PNGs";
    EXPECT_FLOAT_EQ(frames[k].image.at<cv::Vec3f>(0, 0)[1], 1000.0f * (k + 1));
  }
  EXPECT_EQ(source.next(0).status, FrameStatus::EndOfStream);
  EXPECT_EQ(source.counts().delivered, 3);
}

TEST(ImagesSource, AGlobTakesItsTimesFromTheCsvByStem) {
  TempDir dir;
  write_time_lapse(dir);
  ImagesSource source(ImagesSettings{.path = dir.path() / "*.png"});
  const std::vector<Frame> frames = drain(source);
  ASSERT_EQ(frames.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_DOUBLE_EQ(frames[k].timestamp, 1800.0 * k);
    EXPECT_EQ(frames[k].image.type(), CV_8UC3);
    EXPECT_EQ(frames[k].image.at<cv::Vec3b>(0, 0)[1], 10 * (k + 1));
  }
}

TEST(ImagesSource, NumericTimestampsOrderTheFramesAndAGlobSelectsThem) {
  TempDir dir;
  write_png(dir.path() / "shot_a.png", 1);
  write_png(dir.path() / "shot_b.png", 2);
  write_png(dir.path() / "shot_c.png", 3);
  write_png(dir.path() / "other.png", 4);
  const fs::path csv = dir.write("times.csv", "shot_a.png, 2.5\nshot_b.png, 0.5\n\"shot_c.png\",1.25\nother.png,9\n");
  ImagesSource source(ImagesSettings{.path = dir.path() / "shot_*.png", .timestamps = csv});
  const std::vector<Frame> frames = drain(source);
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_DOUBLE_EQ(frames[0].timestamp, 0.5);
  EXPECT_DOUBLE_EQ(frames[1].timestamp, 1.25);
  EXPECT_DOUBLE_EQ(frames[2].timestamp, 2.5);
  EXPECT_EQ(frames[0].image.at<cv::Vec3b>(0, 0)[0], 2);
  EXPECT_EQ(frames[2].image.at<cv::Vec3b>(0, 0)[0], 1);
  EXPECT_FALSE(frames[0].utc.has_value());
  EXPECT_NE(frames[0].source.find("shot_*.png"), std::string::npos);
}

TEST(ImagesSource, FrameRateWithoutCsvAndLoopingKeepsTimeIncreasing) {
  TempDir dir;
  write_png(dir.path() / "a.png", 1);
  write_png(dir.path() / "b.png", 2);
  ImagesSource source(ImagesSettings{.path = dir.path(), .fps = 4.0, .loop = true});
  const std::vector<Frame> frames = drain(source, 5);
  ASSERT_EQ(frames.size(), 5u);
  for (int k = 0; k < 5; ++k) {
    EXPECT_DOUBLE_EQ(frames[k].timestamp, 0.25 * k) << k;
    EXPECT_EQ(frames[k].sequence, k);
    EXPECT_EQ(frames[k].image.at<cv::Vec3b>(0, 0)[0], 1 + k % 2);
  }
}

TEST(ImagesSource, SkipsAndCountsAnUnreadableImage) {
  TempDir dir;
  write_png(dir.path() / "a.png", 1);
  dir.write("b.png", "not a PNG, cut short while copying");
  write_png(dir.path() / "c.png", 3);
  ImagesSource source(ImagesSettings{.path = dir.path(), .fps = 1.0});
  const std::vector<Frame> frames = drain(source);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_DOUBLE_EQ(frames[1].timestamp, 2.0);  // c.png keeps its place in time
  EXPECT_EQ(source.counts().dropped_unreadable, 1);
  EXPECT_EQ(source.counts().delivered, 2);
}

TEST(ImagesSource, ErrorsNameTheFileLineAndFix) {
  TempDir dir;
  write_png(dir.path() / "a.png", 1);
  write_png(dir.path() / "b.png", 2);
  std::string message = error_of([&] { ImagesSource(ImagesSettings{.path = dir.path()}); });
  EXPECT_NE(message.find("fps"), std::string::npos) << message;
  EXPECT_NE(message.find("frames.csv"), std::string::npos) << message;

  message = error_of([&] { ImagesSource(ImagesSettings{.path = dir.path() / "missing"}); });
  EXPECT_NE(message.find("no such file or folder"), std::string::npos) << message;
  message = error_of([&] { ImagesSource(ImagesSettings{.path = dir.path() / "*.jpg", .fps = 1.0}); });
  EXPECT_NE(message.find("no images match"), std::string::npos) << message;

  fs::path csv = dir.write("t1.csv", "file,timestamp\na.png,0\nb.png,later\n");
  message = error_of([&] { ImagesSource(ImagesSettings{.path = dir.path(), .timestamps = csv}); });
  EXPECT_NE(message.find("t1.csv:3:7: field 'timestamp': 'later'"), std::string::npos) << message;

  csv = dir.write("t2.csv", "file,timestamp\na.png,0\n");
  message = error_of([&] { ImagesSource(ImagesSettings{.path = dir.path() / "*.png", .timestamps = csv}); });
  EXPECT_NE(message.find("no row for 'b.png'"), std::string::npos) << message;
  EXPECT_NE(message.find("Fix: add a row 'b.png,TIMESTAMP'"), std::string::npos) << message;

  csv = dir.write("t3.csv", "a.png,0\nb.png\n");
  message = error_of([&] { ImagesSource(ImagesSettings{.path = dir.path(), .timestamps = csv}); });
  EXPECT_NE(message.find("t3.csv:2:1: 1 field(s), 2 needed"), std::string::npos) << message;

  csv = dir.write("t4.csv", "a.png,0\n\"b.png,1\n");
  message = error_of([&] { ImagesSource(ImagesSettings{.path = dir.path(), .timestamps = csv}); });
  EXPECT_NE(message.find("t4.csv:2:1: a quote is not closed"), std::string::npos) << message;

  csv = dir.write("t6.csv", "a.png,0\nc.png,1\n");
  message = error_of([&] { ImagesSource(ImagesSettings{.path = dir.path(), .timestamps = csv}); });
  EXPECT_NE(message.find("t6.csv:2:1: field 'file': 'c.png' does not exist"), std::string::npos) << message;

  csv = dir.write("t5.csv", "a.png,0\nb.png,2026-06-21T00:00:00Z\n");
  message = error_of([&] { ImagesSource(ImagesSettings{.path = dir.path(), .timestamps = csv}); });
  EXPECT_NE(message.find("t5.csv:2:7"), std::string::npos) << message;
}

// ---------------------------------------------------------------------------------------------

fs::path write_video(const fs::path& file, int frames, double fps) {
  cv::VideoWriter writer(file.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, cv::Size(64, 48));
  EXPECT_TRUE(writer.isOpened());
  for (int k = 0; k < frames; ++k) writer.write(grey(64, 48, 40 * k + 20));
  writer.release();
  return file;
}

TEST(VideoSource, ReadsBackAnMjpegAviWithItsTimestamps) {
  TempDir dir;
  const fs::path file = write_video(dir.path() / "clip.avi", 5, 10.0);
  VideoSource source(VideoSettings{.file = file});
  const std::vector<Frame> frames = drain(source);
  ASSERT_EQ(frames.size(), 5u);
  for (int k = 0; k < 5; ++k) {
    EXPECT_NEAR(frames[k].timestamp, 0.1 * k, 1e-6) << k;
    EXPECT_EQ(frames[k].sequence, k);
    ASSERT_EQ(frames[k].image.size(), cv::Size(64, 48));
    EXPECT_NEAR(cv::mean(frames[k].image)[1], 40 * k + 20, 3.0) << "JPEG keeps a flat grey within a few codes";
  }
  EXPECT_EQ(source.next(0).status, FrameStatus::EndOfStream);
}

TEST(VideoSource, LoopsWithIncreasingTimestamps) {
  TempDir dir;
  const fs::path file = write_video(dir.path() / "clip.avi", 3, 5.0);
  VideoSource source(VideoSettings{.file = file, .loop = true});
  const std::vector<Frame> frames = drain(source, 7);
  ASSERT_EQ(frames.size(), 7u);
  for (int k = 0; k < 7; ++k) {
    EXPECT_NEAR(frames[k].timestamp, 0.2 * k, 1e-6) << k;
    EXPECT_NEAR(cv::mean(frames[k].image)[0], 40 * (k % 3) + 20, 3.0) << k;
  }
}

TEST(VideoSource, AMissingOrUndecodableFileIsAnInputError) {
  TempDir dir;
  std::string message = error_of([&] { VideoSource(VideoSettings{.file = dir.path() / "none.avi"}); });
  EXPECT_NE(message.find("none.avi"), std::string::npos) << message;
  EXPECT_NE(message.find("no such video file"), std::string::npos) << message;
  const fs::path junk = dir.write("junk.avi", "this is not a video");
  message = error_of([&] { VideoSource(VideoSettings{.file = junk}); });
  EXPECT_NE(message.find("cannot decode"), std::string::npos) << message;
}

}  // namespace
