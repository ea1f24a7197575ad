// The raster visibility engine: one orthographic shadow map per sample direction (OpenGL ES 3.1,
// headless EGL), then one fragment per plane texel or mesh vertex that counts, over the
// directions, whether its shadow-map depth test passes. See visibility.hpp for the contract.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

// geom::Plane::normal() uses cross(), which lives in Eigen/Geometry.
#include <Eigen/Geometry>

#include "skylit/baker/visibility.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/gpu/gl.hpp"
#include "skylit/gpu/shader.hpp"

namespace skylit::baker {

namespace {

using gpu::check_gl_error;

// Directions per shadow-map batch: the uniform block of visibility.frag holds 64 lights.
constexpr int kMaxLightsPerBatch = 64;
// Depth memory per batch; 2048² maps at 32 bits give 16 layers (K = 64 at 2048² would be 1 GiB).
constexpr std::size_t kBatchDepthBytes = std::size_t{256} << 20;
// Vertex pass target: kVertexTargetWidth columns, at most as many rows per draw.
constexpr int kVertexTargetWidth = 1024;
constexpr int kMaxTargetSide = 2048;  // the ES 3.1 minimum of GL_MAX_RENDERBUFFER_SIZE
// Slope-scaled bias: the depth test at a point compares against the depth at the shadow-map
// texel centre, up to half a texel away; a factor of 2 covers that on any slope (with margin),
// and the units cover rounding on flat slopes.
constexpr float kPolygonOffsetFactor = 2.0f;
constexpr float kPolygonOffsetUnits = 4.0f;

// std140 layout of visibility.frag's Lights block.
struct LightBlock {
  std::array<float, 16 * kMaxLightsPerBatch> shadow_from_world;  // column-major mat4s
  std::array<float, 4 * kMaxLightsPerBatch> light_direction;
  std::array<float, 4 * kMaxLightsPerBatch> light_weight;
};

using Matrix4 = Eigen::Matrix4d;

struct BoundingSphere {
  Vec3 centre = Vec3::Zero();
  double radius = 1.0;
};

// A sphere around mesh ∪ planes: the box centre and the farthest point from it.
BoundingSphere bounding_sphere(const scene::Mesh& mesh, std::span<const geom::Plane> planes) {
  std::vector<Vec3> points;
  points.reserve(mesh.positions.size() + 4 * planes.size());
  for (const auto& p : mesh.positions) points.push_back(p.cast<double>());
  for (const geom::Plane& plane : planes) {
    points.push_back(plane.origin);
    points.push_back(plane.origin + plane.u);
    points.push_back(plane.origin + plane.v);
    points.push_back(plane.origin + plane.u + plane.v);
  }
  BoundingSphere sphere;
  if (points.empty()) return sphere;
  Vec3 lo = points.front();
  Vec3 hi = points.front();
  for (const Vec3& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  sphere.centre = 0.5 * (lo + hi);
  double radius = 0.0;
  for (const Vec3& p : points) radius = std::max(radius, (p - sphere.centre).norm());
  // A margin keeps every point strictly inside the map and the depth range; a point scene still
  // gets a valid projection.
  sphere.radius = std::max(radius * 1.01, 1e-3);
  return sphere;
}

// Orthographic projection looking along −ω: x, y across the sphere, z_ndc = −(p−c)·ω / R, so the
// side towards the sky is nearer.
Matrix4 clip_from_world(const BoundingSphere& sphere, const Vec3& towards_sky) {
  const Vec3 w = towards_sky.normalized();
  const Vec3 helper = std::abs(w.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX();
  const Vec3 right = helper.cross(w).normalized();
  const Vec3 up = w.cross(right);
  Matrix4 m = Matrix4::Identity();
  m.block<1, 3>(0, 0) = right.transpose() / sphere.radius;
  m.block<1, 3>(1, 0) = up.transpose() / sphere.radius;
  m.block<1, 3>(2, 0) = -w.transpose() / sphere.radius;
  for (int row = 0; row < 3; ++row) m(row, 3) = -m.block<1, 3>(row, 0).dot(sphere.centre);
  return m;
}

// NDC [-1, 1]³ → texture coordinates and window depth [0, 1]³.
Matrix4 shadow_from_clip() {
  Matrix4 m = Matrix4::Identity() * 0.5;
  m(3, 3) = 1.0;
  m.block<3, 1>(0, 3).setConstant(0.5);
  return m;
}

std::array<float, 16> to_floats(const Matrix4& m) {
  std::array<float, 16> out{};
  for (int col = 0; col < 4; ++col) {
    for (int row = 0; row < 4; ++row) out[static_cast<std::size_t>(col * 4 + row)] = static_cast<float>(m(row, col));
  }
  return out;
}

// A float colour render target (RGBA32F renderbuffer + framebuffer), reallocated on size change.
class ColourTarget {
 public:
  void bind(int width, int height) {
    if (!framebuffer_ || width != width_ || height != height_) {
      renderbuffer_ = gpu::make_renderbuffer();
      glBindRenderbuffer(GL_RENDERBUFFER, renderbuffer_.get());
      glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA32F, width, height);
      framebuffer_ = gpu::make_framebuffer();
      glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.get());
      glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, renderbuffer_.get());
      check_gl_error("raster engine: allocating a " + std::to_string(width) + "×" + std::to_string(height) +
                     " RGBA32F target");
      gpu::check_framebuffer_complete(GL_FRAMEBUFFER, "raster engine: RGBA32F target");
      width_ = width;
      height_ = height;
    }
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.get());
    glViewport(0, 0, width, height);
  }

  // Every pixel, row by row from the bottom (gl y = 0), as (r, g, b, a) floats.
  void read(std::vector<float>& rgba) const {
    rgba.resize(4 * static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_));
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, 0, width_, height_, GL_RGBA, GL_FLOAT, rgba.data());
    check_gl_error("raster engine: glReadPixels");
  }

 private:
  gpu::Renderbuffer renderbuffer_;
  gpu::Framebuffer framebuffer_;
  int width_ = 0;
  int height_ = 0;
};

// Running sums of one pass over all batches, per sample point (texel or vertex) and layer.
struct Sums {
  std::size_t count;
  std::size_t layers;
  std::vector<double> occluded;  // O_k = Σ_s w_ks c_s (1 − V_s), [k * count + i]
  std::vector<double> visible;   // Σ_s V_s

  Sums(std::size_t points, int layer_count)
      : count(points),
        layers(static_cast<std::size_t>(layer_count)),
        occluded(points * layers, 0.0),
        visible(points, 0.0) {}

  // Adds one RGBA result of visibility.frag for point i.
  void add(std::size_t i, const float* rgba) {
    for (std::size_t k = 0; k < layers; ++k) occluded[k * count + i] += rgba[k];
    visible[i] += rgba[3];
  }

  // f_k = 1 − O_k / D_k with D_k = Σ w c from the CPU (`weight(k, i)`), or Σ V / K when D_k = 0.
  // Nothing occluded gives O_k = 0 and f = 1 exactly; nothing visible, f = 0 exactly. In between
  // the shader's float sums against the double D_k may stray by a rounding error: clamped.
  template <typename Weight>
  void write_fractions(std::size_t direction_count, const Weight& weight, std::span<float> out) const {
    for (std::size_t k = 0; k < layers; ++k) {
      for (std::size_t i = 0; i < count; ++i) {
        const double w = weight(k, i);
        double f = visible[i] / static_cast<double>(direction_count);
        if (w > 0.0) f = visible[i] > 0.0 ? 1.0 - occluded[k * count + i] / w : 0.0;
        out[k * count + i] = static_cast<float>(std::clamp(f, 0.0, 1.0));
      }
    }
  }
};

class RasterEngine final : public VisibilityEngine {
 public:
  RasterEngine(const scene::Mesh& mesh, std::span<const geom::Plane> planes, const RasterOptions& options)
      : mesh_(mesh),
        planes_(planes),
        offset_(surface_offset(mesh, planes)),
        sphere_(bounding_sphere(mesh, planes)),
        resolution_(options.shadow_map_resolution) {
    validate_inputs();
    context_.make_current();
    if (!context_.has_extension("GL_EXT_color_buffer_float")) {
      throw std::runtime_error(
          "raster engine: the OpenGL ES driver (" + context_.renderer() + ", " + context_.version() +
          ") lacks GL_EXT_color_buffer_float, needed to render float results; use --method raytrace, "
          "or a driver that offers it (Mesa 20 or later, NVIDIA)");
    }
    GLint max_texture_size = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_texture_size);
    if (resolution_ > max_texture_size) {
      throw std::invalid_argument("raster engine: shadow-map resolution " + std::to_string(resolution_) +
                                  " exceeds this driver's GL_MAX_TEXTURE_SIZE " +
                                  std::to_string(max_texture_size) + "; choose a smaller --shadow-map");
    }
    GLint max_layers = 0;
    glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
    const std::size_t layer_bytes = 4 * static_cast<std::size_t>(resolution_) * static_cast<std::size_t>(resolution_);
    layers_per_batch_ = static_cast<int>(std::clamp<std::size_t>(kBatchDepthBytes / layer_bytes, 1, kMaxLightsPerBatch));
    layers_per_batch_ = std::min(layers_per_batch_, std::max(1, max_layers));

    const std::filesystem::path shader_dir = gpu::find_shader_dir(options.shader_dir);
    shadow_program_ = gpu::load_program(shader_dir, {"shadow_depth.vert", "shadow_depth.frag"});
    plane_program_ = gpu::load_program(shader_dir, {"plane_texels.vert", "visibility.frag"});
    vertex_program_ = gpu::load_program(shader_dir, {"vertex_samples.vert", "visibility.frag"});
    upload_mesh();
    light_buffer_ = gpu::make_buffer();
    glBindBuffer(GL_UNIFORM_BUFFER, light_buffer_.get());
    glBufferData(GL_UNIFORM_BUFFER, sizeof(LightBlock), nullptr, GL_DYNAMIC_DRAW);
    shadow_framebuffer_ = gpu::make_framebuffer();
    empty_vertex_array_ = gpu::make_vertex_array();
    check_gl_error("raster engine: setup");
  }

  ~RasterEngine() override {
    // The GL names below are deleted in the context; make it current on this thread first. A
    // failure here cannot be reported from a destructor, and the context's own teardown frees
    // everything it owns anyway.
    try {
      context_.make_current();
    } catch (const gpu::ContextError&) {
      return;
    }
  }

  RasterEngine(const RasterEngine&) = delete;
  RasterEngine& operator=(const RasterEngine&) = delete;

  std::string name() const override {
    return "raster (OpenGL ES, " + std::to_string(resolution_) + "² shadow maps; " + context_.renderer() + ", " +
           context_.version() + ", on " + context_.platform() + ")";
  }

  int layers() const override { return layers_; }

  void set_weighted_directions(std::span<const Vec3> directions, std::span<const SampleWeights> weights,
                               int layers) override {
    if (directions.empty()) throw std::invalid_argument("raster engine: no sample directions");
    if (layers < 1 || layers > 3) throw std::invalid_argument("raster engine: 1 to 3 layers");
    if (!weights.empty() && weights.size() != directions.size()) {
      throw std::invalid_argument("raster engine: one weight triple per sample direction");
    }
    std::vector<SampleWeights> per_layer;
    per_layer.reserve(directions.size());
    for (std::size_t s = 0; s < directions.size(); ++s) {
      SampleWeights w{0.0f, 0.0f, 0.0f};
      for (int k = 0; k < layers; ++k) {
        const float x = weights.empty() ? 1.0f : weights[s][static_cast<std::size_t>(k)];
        if (!(x >= 0.0f) || !std::isfinite(x)) throw std::invalid_argument("raster engine: weights must be finite, >= 0");
        w[static_cast<std::size_t>(k)] = x;
      }
      per_layer.push_back(w);
    }
    std::vector<Vec3> unit;
    unit.reserve(directions.size());
    for (const Vec3& w : directions) {
      const double length = w.norm();
      if (!std::isfinite(length) || length == 0.0) {
        throw std::invalid_argument("raster engine: a sample direction is zero or not finite");
      }
      unit.push_back(w / length);
    }
    directions_ = std::move(unit);
    weights_ = std::move(per_layer);
    layers_ = layers;
    loaded_batch_ = -1;
    context_.make_current();
    // With one batch the maps are rendered once here and serve every plane and the vertices.
    if (batch_count() == 1) render_batch(0);
  }

  void plane_fractions(int plane_index, std::span<float> out) override {
    if (plane_index < 0 || static_cast<std::size_t>(plane_index) >= planes_.size()) {
      throw std::out_of_range("raster engine: plane index " + std::to_string(plane_index) + " out of range");
    }
    const geom::Plane& plane = planes_[static_cast<std::size_t>(plane_index)];
    const auto width = static_cast<std::size_t>(plane.width);
    const auto height = static_cast<std::size_t>(plane.height);
    if (out.size() != static_cast<std::size_t>(layers_) * width * height) {
      throw std::invalid_argument("raster engine: output for plane '" + plane.name +
                                  "' must hold layers × width × height values");
    }
    require_directions();
    context_.make_current();

    Sums sums(width * height, layers_);
    std::vector<float> rgba;
    for (int batch = 0; batch < batch_count(); ++batch) {
      use_batch(batch);
      glUseProgram(plane_program_.get());
      set_visibility_uniforms(plane_program_.get(), batch);
      const Vec3 normal = plane.normal();
      set_vec3(plane_program_.get(), "plane_normal", normal);
      glBindVertexArray(empty_vertex_array_.get());
      // Tiles keep each render target within the size every ES 3.1 driver supports.
      for (int row0 = 0; row0 < plane.height; row0 += kMaxTargetSide) {
        for (int col0 = 0; col0 < plane.width; col0 += kMaxTargetSide) {
          const int tile_width = std::min(kMaxTargetSide, plane.width - col0);
          const int tile_height = std::min(kMaxTargetSide, plane.height - row0);
          const Vec3 tile_origin = plane.origin + (static_cast<double>(col0) / plane.width) * plane.u +
                                   (static_cast<double>(row0) / plane.height) * plane.v;
          set_vec3(plane_program_.get(), "tile_origin", tile_origin);
          set_vec3(plane_program_.get(), "tile_u", (static_cast<double>(tile_width) / plane.width) * plane.u);
          set_vec3(plane_program_.get(), "tile_v", (static_cast<double>(tile_height) / plane.height) * plane.v);
          colour_target_.bind(tile_width, tile_height);
          glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
          colour_target_.read(rgba);
          for (int row = 0; row < tile_height; ++row) {
            for (int col = 0; col < tile_width; ++col) {
              const std::size_t source = 4 * (static_cast<std::size_t>(row) * static_cast<std::size_t>(tile_width) +
                                              static_cast<std::size_t>(col));
              const std::size_t target = static_cast<std::size_t>(row0 + row) * width + static_cast<std::size_t>(col0 + col);
              sums.add(target, &rgba[source]);
            }
          }
        }
      }
      check_gl_error("raster engine: plane pass for '" + plane.name + "'");
    }
    // The cosine, hence every layer's denominator, is the same for every texel of a plane.
    const std::array<double, 3> weight = layer_weights(plane.normal());
    sums.write_fractions(directions_.size(), [&](std::size_t k, std::size_t) { return weight[k]; }, out);
  }

  void vertex_fractions(std::span<float> out) override {
    const std::size_t vertices = mesh_.vertex_count();
    if (out.size() != static_cast<std::size_t>(layers_) * vertices) {
      throw std::invalid_argument("raster engine: output must hold layers × one value per mesh vertex");
    }
    require_directions();
    if (out.empty()) return;
    context_.make_current();

    Sums sums(vertices, layers_);
    std::vector<float> rgba;
    const std::size_t per_draw = static_cast<std::size_t>(kVertexTargetWidth) * kMaxTargetSide;
    for (int batch = 0; batch < batch_count(); ++batch) {
      use_batch(batch);
      glUseProgram(vertex_program_.get());
      set_visibility_uniforms(vertex_program_.get(), batch);
      glUniform1f(location(vertex_program_.get(), "surface_offset"), static_cast<float>(offset_));
      glBindVertexArray(mesh_vertex_array_.get());
      for (std::size_t first = 0; first < vertices; first += per_draw) {
        const std::size_t count = std::min(per_draw, vertices - first);
        const int rows = static_cast<int>((count + kVertexTargetWidth - 1) / kVertexTargetWidth);
        // The attributes start at the draw's first vertex, so gl_VertexID counts from 0.
        point_attributes_at(first);
        colour_target_.bind(kVertexTargetWidth, rows);
        glUniform2i(location(vertex_program_.get(), "target_size"), kVertexTargetWidth, rows);
        glClearColor(0.0f, 0.0f, 0.0f, 0.0f);
        glClear(GL_COLOR_BUFFER_BIT);
        glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(count));
        colour_target_.read(rgba);
        for (std::size_t i = 0; i < count; ++i) sums.add(first + i, &rgba[4 * i]);
      }
      point_attributes_at(0);
      check_gl_error("raster engine: vertex pass");
    }
    std::vector<std::array<double, 3>> weight(vertices);
    for (std::size_t v = 0; v < vertices; ++v) weight[v] = layer_weights(mesh_.normals[v].cast<double>());
    sums.write_fractions(directions_.size(), [&](std::size_t k, std::size_t v) { return weight[v][k]; }, out);
  }

 private:
  void validate_inputs() const {
    if (resolution_ < 16) {
      throw std::invalid_argument("raster engine: shadow-map resolution must be at least 16 (got " +
                                  std::to_string(resolution_) + ")");
    }
    if (mesh_.indices.size() % 3 != 0) {
      throw std::invalid_argument("raster engine: mesh index count is not a multiple of 3");
    }
    if (mesh_.normals.size() != mesh_.positions.size()) {
      throw std::invalid_argument("raster engine: mesh needs exactly one normal per position");
    }
    if (mesh_.positions.size() > static_cast<std::size_t>(std::numeric_limits<GLsizei>::max())) {
      throw std::invalid_argument("raster engine: mesh has too many vertices for one draw");
    }
    for (std::uint32_t index : mesh_.indices) {
      if (index >= mesh_.positions.size()) {
        throw std::invalid_argument("raster engine: mesh index " + std::to_string(index) +
                                    " is past the last vertex");
      }
    }
    for (const geom::Plane& plane : planes_) {
      if (plane.width <= 0 || plane.height <= 0) {
        throw std::invalid_argument("raster engine: plane '" + plane.name + "' has no texels");
      }
    }
  }

  void require_directions() const {
    if (directions_.empty()) {
      throw std::logic_error("raster engine: set_directions must be called before plane_fractions or "
                             "vertex_fractions");
    }
  }

  // Σ_s w_ks max(0, n·ω_s) per layer: the denominators of f_k for a point with normal n.
  std::array<double, 3> layer_weights(const Vec3& normal) const {
    std::array<double, 3> total{0.0, 0.0, 0.0};
    for (std::size_t s = 0; s < directions_.size(); ++s) {
      const double c = std::max(0.0, normal.dot(directions_[s]));
      for (std::size_t k = 0; k < 3; ++k) total[k] += weights_[s][k] * c;
    }
    return total;
  }

  int batch_count() const {
    return static_cast<int>((directions_.size() + static_cast<std::size_t>(layers_per_batch_) - 1) /
                            static_cast<std::size_t>(layers_per_batch_));
  }

  int batch_size(int batch) const {
    const std::size_t first = static_cast<std::size_t>(batch) * static_cast<std::size_t>(layers_per_batch_);
    return static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(layers_per_batch_), directions_.size() - first));
  }

  void upload_mesh() {
    mesh_vertex_array_ = gpu::make_vertex_array();
    glBindVertexArray(mesh_vertex_array_.get());
    position_buffer_ = gpu::make_buffer();
    glBindBuffer(GL_ARRAY_BUFFER, position_buffer_.get());
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh_.positions.size() * 3 * sizeof(float)),
                 mesh_.positions.empty() ? nullptr : mesh_.positions.data(), GL_STATIC_DRAW);
    normal_buffer_ = gpu::make_buffer();
    glBindBuffer(GL_ARRAY_BUFFER, normal_buffer_.get());
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh_.normals.size() * 3 * sizeof(float)),
                 mesh_.normals.empty() ? nullptr : mesh_.normals.data(), GL_STATIC_DRAW);
    index_buffer_ = gpu::make_buffer();
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, index_buffer_.get());
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh_.indices.size() * sizeof(std::uint32_t)),
                 mesh_.indices.empty() ? nullptr : mesh_.indices.data(), GL_STATIC_DRAW);
    glEnableVertexAttribArray(0);
    glEnableVertexAttribArray(1);
    point_attributes_at(0);
    check_gl_error("raster engine: mesh upload");
  }

  // Points attributes 0 (position) and 1 (normal) at vertex `first` of the mesh buffers.
  void point_attributes_at(std::size_t first) const {
    constexpr std::size_t stride = 3 * sizeof(float);
    glBindBuffer(GL_ARRAY_BUFFER, position_buffer_.get());
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, reinterpret_cast<const void*>(first * stride));
    glBindBuffer(GL_ARRAY_BUFFER, normal_buffer_.get());
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, reinterpret_cast<const void*>(first * stride));
  }

  void ensure_depth_texture() {
    if (depth_texture_) return;
    depth_texture_ = gpu::make_texture();
    glBindTexture(GL_TEXTURE_2D_ARRAY, depth_texture_.get());
    glTexStorage3D(GL_TEXTURE_2D_ARRAY, 1, GL_DEPTH_COMPONENT32F, resolution_, resolution_, layers_per_batch_);
    // NEAREST and no PCF: one binary answer per direction, as a ray gives.
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
    check_gl_error("raster engine: allocating " + std::to_string(layers_per_batch_) + " shadow maps of " +
                   std::to_string(resolution_) + "²");
  }

  void use_batch(int batch) {
    if (loaded_batch_ != batch) render_batch(batch);
  }

  // Renders the shadow maps of one batch of directions and fills the light uniform block.
  void render_batch(int batch) {
    ensure_depth_texture();
    const int first = batch * layers_per_batch_;
    const int count = batch_size(batch);
    auto block = std::make_unique<LightBlock>();
    block->shadow_from_world.fill(0.0f);
    block->light_direction.fill(0.0f);
    block->light_weight.fill(0.0f);

    glBindFramebuffer(GL_FRAMEBUFFER, shadow_framebuffer_.get());
    const GLenum none = GL_NONE;
    glDrawBuffers(1, &none);
    glReadBuffer(GL_NONE);
    glViewport(0, 0, resolution_, resolution_);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glDisable(GL_CULL_FACE);  // open architecture: both sides of a wall cast shadows
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(kPolygonOffsetFactor, kPolygonOffsetUnits);
    glClearDepthf(1.0f);
    glUseProgram(shadow_program_.get());
    const GLint clip_location = location(shadow_program_.get(), "clip_from_world");
    glBindVertexArray(mesh_vertex_array_.get());
    for (int layer = 0; layer < count; ++layer) {
      const Vec3& w = directions_[static_cast<std::size_t>(first + layer)];
      const Matrix4 clip = clip_from_world(sphere_, w);
      glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, depth_texture_.get(), 0, layer);
      if (layer == 0) gpu::check_framebuffer_complete(GL_FRAMEBUFFER, "raster engine: shadow map");
      glClear(GL_DEPTH_BUFFER_BIT);
      const std::array<float, 16> clip_floats = to_floats(clip);
      glUniformMatrix4fv(clip_location, 1, GL_FALSE, clip_floats.data());
      if (!mesh_.indices.empty()) {
        glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(mesh_.indices.size()), GL_UNSIGNED_INT, nullptr);
      }
      const std::array<float, 16> shadow = to_floats(shadow_from_clip() * clip);
      std::copy(shadow.begin(), shadow.end(), block->shadow_from_world.begin() + 16 * layer);
      for (int axis = 0; axis < 3; ++axis) {
        block->light_direction[static_cast<std::size_t>(4 * layer + axis)] = static_cast<float>(w[axis]);
        block->light_weight[static_cast<std::size_t>(4 * layer + axis)] =
            weights_[static_cast<std::size_t>(first + layer)][static_cast<std::size_t>(axis)];
      }
    }
    glDisable(GL_POLYGON_OFFSET_FILL);
    glDisable(GL_DEPTH_TEST);
    glBindBuffer(GL_UNIFORM_BUFFER, light_buffer_.get());
    glBufferSubData(GL_UNIFORM_BUFFER, 0, sizeof(LightBlock), block.get());
    check_gl_error("raster engine: shadow maps");
    loaded_batch_ = batch;
  }

  void set_visibility_uniforms(GLuint program, int batch) const {
    glBindBufferBase(GL_UNIFORM_BUFFER, 0, light_buffer_.get());
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D_ARRAY, depth_texture_.get());
    glUniform1i(location(program, "light_count"), batch_size(batch));
    glUniform1f(location(program, "depth_bias"), static_cast<float>(offset_));
  }

  static GLint location(GLuint program, const char* uniform) {
    const GLint where = glGetUniformLocation(program, uniform);
    if (where < 0) {
      throw gpu::GlError(std::string("raster engine: the shaders have no uniform '") + uniform +
                         "' (shader files from another version of skylit?)");
    }
    return where;
  }

  static void set_vec3(GLuint program, const char* uniform, const Vec3& value) {
    glUniform3f(location(program, uniform), static_cast<float>(value.x()), static_cast<float>(value.y()),
                static_cast<float>(value.z()));
  }

  const scene::Mesh& mesh_;
  std::span<const geom::Plane> planes_;
  double offset_;
  BoundingSphere sphere_;
  int resolution_;
  int layers_per_batch_ = 1;
  std::vector<Vec3> directions_;
  std::vector<SampleWeights> weights_;  // per direction, unused layers 0
  int layers_ = 1;
  int loaded_batch_ = -1;  // whose shadow maps the depth texture holds

  // The context first: it is destroyed last, after every GL name below.
  gpu::HeadlessContext context_;
  gpu::Program shadow_program_;
  gpu::Program plane_program_;
  gpu::Program vertex_program_;
  gpu::Buffer position_buffer_;
  gpu::Buffer normal_buffer_;
  gpu::Buffer index_buffer_;
  gpu::Buffer light_buffer_;
  gpu::VertexArray mesh_vertex_array_;
  gpu::VertexArray empty_vertex_array_;
  gpu::Texture depth_texture_;
  gpu::Framebuffer shadow_framebuffer_;
  ColourTarget colour_target_;
};

}  // namespace

std::unique_ptr<VisibilityEngine> make_raster_engine(const scene::Mesh& mesh, std::span<const geom::Plane> planes,
                                                     const RasterOptions& options) {
  return std::make_unique<RasterEngine>(mesh, planes, options);
}

EngineChoice choose_engine() {
  std::string renderer;
  try {
    renderer = gpu::HeadlessContext().renderer();
  } catch (const gpu::ContextError&) {
    return {"raytrace", "raytrace (Embree): no OpenGL ES 3.1 context can be made here"};
  }
  if (gpu::is_software_renderer(renderer)) {
    return {"raytrace", "raytrace (Embree): the GL renderer " + renderer + " draws on the CPU"};
  }
  return {"raster", "raster (OpenGL ES): the GL renderer " + renderer + " is a GPU's"};
}

}  // namespace skylit::baker
