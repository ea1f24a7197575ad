// Model loading: glTF 2.0 through tinygltf (with Draco-compressed and quantized meshes), OBJ
// through tinyobjloader, both into the site frame.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <span>
#include <stdexcept>
#include <string_view>
#include <tuple>
#include <utility>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>
#include <tiny_obj_loader.h>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/scene/mesh.hpp"
#include "draco_primitive.hpp"

namespace skylit::scene {

Eigen::Vector3f Mesh::bounds_min() const {
  Eigen::Vector3f low = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  for (const Eigen::Vector3f& p : positions) low = low.cwiseMin(p);
  return positions.empty() ? Eigen::Vector3f::Zero() : low;
}

Eigen::Vector3f Mesh::bounds_max() const {
  Eigen::Vector3f high = Eigen::Vector3f::Constant(-std::numeric_limits<float>::infinity());
  for (const Eigen::Vector3f& p : positions) high = high.cwiseMax(p);
  return positions.empty() ? Eigen::Vector3f::Zero() : high;
}

namespace {

namespace fs = std::filesystem;

const std::string kExportFix =
    "export the model again as glTF 2.0 (.glb/.gltf) or OBJ and check that it opens in Blender";

[[noreturn]] void fail(const fs::path& file, const std::string& problem, const std::string& fix) {
  throw InputError(input_message(file, -1, -1, "", problem, fix));
}

// Collects triangles in the model frame. Vertices without a normal in the file are split per
// triangle and get the triangle's flat normal at the end (architecture has hard edges; averaged
// normals would round them off).
struct MeshBuilder {
  Mesh mesh;
  std::vector<bool> needs_flat_normal;  // per vertex
  bool any_texcoord = false;            // texcoords are kept only when some vertex has one

  std::uint32_t add_vertex(const Eigen::Vector3d& position, const Eigen::Vector3d* normal,
                           const Eigen::Vector2f* texcoord = nullptr) {
    mesh.positions.push_back(position.cast<float>());
    mesh.normals.push_back(normal ? Eigen::Vector3f(normal->cast<float>()) : Eigen::Vector3f::Zero());
    mesh.texcoords.push_back(texcoord ? *texcoord : Eigen::Vector2f::Zero());
    any_texcoord = any_texcoord || texcoord != nullptr;
    needs_flat_normal.push_back(normal == nullptr);
    return static_cast<std::uint32_t>(mesh.positions.size() - 1);
  }

  void add_triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t material) {
    mesh.indices.insert(mesh.indices.end(), {a, b, c});
    mesh.triangle_material.push_back(material);
  }
};

constexpr float kMaxSiteExtent = 1e6f;  // metres from the site's origin, along any axis

// Model frame → site frame, then normals: flat where the file had none, unit everywhere.
Mesh finish(MeshBuilder builder, const fs::path& file, UpAxis up, double scale) {
  Mesh& mesh = builder.mesh;
  if (!builder.any_texcoord) mesh.texcoords.clear();
  if (mesh.triangle_count() == 0) {
    fail(file, "the model has no triangles",
         "export the meshes as triangles (or polygons, for OBJ); points and lines are not used");
  }
  for (std::size_t k = 0; k < mesh.positions.size(); ++k) {
    Eigen::Vector3f& p = mesh.positions[k];
    Eigen::Vector3f& n = mesh.normals[k];
    if (!p.allFinite()) {
      fail(file, "vertex " + std::to_string(k) + " has a non-finite position",
           "repair the model (remove broken vertices) and export it again");
    }
    if (up == UpAxis::Y) {  // (x, y, z)_model → (x, −z, y)_site: model −z becomes north
      p = Eigen::Vector3f(p.x(), -p.z(), p.y());
      n = Eigen::Vector3f(n.x(), -n.z(), n.y());
    }
    p *= static_cast<float>(scale);
    if (!p.allFinite()) {
      fail(file, "vertex " + std::to_string(k) + " is out of range after scaling",
           "check scene.scale in the site file");
    }
    // A vertex a thousand kilometres out is damaged data, not a building: its coordinates would
    // overflow the ray tracer's bounds (and a float there has metre-sized steps anyway).
    if (p.cwiseAbs().maxCoeff() > kMaxSiteExtent) {
      char where[96];
      std::snprintf(where, sizeof where, "(%.3g, %.3g, %.3g) m", p.x(), p.y(), p.z());
      fail(file, "vertex " + std::to_string(k) + " lies at " + where + ", more than " +
                     std::to_string(static_cast<long>(kMaxSiteExtent / 1000)) + " km from the site's origin",
           "repair the model (a damaged vertex), or check scene.scale in the site file");
    }
  }

  // Flat normals for split vertices; a file normal that is zero or broken is replaced by the
  // area-weighted normal of its triangles (the only way left to orient it).
  std::vector<Eigen::Vector3f> fallback(mesh.positions.size(), Eigen::Vector3f::Zero());
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const std::uint32_t* tri = &mesh.indices[3 * t];
    const Eigen::Vector3f face = (mesh.positions[tri[1]] - mesh.positions[tri[0]])
                                     .cross(mesh.positions[tri[2]] - mesh.positions[tri[0]]);
    for (int corner = 0; corner < 3; ++corner) fallback[tri[corner]] += face;
  }
  for (std::size_t k = 0; k < mesh.positions.size(); ++k) {
    Eigen::Vector3f& n = mesh.normals[k];
    const float length = n.norm();
    if (builder.needs_flat_normal[k] || !std::isfinite(length) || length < 1e-12f) {
      n = fallback[k];  // a split vertex belongs to one triangle: this is its face normal
    }
    const float fixed_length = n.norm();
    n = (std::isfinite(fixed_length) && fixed_length > 0.0f) ? Eigen::Vector3f(n / fixed_length)
                                                             : Eigen::Vector3f::UnitZ();
  }
  return std::move(builder.mesh);
}

// ---------------------------------------------------------------------------------------------
// glTF

std::size_t component_size(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_INT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: return 8;
    default: return 0;
  }
}

// One component of an accessor's element: a float as it is; an integer as it is, or normalised
// to [0, 1] (unsigned) or [-1, 1] (signed) when the accessor says so. Integer vertex data is
// glTF's KHR_mesh_quantization (texture coordinates may be normalised integers in glTF itself).
double component_value(const unsigned char* p, int type, bool normalized) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      float value = 0.0f;
      std::memcpy(&value, p, sizeof value);
      return value;
    }
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      const auto value = static_cast<double>(static_cast<std::int8_t>(p[0]));
      return normalized ? std::max(value / 127.0, -1.0) : value;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.0 : p[0];
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      std::int16_t value = 0;
      std::memcpy(&value, p, sizeof value);
      return normalized ? std::max(value / 32767.0, -1.0) : value;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      std::uint16_t value = 0;
      std::memcpy(&value, p, sizeof value);
      return normalized ? value / 65535.0 : value;
    }
    default: return 0.0;
  }
}

bool is_small_integer(int type) {
  return type == TINYGLTF_COMPONENT_TYPE_BYTE || type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
         type == TINYGLTF_COMPONENT_TYPE_SHORT || type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
}

// The extensions a model may require: each changes how its geometry is stored, and is read.
// Draco primitives are decoded here (draco_primitive.hpp; tinygltf reads them only after
// without_draco_indices), quantized accessors by component_value.
constexpr std::array<std::string_view, 2> kReadExtensions{"KHR_draco_mesh_compression", "KHR_mesh_quantization"};

class GltfReader {
 public:
  GltfReader(const tinygltf::Model& model, const fs::path& file) : model_(model), file_(file) {}

  Mesh read(UpAxis up, double scale) {
    for (const std::string& extension : model_.extensionsRequired) {
      if (std::find(kReadExtensions.begin(), kReadExtensions.end(), extension) == kReadExtensions.end()) {
        fail(file_, "the model requires the glTF extension '" + extension + "', which skylit does not read",
             "export it again without " + extension + " (skylit reads glTF 2.0 with KHR_draco_mesh_compression "
             "and KHR_mesh_quantization, e.g. gltf-transform draco or quantize)");
      }
    }
    quantized_ = std::find(model_.extensionsUsed.begin(), model_.extensionsUsed.end(), "KHR_mesh_quantization") !=
                 model_.extensionsUsed.end();
    const std::vector<int> image_texture = read_images();
    for (const tinygltf::Material& material : model_.materials) {
      Material m;
      m.name = material.name;
      const std::vector<double>& factor = material.pbrMetallicRoughness.baseColorFactor;
      if (factor.size() == 4) {
        m.base_colour = Eigen::Vector4d(factor[0], factor[1], factor[2], factor[3]).cast<float>();
      }
      const int texture = material.pbrMetallicRoughness.baseColorTexture.index;
      if (texture >= 0 && static_cast<std::size_t>(texture) < model_.textures.size()) {
        const int source = model_.textures[static_cast<std::size_t>(texture)].source;
        if (source >= 0 && static_cast<std::size_t>(source) < image_texture.size()) {
          m.base_colour_texture = image_texture[static_cast<std::size_t>(source)];
        }
      }
      builder_.mesh.materials.push_back(std::move(m));
    }

    std::vector<int> roots;
    if (!model_.scenes.empty()) {
      const int scene = model_.defaultScene >= 0 &&
                                static_cast<std::size_t>(model_.defaultScene) < model_.scenes.size()
                            ? model_.defaultScene
                            : 0;
      roots = model_.scenes[static_cast<std::size_t>(scene)].nodes;
    } else {  // no scene: every node that is nobody's child
      std::vector<bool> is_child(model_.nodes.size(), false);
      for (const tinygltf::Node& node : model_.nodes) {
        for (int child : node.children) {
          if (child >= 0 && static_cast<std::size_t>(child) < is_child.size()) {
            is_child[static_cast<std::size_t>(child)] = true;
          }
        }
      }
      for (std::size_t k = 0; k < model_.nodes.size(); ++k) {
        if (!is_child[k]) roots.push_back(static_cast<int>(k));
      }
    }
    on_path_.assign(model_.nodes.size(), false);
    for (int root : roots) visit(root, Eigen::Matrix4d::Identity());
    return finish(std::move(builder_), file_, up, scale);
  }

 private:
  [[noreturn]] void corrupt(const std::string& problem) const { fail(file_, problem, kExportFix); }

  // The decoded images as RGBA8 textures; per glTF image its texture index, or -1 when it was not
  // decoded (see lenient_image_loader).
  std::vector<int> read_images() {
    std::vector<int> index(model_.images.size(), -1);
    for (std::size_t k = 0; k < model_.images.size(); ++k) {
      const tinygltf::Image& image = model_.images[k];
      const int channels = image.component;
      const int bytes_per_channel = image.bits == 16 ? 2 : 1;
      const std::size_t pixels = static_cast<std::size_t>(std::max(0, image.width)) *
                                 static_cast<std::size_t>(std::max(0, image.height));
      if (pixels == 0 || channels < 1 || channels > 4 || (image.bits != 8 && image.bits != 16) ||
          image.image.size() != pixels * static_cast<std::size_t>(channels * bytes_per_channel)) {
        continue;
      }
      TextureImage texture;
      texture.name = image.name.empty() ? image.uri : image.name;
      texture.width = image.width;
      texture.height = image.height;
      texture.rgba.resize(pixels * 4);
      for (std::size_t p = 0; p < pixels; ++p) {
        std::uint8_t value[4] = {0, 0, 0, 255};
        for (int c = 0; c < channels; ++c) {
          // 16-bit samples are little-endian in tinygltf's buffer: the high byte is the second.
          const std::size_t at = (p * static_cast<std::size_t>(channels) + static_cast<std::size_t>(c)) *
                                 static_cast<std::size_t>(bytes_per_channel);
          value[c] = image.image[at + static_cast<std::size_t>(bytes_per_channel - 1)];
        }
        if (channels == 1 || channels == 2) {  // grey (and alpha): the grey goes to r, g and b
          value[3] = channels == 2 ? value[1] : std::uint8_t{255};
          value[1] = value[2] = value[0];
        }
        std::copy(value, value + 4, texture.rgba.begin() + static_cast<std::ptrdiff_t>(4 * p));
      }
      index[k] = static_cast<int>(builder_.mesh.textures.size());
      builder_.mesh.textures.push_back(std::move(texture));
    }
    return index;
  }

  // TEXCOORD_n as floats: float pairs, normalised unsigned bytes or shorts (glTF allows them), or
  // with KHR_mesh_quantization any byte or short, normalised or not.
  std::vector<Eigen::Vector2f> read_texcoords(int accessor_index, const std::string& what) const {
    if (accessor_index < 0 || static_cast<std::size_t>(accessor_index) >= model_.accessors.size()) {
      corrupt(what + " refers to a missing accessor");
    }
    const tinygltf::Accessor& accessor = model_.accessors[static_cast<std::size_t>(accessor_index)];
    const int type = accessor.componentType;
    const bool core_type = type == TINYGLTF_COMPONENT_TYPE_FLOAT || type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                           type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    if (accessor.type != TINYGLTF_TYPE_VEC2 || !(core_type || (quantized_ && is_small_integer(type)))) {
      corrupt(what + " is not a list of 2-vectors of floats or normalised unsigned integers"
                     " (or of any small integers, with KHR_mesh_quantization)");
    }
    const std::size_t size = component_size(type);
    // glTF itself allows only normalised unsigned integers here: read them as such.
    const bool normalized = accessor.normalized || (!quantized_ && type != TINYGLTF_COMPONENT_TYPE_FLOAT);
    std::vector<Eigen::Vector2f> values(accessor.count);
    for (std::size_t k = 0; k < accessor.count; ++k) {
      const unsigned char* p = element(accessor, 2 * size, k, what);
      for (std::size_t c = 0; c < 2; ++c) {
        values[k][static_cast<Eigen::Index>(c)] = static_cast<float>(component_value(p + size * c, type, normalized));
      }
    }
    return values;
  }

  static Eigen::Matrix4d local_transform(const tinygltf::Node& node) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    if (node.matrix.size() == 16) {
      for (int k = 0; k < 16; ++k) m(k % 4, k / 4) = node.matrix[static_cast<std::size_t>(k)];
      return m;
    }
    Eigen::Affine3d trs = Eigen::Affine3d::Identity();
    if (node.translation.size() == 3) {
      trs.translate(Eigen::Vector3d(node.translation[0], node.translation[1], node.translation[2]));
    }
    if (node.rotation.size() == 4) {  // glTF stores (x, y, z, w)
      trs.rotate(Eigen::Quaterniond(node.rotation[3], node.rotation[0], node.rotation[1],
                                    node.rotation[2])
                     .normalized());
    }
    if (node.scale.size() == 3) {
      trs.scale(Eigen::Vector3d(node.scale[0], node.scale[1], node.scale[2]));
    }
    return trs.matrix();
  }

  void visit(int index, const Eigen::Matrix4d& parent) {
    if (index < 0 || static_cast<std::size_t>(index) >= model_.nodes.size()) {
      corrupt("a scene refers to node " + std::to_string(index) + ", which does not exist");
    }
    const auto slot = static_cast<std::size_t>(index);
    if (on_path_[slot]) corrupt("node " + std::to_string(index) + " is its own ancestor");
    on_path_[slot] = true;
    const tinygltf::Node& node = model_.nodes[slot];
    const Eigen::Matrix4d world = parent * local_transform(node);
    if (node.mesh >= 0) add_mesh(node.mesh, world);
    for (int child : node.children) visit(child, world);
    on_path_[slot] = false;
  }

  // Pointer to element k of an accessor after bounds checks.
  const unsigned char* element(const tinygltf::Accessor& accessor, std::size_t element_size,
                               std::size_t k, const std::string& what) const {
    if (accessor.sparse.isSparse) corrupt(what + " uses a sparse accessor, which is not supported");
    if (accessor.bufferView < 0 ||
        static_cast<std::size_t>(accessor.bufferView) >= model_.bufferViews.size()) {
      corrupt(what + " has no buffer data");
    }
    const tinygltf::BufferView& view = model_.bufferViews[static_cast<std::size_t>(accessor.bufferView)];
    if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model_.buffers.size()) {
      corrupt(what + " refers to a missing buffer");
    }
    const std::vector<unsigned char>& data = model_.buffers[static_cast<std::size_t>(view.buffer)].data;
    const std::size_t stride = view.byteStride > 0 ? view.byteStride : element_size;
    const std::size_t begin = view.byteOffset + accessor.byteOffset + k * stride;
    if (begin + element_size > view.byteOffset + view.byteLength ||
        begin + element_size > data.size()) {
      corrupt(what + " reaches past the end of its buffer");
    }
    return data.data() + begin;
  }

  // The texture coordinates the primitive's material's base-colour texture reads (set 0 unless it
  // says); empty when it has none.
  int base_texcoord_set(const tinygltf::Primitive& primitive) const {
    if (primitive.material < 0 || static_cast<std::size_t>(primitive.material) >= model_.materials.size()) return -1;
    return std::max(0, model_.materials[static_cast<std::size_t>(primitive.material)].pbrMetallicRoughness.baseColorTexture.texCoord);
  }

  std::vector<Eigen::Vector2f> read_base_texcoords(const tinygltf::Primitive& primitive, std::size_t vertices,
                                                   const std::string& what) const {
    const int set = base_texcoord_set(primitive);
    if (set < 0) return {};
    const auto texcoord_it = primitive.attributes.find("TEXCOORD_" + std::to_string(set));
    if (texcoord_it == primitive.attributes.end()) return {};
    std::vector<Eigen::Vector2f> texcoords = read_texcoords(texcoord_it->second, what + " " + texcoord_it->first);
    if (texcoords.size() != vertices) corrupt(what + " has a different number of texture coordinates than positions");
    return texcoords;
  }

  // A KHR_draco_mesh_compression primitive: its buffer view checked, then decoded by Draco.
  DracoPrimitive read_draco(const tinygltf::Value& extension, const tinygltf::Primitive& primitive,
                            const std::string& what) const {
    const std::string where = what + " (KHR_draco_mesh_compression)";
    if (!extension.IsObject() || !extension.Get("bufferView").IsInt() || !extension.Get("attributes").IsObject()) {
      corrupt(where + " lacks its bufferView or attributes");
    }
    const int view_index = extension.Get("bufferView").GetNumberAsInt();
    if (view_index < 0 || static_cast<std::size_t>(view_index) >= model_.bufferViews.size()) {
      corrupt(where + " names buffer view " + std::to_string(view_index) + ", which does not exist");
    }
    const tinygltf::BufferView& view = model_.bufferViews[static_cast<std::size_t>(view_index)];
    if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model_.buffers.size()) {
      corrupt(where + " refers to a missing buffer");
    }
    const std::vector<unsigned char>& data = model_.buffers[static_cast<std::size_t>(view.buffer)].data;
    if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset) {
      corrupt(where + " reaches past the end of its buffer");
    }
    const tinygltf::Value& attributes = extension.Get("attributes");
    const auto id_of = [&](const std::string& name) {
      const tinygltf::Value& id = attributes.Get(name);
      if (!attributes.Has(name)) return -1;
      if (!id.IsInt() || id.GetNumberAsInt() < 0) corrupt(where + " gives " + name + " an id that is not a count");
      return id.GetNumberAsInt();
    };
    DracoAttributeIds ids;
    ids.position = id_of("POSITION");
    ids.normal = id_of("NORMAL");
    const int set = base_texcoord_set(primitive);
    if (set >= 0) ids.texcoord = id_of("TEXCOORD_" + std::to_string(set));
    try {
      return decode_draco_primitive(std::span(data).subspan(view.byteOffset, view.byteLength), ids);
    } catch (const std::runtime_error& e) {
      corrupt(where + ": " + e.what());
    }
  }

  // POSITION or NORMAL: float 3-vectors, or with KHR_mesh_quantization bytes or shorts, normalised
  // or not (the node's transform then scales them back to metres).
  std::vector<Eigen::Vector3d> read_vec3(int accessor_index, const std::string& what) const {
    if (accessor_index < 0 || static_cast<std::size_t>(accessor_index) >= model_.accessors.size()) {
      corrupt(what + " refers to a missing accessor");
    }
    const tinygltf::Accessor& accessor = model_.accessors[static_cast<std::size_t>(accessor_index)];
    const int type = accessor.componentType;
    if (accessor.type != TINYGLTF_TYPE_VEC3 ||
        (type != TINYGLTF_COMPONENT_TYPE_FLOAT && !(quantized_ && is_small_integer(type)))) {
      corrupt(what + " is not a list of float 3-vectors" +
              std::string(is_small_integer(type) ? " (integer components need the KHR_mesh_quantization extension)" : ""));
    }
    const std::size_t size = component_size(type);
    std::vector<Eigen::Vector3d> values(accessor.count);
    for (std::size_t k = 0; k < accessor.count; ++k) {
      const unsigned char* p = element(accessor, 3 * size, k, what);
      for (std::size_t c = 0; c < 3; ++c) {
        values[k][static_cast<Eigen::Index>(c)] = component_value(p + size * c, type, accessor.normalized);
      }
    }
    return values;
  }

  std::vector<std::uint32_t> read_indices(const tinygltf::Primitive& primitive,
                                          std::size_t vertex_count, const std::string& what) const {
    std::vector<std::uint32_t> indices;
    if (primitive.indices < 0) {  // non-indexed: the vertices in order
      indices.reserve(vertex_count);
      for (std::size_t k = 0; k < vertex_count; ++k) indices.push_back(static_cast<std::uint32_t>(k));
      return indices;
    }
    if (static_cast<std::size_t>(primitive.indices) >= model_.accessors.size()) {
      corrupt(what + " refers to a missing index accessor");
    }
    const tinygltf::Accessor& accessor = model_.accessors[static_cast<std::size_t>(primitive.indices)];
    const std::size_t size = component_size(accessor.componentType);
    if (accessor.type != TINYGLTF_TYPE_SCALAR ||
        (accessor.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
         accessor.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
         accessor.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)) {
      corrupt(what + " has indices that are not unsigned integers");
    }
    indices.reserve(accessor.count);
    for (std::size_t k = 0; k < accessor.count; ++k) {
      const unsigned char* p = element(accessor, size, k, what + " indices");
      std::uint32_t value = 0;
      if (size == 1) {
        value = *p;
      } else if (size == 2) {
        std::uint16_t v16 = 0;
        std::memcpy(&v16, p, 2);
        value = v16;
      } else {
        std::memcpy(&value, p, 4);
      }
      if (value >= vertex_count) corrupt(what + " has an index past its last vertex");
      indices.push_back(value);
    }
    return indices;
  }

  // Triangle corners (into the primitive's vertices) for the three triangle modes.
  static std::vector<std::uint32_t> triangles(int mode, const std::vector<std::uint32_t>& idx) {
    std::vector<std::uint32_t> out;
    if (mode == TINYGLTF_MODE_TRIANGLES || mode == -1) {
      out.assign(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(idx.size() / 3 * 3));
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (std::size_t k = 0; k + 2 < idx.size(); ++k) {
        if (k % 2 == 0) {
          out.insert(out.end(), {idx[k], idx[k + 1], idx[k + 2]});
        } else {
          out.insert(out.end(), {idx[k + 1], idx[k], idx[k + 2]});
        }
      }
    } else if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
      for (std::size_t k = 1; k + 1 < idx.size(); ++k) out.insert(out.end(), {idx[0], idx[k], idx[k + 1]});
    }
    return out;  // points and lines carry no surface
  }

  std::uint32_t material_index(int gltf_material) {
    if (gltf_material >= 0 && static_cast<std::size_t>(gltf_material) < model_.materials.size()) {
      return static_cast<std::uint32_t>(gltf_material);
    }
    if (!default_material_) {  // glTF's default material: white
      builder_.mesh.materials.push_back(Material{"default", Eigen::Vector4f::Ones()});
      default_material_ = static_cast<std::uint32_t>(builder_.mesh.materials.size() - 1);
    }
    return *default_material_;
  }

  void add_mesh(int mesh_index, const Eigen::Matrix4d& world) {
    if (static_cast<std::size_t>(mesh_index) >= model_.meshes.size()) {
      corrupt("a node refers to mesh " + std::to_string(mesh_index) + ", which does not exist");
    }
    const tinygltf::Mesh& gltf_mesh = model_.meshes[static_cast<std::size_t>(mesh_index)];
    const Eigen::Matrix3d linear = world.topLeftCorner<3, 3>();
    const Eigen::Matrix3d normal_matrix = linear.inverse().transpose();
    const bool mirrored = linear.determinant() < 0.0;  // glTF: a mirror flips the front faces

    // Primitives that share their vertex accessors share their vertices (one instance).
    std::map<std::pair<int, int>, std::uint32_t> shared_base;
    for (std::size_t p = 0; p < gltf_mesh.primitives.size(); ++p) {
      const tinygltf::Primitive& primitive = gltf_mesh.primitives[p];
      const std::string what = "mesh '" + gltf_mesh.name + "' primitive " + std::to_string(p);
      const auto position_it = primitive.attributes.find("POSITION");
      if (position_it == primitive.attributes.end()) continue;  // nothing to draw
      const auto normal_it = primitive.attributes.find("NORMAL");
      const int normal_accessor = normal_it == primitive.attributes.end() ? -1 : normal_it->second;

      const auto draco = primitive.extensions.find("KHR_draco_mesh_compression");
      std::vector<Eigen::Vector3d> positions;
      std::vector<Eigen::Vector3d> normals;
      std::vector<Eigen::Vector2f> texcoords;
      std::vector<std::uint32_t> corners;
      if (draco != primitive.extensions.end()) {
        DracoPrimitive decoded = read_draco(draco->second, primitive, what);
        positions = std::move(decoded.positions);
        normals = std::move(decoded.normals);
        texcoords = std::move(decoded.texcoords);
        corners = std::move(decoded.indices);
      } else {
        positions = read_vec3(position_it->second, what + " POSITION");
        if (normal_accessor >= 0) {
          normals = read_vec3(normal_accessor, what + " NORMAL");
          if (normals.size() != positions.size()) corrupt(what + " has fewer normals than positions");
        }
        corners = triangles(primitive.mode, read_indices(primitive, positions.size(), what));
        texcoords = read_base_texcoords(primitive, positions.size(), what);
      }
      if (corners.empty()) continue;
      const std::uint32_t material = material_index(primitive.material);
      auto texcoord_of = [&](std::size_t k) { return texcoords.empty() ? nullptr : &texcoords[k]; };

      auto transform_point = [&](std::size_t k) {
        return Eigen::Vector3d((world * positions[k].homogeneous()).head<3>());
      };
      if (!normals.empty()) {
        // A Draco primitive's vertices are its own: a key no accessor pair has.
        const auto key = draco != primitive.extensions.end() ? std::make_pair(-1 - static_cast<int>(p), -1)
                                                              : std::make_pair(position_it->second, normal_accessor);
        auto found = shared_base.find(key);
        if (found == shared_base.end()) {
          const auto base = static_cast<std::uint32_t>(builder_.mesh.positions.size());
          for (std::size_t k = 0; k < positions.size(); ++k) {
            const Eigen::Vector3d n = normal_matrix * normals[k];
            builder_.add_vertex(transform_point(k), &n, texcoord_of(k));
          }
          found = shared_base.emplace(key, base).first;
        }
        for (std::size_t t = 0; t + 2 < corners.size(); t += 3) {
          const std::uint32_t a = found->second + corners[t];
          const std::uint32_t b = found->second + corners[t + (mirrored ? 2 : 1)];
          const std::uint32_t c = found->second + corners[t + (mirrored ? 1 : 2)];
          builder_.add_triangle(a, b, c, material);
        }
      } else {
        for (std::size_t t = 0; t + 2 < corners.size(); t += 3) {
          const std::uint32_t corner_b = corners[t + (mirrored ? 2 : 1)];
          const std::uint32_t corner_c = corners[t + (mirrored ? 1 : 2)];
          const std::uint32_t a = builder_.add_vertex(transform_point(corners[t]), nullptr, texcoord_of(corners[t]));
          const std::uint32_t b = builder_.add_vertex(transform_point(corner_b), nullptr, texcoord_of(corner_b));
          const std::uint32_t c = builder_.add_vertex(transform_point(corner_c), nullptr, texcoord_of(corner_c));
          builder_.add_triangle(a, b, c, material);
        }
      }
    }
  }

  const tinygltf::Model& model_;
  const fs::path& file_;
  MeshBuilder builder_;
  std::vector<bool> on_path_;
  std::optional<std::uint32_t> default_material_;
  bool quantized_ = false;  // the model uses KHR_mesh_quantization
};

// Base-colour textures are decoded for the compositor (the baker ignores them). An image the
// decoder cannot read (an exotic format) must not make the model unusable for the baker: it is
// left empty, and read_images leaves it out.
bool lenient_image_loader(tinygltf::Image* image, const int image_index, std::string* error,
                          std::string* warning, int width, int height, const unsigned char* bytes,
                          int size, void* user_data) {
  std::string ignored;
  if (!tinygltf::LoadImageData(image, image_index, &ignored, warning, width, height, bytes, size,
                               user_data)) {
    image->image.clear();
    image->width = image->height = 0;
  }
  (void)error;
  return true;
}

// Drops the `indices` of every Draco primitive from glTF JSON; false when there were none. The
// indices are in the Draco data; tinygltf (Debian's, built without Draco) refuses their
// accessor, which has no buffer view.
bool drop_draco_indices(nlohmann::json& gltf) {
  bool changed = false;
  const auto meshes = gltf.find("meshes");
  if (meshes == gltf.end() || !meshes->is_array()) return false;
  for (nlohmann::json& mesh : *meshes) {
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
    for (nlohmann::json& primitive : mesh["primitives"]) {
      if (!primitive.is_object() || !primitive.contains("extensions") || !primitive["extensions"].is_object()) continue;
      if (primitive["extensions"].contains("KHR_draco_mesh_compression") && primitive.erase("indices") > 0) changed = true;
    }
  }
  return changed;
}

// The file's bytes as tinygltf is to read them: without the indices of Draco primitives (GLB:
// its JSON chunk rewritten, its binary chunk kept). Bytes that are not such a file go as they
// are (tinygltf then says what is wrong).
std::string readable_gltf(std::string bytes, bool binary) {
  constexpr std::uint32_t kJsonChunk = 0x4E4F534A;  // "JSON"
  std::size_t json_begin = 0;
  std::size_t json_size = bytes.size();
  if (binary) {
    if (bytes.size() < 20 || bytes.compare(0, 4, "glTF") != 0) return bytes;
    std::uint32_t chunk_size = 0;
    std::uint32_t chunk_type = 0;
    std::memcpy(&chunk_size, bytes.data() + 12, 4);
    std::memcpy(&chunk_type, bytes.data() + 16, 4);
    if (chunk_type != kJsonChunk || chunk_size > bytes.size() - 20) return bytes;
    json_begin = 20;
    json_size = chunk_size;
  }
  nlohmann::json gltf = nlohmann::json::parse(bytes.begin() + static_cast<std::ptrdiff_t>(json_begin),
                                              bytes.begin() + static_cast<std::ptrdiff_t>(json_begin + json_size),
                                              nullptr, false);
  if (gltf.is_discarded() || !drop_draco_indices(gltf)) return bytes;
  std::string json = gltf.dump();
  if (!binary) return json;
  json.append((4 - json.size() % 4) % 4, ' ');  // chunks are 4-byte aligned
  const std::string rest = bytes.substr(json_begin + json_size);
  std::string out = bytes.substr(0, 12);
  const auto json_length = static_cast<std::uint32_t>(json.size());
  out.append(reinterpret_cast<const char*>(&json_length), 4);
  out.append(reinterpret_cast<const char*>(&kJsonChunk), 4);
  out += json;
  out += rest;
  const auto total = static_cast<std::uint32_t>(out.size());
  std::memcpy(out.data() + 8, &total, 4);
  return out;
}

Mesh load_gltf(const fs::path& file, bool binary, UpAxis up, double scale) {
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(&lenient_image_loader, nullptr);
  tinygltf::Model model;
  std::string error;
  std::string warning;
  const std::string bytes = readable_gltf(read_file(file), binary);
  const std::string base_dir = file.parent_path().string();
  const bool ok =
      binary ? loader.LoadBinaryFromMemory(&model, &error, &warning, reinterpret_cast<const unsigned char*>(bytes.data()),
                                           static_cast<unsigned int>(bytes.size()), base_dir)
             : loader.LoadASCIIFromString(&model, &error, &warning, bytes.data(), static_cast<unsigned int>(bytes.size()),
                                          base_dir);
  if (!ok) {
    if (error.empty()) error = "unknown error";
    while (!error.empty() && (error.back() == '\n' || error.back() == '.')) error.pop_back();
    fail(file, "cannot read the glTF file: " + error, kExportFix);
  }
  return GltfReader(model, file).read(up, scale);
}

// ---------------------------------------------------------------------------------------------
// OBJ

Mesh load_obj(const fs::path& file, UpAxis up, double scale) {
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  config.mtl_search_path = file.parent_path().string();
  tinyobj::ObjReader reader;
  if (!reader.ParseFromFile(file.string(), config)) {
    std::string error = reader.Error().empty() ? "unknown error" : reader.Error();
    while (!error.empty() && (error.back() == '\n' || error.back() == '.')) error.pop_back();
    fail(file, "cannot read the OBJ file: " + error, kExportFix);
  }
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  MeshBuilder builder;
  for (const tinyobj::material_t& material : reader.GetMaterials()) {
    builder.mesh.materials.push_back(
        Material{material.name, Eigen::Vector4f(static_cast<float>(material.diffuse[0]),
                                                static_cast<float>(material.diffuse[1]),
                                                static_cast<float>(material.diffuse[2]),
                                                static_cast<float>(material.dissolve))});
  }
  std::optional<std::uint32_t> default_material;
  const std::size_t position_count = attrib.vertices.size() / 3;
  const std::size_t normal_count = attrib.normals.size() / 3;
  auto position = [&](int k) {
    if (k < 0 || static_cast<std::size_t>(k) >= position_count) {
      fail(file, "a face refers to vertex " + std::to_string(k + 1) + ", which does not exist",
           kExportFix);
    }
    const auto s = static_cast<std::size_t>(k) * 3;
    return Eigen::Vector3d(attrib.vertices[s], attrib.vertices[s + 1], attrib.vertices[s + 2]);
  };
  auto normal = [&](int k) {
    const auto s = static_cast<std::size_t>(k) * 3;
    return Eigen::Vector3d(attrib.normals[s], attrib.normals[s + 1], attrib.normals[s + 2]);
  };

  // Corners with the same (position, normal) pair share a vertex, in order of first use.
  std::map<std::pair<int, int>, std::uint32_t> shared;
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    std::size_t offset = 0;
    for (std::size_t face = 0; face < shape.mesh.num_face_vertices.size(); ++face) {
      const std::size_t corners = shape.mesh.num_face_vertices[face];
      if (corners != 3) {  // triangulation leaves only triangles; skip anything degenerate
        offset += corners;
        continue;
      }
      const tinyobj::index_t* corner = &shape.mesh.indices[offset];
      offset += corners;
      bool has_normals = true;
      for (int k = 0; k < 3; ++k) {
        if (corner[k].normal_index < 0 ||
            static_cast<std::size_t>(corner[k].normal_index) >= normal_count) {
          has_normals = false;
        }
      }
      const int obj_material =
          face < shape.mesh.material_ids.size() ? shape.mesh.material_ids[face] : -1;
      std::uint32_t material = 0;
      if (obj_material >= 0 && static_cast<std::size_t>(obj_material) < reader.GetMaterials().size()) {
        material = static_cast<std::uint32_t>(obj_material);
      } else {
        if (!default_material) {
          builder.mesh.materials.push_back(Material{"default", Eigen::Vector4f::Ones()});
          default_material = static_cast<std::uint32_t>(builder.mesh.materials.size() - 1);
        }
        material = *default_material;
      }
      std::uint32_t vertex[3];
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d p = position(corner[k].vertex_index);
        if (has_normals) {
          const auto key = std::make_pair(corner[k].vertex_index, corner[k].normal_index);
          auto found = shared.find(key);
          if (found == shared.end()) {
            const Eigen::Vector3d n = normal(corner[k].normal_index);
            found = shared.emplace(key, builder.add_vertex(p, &n)).first;
          }
          vertex[k] = found->second;
        } else {
          vertex[k] = builder.add_vertex(p, nullptr);
        }
      }
      builder.add_triangle(vertex[0], vertex[1], vertex[2], material);
    }
  }
  return finish(std::move(builder), file, up, scale);
}

}  // namespace

Mesh load_model(const std::filesystem::path& file, UpAxis up, double scale) {
  if (!std::isfinite(scale) || scale <= 0.0) {
    fail(file, "the scale " + std::to_string(scale) + " is not a positive number",
         "set scene.scale to the length of one model unit in metres");
  }
  std::error_code error;
  if (!fs::exists(file, error)) {
    fail(file, "the model file does not exist",
         "check scene.model in the site file (it is relative to the site file's directory)");
  }
  if (fs::is_directory(file, error)) {
    fail(file, "the model path is a directory, not a file", "point scene.model at the model file");
  }
  std::string extension = file.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".glb") return load_gltf(file, true, up, scale);
  if (extension == ".gltf") return load_gltf(file, false, up, scale);
  if (extension == ".obj") return load_obj(file, up, scale);
  fail(file, "unsupported model format '" + extension + "'",
       "export the model as glTF 2.0 (.glb or .gltf) or Wavefront OBJ (.obj)");
}

}  // namespace skylit::scene
