#pragma once
// The sun's real-time shadow: the site mesh's depth seen from the sun (orthographic, fitted to
// the bounds of the mesh and the shadowing planes), and from it the visible fraction of the
// sun's disc at every texel of every plane, for the GPU blend's sun term (gpu_blend.hpp).
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
  std::filesystem::path shader_dir;  // empty: gpu::find_shader_dir's default search
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

  int plane_count() const { return static_cast<int>(planes_.size()); }
  // V over plane `plane` (its texels, as the basis images), for blend::GpuBlender::blend. Valid after
  // the first update.
  const blend::SunVisibilityTexture& visibility(int plane) const;
  // V of every texel of the plane, row-major (for tests and tools; blocks until the GPU is done).
  std::vector<float> read_visibility(int plane) const;

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

  SunShadowOptions options_;
  Eigen::Vector3d bounds_min_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d bounds_max_ = Eigen::Vector3d::Zero();
  GLsizei index_count_ = 0;
  std::uint64_t revision_ = 0;
  SunShadowSampling sampling_;
  gpu::Program depth_program_;
  gpu::Program visibility_program_;
  gpu::Program minmax_program_;
  gpu::Buffer position_buffer_;
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
