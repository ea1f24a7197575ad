// A building model (scene::load_model): OBJ, binary glTF or glTF (the first byte picks the
// extension). An accepted mesh is what the ray tracer and the GPU may be given: finite positions
// within the site's extent, unit normals, indices in range.
#include <array>
#include <cmath>

#include "fuzz_target.hpp"
#include "skylit/scene/mesh.hpp"

SKYLIT_FUZZ_TARGET(model) {
  if (size == 0) return 0;
  constexpr std::array<const char*, 3> kNames = {"model/model.obj", "model/model.glb", "model/model.gltf"};
  const auto file = skylit::fuzz::write_input(kNames[data[0] % kNames.size()], data + 1, size - 1);
  skylit::fuzz::refuse_only_with_input_error([&] {
    const skylit::scene::Mesh mesh = skylit::scene::load_model(file, skylit::scene::UpAxis::Z, 1.0);
    skylit::fuzz::require(mesh.normals.size() == mesh.positions.size(), "a normal per position");
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
      skylit::fuzz::require(mesh.positions[i].allFinite(), "positions are finite");
      skylit::fuzz::require(std::abs(mesh.normals[i].norm() - 1.0f) < 1e-3f, "normals are unit");
    }
    skylit::fuzz::require(mesh.indices.size() % 3 == 0, "three indices per triangle");
    for (const std::uint32_t index : mesh.indices) {
      skylit::fuzz::require(index < mesh.positions.size(), "indices name a position");
    }
    skylit::fuzz::require(mesh.triangle_material.size() == mesh.indices.size() / 3, "a material per triangle");
    for (const std::uint32_t material : mesh.triangle_material) {
      skylit::fuzz::require(material < mesh.materials.size(), "materials exist");
    }
  });
  return 0;
}
