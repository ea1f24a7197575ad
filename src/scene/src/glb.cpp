// Binary glTF writer: one buffer, shared positions and normals, one primitive per material.
#include <algorithm>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <tiny_gltf.h>

#include "skylit/base/files.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::scene {
namespace {

void check_consistent(const Mesh& mesh) {
  if (mesh.triangle_count() == 0) throw std::invalid_argument("write_glb: the mesh has no triangles");
  if (mesh.indices.size() % 3 != 0 || mesh.normals.size() != mesh.positions.size() ||
      mesh.triangle_material.size() != mesh.triangle_count()) {
    throw std::invalid_argument("write_glb: mesh arrays have inconsistent sizes");
  }
  for (std::uint32_t index : mesh.indices) {
    if (index >= mesh.positions.size()) throw std::invalid_argument("write_glb: index out of range");
  }
  for (std::uint32_t material : mesh.triangle_material) {
    if (material >= mesh.materials.size()) {
      throw std::invalid_argument("write_glb: triangle material out of range");
    }
  }
}

// Appends raw bytes to the buffer, 4-byte aligned as glTF requires, and returns a view on them.
int append_view(tinygltf::Model& model, const void* data, std::size_t bytes, int target) {
  std::vector<unsigned char>& buffer = model.buffers[0].data;
  while (buffer.size() % 4 != 0) buffer.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.size();
  view.byteLength = bytes;
  view.target = target;
  const auto* bytes_begin = static_cast<const unsigned char*>(data);
  buffer.insert(buffer.end(), bytes_begin, bytes_begin + bytes);
  model.bufferViews.push_back(view);
  return static_cast<int>(model.bufferViews.size() - 1);
}

int vec3_accessor(tinygltf::Model& model, const std::vector<float>& xyz, bool with_bounds) {
  tinygltf::Accessor accessor;
  accessor.bufferView = append_view(model, xyz.data(), xyz.size() * sizeof(float),
                                    TINYGLTF_TARGET_ARRAY_BUFFER);
  accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  accessor.type = TINYGLTF_TYPE_VEC3;
  accessor.count = xyz.size() / 3;
  if (with_bounds) {  // required for POSITION by the glTF specification
    accessor.minValues.assign(3, std::numeric_limits<double>::infinity());
    accessor.maxValues.assign(3, -std::numeric_limits<double>::infinity());
    for (std::size_t k = 0; k < xyz.size(); ++k) {
      accessor.minValues[k % 3] = std::min(accessor.minValues[k % 3], static_cast<double>(xyz[k]));
      accessor.maxValues[k % 3] = std::max(accessor.maxValues[k % 3], static_cast<double>(xyz[k]));
    }
  }
  model.accessors.push_back(accessor);
  return static_cast<int>(model.accessors.size() - 1);
}

}  // namespace

void write_glb(const Mesh& mesh, const std::filesystem::path& file) {
  check_consistent(mesh);
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "skylit";
  model.buffers.emplace_back();

  // Site frame (z up) → glTF (y up): (x, y, z)_site → (x, z, −y)_model.
  std::vector<float> positions;
  std::vector<float> normals;
  positions.reserve(mesh.positions.size() * 3);
  normals.reserve(mesh.normals.size() * 3);
  for (std::size_t k = 0; k < mesh.positions.size(); ++k) {
    const Eigen::Vector3f& p = mesh.positions[k];
    const Eigen::Vector3f& n = mesh.normals[k];
    positions.insert(positions.end(), {p.x(), p.z(), -p.y()});
    normals.insert(normals.end(), {n.x(), n.z(), -n.y()});
  }
  const int position_accessor = vec3_accessor(model, positions, true);
  const int normal_accessor = vec3_accessor(model, normals, false);

  for (const Material& material : mesh.materials) {
    tinygltf::Material gltf_material;
    gltf_material.name = material.name;
    gltf_material.pbrMetallicRoughness.baseColorFactor = {
        material.base_colour[0], material.base_colour[1], material.base_colour[2],
        material.base_colour[3]};
    gltf_material.pbrMetallicRoughness.metallicFactor = 0.0;  // stone, wood, plaster, tiles
    gltf_material.pbrMetallicRoughness.roughnessFactor = 1.0;
    model.materials.push_back(gltf_material);
  }

  tinygltf::Mesh gltf_mesh;
  gltf_mesh.name = "site";
  for (std::size_t material = 0; material < mesh.materials.size(); ++material) {
    std::vector<std::uint32_t> indices;
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
      if (mesh.triangle_material[t] != material) continue;
      indices.insert(indices.end(), mesh.indices.begin() + static_cast<std::ptrdiff_t>(3 * t),
                     mesh.indices.begin() + static_cast<std::ptrdiff_t>(3 * t + 3));
    }
    if (indices.empty()) continue;
    tinygltf::Accessor accessor;
    accessor.bufferView = append_view(model, indices.data(), indices.size() * sizeof(std::uint32_t),
                                      TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    accessor.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    accessor.type = TINYGLTF_TYPE_SCALAR;
    accessor.count = indices.size();
    model.accessors.push_back(accessor);

    tinygltf::Primitive primitive;
    primitive.attributes["POSITION"] = position_accessor;
    primitive.attributes["NORMAL"] = normal_accessor;
    primitive.indices = static_cast<int>(model.accessors.size() - 1);
    primitive.material = static_cast<int>(material);
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    gltf_mesh.primitives.push_back(primitive);
  }
  model.meshes.push_back(gltf_mesh);

  tinygltf::Node node;
  node.mesh = 0;
  node.name = "site";
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(scene);
  model.defaultScene = 0;

  tinygltf::TinyGLTF writer;
  std::ostringstream stream;
  if (!writer.WriteGltfSceneToStream(&model, stream, /*prettyPrint=*/false, /*writeBinary=*/true)) {
    throw std::runtime_error("write_glb: tinygltf could not serialise the model for " +
                             file.string());
  }
  write_file_atomic(file, stream.str());
}

}  // namespace skylit::scene
