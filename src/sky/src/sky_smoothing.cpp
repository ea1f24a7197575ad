// Exponential smoothing of S by frame timestamps (see sky_smoothing.hpp).
#include "skylit/sky/sky_smoothing.hpp"

#include <cmath>
#include <string>

#include "skylit/base/error.hpp"

namespace skylit::sky {
namespace {

[[noreturn]] void bad_input(const std::string& field, const std::string& problem, const std::string& fix) {
  throw InputError(input_message({}, -1, -1, field, problem, fix));
}

}  // namespace

SkySmoother::SkySmoother(double time_constant_s) : time_constant_(time_constant_s) {
  if (!std::isfinite(time_constant_s) || time_constant_s < 0.0) {
    bad_input("smoothing time constant", std::to_string(time_constant_s) + " s is not finite and >= 0",
              "use 0 (off) or a few seconds");
  }
}

void SkySmoother::update(double timestamp_s, std::span<const Eigen::Vector3d> S,
                         const std::optional<Eigen::Vector3d>& sun_energy) {
  if (!std::isfinite(timestamp_s)) bad_input("timestamp", "is not finite", "pass the frame's capture time in seconds");
  for (std::size_t i = 0; i < S.size(); ++i) {
    if (!S[i].allFinite()) {
      bad_input("S[" + std::to_string(i) + "]", "is not finite", "smooth the luminance parameters of the sky stage");
    }
  }
  if (sun_energy && !sun_energy->allFinite()) bad_input("sun.energy", "is not finite", "pass the detected sun's energy");

  const bool restart = !started_ || time_constant_ == 0.0 || S.size() != S_.size() ||
                       sun_energy.has_value() != sun_energy_.has_value() || timestamp_s < last_time_;
  restarted_ = restart;
  if (restart) {
    S_.assign(S.begin(), S.end());
    sun_energy_ = sun_energy;
    started_ = true;
    last_time_ = timestamp_s;
    return;
  }
  const double alpha = -std::expm1(-(timestamp_s - last_time_) / time_constant_);  // 1 − e^(−Δt/τ)
  for (std::size_t i = 0; i < S.size(); ++i) S_[i] += alpha * (S[i] - S_[i]);
  if (sun_energy) *sun_energy_ += alpha * (*sun_energy - *sun_energy_);
  last_time_ = timestamp_s;
}

SkyEstimate SkySmoother::smooth(double timestamp_s, SkyEstimate estimate) {
  // Every value the blend or a report reads: the face means, and with the corners or quadratics
  // basis the coefficients of each face's functions after them.
  const bool fitted = estimate.luminance.basis != geom::DomeBasis::Faces;
  const auto layers = static_cast<std::size_t>(geom::layers_per_face(estimate.luminance.basis));
  std::vector<Eigen::Vector3d> S;
  S.reserve(estimate.luminance.faces.size() * (fitted ? layers + 1 : 1));
  for (const FaceLuminance& face : estimate.luminance.faces) S.push_back(face.rgb);
  if (fitted) {
    for (const FaceLuminance& face : estimate.luminance.faces) {
      for (std::size_t k = 0; k < layers; ++k) S.push_back(k < face.coefficients.size() ? face.coefficients[k] : face.rgb);
    }
  }
  std::optional<Eigen::Vector3d> sun;
  if (estimate.sun) sun = estimate.sun->energy;
  update(timestamp_s, S, sun);
  const std::size_t n = estimate.luminance.faces.size();
  for (std::size_t i = 0; i < n; ++i) estimate.luminance.faces[i].rgb = S_[i];
  if (fitted) {
    for (std::size_t i = 0; i < n; ++i) {
      estimate.luminance.faces[i].coefficients.resize(layers);
      for (std::size_t k = 0; k < layers; ++k) estimate.luminance.faces[i].coefficients[k] = S_[n + layers * i + k];
    }
  }
  if (estimate.sun) estimate.sun->energy = *sun_energy_;
  return estimate;
}

}  // namespace skylit::sky
