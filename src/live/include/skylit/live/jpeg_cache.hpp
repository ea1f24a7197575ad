#pragma once
// An image's JPEG, encoded once per new image however many consoles ask for it (docs/console.md).
#include <cstdint>
#include <functional>
#include <mutex>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "skylit/live/mailbox.hpp"

namespace skylit::live {

class JpegCache {
 public:
  // The JPEG of `latest`'s newest image (empty before one).
  std::vector<std::uint8_t> get(const Latest<cv::Mat>& latest);
  std::uint64_t encodes() const {  // images encoded so far
    std::lock_guard lock(mutex_);
    return encodes_;
  }

 private:
  mutable std::mutex mutex_;
  std::uint64_t encodes_ = 0;
  std::uint64_t version_ = 0;  // of the image encoded
  std::vector<std::uint8_t> bytes_;
};

}  // namespace skylit::live
