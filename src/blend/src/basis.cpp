// load_basis: one plane of a bake, as half floats in face order, checked against its manifest.
#include <algorithm>
#include <cmath>
#include <string>

// Plane::normal() uses cross(), which Eigen defines in <Eigen/Geometry>.
#include <Eigen/Geometry>

#include "skylit/bake_format/footprint.hpp"
#include "skylit/bake_format/pca.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/bake_format/arrays.hpp"

namespace skylit::blend {
namespace {

namespace fs = std::filesystem;

// The basis of a bake with this many layers per face (what layer names need).
geom::DomeBasis basis_with_layers(int layers_per_face) {
  for (const geom::DomeBasis b : {geom::DomeBasis::Corners, geom::DomeBasis::Quadratics}) {
    if (geom::layers_per_face(b) == layers_per_face) return b;
  }
  return geom::DomeBasis::Faces;
}

constexpr const char* kRebake = "re-bake (skylit-bake --force), or restore the bake directory from a copy "
                                "and check it with 'skylit-bake verify'";

std::string plane_field(int plane, const std::string& key) {
  return "planes[" + std::to_string(plane) + "]" + (key.empty() ? "" : "." + key);
}

// Every value must be a finite B ≥ 0 (−0 included): a NaN or an infinity would poison every
// shadow ratio it is summed into, and a bake never writes one.
void check_values(const fs::path& file, const BasisImages& basis) {
  const std::size_t texels = basis.texel_count();
  for (std::size_t k = 0; k < basis.half.size(); ++k) {
    const std::uint16_t h = basis.half[k];
    const bool not_finite = (h & 0x7c00u) == 0x7c00u;
    const bool negative = (h & 0x8000u) != 0 && (h & 0x7fffu) != 0;
    if (not_finite || negative) {
      const std::size_t layer = k / texels;
      const std::size_t texel = k % texels;
      const std::size_t width = static_cast<std::size_t>(basis.width);
      throw InputError(input_message(
          file, -1, -1,
          bake_format::layer_name(basis_with_layers(basis.layers_per_face), static_cast<int>(layer)) +
              ".Y",
          "texel (col " + std::to_string(texel % width) + ", row " + std::to_string(texel / width) + ") holds " +
              std::to_string(half_to_float(h)) + "; basis values are finite and >= 0 (steradians)",
          kRebake));
    }
  }
}

// The plane's images as read, with what the blend needs from its record.
BasisImages basis_of(const bake_format::PlaneRecord& record, const bake_format::Manifest& manifest, bake_format::ImageStackHalf stack) {
  BasisImages basis;
  basis.name = record.plane.name;
  basis.width = stack.width;
  basis.height = stack.height;
  basis.layers = stack.layers;
  basis.half = std::move(stack.data);
  basis.unoccluded = record.unoccluded;
  basis.normal = record.plane.normal();
  basis.layers_per_face = manifest.plan.layers_per_face();
  return basis;
}

// Keeps the layers that hold a shadow, one layer of ones for the unshadowed ones' constant light,
// nothing for the layers the plane cannot see; `projection` maps the dome's weights onto them.
// crop: each shadowed layer keeps only the rectangle it shadows (outside it B = A, the fill), the
// layer of ones nothing (fill 1).
void make_lean(BasisImages& basis, bool crop) {
  bake_format::ImageStackHalf stack;
  stack.width = basis.width;
  stack.height = basis.height;
  stack.layers = basis.layers;
  stack.data = std::move(basis.half);
  const bake_format::PlaneFootprint footprint = bake_format::analyse_footprint(stack, basis.unoccluded);
  const std::size_t texels = basis.texel_count();
  const int kept = footprint.needed_layers();
  basis.half.clear();
  basis.half.reserve(static_cast<std::size_t>(kept) * texels);
  basis.projection = Eigen::MatrixXf::Zero(basis.layers, kept);
  int stored = 0;
  for (int l = 0; l < basis.layers; ++l) {
    if (footprint.layers[static_cast<std::size_t>(l)].kind != bake_format::LayerFootprint::Kind::Shadowed) continue;
    const auto begin = stack.data.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(l) * texels);
    basis.half.insert(basis.half.end(), begin, begin + static_cast<std::ptrdiff_t>(texels));
    basis.projection(l, stored++) = 1.0f;
  }
  if (footprint.unshadowed > 0) {
    basis.half.insert(basis.half.end(), texels, float_to_half(1.0f));
    for (int l = 0; l < basis.layers; ++l) {
      if (footprint.layers[static_cast<std::size_t>(l)].kind == bake_format::LayerFootprint::Kind::Unshadowed) {
        basis.projection(l, stored) = static_cast<float>(basis.unoccluded[static_cast<std::size_t>(l)]);
      }
    }
  }
  basis.layers = kept;
  if (!crop) return;
  std::vector<std::uint16_t> rectangles;
  int k = 0;
  for (int l = 0; l < static_cast<int>(footprint.layers.size()); ++l) {
    const bake_format::LayerFootprint& f = footprint.layers[static_cast<std::size_t>(l)];
    if (f.kind != bake_format::LayerFootprint::Kind::Shadowed) continue;
    // The fill is A rounded to half, as the full form stores an unshadowed texel's B.
    LayerCrop c{f.col, f.row, f.cols, f.rows, rectangles.size(),
                half_to_float(float_to_half(static_cast<float>(basis.unoccluded[static_cast<std::size_t>(l)])))};
    const std::uint16_t* layer = basis.half.data() + static_cast<std::size_t>(k) * texels;
    for (int r = 0; r < c.rows; ++r) {
      const std::uint16_t* from = layer + static_cast<std::size_t>(c.row + r) * static_cast<std::size_t>(basis.width) +
                                  static_cast<std::size_t>(c.col);
      rectangles.insert(rectangles.end(), from, from + c.cols);
    }
    basis.crops.push_back(c);
    ++k;
  }
  if (footprint.unshadowed > 0) basis.crops.push_back(LayerCrop{0, 0, 0, 0, rectangles.size(), 1.0f});
  basis.half = std::move(rectangles);
}

BasisImages load_pca_form(const fs::path& bake_dir, const bake_format::Manifest& manifest, int plane) {
  const fs::path manifest_file = bake_dir / "manifest.json";
  const bake_format::PlaneRecord& record = manifest.planes[static_cast<std::size_t>(plane)];
  if (!record.pca) {
    throw InputError(input_message(manifest_file, -1, -1, plane_field(plane, "pca"),
                                   "plane '" + record.plane.name + "' has no PCA form",
                                   "compress the bake: skylit-bake compress " + bake_dir.string() +
                                       " --pca-variance 0.999 (or --pca-components K, --pca-max-error E); or "
                                       "read the full form"));
  }
  const bake_format::PcaRecord& pca = *record.pca;
  const std::size_t n = manifest.layer_count();
  const int k = pca.components;
  const fs::path file = bake_dir / pca.file;
  std::vector<std::string> names;
  bake_format::ImageStackHalf stack = bake_format::read_exr_stack_half(file, &names);
  const std::vector<std::string> expected = bake_format::pca_layer_names(std::max(k, 0));
  if (stack.width != record.plane.width || stack.height != record.plane.height || names != expected) {
    throw InputError(input_message(file, -1, -1, "layers",
                                   std::to_string(stack.width) + "x" + std::to_string(stack.height) + " with " +
                                       std::to_string(names.size()) + " layers; manifest.json says plane '" +
                                       record.plane.name + "' is " + std::to_string(record.plane.width) + "x" +
                                       std::to_string(record.plane.height) + " with " + std::to_string(expected.size()) +
                                       " (mean, pc_001 …)",
                                   "compress the bake again: skylit-bake compress " + bake_dir.string() + " --pca-…"));
  }
  // Clustered PCA: one projection per tile, [tiles, n, K] coefficients.
  const auto tiles = static_cast<std::size_t>(pca.tiles_x(record.plane.width)) *
                     static_cast<std::size_t>(pca.tiles_y(record.plane.height));
  std::vector<std::size_t> shape;
  const std::vector<float> coefficients = bake_format::read_npy(bake_dir / pca.coefficients, &shape);
  const std::vector<std::size_t> expected_shape =
      pca.tile > 0 ? std::vector<std::size_t>{tiles, n, static_cast<std::size_t>(k)}
                   : std::vector<std::size_t>{n, static_cast<std::size_t>(k)};
  if (shape != expected_shape) {
    // Appended piecewise: GCC 12 warns falsely (-Wrestrict) on "[" + std::string.
    std::string expected_text = "is not [";
    if (pca.tile > 0) expected_text += std::to_string(tiles) + ", ";
    expected_text += std::to_string(n) + ", " + std::to_string(k);
    expected_text += pca.tile > 0 ? "] (tiles × layers × components)" : "] (layers × components)";
    throw InputError(input_message(bake_dir / pca.coefficients, -1, -1, "shape", expected_text,
                                   "compress the bake again: skylit-bake compress " + bake_dir.string() + " --pca-…"));
  }
  BasisImages basis = basis_of(record, manifest, std::move(stack));
  basis.tile = pca.tile;
  const auto stored = static_cast<Eigen::Index>(k + 1);
  basis.projection.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(tiles) * stored);
  for (std::size_t t = 0; t < tiles; ++t) {
    for (std::size_t l = 0; l < n; ++l) {
      const auto a = static_cast<float>(record.unoccluded[l]);
      const auto row = static_cast<Eigen::Index>(l);
      const Eigen::Index column = static_cast<Eigen::Index>(t) * stored;
      const float* p = coefficients.data() + (t * n + l) * static_cast<std::size_t>(k);
      basis.projection(row, column) = a;
      for (int c = 0; c < k; ++c) basis.projection(row, column + c + 1) = a * p[c];
    }
  }
  for (std::size_t i = 0; i < basis.half.size(); ++i) {
    if ((basis.half[i] & 0x7c00u) == 0x7c00u) {
      throw InputError(input_message(file, -1, -1, expected[i / basis.texel_count()] + ".Y",
                                     "holds a value that is not finite", "compress the bake again"));
    }
  }
  if (!basis.projection.allFinite()) {
    throw InputError(input_message(bake_dir / pca.coefficients, -1, -1, "data", "holds a value that is not finite",
                                   "compress the bake again"));
  }
  return basis;
}

}  // namespace

BasisImages load_basis(const fs::path& bake_dir, const bake_format::Manifest& manifest, int plane, BasisForm form) {
  const fs::path manifest_file = bake_dir / "manifest.json";
  const int plane_count = static_cast<int>(manifest.planes.size());
  if (plane < 0 || plane >= plane_count) {
    std::string names;
    for (const bake_format::PlaneRecord& r : manifest.planes) names += (names.empty() ? "'" : ", '") + r.plane.name + "'";
    throw InputError(input_message(manifest_file, -1, -1, "planes",
                                   "there is no plane number " + std::to_string(plane) + "; the bake has " +
                                       std::to_string(plane_count) + (plane_count == 1 ? " plane" : " planes") +
                                       (names.empty() ? std::string() : " (" + names + ")"),
                                   plane_count == 0 ? std::string("bake a site that has at least one plane")
                                                    : "choose a plane from 0 to " + std::to_string(plane_count - 1)));
  }
  const bake_format::PlaneRecord& record = manifest.planes[static_cast<std::size_t>(plane)];
  if (manifest.faces.empty()) {
    throw InputError(input_message(manifest_file, -1, -1, "dome.faces", "the dome has no faces", kRebake));
  }
  // The layers: one per face, or three (corners) or six (quadratics) per face.
  const std::size_t faces = manifest.layer_count();
  const geom::DomeBasis basis_kind = manifest.plan.basis;
  const std::string layers_text = manifest.plan.layers_per_face() == 1
                                      ? std::to_string(faces) + " dome faces"
                                      : std::to_string(faces) + " layers (" +
                                            std::string(geom::basis_name(basis_kind)) + " basis: " +
                                            std::to_string(manifest.plan.layers_per_face()) + " per face of " +
                                            std::to_string(manifest.faces.size()) + " dome faces)";
  if (record.unoccluded.size() != faces) {
    throw InputError(input_message(manifest_file, -1, -1, plane_field(plane, "unoccluded"),
                                   "has " + std::to_string(record.unoccluded.size()) + " values for " + layers_text,
                                   kRebake));
  }
  for (std::size_t i = 0; i < faces; ++i) {
    const double a = record.unoccluded[i];
    if (!std::isfinite(a) || a < 0.0) {
      throw InputError(input_message(manifest_file, -1, -1,
                                     plane_field(plane, "unoccluded") + "[" + std::to_string(i) + "]",
                                     "value " + std::to_string(a) + " is not a finite solid angle >= 0", kRebake));
    }
  }

  if (form == BasisForm::Pca) return load_pca_form(bake_dir, manifest, plane);

  const fs::path file = bake_dir / record.file;
  std::vector<std::string> names;
  bake_format::ImageStackHalf stack = bake_format::read_exr_stack_half(file, &names);
  if (stack.width != record.plane.width || stack.height != record.plane.height) {
    throw InputError(input_message(file, -1, -1, "data window",
                                   "the image is " + std::to_string(stack.width) + "x" +
                                       std::to_string(stack.height) + " texels but manifest.json says plane '" +
                                       record.plane.name + "' is " + std::to_string(record.plane.width) + "x" +
                                       std::to_string(record.plane.height),
                                   kRebake));
  }
  // Layers are read in face order; the first name out of place is the missing (or foreign) one.
  for (std::size_t i = 0; i < faces; ++i) {
    const std::string expected = bake_format::layer_name(basis_kind, static_cast<int>(i));
    if (i >= names.size() || names[i] != expected) {
      throw InputError(input_message(file, -1, -1, expected + ".Y",
                                     "missing: the image has " + std::to_string(names.size()) + " layers, the bake " +
                                         layers_text + " (" + bake_format::layer_name(basis_kind, 0) + " … " +
                                         bake_format::layer_name(basis_kind, static_cast<int>(faces) - 1) + ")",
                                     kRebake));
    }
  }
  if (names.size() != faces) {
    throw InputError(input_message(file, -1, -1, names[faces] + ".Y",
                                   "unexpected layer: the bake has " + layers_text, kRebake));
  }

  BasisImages basis = basis_of(record, manifest, std::move(stack));
  check_values(file, basis);
  if (form == BasisForm::Lean || form == BasisForm::Cropped) make_lean(basis, form == BasisForm::Cropped);
  return basis;
}

}  // namespace skylit::blend
