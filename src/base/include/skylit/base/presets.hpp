#pragma once
// Named settings (config/presets.yaml, docs/presets.md): fast, balanced, accurate. Each names the
// bake's settings (what skylit-bake --preset NAME uses) and the live service's (what a
// skylit-live config's `preset: NAME` sets before its own keys, which override them). Chosen
// from the trade table (skylit-bench trade, bench/RESULTS.md).
//
//   balanced:
//     bake: {frequency: 2, basis: corners, samples: 16, pca_components: 0}
//     live: {basis: full, storage: half, skip_threshold: 0, change_threshold: 0.002,
//            smoothing: 0, sun: auto}
#include <filesystem>
#include <string>
#include <vector>

namespace skylit {

struct BakePreset {
  int frequency = 2;
  std::string basis = "faces";   // faces | corners
  int samples = 16;
  int pca_components = 0;        // 0: no PCA form stored
  int pca_tile = 0;              // clustered PCA: tiles of this many texels (0: one set per plane)
};

struct LivePreset {
  std::string basis = "full";    // blend.basis: full | lean | pca
  std::string storage = "half";  // blend.storage: half | unorm8 | eac
  double skip_threshold = 0.0;   // blend.skip_threshold (S threshold)
  double change_threshold = 0.002;  // blend.change_threshold (ΔS threshold)
  double smoothing = 0.0;        // sky.smoothing, seconds
  bool sun = true;               // sky.sun: auto (true) | off
  double render_scale = 1.0;     // render.scale: the building's render resolution, (0, 1]
};

struct Preset {
  std::string name;
  BakePreset bake;
  LivePreset live;
};

// The presets file the tools use when none is given: presets.yaml in the source tree's config/.
std::filesystem::path default_presets_file();

// Every preset of `file`, in file order. InputError (file, line, field, fix) for anything wrong.
std::vector<Preset> load_presets(const std::filesystem::path& file);

// The preset `name` of `file`; InputError naming the file and the valid names when there is none.
Preset find_preset(const std::filesystem::path& file, const std::string& name);

// "fast, balanced, accurate": the names of `presets`, comma-separated.
std::string preset_names(const std::vector<Preset>& presets);

}  // namespace skylit
