#pragma once
// The forms a plane's basis is read in (full, lean, PCA, cropped) and stored in on the GPU (half,
// 8-bit, EAC): the one set of names that configs, presets, the trade table and the blends share.
#include <optional>
#include <string_view>

namespace skylit::blend {

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

// How the basis images are stored on the GPU.
enum class BasisStorage {
  Half,    // 16-bit float: the baked half floats as they are (exact; 2 bytes per texel and layer)
  Unorm8,  // 8-bit: each layer scaled by its maximum, B ≈ max_i · q/255 (1 byte; T error ≤ Σ_i c_i / 510)
  // EAC R11 blocks (eac.hpp; core in ES 3.0): each layer scaled by its maximum and compressed in
  // 4×4 blocks on upload, B ≈ max_i · e (half a byte; the block error is data-dependent: the
  // blender measures it, eac_error(), and T is off by at most Σ_i |w_i| max_i eac_error_i).
  // Packed: two layers per texel (RG11 EAC).
  Eac11,
};

// The names configs and presets use: "full", "lean", "pca", "cropped"; "half", "unorm8", "eac".
std::string_view form_name(BasisForm form);
std::optional<BasisForm> parse_form(std::string_view name);
std::string_view storage_name(BasisStorage storage);
std::optional<BasisStorage> parse_storage(std::string_view name);

// Every name, in enum order (for "use one of" messages and YAML choices).
inline constexpr std::string_view kFormNames[] = {"full", "lean", "pca", "cropped"};
inline constexpr std::string_view kStorageNames[] = {"half", "unorm8", "eac"};

}  // namespace skylit::blend
