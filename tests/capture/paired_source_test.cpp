// A stereo camera from two sources paired by timestamp (real image sequences with frames.csv
// times): pairs, jitter, gaps, a side running ahead, the end, mismatched sizes; `kind: pair` in a
// config; and the split and join of side-by-side frames.
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <yaml-cpp/yaml.h>

#include "capture_test_support.hpp"
#include "skylit/base/error.hpp"
#include "skylit/capture/config.hpp"
#include "skylit/capture/paired_source.hpp"
#include "skylit/capture/sources.hpp"

namespace paired_source_test {

using namespace skylit::capture;
using skylit::InputError;
using skylit::capture::testing::grey;
using skylit::capture::testing::TempDir;
namespace fs = std::filesystem;

// A camera's recording: frame k is a grey image of value first_value + k at timestamps[k], in
// `folder` with its frames.csv.
fs::path write_camera(const TempDir& dir, const std::string& folder, const std::vector<double>& timestamps,
                      int first_value, cv::Size size = {8, 6}) {
  std::string csv = "file,timestamp\n";
  for (std::size_t k = 0; k < timestamps.size(); ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%04zu.png", k);
    const fs::path file = dir / folder / name;
    fs::create_directories(file.parent_path());
    EXPECT_TRUE(cv::imwrite(file.string(), grey(size.width, size.height, first_value + static_cast<int>(k))));
    char row[64];
    std::snprintf(row, sizeof row, "%s,%.6f\n", name, timestamps[k]);
    csv += row;
  }
  dir.write(fs::path(folder) / "frames.csv", csv);
  return dir / folder;
}

std::unique_ptr<FrameSource> images(const fs::path& folder) {
  return std::make_unique<ImagesSource>(ImagesSettings{.path = folder});
}

// Times k / rate_hz + offset_s, for k in [first, last).
std::vector<double> times(int first, int last, double rate_hz, double offset_s = 0) {
  std::vector<double> t;
  for (int k = first; k < last; ++k) t.push_back(k / rate_hz + offset_s);
  return t;
}

std::vector<Frame> drain(FrameSource& source, int limit = 1000) {
  std::vector<Frame> frames;
  for (int calls = 0; calls < limit; ++calls) {
    FrameResult result = source.next(1.0);
    if (result.status == FrameStatus::EndOfStream) break;
    EXPECT_EQ(result.status, FrameStatus::Ready) << "files are always ready: a pair or the end";
    if (result.status == FrameStatus::Ready) frames.push_back(std::move(result.frame));
  }
  return frames;
}

// The grey value of each half of a side-by-side frame.
std::pair<int, int> half_values(const Frame& frame) {
  const StereoHalves halves = split_side_by_side(frame.image);
  return {halves.left.at<cv::Vec3b>(0, 0)[0], halves.right.at<cv::Vec3b>(0, 0)[0]};
}

std::string error_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(PairedSource, TwoCamerasAtTheSameTimesPairOneToOne) {
  TempDir dir;
  const fs::path left = write_camera(dir, "left", times(0, 6, 90), 10);
  const fs::path right = write_camera(dir, "right", times(0, 6, 90), 100);
  PairedSource pair(images(left), images(right));
  EXPECT_EQ(pair.describe(), "pair (images " + left.string() + " | images " + right.string() + ", ±5 ms)");
  const std::vector<Frame> frames = drain(pair);
  ASSERT_EQ(frames.size(), 6u);
  for (int k = 0; k < 6; ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(frames[k].image.size(), cv::Size(16, 6));
    const StereoHalves halves = split_side_by_side(frames[k].image);
    EXPECT_EQ(cv::norm(halves.left, grey(8, 6, 10 + k), cv::NORM_INF), 0.0) << "the left camera's image, as it was";
    EXPECT_EQ(cv::norm(halves.right, grey(8, 6, 100 + k), cv::NORM_INF), 0.0);
    EXPECT_NEAR(frames[k].timestamp, k / 90.0, 1e-6);
    EXPECT_EQ(frames[k].sequence, k);
    EXPECT_EQ(frames[k].source, pair.describe());
  }
  EXPECT_EQ(pair.next(1.0).status, FrameStatus::EndOfStream);
  const PairCounts counts = pair.pair_counts();
  EXPECT_EQ(counts.paired, 6);
  EXPECT_EQ(counts.unpaired_left, 0);
  EXPECT_EQ(counts.unpaired_right, 0);
  EXPECT_EQ(pair.counts().delivered, 6) << "a pair is one frame";
  EXPECT_EQ(pair.counts().dropped(), 0);
  EXPECT_FALSE(pair.set_exposure_time(0.002)) << "image files have no exposure control";
}

TEST(PairedSource, JitterWithinTheTolerancePairsAndBeyondItDoesNot) {
  TempDir dir;
  // 10 Hz; the right camera's frames off by +4, −3, +7, −9 and 0 ms.
  const std::vector<double> jitter_ms{4, -3, 7, -9, 0};
  std::vector<double> right_times = times(0, 5, 10);
  for (std::size_t k = 0; k < right_times.size(); ++k) right_times[k] += jitter_ms[k] * 1e-3;
  const fs::path left = write_camera(dir, "left", times(0, 5, 10), 10);
  const fs::path right = write_camera(dir, "right", right_times, 100);

  PairedSource strict(images(left), images(right), 0.005);
  const std::vector<Frame> frames = drain(strict);
  ASSERT_EQ(frames.size(), 3u) << "frames 0, 1 and 4 are within 5 ms";
  EXPECT_EQ(half_values(frames[0]), std::make_pair(10, 100));
  EXPECT_EQ(half_values(frames[1]), std::make_pair(11, 101));
  EXPECT_EQ(half_values(frames[2]), std::make_pair(14, 104));
  EXPECT_NEAR(frames[0].timestamp, 0.002, 1e-6) << "the mean of the two";
  EXPECT_NEAR(frames[1].timestamp, 0.0985, 1e-6);
  EXPECT_EQ(frames[2].sequence, 2) << "the pair's own count";
  const PairCounts counts = strict.pair_counts();
  EXPECT_EQ(counts.paired, 3);
  EXPECT_EQ(counts.unpaired_left, 2) << "left frames 2 and 3";
  EXPECT_EQ(counts.unpaired_right, 2) << "right frames 2 and 3";

  PairedSource loose(images(left), images(right), 0.010);
  EXPECT_EQ(drain(loose).size(), 5u) << "every frame within 10 ms";
  EXPECT_EQ(loose.pair_counts().unpaired_left + loose.pair_counts().unpaired_right, 0);
}

TEST(PairedSource, ACameraDroppingFramesOrRunningAheadNeverStallsThePairing) {
  TempDir dir;
  // The right camera lost frames 3, 4, 5 and 11 of 20 (90 Hz).
  std::vector<double> right_times;
  std::vector<int> right_index;
  for (int k = 0; k < 20; ++k) {
    if (k == 3 || k == 4 || k == 5 || k == 11) continue;
    right_times.push_back(k / 90.0);
    right_index.push_back(k);
  }
  const fs::path left = write_camera(dir, "left", times(0, 20, 90), 10);
  const fs::path gappy = write_camera(dir, "gappy", right_times, 100);
  {
    PairedSource pair(images(left), images(gappy));
    const std::vector<Frame> frames = drain(pair);
    ASSERT_EQ(frames.size(), right_times.size());
    for (std::size_t j = 0; j < frames.size(); ++j) {
      EXPECT_EQ(half_values(frames[j]).first - 10, right_index[j]) << "each right frame meets its own left frame";
    }
    EXPECT_EQ(pair.pair_counts().unpaired_left, 4);
    EXPECT_EQ(pair.pair_counts().unpaired_right, 0);
  }
  // The right camera started 10 frames late: the left camera's first 10 frames are dropped in
  // one call, and the first pair comes at once.
  const fs::path late = write_camera(dir, "late", times(10, 20, 90), 110);
  {
    PairedSource pair(images(left), images(late));
    FrameResult first = pair.next(1.0);
    ASSERT_EQ(first.status, FrameStatus::Ready);
    EXPECT_EQ(half_values(first.frame), std::make_pair(20, 110));
    EXPECT_EQ(pair.pair_counts().unpaired_left, 10);
    EXPECT_EQ(drain(pair).size(), 9u);
    EXPECT_EQ(pair.pair_counts().paired, 10);
  }
  // The same with the sides swapped: the late camera on the left, so the other side's frames go.
  {
    PairedSource pair(images(late), images(left));
    EXPECT_EQ(drain(pair).size(), 10u);
    EXPECT_EQ(pair.pair_counts().unpaired_left, 0);
    EXPECT_EQ(pair.pair_counts().unpaired_right, 10);
  }
  // Asked with no time to wait, a drop ends the call (ask again); nothing is lost by it.
  {
    PairedSource pair(images(left), images(late));
    int not_yet = 0;
    int ready = 0;
    for (int calls = 0; calls < 100; ++calls) {
      const FrameStatus status = pair.next(0.0).status;
      if (status == FrameStatus::EndOfStream) break;
      (status == FrameStatus::Ready ? ready : not_yet) += 1;
    }
    EXPECT_EQ(ready, 10);
    EXPECT_LE(not_yet, 10);
    EXPECT_EQ(pair.pair_counts().unpaired_left, 10);
  }
}

TEST(PairedSource, EndsWhenEitherSideEnds) {
  TempDir dir;
  const fs::path longer = write_camera(dir, "longer", times(0, 5, 30), 10);
  const fs::path shorter = write_camera(dir, "shorter", times(0, 3, 30), 100);
  {
    PairedSource pair(images(longer), images(shorter));
    EXPECT_EQ(drain(pair).size(), 3u);
    EXPECT_EQ(pair.next(1.0).status, FrameStatus::EndOfStream) << "and stays ended";
    const PairCounts counts = pair.pair_counts();
    EXPECT_EQ(counts.paired, 3);
    EXPECT_EQ(counts.unpaired_left, 1) << "the left frame that waited for a partner when the right side ended";
    EXPECT_EQ(counts.unpaired_right, 0);
  }
  {
    PairedSource pair(images(shorter), images(longer));
    EXPECT_EQ(drain(pair).size(), 3u);
    EXPECT_EQ(pair.pair_counts().unpaired_left + pair.pair_counts().unpaired_right, 0);
  }
}

TEST(PairedSource, CamerasOfDifferentSizesAreAnErrorNamingBoth) {
  TempDir dir;
  const fs::path left = write_camera(dir, "left", times(0, 2, 30), 10, {8, 6});
  const fs::path right = write_camera(dir, "right", times(0, 2, 30), 100, {10, 6});
  PairedSource pair(images(left), images(right));
  const std::string message = error_of([&] { pair.next(1.0); });
  EXPECT_NE(message.find("left images " + left.string() + " 8×6 CV_8UC3"), std::string::npos) << message;
  EXPECT_NE(message.find("right images " + right.string() + " 10×6 CV_8UC3"), std::string::npos) << message;
  EXPECT_NE(message.find("Fix: set both cameras to the same mode"), std::string::npos) << message;
  EXPECT_EQ(pair.pair_counts().unpaired_left, 1);
  EXPECT_EQ(pair.pair_counts().unpaired_right, 1);

  EXPECT_NE(error_of([&] { PairedSource(images(left), images(right), 0.0); }).find("tolerance_ms"), std::string::npos);
  EXPECT_NE(error_of([&] { PairedSource(images(left), nullptr); }).find("source.right"), std::string::npos);
}

TEST(StereoFrame, SplitAndJoinAreInverseAndSplitDoesNotCopy) {
  cv::Mat left(5, 7, CV_16UC3);
  cv::Mat right(5, 7, CV_16UC3);
  cv::randu(left, 0, 65535);
  cv::randu(right, 0, 65535);
  const cv::Mat joined = join_side_by_side(left, right);
  ASSERT_EQ(joined.size(), cv::Size(14, 5));
  const StereoHalves halves = split_side_by_side(joined);
  EXPECT_EQ(cv::norm(halves.left, left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(halves.right, right, cv::NORM_INF), 0.0);
  EXPECT_EQ(halves.left.data, joined.data) << "views into the frame";
  EXPECT_EQ(halves.right.data, joined.data + 7 * joined.elemSize());
  EXPECT_EQ(cv::norm(join_side_by_side(halves.left, halves.right), joined, cv::NORM_INF), 0.0);

  EXPECT_NE(error_of([] { split_side_by_side(cv::Mat(4, 15, CV_8UC3)); }).find("15 pixels wide"), std::string::npos);
  EXPECT_NE(error_of([] { split_side_by_side(cv::Mat()); }).find("empty"), std::string::npos);
  const std::string mismatch = error_of([] { join_side_by_side(cv::Mat(4, 8, CV_8UC3), cv::Mat(4, 8, CV_8UC1)); });
  EXPECT_NE(mismatch.find("8×4 CV_8UC3"), std::string::npos) << mismatch;
  EXPECT_NE(mismatch.find("8×4 CV_8UC1"), std::string::npos) << mismatch;
}

// ---------------------------------------------------------------------------------------------
// `kind: pair` in a config.

std::string config_error(const fs::path& file) {
  return error_of([&] { load_source_config(file); });
}

TEST(PairConfig, ReadsTwoSourcesAndTheTolerance) {
  TempDir dir;
  const SourceConfig config = load_source_config(dir.write("live.yaml",
                                                           "source:\n"
                                                           "  kind: pair\n"
                                                           "  name: hmd\n"
                                                           "  tolerance_ms: 3\n"
                                                           "  left: {kind: images, path: left}\n"
                                                           "  right:\n"
                                                           "    kind: v4l2\n"
                                                           "    device: /dev/video2\n"
                                                           "    width: 1280\n"
                                                           "    height: 720\n"
                                                           "    reconnect: {initial: 1}\n"));
  EXPECT_EQ(kind_name(config), "pair");
  EXPECT_EQ(config.name, "hmd");
  EXPECT_FALSE(config.reconnect.has_value()) << "the pair is not reopened as a whole";
  const SourceConfig copy = config;  // copyable, as the services copy it
  const auto& pair = std::get<PairSettings>(copy.settings);
  EXPECT_DOUBLE_EQ(pair.tolerance_s, 0.003);
  EXPECT_EQ(kind_name(*pair.left), "images");
  EXPECT_EQ(std::get<ImagesSettings>(pair.left->settings).path, dir / "left");
  EXPECT_FALSE(pair.left->reconnect.has_value());
  const auto& v4l2 = std::get<V4l2Settings>(pair.right->settings);
  EXPECT_EQ(v4l2.device, "/dev/video2");
  EXPECT_EQ(v4l2.width, 1280);
  EXPECT_EQ(pair.right->checks.size, cv::Size(1280, 720));
  ASSERT_TRUE(pair.right->reconnect.has_value()) << "a camera side reconnects as a camera does";
  EXPECT_DOUBLE_EQ(pair.right->reconnect->initial_s, 1.0);

  const SourceConfig defaults = load_source_config(dir.write(
      "b.yaml", "source:\n  kind: pair\n  left: {kind: images, path: l}\n  right: {kind: images, path: r}\n"));
  EXPECT_DOUBLE_EQ(std::get<PairSettings>(defaults.settings).tolerance_s, 0.005);
}

// docs/live.md's `pair` examples ("Stereo cameras") are configs that parse.
TEST(PairConfig, TheDocsExamplesParse) {
  std::ifstream doc(fs::path(SKYLIT_SOURCE_DIR) / "docs/live.md");
  ASSERT_TRUE(doc) << "docs/live.md";
  std::vector<std::string> examples;
  std::string line;
  std::string block;
  bool in_yaml = false;
  while (std::getline(doc, line)) {
    if (!in_yaml && line == "```yaml") {
      in_yaml = true;
      block.clear();
    } else if (in_yaml && line == "```") {
      in_yaml = false;
      if (block.find("kind: pair") != std::string::npos) examples.push_back(block);
    } else if (in_yaml) {
      block += line + "\n";
    }
  }
  ASSERT_EQ(examples.size(), 2u) << "two cameras, two folders";
  TempDir dir;
  for (const std::string& example : examples) {
    SCOPED_TRACE(example);
    const SourceConfig config = load_source_config(dir.write("live.yaml", example));
    EXPECT_EQ(kind_name(config), "pair");
  }
}

TEST(PairConfig, ErrorsNameTheSideTheFieldAndTheFix) {
  struct BadCase {
    std::string name;
    std::string yaml;
    std::string expected;
  };
  const std::string sides = "  left: {kind: images, path: l}\n  right: {kind: images, path: r}\n";
  const BadCase cases[] = {
      {"MissingRight", "source:\n  kind: pair\n  left: {kind: images, path: l}\n",
       "live.yaml:2:3: field 'source.right': required field is missing. Fix: add it: give the right camera's source node"},
      {"SideNotAMap", "source:\n  kind: pair\n  left: /dev/video0\n  right: {kind: v4l2}\n",
       "live.yaml:3:9: field 'source.left': expected a map of fields"},
      {"NestedPair", "source:\n  kind: pair\n  left:\n    kind: pair\n  right: {kind: v4l2}\n",
       "live.yaml:4:11: field 'source.left.kind': a side of a pair is one camera or recording, not another pair. Fix: write 'kind:' and one of images, video, v4l2, libcamera, sky-sim"},
      {"SideUnknownKind", "source:\n  kind: pair\n  left: {kind: v4l2}\n  right: {kind: v4l}\n",
       "field 'source.right.kind': unknown kind 'v4l'"},
      {"SideField", "source:\n  kind: pair\n  left: {kind: images}\n  right: {kind: images, path: r}\n",
       "live.yaml:3:9: field 'source.left.path': required field is missing"},
      {"SideUnknownField", "source:\n  kind: pair\n  left: {kind: images, path: l, fsp: 2}\n  right: {kind: images, path: r}\n",
       "live.yaml:3:33: field 'source.left.fsp': unknown field. Fix: did you mean 'fps'?"},
      {"UnknownField", "source:\n  kind: pair\n  tolerance: 5\n" + sides,
       "live.yaml:3:3: field 'source.tolerance': unknown field. Fix: did you mean 'tolerance_ms'?"},
      {"ToleranceZero", "source:\n  kind: pair\n  tolerance_ms: 0\n" + sides,
       "live.yaml:3:17: field 'source.tolerance_ms': must be positive"},
      {"ToleranceText", "source:\n  kind: pair\n  tolerance_ms: tight\n" + sides,
       "field 'source.tolerance_ms': 'tight' is not a number"},
      {"ToleranceLarge", "source:\n  kind: pair\n  tolerance_ms: 250\n" + sides,
       "field 'source.tolerance_ms': 250 is above 100 ms. Fix: give milliseconds, below half a frame interval"},
      {"WidthOnThePair", "source:\n  kind: pair\n  width: 640\n" + sides,
       "live.yaml:3:3: field 'source.width': each camera of a pair has its own. Fix: move it under left: and right:"},
      {"ReconnectOnThePair", "source:\n  kind: pair\n  reconnect: false\n" + sides, "field 'source.reconnect': each camera of a pair has its own"},
      {"RealtimeCameras", "source:\n  kind: pair\n  realtime: true\n  left: {kind: v4l2}\n  right: {kind: v4l2, device: 2}\n",
       "field 'source.realtime': a camera is always real time"}};
  TempDir dir;
  for (const BadCase& bad : cases) {
    SCOPED_TRACE(bad.name);
    const fs::path file = dir.write("live.yaml", bad.yaml);
    const std::string message = config_error(file);
    EXPECT_NE(message.find(file.string()), std::string::npos) << message;
    EXPECT_NE(message.find(bad.expected), std::string::npos) << message;
    EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
  }
}

TEST(PairConfig, OpensBothSidesAsOneStereoSource) {
  TempDir dir;
  write_camera(dir, "left", times(0, 4, 90), 10);
  write_camera(dir, "right", times(0, 4, 90, 0.002), 100);
  SourceConfig config = load_source_config(dir.write("live.yaml",
                                                     "source:\n"
                                                     "  kind: pair\n"
                                                     "  name: hmd\n"
                                                     "  left: {kind: images, path: left, name: left eye}\n"
                                                     "  right: {kind: images, path: right}\n"));
  {
    const OpenedSource opened = open_source_with_status(config);
    ASSERT_NE(opened.paired, nullptr);
    EXPECT_EQ(opened.reconnecting, nullptr);
    EXPECT_EQ(opened.left_reconnecting, nullptr) << "files are not reopened";
    EXPECT_EQ(opened.paired->describe(), "pair (left eye | images " + (dir / "right").string() + ", ±5 ms)");
    const std::vector<Frame> frames = drain(*opened.source);
    ASSERT_EQ(frames.size(), 4u);
    EXPECT_EQ(frames[0].source, "hmd");
    EXPECT_EQ(frames[0].image.size(), cv::Size(16, 6));
    EXPECT_EQ(opened.paired->pair_counts().paired, 4);
  }
  // A service that reopens every source (skylit-live) sets a reconnect on the pair: it goes to
  // each side, and the pair itself stays as it is.
  config.reconnect = BackoffSettings{};
  const OpenedSource opened = open_source_with_status(config);
  ASSERT_NE(opened.left_reconnecting, nullptr);
  ASSERT_NE(opened.right_reconnecting, nullptr);
  EXPECT_EQ(opened.reconnecting, nullptr);
  EXPECT_TRUE(opened.left_reconnecting->status().connected);
  EXPECT_EQ(drain(*opened.source).size(), 4u);
}

}  // namespace paired_source_test
