// glTF as pipelines export it: the sample gate compressed with Draco and quantized by
// gltf-transform (data/models/README.md) loads as the plain gate.glb within the compression's
// stated precision; a required extension skylit does not read is refused by name.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::scene {
namespace {

namespace fs = std::filesystem;
const fs::path kModels = fs::path(SKYLIT_SOURCE_DIR) / "data" / "models";

// The largest distance from a point of `from` to the nearest point of `to`.
double farthest_nearest(const std::vector<Eigen::Vector3f>& from, const std::vector<Eigen::Vector3f>& to) {
  double farthest = 0.0;
  for (const Eigen::Vector3f& p : from) {
    float nearest = std::numeric_limits<float>::infinity();
    for (const Eigen::Vector3f& q : to) nearest = std::min(nearest, (p - q).squaredNorm());
    farthest = std::max(farthest, static_cast<double>(std::sqrt(nearest)));
  }
  return farthest;
}

std::vector<Eigen::Vector3f> centroids(const Mesh& mesh) {
  std::vector<Eigen::Vector3f> out;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    out.push_back((mesh.positions[mesh.indices[3 * t]] + mesh.positions[mesh.indices[3 * t + 1]] +
                   mesh.positions[mesh.indices[3 * t + 2]]) / 3.0f);
  }
  return out;
}

double area(const Mesh& mesh) {
  double total = 0.0;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Eigen::Vector3f& a = mesh.positions[mesh.indices[3 * t]];
    total += 0.5 * (mesh.positions[mesh.indices[3 * t + 1]] - a).cross(mesh.positions[mesh.indices[3 * t + 2]] - a).norm();
  }
  return total;
}

class CompressedGate : public ::testing::TestWithParam<const char*> {};

TEST_P(CompressedGate, LoadsAsThePlainGateWithinItsQuantizationStep) {
  const Mesh plain = load_model(kModels / "gate.glb", UpAxis::Y, 1.0);
  const Mesh compressed = load_model(kModels / GetParam(), UpAxis::Y, 1.0);
  // 14-bit positions over the bounding box's largest side: a corner moves by at most one step
  // (the rounding gives half a step along each axis; gltf-transform's mapping onto normalised
  // shorts adds a little: 1.48 mm of a 1.62 mm step on the gate).
  const double extent = (plain.bounds_max() - plain.bounds_min()).maxCoeff();
  const double step = extent / ((1 << 14) - 1);
  const double tolerance = step;
  ASSERT_EQ(compressed.triangle_count(), plain.triangle_count());
  const double vertices_out = farthest_nearest(compressed.positions, plain.positions);
  const double vertices_in = farthest_nearest(plain.positions, compressed.positions);
  const double triangles = std::max(farthest_nearest(centroids(compressed), centroids(plain)),
                                    farthest_nearest(centroids(plain), centroids(compressed)));
  std::printf("measured: %s: vertices within %.2f mm and %.2f mm, triangle centres within %.2f mm "
              "(a step of %.2f mm), area %.4f of the plain gate's\n",
              GetParam(), 1e3 * vertices_out, 1e3 * vertices_in, 1e3 * triangles, 1e3 * step, area(compressed) / area(plain));
  EXPECT_LE(vertices_out, tolerance);
  EXPECT_LE(vertices_in, tolerance);
  EXPECT_LE(triangles, tolerance);
  EXPECT_NEAR(area(compressed) / area(plain), 1.0, 1e-3);
  EXPECT_LE((compressed.bounds_min() - plain.bounds_min()).cwiseAbs().maxCoeff(), tolerance);
  EXPECT_LE((compressed.bounds_max() - plain.bounds_max()).cwiseAbs().maxCoeff(), tolerance);
  // Normals (10 bits): every triangle keeps its orientation.
  for (std::size_t t = 0; t < compressed.triangle_count(); ++t) {
    const Eigen::Vector3f& a = compressed.positions[compressed.indices[3 * t]];
    const Eigen::Vector3f face = (compressed.positions[compressed.indices[3 * t + 1]] - a)
                                     .cross(compressed.positions[compressed.indices[3 * t + 2]] - a);
    if (face.norm() < 1e-6f) continue;
    for (int c = 0; c < 3; ++c) {
      EXPECT_GT(compressed.normals[compressed.indices[3 * t + static_cast<std::size_t>(c)]].dot(face.normalized()), 0.99f)
          << GetParam() << " triangle " << t;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Exports, CompressedGate, ::testing::Values("gate_draco.glb", "gate_quantized.glb"));

TEST(LoadModel, ARequiredExtensionSkylitDoesNotReadIsRefusedByName) {
  test::TempDir dir;
  // A triangle whose file says it cannot be read without meshopt's decoder.
  const fs::path file = dir.write("meshopt.gltf", R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["EXT_meshopt_compression"],
    "extensionsRequired": ["EXT_meshopt_compression"],
    "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "nodes": [{"mesh": 0}],
    "scenes": [{"nodes": [0]}]
  })");
  const std::string message = test::error_of([&] { (void)load_model(file, UpAxis::Y, 1.0); });
  EXPECT_NE(message.find("EXT_meshopt_compression"), std::string::npos) << message;
  EXPECT_NE(message.find("KHR_draco_mesh_compression"), std::string::npos) << message;
  EXPECT_NE(message.find(file.string()), std::string::npos) << message;
}

}  // namespace
}  // namespace skylit::scene
