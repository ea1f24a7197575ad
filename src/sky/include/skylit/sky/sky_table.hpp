#pragma once
// The dome-to-pixel table of a sky camera: built once per calibration and dome, it says for
// every (sub-sampled) pixel which dome face it sees and with what solid angle.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core/mat.hpp>

#include <Eigen/Core>

#include "skylit/geom/dome.hpp"
#include "skylit/geom/dome_basis.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// Pixels are stored as runs of consecutive sampled pixels on one image row that see the same
// face, so that luminance parameters are a streaming pass over the frame (the hot loop of the
// sky thread). With step s only every s-th pixel of every s-th row is sampled, and each sample
// carries the solid angle of its s×s block: Σ w still covers the image's view of each face.
struct PixelRun {
  std::int32_t row = 0;         // image row
  std::int32_t col_begin = 0;   // first column
  std::int32_t count = 0;       // samples: columns col_begin, col_begin + step, ...
  std::int32_t face = 0;        // dome face
  std::uint32_t weight_offset = 0;  // into SkyTable::weights
};

struct SkyTable {
  int image_width = 0;
  int image_height = 0;
  int step = 1;
  std::vector<PixelRun> runs;          // row-major order
  std::vector<float> weights;          // steradians per sample, run by run
  std::vector<double> face_solid_angle;  // Σ w per face (what the image sees of it)
  std::vector<double> coverage;        // face_solid_angle / Ω_i, in [0, 1] (up to rounding)
  std::size_t sample_count() const { return weights.size(); }

  // ---- the corners and quadratics bases only (empty for faces) ----
  geom::DomeBasis basis = geom::DomeBasis::Faces;
  // With the corners or quadratics basis (geom/dome_basis.hpp) every sample also carries its
  // barycentric coordinates in its face (λ0, λ1 as 16-bit fractions; λ2 = 1 − λ0 − λ1), and the
  // table holds per face the mass matrix of the basis' functions φ over its own samples,
  // M = Σ_p w_p φ_p φ_pᵀ (3×3 for corners, 6×6 for quadratics), from those same stored
  // coordinates, inverted once here: the luminance pass then fits the face's functions by least
  // squares with one small product per face.
  //
  // λ0, λ1 per sample in units of 1/65535 (kCornerWeightUnit), run by run (2 × weights.size()):
  // 4 bytes a sample instead of 8, which the streaming pass feels; the rounding (≤ 7.6e-6) is
  // the same in the pass and in M, so the fit stays consistent.
  std::vector<std::uint16_t> corner_weights;
  std::vector<Eigen::MatrixXd> corner_mass;     // per face: Σ_p w_p φ_p φ_pᵀ over its samples
  std::vector<Eigen::MatrixXd> corner_inverse;  // its inverse (zero when singular)
  // ∫ φ φᵀ dω over the whole face: the mass matrix a camera that sees all of it would have.
  std::vector<Eigen::MatrixXd> corner_full_mass;
  // Smallest eigenvalue of corner_mass over that of corner_full_mass: 1 for a face the image
  // sees whole, → 0 for one seen on a sliver (the fit then extrapolates; see LuminanceOptions).
  std::vector<double> corner_conditioning;
};

inline constexpr double kCornerWeightUnit = 1.0 / 65535.0;

struct SkyTableOptions {
  int step = 1;                        // sample every step-th pixel and row (1 = every pixel)
  geom::DomeBasis basis = geom::DomeBasis::Faces;  // corners, quadratics: barycentric weights and mass matrices
};

// λ_min(m) / λ_min(full): how well the samples behind `m` pin down a face's functions (see
// SkyTable::corner_conditioning). 0 when m is singular or not positive definite.
double corner_conditioning(const Eigen::MatrixXd& m, const Eigen::MatrixXd& full);

// Pixels whose direction lies below the horizon, outside the lens model's range, or where the
// mask (CV_8U, image size, 0 = hidden) is 0 are left out. `mask` may be empty; when it is empty
// and calibration.mask names a file, that file is read (InputError if unreadable or of another
// size, naming the calibration file and the field).
//
// Sampling (OpenCV's convention: pixel centres at integers, pixel (x, y) spans [x±½] × [y±½]):
// along each axis the samples are the pixels b·s + ⌊s/2⌋ (b = 0, 1, …, while inside the image),
// and a sample's block reaches halfway to its neighbours, so that the sample sits at its block's
// centre (for even s the block edges run through pixel centres); the first and the last block
// of a row or column reach out to the image's edge (−½ and size − ½). A sample is kept when its
// pixel centre unprojects (within the lens model's range), looks at or above the horizon and is
// not masked, and all four block corners unproject; its face is the one its pixel centre sees
// (so a frame painted by face reads back exactly) and its weight is block_solid_angle of its
// block. A block on a face edge goes wholly to one face, which is why coverage per face is
// exact only to about the block's size.
SkyTable build_sky_table(const camera::Lens& lens, const geom::Dome& dome, const cv::Mat& mask,
                         const SkyTableOptions& options);
SkyTable build_sky_table(const camera::Lens& lens, const geom::Dome& dome,
                         const SkyTableOptions& options = {});

// Solid angle (sr) of the pixel block [x0, x1] × [y0, y1] (pixel-edge coordinates), from the
// unprojected corners (two spherical triangles). 0 when a corner cannot be unprojected.
double block_solid_angle(const camera::Lens& lens, double x0, double y0, double x1, double y1);

}  // namespace skylit::sky
