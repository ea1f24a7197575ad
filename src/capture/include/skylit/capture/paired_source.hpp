#pragma once
// A stereo camera as one frame source: two sources (the left and the right eye's camera, any
// kind) paired by timestamp and delivered as one side-by-side frame, the left camera's image in
// the left half. A camera that delivers side-by-side frames itself (ZED-class) needs no pairing.
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core/mat.hpp>

#include "skylit/capture/frame_source.hpp"

namespace skylit::capture {

// The two halves of a side-by-side stereo frame.
struct StereoHalves {
  cv::Mat left;
  cv::Mat right;
};

// The halves of `frame` as views into it (no copy). InputError for an empty frame or an odd width.
StereoHalves split_side_by_side(const cv::Mat& frame);
// One side-by-side frame (a copy): `left` in the left half. InputError naming both sizes and
// types when they differ, or when either is empty.
cv::Mat join_side_by_side(const cv::Mat& left, const cv::Mat& right);

// Frames the pairing took, and those that found no partner, per side (a snapshot; safe to take
// from any thread).
struct PairCounts {
  std::int64_t paired = 0;
  std::int64_t unpaired_left = 0;
  std::int64_t unpaired_right = 0;
};

// Pairs the frames of two sources whose timestamps lie on one clock (V4L2 and libcamera: the
// steady clock; image sequences: their CSVs). A pair is two frames at most `tolerance_s` apart;
// it becomes one frame:
//   image      the left image beside the right (both must have the same size and type: else
//              InputError naming both sources' sizes and types, at the first pair, since every
//              source keeps the size and type of its first frame)
//   timestamp  the mean of the two: within tolerance_s / 2 of either camera's exposure, so a
//              pose looked up at that time fits both eyes equally
//   sequence   the pair's own count; exposure_time, gain and utc: the left frame's
// A frame whose partner can no longer come (the other side has passed it by more than the
// tolerance; timestamps increase per source) is dropped and counted on its side, so one side
// running ahead or dropping frames never stalls the pairing. End of stream when either side ends.
class PairedSource final : public FrameSource {
 public:
  // InputError when a side is missing or the tolerance is not a positive number of seconds.
  PairedSource(std::unique_ptr<FrameSource> left, std::unique_ptr<FrameSource> right, double tolerance_s = 0.005,
               FrameChecks checks = {});

  // "pair (images left/ | images right/, ±5 ms)".
  std::string describe() const override;
  // Applied to both cameras; true when both took it.
  bool set_exposure_time(double seconds) override;
  bool set_gain(double gain) override;
  // Both sides' drops (malformed frames) and this source's; delivered: the pairs handed out.
  FrameCounts counts() const override;
  PairCounts pair_counts() const;
  double tolerance_s() const { return tolerance_s_; }

 protected:
  FrameResult read(double timeout_s) override;

 private:
  FrameResult end_of_stream();  // counts the frames left waiting as unpaired
  Frame join(Frame& left, Frame& right);

  std::unique_ptr<FrameSource> left_;
  std::unique_ptr<FrameSource> right_;
  double tolerance_s_;
  std::optional<Frame> left_waiting_;
  std::optional<Frame> right_waiting_;
  bool ended_ = false;
  std::int64_t sequence_ = 0;
  std::atomic<std::int64_t> paired_{0};
  std::atomic<std::int64_t> unpaired_left_{0};
  std::atomic<std::int64_t> unpaired_right_{0};
};

}  // namespace skylit::capture
