#pragma once
// Luminance parameters: the mean radiance S_i of every dome face, per colour channel, from a
// linear radiance frame and the sky table (paper 003, section 3.1, with the radiometric care it
// left as future work).
//
//     S_i = Σ_p w_p L_p / Σ_p w_p     over the sampled pixels p that see face i
//
// Bad pixels never propagate: NaN, ±Inf and negative values count as 0 and are counted. Faces
// the lens does not see (coverage under a threshold) are filled from their neighbours.
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "skylit/geom/dome.hpp"
#include "skylit/sky/sky_table.hpp"

namespace skylit::sky {

enum FaceFlag : std::uint32_t {
  kFaceUnseen = 1u << 0,      // coverage under the threshold: S filled from neighbouring faces
  kFaceClipped = 1u << 1,     // some of its pixels are clipped: S is a lower bound
  kFaceBadPixels = 1u << 2,   // NaN, Inf or negative pixels were counted as 0
  kFaceSunRemoved = 1u << 3,  // the sun's pixels were taken out (they go to the sun term)
};

struct FaceLuminance {
  Eigen::Vector3d rgb = Eigen::Vector3d::Zero();  // S_i, linear, R G B
  double coverage = 0;            // fraction of Ω_i the image sees (after exclusions)
  double clipped_fraction = 0;    // solid-angle fraction of the seen part that is clipped
  std::uint32_t flags = 0;
};

struct Luminance {
  std::vector<FaceLuminance> faces;
  std::int64_t samples = 0;           // table samples visited (excluded ones included)
  // Sampled, not excluded pixels with a NaN / ±Inf / negative (finite) channel: a pixel counts
  // once per kind. Clipped: set in `clipped` (and not excluded).
  std::int64_t nan_pixels = 0;
  std::int64_t inf_pixels = 0;
  std::int64_t negative_pixels = 0;
  std::int64_t clipped_pixels = 0;
  int unseen_faces = 0;
  bool no_face_seen = false;          // nothing to fill from: every S is 0
};

struct LuminanceOptions {
  double min_coverage = 0.05;         // below this a face counts as unseen and is filled
};

// `radiance`: CV_32FC3 BGR, the table's image size. `clipped` (CV_8U, 255 = clipped) and
// `exclude` (CV_8U, 255 = leave the pixel out, e.g. the sun's disc) may be empty; any non-zero
// value counts as set.
// InputError when sizes or types do not match the table.
Luminance compute_luminance(const SkyTable& table, const geom::Dome& dome, const cv::Mat& radiance,
                            const cv::Mat& clipped, const cv::Mat& exclude,
                            const LuminanceOptions& options = {});

}  // namespace skylit::sky
