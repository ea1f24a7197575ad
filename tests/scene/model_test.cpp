#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>
#include <string>
#include <tuple>

#include <Eigen/Geometry>

#include "skylit/base/error.hpp"
#include "skylit/scene/mesh.hpp"
#include "../support/temp_dir.hpp"

namespace skylit::scene {
namespace {

using skylit::test::TempDir;
using Eigen::Vector3f;

// Unit cube [0,1]³ as an OBJ: 8 vertices, 6 quads counter-clockwise seen from outside.
const std::string kCubeVertices =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
const std::string kCubeFacesFlat =
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
const std::string kCubeWithNormals =
    kCubeVertices +
    "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 1 0 0\nvn 0 1 0\nvn -1 0 0\n"
    "f 1//1 4//1 3//1 2//1\nf 5//2 6//2 7//2 8//2\nf 1//3 2//3 6//3 5//3\n"
    "f 2//4 3//4 7//4 6//4\nf 3//5 4//5 8//5 7//5\nf 4//6 1//6 5//6 8//6\n";

Vector3f face_normal(const Mesh& mesh, std::size_t t) {
  const Vector3f& a = mesh.positions[mesh.indices[3 * t]];
  const Vector3f& b = mesh.positions[mesh.indices[3 * t + 1]];
  const Vector3f& c = mesh.positions[mesh.indices[3 * t + 2]];
  return (b - a).cross(c - a).normalized();
}

Vector3f centroid(const Mesh& mesh, std::size_t t) {
  return (mesh.positions[mesh.indices[3 * t]] + mesh.positions[mesh.indices[3 * t + 1]] +
          mesh.positions[mesh.indices[3 * t + 2]]) /
         3.0f;
}

// Every triangle of a convex solid around `centre`: winding and stored normals point outward and
// agree, and the normal is one of the six axis directions.
void expect_outward_axis_cube(const Mesh& mesh, const Vector3f& centre) {
  ASSERT_EQ(mesh.triangle_count(), 12u);
  ASSERT_EQ(mesh.normals.size(), mesh.positions.size());
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vector3f n = face_normal(mesh, t);
    EXPECT_GT(n.dot(centroid(mesh, t) - centre), 0.0f) << "triangle " << t << " faces inward";
    EXPECT_NEAR(n.cwiseAbs().maxCoeff(), 1.0f, 1e-6f);
    for (int c = 0; c < 3; ++c) {
      const Vector3f& stored = mesh.normals[mesh.indices[3 * t + static_cast<std::size_t>(c)]];
      EXPECT_NEAR((stored - n).norm(), 0.0f, 1e-6f) << "triangle " << t;
    }
  }
}

TEST(LoadModel, ObjCubeWithoutNormalsGetsFlatNormalsOnSplitVertices) {
  TempDir dir;
  const auto file = dir.write("cube.obj", kCubeVertices + kCubeFacesFlat);
  const Mesh mesh = load_model(file, UpAxis::Z, 1.0);
  EXPECT_EQ(mesh.vertex_count(), 36u);  // three own vertices per triangle: hard edges
  expect_outward_axis_cube(mesh, Vector3f(0.5f, 0.5f, 0.5f));
  EXPECT_EQ(mesh.bounds_min(), Vector3f(0, 0, 0));
  EXPECT_EQ(mesh.bounds_max(), Vector3f(1, 1, 1));
  ASSERT_EQ(mesh.triangle_material.size(), 12u);
  ASSERT_EQ(mesh.materials.size(), 1u);  // the default material
  EXPECT_EQ(mesh.materials[0].base_colour, Eigen::Vector4f::Ones());
}

TEST(LoadModel, ObjCubeWithNormalsSharesVerticesPerNormal) {
  TempDir dir;
  const auto file = dir.write("cube.obj", kCubeWithNormals);
  const Mesh mesh = load_model(file, UpAxis::Z, 1.0);
  EXPECT_EQ(mesh.vertex_count(), 24u);  // one per (corner, face normal) pair
  expect_outward_axis_cube(mesh, Vector3f(0.5f, 0.5f, 0.5f));
}

TEST(LoadModel, ObjMaterialsComeFromTheMtlFile) {
  TempDir dir;
  dir.write("cube.mtl", "newmtl red\nKd 0.8 0.1 0.05\nd 1\nnewmtl blue\nKd 0 0 1\n");
  const auto file =
      dir.write("cube.obj", "mtllib cube.mtl\n" + kCubeVertices +
                                "usemtl blue\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\n"
                                "usemtl red\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n");
  const Mesh mesh = load_model(file, UpAxis::Z, 1.0);
  ASSERT_EQ(mesh.materials.size(), 2u);
  EXPECT_EQ(mesh.materials[0].name, "red");
  EXPECT_TRUE(mesh.materials[0].base_colour.isApprox(Eigen::Vector4f(0.8f, 0.1f, 0.05f, 1.0f)));
  ASSERT_EQ(mesh.triangle_material.size(), 12u);
  EXPECT_EQ(mesh.triangle_material[0], 1u);   // blue
  EXPECT_EQ(mesh.triangle_material[11], 0u);  // red
}

TEST(LoadModel, UpAxisYRotatesModelMinusZToNorthAndScales) {
  TempDir dir;
  const auto file = dir.write("tri.obj", "v 0 0 0\nv 0 1 0\nv 0 0 -1\nv 1 0 0\nf 1 4 2\nf 1 3 4\n");
  const Mesh z_up = load_model(file, UpAxis::Z, 1.0);
  const Mesh y_up = load_model(file, UpAxis::Y, 1.0);
  const Mesh scaled = load_model(file, UpAxis::Y, 2.5);
  ASSERT_EQ(y_up.vertex_count(), 6u);
  // Vertex order is kept: split vertices in face order 1 4 2, 1 3 4.
  EXPECT_EQ(z_up.positions[2], Vector3f(0, 1, 0));
  EXPECT_EQ(y_up.positions[2], Vector3f(0, 0, 1));   // model up → site up
  EXPECT_EQ(y_up.positions[4], Vector3f(0, 1, 0));   // model −z → site north (+y)
  EXPECT_EQ(y_up.positions[1], Vector3f(1, 0, 0));   // x stays east
  EXPECT_EQ(scaled.positions[2], Vector3f(0, 0, 2.5f));
  EXPECT_EQ(scaled.positions[4], Vector3f(0, 2.5f, 0));
  // Triangle 1 4 2 lies in the model's xy plane facing +z (towards the viewer): in the site it
  // faces south (−y). The rotation is proper, so the flat normal agrees with the winding.
  EXPECT_NEAR((y_up.normals[0] - Vector3f(0, -1, 0)).norm(), 0.0f, 1e-7f);
  EXPECT_NEAR((scaled.normals[0] - Vector3f(0, -1, 0)).norm(), 0.0f, 1e-7f);
}

// A hand-written glTF with an external .bin: one triangle without normals or indices, placed by
// a node transform, optionally mirrored.
std::filesystem::path write_triangle_gltf(const TempDir& dir, const std::string& name,
                                          const std::string& node, float x_of_third = 0.0f) {
  const std::array<float, 9> xyz = {0, 0, 0, 1, 0, 0, x_of_third, 1, 0};
  std::string bin(sizeof xyz, '\0');
  std::memcpy(bin.data(), xyz.data(), sizeof xyz);
  dir.write(name + ".bin", bin);
  const std::string json = R"({"asset": {"version": "2.0"}, "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"children": [1], "translation": [0, 0, -2]}, )" + node + R"(],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
    "materials": [{"name": "stone", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 0.125, 1]}}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [-1, 0, 0], "max": [1, 1, 0]}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "buffers": [{"byteLength": 36, "uri": ")" + name + R"(.bin"}]})";
  return dir.write(name + ".gltf", json);
}

TEST(LoadModel, GltfNodeTransformsUpAxisAndFlatNormals) {
  TempDir dir;
  const auto file = write_triangle_gltf(dir, "tri", R"({"mesh": 0, "scale": [2, 2, 2]})");
  const Mesh mesh = load_model(file, UpAxis::Y, 1.0);
  ASSERT_EQ(mesh.vertex_count(), 3u);
  // Model: T(0,0,−2)·S(2): (0,0,−2), (2,0,−2), (0,2,−2); site (x, −z, y).
  EXPECT_NEAR((mesh.positions[0] - Vector3f(0, 2, 0)).norm(), 0.0f, 1e-6f);
  EXPECT_NEAR((mesh.positions[1] - Vector3f(2, 2, 0)).norm(), 0.0f, 1e-6f);
  EXPECT_NEAR((mesh.positions[2] - Vector3f(0, 2, 2)).norm(), 0.0f, 1e-6f);
  for (const Vector3f& n : mesh.normals) EXPECT_NEAR((n - Vector3f(0, -1, 0)).norm(), 0.0f, 1e-6f);
  ASSERT_EQ(mesh.materials.size(), 1u);
  EXPECT_EQ(mesh.materials[0].name, "stone");
  EXPECT_EQ(mesh.materials[0].base_colour, Eigen::Vector4f(0.5f, 0.25f, 0.125f, 1.0f));
}

TEST(LoadModel, GltfYUpPointLandsOnSiteUp) {
  TempDir dir;
  const auto file = write_triangle_gltf(dir, "tri", R"({"mesh": 0, "translation": [0, 0, 2]})");
  const Mesh mesh = load_model(file, UpAxis::Y, 1.0);  // parent −2 and child +2 cancel
  EXPECT_NEAR((mesh.positions[2] - Vector3f(0, 0, 1)).norm(), 0.0f, 1e-7f);  // (0,1,0) model
}

TEST(LoadModel, GltfMirroringNodeKeepsFrontFacesOutward) {
  TempDir dir;
  // Rotation of 90° about model y, then a mirror in x: a front face stays a front face.
  const auto file = write_triangle_gltf(
      dir, "tri", R"({"mesh": 0, "rotation": [0, 0.7071067811865476, 0, 0.7071067811865476],
                      "scale": [-1, 1, 1]})");
  const Mesh mesh = load_model(file, UpAxis::Z, 1.0);
  // Model normal +z; R_y(90°)·diag(−1,1,1)·(0,0,1) = R_y(90°)·(0,0,1) = (1,0,0).
  for (const Vector3f& n : mesh.normals) EXPECT_NEAR((n - Vector3f(1, 0, 0)).norm(), 0.0f, 1e-6f);
  EXPECT_NEAR((face_normal(mesh, 0) - Vector3f(1, 0, 0)).norm(), 0.0f, 1e-6f);
}

// A 2×2 RGBA PNG: red, green on the top row; blue, white at half alpha on the bottom row.
const std::array<unsigned char, 76> kTinyPng = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52,
    0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x02, 0x08, 0x06, 0x00, 0x00, 0x00, 0x72, 0xb6, 0x0d,
    0x24, 0x00, 0x00, 0x00, 0x13, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0xf8, 0xcf, 0xc0, 0xf0,
    0x1f, 0x0c, 0x81, 0x34, 0x08, 0x34, 0x00, 0x00, 0x49, 0x49, 0x09, 0x78, 0x28, 0xa0, 0xdb, 0x77,
    0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};

// A textured quad: 4 shared vertices (positions, normals, TEXCOORD_1 as normalised bytes, set 1
// named by the material), 2 indexed triangles; `image` is the PNG's uri.
std::filesystem::path write_textured_quad_gltf(const TempDir& dir, const std::string& image) {
  const std::array<float, 12> xyz = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  const std::array<float, 12> normals = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
  const std::array<std::uint8_t, 8> uv = {0, 255, 255, 255, 255, 0, 0, 0};
  const std::array<std::uint16_t, 6> index = {0, 1, 2, 0, 2, 3};
  std::string bin(48 + 48 + 8 + 12, '\0');
  std::memcpy(bin.data(), xyz.data(), 48);
  std::memcpy(bin.data() + 48, normals.data(), 48);
  std::memcpy(bin.data() + 96, uv.data(), 8);
  std::memcpy(bin.data() + 104, index.data(), 12);
  dir.write("quad.bin", bin);
  dir.write("tiles.png", std::string(kTinyPng.begin(), kTinyPng.end()));
  const std::string json = R"({"asset": {"version": "2.0"}, "scene": 0,
    "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_1": 2},
                                "indices": 3, "material": 0}]}],
    "materials": [{"name": "tiles", "pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 1, 1],
                   "baseColorTexture": {"index": 0, "texCoord": 1}}}],
    "textures": [{"source": 0}],
    "images": [{"uri": ")" + image + R"("}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
      {"bufferView": 2, "componentType": 5121, "normalized": true, "count": 4, "type": "VEC2"},
      {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                    {"buffer": 0, "byteOffset": 48, "byteLength": 48},
                    {"buffer": 0, "byteOffset": 96, "byteLength": 8},
                    {"buffer": 0, "byteOffset": 104, "byteLength": 12}],
    "buffers": [{"byteLength": 116, "uri": "quad.bin"}]})";
  return dir.write("quad.gltf", json);
}

TEST(LoadModel, GltfTexcoordsAndBaseColourTextureKeepVertexOrder) {
  TempDir dir;
  const Mesh mesh = load_model(write_textured_quad_gltf(dir, "tiles.png"), UpAxis::Z, 1.0);
  ASSERT_EQ(mesh.vertex_count(), 4u);  // shared vertices, in file order
  EXPECT_EQ(mesh.positions[1], Vector3f(1, 0, 0));
  ASSERT_EQ(mesh.texcoords.size(), 4u);
  EXPECT_EQ(mesh.texcoords[0], Eigen::Vector2f(0, 1));
  EXPECT_EQ(mesh.texcoords[2], Eigen::Vector2f(1, 0));
  ASSERT_EQ(mesh.materials.size(), 1u);
  EXPECT_EQ(mesh.materials[0].base_colour, Eigen::Vector4f(1, 0.5f, 1, 1));
  ASSERT_EQ(mesh.materials[0].base_colour_texture, 0);
  ASSERT_EQ(mesh.textures.size(), 1u);
  const TextureImage& texture = mesh.textures[0];
  ASSERT_EQ(texture.width, 2);
  ASSERT_EQ(texture.height, 2);
  // Rows from the top of the picture: red, green; blue, white at alpha 128.
  const std::vector<std::uint8_t> expected = {255, 0, 0, 255, 0, 255, 0, 255,
                                              0, 0, 255, 255, 255, 255, 255, 128};
  EXPECT_EQ(texture.rgba, expected);
}

TEST(LoadModel, UndecodableTextureIsLeftOutNotAnError) {
  TempDir dir;
  dir.write("broken.png", "not a png at all");
  const Mesh mesh = load_model(write_textured_quad_gltf(dir, "broken.png"), UpAxis::Z, 1.0);
  EXPECT_EQ(mesh.vertex_count(), 4u);
  EXPECT_TRUE(mesh.textures.empty());
  EXPECT_EQ(mesh.materials[0].base_colour_texture, -1);
  EXPECT_EQ(mesh.texcoords.size(), 4u);
}

TEST(LoadModel, ModelsWithoutTexcoordsHaveNone) {
  TempDir dir;
  EXPECT_TRUE(load_model(write_triangle_gltf(dir, "tri", R"({"mesh": 0})"), UpAxis::Y, 1.0).texcoords.empty());
  EXPECT_TRUE(load_model(dir.write("cube.obj", kCubeWithNormals), UpAxis::Z, 1.0).texcoords.empty());
}

Mesh two_material_mesh() {
  Mesh mesh;
  mesh.materials = {Material{"red", {1.0f, 0.0f, 0.0f, 1.0f}},
                    Material{"grey", {0.25f, 0.25f, 0.25f, 0.5f}}};
  // A tetrahedron with shared corners and smooth normals, then a second one far away.
  for (float offset : {0.0f, 10.0f}) {
    const auto base = static_cast<std::uint32_t>(mesh.positions.size());
    const std::array<Vector3f, 4> corners = {Vector3f(0, 0, 0), Vector3f(1, 0, 0),
                                             Vector3f(0, 1, 0), Vector3f(0, 0, 1)};
    for (const Vector3f& c : corners) {
      mesh.positions.push_back(c + Vector3f(offset, -offset / 3, offset / 7));
      mesh.normals.push_back((c - Vector3f(0.25f, 0.25f, 0.25f)).normalized());
    }
    const std::uint32_t faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    for (std::size_t f = 0; f < 4; ++f) {
      mesh.indices.insert(mesh.indices.end(),
                          {base + faces[f][0], base + faces[f][1], base + faces[f][2]});
      mesh.triangle_material.push_back(offset == 0.0f ? 1u : 0u);
    }
  }
  return mesh;
}

TEST(WriteGlb, RoundTripKeepsPositionsNormalsAndMaterials) {
  TempDir dir;
  const Mesh mesh = two_material_mesh();
  const auto file = dir.path() / "out.glb";
  write_glb(mesh, file);
  std::ifstream in(file, std::ios::binary);
  char magic[4] = {};
  in.read(magic, 4);
  EXPECT_EQ(std::string(magic, 4), "glTF");

  const Mesh back = load_model(file, UpAxis::Y, 1.0);
  ASSERT_EQ(back.vertex_count(), mesh.vertex_count());
  for (std::size_t k = 0; k < mesh.vertex_count(); ++k) {
    EXPECT_LE((back.positions[k] - mesh.positions[k]).norm(), 1e-5f) << k;
    EXPECT_LE((back.normals[k] - mesh.normals[k]).norm(), 1e-5f) << k;
  }
  ASSERT_EQ(back.materials.size(), 2u);
  for (std::size_t m = 0; m < 2; ++m) {
    EXPECT_EQ(back.materials[m].name, mesh.materials[m].name);
    EXPECT_EQ(back.materials[m].base_colour, mesh.materials[m].base_colour);
  }
  // One primitive per material: triangles come back grouped by material, each one unchanged.
  using Triangle = std::tuple<std::uint32_t, std::uint32_t, std::uint32_t, std::uint32_t>;
  auto triangles = [](const Mesh& m) {
    std::multiset<Triangle> set;
    for (std::size_t t = 0; t < m.triangle_count(); ++t) {
      set.emplace(m.indices[3 * t], m.indices[3 * t + 1], m.indices[3 * t + 2],
                  m.triangle_material[t]);
    }
    return set;
  };
  EXPECT_EQ(triangles(back), triangles(mesh));
  EXPECT_EQ(back.triangle_material.front(), 0u);
  EXPECT_EQ(back.triangle_material.back(), 1u);
}

TEST(WriteGlb, RejectsInconsistentMeshes) {
  TempDir dir;
  Mesh mesh = two_material_mesh();
  mesh.triangle_material.back() = 7;
  EXPECT_THROW(write_glb(mesh, dir.path() / "bad.glb"), std::invalid_argument);
  EXPECT_THROW(write_glb(Mesh{}, dir.path() / "empty.glb"), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "bad.glb"));
}

// The message names the file and says `expected`.
void expect_model_error(const std::filesystem::path& file, const std::string& expected,
                        UpAxis up = UpAxis::Z, double scale = 1.0) {
  SCOPED_TRACE(file.filename().string());
  try {
    (void)load_model(file, up, scale);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(file.string()), std::string::npos) << message;
    EXPECT_NE(message.find(expected), std::string::npos) << message;
    EXPECT_NE(message.find("Fix: "), std::string::npos) << message;
  }
}

TEST(LoadModel, BadFilesAreInputErrors) {
  TempDir dir;
  expect_model_error(dir.path() / "missing.glb", "does not exist");
  expect_model_error(dir.write("empty.glb", ""), "cannot read the glTF file");
  expect_model_error(dir.write("garbage.glb", std::string(200, '\x7f')), "cannot read the glTF file");
  expect_model_error(dir.write("broken.gltf", "{\"asset\": {\"version\": "), "cannot read the glTF file");
  expect_model_error(dir.write("empty.obj", ""), "the model has no triangles");
  expect_model_error(dir.write("lines.obj", "v 0 0 0\nv 1 0 0\nl 1 2\n"), "the model has no triangles");
  expect_model_error(dir.write("model.fbx", "Kaydara FBX Binary"), "unsupported model format '.fbx'");
  std::filesystem::create_directories(dir.path() / "folder.obj");
  expect_model_error(dir.path() / "folder.obj", "directory");
  expect_model_error(dir.write("cube.obj", kCubeVertices + kCubeFacesFlat), "scale", UpAxis::Z, 0.0);

  // A glTF whose indices point past its vertices, and one with a NaN position.
  const auto no_mesh = write_triangle_gltf(dir, "nomesh", R"({"name": "empty node"})");
  expect_model_error(no_mesh, "the model has no triangles");
  const auto nan = write_triangle_gltf(dir, "nan", R"({"mesh": 0})",
                                       std::numeric_limits<float>::quiet_NaN());
  expect_model_error(nan, "non-finite position");
  // A damaged vertex that is finite but absurd (it once reached the ray tracer's assertions).
  const auto far = write_triangle_gltf(dir, "far", R"({"mesh": 0})", 3.0e37f);
  expect_model_error(far, "km from the site's origin");
}

TEST(LoadModel, LoadsAreDeterministic) {
  TempDir dir;
  const auto file = dir.write("cube.obj", kCubeWithNormals);
  const Mesh a = load_model(file, UpAxis::Y, 1.0);
  const Mesh b = load_model(file, UpAxis::Y, 1.0);
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.indices, b.indices);
}

}  // namespace
}  // namespace skylit::scene
