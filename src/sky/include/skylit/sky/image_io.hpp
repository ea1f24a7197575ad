#pragma once
// Pictures for people: 8-bit PNG/JPEG views of radiance and of shadow ratios, written atomically
// (a temporary beside the file, then a rename). Float data goes to OpenEXR with write_sky_exr
// (radiometry.hpp).
#include <filesystem>

#include <opencv2/core/mat.hpp>

namespace skylit::sky {

// Any image cv::imwrite takes, chosen by the file's extension.
void write_image(const std::filesystem::path& file, const cv::Mat& image);

// A linear radiance frame as an 8-bit sRGB picture: scaled so that the given percentile of the
// luminance of finite pixels maps to `white` (0.99 and 0.8: the sky shows, the sun clips).
cv::Mat tone_map(const cv::Mat& radiance, double percentile = 0.99, double white = 0.8);

// Linear [0, 1] values to 8-bit (no curve): the view of a shadow ratio, where 0.5 means half.
cv::Mat to_8bit_linear(const cv::Mat& unit_image);

}  // namespace skylit::sky
