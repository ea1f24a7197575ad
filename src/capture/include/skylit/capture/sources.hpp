#pragma once
// The frame-source backends and their settings. config.hpp makes them from a `source:` node.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "skylit/capture/frame_source.hpp"

namespace cv {
class VideoCapture;
}

namespace skylit::camera {
class Lens;
}

namespace skylit::capture {

// ---------------------------------------------------------------------------------------------
// Image sequences: a folder or a glob of PNG, JPEG, TIFF, EXR or HDR files.

struct ImagesSettings {
  // A folder (every image in it, by name) or a glob ("shots/sky_*.png").
  std::filesystem::path path{};
  // A CSV with columns `file` and `timestamp` (seconds, or ISO 8601 times with a zone, as
  // skylit-sky's frames.csv); empty: frames.csv or timestamps.csv beside the images when there.
  // With a folder the frames are the files the CSV lists; with a glob they are the glob's files,
  // each found in the CSV by name, then by stem (frame_0001.png finds frame_0001.exr's row).
  std::filesystem::path timestamps{};
  std::optional<double> fps{};  // timestamps k / fps when there is no CSV
  bool loop = false;          // start again after the last image (timestamps keep increasing)
};

class ImagesSource final : public FrameSource {
 public:
  // InputError naming the path when nothing matches, naming the CSV's line and column for a
  // bad row or a missing file, and asking for fps when there is neither CSV nor fps.
  explicit ImagesSource(const ImagesSettings& settings, FrameChecks checks = {});
  std::string describe() const override;
  std::size_t size() const { return files_.size(); }

 protected:
  FrameResult read(double timeout_s) override;

 private:
  struct Entry {
    std::filesystem::path file{};
    double timestamp = 0;
    std::optional<std::chrono::sys_seconds> utc{};
  };
  std::vector<Entry> files_;
  std::filesystem::path pattern_;
  bool loop_ = false;
  double loop_period_ = 0;  // time added per pass when looping
  std::size_t next_ = 0;
  std::int64_t pass_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Video files (anything OpenCV's FFmpeg backend reads); timestamps from CAP_PROP_POS_MSEC.

struct VideoSettings {
  std::filesystem::path file{};
  bool loop = false;
};

class VideoSource final : public FrameSource {
 public:
  explicit VideoSource(const VideoSettings& settings, FrameChecks checks = {});
  ~VideoSource() override;
  std::string describe() const override;

 protected:
  FrameResult read(double timeout_s) override;

 private:
  VideoSettings settings_;
  std::unique_ptr<cv::VideoCapture> capture_;
  std::int64_t sequence_ = 0;
  double pass_offset_ = 0;  // seconds added to timestamps after each loop
  double last_timestamp_ = 0;
  double frame_period_ = 0;
};

// ---------------------------------------------------------------------------------------------
// V4L2 cameras through OpenCV.

struct V4l2Settings {
  std::string device = "0";  // an index ("0") or a device node ("/dev/video2")
  int width = 0;             // requested size; 0: the driver's default
  int height = 0;
  double fps = 0;            // requested rate; 0: the driver's default
  std::string fourcc{};      // requested pixel format ("MJPG", "YUYV"); empty: the default
  // Frames dropped after each new exposure of a bracket: V4L2 frames do not report their
  // exposure, and the driver's queued buffers and the sensor carry the old one a few frames.
  int bracket_settle_frames = 4;
};

// A V4L2 device node and the name the driver gives it.
struct V4l2Device {
  std::filesystem::path node{};  // /dev/video0
  std::string name{};            // from /sys/class/video4linux/video0/name; "" when unknown
};

// Where V4L2 devices are looked for (tests point these at a folder of their own).
struct V4l2Paths {
  std::filesystem::path dev = "/dev";
  std::filesystem::path sysfs = "/sys/class/video4linux";
};

// The video device nodes present, by number.
std::vector<V4l2Device> list_v4l2_devices(const V4l2Paths& paths = {});
// "/dev/video0 (UVC Camera), /dev/video2 (USB2.0 HD)" or "none found".
std::string describe_devices(const std::vector<V4l2Device>& devices);

class V4l2Source final : public FrameSource {
 public:
  // InputError naming the device, with the cameras present, when it does not exist; and naming
  // the likely causes (busy, permissions) when it exists but does not open.
  explicit V4l2Source(const V4l2Settings& settings, FrameChecks checks = {}, const V4l2Paths& paths = {});
  ~V4l2Source() override;
  std::string describe() const override;
  // Through CAP_PROP_AUTO_EXPOSURE (manual) and CAP_PROP_EXPOSURE in V4L2's 100 µs units;
  // true when the driver took it.
  bool set_exposure_time(double seconds) override;
  // CAP_PROP_GAIN in the driver's own units (not linear on every camera).
  bool set_gain(double gain) override;

 protected:
  FrameResult read(double timeout_s) override;
  // Each exposure in turn: set, bracket_settle_frames frames dropped, the next one kept (its
  // exposure_time the one set); the exposure in force before is restored (auto exposure when
  // none was set). nullopt when the driver takes no manual exposure.
  std::optional<std::vector<Frame>> read_bracket(std::span<const double> exposure_times_s, double timeout_s) override;

 private:
  int bracket_settle_frames_ = 4;
  std::filesystem::path node_;
  std::string name_;
  std::unique_ptr<cv::VideoCapture> capture_;
  std::int64_t sequence_ = 0;
  std::optional<double> exposure_time_;
  std::optional<double> gain_;
};

// ---------------------------------------------------------------------------------------------
// The sky simulator: what a calibrated sky camera records under an analytic sky (a time-lapse of
// the clear or overcast sky, the sun where it stands at the place and time) or a fixed HDR
// equirect (skylit/sky/simulate.hpp).

struct SkySimSettings {
  std::filesystem::path calibration{};  // the sky camera (frames have its size)
  enum class Sky { Clear, Overcast, Equirect };
  Sky sky = Sky::Clear;
  std::filesystem::path equirect{};     // Sky::Equirect: the HDR sky image
  double azimuth_offset_deg = 0;      // Sky::Equirect: azimuth the image's centre column looks at
  std::chrono::sys_seconds start{};   // UTC of frame 0
  std::chrono::seconds step{600};     // sky time between frames
  std::int64_t frames = 0;            // how many (0: no end)
  double latitude_deg = 0;
  double longitude_deg = 0;
  double turbidity = 3.0;             // Sky::Clear, 2..10
  double zenith_radiance = 5.0;       // Sky::Overcast
  int supersample = 2;                // 1..16
  // Set: 8-bit frames as a camera writes them, code = sRGB(clamp(L · time · gain)); unset:
  // float radiance frames. set_exposure_time switches to 8-bit.
  std::optional<double> exposure_time{};
  double gain = 1.0;
};

class SkySimSource final : public FrameSource {
 public:
  // InputError naming the calibration or the equirect when they cannot be read, or a value out
  // of range.
  explicit SkySimSource(const SkySimSettings& settings, FrameChecks checks = {});
  ~SkySimSource() override;
  std::string describe() const override;
  bool set_exposure_time(double seconds) override;
  bool set_gain(double gain) override;
  // Frame k's UTC (start + k · step).
  std::chrono::sys_seconds utc_of(std::int64_t k) const;

 protected:
  FrameResult read(double timeout_s) override;
  // One sky rendered once and clipped at each exposure (all frames share its time).
  std::optional<std::vector<Frame>> read_bracket(std::span<const double> exposure_times_s,
                                                 double timeout_s) override;

 private:
  cv::Mat render(std::int64_t k) const;  // linear radiance of frame k
  Frame make_frame(const cv::Mat& radiance, std::int64_t k, std::optional<double> exposure_time) const;
  SkySimSettings settings_;
  std::unique_ptr<camera::Lens> lens_;
  cv::Mat equirect_render_;  // Sky::Equirect: rendered once
  std::int64_t next_ = 0;
  std::int64_t sequence_ = 0;
};

}  // namespace skylit::capture
