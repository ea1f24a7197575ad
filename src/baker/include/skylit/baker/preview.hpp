#pragma once
// Pictures of a bake for installers: per plane a contact sheet of its basis images laid out
// like the dome (the paper's figure 8), and the plane under a uniform sky; the model coloured by
// a value per vertex.
#include <filesystem>
#include <span>
#include <string>

#include <Eigen/Core>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::baker {

// Writes preview/<plane>.png (contact sheet) and preview/<plane>_uniform_sky.png
// (Σ_i B_i / Σ_i A_i: the shadow ratio under a uniform sky) for one plane.
void write_plane_previews(const std::filesystem::path& preview_dir, const bake_format::Manifest& manifest,
                          int plane, const bake_format::ImageStack& basis);

// A picture of the model coloured by a linear RGB value per vertex (the building's irradiance),
// interpolated over each triangle, from a default view: from the south-west, 20° above the
// model's centre, far enough to hold all of it. `white` is the value drawn white (sRGB-encoded,
// brighter values clip); `caption` is written under the picture. PNG, written atomically.
void write_vertex_picture(const std::filesystem::path& file, const scene::Mesh& mesh,
                          std::span<const Eigen::Vector3d> linear_rgb, double white, const std::string& caption,
                          int width = 960);

}  // namespace skylit::baker
