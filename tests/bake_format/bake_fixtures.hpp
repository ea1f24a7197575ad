#pragma once
// Shared by the bake format tests: the tests' temporary directory and a small synthetic bake.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/pca.hpp"
#include "../support/temp_dir.hpp"

namespace skylit::bake_format::test {

namespace fs = std::filesystem;

// PcaOptions with one criterion (designated initializers would leave the others to a warning).
inline PcaOptions pca_components(int k) {
  PcaOptions o;
  o.components = k;
  return o;
}
inline PcaOptions pca_variance(double fraction) {
  PcaOptions o;
  o.variance = fraction;
  return o;
}
inline PcaOptions pca_max_error(double bound) {
  PcaOptions o;
  o.max_error = bound;
  return o;
}

using skylit::test::TempDir;

inline geom::Plane make_plane(std::string name, geom::Vec3 origin, geom::Vec3 u, geom::Vec3 v, int width,
                              int height) {
  geom::Plane p;
  p.name = std::move(name);
  p.origin = origin;
  p.u = u;
  p.v = v;
  p.width = width;
  p.height = height;
  return p;
}

// A plan with awkward doubles (not exact in decimal, tiny, huge, negative).
inline Plan sample_plan() {
  Plan plan;
  plan.site_file = "/sites/temple/site.yaml";
  plan.site_sha256 = std::string(64, 'a');
  plan.model_file = "/sites/temple/temple.glb";
  plan.model_sha256 = std::string(64, 'b');
  plan.frequency = 2;
  plan.samples = 16;
  plan.method = "raytrace";
  plan.shadow_map_resolution = 0;
  plan.planes.push_back(make_plane("ground", {-10.0 / 3.0, 0.1, 1e-300}, {20.0 / 3.0, 0.0, 0.0},
                                   {0.0, 12.7, 0.0}, 8, 6));
  plan.planes.push_back(make_plane("wall", {1.0, -2.5e10, 0.3}, {0.0, 5.0, 0.0}, {0.0, 0.0, std::numbers::pi},
                                   5, 4));
  plan.vertex_count = 3;
  plan.triangle_count = 1;
  return plan;
}

// B for plane j, face i, texel t: within [0, A_{j,i}], distinct per texel so orientation errors show.
inline float sample_basis(std::size_t plane, int face, std::size_t texel) {
  return static_cast<float>(std::fmod(0.37 * static_cast<double>(texel) + 0.11 * face + 0.5 * plane, 1.0) *
                            (2.0 * std::numbers::pi / 40.0) * 0.5);
}

// A complete, valid bake of sample_plan() on a ν=2 dome (40 faces of equal solid angle 2π/40),
// written with the library's own writers, with one layer per face (faces) or three (corners).
// Returns its manifest as written.
inline Manifest write_synthetic_bake(const fs::path& dir, geom::DomeBasis basis = geom::DomeBasis::Faces) {
  Manifest m;
  m.generator = "skylit-bake test";
  m.created_utc = "2024-06-21T12:00:00Z";
  m.plan = sample_plan();
  m.plan.basis = basis;
  const int faces = 10 * m.plan.frequency * m.plan.frequency;
  const int n = faces * geom::layers_per_face(basis);  // layers
  const double omega = 2.0 * std::numbers::pi / faces;
  for (int i = 0; i < faces; ++i) {
    FaceRecord f;
    f.index = i;
    const double azimuth = 2.0 * std::numbers::pi * i / faces;
    f.direction = geom::Vec3(std::cos(azimuth), std::sin(azimuth), 0.5).normalized();
    f.solid_angle = omega;
    f.vertices = {geom::Vec3(0, 0, 1), geom::Vec3(std::cos(azimuth), std::sin(azimuth), 0),
                  geom::Vec3(-std::sin(azimuth), std::cos(azimuth), 0)};
    f.neighbours = {(i + 1) % faces, (i + faces - 1) % faces, -1};
    m.faces.push_back(f);
  }
  const std::vector<std::string> names = layer_names(basis, faces);
  fs::create_directories(dir / "planes");
  for (std::size_t j = 0; j < m.plan.planes.size(); ++j) {
    const geom::Plane& p = m.plan.planes[j];
    PlaneRecord r;
    r.plane = p;
    r.file = "planes/" + p.name + ".exr";
    for (int i = 0; i < n; ++i) r.unoccluded.push_back(omega * (0.25 + 0.5 * i / n));
    ImageStack stack;
    stack.width = p.width;
    stack.height = p.height;
    stack.layers = n;
    stack.data.resize(static_cast<std::size_t>(p.width * p.height * n));
    for (int i = 0; i < n; ++i) {
      std::span<float> layer = stack.layer(i);
      for (std::size_t t = 0; t < layer.size(); ++t) layer[t] = sample_basis(j, i, t);
    }
    write_exr_stack(dir / r.file, stack, names);
    m.files.push_back({r.file, 0, ""});
    m.planes.push_back(std::move(r));
  }
  const std::size_t vertices = m.plan.vertex_count;
  std::vector<float> transfer(vertices * static_cast<std::size_t>(n));
  for (std::size_t k = 0; k < transfer.size(); ++k) transfer[k] = static_cast<float>(0.001 * static_cast<double>(k));
  const std::size_t transfer_shape[] = {vertices, static_cast<std::size_t>(n)};
  write_npy(dir / m.transfer_file, transfer, transfer_shape);
  std::vector<float> positions(vertices * 6, 0.5f);
  const std::size_t vertices_shape[] = {vertices, 6};
  write_npy(dir / m.vertices_file, positions, vertices_shape);
  m.files.push_back({m.transfer_file, 0, ""});
  m.files.push_back({m.vertices_file, 0, ""});
  m.bake_seconds = 12.5;
  m.finalize_seconds = 0.25;
  write_manifest(dir, m);
  return m;
}

inline void flip_byte(const fs::path& file, std::uintmax_t offset) {
  std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(static_cast<std::streamoff>(offset));
  char c = 0;
  f.read(&c, 1);
  c = static_cast<char>(c ^ 0x5a);
  f.seekp(static_cast<std::streamoff>(offset));
  f.write(&c, 1);
}

}  // namespace skylit::bake_format::test
