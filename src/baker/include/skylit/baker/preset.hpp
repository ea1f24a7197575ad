#pragma once
// A preset's bake settings (the `bake:` section of config/presets.yaml, docs/presets.md): what
// skylit-bake --preset NAME bakes with, unless its own options say otherwise.
#include <string>

#include "skylit/base/presets.hpp"
#include "skylit/geom/dome_basis.hpp"

namespace skylit::baker {

struct BakePreset {
  std::string name;
  int frequency = 2;                              // dome frequency ν, even
  geom::DomeBasis basis = geom::DomeBasis::Faces;
  int samples = 16;                               // visibility samples per face
  int pca_components = 0;                         // 0: no PCA form stored
  int pca_tile = 0;                               // clustered PCA: tiles of this many texels (0: one set per plane)
  double refine = 0;                              // skylit-bake --refine (0: the model as it is)
  int vertex_fit = 0;                             // skylit-bake --vertex-fit (0: each vertex's own light)
  double light_map = 0;                           // skylit-bake --light-map, metres per texel (0: none)
  double light_map_min_area = 0.1;                // --light-map-min-area, m²
  int light_map_min_across = 10;                  // --light-map-min-across, texels
  int light_map_components = 0;                   // --light-map-components (0: the full form only)
  bool light_map_pca_only = false;                // --light-map-pca-only: the bake leaves the full form out
};

// The bake section of preset `name`. InputError (file, line, field, fix) for anything wrong.
BakePreset load_bake_preset(const PresetsFile& presets, const std::string& name);

}  // namespace skylit::baker
