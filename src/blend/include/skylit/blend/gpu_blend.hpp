#pragma once
// Shadow ratios on the GPU (OpenGL ES 3.1 compute, shaders/blend.comp): the same sums as
// blend_cpu (cpu_blend.hpp), over the plane's basis images held in one texture array, with two
// bounded savings (docs/live.md, "GPU blend").
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "skylit/gpu/gl.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/forms.hpp"

namespace skylit::blend {

// The texel format of the shadow-ratio texture.
enum class ShadowRatioFormat {
  Half,   // RGBA16F: filterable on every ES 3 driver (what a compositor samples); T rounded to
          // half (≤ 2^-11 off, one unit in the last place below 1)
  Float,  // RGBA32F: T exactly as summed (for checks; linear filtering needs OES_texture_float_linear)
};

// Two savings, both settings (docs/live.md, "GPU blend"), both bounded in units of T (T is the
// fraction of the plane's unoccluded irradiance D = Σ_k S_k A_k + E_sun c, so a bound of 0.01
// means one per cent of full light):
//
//   skip_threshold    layers whose largest possible contribution c_i = max_c |w_{i,c}| · max_x B_i(x)
//                     is smallest are left out while their c_i add up to at most this: the
//                     skipped layers change no texel's T by more than skip_threshold (with a
//                     faces basis, whose weights are >= 0, T only gets darker). 0: only layers
//                     that add nothing anywhere (c_i = 0). With packed layers a texture slice
//                     is read when any of its four layers is kept, and then all four are summed.
//                     Tiled: each (tile, layer) weight is a candidate with c = max|w| · max_x B
//                     (the layer's maximum over the whole plane), and a slice is read for every
//                     tile when any tile keeps any of its layers.
//                     Cropped (paged): each active layer is kept or skipped for the whole plane;
//                     a skipped layer is removed altogether (its pages' channel weighs 0 and its
//                     fill leaves the tiles' constants), so the bound holds exactly as stated
//                     (max_x B includes the fill); a page is read when any of its layers is kept.
//   change_threshold  a blend is skipped, the last T kept, while the weights differ from those
//                     of the last blend that ran by at most this much in T:
//                     Σ_i |Δw_{i,c}| max_x B_i(x) + Σ_k |Δw_k,c| ≤ change_threshold for every c
//                     (and the channels without light, the number of separated sources and their
//                     visibility are unchanged).
//                     0: skipped only when nothing changed.
struct GpuBlendOptions {
  BasisStorage storage = BasisStorage::Half;
  // Four layers per texel of the texture array (RGBA16F / RGBA8: one fetch brings four layers;
  // two for EAC: RG11), or one (R16F / R8 / R11). Same values either way; four is faster where fetches, not bytes, are the
  // limit (bench/RESULTS.md, "GPU blend"). A cropped basis packs the same way, per page.
  bool pack_layers = true;
  ShadowRatioFormat output = ShadowRatioFormat::Half;
  double skip_threshold = 0.0;    // T units, see above; >= 0
  double change_threshold = 0.0;  // T units, see above; >= 0
  std::filesystem::path shader_dir;  // empty: gpu::find_shader_dir's default search
};

// The visibility of the separated sources over a plane (SunShadowMap makes these): V_k in [0, 1]
// in the red channel of layer k of a GL_TEXTURE_2D_ARRAY of the plane's width × height, one layer
// per source (the sun first), texel (col, row) as the basis images, read with texelFetch (any
// format; a float one needs NEAREST filtering to be complete). The blender clamps V to [0, 1]
// (blend_cpu rejects values outside instead).
struct SunVisibilityTexture {
  GLuint texture = 0;
  int width = 0;
  int height = 0;
  std::uint64_t revision = 0;  // changes whenever the texture's content does
  int layers = 1;              // sources it holds V for: layer k is BlendWeights::sources[k]'s
};

// Separated terms the GPU blend sums at most (BlendWeights::sources; shaders/blend.comp).
inline constexpr int kMaxGpuSources = 32;

// A cropped basis (BasisImages::cropped(), the cropped form) stays cropped on the GPU, in pages
// of an atlas. The plane is cut into tiles of kGpuPageSize × kGpuPageSize texels (16; row-major,
// the last column and row of tiles narrower where the plane's size is not a multiple of 16).
// Each tile lists the stored layers whose rectangle overlaps it, ascending, in groups of as many
// layers as a texel holds (4 packed RGBA16F / RGBA8, 2 packed RG11 EAC, 1 unpacked): a page,
// 16 × 16 texels of the atlas whose channel c holds the group's c-th layer over the tile (B
// inside the layer's rectangle, its fill outside it and past the plane's edge; unused channels
// 0). The atlas is a texture array of pages in rows (as few texels per side as the page count
// allows, at most min(GL_MAX_TEXTURE_SIZE, 2048)). A texel sums its tile's constant Σ w_k fill_k
// over the summed layers whose rectangle misses the tile, plus w·B over the tile's pages read.
// A layer with an empty rectangle (the layer of ones) has no page at all: its fill is constant.
// gpu_basis_bytes says what the atlas takes without a GL context.
//
// Texels per side of a page of a cropped basis's atlas (and of the tiles it cuts the plane into).
inline constexpr int kGpuPageSize = 16;

// The bytes of basis texture a GpuBlender of `basis` with `options` allocates (basis_bytes()),
// computed without a GL context: the atlas of a cropped basis (assuming GL_MAX_TEXTURE_SIZE ≥
// 2048, which ES 3.0 guarantees, so that it agrees with basis_bytes() on every conforming
// driver), whole layers otherwise. For a basis the blender would refuse it returns what the
// sizes alone say (it checks nothing).
std::size_t gpu_basis_bytes(const BasisImages& basis, const GpuBlendOptions& options = {});

// The blend:
//
//   T(x) = Σ_{i active} w_i B_i(x) + Σ_k w_k V_k(x)   per colour channel, fp32, in layer order,
//   then a channel without light is 1 and T is clamped to [0, 1];
//
// k over the separated sources (BlendWeights::sources, the sun first; when that is empty, the
// sun alone, BlendWeights::sun), as blend_cpu_sources sums them, V_k from layer k of the
// visibility texture. A source whose weight is zero is not read.
//
// A tiled (clustered PCA) basis (BasisImages::tile) sums, at each texel, its tile's weights
// (weights.face[t · layers + i]) over one slice list shared by all tiles (see skip_threshold above).
//
// Every object here holds GL names: create, use and destroy it with the same GL context current
// (gpu::HeadlessContext or a window's), on one thread.
//
// This file and gpu_blend.cpp use only the C++ library, Eigen, OpenGL ES and header-only
// declarations (cpu_blend.hpp names nlohmann::json through the bake format), so that the GPU
// benchmark builds on a machine with nothing else (bench/gpu_standalone.sh).
//
// One shadowing plane: its basis images in a texture array, its shadow ratios in a texture.
class GpuBlender {
 public:
  // Uploads the basis (the context must be current). InputError for a malformed basis or a
  // negative threshold; std::runtime_error when the driver cannot hold it (too many layers for
  // GL_MAX_ARRAY_TEXTURE_LAYERS, a plane larger than GL_MAX_TEXTURE_SIZE).
  explicit GpuBlender(const BasisImages& basis, const GpuBlendOptions& options = {});

  // Blends with weights from blend_weights (or blend_weights_sources) for this basis, unless
  // change_threshold says the last result still holds; returns whether it ran. `sources` is
  // needed when a separated term is not zero, with a layer for each term (InputError otherwise,
  // as blend_cpu_sources; and for more than kMaxGpuSources terms); it may be null otherwise.
  bool blend(const BlendWeights& weights, const SunVisibilityTexture* sources = nullptr);

  // The next blend runs whatever its weights (e.g. after the caller rewrote its sun visibility
  // texture without changing the revision).
  void invalidate() { has_result_ = false; }

  // The shadow ratios: GL_TEXTURE_2D, RGBA, T in rgb, texel (col, row) as the basis. Sampling
  // it after a blend needs no barrier of the caller's (the blender issues it).
  GLuint shadow_ratio_texture() const { return output_.get(); }
  // T of every texel as blend_cpu writes it: width × height × 3 floats, RGB, row-major. Blocks
  // until the GPU is done (for tests and tools, not for the frame loop). Needs
  // GL_EXT_color_buffer_float (std::runtime_error without it).
  std::vector<float> read_back() const;

  int width() const { return width_; }
  int height() const { return height_; }
  int layers() const { return layers_; }
  // Array layers of the texture array: layers, or layers / 4 (/ 2 for EAC) rounded up, when
  // whole; the atlas's array layers (each of several pages) when paged.
  int slices() const { return slices_; }
  int tile_count() const { return tile_count_; }   // BasisImages::tile_count(): 1 when untiled (and when paged)
  bool paged() const { return paged_; }            // the basis is cropped: held in pages of an atlas
  int pages() const { return pages_; }             // pages of the atlas (0 when not paged)
  const GpuBlendOptions& options() const { return options_; }
  // max_x |B_i(x)| per layer (0 for a layer that is zero everywhere): the R8 scale and the bound
  // behind both thresholds.
  const std::vector<float>& layer_max() const { return layer_max_; }
  // Eac11: max_x |B_i(x) − B̂_i(x)| per layer, the decoded block against the half float, in units
  // of B (measured on upload with the decoder of eac.hpp); empty for other storages.
  const std::vector<float>& eac_error() const { return eac_error_; }
  // Bytes of the basis texture array as allocated (whole layers, or the paged atlas, unused page
  // slots included): what one blend reads at most. Equals gpu_basis_bytes(basis, options).
  std::size_t basis_bytes() const;

  // About the last blend that ran. A tiled basis counts per tile: summed_layers, skipped_layers
  // and skipped_bound are over (tile, layer) weights, i.e. over weights.face entries; summed_slices
  // is per texel (every tile reads the same slices). A paged basis: summed_layers counts the
  // layers kept (each summed wherever its rectangle or fill lies), summed_slices the page
  // entries read over all tiles of the plane (a tile's texels each read its entries).
  int summed_layers() const { return summed_layers_; }      // layers summed (packed: in the slices read)
  int summed_slices() const { return summed_slices_; }      // texture slices (paged: page entries) read
  int skipped_layers() const { return skipped_layers_; }    // active layers left out by skip_threshold
  double skipped_bound() const { return skipped_bound_; }   // Σ c_i of those (≤ skip_threshold)

 private:
  struct SliceList;
  void check_blend_input(const BlendWeights& weights, const std::vector<Eigen::Vector3f>& terms,
                         const SunVisibilityTexture* sources) const;
  bool unchanged_since_last(const BlendWeights& weights, const std::vector<Eigen::Vector3f>& terms,
                            const SunVisibilityTexture* sources) const;
  void choose_skipped(const BlendWeights& weights, std::vector<double>& contribution, std::vector<bool>& keep) const;
  SliceList paged_slices(const BlendWeights& weights, const std::vector<double>& contribution,
                         const std::vector<bool>& keep) const;
  SliceList layer_slices(const BlendWeights& weights, const std::vector<double>& contribution,
                         const std::vector<bool>& keep) const;
  void dispatch(const SliceList& list, const BlendWeights& weights, const std::vector<Eigen::Vector3f>& terms,
                const SunVisibilityTexture* sources);
  void upload_layers(const BasisImages& basis);  // whole layers, one or more per slice
  void upload_pages(const BasisImages& basis);   // a cropped basis, in pages of an atlas

  GpuBlendOptions options_;
  std::string name_;
  int width_ = 0;
  int height_ = 0;
  int layers_ = 0;
  int layers_per_slice_ = 1;
  int slices_ = 0;
  int tile_ = 0;         // BasisImages::tile (0: untiled)
  int tiles_x_ = 1;
  int tile_count_ = 1;
  int group_size_x_ = 8;
  int group_size_y_ = 8;
  std::vector<float> layer_max_;
  std::vector<float> eac_error_;
  // Paged (a cropped basis): tiles of kGpuPageSize texels; tile t's pages are page_begin_[t] …
  // page_begin_[t + 1] − 1; page p holds layers page_layers_[p · layers_per_slice_ + c] (−1:
  // none) at texel (page_origin_[p][1], [2]) of array layer page_origin_[p][0].
  bool paged_ = false;
  int pages_ = 0;
  int page_tiles_x_ = 1;
  int page_tiles_ = 1;
  int atlas_width_ = 0;
  int atlas_height_ = 0;
  std::vector<int> page_begin_;
  std::vector<int> page_layers_;
  std::vector<std::array<GLint, 3>> page_origin_;
  std::vector<float> fills_;  // LayerCrop::fill per layer
  gpu::Program program_;
  gpu::Texture basis_;
  gpu::Texture output_;
  gpu::Buffer weight_buffer_;
  gpu::Buffer tile_buffer_;  // per-tile constants and page ranges (paged; one unused record otherwise)
  GLint slice_count_location_ = -1;
  GLint paged_location_ = -1;
  GLint source_term_location_ = -1;
  GLint source_count_location_ = -1;
  GLint no_light_location_ = -1;
  GLint tile_size_location_ = -1;
  GLint tiles_x_location_ = -1;

  // The weights and inputs of the last blend that ran (for change_threshold).
  bool has_result_ = false;
  std::vector<Eigen::Vector3f> last_face_;
  std::vector<Eigen::Vector3f> last_sources_;  // the separated terms (separated_terms)
  std::array<bool, 3> last_no_light_{false, false, false};
  GLuint last_sun_texture_ = 0;
  std::uint64_t last_sun_revision_ = 0;

  int summed_layers_ = 0;
  int summed_slices_ = 0;
  int skipped_layers_ = 0;
  double skipped_bound_ = 0.0;
};

}  // namespace skylit::blend
