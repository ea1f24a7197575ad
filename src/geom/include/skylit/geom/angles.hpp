#pragma once
// π and the degree in radians: one definition for every module that converts angles.
#include <numbers>

namespace skylit::geom {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDeg = kPi / 180.0;  // one degree in radians: radians = degrees * kDeg

}  // namespace skylit::geom
