// The PLY writer, read back field by field: the header a viewer needs, the vertices' positions,
// normals, colours and float properties, and the triangles, in binary little-endian.
#include "skylit/scene/ply.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../support/temp_dir.hpp"

namespace {

namespace scene = skylit::scene;

scene::Mesh two_triangles() {
  scene::Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.5f}, {0, 1, -2}};
  mesh.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0.6f, 0.8f}, {1, 0, 0}};
  mesh.indices = {0, 1, 2, 0, 2, 3};
  return mesh;
}

template <typename T>
T take(const std::string& bytes, std::size_t& at) {
  T value;
  std::memcpy(&value, bytes.data() + at, sizeof(T));
  at += sizeof(T);
  return value;
}

TEST(Ply, WritesWhatItIsGivenAsBinaryLittleEndian) {
  skylit::test::TempDir dir("ply");
  const scene::Mesh mesh = two_triangles();
  const std::vector<std::array<std::uint8_t, 3>> colours{{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {10, 20, 30}};
  const std::vector<scene::VertexProperty> properties{{"irradiance_r", {1.5f, 2.5f, 3.5f, 4.5f}},
                                                      {"sun_visibility", {0, 0.25f, 1, 0.5f}}};
  scene::write_ply(dir.path() / "m.ply", mesh, colours, properties);
  std::ifstream in(dir.path() / "m.ply", std::ios::binary);
  const std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t end = all.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  const std::string header = all.substr(0, end);
  EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(header.find("element vertex 4\n"), std::string::npos);
  EXPECT_NE(header.find("property uchar red\nproperty uchar green\nproperty uchar blue\n"), std::string::npos);
  EXPECT_NE(header.find("property float irradiance_r\nproperty float sun_visibility\n"), std::string::npos);
  EXPECT_NE(header.find("element face 2\nproperty list uchar uint vertex_indices\n"), std::string::npos);
  std::size_t at = end + std::strlen("end_header\n");
  for (std::size_t v = 0; v < 4; ++v) {
    for (int k = 0; k < 3; ++k) EXPECT_EQ(take<float>(all, at), mesh.positions[v][k]);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(take<float>(all, at), mesh.normals[v][k]);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(take<std::uint8_t>(all, at), colours[v][static_cast<std::size_t>(k)]);
    EXPECT_EQ(take<float>(all, at), properties[0].values[v]);
    EXPECT_EQ(take<float>(all, at), properties[1].values[v]);
  }
  for (std::size_t t = 0; t < 2; ++t) {
    EXPECT_EQ(take<std::uint8_t>(all, at), 3);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(take<std::uint32_t>(all, at), mesh.indices[3 * t + static_cast<std::size_t>(k)]);
  }
  EXPECT_EQ(at, all.size()) << "nothing after the last face";
}

TEST(Ply, RefusesColumnsThatDoNotFit) {
  skylit::test::TempDir dir("ply");
  const scene::Mesh mesh = two_triangles();
  const std::vector<std::array<std::uint8_t, 3>> three(3);
  EXPECT_THROW(scene::write_ply(dir.path() / "a.ply", mesh, three, {}), std::invalid_argument);
  const std::vector<scene::VertexProperty> short_column{{"e", {1, 2}}};
  EXPECT_THROW(scene::write_ply(dir.path() / "b.ply", mesh, {}, short_column), std::invalid_argument);
  const std::vector<scene::VertexProperty> spaced{{"two words", {1, 2, 3, 4}}};
  EXPECT_THROW(scene::write_ply(dir.path() / "c.ply", mesh, {}, spaced), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "a.ply"));
  scene::write_ply(dir.path() / "d.ply", mesh, {}, {});  // positions, normals and faces alone
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "d.ply"));
}

}  // namespace
