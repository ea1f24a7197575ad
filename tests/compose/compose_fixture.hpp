#pragma once
// A small site baked once per test program: a 4 m tower with a 1.5 m annex to its east, on real
// ground, with a virtual roof plane on the tower's top and a virtual wall plane on its south
// face. The tower has a textured material (a checker), the annex a plain one. An HMD camera with
// a distorting lens stands south of it, looking north and a little down.
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <string>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../support/fixture_cache.hpp"
#include "../support/quiet_bake.hpp"
#include "reference_composite.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/scene/mesh.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::compose_test {

namespace fs = std::filesystem;

struct Box {
  Vector3d low, high;
  std::uint32_t material = 0;
};

// Six faces of four own vertices each (flat normals), texcoords in metres / 2 (a texture repeats
// every 2 m), counter-clockwise from outside.
inline void add_box(scene::Mesh& mesh, const Box& box) {
  const Vector3d& a = box.low;
  const Vector3d& b = box.high;
  struct Face {
    Vector3d normal;
    std::array<Vector3d, 4> corners;
  };
  const std::array<Face, 6> faces{{
      {{1, 0, 0}, {{{b.x(), a.y(), a.z()}, {b.x(), b.y(), a.z()}, {b.x(), b.y(), b.z()}, {b.x(), a.y(), b.z()}}}},
      {{-1, 0, 0}, {{{a.x(), b.y(), a.z()}, {a.x(), a.y(), a.z()}, {a.x(), a.y(), b.z()}, {a.x(), b.y(), b.z()}}}},
      {{0, 1, 0}, {{{b.x(), b.y(), a.z()}, {a.x(), b.y(), a.z()}, {a.x(), b.y(), b.z()}, {b.x(), b.y(), b.z()}}}},
      {{0, -1, 0}, {{{a.x(), a.y(), a.z()}, {b.x(), a.y(), a.z()}, {b.x(), a.y(), b.z()}, {a.x(), a.y(), b.z()}}}},
      {{0, 0, 1}, {{{a.x(), a.y(), b.z()}, {b.x(), a.y(), b.z()}, {b.x(), b.y(), b.z()}, {a.x(), b.y(), b.z()}}}},
      {{0, 0, -1}, {{{a.x(), b.y(), a.z()}, {b.x(), b.y(), a.z()}, {b.x(), a.y(), a.z()}, {a.x(), a.y(), a.z()}}}},
  }};
  for (const Face& face : faces) {
    const auto first = static_cast<std::uint32_t>(mesh.positions.size());
    const Vector3d e1 = (face.corners[1] - face.corners[0]);
    const Vector3d e2 = (face.corners[3] - face.corners[0]);
    for (int k = 0; k < 4; ++k) {
      const Vector3d& corner = face.corners[static_cast<std::size_t>(k)];
      mesh.positions.push_back(corner.cast<float>());
      mesh.normals.push_back(face.normal.cast<float>());
      const Vector3d offset = corner - face.corners[0];
      mesh.texcoords.emplace_back(static_cast<float>(offset.dot(e1.normalized()) / 2.0),
                                  static_cast<float>(1.0 - offset.dot(e2.normalized()) / 2.0));
    }
    for (std::uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) mesh.indices.push_back(first + i);
    mesh.triangle_material.insert(mesh.triangle_material.end(), {box.material, box.material});
  }
}

// A 4×4 checker of two sRGB colours.
inline scene::TextureImage checker() {
  scene::TextureImage image;
  image.name = "checker";
  image.width = image.height = 4;
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 4; ++col) {
      const bool light = (row + col) % 2 == 0;
      const std::array<std::uint8_t, 4> rgba = light ? std::array<std::uint8_t, 4>{230, 220, 200, 255}
                                                     : std::array<std::uint8_t, 4>{120, 60, 40, 255};
      image.rgba.insert(image.rgba.end(), rgba.begin(), rgba.end());
    }
  }
  return image;
}

inline scene::Mesh tower_and_annex() {
  scene::Mesh mesh;
  mesh.materials = {scene::Material{"tower", {0.9f, 0.9f, 0.9f, 1.0f}, 0},
                    scene::Material{"annex", {0.3f, 0.5f, 0.7f, 1.0f}, -1}};
  mesh.textures = {checker()};
  add_box(mesh, {{-1, -1, 0}, {1, 1, 4}, 0});
  add_box(mesh, {{1, -1, 0}, {4, 1, 1.5}, 1});
  return mesh;
}

// The HMD camera: 320×240, a barrel-distorting pinhole lens, at (1.5, −9, 1.7) looking north,
// 10° down.
inline camera::CameraCalibration hmd_camera() {
  camera::CameraCalibration c;
  c.file = "hmd_test.yaml";
  c.image_width = 320;
  c.image_height = 240;
  c.model = camera::LensModel::Pinhole;
  c.fx = c.fy = 200.0;
  c.cx = 161.3;
  c.cy = 118.2;
  c.D = {-0.28, 0.09, 0.0008, -0.0005, -0.01};
  return c;
}

inline render::CameraPose hmd_pose(double x = 1.5, double y = -9.0, double z = 1.7, double pitch_deg = 10.0) {
  const double p = pitch_deg * std::numbers::pi / 180.0;
  const Vector3d forward(0, std::cos(p), -std::sin(p));
  const Vector3d right(1, 0, 0);
  const Vector3d down = forward.cross(right);
  render::CameraPose pose;
  pose.R_site_from_camera.col(0) = right;
  pose.R_site_from_camera.col(1) = down;
  pose.R_site_from_camera.col(2) = forward;
  pose.t_site_from_camera = Vector3d(x, y, z);
  return pose;
}

// Unit direction at elevation/azimuth (degrees, azimuth from north towards east).
inline Vector3d from_angles(double azimuth_deg, double elevation_deg) {
  const double az = azimuth_deg * std::numbers::pi / 180.0, el = elevation_deg * std::numbers::pi / 180.0;
  return {std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)};
}

// The baked site, shared by every test of the program (made on first use, kept on disk).
struct BakedSite {
  fs::path dir;
  scene::Site site;
  scene::Mesh mesh;
  bake_format::Manifest manifest;
  std::vector<float> transfer;
  std::vector<blend::BasisImages> basis;

  BakedSite() {
    mesh = tower_and_annex();
    // Made once per build of the test program and shared by its tests (read only).
    dir = test::cached_fixture("compose_site", [this](const fs::path& out) {
      scene::write_glb(mesh, out / "tower.glb");
      std::ofstream(out / "site.yaml") << "scene:\n  model: tower.glb\n  up: y\n  scale: 1\n"
                                          "dome:\n  frequency: 2\n"
                                          "planes:\n"
                                          "  - name: ground\n    origin: [-8, -8, 0.01]\n    u: [16, 0, 0]\n"
                                          "    v: [0, 16, 0]\n    resolution: [128, 128]\n    surface: real\n"
                                          "  - name: roof\n    origin: [-1, -1, 4.01]\n    u: [2, 0, 0]\n"
                                          "    v: [0, 2, 0]\n    resolution: [16, 16]\n"
                                          "  - name: wall\n    origin: [-1, -1.01, 0]\n    u: [2, 0, 0]\n"
                                          "    v: [0, 0, 4]\n    resolution: [16, 32]\n    surface: virtual\n";
      test::quiet_bake(out / "site.yaml", out / "bake");
    });
    manifest = bake_format::read_manifest(dir / "bake");
    site = scene::load_site(dir / "site.yaml");
    // The model as the bake saw it has the same vertex order as the mesh in memory, which keeps
    // its texcoords and texture (write_glb does not store them).
    const scene::Mesh loaded = scene::load_site_model(site);
    if (loaded.vertex_count() != mesh.vertex_count()) throw std::runtime_error("glb round trip changed the vertices");
    std::vector<std::size_t> shape;
    transfer = bake_format::read_npy(dir / "bake" / manifest.transfer_file, &shape);
    for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
      basis.push_back(blend::load_basis(dir / "bake", manifest, static_cast<int>(j)));
    }
  }
  BakedSite(const BakedSite&) = delete;
  BakedSite& operator=(const BakedSite&) = delete;

  // T of every plane for a sky, on the CPU (blend_cpu, with the sun's disc visibility ray-cast).
  std::vector<PlaneRatios> shadow_ratios(std::span<const Vector3d> sky, const std::optional<blend::SunLight>& sun,
                                         const std::vector<Vector3d>& disc_directions = {},
                                         const std::vector<double>& disc_weights = {}) const {
    std::vector<PlaneRatios> out;
    for (std::size_t j = 0; j < basis.size(); ++j) {
      const blend::BlendWeights weights = blend::blend_weights(basis[j], sky, sun);
      std::vector<float> visibility;
      if (!weights.sun.isZero()) {
        visibility.resize(basis[j].texel_count());
        if (disc_directions.empty()) {
          const std::vector<Vector3d> direction{sun->direction};
          const std::vector<double> weight{1.0};
          baker::area_light_visibility(mesh, manifest.planes[j].plane, direction, weight, visibility);
        } else {
          baker::area_light_visibility(mesh, manifest.planes[j].plane, disc_directions, disc_weights, visibility);
        }
      }
      PlaneRatios ratios{basis[j].width, basis[j].height, std::vector<float>(basis[j].texel_count() * 3)};
      blend::blend_cpu(basis[j], weights, visibility, ratios.rgb);
      out.push_back(std::move(ratios));
    }
    return out;
  }

  static const BakedSite& get() {
    static const std::unique_ptr<BakedSite> site = std::make_unique<BakedSite>();
    return *site;
  }
};

// Statistics of |GPU − reference| over the pixels of a mask.
struct Difference {
  double mean = 0;
  double max = 0;
  double fraction_off = 0;  // pixels with a channel off by more than absolute + relative × reference
  std::int64_t pixels = 0;
};

inline Difference compare(const cv::Mat& gpu, const cv::Mat& reference, const cv::Mat& mask, double absolute,
                          double relative) {
  Difference d;
  std::int64_t off = 0;
  double sum = 0;
  for (int y = 0; y < gpu.rows; ++y) {
    for (int x = 0; x < gpu.cols; ++x) {
      if (!mask.empty() && mask.at<std::uint8_t>(y, x) == 0) continue;
      const cv::Vec3f g = gpu.at<cv::Vec3f>(y, x);
      const cv::Vec3f r = reference.at<cv::Vec3f>(y, x);
      bool pixel_off = false;
      for (int c = 0; c < 3; ++c) {
        const double e = std::abs(static_cast<double>(g[c]) - r[c]);
        sum += e;
        d.max = std::max(d.max, e);
        if (e > absolute + relative * std::abs(r[c])) pixel_off = true;
      }
      off += pixel_off ? 1 : 0;
      ++d.pixels;
    }
  }
  d.mean = d.pixels > 0 ? sum / (3.0 * static_cast<double>(d.pixels)) : 0.0;
  d.fraction_off = d.pixels > 0 ? static_cast<double>(off) / static_cast<double>(d.pixels) : 0.0;
  return d;
}

// Where SKYLIT_TEST_OUTPUT names a directory, tests write their pictures there (to look at):
// 8-bit images as they are, linear float ones sRGB-encoded.
inline void save_picture(const std::string& name, const cv::Mat& image) {
  const char* dir = std::getenv("SKYLIT_TEST_OUTPUT");
  if (dir == nullptr || *dir == '\0') return;
  cv::Mat out = image;
  if (image.depth() == CV_32F) {
    out = cv::Mat(image.size(), CV_8UC3);
    for (int y = 0; y < image.rows; ++y) {
      for (int x = 0; x < image.cols; ++x) {
        const cv::Vec3f p = image.at<cv::Vec3f>(y, x);
        for (int c = 0; c < 3; ++c) {
          const double v = std::clamp(static_cast<double>(p[c]), 0.0, 1.0);
          out.at<cv::Vec3b>(y, x)[c] = static_cast<std::uint8_t>(std::lround(255.0 * srgb_encode(std::isfinite(v) ? v : 0.0)));
        }
      }
    }
  }
  cv::imwrite((fs::path(dir) / (name + ".png")).string(), out);
}

}  // namespace skylit::compose_test
