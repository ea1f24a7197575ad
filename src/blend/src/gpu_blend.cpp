// The GPU blend: basis upload (whole layers, or a cropped basis in pages of an atlas), the two
// savings, the dispatch of shaders/blend.comp (see gpu_blend.hpp). Only the C++ library, Eigen and OpenGL ES here (bench/gpu_standalone.sh).
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/blend/half.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <span>
#include <stdexcept>
#include <string>

#include "skylit/base/error.hpp"
#include "skylit/gpu/shader.hpp"
#include "skylit/blend/eac.hpp"

namespace skylit::blend {
namespace {

constexpr const char* kShaderFile = "blend.comp";
constexpr int kPackedLayers = 4;  // layers per texel of a packed array: R, G, B, A
constexpr int kPackedEacLayers = 2;  // RG11 EAC: R, G

[[noreturn]] void refuse_gpu_input(const std::string& field, const std::string& problem, const std::string& fix) {
  throw InputError(input_message({}, -1, -1, field, problem, fix));
}

void check_gpu_basis(const BasisImages& basis) {
  const std::string field = "basis '" + basis.name + "'";
  if (basis.width <= 0 || basis.height <= 0 || basis.layers < 0) {
    refuse_gpu_input(field, "size " + std::to_string(basis.width) + "x" + std::to_string(basis.height) + "x" +
                         std::to_string(basis.layers) + " has no texels",
              "load the basis with load_basis");
  }
  check_basis_storage(basis);
  if (basis.tile < 0) {
    refuse_gpu_input(field + ".tile", std::to_string(basis.tile) + " is negative", "load the basis with load_basis");
  }
}

// max |B| over a layer's values, and whether any is negative (NaN ignored).
struct LayerExtent {
  float top = 0.0f;
  bool negative = false;
};
LayerExtent extent_of(std::span<const float> values) {
  LayerExtent e;
  for (const float b : values) {
    e.top = std::abs(b) > e.top ? std::abs(b) : e.top;  // NaN compares false: ignored
    e.negative |= b < 0.0f;
  }
  return e;
}

// InputError when layer `layer` of plane `plane` cannot be stored as `storage`: a PCA basis has
// eigen-images of either sign, which 8-bit and EAC layers cannot hold; an infinite value none can.
void check_storable(const std::string& plane, std::size_t layer, const LayerExtent& e, BasisStorage storage) {
  const std::string field = "basis '" + plane + "' layer " + std::to_string(layer);
  const bool eac = storage == BasisStorage::Eac11;
  if (storage != BasisStorage::Half && e.negative) {
    refuse_gpu_input(field,
              std::string("holds negative values (a PCA basis), which ") + (eac ? "EAC" : "8-bit") +
                  " layers cannot store",
              "store the basis as half floats (blend.storage: half) or read the full form");
  }
  if (!std::isfinite(e.top)) refuse_gpu_input(field, "holds an infinite value", "re-bake the plane");
}

// The basis texture array's formats for a storage and layout.
struct ArrayFormat {
  GLenum internal_format;
  GLenum format;  // of uncompressed uploads
  GLenum type;    // of uncompressed uploads
  bool compressed;
};
ArrayFormat array_format(const GpuBlendOptions& options) {
  const bool packed = options.pack_layers;
  switch (options.storage) {
    case BasisStorage::Eac11:
      return {packed ? GLenum(GL_COMPRESSED_RG11_EAC) : GLenum(GL_COMPRESSED_R11_EAC), GL_NONE, GL_NONE, true};
    case BasisStorage::Unorm8:
      return {packed ? GLenum(GL_RGBA8) : GLenum(GL_R8), packed ? GLenum(GL_RGBA) : GLenum(GL_RED), GL_UNSIGNED_BYTE, false};
    case BasisStorage::Half:
      break;
  }
  return {packed ? GLenum(GL_RGBA16F) : GLenum(GL_R16F), packed ? GLenum(GL_RGBA) : GLenum(GL_RED), GL_HALF_FLOAT, false};
}

// Storage for the bound texture array: `slices` slices of width × height, read texel by texel.
void allocate_array(const ArrayFormat& f, int width, int height, int slices) {
  glTexStorage3D(GL_TEXTURE_2D_ARRAY, 1, f.internal_format, width, height, slices);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
}

// One whole slice of the bound texture array: EAC blocks, 8-bit values or halves, as `f` says.
void upload_slice(const ArrayFormat& f, int slice, int width, int height, const std::vector<std::uint8_t>& blocks,
                  const std::vector<std::uint8_t>& bytes, const std::vector<std::uint16_t>& halves) {
  if (f.compressed) {
    glCompressedTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, slice, width, height, 1, f.internal_format,
                              static_cast<GLsizei>(blocks.size()), blocks.data());
  } else {
    glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, slice, width, height, 1, f.format, f.type,
                    f.type == GL_UNSIGNED_BYTE ? static_cast<const void*>(bytes.data())
                                               : static_cast<const void*>(halves.data()));
  }
}

void check_threshold(double value, const std::string& field) {
  if (!std::isfinite(value) || value < 0.0) {
    refuse_gpu_input(field, "value " + std::to_string(value) + " is not finite and >= 0",
              "use 0 (exact) or a small fraction of full light such as 0.002");
  }
}

// The compute program; a float shadow-ratio texture needs the image format changed, which the
// shader takes from a macro defined here (the #line keeps the driver's line numbers the file's).
gpu::Program load_blend_program(const GpuBlendOptions& options) {
  const std::filesystem::path dir = gpu::find_shader_dir(options.shader_dir);
  const std::filesystem::path path = dir / kShaderFile;
  std::string text = gpu::read_shader(dir, kShaderFile);
  if (options.output == ShadowRatioFormat::Float) {
    const std::size_t version_end = text.find('\n');
    if (version_end == std::string::npos) {
      throw InputError(input_message(path, 1, -1, "#version", "the file has a single line",
                                     "use skylit's shaders/blend.comp"));
    }
    text.insert(version_end + 1, "#define SKYLIT_T_FORMAT rgba32f\n#line 2\n");
  }
  const gpu::ShaderSource source{GL_COMPUTE_SHADER, path.string(), text};
  return gpu::link_program(std::span<const gpu::ShaderSource>(&source, 1));
}

GLint uniform_location(GLuint program, const char* name) {
  const GLint location = glGetUniformLocation(program, name);
  if (location < 0) {
    throw gpu::GlError(std::string("GPU blend: ") + kShaderFile + " has no uniform '" + name +
                       "' (shader files from another version of skylit?)");
  }
  return location;
}

// std430 layout of blend.comp's Slice.
struct SliceWeights {
  std::array<float, 4> red;
  std::array<float, 4> green;
  std::array<float, 4> blue;
  std::array<GLint, 4> index;
};
static_assert(sizeof(SliceWeights) == 64);

// std430 layout of blend.comp's TileRange (paged): the tile's constant and its entries of Slices.
struct TileRecord {
  std::array<float, 4> constant;
  std::array<GLint, 4> range;  // first entry, entry count
};
static_assert(sizeof(TileRecord) == 32);

constexpr int kPage = kGpuPageSize;
constexpr int kAtlasSideCap = 2048;  // texels per side of the atlas at most (ES 3.0's least GL_MAX_TEXTURE_SIZE)
static_assert(kPage % 4 == 0, "EAC blocks must tile a page");

int layers_per_texel(const GpuBlendOptions& options) {
  if (!options.pack_layers) return 1;
  return options.storage == BasisStorage::Eac11 ? kPackedEacLayers : kPackedLayers;
}

// Bytes of `array_layers` array layers of width × height texels holding `per_texel` layers each.
std::size_t stored_bytes(BasisStorage storage, int per_texel, int width, int height, int array_layers) {
  const std::size_t layers = static_cast<std::size_t>(array_layers) * static_cast<std::size_t>(per_texel);
  if (storage == BasisStorage::Eac11) return eac_block_count(width, height) * kEacBlockBytes * layers;
  const std::size_t per_layer = storage == BasisStorage::Unorm8 ? 1 : 2;
  return static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * layers * per_layer;
}

// The pages of a cropped basis: the plane's tiles of kPage texels, row-major; tile t's pages are
// page_begin[t] … page_begin[t + 1] − 1, page p holding layers page_layers[p · per_page + c]
// (−1: none), the layers whose rectangle overlaps the tile in ascending order.
struct PagePlan {
  int tiles_x = 1;
  int tiles_y = 1;
  std::vector<int> page_begin;
  std::vector<int> page_layers;
  int pages() const { return page_begin.empty() ? 0 : page_begin.back(); }
};

PagePlan plan_pages(const BasisImages& basis, int per_page) {
  PagePlan plan;
  plan.tiles_x = std::max((basis.width + kPage - 1) / kPage, 1);
  plan.tiles_y = std::max((basis.height + kPage - 1) / kPage, 1);
  const std::size_t tiles = static_cast<std::size_t>(plan.tiles_x) * static_cast<std::size_t>(plan.tiles_y);
  std::vector<std::vector<int>> overlaps(tiles);
  for (int k = 0; k < static_cast<int>(basis.crops.size()); ++k) {
    const LayerCrop& c = basis.crops[static_cast<std::size_t>(k)];
    if (c.cols <= 0 || c.rows <= 0) continue;  // an empty rectangle: the fill everywhere
    const int x0 = std::clamp(c.col / kPage, 0, plan.tiles_x - 1);
    const int x1 = std::clamp((c.col + c.cols - 1) / kPage, 0, plan.tiles_x - 1);
    const int y0 = std::clamp(c.row / kPage, 0, plan.tiles_y - 1);
    const int y1 = std::clamp((c.row + c.rows - 1) / kPage, 0, plan.tiles_y - 1);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) overlaps[static_cast<std::size_t>(y * plan.tiles_x + x)].push_back(k);
    }
  }
  plan.page_begin.assign(tiles + 1, 0);
  int pages = 0;
  for (std::size_t t = 0; t < tiles; ++t) {
    plan.page_begin[t] = pages;
    const std::vector<int>& list = overlaps[t];
    for (std::size_t first = 0; first < list.size(); first += static_cast<std::size_t>(per_page)) {
      for (std::size_t c = 0; c < static_cast<std::size_t>(per_page); ++c) {
        plan.page_layers.push_back(first + c < list.size() ? list[first + c] : -1);
      }
      ++pages;
    }
  }
  plan.page_begin[tiles] = pages;
  return plan;
}

// The atlas's shape: pages in rows of `per_row`, `rows` rows per array layer, `layers` array
// layers; as square as the page count allows, at most min(max_size, 2048) texels per side. At
// least one page, since a texture array cannot be empty.
struct AtlasShape {
  int per_row = 1;
  int rows = 1;
  int layers = 1;
  int width() const { return per_row * kPage; }
  int height() const { return rows * kPage; }
  int pages_per_layer() const { return per_row * rows; }
};

AtlasShape atlas_shape(int pages, int max_size) {
  const int cap = std::max(std::min(max_size, kAtlasSideCap) / kPage, 1);
  const int n = std::max(pages, 1);
  int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
  while (side > 1 && (side - 1) * (side - 1) >= n) --side;
  while (side * side < n) ++side;
  AtlasShape shape;
  shape.per_row = std::min(side, cap);
  shape.rows = std::min((n + shape.per_row - 1) / shape.per_row, cap);
  shape.layers = (n + shape.pages_per_layer() - 1) / shape.pages_per_layer();
  return shape;
}

GLint max_integer(GLenum name) {
  GLint value = 0;
  glGetIntegerv(name, &value);
  return value;
}

}  // namespace

std::size_t gpu_basis_bytes(const BasisImages& basis, const GpuBlendOptions& options) {
  const int per_texel = layers_per_texel(options);
  if (basis.cropped()) {
    const AtlasShape atlas = atlas_shape(plan_pages(basis, per_texel).pages(), kAtlasSideCap);
    return stored_bytes(options.storage, per_texel, atlas.width(), atlas.height(), atlas.layers);
  }
  const int slices = std::max((basis.layers + per_texel - 1) / per_texel, 1);
  return stored_bytes(options.storage, per_texel, basis.width, basis.height, slices);
}

GpuBlender::GpuBlender(const BasisImages& basis, const GpuBlendOptions& options)
    : options_(options), name_(basis.name), width_(basis.width), height_(basis.height), layers_(basis.layers) {
  check_gpu_basis(basis);
  // A cropped basis stays cropped: pages of an atlas (gpu_blend.hpp).
  paged_ = basis.cropped();
  tile_ = basis.tile;
  tiles_x_ = basis.tiles_x();
  tile_count_ = basis.tile_count();
  check_threshold(options.skip_threshold, "skip_threshold");
  check_threshold(options.change_threshold, "change_threshold");
  layers_per_slice_ = layers_per_texel(options_);
  const GLint max_slices = max_integer(GL_MAX_ARRAY_TEXTURE_LAYERS);
  const GLint max_size = max_integer(GL_MAX_TEXTURE_SIZE);
  if (paged_) {
    PagePlan plan = plan_pages(basis, layers_per_slice_);
    pages_ = plan.pages();
    page_tiles_x_ = plan.tiles_x;
    page_tiles_ = plan.tiles_x * plan.tiles_y;
    page_begin_ = std::move(plan.page_begin);
    page_layers_ = std::move(plan.page_layers);
    const AtlasShape atlas = atlas_shape(pages_, max_size);
    atlas_width_ = atlas.width();
    atlas_height_ = atlas.height();
    slices_ = atlas.layers;
    page_origin_.resize(static_cast<std::size_t>(pages_));
    for (int p = 0; p < pages_; ++p) {
      const int q = p % atlas.pages_per_layer();
      page_origin_[static_cast<std::size_t>(p)] = {p / atlas.pages_per_layer(), (q % atlas.per_row) * kPage,
                                                   (q / atlas.per_row) * kPage};
    }
    if (slices_ > max_slices) {
      throw std::runtime_error("GPU blend: plane '" + name_ + "' needs " + std::to_string(pages_) + " pages of " +
                               std::to_string(kPage) + "x" + std::to_string(kPage) + " texels, " +
                               std::to_string(slices_) + " array layers of " + std::to_string(atlas_width_) + "x" +
                               std::to_string(atlas_height_) + "; this driver's texture arrays hold " +
                               std::to_string(max_slices) +
                               " (GL_MAX_ARRAY_TEXTURE_LAYERS): pack the layers, or bake with a smaller dome frequency");
    }
  } else {
    slices_ = std::max((layers_ + layers_per_slice_ - 1) / layers_per_slice_, 1);
    if (slices_ > max_slices) {
      throw std::runtime_error("GPU blend: plane '" + name_ + "' needs " + std::to_string(slices_) +
                               " texture slices; this driver's texture arrays hold " + std::to_string(max_slices) +
                               " (GL_MAX_ARRAY_TEXTURE_LAYERS): pack the layers, or bake with a smaller dome frequency");
    }
  }
  if (width_ > max_size || height_ > max_size) {
    throw std::runtime_error("GPU blend: plane '" + name_ + "' is " + std::to_string(width_) + "x" +
                             std::to_string(height_) + " texels; this driver's textures hold " +
                             std::to_string(max_size) + " per side (GL_MAX_TEXTURE_SIZE)");
  }
  // One weight entry per tile and slice (tiled basis), or per page at most (paged): the weight
  // buffer must hold them all.
  const std::size_t entries = paged_ ? static_cast<std::size_t>(std::max(pages_, 1))
                                     : static_cast<std::size_t>(slices_) * static_cast<std::size_t>(tile_count_);
  const std::size_t weight_bytes = sizeof(SliceWeights) * entries;
  const GLint max_block = max_integer(GL_MAX_SHADER_STORAGE_BLOCK_SIZE);
  if (max_block > 0 && weight_bytes > static_cast<std::size_t>(max_block)) {
    throw std::runtime_error("GPU blend: plane '" + name_ + "' needs " + std::to_string(weight_bytes) +
                             " bytes of weights (" +
                             (paged_ ? std::to_string(pages_) + " pages"
                                     : std::to_string(tile_count_) + " tiles x " + std::to_string(slices_) + " slices") +
                             "); this driver's storage blocks hold " + std::to_string(max_block) +
                             " (GL_MAX_SHADER_STORAGE_BLOCK_SIZE): compress with larger tiles");
  }
  program_ = load_blend_program(options_);
  glUseProgram(program_.get());
  GLint group_size[3] = {0, 0, 0};
  glGetProgramiv(program_.get(), GL_COMPUTE_WORK_GROUP_SIZE, group_size);
  group_size_x_ = std::max(group_size[0], 1);
  group_size_y_ = std::max(group_size[1], 1);
  slice_count_location_ = uniform_location(program_.get(), "slice_count");
  source_term_location_ = uniform_location(program_.get(), "source_term");
  source_count_location_ = uniform_location(program_.get(), "source_count");
  no_light_location_ = uniform_location(program_.get(), "no_light");
  tile_size_location_ = uniform_location(program_.get(), "tile_size");
  tiles_x_location_ = uniform_location(program_.get(), "tiles_x");
  paged_location_ = uniform_location(program_.get(), "paged");
  // A paged basis is never tiled PCA (check_gpu_basis): its pages' tiles take the tile uniforms.
  glUniform1i(tile_size_location_, paged_ ? kPage : tile_);
  glUniform1i(tiles_x_location_, paged_ ? page_tiles_x_ : tiles_x_);
  glUniform1i(paged_location_, paged_ ? 1 : 0);

  basis_ = gpu::make_texture();
  glBindTexture(GL_TEXTURE_2D_ARRAY, basis_.get());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (paged_) {
    upload_pages(basis);
  } else {
    upload_layers(basis);
  }
  gpu::check_gl_error("GPU blend: uploading the basis of plane '" + name_ + "'");

  // T starts as 1 (no shadow) so that sampling before the first blend shows the camera image.
  output_ = gpu::make_texture();
  glBindTexture(GL_TEXTURE_2D, output_.get());
  const bool float_output = options_.output == ShadowRatioFormat::Float;
  glTexStorage2D(GL_TEXTURE_2D, 1, float_output ? GL_RGBA32F : GL_RGBA16F, width_, height_);
  const GLint filter = float_output ? GL_NEAREST : GL_LINEAR;
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, filter);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, filter);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  const std::vector<float> ones(4 * basis.texel_count(), 1.0f);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width_, height_, GL_RGBA, GL_FLOAT, ones.data());

  weight_buffer_ = gpu::make_buffer();
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, weight_buffer_.get());
  glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(weight_bytes), nullptr, GL_DYNAMIC_DRAW);
  // The tile records: one per tile of a paged basis; one zero record otherwise (never read, but
  // the shader's block is bound all the same).
  const std::vector<TileRecord> records(paged_ ? static_cast<std::size_t>(page_tiles_) : 1, TileRecord{{}, {}});
  tile_buffer_ = gpu::make_buffer();
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, tile_buffer_.get());
  glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(records.size() * sizeof(TileRecord)), records.data(),
               GL_DYNAMIC_DRAW);
  gpu::check_gl_error("GPU blend: setting up plane '" + name_ + "'");
}

// The basis as whole layers, one slice at a time: a layer, or four (two for EAC) in the channels
// of a texel (the last slice padded with zeros). 8-bit and EAC layers are scaled by their
// maximum on the way. A plane without layers still gets a slice, never read, since a texture
// array cannot be empty.
void GpuBlender::upload_layers(const BasisImages& basis) {
  const bool eac = options_.storage == BasisStorage::Eac11;
  const std::size_t texels = basis.texel_count();
  const bool unorm8 = options_.storage == BasisStorage::Unorm8;
  const std::size_t channels = static_cast<std::size_t>(layers_per_slice_);
  const ArrayFormat array = array_format(options_);
  const std::size_t layer_block_bytes = eac_block_count(width_, height_) * kEacBlockBytes;
  allocate_array(array, width_, height_, slices_);
  layer_max_.assign(static_cast<std::size_t>(layers_), 0.0f);
  std::vector<float> values(texels);
  std::vector<std::uint16_t> halves(unorm8 || eac ? 0 : channels * texels);
  std::vector<std::uint8_t> bytes(unorm8 ? channels * texels : 0);
  // EAC: a slice is the R blocks then, packed, the G blocks, block by block (8 + 8 bytes).
  std::vector<std::uint8_t> blocks(eac ? channels * layer_block_bytes : 0);
  std::vector<float> unit(eac ? texels : 0);
  // An absent layer of the last packed slice is zero: any valid blocks will do (its weight is 0).
  const std::vector<std::uint8_t> zero_blocks = eac ? encode_eac_r11(std::vector<float>(texels, 0.0f), width_, height_)
                                                    : std::vector<std::uint8_t>();
  if (eac) eac_error_.assign(static_cast<std::size_t>(layers_), 0.0f);
  for (int slice = 0; slice < slices_ && layers_ > 0; ++slice) {
    std::fill(halves.begin(), halves.end(), std::uint16_t{0});
    std::fill(bytes.begin(), bytes.end(), std::uint8_t{0});
    if (eac) {
      for (std::size_t c = 0; c < channels; ++c) {
        for (std::size_t b = 0; b < layer_block_bytes / kEacBlockBytes; ++b) {
          std::copy_n(zero_blocks.begin() + static_cast<std::ptrdiff_t>(b * kEacBlockBytes), kEacBlockBytes,
                      blocks.begin() + static_cast<std::ptrdiff_t>((b * channels + c) * kEacBlockBytes));
        }
      }
    }
    for (std::size_t c = 0; c < channels; ++c) {
      const int i = slice * layers_per_slice_ + static_cast<int>(c);
      if (i >= layers_) break;
      const std::uint16_t* layer = basis.half.data() + static_cast<std::size_t>(i) * texels;
      halves_to_floats(std::span<const std::uint16_t>(layer, texels), values);
      const LayerExtent extent = extent_of(values);
      check_storable(name_, static_cast<std::size_t>(i), extent, options_.storage);
      const float top = extent.top;
      layer_max_[static_cast<std::size_t>(i)] = top;
      if (unorm8) {
        // B ≈ top · q / 255, q rounded to nearest; negative values (none in a bake) become 0.
        const float scale = top > 0.0f ? 255.0f / top : 0.0f;
        for (std::size_t k = 0; k < texels; ++k) {
          const float q = values[k] * scale;
          bytes[k * channels + c] = static_cast<std::uint8_t>(q > 0.0f ? std::lround(std::min(q, 255.0f)) : 0);
        }
      } else if (eac) {
        const float scale = top > 0.0f ? 1.0f / top : 0.0f;
        for (std::size_t k = 0; k < texels; ++k) unit[k] = values[k] * scale;
        const std::vector<std::uint8_t> encoded = encode_eac_r11(unit, width_, height_);
        const std::vector<float> decoded = decode_eac_r11(encoded, width_, height_);
        float worst = 0.0f;
        for (std::size_t k = 0; k < texels; ++k) worst = std::max(worst, std::abs(decoded[k] * top - values[k]));
        eac_error_[static_cast<std::size_t>(i)] = worst;
        for (std::size_t b = 0; b < layer_block_bytes / kEacBlockBytes; ++b) {
          std::copy_n(encoded.begin() + static_cast<std::ptrdiff_t>(b * kEacBlockBytes), kEacBlockBytes,
                      blocks.begin() + static_cast<std::ptrdiff_t>((b * channels + c) * kEacBlockBytes));
        }
      } else {
        for (std::size_t k = 0; k < texels; ++k) halves[k * channels + c] = layer[k];
      }
    }
    upload_slice(array, slice, width_, height_, blocks, bytes, halves);
  }
}

// A cropped basis in pages (gpu_blend.hpp): the layers' maxima and checks first (over the
// rectangle, and the fill where the rectangle leaves any of the plane), then the atlas one array
// layer at a time, assembled here and uploaded in one call.
void GpuBlender::upload_pages(const BasisImages& basis) {
  const bool eac = options_.storage == BasisStorage::Eac11;
  const bool unorm8 = options_.storage == BasisStorage::Unorm8;
  const std::size_t channels = static_cast<std::size_t>(layers_per_slice_);
  const std::size_t layers = static_cast<std::size_t>(layers_);
  layer_max_.assign(layers, 0.0f);
  fills_.assign(layers, 0.0f);
  if (eac) eac_error_.assign(layers, 0.0f);
  std::vector<float> values;
  for (std::size_t k = 0; k < layers; ++k) {
    const LayerCrop& c = basis.crops[k];
    const std::size_t area = static_cast<std::size_t>(c.cols) * static_cast<std::size_t>(c.rows);
    values.resize(area);
    halves_to_floats(std::span<const std::uint16_t>(basis.half.data() + c.offset, area), values);
    LayerExtent extent = extent_of(values);
    if (area < basis.texel_count()) {
      // The fill as stored in the pages (a half) and as summed in the tiles' constants.
      const float stored = half_to_float(float_to_half(c.fill));
      extent.top = std::max({extent.top, std::abs(c.fill), std::abs(stored)});
      extent.negative |= c.fill < 0.0f;
    }
    check_storable(name_, k, extent, options_.storage);
    layer_max_[k] = extent.top;
    fills_[k] = c.fill;
  }

  const ArrayFormat array = array_format(options_);
  allocate_array(array, atlas_width_, atlas_height_, slices_);

  // The tile of each page.
  std::vector<int> page_tile(static_cast<std::size_t>(pages_), 0);
  for (int t = 0; t < page_tiles_; ++t) {
    for (int p = page_begin_[static_cast<std::size_t>(t)]; p < page_begin_[static_cast<std::size_t>(t) + 1]; ++p) {
      page_tile[static_cast<std::size_t>(p)] = t;
    }
  }
  const auto atlas_texels = static_cast<std::size_t>(atlas_width_) * static_cast<std::size_t>(atlas_height_);
  const std::size_t block_columns = static_cast<std::size_t>(atlas_width_ / 4);
  std::vector<std::uint16_t> halves(unorm8 || eac ? 0 : channels * atlas_texels);
  std::vector<std::uint8_t> bytes(unorm8 ? channels * atlas_texels : 0);
  // EAC: the R blocks then, packed, the G blocks, block by block (8 + 8 bytes). Unused channels
  // and page slots hold zeros' blocks.
  std::vector<std::uint8_t> blocks(eac ? channels * atlas_texels / 16 * kEacBlockBytes : 0);
  const std::vector<std::uint8_t> zero_block =
      eac ? encode_eac_r11(std::vector<float>(16, 0.0f), 4, 4) : std::vector<std::uint8_t>();
  constexpr std::size_t kPageTexels = static_cast<std::size_t>(kPage) * kPage;
  std::array<std::uint16_t, kPageTexels> raw{};
  std::array<float, kPageTexels> page_values{};
  std::array<bool, kPageTexels> on_plane{};
  const int pages_per_layer = (atlas_width_ / kPage) * (atlas_height_ / kPage);
  for (int slice = 0; slice < slices_; ++slice) {
    std::fill(halves.begin(), halves.end(), std::uint16_t{0});
    std::fill(bytes.begin(), bytes.end(), std::uint8_t{0});
    for (std::size_t b = 0; b < blocks.size() / kEacBlockBytes; ++b) {
      std::copy_n(zero_block.begin(), kEacBlockBytes, blocks.begin() + static_cast<std::ptrdiff_t>(b * kEacBlockBytes));
    }
    const int first_page = slice * pages_per_layer;
    const int last_page = std::min(first_page + pages_per_layer, pages_);
    for (int p = first_page; p < last_page; ++p) {
      const std::array<GLint, 3>& origin = page_origin_[static_cast<std::size_t>(p)];
      const int t = page_tile[static_cast<std::size_t>(p)];
      const int col0 = (t % page_tiles_x_) * kPage;
      const int row0 = (t / page_tiles_x_) * kPage;
      for (std::size_t c = 0; c < channels; ++c) {
        const int k = page_layers_[static_cast<std::size_t>(p) * channels + c];
        if (k < 0) continue;
        const LayerCrop& crop = basis.crops[static_cast<std::size_t>(k)];
        const std::uint16_t fill = float_to_half(crop.fill);
        for (int j = 0; j < kPage; ++j) {
          for (int i = 0; i < kPage; ++i) {
            const int col = col0 + i;
            const int row = row0 + j;
            const std::size_t at = static_cast<std::size_t>(j * kPage + i);
            on_plane[at] = col < width_ && row < height_;
            raw[at] = on_plane[at] && crop.contains(col, row)
                          ? basis.half[crop.offset + static_cast<std::size_t>(row - crop.row) * static_cast<std::size_t>(crop.cols) +
                                       static_cast<std::size_t>(col - crop.col)]
                          : fill;
          }
        }
        const float top = layer_max_[static_cast<std::size_t>(k)];
        if (!unorm8 && !eac) {
          for (int j = 0; j < kPage; ++j) {
            for (int i = 0; i < kPage; ++i) {
              const std::size_t texel = static_cast<std::size_t>(origin[2] + j) * static_cast<std::size_t>(atlas_width_) +
                                        static_cast<std::size_t>(origin[1] + i);
              halves[texel * channels + c] = raw[static_cast<std::size_t>(j * kPage + i)];
            }
          }
          continue;
        }
        halves_to_floats(raw, page_values);
        if (unorm8) {
          // B ≈ top · q / 255, q rounded to nearest; negative values (none in a bake) become 0.
          const float scale = top > 0.0f ? 255.0f / top : 0.0f;
          for (int j = 0; j < kPage; ++j) {
            for (int i = 0; i < kPage; ++i) {
              const float q = page_values[static_cast<std::size_t>(j * kPage + i)] * scale;
              const std::size_t texel = static_cast<std::size_t>(origin[2] + j) * static_cast<std::size_t>(atlas_width_) +
                                        static_cast<std::size_t>(origin[1] + i);
              bytes[texel * channels + c] = static_cast<std::uint8_t>(q > 0.0f ? std::lround(std::min(q, 255.0f)) : 0);
            }
          }
          continue;
        }
        // EAC: the page's 4 × 4 blocks, their error measured on the plane's texels.
        const float scale = top > 0.0f ? 1.0f / top : 0.0f;
        std::array<float, kPageTexels> unit{};
        for (std::size_t x = 0; x < kPageTexels; ++x) unit[x] = page_values[x] * scale;
        const std::vector<std::uint8_t> encoded = encode_eac_r11(unit, kPage, kPage);
        const std::vector<float> decoded = decode_eac_r11(encoded, kPage, kPage);
        float& worst = eac_error_[static_cast<std::size_t>(k)];
        for (std::size_t x = 0; x < kPageTexels; ++x) {
          if (on_plane[x]) worst = std::max(worst, std::abs(decoded[x] * top - page_values[x]));
        }
        for (int by = 0; by < kPage / 4; ++by) {
          for (int bx = 0; bx < kPage / 4; ++bx) {
            const std::size_t block = (static_cast<std::size_t>(origin[2] / 4 + by) * block_columns +
                                       static_cast<std::size_t>(origin[1] / 4 + bx)) * channels + c;
            std::copy_n(encoded.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(by * (kPage / 4) + bx) * kEacBlockBytes),
                        kEacBlockBytes, blocks.begin() + static_cast<std::ptrdiff_t>(block * kEacBlockBytes));
          }
        }
      }
    }
    upload_slice(array, slice, atlas_width_, atlas_height_, blocks, bytes, halves);
  }
}

std::size_t GpuBlender::basis_bytes() const {
  return paged_ ? stored_bytes(options_.storage, layers_per_slice_, atlas_width_, atlas_height_, slices_)
                : stored_bytes(options_.storage, layers_per_slice_, width_, height_, slices_);
}

bool GpuBlender::unchanged_since_last(const BlendWeights& weights, const std::vector<Eigen::Vector3f>& terms,
                                      const SunVisibilityTexture* sources) const {
  if (!has_result_ || weights.no_light != last_no_light_ || terms.size() != last_sources_.size()) return false;
  const auto lit = [](const std::vector<Eigen::Vector3f>& w) {
    return std::any_of(w.begin(), w.end(), [](const Eigen::Vector3f& x) { return !x.isZero(0); });
  };
  const bool lit_now = lit(terms);
  const GLuint texture = lit_now ? sources->texture : 0;
  const std::uint64_t revision = lit_now ? sources->revision : 0;
  if (lit_now && lit(last_sources_) && (texture != last_sun_texture_ || revision != last_sun_revision_)) return false;
  // The largest change of T any texel can see, per channel (B ≤ layer_max, V ≤ 1); summed over
  // every tile's weights, which bounds the change in any one tile.
  Eigen::Vector3d bound = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < terms.size(); ++k) bound += (terms[k] - last_sources_[k]).cwiseAbs().cast<double>();
  const std::size_t layers = static_cast<std::size_t>(layers_);
  for (std::size_t i = 0; i < weights.face.size(); ++i) {
    bound += (weights.face[i] - last_face_[i]).cwiseAbs().cast<double>() * static_cast<double>(layer_max_[i % layers]);
  }
  return bound.maxCoeff() <= options_.change_threshold;
}

// The slices (or pages) the shader reads with their weights, and what was summed and skipped.
struct GpuBlender::SliceList {
  std::vector<SliceWeights> slices;
  std::vector<TileRecord> tile_records;
  std::size_t read = 0;  // slice_count: entries per tile (whole layers)
  double skipped = 0.0;
  int skipped_count = 0;
  int summed = 0;
};

// InputError unless the weights are this basis's and the sun's visibility is there when needed.
void GpuBlender::check_blend_input(const BlendWeights& weights, const std::vector<Eigen::Vector3f>& terms,
                                   const SunVisibilityTexture* sources) const {
  const auto layers = static_cast<std::size_t>(layers_);
  const auto tiles = static_cast<std::size_t>(tile_count_);
  const std::size_t weight_count = layers * tiles;  // face[t · layers + i]: layer i within tile t
  if (weights.face.size() != weight_count) {
    refuse_gpu_input("weights.face", std::to_string(weights.face.size()) + " weights for the " + std::to_string(weight_count) +
                                  " layers" +
                                  (tile_ > 0 ? " (" + std::to_string(layers) + " in each of " + std::to_string(tiles) +
                                                   " tiles)"
                                             : std::string()) +
                                  " of plane '" + name_ + "'",
              "compute the weights with blend_weights for this basis");
  }
  int previous = -1;
  for (const int i : weights.active) {
    if (i <= previous || static_cast<std::size_t>(i) >= weight_count) {
      refuse_gpu_input("weights.active", "layer " + std::to_string(i) + " is out of order or out of range",
                "compute the weights with blend_weights for this basis");
    }
    previous = i;
  }
  for (const Eigen::Vector3f& w : weights.face) {
    if (!w.allFinite()) refuse_gpu_input("weights.face", "holds a value that is not finite", "compute the weights with blend_weights");
  }
  if (terms.size() > static_cast<std::size_t>(kMaxGpuSources)) {
    refuse_gpu_input("weights.sources", std::to_string(terms.size()) + " separated sources; the GPU blend sums " +
                                            std::to_string(kMaxGpuSources) + " at most",
                     "separate fewer sources (sky max_sources)");
  }
  std::size_t needed = 0;  // layers the lit sources need
  for (std::size_t k = 0; k < terms.size(); ++k) {
    const std::string field = weights.sources.empty() ? std::string("weights.sun") : "weights.sources[" + std::to_string(k) + "]";
    if (!terms[k].allFinite()) refuse_gpu_input(field, "is not finite", "compute the weights with blend_weights");
    if (!terms[k].isZero(0)) needed = k + 1;
  }
  if (needed > 0) {
    if (sources == nullptr || sources->texture == 0) {
      refuse_gpu_input("sun_visibility", "is missing but the sun lights plane '" + name_ + "'",
                "pass the plane's SunVisibilityTexture (SunShadowMap::visibility), or blend without the sun");
    }
    if (sources->width != width_ || sources->height != height_) {
      refuse_gpu_input("sun_visibility", "is " + std::to_string(sources->width) + "x" + std::to_string(sources->height) +
                                      "; plane '" + name_ + "' has " + std::to_string(width_) + "x" +
                                      std::to_string(height_) + " texels",
                "pass this plane's visibility texture");
    }
    if (static_cast<std::size_t>(sources->layers) < needed) {
      refuse_gpu_input("sun_visibility", "holds " + std::to_string(sources->layers) + " source layer(s); plane '" + name_ +
                                             "' is lit by " + std::to_string(needed) + " separated sources",
                       "draw the shadow maps with max_sources at least the sky's (SunShadowOptions::max_sources)");
    }
  }
}

// skip_threshold: leave out the layers of least possible contribution while their bounds add
// up to no more than the threshold; the rest are summed in ascending layer (slice) order. A
// tiled basis weighs (tile, layer) pairs: face index i is layer i % layers of tile i / layers.
// keep[a] and contribution[a] for each active weight a.
void GpuBlender::choose_skipped(const BlendWeights& weights, std::vector<double>& contribution,
                                std::vector<bool>& keep) const {
  const auto layers = static_cast<std::size_t>(layers_);
  const std::size_t active = weights.active.size();
  contribution.assign(active, 0.0);
  for (std::size_t a = 0; a < active; ++a) {
    const auto i = static_cast<std::size_t>(weights.active[a]);
    contribution[a] =
        static_cast<double>(weights.face[i].cwiseAbs().maxCoeff()) * static_cast<double>(layer_max_[i % layers]);
  }
  std::vector<std::size_t> order(active);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return contribution[a] < contribution[b]; });
  keep.assign(active, true);
  double candidates = 0.0;
  for (const std::size_t a : order) {
    if (candidates + contribution[a] > options_.skip_threshold) break;
    candidates += contribution[a];
    keep[a] = false;
  }
}

// A cropped basis: each layer is kept or skipped for the whole plane, and each tile reads its pages.
GpuBlender::SliceList GpuBlender::paged_slices(const BlendWeights& weights, const std::vector<double>& contribution,
                                               const std::vector<bool>& keep) const {
  const auto layers = static_cast<std::size_t>(layers_);
  const std::size_t active = weights.active.size();
  const bool scaled = options_.storage != BasisStorage::Half;  // layers stored as B / max_i
  const int per_slice = layers_per_slice_;
  SliceList list;
  std::vector<SliceWeights>& slices = list.slices;
  std::vector<TileRecord>& tile_records = list.tile_records;
  double& skipped = list.skipped;
  int& skipped_count = list.skipped_count;
  int& summed = list.summed;
  // Each layer is kept or skipped for the whole plane. A tile starts from the fills of the
  // kept layers whose rectangle misses it (the sum of all kept fills less those of the layers
  // in its pages, in double) and reads each of its pages that holds a kept layer, the others'
  // channels weighing 0.
  std::vector<std::array<float, 3>> kept_weight(layers, std::array<float, 3>{0.0f, 0.0f, 0.0f});
  std::vector<bool> kept(layers, false);
  std::array<double, 3> all_fills{0.0, 0.0, 0.0};
  for (std::size_t a = 0; a < active; ++a) {
    const auto i = static_cast<std::size_t>(weights.active[a]);
    if (!keep[a]) {
      skipped += contribution[a];
      ++skipped_count;
      continue;
    }
    kept[i] = true;
    for (int c = 0; c < 3; ++c) {
      kept_weight[i][static_cast<std::size_t>(c)] = weights.face[i][c];
      all_fills[static_cast<std::size_t>(c)] += static_cast<double>(weights.face[i][c]) * static_cast<double>(fills_[i]);
    }
    ++summed;
  }
  tile_records.resize(static_cast<std::size_t>(page_tiles_));
  for (std::size_t t = 0; t < tile_records.size(); ++t) {
    std::array<double, 3> constant = all_fills;
    const auto first = static_cast<GLint>(slices.size());
    for (int p = page_begin_[t]; p < page_begin_[t + 1]; ++p) {
      const std::array<GLint, 3>& origin = page_origin_[static_cast<std::size_t>(p)];
      SliceWeights entry{{}, {}, {}, {origin[0], origin[1], origin[2], 0}};
      bool any = false;
      for (int c = 0; c < per_slice; ++c) {
        const int k = page_layers_[static_cast<std::size_t>(p) * static_cast<std::size_t>(per_slice) + static_cast<std::size_t>(c)];
        if (k < 0 || !kept[static_cast<std::size_t>(k)]) continue;
        any = true;
        const std::array<float, 3>& w = kept_weight[static_cast<std::size_t>(k)];
        const float fill = fills_[static_cast<std::size_t>(k)];
        for (std::size_t ch = 0; ch < 3; ++ch) constant[ch] -= static_cast<double>(w[ch]) * static_cast<double>(fill);
        const float scale = scaled ? layer_max_[static_cast<std::size_t>(k)] : 1.0f;
        entry.red[static_cast<std::size_t>(c)] = w[0] * scale;
        entry.green[static_cast<std::size_t>(c)] = w[1] * scale;
        entry.blue[static_cast<std::size_t>(c)] = w[2] * scale;
      }
      if (any) slices.push_back(entry);
    }
    TileRecord& record = tile_records[t];
    record.constant = {static_cast<float>(constant[0]), static_cast<float>(constant[1]), static_cast<float>(constant[2]), 0.0f};
    record.range = {first, static_cast<GLint>(slices.size()) - first, 0, 0};
  }
  return list;
}

// Whole layers (plain or tiled): the slices any tile reads, the same list for every tile.
GpuBlender::SliceList GpuBlender::layer_slices(const BlendWeights& weights, const std::vector<double>& contribution,
                                               const std::vector<bool>& keep) const {
  const auto layers = static_cast<std::size_t>(layers_);
  const auto tiles = static_cast<std::size_t>(tile_count_);
  const std::size_t active = weights.active.size();
  const bool scaled = options_.storage != BasisStorage::Half;  // layers stored as B / max_i
  const int per_slice = layers_per_slice_;
  SliceList list;
  std::vector<SliceWeights>& slices = list.slices;
  std::size_t& read = list.read;
  double& skipped = list.skipped;
  int& skipped_count = list.skipped_count;
  int& summed = list.summed;
  // A slice is read when one of its layers is kept (in any tile); then all its active layers
  // are summed (they come with the fetch), and only the layers of unread slices count as
  // skipped. Every tile reads the same slices, in ascending order: tile t's weights are entries
  // t · read … (t + 1) · read − 1 (zero for a layer the tile does not weigh).
  std::vector<bool> slice_read(static_cast<std::size_t>(slices_), false);
  for (std::size_t a = 0; a < active; ++a) {
    const int layer = weights.active[a] % layers_;
    if (keep[a]) slice_read[static_cast<std::size_t>(layer / per_slice)] = true;
  }
  std::vector<int> position(static_cast<std::size_t>(slices_), -1);  // in each tile's list
  std::vector<SliceWeights> tile_slices;                              // one tile's list, weights 0
  for (int slice = 0; slice < slices_; ++slice) {
    if (!slice_read[static_cast<std::size_t>(slice)]) continue;
    position[static_cast<std::size_t>(slice)] = static_cast<int>(tile_slices.size());
    tile_slices.push_back(SliceWeights{{}, {}, {}, {slice, 0, 0, 0}});
  }
  read = tile_slices.size();
  slices.reserve(read * tiles);
  for (std::size_t t = 0; t < tiles; ++t) slices.insert(slices.end(), tile_slices.begin(), tile_slices.end());
  for (std::size_t a = 0; a < active; ++a) {
    const auto i = static_cast<std::size_t>(weights.active[a]);
    const std::size_t tile = i / layers;
    const std::size_t layer = i % layers;
    const std::size_t slice = layer / static_cast<std::size_t>(per_slice);
    if (!slice_read[slice]) {
      skipped += contribution[a];
      ++skipped_count;
      continue;
    }
    SliceWeights& entry = slices[tile * read + static_cast<std::size_t>(position[slice])];
    const std::size_t c = layer % static_cast<std::size_t>(per_slice);
    const float scale = scaled ? layer_max_[layer] : 1.0f;
    const Eigen::Vector3f& w = weights.face[i];
    entry.red[c] = w.x() * scale;
    entry.green[c] = w.y() * scale;
    entry.blue[c] = w.z() * scale;
    ++summed;
  }
  return list;
}

// Uploads the slice weights and tile records and runs the compute shader over the plane.
void GpuBlender::dispatch(const SliceList& list, const BlendWeights& weights, const std::vector<Eigen::Vector3f>& terms,
                          const SunVisibilityTexture* sources) {
  const std::vector<SliceWeights>& slices = list.slices;
  const std::vector<TileRecord>& tile_records = list.tile_records;
  const std::size_t read = list.read;
  glUseProgram(program_.get());
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, weight_buffer_.get());
  if (!slices.empty()) {
    glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(slices.size() * sizeof(SliceWeights)),
                    slices.data());
  }
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, weight_buffer_.get());
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, tile_buffer_.get());
  if (!tile_records.empty()) {
    glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(tile_records.size() * sizeof(TileRecord)),
                    tile_records.data());
  }
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, tile_buffer_.get());
  glUniform1i(slice_count_location_, static_cast<GLint>(read));
  // The lit sources, each with its layer of the visibility texture.
  std::vector<float> source_terms;
  for (std::size_t k = 0; k < terms.size(); ++k) {
    if (terms[k].isZero(0)) continue;
    source_terms.insert(source_terms.end(), {terms[k].x(), terms[k].y(), terms[k].z(), static_cast<float>(k)});
  }
  const auto source_count = static_cast<GLsizei>(source_terms.size() / 4);
  if (source_count > 0) glUniform4fv(source_term_location_, source_count, source_terms.data());
  glUniform1i(source_count_location_, source_count);
  glUniform3i(no_light_location_, weights.no_light[0] ? 1 : 0, weights.no_light[1] ? 1 : 0, weights.no_light[2] ? 1 : 0);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D_ARRAY, basis_.get());
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D_ARRAY, source_count > 0 ? sources->texture : 0);
  glActiveTexture(GL_TEXTURE0);
  const GLenum format = options_.output == ShadowRatioFormat::Float ? GL_RGBA32F : GL_RGBA16F;
  glBindImageTexture(0, output_.get(), 0, GL_FALSE, 0, GL_WRITE_ONLY, format);
  glDispatchCompute(static_cast<GLuint>((width_ + group_size_x_ - 1) / group_size_x_),
                    static_cast<GLuint>((height_ + group_size_y_ - 1) / group_size_y_), 1);
  // Whoever reads T next (a sampler, a framebuffer read, another image load) sees this result.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT |
                  GL_TEXTURE_UPDATE_BARRIER_BIT);
  gpu::check_gl_error("GPU blend of plane '" + name_ + "'");

}

bool GpuBlender::blend(const BlendWeights& weights, const SunVisibilityTexture* sources) {
  std::vector<Eigen::Vector3f> terms = separated_terms(weights);
  check_blend_input(weights, terms, sources);
  const bool lit = std::any_of(terms.begin(), terms.end(), [](const Eigen::Vector3f& w) { return !w.isZero(0); });
  if (unchanged_since_last(weights, terms, sources)) return false;
  std::vector<double> contribution;
  std::vector<bool> keep;
  choose_skipped(weights, contribution, keep);
  const SliceList list = paged_ ? paged_slices(weights, contribution, keep) : layer_slices(weights, contribution, keep);
  dispatch(list, weights, terms, sources);

  const std::vector<SliceWeights>& slices = list.slices;
  const std::size_t read = list.read;
  const int summed = list.summed, skipped_count = list.skipped_count;
  const double skipped = list.skipped;
  has_result_ = true;
  last_face_ = weights.face;
  last_sources_ = std::move(terms);
  last_no_light_ = weights.no_light;
  last_sun_texture_ = lit ? sources->texture : 0;
  last_sun_revision_ = lit ? sources->revision : 0;
  summed_layers_ = summed;
  summed_slices_ = static_cast<int>(paged_ ? slices.size() : read);
  skipped_layers_ = skipped_count;
  skipped_bound_ = skipped;
  return true;
}

std::vector<float> GpuBlender::read_back() const {
  GLint previous = 0;
  glGetIntegerv(GL_FRAMEBUFFER_BINDING, &previous);
  const gpu::Framebuffer framebuffer = gpu::make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.get());
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, output_.get(), 0);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(previous));
    throw std::runtime_error("GPU blend: the driver cannot read back a float texture (it lacks "
                             "GL_EXT_color_buffer_float); sample shadow_ratio_texture() instead");
  }
  std::vector<float> rgba(4 * static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_));
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_FLOAT, rgba.data());
  glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(previous));
  gpu::check_gl_error("GPU blend: reading back plane '" + name_ + "'");
  std::vector<float> rgb(3 * static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_));
  for (std::size_t k = 0; k < rgb.size() / 3; ++k) {
    for (std::size_t c = 0; c < 3; ++c) rgb[3 * k + c] = rgba[4 * k + c];
  }
  return rgb;
}

}  // namespace skylit::blend
