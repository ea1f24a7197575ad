#include "skylit/live/jpeg_cache.hpp"

#include "service_state.hpp"

namespace skylit::live {

std::vector<std::uint8_t> JpegCache::get(const Latest<cv::Mat>& latest) {
  std::lock_guard lock(mutex_);
  if (latest.version() != version_) {
    auto [image, version] = latest.get_versioned();
    bytes_ = encode_jpeg(image.value_or(cv::Mat()));
    version_ = version;
    ++encodes_;
  }
  return bytes_;
}

}  // namespace skylit::live
