#pragma once
// Luminance parameters: the mean radiance S_i of every dome face, per colour channel, from a
// linear radiance frame and the sky table (paper 003, section 3.1, with the radiometric care it
// left as future work).
#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "skylit/geom/dome.hpp"
#include "skylit/sky/sky_table.hpp"

namespace skylit::sky {

// Bad pixels never propagate: NaN, ±Inf and negative values count as 0 and are counted. Faces
// the lens does not see (coverage under a threshold) are filled from their neighbours.
enum FaceFlag : std::uint32_t {
  kFaceUnseen = 1u << 0,      // coverage under the threshold: S filled from neighbouring faces
  kFaceClipped = 1u << 1,     // some of its pixels are clipped: S is a lower bound
  kFaceBadPixels = 1u << 2,   // NaN, Inf or negative pixels were counted as 0
  kFaceSunRemoved = 1u << 3,  // the sun's pixels were taken out (they go to the sun term)
  // Corners basis: the pixels do not pin down three corners (a face seen on a sliver, or the
  // sun's exclusion took most of it): all three corners carry the face's mean S_i.
  kFaceCornersFromMean = 1u << 4,
  // Quadratics basis: the pixels pin down a linear fit but not a quadratic one: the face carries
  // the linear fit.
  kFaceFitLinear = 1u << 5,
};

// The luminance parameter of face i, per colour channel:
//
//     S_i = Σ_p w_p L_p / Σ_p w_p     over the sampled pixels p that see face i
//
// With a corners table (SkyTable::basis) each face also gets three corner coefficients, the
// least-squares fit of the linear hats to its pixels (the local L2 projection):
//
//     [S_{i,0} S_{i,1} S_{i,2}]ᵀ = M_i⁻¹ Σ_p w_p λ_p L_p,     M_i = Σ_p w_p λ_p λ_pᵀ
//
// over the same pixels as S_i. Corner coefficients may be negative (a linear fit to a sky that
// is not linear across the face); the blend keeps T in [0, 1]. A quadratics table fits the six
// quadratic Bernstein functions φ the same way (M_i = Σ_p w_p φ_p φ_pᵀ, 6×6); a face whose
// pixels cannot pin six functions down but can pin three gets the linear fit, written in the
// quadratic functions (geom::corner_to_quadratic), and kFaceFitLinear.
struct FaceLuminance {
  Eigen::Vector3d rgb = Eigen::Vector3d::Zero();  // S_i, linear, R G B: the face's mean
  // Corners and quadratics bases: the coefficient S_{i,k} of each of the face's functions, R G B
  // (corners: at the face's vertex k, DomeFace::vertex[k]; quadratics: geom::layer_values'
  // order). Unseen and kFaceCornersFromMean faces have rgb in all. Empty for the faces basis.
  std::vector<Eigen::Vector3d> coefficients;
  double coverage = 0;            // fraction of Ω_i the image sees (after exclusions)
  double clipped_fraction = 0;    // solid-angle fraction of the seen part that is clipped
  std::uint32_t flags = 0;
};

struct Luminance {
  geom::DomeBasis basis = geom::DomeBasis::Faces;  // the table's
  std::vector<FaceLuminance> faces;
  std::int64_t samples = 0;           // table samples visited (excluded ones included)
  // Sampled, not excluded pixels with a NaN / ±Inf / negative (finite) channel: a pixel counts
  // once per kind. Clipped: set in `clipped` (and not excluded).
  std::int64_t nan_pixels = 0;
  std::int64_t inf_pixels = 0;
  std::int64_t negative_pixels = 0;
  std::int64_t clipped_pixels = 0;
  int unseen_faces = 0;
  int corners_from_mean = 0;          // seen faces flagged kFaceCornersFromMean
  int linear_fits = 0;                // seen faces flagged kFaceFitLinear
  bool no_face_seen = false;          // nothing to fill from: every S is 0
};

struct LuminanceOptions {
  double min_coverage = 0.05;         // below this a face counts as unseen and is filled
  // Corners and quadratics bases: the fit is used when the seen pixels' mass matrix keeps at
  // least this share of a fully seen face's smallest eigenvalue (SkyTable::corner_conditioning);
  // below it the fit would extrapolate into what the camera does not see, and the face's mean
  // (or, for quadratics, the linear fit if that one passes) is used.
  double min_corner_conditioning = 0.25;
  // Corners basis: the eight-lane AVX2/FMA pass where the CPU has it (false: the portable
  // four-lane pass everywhere, e.g. to compare the two). Both agree to float rounding.
  bool use_simd = true;
};

// What the blend takes: one RGB value per layer of a bake with luminance.basis, S_i (faces) or
// S_{i,k} at layer 3i + k (corners) or 6i + k (quadratics).
std::vector<Eigen::Vector3d> layer_radiances(const Luminance& luminance);

// `radiance`: CV_32FC3 BGR, the table's image size. `clipped` (CV_8U, 255 = clipped) and
// `exclude` (CV_8U, 255 = leave the pixel out, e.g. the sun's disc) may be empty; any non-zero
// value counts as set.
// InputError when sizes or types do not match the table.
Luminance compute_luminance(const SkyTable& table, const geom::Dome& dome, const cv::Mat& radiance,
                            const cv::Mat& clipped, const cv::Mat& exclude,
                            const LuminanceOptions& options = {});

}  // namespace skylit::sky
