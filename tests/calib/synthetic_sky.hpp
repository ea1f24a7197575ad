#pragma once
// Timestamped sky frames with a known answer: the sky simulator's clear (or overcast) sky seen
// through a sky camera of known orientation, written as float EXR with a frames.csv.
#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "skylit/camera/calibration.hpp"

namespace skylit::calib_test {

// A small equidistant sky camera (size × size, 180° across the image's width).
camera::CameraCalibration small_sky_camera(int size);

// Renders one frame per time into `dir` (frame_00.exr, ...) through `camera` (its R is the
// truth) and writes `dir`/frames.csv (timestamp,file) with `csv_times` (the render times when
// empty). Returns the CSV's path.
std::filesystem::path write_sky_frames(const std::filesystem::path& dir, const camera::CameraCalibration& camera,
                                       double latitude_deg, double longitude_deg,
                                       const std::vector<std::chrono::sys_seconds>& times, bool clear,
                                       const std::vector<std::string>& csv_times = {});

}  // namespace skylit::calib_test
