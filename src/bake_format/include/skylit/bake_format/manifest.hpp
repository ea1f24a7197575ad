#pragma once
// A bake's manifest: the plan it was made with, its dome faces and planes, every data file with
// its size and SHA-256, and the check of a bake directory against it (verify).
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

namespace skylit::bake_format {

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
  // The preset whose bake settings it was made with (skylit-bake --preset); empty: none. The
  // live service runs such a bake only with the same `preset:`, whose dome differs from the site's.
  std::string preset;
  std::vector<geom::Plane> planes;        // after any --resolution override
  // Directions per vertex of the ground's transfer (ground_transfer.npy; skylit-bake
  // --ground-samples); 0: the bake has no ground layer. Plans without the field have 0.
  int ground_samples = 0;
  // The refinement of the model where the light changes (skylit-bake --refine; baker/refine.hpp),
  // tolerance 0: none. vertex_count and triangle_count are then the refined model's. Plans
  // without the field have none.
  struct Refine {
    double tolerance = 0.0;
    int rounds = 0;
    double min_edge = 0.0;
    bool operator==(const Refine&) const = default;
  };
  Refine refine;
  // Least-squares vertex values (skylit-bake --vertex-fit N; baker/vertex_fit.hpp): the light is
  // traced at N² points inside every triangle too and the vertices' transfer fitted to it; 0: each
  // vertex's own value. Plans without the field have 0.
  int vertex_fit = 0;
  // The light map (skylit-bake --light-map TEXEL; baker/light_map.hpp): square texels of `texel`
  // metres over the flat regions of at least min_area m², finer on a chart narrower than
  // min_across texels (0: never), `texels` of them traced; texel 0: none. Plans without the field
  // have none.
  struct LightMap {
    double texel = 0.0;
    double min_area = 0.0;
    int min_across = 0;
    std::uint64_t texels = 0;
    bool operator==(const LightMap&) const = default;
  };
  LightMap light_map;
  std::uint64_t vertex_count = 0;
  std::uint64_t triangle_count = 0;
  // The values a bake's parts hold per layer: the vertices', the fit's points', the light map's texels'.
  std::uint64_t traced_count() const {
    return vertex_count + triangle_count * static_cast<std::uint64_t>(vertex_fit) * static_cast<std::uint64_t>(vertex_fit) +
           light_map.texels;
  }

  int layers_per_face() const { return geom::layers_per_face(basis); }

  bool operator==(const Plan&) const;
  // Human-readable list of what differs ("samples: 1 vs 16; plane 'roof' resolution ...").
  std::string difference(const Plan& other) const;
};

// What a bake directory holds (docs/bake-format.md):
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
//   BAKE_DIR/ground_transfer.npy  optional, float32 [vertex_count, layer_count]: t^g_{v,l}, the
//                                 ground's light per layer at the vertices (steradians), with
//                                 the layers' unoccluded integrals for the horizontal, A_l(z),
//                                 in the manifest
//   BAKE_DIR/vertices.npy         float32 [vertex_count, 6]: position xyz, normal xyz (site frame)
//   BAKE_DIR/refinement.npy       optional, uint32 [edges, 2]: the model's edges split, round
//                                 after round (the manifest gives each round's count), which
//                                 every program replays on the site's model (model.hpp)
//   BAKE_DIR/light_map_*.npy      optional: the light map (light_map.hpp): its charts, each
//                                 triangle's chart, its texels, and their transfer (and the
//                                 ground's, with a ground layer), float32 [texels, layer_count];
//                                 optional light_map_pca_*.npy, the same compressed by chart
//   BAKE_DIR/preview/*.png        contact sheets (not part of the verified data)
//
// While a bake runs, finished work lives in BAKE_DIR/parts/ (one file per dome face, written
// atomically) next to BAKE_DIR/parts/plan.json, which pins the parameters so that --resume and
// merge refuse work from a different plan.
struct Manifest {
  int schema_version = kSchemaVersion;
  std::string generator;                  // "skylit-bake 0.1.0"
  std::string created_utc;                // ISO 8601
  Plan plan;
  std::vector<FaceRecord> faces;
  std::vector<PlaneRecord> planes;
  std::string transfer_file = "transfer.npy";
  std::string vertices_file = "vertices.npy";
  // The ground layer (plan.ground_samples > 0): the file of t^g_{v,l}, and A_l(z) per layer, with
  // which a separated source's light on the ground joins the layers (blend::GroundLayers).
  struct Ground {
    std::string file = "ground_transfer.npy";
    std::vector<double> horizontal_unoccluded;
  };
  std::optional<Ground> ground;
  // plan.refine.tolerance > 0: the edges split, in rounds of round_sizes edges each.
  struct Refinement {
    std::string file = "refinement.npy";
    std::vector<std::uint64_t> round_sizes;
    std::uint64_t edge_count() const;
  };
  std::optional<Refinement> refinement;
  // plan.light_map.texel > 0: the atlas's size and its files (light_map.hpp).
  struct LightMap {
    int width = 0, height = 0;
    std::uint64_t chart_count = 0;
    std::string charts_file = "light_map_charts.npy";
    std::string triangles_file = "light_map_triangles.npy";
    std::string texels_file = "light_map_texels.npy";
    // The full form; both empty when the bake keeps only the PCA form (--light-map-pca-only).
    std::string transfer_file = "light_map_transfer.npy";
    std::string ground_file;                // "light_map_ground.npy" with a ground layer, else empty
    bool has_full_form() const { return !transfer_file.empty(); }
    // Optional: the transfer compressed chart by chart (light_map_pca.hpp; skylit-bake
    // --light-map-components), the full form beside it unless --light-map-pca-only.
    struct Pca {
      int components = 0;
      double sky_correlation_deg = 0.0;
      std::string weights_file = "light_map_pca_weights.npy";   // float32 [texels, K]
      std::string vectors_file = "light_map_pca_vectors.npy";   // float32 [charts, K + 1, layers]
      std::string ground_weights_file, ground_vectors_file;     // with a ground layer, else empty
      double rms_error = 0.0, max_error = 0.0;                  // steradians, the sky's transfer
      double ground_rms_error = 0.0, ground_max_error = 0.0;    // the ground's
    };
    std::optional<Pca> pca;
  };
  std::optional<LightMap> light_map;
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

// The names of a plane image's layers.
std::string face_layer_name(int face);    // "face_007"
// Layer `layer` of a bake with this basis: face_layer_name(layer) for faces, "face_007_2" for
// layer 3·7 + 2 of a corners bake.
std::string layer_name(geom::DomeBasis basis, int layer);
std::vector<std::string> layer_names(geom::DomeBasis basis, int face_count);

}  // namespace skylit::bake_format
