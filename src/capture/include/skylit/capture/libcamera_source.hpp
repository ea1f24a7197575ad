#pragma once
// Cameras through libcamera (Raspberry Pi cameras, and UVC cameras libcamera supports): one
// stream, a request loop over a frame-buffer allocator's buffers, exposure time and analogue
// gain set per request so that the sky camera can bracket. libcamera's types stay in the .cpp.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "skylit/capture/frame_source.hpp"

namespace skylit::capture {

struct LibcameraSettings {
  std::string camera{};   // a camera id (`cam --list` shows them) or an index ("0"); empty: the first
  int width = 0;          // requested size; 0: the camera's default for its role
  int height = 0;
  // RGB888, BGR888, XRGB8888, XBGR8888, YUYV, NV12 or MJPEG (libcamera's names); frames come
  // out as 8-bit BGR.
  std::string pixel_format = "RGB888";
  int buffer_count = 4;   // requests in flight
  std::optional<double> exposure_time{};  // seconds; set: auto exposure off from the start
  std::optional<double> gain{};           // analogue gain; set: auto exposure off from the start
  // Frames a new exposure may take to reach the sensor before a bracket gives up on it
  // (libcamera pipelines apply controls a few frames late).
  int bracket_settle_frames = 8;
};

struct LibcameraCamera {
  std::string id{};
  std::string model{};  // the Model property; "" when the camera does not say
};

// The cameras libcamera sees now.
std::vector<LibcameraCamera> list_libcamera_cameras();
// "imx477 (/base/soc/i2c0mux/i2c@1/imx477@1a), ..." or "none found".
std::string describe_cameras(const std::vector<LibcameraCamera>& cameras);

// The pixel formats frames can be delivered in, and the conversion of one frame's planes (as
// mapped from the frame buffer; `stride` bytes per row of the first plane, `used` the bytes of
// an MJPEG frame) to 8-bit BGR. Empty when the data is short or does not decode.
const std::vector<std::string>& libcamera_pixel_formats();
cv::Mat libcamera_frame_to_bgr(const std::string& pixel_format, cv::Size size, int stride,
                               std::span<const std::span<const unsigned char>> planes, std::size_t used);

class LibcameraSource final : public FrameSource {
 public:
  // InputError naming the camera, with the cameras present, when it is not there; naming the
  // format and the supported ones for a pixel format libcamera or skylit cannot use; CaptureError
  // when the camera refuses to be acquired, configured or started.
  explicit LibcameraSource(const LibcameraSettings& settings, FrameChecks checks = {});
  ~LibcameraSource() override;
  std::string describe() const override;
  bool set_exposure_time(double seconds) override;  // ExposureTime, auto exposure off
  bool set_gain(double gain) override;              // AnalogueGain, auto exposure off

 protected:
  FrameResult read(double timeout_s) override;
  // Each exposure in turn: requests carry it until a frame whose metadata reports it (within
  // 2% or 20 µs) comes back, or bracket_settle_frames frames have passed (then the last one, its
  // reported exposure in Frame::exposure_time). The exposure in force before is restored.
  std::optional<std::vector<Frame>> read_bracket(std::span<const double> exposure_times_s,
                                                 double timeout_s) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace skylit::capture
