// Cameras: V4L2 enumeration and the absent-device messages (on a fake /dev and sysfs, and on
// this machine), libcamera's absent-camera message and its pixel-format conversions.
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "capture_test_support.hpp"
#include "skylit/base/error.hpp"
#include "skylit/capture/libcamera_source.hpp"
#include "skylit/capture/sources.hpp"

namespace {

using namespace skylit::capture;
using skylit::capture::testing::TempDir;
namespace fs = std::filesystem;

template <typename Action>
std::string input_error_of(Action action) {
  try {
    action();
  } catch (const skylit::InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

V4l2Paths fake_cameras(const TempDir& dir) {
  dir.write("dev/video0", "");
  dir.write("dev/video2", "");
  dir.write("dev/video10", "");
  dir.write("dev/vcs1", "");
  dir.write("sys/video0/name", "UVC Camera (046d:0825)\n");
  dir.write("sys/video2/name", "USB2.0 HD UVC WebCam\n");
  return V4l2Paths{dir.path() / "dev", dir.path() / "sys"};
}

TEST(V4l2, ListsVideoNodesByNumberWithTheirNames) {
  TempDir dir;
  const V4l2Paths paths = fake_cameras(dir);
  const std::vector<V4l2Device> devices = list_v4l2_devices(paths);
  ASSERT_EQ(devices.size(), 3u);
  EXPECT_EQ(devices[0].node, paths.dev / "video0");
  EXPECT_EQ(devices[0].name, "UVC Camera (046d:0825)");
  EXPECT_EQ(devices[1].node, paths.dev / "video2");
  EXPECT_EQ(devices[2].node, paths.dev / "video10");
  EXPECT_EQ(devices[2].name, "");
  EXPECT_EQ(describe_devices(devices), (paths.dev / "video0").string() + " (UVC Camera (046d:0825)), " +
                                           (paths.dev / "video2").string() + " (USB2.0 HD UVC WebCam), " +
                                           (paths.dev / "video10").string());
}

TEST(V4l2, AnAbsentCameraListsTheCamerasThatAreThere) {
  TempDir dir;
  const V4l2Paths paths = fake_cameras(dir);
  const std::string message = input_error_of([&] { V4l2Source(V4l2Settings{.device = "3"}, {}, paths); });
  EXPECT_NE(message.find("no V4L2 camera '" + (paths.dev / "video3").string() + "'"), std::string::npos) << message;
  EXPECT_NE(message.find("cameras present: " + (paths.dev / "video0").string() + " (UVC Camera (046d:0825))"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("Fix: plug the camera in"), std::string::npos) << message;
}

TEST(V4l2, NoCamerasAtAllIsSaidPlainly) {
  TempDir dir;
  fs::create_directories(dir.path() / "dev");
  const V4l2Paths paths{dir.path() / "dev", dir.path() / "sys"};
  const std::string message = input_error_of([&] { V4l2Source(V4l2Settings{.device = "0"}, {}, paths); });
  EXPECT_NE(message.find("cameras present: none found"), std::string::npos) << message;
}

TEST(V4l2, ThisMachinesAbsentDeviceMessageListsItsCameras) {
  const std::string expected = describe_devices(list_v4l2_devices());
  const std::string message = input_error_of([] { V4l2Source(V4l2Settings{.device = "/dev/video99"}); });
  EXPECT_NE(message.find("no V4L2 camera '/dev/video99'; cameras present: " + expected), std::string::npos) << message;
}

TEST(V4l2, ANodeThatIsNoCameraDoesNotOpen) {
  TempDir dir;
  const V4l2Paths paths = fake_cameras(dir);  // plain files, not devices
  const std::string message = input_error_of([&] { V4l2Source(V4l2Settings{.device = "2"}, {}, paths); });
  EXPECT_NE(message.find("cannot open the V4L2 camera " + (paths.dev / "video2").string() + " (USB2.0 HD UVC WebCam)"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("'video' group"), std::string::npos) << message;
}

// ---------------------------------------------------------------------------------------------

TEST(Libcamera, AnAbsentCameraListsTheCamerasThatAreThere) {
  const std::vector<LibcameraCamera> cameras = list_libcamera_cameras();
  const std::string message =
      input_error_of([] { LibcameraSource(LibcameraSettings{.camera = "no-such-camera"}); });
  EXPECT_NE(message.find("no libcamera camera 'no-such-camera'; cameras present: " + describe_cameras(cameras)),
            std::string::npos)
      << message;
  if (cameras.empty()) {
    EXPECT_NE(message.find("none found"), std::string::npos) << message;
    const std::string first = input_error_of([] { LibcameraSource(LibcameraSettings{}); });
    EXPECT_NE(first.find("no libcamera camera '(the first)'; cameras present: none found"), std::string::npos) << first;
  }
}

TEST(Libcamera, DescribesCamerasByIndexModelAndId) {
  EXPECT_EQ(describe_cameras({}), "none found");
  EXPECT_EQ(describe_cameras({{"/base/soc/i2c0mux/i2c@1/imx477@1a", "imx477"}, {"\\_SB_.PCI0-2.1:1.0-046d:0825", ""}}),
            "0: imx477 (/base/soc/i2c0mux/i2c@1/imx477@1a), 1: \\_SB_.PCI0-2.1:1.0-046d:0825");
}

TEST(Libcamera, AnUnsupportedPixelFormatIsRefusedBeforeTheCameraIsTouched) {
  const std::string message = input_error_of([] { LibcameraSource(LibcameraSettings{.pixel_format = "SRGGB10"}); });
  EXPECT_NE(message.find("field 'pixel_format': 'SRGGB10' is not supported"), std::string::npos) << message;
  EXPECT_NE(message.find("RGB888"), std::string::npos) << message;
}

// Frame buffers as libcamera fills them, with row padding.
std::vector<unsigned char> padded(const cv::Mat& image, int stride) {
  std::vector<unsigned char> bytes(static_cast<std::size_t>(stride) * image.rows, 0xEE);
  const std::size_t row = image.cols * image.elemSize();
  for (int y = 0; y < image.rows; ++y) std::memcpy(bytes.data() + static_cast<std::size_t>(y) * stride, image.ptr(y), row);
  return bytes;
}

cv::Mat pattern() {
  cv::Mat bgr(4, 6, CV_8UC3);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 6; ++x) bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(10 * x, 20 * y, 200 - 5 * x - 7 * y);
  }
  return bgr;
}

cv::Mat convert(const std::string& format, const std::vector<std::vector<unsigned char>>& planes, int stride,
                std::size_t used = 0) {
  std::vector<std::span<const unsigned char>> views;
  for (const auto& plane : planes) views.emplace_back(plane.data(), plane.size());
  return libcamera_frame_to_bgr(format, cv::Size(6, 4), stride, views, used);
}

TEST(Libcamera, ConvertsPackedRgbFormatsRespectingTheStride) {
  const cv::Mat bgr = pattern();
  // RGB888 is stored B, G, R (DRM's little-endian naming): OpenCV's order.
  EXPECT_EQ(cv::norm(convert("RGB888", {padded(bgr, 32)}, 32), bgr, cv::NORM_INF), 0.0);
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  EXPECT_EQ(cv::norm(convert("BGR888", {padded(rgb, 20)}, 20), bgr, cv::NORM_INF), 0.0);
  cv::Mat bgra;
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  EXPECT_EQ(cv::norm(convert("XRGB8888", {padded(bgra, 32)}, 32), bgr, cv::NORM_INF), 0.0);
  cv::Mat rgba;
  cv::cvtColor(bgr, rgba, cv::COLOR_BGR2RGBA);
  EXPECT_EQ(cv::norm(convert("XBGR8888", {padded(rgba, 24)}, 24), bgr, cv::NORM_INF), 0.0);
  // A buffer shorter than the rows it should hold gives no frame.
  std::vector<unsigned char> short_buffer = padded(bgr, 32);
  short_buffer.resize(40);
  EXPECT_TRUE(convert("RGB888", {short_buffer}, 32).empty());
}

TEST(Libcamera, ConvertsYuvAndMjpegFrames) {
  // Mid grey: Y = 128, U = V = 128 in YUYV (Y0 U Y1 V) and NV12 (Y plane, then UV pairs); video
  // range (BT.601, Y 16..235), so 1.164 (128 − 16) = 130 in RGB.
  std::vector<unsigned char> yuyv(16 * 4, 128);
  const cv::Mat from_yuyv = convert("YUYV", {yuyv}, 16);
  ASSERT_EQ(from_yuyv.size(), cv::Size(6, 4));
  EXPECT_NEAR(cv::mean(from_yuyv)[0], 130, 1.0);
  EXPECT_NEAR(cv::mean(from_yuyv)[2], 130, 1.0);

  std::vector<unsigned char> luma(8 * 4, 128), chroma(8 * 2, 128);
  for (int x = 0; x < 6; ++x) luma[x] = 235;  // first row white
  const cv::Mat two_planes = convert("NV12", {luma, chroma}, 8);
  ASSERT_EQ(two_planes.size(), cv::Size(6, 4));
  EXPECT_GT(two_planes.at<cv::Vec3b>(0, 0)[1], 250);
  EXPECT_NEAR(two_planes.at<cv::Vec3b>(3, 5)[1], 130, 1);
  std::vector<unsigned char> one_plane = luma;
  one_plane.insert(one_plane.end(), chroma.begin(), chroma.end());
  EXPECT_EQ(cv::norm(convert("NV12", {one_plane}, 8), two_planes, cv::NORM_INF), 0.0);

  std::vector<unsigned char> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", pattern(), jpeg, {cv::IMWRITE_JPEG_QUALITY, 100}));
  const std::size_t used = jpeg.size();
  jpeg.resize(used + 100, 0);  // the buffer is larger than the frame
  const cv::Mat from_jpeg = convert("MJPEG", {jpeg}, 6, used);
  ASSERT_EQ(from_jpeg.size(), cv::Size(6, 4));
  EXPECT_LT(cv::norm(from_jpeg, pattern(), cv::NORM_INF), 24.0);  // 4:2:0 chroma on a tiny image
  EXPECT_TRUE(convert("MJPEG", {jpeg}, 6, 0).empty());
}

}  // namespace
