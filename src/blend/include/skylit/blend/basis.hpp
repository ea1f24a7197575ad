#pragma once
// The basis images of one plane as the blends read them: whole half-float layers, the lean,
// PCA (plain or clustered in tiles) and cropped forms of a bake, loaded and checked (load_basis).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/blend/forms.hpp"

namespace skylit::blend {

using geom::Vec3;

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


// Reads plane `plane` (an index into manifest.planes) of a verified bake, in the form asked for.
BasisImages load_basis(const std::filesystem::path& bake_dir, const bake_format::Manifest& manifest, int plane,
                       BasisForm form = BasisForm::Full);

// A cropped basis with every layer whole again (the fill outside its rectangle), for consumers
// that read whole layers; any other basis as it is.
BasisImages uncropped(const BasisImages& basis);

// InputError unless the stored values are what the header says: sizes not negative, and
// `half` holding every whole layer, or (cropped) one rectangle per layer inside the plane, back
// to back, with finite fills. Both blends check this before any loop trusts the sizes.
void check_basis_storage(const BasisImages& basis);

}  // namespace skylit::blend
