#pragma once
// The bake directory: a versioned, self-describing result of skylit-bake, shared by the baker
// (writes) and the live service (reads). See docs/bake-format.md.
//
//   BAKE_DIR/manifest.json        written last, atomically; lists every data file with its
//                                 size and SHA-256. No manifest, no bake.
//   BAKE_DIR/planes/<name>.exr    per plane: multi-layer half-float OpenEXR, one layer per basis
//                                 function: per dome face ("face_NNN.Y") with the faces basis,
//                                 per face and corner k ("face_NNN_k.Y", layer 3i+k) with the
//                                 corners basis; B_{j,l} in steradians; scanline y = texel row
//                                 (along v), x = column (along u)
//   BAKE_DIR/planes/<name>.pca.exr, .pca.npy  optional: the plane's basis compressed by
//                                 principal components (pca.hpp), K + 1 layers and P_{l,k}
//   BAKE_DIR/transfer.npy         float32 [vertex_count, layer_count]: t_{v,l}, steradians
//   BAKE_DIR/vertices.npy         float32 [vertex_count, 6]: position xyz, normal xyz (site frame)
//   BAKE_DIR/preview/*.png        contact sheets (not part of the verified data)
//
// While a bake runs, finished work lives in BAKE_DIR/parts/ (one file per dome face, written
// atomically) next to BAKE_DIR/parts/plan.json, which pins the parameters so that --resume and
// merge refuse work from a different plan.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "skylit/geom/dome_basis.hpp"
#include "skylit/geom/plane.hpp"

namespace skylit::bake {

inline constexpr int kSchemaVersion = 1;
inline constexpr const char* kFormatName = "skylit-bake";

using geom::Vec3;

struct FaceRecord {
  int index = 0;
  Vec3 direction = Vec3::Zero();          // unit centre direction
  double solid_angle = 0.0;               // steradians
  std::array<Vec3, 3> vertices{};         // unit, counter-clockwise from outside
  std::array<int, 3> neighbours{-1, -1, -1};
};

// The PCA form of a plane's basis (pca.hpp), when the bake stores one beside the full form.
struct PcaRecord {
  std::string file;                       // half-float EXR: layers "mean.Y", "pc_001.Y", …
  // float32 .npy [layer_count, components]: P_{l,k}; tiled, [tiles, layer_count, components]
  std::string coefficients;
  int components = 0;                     // K
  int tile = 0;                           // clustered PCA: tile × tile texels per tile (0: untiled)
  double max_error = 0.0;                 // max |F − F̂| (pca.hpp): bounds |T − T_full|
  double rms_error = 0.0;
  double variance_kept = 1.0;
  double sky_correlation_deg = 0.0;       // the sky prior it was made with (0: none; pca.hpp)
  // Tiles across and down for a plane of width × height texels (1 × 1 untiled).
  int tiles_x(int width) const { return tile > 0 ? (width + tile - 1) / tile : 1; }
  int tiles_y(int height) const { return tile > 0 ? (height + tile - 1) / tile : 1; }
};

struct PlaneRecord {
  geom::Plane plane;
  std::vector<double> unoccluded;         // A_{j,l}, one per layer, steradians
  std::string file;                       // relative to the bake directory
  std::optional<PcaRecord> pca;           // manifests without "pca" have none
};

struct FileRecord {
  std::string path;                       // relative to the bake directory
  std::uint64_t size = 0;
  std::string sha256;
};

// The parameters that define a bake; equal plans produce interchangeable parts.
struct Plan {
  std::string site_file;                  // as given (for the record)
  std::string site_sha256;
  std::string model_file;
  std::string model_sha256;
  int frequency = 2;
  // The radiance basis (docs/bake-format.md): faces (one layer per face) or corners (three).
  // Manifests and plans without the field are faces.
  geom::DomeBasis basis = geom::DomeBasis::Faces;
  int samples = 1;
  std::string method = "raster";          // raster | raytrace
  int shadow_map_resolution = 0;          // raster only; 0 for raytrace
  std::vector<geom::Plane> planes;        // after any --resolution override
  std::uint64_t vertex_count = 0;
  std::uint64_t triangle_count = 0;

  int layers_per_face() const { return geom::layers_per_face(basis); }

  bool operator==(const Plan&) const;
  // Human-readable list of what differs ("samples: 1 vs 16; plane 'roof' resolution ...").
  std::string difference(const Plan& other) const;
};

struct Manifest {
  int schema_version = kSchemaVersion;
  std::string generator;                  // "skylit-bake 0.1.0"
  std::string created_utc;                // ISO 8601
  Plan plan;
  std::vector<FaceRecord> faces;
  std::vector<PlaneRecord> planes;
  std::string transfer_file = "transfer.npy";
  std::string vertices_file = "vertices.npy";
  double bake_seconds = 0.0;              // wall time of the face work (all shards)
  double finalize_seconds = 0.0;
  std::vector<FileRecord> files;          // every data file, hashed

  // Layers of every plane image and columns of transfer.npy: faces × layers per face.
  std::size_t layer_count() const { return faces.size() * static_cast<std::size_t>(plan.layers_per_face()); }
};

nlohmann::json to_json(const Plan& plan);
Plan plan_from_json(const nlohmann::json& j, const std::filesystem::path& source);
nlohmann::json to_json(const Manifest& manifest);
Manifest manifest_from_json(const nlohmann::json& j, const std::filesystem::path& source);

// Reads BAKE_DIR/manifest.json. InputError for a missing file, bad JSON, another format, another
// schema version (says which and what to do) or missing fields.
Manifest read_manifest(const std::filesystem::path& bake_dir);
// Hashes the data files named in manifest.files (filling size and sha256) and writes
// manifest.json atomically.
void write_manifest(const std::filesystem::path& bake_dir, Manifest manifest);

struct VerifyReport {
  bool ok = false;
  std::vector<std::string> problems;      // one line each, naming the file and the fix
  Manifest manifest;                      // valid when the manifest could be read
};
// Checks version, every file's presence, size and SHA-256, and that every plane image has the
// manifest's resolution and one layer per face, and the transfer arrays their shapes.
VerifyReport verify(const std::filesystem::path& bake_dir);

// ---- images and arrays ----

// Layer-major float stack: data[(layer * height + row) * width + col].
struct ImageStack {
  int width = 0;
  int height = 0;
  int layers = 0;
  std::vector<float> data;
  std::span<float> layer(int i);
  std::span<const float> layer(int i) const;
};

std::string face_layer_name(int face);    // "face_007"
// Layer `layer` of a bake with this basis: face_layer_name(layer) for faces, "face_007_2" for
// layer 3·7 + 2 of a corners bake.
std::string layer_name(geom::DomeBasis basis, int layer);
std::vector<std::string> layer_names(geom::DomeBasis basis, int face_count);
// Multi-layer half-float OpenEXR (ZIP compressed), channel "<layer_names[i]>.Y" per layer.
void write_exr_stack(const std::filesystem::path& file, const ImageStack& stack,
                     std::span<const std::string> layer_names);
ImageStack read_exr_stack(const std::filesystem::path& file,
                          std::vector<std::string>* layer_names = nullptr);

// The same stack as stored: IEEE binary16 bits, no float round trip (the live blend reads these
// directly, at half the memory). Layout and errors as read_exr_stack.
struct ImageStackHalf {
  int width = 0;
  int height = 0;
  int layers = 0;
  std::vector<std::uint16_t> data;        // data[(layer * height + row) * width + col]
};
ImageStackHalf read_exr_stack_half(const std::filesystem::path& file,
                                   std::vector<std::string>* layer_names = nullptr);

// NumPy .npy, little-endian float32, C order.
void write_npy(const std::filesystem::path& file, std::span<const float> data,
               std::span<const std::size_t> shape);
std::vector<float> read_npy(const std::filesystem::path& file, std::vector<std::size_t>* shape);

// Inspection without reading the data (cheap; used by verify). Both throw InputError naming the
// file for an unreadable or foreign file. read_npy_info also refuses a file size other than the
// shape requires; read_exr_info sees a cut-off header or offset table, but not missing pixel data
// (read_exr_stack does; verify compares sizes and hashes).
struct ExrInfo {
  int width = 0;
  int height = 0;
  std::vector<std::string> layer_names;   // of the "*.Y" channels, in the order read_exr_stack uses
};
ExrInfo read_exr_info(const std::filesystem::path& file);

struct NpyInfo {
  std::vector<std::size_t> shape;
  std::uint64_t data_offset = 0;          // bytes before the float32 data
};
NpyInfo read_npy_info(const std::filesystem::path& file);

// ---- parts of a bake in progress ----

// Visible fractions of one dome face for every plane texel and every model vertex, as computed
// by a visibility engine (B = A · fraction, see basis_baker/), one set per layer of the face
// (plan.layers_per_face(): 1 for faces, 3 for corners), layer-major.
struct FacePart {
  int face = 0;
  std::vector<std::vector<float>> plane_fractions;  // per plane: layers × width*height, row-major
  std::vector<float> vertex_fractions;              // layers × vertex count
};

class PartStore {
 public:
  // dir is BAKE_DIR/parts.
  explicit PartStore(std::filesystem::path dir);
  const std::filesystem::path& dir() const { return dir_; }

  // plan.json: written once when a bake starts, checked by --resume and merge.
  void write_plan(const Plan& plan) const;
  std::optional<Plan> read_plan() const;

  // Atomic; the file carries a header with sizes and a SHA-256 of its payload.
  void write(const FacePart& part) const;
  // True when face's part exists and is complete and consistent with `plan`.
  bool has(int face, const Plan& plan) const;
  FacePart read(int face, const Plan& plan) const;  // InputError when corrupt or mismatched
  std::filesystem::path path_of(int face) const;

 private:
  std::filesystem::path dir_;
};

}  // namespace skylit::bake
