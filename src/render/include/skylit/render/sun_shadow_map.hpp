#pragma once
// The real-time shadows of the separated sources (the sun, lamps): the site mesh's depth seen
// from each (orthographic, fitted to the site's bounds), and from it the visible fraction of the
// source's disc at every plane texel (the GPU blend's separated terms) and model vertex.
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/geom/plane.hpp"
#include "skylit/gpu/gl.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::render {

struct SunShadowOptions {
  int resolution = 2048;      // texels along each side of the depth map
  // Distance the receiver moves towards the sun before the depth comparison, in map texels
  // (besides the slope-scaled offset of the depth pass): keeps surfaces from shadowing
  // themselves, at the price of shadows that start this much late at a contact.
  double bias_texels = 1.5;
  // Separated sources one update draws at most (1: the sun alone): the layers of every plane's
  // visibility texture. Each source costs a depth pass, its pyramid and its visibility passes.
  int max_sources = 1;
  std::filesystem::path shader_dir;  // empty: gpu::find_shader_dir's default search
};

// A separated source whose shadow the map draws.
struct ShadowSource {
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // towards it, site frame, any length > 0
  double angular_radius = 0.0;  // radians, [0, 0.5): the disc (the real sun's is 0.0047)
};

// What a shader needs to sample the map (the uniforms of shaders/sun_shadow.glsl).
struct SunShadowSampling {
  GLuint depth_texture = 0;        // GL_TEXTURE_2D, DEPTH_COMPONENT32F, NEAREST, compare mode NONE
  Eigen::Matrix4f shadow_from_world = Eigen::Matrix4f::Identity();  // world → (s, t, depth) in [0, 1]
  Eigen::Vector3f direction = Eigen::Vector3f::UnitZ();             // unit, towards the sun
  float texel_m = 0;               // size of a map texel in the site (metres)
  float depth_range_m = 0;         // metres from depth 0 to depth 1
  float tan_angular_radius = 0;
  float bias_m = 0;
  // GL_TEXTURE_2D, RGBA32F: the pyramid's levels side by side; level k holds (min, max) depth
  // over blocks of 8·2^k × 8·2^k map texels (layout: shaders/sun_shadow.glsl).
  GLuint minmax_texture = 0;
};

// The penumbra follows the sun's angular radius times the distance to the occluder (percentage-
// closer soft shadows, shaders/sun_shadow.glsl). The same map shades anything else: a shader
// that appends shaders/sun_shadow.glsl ("// library: sun_shadow.glsl") gets
// sun_visibility(world_position), and bind() sets its uniforms. With each update the map also
// gets a pyramid of its minimum and maximum depths, from which the library decides the points
// plainly lit or in umbra with four texel reads instead of its search and filter taps, for the
// same answer, and narrows the search elsewhere; a shader opts in by defining SUN_SHADOW_MINMAX
// and is bound with two units.
//
// Holds GL names: create, use and destroy it with the same GL context current, on one thread.
class SunShadowMap {
 public:
  // Uploads the mesh (copied; the caller may drop it) and allocates the depth map and one
  // visibility texture per plane. The context must be current. InputError for a bad mesh,
  // plane or option.
  SunShadowMap(const scene::Mesh& mesh, std::span<const geom::Plane> planes, const SunShadowOptions& options = {});

  // Renders the map for a sun towards `direction` (site frame, any length > 0) with a disc of
  // `angular_radius` (radians, >= 0; the real sun's is 0.0047), then every plane's
  // visibility. Each call bumps the visibility textures' revision.
  void update(const Eigen::Vector3d& direction, double angular_radius);
  // The same for 1 … max_sources separated sources, the sun (or brightest) first: source k's
  // visibility goes to layer k of every plane's texture and to the vertices' values; the depth
  // map left for sampling() and bind() is source 0's. InputError for a bad source or count.
  void update(std::span<const ShadowSource> sources);
  int source_count() const { return source_count_; }  // of the last update

  int plane_count() const { return static_cast<int>(planes_.size()); }
  // V over plane `plane` (its texels, as the basis images), for blend::GpuBlender::blend. Valid after
  // the first update.
  const blend::SunVisibilityTexture& visibility(int plane) const;
  // V of every texel of the plane for source `source`, row-major (for tests and tools; blocks
  // until the GPU is done).
  std::vector<float> read_visibility(int plane, int source = 0) const;
  // V of source `source` at every mesh vertex (its position moved bias_texels along its normal),
  // in the mesh's order: the building's light from a lamp, per vertex (blocks until the GPU is
  // done; the live service reads it once per drawn map, off the render thread).
  std::vector<float> read_vertex_visibility(int source) const;

  // The map for other shaders (valid after the first update).
  SunShadowSampling sampling() const;
  // Sets the uniforms of shaders/sun_shadow.glsl in `program` (which must be in use) and binds
  // the depth texture to texture unit `unit`. Uniforms the program does not use are skipped.
  void bind(GLuint program, int unit) const;
  // The same for a program that defines SUN_SHADOW_MINMAX: the pyramid is bound to unit
  // `minmax_unit`. (bind(program, unit) throws std::logic_error for such a program.)
  void bind(GLuint program, int unit, int minmax_unit) const;

  const SunShadowOptions& options() const { return options_; }

 private:
  struct PlaneTarget {
    geom::Plane plane;
    gpu::Texture texture;
    blend::SunVisibilityTexture visibility;
  };

  SunShadowSampling draw_source(const ShadowSource& source, int layer);
  void bind_sampling(GLuint program, const SunShadowSampling& sampling, int unit, int minmax_unit) const;

  SunShadowOptions options_;
  int source_count_ = 0;
  GLsizei vertex_count_ = 0;
  Eigen::Vector3d bounds_min_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d bounds_max_ = Eigen::Vector3d::Zero();
  GLsizei index_count_ = 0;
  std::uint64_t revision_ = 0;
  SunShadowSampling sampling_;
  gpu::Program depth_program_;
  gpu::Program visibility_program_;
  gpu::Program minmax_program_;
  gpu::Program vertex_program_;      // V at the mesh's vertices
  gpu::Buffer position_buffer_;
  gpu::Buffer normal_buffer_;
  gpu::Buffer vertex_visibility_;    // vertex_count_ × max_sources floats, source-major
  gpu::Buffer index_buffer_;
  gpu::VertexArray vertex_array_;
  gpu::Texture depth_texture_;
  gpu::Texture minmax_texture_;
  int minmax_size_ = 1;              // level 0's side: a power of two, at least an eighth of the map's
  int minmax_levels_ = 1;
  gpu::Framebuffer framebuffer_;
  std::vector<PlaneTarget> planes_;
};

}  // namespace skylit::render
