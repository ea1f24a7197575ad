#pragma once
// Pictures of a bake for installers: per plane a contact sheet of its basis images laid out
// like the dome (the paper's figure 8), and the plane under a uniform sky.
#include <filesystem>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"

namespace skylit::baker {

// Writes preview/<plane>.png (contact sheet) and preview/<plane>_uniform_sky.png
// (Σ_i B_i / Σ_i A_i: the shadow ratio under a uniform sky) for one plane.
void write_plane_previews(const std::filesystem::path& preview_dir, const bake_format::Manifest& manifest,
                          int plane, const bake_format::ImageStack& basis);

}  // namespace skylit::baker
