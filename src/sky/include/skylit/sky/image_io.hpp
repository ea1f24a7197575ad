#pragma once
// Writing the images skylit produces: float RGB OpenEXR for data, 8-bit PNG/JPEG views for
// people. Every write is atomic (a temporary beside the file, then a rename).
#include <filesystem>

#include <opencv2/core/mat.hpp>

namespace skylit::sky {

// CV_32FC3 (BGR) or CV_32FC1 as float RGB (or Y) OpenEXR, ZIP compressed.
void write_exr(const std::filesystem::path& file, const cv::Mat& image);

// Any image cv::imwrite takes, chosen by the file's extension.
void write_image(const std::filesystem::path& file, const cv::Mat& image);

// A linear radiance frame as an 8-bit sRGB picture: scaled so that the given percentile of the
// luminance of finite pixels maps to `white` (0.99 and 0.8: the sky shows, the sun clips).
cv::Mat tone_map(const cv::Mat& radiance, double percentile = 0.99, double white = 0.8);

// Linear [0, 1] values to 8-bit (no curve): the view of a shadow ratio, where 0.5 means half.
cv::Mat to_8bit_linear(const cv::Mat& unit_image);

}  // namespace skylit::sky
