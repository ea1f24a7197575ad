#pragma once
// The parts of the accuracy study (bench/accuracy_study.cpp) that the trade table
// (study/trade.hpp, `skylit-bench trade`) shares with it: the dense reference over an
// equirect sky, the sun as the equirect has it, the site at a coarser resolution, error
// statistics; and the compositor's benchmark view (bench/compose_bench.cpp).
#include <chrono>
#include <filesystem>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "skylit/render/compositor.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/camera/calibration.hpp"
#include "skylit/sky/simulate.hpp"

namespace skylit::study {

using geom::Vec3;
using Clock = std::chrono::steady_clock;

struct Errors {
  double rms = 0, p99 = 0, max = 0;
};

// RMS, 99th percentile and maximum of `diffs` (all 0 when empty).
Errors errors_of(std::vector<double> diffs);
// The same with each diff standing for weights[k] of the whole (an area): the weighted RMS, the
// diff below which 99% of the weight lies, and the largest diff of positive weight.
Errors errors_of(std::span<const double> diffs, std::span<const double> weights);

double seconds_since(Clock::time_point t);
double median(std::vector<double> values);  // the upper median; 0 when empty
double luminance(const Eigen::Vector3d& rgb);
double degrees_between(const Vec3& a, const Vec3& b);

// The sun as the equirect has it: its brightest pixel above the horizon, the median radiance of
// the ring 6°–15° around it as background, and the pixels within kOracleRadiusDeg with their
// radiance above that background (energy = Σ (L − L_bg) Ω, per channel).
inline constexpr double kOracleRadiusDeg = 4.0;
struct EquirectSun {
  bool found = false;
  Vec3 peak = Vec3::UnitZ();
  Vec3 centroid = Vec3::UnitZ();             // energy-weighted
  Eigen::Vector3d background = Eigen::Vector3d::Zero();
  Eigen::Vector3d energy = Eigen::Vector3d::Zero();
  std::vector<Vec3> directions;
  std::vector<double> weights;               // share of the energy's luminance, sum 1
  std::vector<std::pair<int, int>> pixels;   // (row, col)
  double energy_within(double radius_deg, const cv::Mat& equirect) const;
};
EquirectSun equirect_sun(const cv::Mat& equirect);

// What an HMD camera sees of real ground under an equirect sky (sky.clipped_sun_energy:
// shadow_contrast): grey ground of albedo 0.2 with a ±15% texture, in the open (left half) and in
// the shadow of a post that hides every sky pixel within `occluder_deg` of `sun` (right half),
// as one 8-bit sRGB frame exposed for the lit ground (its brightest channel's median at half
// scale), read back.
struct GroundView {
  cv::Mat linear;               // CV_32FC3 BGR, the frame through the sRGB curve
  cv::Mat lit, shadowed;        // CV_8U masks
  Eigen::Vector3d lit_irradiance = Eigen::Vector3d::Zero();       // the truth: E on the open ground
  Eigen::Vector3d shadowed_irradiance = Eigen::Vector3d::Zero();  // and in the post's shadow
};
GroundView real_ground_view(const cv::Mat& equirect, const Vec3& sun, double occluder_deg);

// The site with every plane's resolution divided by `scale` (the reference costs one ray per
// texel and sky pixel), written to dir/site.yaml; returns its path.
std::filesystem::path coarse_site(const std::filesystem::path& site_file, int scale, const std::filesystem::path& dir);

// An equirect HDR sky with its negative and non-finite pixels set to 0. Lossy HDR captures hold
// them; both paths see the same sky, cleaned once, so that resampling the artefacts into the
// fisheye does not count as error of the dome.
cv::Mat read_clean_sky(const std::filesystem::path& file);

// Every pixel of an equirect sky above the horizon as a light: its direction and radiance ×
// solid angle (RGB). With supersample N > 1 the pixels near a bright one (over
// kBrightOverMedian × the median, or next to one) become N×N sub-directions with the bilinearly
// interpolated radiance (dense_reference's lights).
struct EquirectLights {
  std::vector<Vec3> directions;
  std::vector<Eigen::Vector3d> weights;
  std::size_t supersampled = 0;  // pixels split into sub-directions
};
EquirectLights equirect_lights(const cv::Mat& equirect, int supersample);

// T_ref of every plane of `site` (per texel, RGB):
//
//   T_ref(x) = Σ_p L_p Ω_p max(0, n·ω_p) V(x, ω_p) / Σ_p L_p Ω_p max(0, n·ω_p)   (per channel)
//
// With reference_supersample N > 1, the pixels near a bright one (over kBrightOverMedian × the
// median, or next to one) become N×N sub-directions with the bilinearly interpolated radiance:
// the continuous sky the fisheye is rendered from, instead of one point light per pixel.
inline constexpr double kBrightOverMedian = 20.0;
struct DenseReference {
  std::vector<std::vector<Eigen::Vector3d>> planes;
  std::vector<Eigen::Vector3d> totals;  // per plane: Σ_p L_p Ω_p max(0, n·ω_p), T_ref's denominator
  double seconds = 0;            // the ray casts
  std::size_t supersampled = 0;  // pixels split into sub-directions
};
DenseReference dense_reference(const cv::Mat& equirect, const scene::Site& site, const scene::Mesh& mesh,
                               int reference_supersample);
// dense_reference from lights already made: a caller that also needs the building's reference
// (building_light.hpp) makes them once.
DenseReference dense_reference(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh);

// A sky sequence (skylit-bench trade --sequence, docs/trade.md): an analytic clear sky (the sky
// simulator's, sky::analytic_sky) over `frames` seconds from `start`, one sky per `interval_s`,
// with the sun where the solar-position algorithm puts it at (latitude, longitude), and a passing
// cloud: over the middle half of the sequence the sun's irradiance is dimmed by
//     d(t) = 1 − cloud · ½ (1 − cos 2π (t − t_a) / (t_b − t_a)),   t_a, t_b = ¼, ¾ of the duration
// (1 outside), and the sky's radiance by 0.7 + 0.3 d(t), so that S and the sun's share change.
struct SequenceOptions {
  int frames = 60;
  double interval_s = 1.0;
  std::chrono::sys_seconds start{};
  double latitude_deg = 34.68, longitude_deg = 135.84;  // Nara: the sample site's temple gate
  double turbidity = 3.0;
  double cloud = 0.65;
};
double sequence_time(const SequenceOptions& options, int frame);     // seconds from the start
double sequence_dimming(const SequenceOptions& options, int frame);  // d(t) of the sun, 1 outside the cloud
sky::SkyFunction sequence_sky(const SequenceOptions& options, int frame);

// The dense reference of every frame of the sequence: T_ref as dense_reference defines it, every
// pixel of an equirect of the sky (without the disc) above the horizon a light, plus the sun's
// disc as an area light (a polar grid of directions over its angular radius, equal weights), all
// ray-cast with Embree. To stay cheap, the sky part (which only follows the slow sun) is
// ray-cast at key frames `key_interval_s` apart (and the last frame) and its sums interpolated
// linearly in time between them, times the frame's sky dimming; the sun's disc is ray-cast for
// every frame. planes[frame][plane][texel] RGB.
struct SequenceReference {
  std::vector<std::vector<std::vector<Eigen::Vector3d>>> frames;
  double seconds = 0;  // the ray casts
};
SequenceReference sequence_reference(const SequenceOptions& options, const scene::Site& site, const scene::Mesh& mesh,
                                     int equirect_width = 128, double key_interval_s = 30.0);

// The compositor benchmark's view: the HMD camera of `calibration_file` scaled to width (same
// focal length per pixel of width), any height, principal point centred; and a visitor's pose:
// eye height 1.6 m, 18 m south of the gate's centre, looking at its middle (0, 0, 3 m).
camera::CameraCalibration scaled_camera(const std::filesystem::path& calibration_file, int width, int height);
render::CameraPose visitor_pose();
inline constexpr double kVisitorDistance = 18.0;  // m, eye to the gate's centre

// The benchmarks' separated sources: the sun towards `sun` (the real sun's 0.27° disc) and
// count − 1 lamps of 2° radius spread over the sky (elevations 35°–75°, azimuths a golden angle
// apart), each of `lamp_energy`.
struct BenchSources {
  std::vector<render::ShadowSource> discs;  // for the shadow maps, the sun first
  std::vector<blend::SunLight> lamps;       // the lamps as lights (after the sun)
};
BenchSources bench_sources(const Eigen::Vector3d& sun, int count, const Eigen::Vector3d& lamp_energy);

}  // namespace skylit::study
