#pragma once
// A bake in progress: one file per finished dome face in BAKE_DIR/parts/, next to the plan that
// pins its parameters, so that --resume and merge refuse work from a different plan.
#include <filesystem>
#include <optional>
#include <vector>

#include "skylit/bake_format/manifest.hpp"

namespace skylit::bake_format {


// Visible fractions of one dome face for every plane texel and every model vertex, as computed
// by a visibility engine (B = A · fraction, see src/baker/), one set per layer of the face
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

}  // namespace skylit::bake_format
