#pragma once
// The sRGB transfer function (IEC 61966-2-1) between linear values and encoded ones, both in
// [0, 1]: the one definition every picture, frame and response curve here uses.
#include <algorithm>
#include <cmath>

namespace skylit::sky {

// Linear → encoded. Inputs are clamped to [0, 1]; NaN gives 0.
inline double srgb_encode(double linear) {
  const double v = linear > 0.0 ? std::min(linear, 1.0) : 0.0;
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

// In float for per-pixel loops (float pow is several times cheaper than double's).
inline float srgb_encode(float linear) {
  const float v = linear > 0.0f ? std::min(linear, 1.0f) : 0.0f;
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

// Encoded → linear, the inverse of srgb_encode. Inputs are clamped to [0, 1]; NaN gives 0.
inline double srgb_decode(double encoded) {
  const double v = encoded > 0.0 ? std::min(encoded, 1.0) : 0.0;
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// Linear → an 8-bit code, rounded to nearest.
inline unsigned char srgb_encode8(double linear) {
  return static_cast<unsigned char>(std::lround(255.0 * srgb_encode(linear)));
}

}  // namespace skylit::sky
