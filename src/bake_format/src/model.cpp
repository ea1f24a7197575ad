// The model a bake was made on (model.hpp).
#include "skylit/bake_format/model.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "skylit/bake_format/arrays.hpp"
#include "skylit/base/error.hpp"

namespace skylit::bake_format {

scene::Refinement read_refinement(const std::filesystem::path& bake_dir, const Manifest& manifest) {
  scene::Refinement refinement;
  if (!manifest.refinement) return refinement;
  const std::filesystem::path file = bake_dir / manifest.refinement->file;
  std::vector<std::size_t> shape;
  const std::vector<std::uint32_t> edges = read_npy_u32(file, &shape);
  if (shape.size() != 2 || shape[1] != 2 || shape[0] != manifest.refinement->edge_count()) {
    throw InputError(file.string() + ": its shape is not [" + std::to_string(manifest.refinement->edge_count()) +
                     ", 2], the edges the manifest's rounds split. Fix: re-bake");
  }
  std::size_t at = 0;
  for (std::uint64_t size : manifest.refinement->round_sizes) {
    std::vector<scene::Edge>& round = refinement.rounds.emplace_back();
    for (std::uint64_t k = 0; k < size; ++k, ++at) round.emplace_back(edges[2 * at], edges[2 * at + 1]);
  }
  return refinement;
}

scene::Mesh load_baked_model(const scene::Site& site, const std::filesystem::path& bake_dir, const Manifest& manifest) {
  scene::Mesh mesh = scene::load_site_model(site);
  const std::string fix = ". Fix: re-bake the site (skylit-bake " + site.file.string() + " -o " + bake_dir.string() +
                          " --force), or point to the bake of this model";
  try {
    apply_refinement(mesh, read_refinement(bake_dir, manifest));
  } catch (const std::invalid_argument& e) {
    throw InputError(bake_dir.string() + ": the bake's refinement does not fit the model " + site.model.string() + " (" +
                     e.what() + ")" + fix);
  }
  if (mesh.vertex_count() != manifest.plan.vertex_count) {
    throw InputError(bake_dir.string() + ": baked on a model of " + std::to_string(manifest.plan.vertex_count) +
                     " vertices; " + site.model.string() + " now makes " + std::to_string(mesh.vertex_count()) + fix);
  }
  std::vector<std::size_t> shape;
  const std::vector<float> baked = read_npy(bake_dir / manifest.vertices_file, &shape);
  if (shape.size() != 2 || shape[0] != mesh.vertex_count() || shape[1] != 6) {
    throw InputError((bake_dir / manifest.vertices_file).string() + ": shape is not [" + std::to_string(mesh.vertex_count()) +
                     ", 6]" + fix);
  }
  // The same arithmetic on the same file gives the same floats; a model edited since the bake
  // moves some vertex by more than this.
  const float tolerance = 1e-4f * std::max(1.0f, (mesh.bounds_max() - mesh.bounds_min()).norm());
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const Eigen::Vector3f at(baked[6 * v], baked[6 * v + 1], baked[6 * v + 2]);
    if (!((at - mesh.positions[v]).norm() <= tolerance)) {
      throw InputError(bake_dir.string() + ": vertex " + std::to_string(v) + " of " + site.model.string() +
                       " is not where the bake had it" + fix);
    }
  }
  return mesh;
}

}  // namespace skylit::bake_format
