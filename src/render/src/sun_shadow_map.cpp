// The separated sources' shadow maps and the visibility of the planes and vertices (see
// sun_shadow_map.hpp). The depth pass is the baker's (shaders/shadow_depth.*, same slope-scaled
// offset); the visibility passes are compute shaders over plane texels and mesh vertices
// (shaders/sun_visibility.comp, source_vertex_visibility.comp, both with sun_shadow.glsl).
#include "skylit/render/sun_shadow_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <cstring>
#include <string>

#include <Eigen/Geometry>

#include "skylit/base/error.hpp"
#include "skylit/gpu/shader.hpp"

namespace skylit::render {
namespace {

constexpr int kGroupSize = 8;  // sun_visibility.comp's local size, both axes
constexpr int kVertexGroupSize = 64;  // source_vertex_visibility.comp's local size
// Slope-scaled depth offset of the depth pass, as the baker's raster engine: the comparison at
// a point uses the depth at the nearest texel centre, up to half a texel away.
constexpr float kPolygonOffsetFactor = 2.0f;
constexpr float kPolygonOffsetUnits = 4.0f;

[[noreturn]] void bad_input(const std::string& field, const std::string& problem, const std::string& fix) {
  throw InputError(input_message({}, -1, -1, field, problem, fix));
}

GLint max_integer(GLenum name) {
  GLint value = 0;
  glGetIntegerv(name, &value);
  return value;
}

void set_plane_uniform(GLuint program, const char* name, const Eigen::Vector3d& value) {
  const GLint location = glGetUniformLocation(program, name);
  if (location < 0) {
    throw gpu::GlError(std::string("sun shadow map: sun_visibility.comp has no uniform '") + name +
                       "' (shader files from another version of skylit?)");
  }
  glUniform3f(location, static_cast<float>(value.x()), static_cast<float>(value.y()), static_cast<float>(value.z()));
}

}  // namespace

SunShadowMap::SunShadowMap(const scene::Mesh& mesh, std::span<const geom::Plane> planes, const SunShadowOptions& options)
    : options_(options) {
  const GLint max_size = max_integer(GL_MAX_TEXTURE_SIZE);
  if (options_.resolution < 16 || options_.resolution > max_size) {
    bad_input("sun shadow resolution", std::to_string(options_.resolution) + " is outside 16 … " + std::to_string(max_size),
              "choose a resolution the driver supports (2048 is typical)");
  }
  if (!std::isfinite(options_.bias_texels) || options_.bias_texels < 0.0) {
    bad_input("sun shadow bias_texels", "is not finite and >= 0", "use about 1.5");
  }
  if (options_.max_sources < 1 || options_.max_sources > blend::kMaxGpuSources) {
    bad_input("sun shadow max_sources", std::to_string(options_.max_sources) + " is outside 1 … " +
                                            std::to_string(blend::kMaxGpuSources),
              "draw between 1 (the sun alone) and " + std::to_string(blend::kMaxGpuSources) + " separated sources");
  }
  if (mesh.normals.size() != mesh.positions.size()) {
    bad_input("mesh", "has " + std::to_string(mesh.normals.size()) + " normals for " +
                          std::to_string(mesh.positions.size()) + " vertices",
              "load the model with load_model (it computes missing normals)");
  }
  if (mesh.indices.size() % 3 != 0) bad_input("mesh", "index count is not a multiple of 3", "load the model with load_model");
  for (const std::uint32_t index : mesh.indices) {
    if (index >= mesh.positions.size()) {
      bad_input("mesh", "index " + std::to_string(index) + " is past the last vertex", "load the model with load_model");
    }
  }
  if (mesh.positions.size() > static_cast<std::size_t>(std::numeric_limits<GLsizei>::max()) ||
      mesh.indices.size() > static_cast<std::size_t>(std::numeric_limits<GLsizei>::max())) {
    bad_input("mesh", "is too large for one draw", "simplify the model");
  }

  // The site's bounds: the mesh and every plane.
  bounds_min_.setConstant(std::numeric_limits<double>::infinity());
  bounds_max_.setConstant(-std::numeric_limits<double>::infinity());
  const auto include = [this](const Eigen::Vector3d& p) {
    bounds_min_ = bounds_min_.cwiseMin(p);
    bounds_max_ = bounds_max_.cwiseMax(p);
  };
  for (const Eigen::Vector3f& p : mesh.positions) include(p.cast<double>());
  for (const geom::Plane& plane : planes) {
    if (plane.width <= 0 || plane.height <= 0) {
      bad_input("plane '" + plane.name + "'", "has no texels", "give the plane a resolution");
    }
    include(plane.origin);
    include(plane.origin + plane.u);
    include(plane.origin + plane.v);
    include(plane.origin + plane.u + plane.v);
  }
  if (!bounds_min_.allFinite() || !bounds_max_.allFinite()) {
    bounds_min_.setZero();  // nothing at all: a tiny map, everything lit
    bounds_max_.setConstant(1.0);
  }

  const std::filesystem::path shader_dir = gpu::find_shader_dir(options_.shader_dir);
  depth_program_ = gpu::load_program(shader_dir, {"shadow_depth.vert", "shadow_depth.frag"});
  visibility_program_ = gpu::load_program(shader_dir, {"sun_visibility.comp"});
  minmax_program_ = gpu::load_program(shader_dir, {"sun_shadow_minmax.comp"});
  vertex_program_ = gpu::load_program(shader_dir, {"source_vertex_visibility.comp"});

  vertex_array_ = gpu::make_vertex_array();
  glBindVertexArray(vertex_array_.get());
  position_buffer_ = gpu::make_buffer();
  glBindBuffer(GL_ARRAY_BUFFER, position_buffer_.get());
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.positions.size() * 3 * sizeof(float)),
               mesh.positions.empty() ? nullptr : mesh.positions.data(), GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  index_buffer_ = gpu::make_buffer();
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, index_buffer_.get());
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.indices.size() * sizeof(std::uint32_t)),
               mesh.indices.empty() ? nullptr : mesh.indices.data(), GL_STATIC_DRAW);
  index_count_ = static_cast<GLsizei>(mesh.indices.size());
  glBindVertexArray(0);
  vertex_count_ = static_cast<GLsizei>(mesh.positions.size());
  normal_buffer_ = gpu::make_buffer();
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, normal_buffer_.get());
  glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(std::max<std::size_t>(mesh.normals.size(), 1) * 3 * sizeof(float)),
               mesh.normals.empty() ? nullptr : mesh.normals.data(), GL_STATIC_DRAW);
  vertex_visibility_ = gpu::make_buffer();
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, vertex_visibility_.get());
  glBufferData(GL_SHADER_STORAGE_BUFFER,
               static_cast<GLsizeiptr>(std::max<std::size_t>(mesh.positions.size(), 1) *
                                       static_cast<std::size_t>(options_.max_sources) * sizeof(float)),
               nullptr, GL_DYNAMIC_READ);
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, 0);

  depth_texture_ = gpu::make_texture();
  glBindTexture(GL_TEXTURE_2D, depth_texture_.get());
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_DEPTH_COMPONENT32F, options_.resolution, options_.resolution);
  // Raw depth through texelFetch: the library does its own comparisons and filtering.
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_NONE);
  framebuffer_ = gpu::make_framebuffer();

  // The minimum/maximum pyramid's atlas (shaders/sun_shadow_minmax.comp): level 0 of blocks of
  // 8 × 8 map texels, its side rounded up to a power of two so that every level halves exactly,
  // down to one texel for the whole map; the levels above it in a column to its right.
  minmax_size_ = 1;
  minmax_levels_ = 1;
  while (8 * minmax_size_ < options_.resolution) {
    minmax_size_ *= 2;
    ++minmax_levels_;
  }
  minmax_texture_ = gpu::make_texture();
  glBindTexture(GL_TEXTURE_2D, minmax_texture_.get());
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, minmax_size_ + std::max(minmax_size_ / 2, 1), minmax_size_);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);

  for (const geom::Plane& plane : planes) {
    PlaneTarget target;
    target.plane = plane;
    target.texture = gpu::make_texture();
    glBindTexture(GL_TEXTURE_2D_ARRAY, target.texture.get());
    glTexStorage3D(GL_TEXTURE_2D_ARRAY, 1, GL_R32F, plane.width, plane.height, options_.max_sources);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    target.visibility = {target.texture.get(), plane.width, plane.height, 0, options_.max_sources};
    planes_.push_back(std::move(target));
  }
  gpu::check_gl_error("sun shadow map: setup");
}

void SunShadowMap::update(const Eigen::Vector3d& direction, double angular_radius) {
  const ShadowSource sun{direction, angular_radius};
  update(std::span<const ShadowSource>(&sun, 1));
}

void SunShadowMap::update(std::span<const ShadowSource> sources) {
  if (sources.empty() || sources.size() > static_cast<std::size_t>(options_.max_sources)) {
    bad_input("sources", std::to_string(sources.size()) + " separated sources; this map draws 1 … " +
                             std::to_string(options_.max_sources),
              "raise SunShadowOptions::max_sources (live: sky.max_sources), or pass fewer sources");
  }
  for (std::size_t k = 0; k < sources.size(); ++k) {
    const std::string name = k == 0 ? std::string("sun") : "sources[" + std::to_string(k) + "]";
    const double length = sources[k].direction.norm();
    if (!sources[k].direction.allFinite() || !(length > 0.0)) {
      bad_input(name + ".direction", "is zero or not finite", "pass a vector towards the source, site frame");
    }
    const double radius = sources[k].angular_radius;
    if (!std::isfinite(radius) || radius < 0.0 || radius >= 0.5) {
      bad_input(name + ".angular_radius", std::to_string(radius) + " rad is not in [0, 0.5)",
                "pass the disc's angular radius in radians (the sun's is 0.0047)");
    }
  }
  // The last drawn stays in the depth map: source 0's, which sampling() and bind() describe.
  ++revision_;
  for (std::size_t k = sources.size(); k-- > 0;) sampling_ = draw_source(sources[k], static_cast<int>(k));
  source_count_ = static_cast<int>(sources.size());
  for (PlaneTarget& target : planes_) target.visibility.revision = revision_;
  // The blend (texelFetch), a framebuffer read, image loads and buffer reads see the new values.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT |
                  GL_TEXTURE_UPDATE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
  gpu::check_gl_error("sun shadow map: visibility passes");
}

// One source: its depth map, pyramid, and visibility into layer `layer` of every plane's
// texture and of the vertices' values; returns how to sample its map.
SunShadowSampling SunShadowMap::draw_source(const ShadowSource& source, int layer) {
  const Eigen::Vector3d w = source.direction.normalized();
  const double angular_radius = source.angular_radius;

  // Orthographic view along -w fitted to the corners of the site's bounds: x, y across, depth
  // growing away from the sun; square texels.
  const Eigen::Vector3d helper = std::abs(w.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d right = helper.cross(w).normalized();
  const Eigen::Vector3d up = w.cross(right);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d p((corner & 1) ? bounds_max_.x() : bounds_min_.x(), (corner & 2) ? bounds_max_.y() : bounds_min_.y(),
                            (corner & 4) ? bounds_max_.z() : bounds_min_.z());
    const Eigen::Vector3d light(p.dot(right), p.dot(up), -p.dot(w));
    lo = lo.cwiseMin(light);
    hi = hi.cwiseMax(light);
  }
  const double resolution = options_.resolution;
  // Two texels of margin on each side, so that filtering at the edge of the site reads the site.
  const double extent = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1e-3});
  const double side = extent * resolution / (resolution - 4.0);
  const double depth_margin = 0.01 * (hi.z() - lo.z()) + 1e-3;
  const double near = lo.z() - depth_margin;
  const double far = hi.z() + depth_margin;
  const Eigen::Vector2d centre = 0.5 * (lo.head<2>() + hi.head<2>());
  Eigen::Matrix4d clip = Eigen::Matrix4d::Identity();
  clip.block<1, 3>(0, 0) = 2.0 * right.transpose() / side;
  clip(0, 3) = -2.0 * centre.x() / side;
  clip.block<1, 3>(1, 0) = 2.0 * up.transpose() / side;
  clip(1, 3) = -2.0 * centre.y() / side;
  clip.block<1, 3>(2, 0) = -2.0 * w.transpose() / (far - near);
  clip(2, 3) = -2.0 * near / (far - near) - 1.0;
  Eigen::Matrix4d shadow_from_clip = Eigen::Matrix4d::Identity() * 0.5;
  shadow_from_clip(3, 3) = 1.0;
  shadow_from_clip.block<3, 1>(0, 3).setConstant(0.5);

  SunShadowSampling sampling;
  sampling.depth_texture = depth_texture_.get();
  sampling.shadow_from_world = (shadow_from_clip * clip).cast<float>();
  sampling.direction = w.cast<float>();
  sampling.texel_m = static_cast<float>(side / resolution);
  sampling.depth_range_m = static_cast<float>(far - near);
  sampling.tan_angular_radius = static_cast<float>(std::tan(angular_radius));
  sampling.bias_m = static_cast<float>(options_.bias_texels * side / resolution);
  sampling.minmax_texture = minmax_texture_.get();

  // Depth pass.
  GLint previous_framebuffer = 0;
  glGetIntegerv(GL_FRAMEBUFFER_BINDING, &previous_framebuffer);
  std::array<GLint, 4> previous_viewport{};
  glGetIntegerv(GL_VIEWPORT, previous_viewport.data());
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.get());
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_texture_.get(), 0);
  const GLenum none = GL_NONE;
  glDrawBuffers(1, &none);
  glReadBuffer(GL_NONE);
  gpu::check_framebuffer_complete(GL_FRAMEBUFFER, "sun shadow map: depth target");
  glViewport(0, 0, options_.resolution, options_.resolution);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_CULL_FACE);  // both sides of a wall cast shadows
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(kPolygonOffsetFactor, kPolygonOffsetUnits);
  glClearDepthf(1.0f);
  glClear(GL_DEPTH_BUFFER_BIT);
  glUseProgram(depth_program_.get());
  const Eigen::Matrix4f clip_floats = clip.cast<float>();
  glUniformMatrix4fv(glGetUniformLocation(depth_program_.get(), "clip_from_world"), 1, GL_FALSE, clip_floats.data());
  glBindVertexArray(vertex_array_.get());
  if (index_count_ > 0) glDrawElements(GL_TRIANGLES, index_count_, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  glDisable(GL_POLYGON_OFFSET_FILL);
  glDisable(GL_DEPTH_TEST);
  glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(previous_framebuffer));
  glViewport(previous_viewport[0], previous_viewport[1], previous_viewport[2], previous_viewport[3]);
  gpu::check_gl_error("sun shadow map: depth pass");

  // The minimum/maximum pyramid, level after level.
  const GLuint minmax = minmax_program_.get();
  glUseProgram(minmax);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, depth_texture_.get());
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, minmax_texture_.get());
  glActiveTexture(GL_TEXTURE0);
  glUniform1i(glGetUniformLocation(minmax, "depth_map"), 0);
  glUniform1i(glGetUniformLocation(minmax, "atlas"), 1);
  glBindImageTexture(0, minmax_texture_.get(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA32F);
  const auto level_origin = [this](int level) {
    return level == 0 ? Eigen::Vector2i(0, 0) : Eigen::Vector2i(minmax_size_, minmax_size_ - (minmax_size_ >> (level - 1)));
  };
  for (int level = 0; level < minmax_levels_; ++level) {
    const int size = minmax_size_ >> level;
    const Eigen::Vector2i from = level_origin(std::max(level - 1, 0));
    const Eigen::Vector2i target = level_origin(level);
    glUniform1i(glGetUniformLocation(minmax, "from_depth"), level == 0 ? 1 : 0);
    glUniform2i(glGetUniformLocation(minmax, "source_origin"), from.x(), from.y());
    glUniform2i(glGetUniformLocation(minmax, "target_origin"), target.x(), target.y());
    glUniform1i(glGetUniformLocation(minmax, "target_size"), size);
    const auto groups = static_cast<GLuint>((size + kGroupSize - 1) / kGroupSize);
    glDispatchCompute(groups, groups, 1);
    glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);
  }
  gpu::check_gl_error("sun shadow map: minimum/maximum pyramid");

  // Visibility of every plane texel, into this source's layer.
  glUseProgram(visibility_program_.get());
  bind_sampling(visibility_program_.get(), sampling, 0, 1);
  for (PlaneTarget& target : planes_) {
    const geom::Plane& plane = target.plane;
    set_plane_uniform(visibility_program_.get(), "plane_origin", plane.origin);
    set_plane_uniform(visibility_program_.get(), "plane_u", plane.u);
    set_plane_uniform(visibility_program_.get(), "plane_v", plane.v);
    glBindImageTexture(0, target.texture.get(), 0, GL_FALSE, layer, GL_WRITE_ONLY, GL_R32F);
    glDispatchCompute(static_cast<GLuint>((plane.width + kGroupSize - 1) / kGroupSize),
                      static_cast<GLuint>((plane.height + kGroupSize - 1) / kGroupSize), 1);
  }

  // Visibility at every mesh vertex.
  if (vertex_count_ > 0) {
    const GLuint program = vertex_program_.get();
    glUseProgram(program);
    bind_sampling(program, sampling, 0, 1);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, position_buffer_.get());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, normal_buffer_.get());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, vertex_visibility_.get());
    glUniform1i(glGetUniformLocation(program, "vertex_count"), vertex_count_);
    glUniform1i(glGetUniformLocation(program, "first_value"), layer * vertex_count_);
    glUniform1f(glGetUniformLocation(program, "normal_offset"), sampling.bias_m);
    glDispatchCompute(static_cast<GLuint>((vertex_count_ + kVertexGroupSize - 1) / kVertexGroupSize), 1, 1);
  }
  // The next source's depth pass rewrites the map these passes read.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT);
  gpu::check_gl_error("sun shadow map: visibility of a source");
  return sampling;
}

const blend::SunVisibilityTexture& SunShadowMap::visibility(int plane) const {
  if (plane < 0 || plane >= plane_count()) {
    bad_input("plane", "index " + std::to_string(plane) + " is out of range", "use 0 … plane_count() - 1");
  }
  return planes_[static_cast<std::size_t>(plane)].visibility;
}

std::vector<float> SunShadowMap::read_visibility(int plane, int source) const {
  const blend::SunVisibilityTexture& v = visibility(plane);
  if (source < 0 || source >= options_.max_sources) {
    bad_input("source", "index " + std::to_string(source) + " is out of range", "use 0 … max_sources - 1");
  }
  GLint previous = 0;
  glGetIntegerv(GL_FRAMEBUFFER_BINDING, &previous);
  const gpu::Framebuffer framebuffer = gpu::make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.get());
  glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, v.texture, 0, source);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(previous));
    throw std::runtime_error("sun shadow map: the driver cannot read back an R32F texture (it lacks "
                             "GL_EXT_color_buffer_float)");
  }
  const std::size_t texels = static_cast<std::size_t>(v.width) * static_cast<std::size_t>(v.height);
  std::vector<float> rgba(4 * texels);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glReadPixels(0, 0, v.width, v.height, GL_RGBA, GL_FLOAT, rgba.data());
  glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(previous));
  gpu::check_gl_error("sun shadow map: reading back a visibility texture");
  std::vector<float> out(texels);
  for (std::size_t k = 0; k < texels; ++k) out[k] = rgba[4 * k];
  return out;
}

std::vector<float> SunShadowMap::read_vertex_visibility(int source) const {
  if (source < 0 || source >= options_.max_sources) {
    bad_input("source", "index " + std::to_string(source) + " is out of range", "use 0 … max_sources - 1");
  }
  std::vector<float> out(static_cast<std::size_t>(vertex_count_));
  if (out.empty()) return out;
  const auto bytes = static_cast<GLsizeiptr>(out.size() * sizeof(float));
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, vertex_visibility_.get());
  const void* mapped = glMapBufferRange(GL_SHADER_STORAGE_BUFFER, static_cast<GLintptr>(source) * bytes, bytes, GL_MAP_READ_BIT);
  if (mapped == nullptr) {
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, 0);
    gpu::check_gl_error("sun shadow map: mapping the vertices' visibility");
    throw gpu::GlError("sun shadow map: the driver could not map the vertices' visibility");
  }
  std::memcpy(out.data(), mapped, out.size() * sizeof(float));
  glUnmapBuffer(GL_SHADER_STORAGE_BUFFER);
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, 0);
  gpu::check_gl_error("sun shadow map: reading the vertices' visibility");
  return out;
}

SunShadowSampling SunShadowMap::sampling() const { return sampling_; }

void SunShadowMap::bind(GLuint program, int unit) const {
  if (glGetUniformLocation(program, "sun_shadow_minmax") >= 0) {
    throw std::logic_error("SunShadowMap::bind: the program samples the minimum/maximum pyramid "
                           "(SUN_SHADOW_MINMAX): bind it with bind(program, unit, minmax_unit)");
  }
  bind(program, unit, -1);
}

void SunShadowMap::bind(GLuint program, int unit, int minmax_unit) const { bind_sampling(program, sampling_, unit, minmax_unit); }

void SunShadowMap::bind_sampling(GLuint program, const SunShadowSampling& sampling, int unit, int minmax_unit) const {
  glActiveTexture(static_cast<GLenum>(GL_TEXTURE0 + unit));
  glBindTexture(GL_TEXTURE_2D, depth_texture_.get());
  if (minmax_unit >= 0) {
    glActiveTexture(static_cast<GLenum>(GL_TEXTURE0 + minmax_unit));
    glBindTexture(GL_TEXTURE_2D, minmax_texture_.get());
  }
  glActiveTexture(GL_TEXTURE0);
  if (const GLint at = glGetUniformLocation(program, "sun_shadow_depth"); at >= 0) glUniform1i(at, unit);
  if (const GLint at = glGetUniformLocation(program, "sun_shadow_minmax"); at >= 0 && minmax_unit >= 0) {
    glUniform1i(at, minmax_unit);
  }
  if (const GLint at = glGetUniformLocation(program, "sun_shadow_from_world"); at >= 0) {
    glUniformMatrix4fv(at, 1, GL_FALSE, sampling.shadow_from_world.data());
  }
  if (const GLint at = glGetUniformLocation(program, "sun_shadow_params"); at >= 0) {
    glUniform4f(at, sampling.texel_m, sampling.depth_range_m, sampling.tan_angular_radius, sampling.bias_m);
  }
  if (const GLint at = glGetUniformLocation(program, "sun_shadow_direction"); at >= 0) {
    glUniform3f(at, sampling.direction.x(), sampling.direction.y(), sampling.direction.z());
  }
  gpu::check_gl_error("sun shadow map: binding to a program");
}

}  // namespace skylit::render
