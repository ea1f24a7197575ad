#pragma once
// Shadow ratios on the CPU: the reference that every GPU blend is tested against, and the
// fallback for machines without a GPU (paper 003, section 3.3, plus an exact sun term).
//
//   T_j(x) = (Σ_i S_i B_{j,i}(x) + E_sun V(x, ω_sun) c) / (Σ_i S_i A_{j,i} + E_sun c),
//   c = max(0, n·ω_sun),  per colour channel.
//
// With several separated sources (the sun and compact lamps, sky/sky_estimate.hpp max_sources)
// the sun term becomes Σ_k E_k c_k V_k in the numerator and Σ_k E_k c_k in the denominator
// (blend_weights_sources, blend_cpu_sources, blend_reference_sources); one source gives the
// same T as the single-sun functions, bit for bit. The GPU blend (gpu_blend.hpp) and the live
// service take one separated term: the first source.
//
// The weights w_i = S_i / D and w_sun = E_sun c / D (D the denominator) are computed once per
// sky (blend_weights); the blend is then one weighted sum over the plane's basis layers, read
// once each from half floats and accumulated in float. T is always finite and in [0, 1]: when a
// channel's denominator is too small to mean anything (a night sky, a plane that faces away from
// every lit face) that channel is 1 and flagged, and values a hair outside [0, 1] from half-float
// rounding of B ≤ A are clamped and measured.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/bake/format.hpp"

namespace skylit::render {

using geom::Vec3;

class BlendWorkers;

// A stored layer cropped to the rectangle of texels where it differs from a constant: inside,
// its values row by row at half[offset …] (cols × rows of them); outside, `fill` (BasisForm::Cropped).
struct LayerCrop {
  int col = 0, row = 0, cols = 0, rows = 0;
  std::size_t offset = 0;
  float fill = 0.0f;
  bool contains(int c, int r) const { return c >= col && c < col + cols && r >= row && r < row + rows; }
};

// The basis images of one plane, as the bake stores them: layer-major IEEE half floats,
// half[(layer * height + row) * width + col] = B_{j,i} (steradians); or, cropped, each layer's
// rectangle after the one before (`crops`).
struct BasisImages {
  std::string name;
  int width = 0;
  int height = 0;
  int layers = 0;
  std::vector<std::uint16_t> half;
  std::vector<double> unoccluded;      // A_{j,i}, one per layer
  Vec3 normal = Vec3::UnitZ();
  // 1: one layer per dome face (faces basis); 3: layer 3i+k per face i and corner k (corners
  // basis), whose S may be negative (a linear fit across the face).
  int layers_per_face = 1;
  // The PCA form (bake/pca.hpp): the stored layers are the mean visible fraction and K
  // eigen-images (values of either sign), and `projection` (n source layers × `layers`) maps the
  // weights of the full basis onto them: u = projectionᵀ w, with row l = A_l · (1, P_{l,1..K}).
  // The lean form (BasisForm::Lean) uses the same: its shadowed layers map one to one and the
  // unshadowed ones onto a layer of ones with A_l. Empty (0 rows) for the full form, whose layers
  // are the basis itself. `unoccluded` has n values either way.
  Eigen::MatrixXf projection;
  // Clustered PCA (bake/pca.hpp, PcaOptions::tile): the plane is cut into tiles of tile × tile
  // texels, row-major from texel (0, 0) (the last column and row of tiles may be narrower), and
  // each tile has its own mean and eigen-images, stored in its region of the `layers` images,
  // and its own projection: columns t·layers … (t+1)·layers − 1 of `projection` map the weights
  // onto tile t's layers. 0: one tile, the whole plane (every other form).
  int tile = 0;
  int tiles_x() const { return tile > 0 ? (width + tile - 1) / tile : 1; }
  int tiles_y() const { return tile > 0 ? (height + tile - 1) / tile : 1; }
  int tile_count() const { return tiles_x() * tiles_y(); }
  // The tile that texel (col, row) belongs to.
  int tile_of(int col, int row) const { return tile > 0 ? (row / tile) * tiles_x() + col / tile : 0; }
  bool compressed() const { return projection.rows() > 0; }
  // The cropped form (BasisForm::Cropped): one entry per stored layer; `half` holds only their
  // rectangles. Empty: every layer whole, texel_count() values each.
  std::vector<LayerCrop> crops;
  bool cropped() const { return !crops.empty(); }
  // Stored layer k at texel (col, row), as a float, whichever way it is stored.
  float value(int layer, int col, int row) const;
  // n: the layers S and A are given for (the dome's), whichever form is stored.
  int source_layers() const { return compressed() ? static_cast<int>(projection.rows()) : layers; }
  std::size_t texel_count() const { return static_cast<std::size_t>(width) * height; }
};

// Which form of a plane's basis to read:
//   Full  every layer as baked;
//   Lean  the layers that hold a shadow (bake/footprint.hpp), plus one layer of ones that carries
//         the unshadowed layers' constant light; layers the plane cannot see are left out. T
//         changes by at most 1e-3 (the footprint's tolerance), the blend reads fewer layers;
//   Pca   its principal components (stored when the bake was made or compressed with --pca-*;
//         InputError otherwise);
//   Cropped  the lean form with each shadowed layer cropped to the rectangle it shadows (outside
//         it B = A, its `fill`), the layer of ones to nothing: the CPU blend reads only the
//         rectangles (bake/footprint.hpp: at ν = 8 the sample site's ground keeps 43% of its
//         shadowed layers' texels). Outside its rectangle a layer's B is within the footprint's
//         tolerance of A, so T is within 10⁻³ of the full form's, as Lean's.
enum class BasisForm { Full, Lean, Pca, Cropped };

// Reads plane `plane` (an index into manifest.planes) of a verified bake, in the form asked for.
BasisImages load_basis(const std::filesystem::path& bake_dir, const bake::Manifest& manifest, int plane,
                       BasisForm form = BasisForm::Full);

// A cropped basis with every layer whole again (the fill outside its rectangle), for consumers
// that read whole layers; any other basis as it is.
BasisImages uncropped(const BasisImages& basis);

// InputError unless the stored values are what the header says: sizes not negative, and
// `half` holding every whole layer, or (cropped) one rectangle per layer inside the plane, back
// to back, with finite fills. Both blends check this before any loop trusts the sizes.
void check_basis_storage(const BasisImages& basis);

struct SunLight {
  Vec3 direction = Vec3::UnitZ();                    // unit, site frame, towards the sun
  Eigen::Vector3d energy = Eigen::Vector3d::Zero();  // E_sun, RGB: irradiance facing the sun
};

struct BlendOptions {
  // A channel whose denominator Σ S_i A_i + E_sun c is at or under this is "no light": T = 1.
  double min_denominator = 1e-12;
  int threads = 0;                     // 0 = all hardware threads
  // Threads kept between calls (blend_workers.hpp); when set, `threads` is ignored. Without it
  // each call starts and joins its own threads.
  BlendWorkers* workers = nullptr;
  // false: the portable kernel even on a CPU with AVX2/F16C/FMA (tests compare both; benchmarks
  // time both). The two agree within float rounding; each is bit-identical for any `threads`.
  bool use_simd = true;
};

struct BlendWeights {
  // w_i per stored layer (RGB); zero for skipped faces. For a PCA basis these are the weights of
  // its mean and eigen-images (either sign). A tiled basis (BasisImages::tile) has a set per
  // tile: face[t · layers + k] weighs stored layer k within tile t (tile_count() · layers in all).
  std::vector<Eigen::Vector3f> face;
  std::vector<int> active;             // indices into `face` with a non-zero weight, ascending
  Eigen::Vector3f sun = Eigen::Vector3f::Zero();   // w_sun (RGB), zero without a sun term
  // w_k (RGB) of every separated source, in the order given (sources[0] == sun); one entry or
  // none from blend_weights. blend_cpu reads `sun` only (and refuses more than one source here);
  // blend_cpu_sources reads this (or `sun` when it is empty).
  std::vector<Eigen::Vector3f> sources;
  Eigen::Vector3d denominator = Eigen::Vector3d::Zero();
  std::array<bool, 3> no_light{false, false, false};  // per channel: T = 1
};

// S: one RGB value per source layer (faces without light may be zero). InputError when S has the
// wrong size or holds a non-finite value, or a negative one in a faces basis (corner
// coefficients may be negative: T stays in [0, 1] by the clamp, and a channel whose
// denominator is not above min_denominator is no light).
BlendWeights blend_weights(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                           const std::optional<SunLight>& sun, const BlendOptions& options = {});

// The same for several separated sources: w_k = E_k max(0, n·ω_k) / D for each, D including
// every source. InputError as blend_weights, naming the source ("sources[k].energy").
BlendWeights blend_weights_sources(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                                   std::span<const SunLight> sources, const BlendOptions& options = {});

struct BlendStats {
  float max_above_one = 0;             // largest T - 1 before clamping (0 when none)
  float max_below_zero = 0;            // largest -T before clamping (0 when none)
  std::int64_t clamped = 0;            // values clamped
};

// out: width × height × 3 floats, RGB interleaved, row-major texels (the plane's convention).
// sun_visibility: V per texel in [0, 1] (empty: no sun term, or the sun is fully visible when
// weights.sun is non-zero and visibility is empty -> InputError).
BlendStats blend_cpu(const BasisImages& basis, const BlendWeights& weights,
                     std::span<const float> sun_visibility, std::span<float> out,
                     const BlendOptions& options = {});

// Several separated sources: source_visibility[k] is V_k per texel in [0, 1] for weights.sources[k]
// (an empty span is allowed for a source of zero weight). InputError when the count differs from
// weights.sources (or from one, when only weights.sun is set), or a V is missing or out of range.
BlendStats blend_cpu_sources(const BasisImages& basis, const BlendWeights& weights,
                             std::span<const std::span<const float>> source_visibility, std::span<float> out,
                             const BlendOptions& options = {});

// The same in double precision, one thread, no shortcuts: the reference the fast path is
// tested against.
void blend_reference(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                     const std::optional<SunLight>& sun, std::span<const float> sun_visibility,
                     std::span<double> out, const BlendOptions& options = {});

void blend_reference_sources(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                             std::span<const SunLight> sources,
                             std::span<const std::span<const float>> source_visibility, std::span<double> out,
                             const BlendOptions& options = {});

float half_to_float(std::uint16_t h);
std::uint16_t float_to_half(float f);   // round to nearest even

// Bulk half_to_float with F16C where the CPU has it: equal to the scalar function for every
// value but signalling NaNs (F16C quiets them). in and out must have the same size.
void halves_to_floats(std::span<const std::uint16_t> in, std::span<float> out);

// True when blend_cpu with use_simd runs the AVX2/F16C/FMA kernel on this CPU.
bool blend_simd_available();

}  // namespace skylit::render
