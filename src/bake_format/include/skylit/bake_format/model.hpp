#pragma once
// The model a bake was made on, as every program that reads the bake must draw and light it: the
// site's model, with the bake's refinement where the light changes replayed on it.
#include <filesystem>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/scene/site.hpp"

namespace skylit::bake_format {

// The edges the bake split, round by round (manifest.refinement); none when it has no refinement.
scene::Refinement read_refinement(const std::filesystem::path& bake_dir, const Manifest& manifest);

// scene::load_site_model(site) with read_refinement replayed (scene::apply_refinement). InputError,
// naming the bake and the fix (re-bake), when the model is not the one baked: a refinement that
// does not replay, or vertices other than the bake's vertices.npy.
scene::Mesh load_baked_model(const scene::Site& site, const std::filesystem::path& bake_dir, const Manifest& manifest);

}  // namespace skylit::bake_format
