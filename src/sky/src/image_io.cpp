#include "skylit/sky/image_io.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/sky/srgb.hpp"

namespace skylit::sky {

void write_image(const std::filesystem::path& file, const cv::Mat& image) {
  std::string extension = file.extension().string();
  if (extension.empty()) extension = ".png";
  std::vector<unsigned char> bytes;
  if (!cv::imencode(extension, image, bytes)) {
    throw InputError(file.string() + ": cannot encode an image as '" + extension + "'. Fix: use .png or .jpg");
  }
  write_file_atomic(file, std::span<const std::byte>(reinterpret_cast<const std::byte*>(bytes.data()), bytes.size()));
}

cv::Mat tone_map(const cv::Mat& radiance, double percentile, double white) {
  CV_Assert(radiance.type() == CV_32FC3);
  std::vector<float> luminance;
  luminance.reserve(radiance.total());
  for (int y = 0; y < radiance.rows; ++y) {
    const auto* row = radiance.ptr<cv::Vec3f>(y);
    for (int x = 0; x < radiance.cols; ++x) {
      const float l = 0.0722f * row[x][0] + 0.7152f * row[x][1] + 0.2126f * row[x][2];
      if (std::isfinite(l) && l > 0.0f) luminance.push_back(l);
    }
  }
  double scale = 1.0;
  if (!luminance.empty()) {
    const auto at = luminance.begin() + static_cast<std::ptrdiff_t>(percentile * static_cast<double>(luminance.size() - 1));
    std::nth_element(luminance.begin(), at, luminance.end());
    if (*at > 0.0f) scale = white / *at;
  }
  cv::Mat out(radiance.size(), CV_8UC3);
  for (int y = 0; y < radiance.rows; ++y) {
    const auto* in = radiance.ptr<cv::Vec3f>(y);
    auto* o = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < radiance.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        double v = in[x][c] * scale;
        if (!std::isfinite(v) || v < 0.0) v = 0.0;
        o[x][c] = srgb_encode8(v);
      }
    }
  }
  return out;
}

cv::Mat to_8bit_linear(const cv::Mat& unit_image) {
  cv::Mat out;
  unit_image.convertTo(out, CV_8U, 255.0);  // saturating, rounds to nearest
  return out;
}

}  // namespace skylit::sky
