#include "draco_primitive.hpp"

#include <stdexcept>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>

namespace skylit::scene {
namespace {

// The attribute with `id`, of `components` components; nullptr for id -1.
const draco::PointAttribute* attribute(const draco::Mesh& mesh, int id, int components, const char* name) {
  if (id < 0) return nullptr;
  const draco::PointAttribute* found = mesh.GetAttributeByUniqueId(static_cast<std::uint32_t>(id));
  if (found == nullptr) {
    throw std::runtime_error(std::string("its Draco data has no attribute ") + std::to_string(id) + " for " + name);
  }
  if (found->num_components() != components) {
    throw std::runtime_error(std::string("its Draco ") + name + " has " + std::to_string(found->num_components()) +
                             " components, not " + std::to_string(components));
  }
  return found;
}

template <int N>
Eigen::Matrix<double, N, 1> value_at(const draco::PointAttribute& a, draco::PointIndex point) {
  float value[N] = {};
  if (!a.ConvertValue<float>(a.mapped_index(point), static_cast<std::int8_t>(N), value)) {
    throw std::runtime_error("its Draco data holds a value that is no number");
  }
  Eigen::Matrix<double, N, 1> out;
  for (int c = 0; c < N; ++c) out[c] = value[c];
  return out;
}

}  // namespace

DracoPrimitive decode_draco_primitive(std::span<const unsigned char> data, const DracoAttributeIds& ids) {
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(data.data()), data.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) throw std::runtime_error("its Draco data does not decode: " + decoded.status().error_msg_string());
  const draco::Mesh& mesh = *decoded.value();

  const draco::PointAttribute* position = attribute(mesh, ids.position, 3, "POSITION");
  if (position == nullptr) throw std::runtime_error("its Draco extension names no POSITION");
  const draco::PointAttribute* normal = attribute(mesh, ids.normal, 3, "NORMAL");
  const draco::PointAttribute* texcoord = attribute(mesh, ids.texcoord, 2, "TEXCOORD");

  DracoPrimitive out;
  const std::uint32_t points = mesh.num_points();
  out.positions.reserve(points);
  for (draco::PointIndex p(0); p < points; ++p) {
    out.positions.push_back(value_at<3>(*position, p));
    if (normal) out.normals.push_back(value_at<3>(*normal, p));
    if (texcoord) out.texcoords.push_back(value_at<2>(*texcoord, p).cast<float>());
  }
  out.indices.reserve(3 * static_cast<std::size_t>(mesh.num_faces()));
  for (draco::FaceIndex f(0); f < mesh.num_faces(); ++f) {
    for (int corner = 0; corner < 3; ++corner) {
      const std::uint32_t index = mesh.face(f)[corner].value();
      if (index >= points) throw std::runtime_error("its Draco data has a triangle past its last vertex");
      out.indices.push_back(index);
    }
  }
  return out;
}

}  // namespace skylit::scene
