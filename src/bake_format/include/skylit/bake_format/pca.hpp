#pragma once
// A plane's basis images compressed by principal components of their visible fractions, so that
// the blend reads K + 1 layers instead of n (docs/bake-format.md, "The PCA form").
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/manifest.hpp"

namespace skylit::bake_format {

// Every basis image is B_l = A_l · F_l, F_l the visible fraction of layer l's light at each
// texel, in [0, 1]. The blend (blend/cpu_blend.hpp) sums T = Σ_l w_l B_l = Σ_l α_l F_l with
// α_l = w_l A_l, and Σ_l α_l ≤ 1 for a faces basis (the denominator holds Σ_l S_l A_l). So the
// components are taken of the fractions F_l, each with equal standing:
//
//   F_l ≈ μ + Σ_k P_{l,k} E_k        μ the mean fraction image, E_k the eigen-images
//   T   ≈ (Σ_l α_l) μ + Σ_k (Σ_l α_l P_{l,k}) E_k
//
// and the blend reads K + 1 layers instead of n. The error of T is then at most
// max_{l,x} |F_l(x) − F̂_l(x)| (`max_error`) for every faces-basis sky, with or without a sun, and
// at most that times Σ_l |α_l| for corners. Layers with A_l = 0 (faces the plane cannot see)
// carry no light and are left out of the components.
//
// K is the smallest count that meets every criterion given (at least one is required), and at
// most the number of layers with light.
struct PcaOptions {
  std::optional<int> components;      // at least this many, ≥ 1
  std::optional<double> variance;     // fraction of the fractions' variance kept, in (0, 1]
  std::optional<double> max_error;    // bound on |T − T_full|, > 0 (see above)
  // The components that matter for skies rather than for single faces: each image's error is
  // weighed by how skies weigh the layers, α_l ∝ A_l L(ω_l), with the radiance L of two layers
  // correlated as exp(−θ²/2σ²) over the angle θ between their directions (σ this, degrees).
  // 0: every layer alike (plain PCA of the fractions). Needs the layers' directions.
  double sky_correlation_deg = 0.0;
  // Clustered PCA: the plane cut into tiles of tile × tile texels (row-major from texel (0, 0);
  // the last column and row of tiles may be narrower), each compressed on its own. A shadow
  // touches few tiles, so a tile's fractions need far fewer components than the whole plane's.
  // Every tile gets the same K (the largest any tile needs for the criteria above, so that the
  // blend reads K + 1 layers everywhere); its mean and eigen-images fill its region of the K + 1
  // images. 0: the whole plane, one set of components.
  int tile = 0;
};

// std::invalid_argument naming the field for an option out of range or none given.
void check_pca_options(const PcaOptions& options);

struct PcaBasis {
  int width = 0;
  int height = 0;
  int source_layers = 0;              // n: the layers of the full basis
  int components = 0;                 // K
  int tile = 0;                       // PcaOptions::tile (0: untiled)
  // K + 1 images, layer-major as ImageStack: the mean fraction μ, then E_1 … E_K, each scaled
  // so that its largest |value| is 1 (half floats keep their precision); tiled, each tile's own
  // in its region.
  ImageStack images;
  // P_{l,k}: source_layers × components, row-major; zero rows for layers without light. Tiled:
  // tiles × source_layers × components, P_{t,l,k} at (t · source_layers + l) · components + k.
  std::vector<float> coefficients;
  // Measured on the stored form (images rounded to half floats, as the blend reads them) against
  // the full basis rounded the same way: |F_l(x) − F̂_l(x)| over layers with light and texels.
  double max_error = 0.0;
  double rms_error = 0.0;
  double variance_kept = 1.0;         // fraction of the total variance of the F_l
  std::vector<double> eigenvalues;    // of the fractions' covariance, descending (for reports;
                                      // tiled: summed over the tiles, rank by rank)
  int tiles_x() const { return tile > 0 ? (width + tile - 1) / tile : 1; }
  int tiles_y() const { return tile > 0 ? (height + tile - 1) / tile : 1; }
  int tile_count() const { return tiles_x() * tiles_y(); }
};

// The components of `stack` (the full basis, B in steradians) with A per layer `unoccluded`.
// std::invalid_argument for sizes that disagree or bad options.
// `directions`: per layer, unit, its face's centre (needed only with sky_correlation_deg > 0).
PcaBasis compress_pca(const ImageStack& stack, std::span<const double> unoccluded, const PcaOptions& options,
                      std::span<const Vec3> directions = {});

// C^{1/2} of the sky prior's second moments C_rc = w_r w_c exp(−θ_rc²/2σ²) over the layers'
// directions (w empty: 1), scaled to a norm near the identity's: the weighting both PCA forms
// (the planes' and the light map's) fit in.
Eigen::MatrixXd sky_prior_root(std::span<const Vec3> directions, std::span<const double> weights, double sigma_deg);

// Names of the PCA form's layers: "mean", "pc_001", …
std::vector<std::string> pca_layer_names(int components);

}  // namespace skylit::bake_format
