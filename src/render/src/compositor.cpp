// The compositor: the building rendered with a pinhole camera, then one pass per camera pixel that
// linearises the camera image, applies the real planes' shadow ratios, and lays the distorted
// building over it (see compositor.hpp and docs/live.md).
#include "skylit/render/compositor.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <ctime>
#include <numbers>
#include <string>
#include <string_view>
#include <utility>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <opencv2/imgproc.hpp>

#include "skylit/base/error.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/gpu/shader.hpp"
#include "skylit/camera/lens.hpp"
#include "building_light.hpp"
#include "plane_ratio_array.hpp"

namespace skylit::render {
namespace {

namespace fs = std::filesystem;
using gpu::check_gl_error;

// Texture units (match the bindings in the shaders).
constexpr GLuint kAlbedoUnit = 2;
constexpr GLuint kSunShadowUnit = 3;
constexpr GLuint kVirtualRatioUnit = 4;   // the array of every virtual plane's T
constexpr GLuint kLightMapUnit = 5;
constexpr GLuint kSunMinmaxUnit = 12;
constexpr GLuint kCameraUnit = 0;
constexpr GLuint kRaysUnit = 1;
constexpr GLuint kBuildingUnit = 2;
constexpr GLuint kRealRatioUnit = 3;      // 3 .. 10
constexpr GLuint kBuildingDepthUnit = 11;
// The building's camera depth where nothing is drawn (compose_final.frag takes the least of four).
constexpr float kNothingDrawn = 1e30f;

// Sampler objects (filtering state for the shadow ratios, whatever their owner set).
using gpu::Sampler;

Sampler bilinear_clamped_sampler() {
  GLuint name = 0;
  glGenSamplers(1, &name);
  glSamplerParameteri(name, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glSamplerParameteri(name, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glSamplerParameteri(name, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glSamplerParameteri(name, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return Sampler(name);
}

bool has_gl_extension(const char* name) {
  GLint count = 0;
  glGetIntegerv(GL_NUM_EXTENSIONS, &count);
  for (GLint i = 0; i < count; ++i) {
    const auto* extension = reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, static_cast<GLuint>(i)));
    if (extension != nullptr && std::string_view(extension) == name) return true;
  }
  return false;
}

struct PlaneGeometry {
  Eigen::Vector3f origin;
  Eigen::Vector3f s_axis;   // s = (x − origin)·s_axis, t = (x − origin)·t_axis: the dual basis of (u, v)
  Eigen::Vector3f t_axis;
  Eigen::Vector3f normal;
};

PlaneGeometry plane_geometry(const geom::Plane& plane) {
  Eigen::Matrix<double, 3, 2> basis;
  basis << plane.u, plane.v;
  // Rows of (BᵀB)⁻¹Bᵀ: exact for points on the plane, and the normal component drops out.
  const Eigen::Matrix<double, 2, 3> dual = (basis.transpose() * basis).inverse() * basis.transpose();
  return {plane.origin.cast<float>(), dual.row(0).transpose().cast<float>(), dual.row(1).transpose().cast<float>(),
          plane.normal().cast<float>()};
}

// Column-major floats for glUniformMatrix*.
template <int N>
std::array<float, N * N> column_major(const Eigen::Matrix<double, N, N>& m) {
  std::array<float, N * N> out{};
  for (int col = 0; col < N; ++col) {
    for (int row = 0; row < N; ++row) out[static_cast<std::size_t>(col * N + row)] = static_cast<float>(m(row, col));
  }
  return out;
}

// A uniform location that may be absent (a driver drops unused uniforms): -1 is ignored by glUniform*.
GLint uniform(GLuint program, const char* name) { return glGetUniformLocation(program, name); }

void set_vec3(GLint location, const Eigen::Vector3d& v) {
  glUniform3f(location, static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
}

void set_vec3_array(GLuint program, const std::string& name, const std::vector<Eigen::Vector3f>& values) {
  if (values.empty()) return;
  glUniform3fv(uniform(program, (name + "[0]").c_str()), static_cast<GLsizei>(values.size()), values.front().data());
}

gpu::Texture texture_2d(GLenum internal_format, int width, int height, GLenum format, GLenum type,
                        const void* pixels) {
  gpu::Texture texture = gpu::make_texture();
  glBindTexture(GL_TEXTURE_2D, texture.get());
  glTexStorage2D(GL_TEXTURE_2D, 1, internal_format, width, height);
  if (pixels != nullptr) {
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, height, format, type, pixels);
  }
  // texelFetch only: filtering never applies, but the texture must be complete.
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return texture;
}

// Wall and process CPU time between laps, each lap after a glFinish (when enabled; otherwise
// every lap is 0).
class StageClock {
 public:
  explicit StageClock(bool enabled) : enabled_(enabled) {
    if (enabled_) {
      glFinish();
      last_wall_ = std::chrono::steady_clock::now();
      last_cpu_ = process_cpu_ms();
    }
  }
  CompositeTimings::Stage lap() {
    if (!enabled_) return {};
    glFinish();
    const auto wall = std::chrono::steady_clock::now();
    const double cpu = process_cpu_ms();
    const CompositeTimings::Stage stage{std::chrono::duration<double, std::milli>(wall - last_wall_).count(),
                                        cpu - last_cpu_};
    last_wall_ = wall;
    last_cpu_ = cpu;
    return stage;
  }

 private:
  static double process_cpu_ms() {
    timespec now{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
    return 1e3 * static_cast<double>(now.tv_sec) + 1e-6 * static_cast<double>(now.tv_nsec);
  }

  bool enabled_;
  std::chrono::steady_clock::time_point last_wall_;
  double last_cpu_ = 0;
};

// A program from shader files with `defines` ("#define NAME VALUE" lines) put after each file's
// #version line: the shaders compiled for one site (compose_*.frag say which names they take).
gpu::Program load_specialised(const fs::path& shader_dir, std::initializer_list<fs::path> files,
                              const std::string& defines) {
  std::vector<gpu::ShaderSource> sources;
  for (const fs::path& file : files) {
    std::string text = gpu::read_shader(shader_dir, file);
    const std::size_t first_line_end = text.find('\n');
    text.insert(first_line_end == std::string::npos ? text.size() : first_line_end + 1,
                std::string(defines).append("#line 2\n"));
    sources.push_back({gpu::shader_stage(file), (shader_dir / file).string(), std::move(text)});
  }
  return gpu::link_program(sources);
}

std::string define(const char* name, int value) {
  return std::string("#define ").append(name).append(" ").append(std::to_string(value)).append("\n");
}

std::string plane_list(const scene::Site& site) {
  std::string names;
  for (const geom::Plane& plane : site.planes) {
    if (!names.empty()) names += ", ";
    names += "'" + plane.name + "'";
  }
  return names.empty() ? std::string("none") : names;
}

}  // namespace

Eigen::Vector3d plane_irradiance(const bake_format::PlaneRecord& plane, std::span<const Eigen::Vector3d> sky,
                                 const std::optional<blend::SunLight>& sun, std::span<const blend::SunLight> lamps) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  const std::size_t layers = std::min(sky.size(), plane.unoccluded.size());
  for (std::size_t i = 0; i < layers; ++i) sum += plane.unoccluded[i] * finite_or_zero(sky[i], nullptr);  // a corner's may be < 0
  const auto add = [&](const blend::SunLight& light) {
    const double cosine = plane.plane.normal().dot(light.direction.normalized());
    if (std::isfinite(cosine) && cosine > 0.0) sum += cosine * finite_nonnegative(light.energy, nullptr);
  };
  if (sun) add(*sun);
  for (const blend::SunLight& lamp : lamps) add(lamp);
  return sum.cwiseMax(0.0);
}

struct Compositor::State {
  State(const camera::CameraCalibration& hmd, CompositorOptions opts)
      : options(std::move(opts)), lens(hmd), remap(make_lens_remap(lens, options.lens)) {}

  CompositorOptions options;
  camera::Lens lens;
  LensRemap remap;
  std::vector<scene::PlaneSurface> surfaces;     // per bake plane
  std::vector<bake_format::PlaneRecord> planes;         // the manifest's
  std::vector<int> virtual_planes;               // bake plane indices, in shader order
  std::optional<PlaneRatioArray> virtual_ratios; // their T, a layer each, gathered every frame
  std::vector<int> real_planes;
  int layer_count = 0;
  int vertices = 0;
  // The building's sums per sky (shared with the other compositors of a stereo HMD, and with a
  // thread that sums ahead), and the per-vertex sky and ground irradiance of the sky they were
  // summed for (irradiance_sky, irradiance_ground; empty: not yet): summed when the sky changes,
  // not per frame.
  std::shared_ptr<const BuildingIrradiance> building_light;
  std::vector<Eigen::Vector3d> irradiance_sky;
  std::vector<Eigen::Vector3d> irradiance_ground;
  std::vector<float> sky_sum;                    // rgb per vertex: Σ_i S_i t_{v,i} (+ the ground's)
  std::vector<float> vertex_irradiance;          // rgb per vertex: the sky sum and the lamps
  std::vector<Eigen::Vector3f> vertex_normals;   // the mesh's, for the lamps' cosines
  bool lamps_added = false;                      // vertex_irradiance holds lamps' light
  // The light map, when the bake has one: the vertices as drawn (split where charts meet) and the
  // atlas of the sky's and the ground's light (building_light.hpp).
  DrawVertices draw_vertices;
  std::optional<ShadowRatioTexture> light_map;

  // Building geometry, grouped by material for one draw each.
  struct MaterialDraw {
    Eigen::Vector3d base_colour = Eigen::Vector3d::Ones();
    int texture = -1;                            // into albedo_textures
    GLsizei first = 0;                           // into the index buffer
    GLsizei count = 0;
  };
  std::vector<MaterialDraw> draws;
  gpu::VertexArray building_vertices;
  gpu::Buffer positions, normals, texcoords, irradiance_values, ground_irradiance_values, atlas_coordinates, indices;
  std::vector<gpu::Texture> albedo_textures;
  gpu::Texture white;                            // 1×1 sRGB white: the albedo of untextured materials
  gpu::Texture ones;                             // 1×1 RGBA32F (1,1,1,1): T of a plane without a texture

  // Targets.
  gpu::Texture building;                         // pinhole render: radiance, 1 where drawn
  gpu::Texture building_camera_depth;            // R32F: camera depth, kNothingDrawn elsewhere
  gpu::Renderbuffer building_depth;
  gpu::Framebuffer building_target;
  // Float textures can be filtered (OES_texture_float_linear): the shaders read bilinearly
  // through the sampler instead of four texelFetch (FILTERED_LOOKUPS).
  bool filtered_lookups = false;
  Sampler bilinear;
  gpu::Texture camera_image;
  GLenum camera_format = GL_NONE;                // GL_SRGB8_ALPHA8 (decoded on fetch) or GL_RGBA32F
  gpu::Texture rays;
  gpu::Texture linear;                           // RGBA32F
  gpu::Texture display;                          // RGBA8, sRGB-encoded
  gpu::Framebuffer composite_target;
  gpu::VertexArray empty_vertices;               // the full-screen pass has no attributes

  fs::path shader_dir;
  // The building's program without (0) and with (1) the sun's shadow map, made on first use.
  std::array<gpu::Program, 2> building_programs;
  gpu::Program depth_program;                    // the building's depth pre-pass
  gpu::Program composite_program;
  CompositeStats stats;
  CompositeTimings timings;

  void check_inputs(const scene::Site& site, const scene::Mesh& mesh, const bake_format::Manifest& manifest,
                    std::span<const float> transfer_values);
  void upload_building(const scene::Mesh& mesh);
  void make_targets();
  void upload_camera(const cv::Mat& frame);
  void update_irradiance(const std::vector<Eigen::Vector3d>& sky_values, const CompositeInput& input);
  void draw_building(const CompositeInput& input, const std::vector<Eigen::Vector3d>& sky_values,
                     const PhotometricMatch& photometric);
  void draw_composite(const CompositeInput& input);
  GLuint building_program(bool sun_shadows);
  GLuint ratio_texture(const CompositeInput& input, int plane) const;
};

void Compositor::State::check_inputs(const scene::Site& site, const scene::Mesh& mesh,
                                     const bake_format::Manifest& manifest, std::span<const float> transfer_values) {
  const fs::path manifest_file = "manifest.json";
  const std::string rebake = "use the model, site and bake that belong together (re-bake with skylit-bake "
                             "after changing the model or the site)";
  if (manifest.faces.empty()) {
    throw InputError(input_message(manifest_file, -1, -1, "dome.faces", "the bake has no dome faces", rebake));
  }
  if (mesh.vertex_count() == 0 || mesh.vertex_count() != manifest.plan.vertex_count) {
    throw InputError(input_message(site.model, -1, -1, "",
                                   "the model has " + std::to_string(mesh.vertex_count()) + " vertices, the bake " +
                                       std::to_string(manifest.plan.vertex_count),
                                   rebake));
  }
  // One transfer column per basis layer of the bake (a layer per dome face, or several per face
  // with a finer radiance basis): S comes with the same layers.
  const std::size_t layers = transfer_values.size() / mesh.vertex_count();
  if (layers == 0 || layers * mesh.vertex_count() != transfer_values.size() || layers % manifest.faces.size() != 0) {
    throw InputError(input_message(manifest_file, -1, -1, "transfer",
                                   "transfer.npy holds " + std::to_string(transfer_values.size()) +
                                       " values, not a whole number of layers for each of " +
                                       std::to_string(mesh.vertex_count()) + " vertices and " +
                                       std::to_string(manifest.faces.size()) + " faces",
                                   rebake));
  }
  layer_count = static_cast<int>(layers);
  for (std::size_t k = 0; k < mesh.normals.size() && k < mesh.positions.size(); ++k) {
    if (!mesh.positions[k].allFinite() || !mesh.normals[k].allFinite()) {
      throw InputError(input_message(site.model, -1, -1, "", "vertex " + std::to_string(k) + " is not finite",
                                     "repair the model and bake it again"));
    }
  }
  if (mesh.normals.size() != mesh.positions.size() || mesh.indices.size() % 3 != 0 ||
      mesh.triangle_material.size() != mesh.triangle_count() ||
      (!mesh.texcoords.empty() && mesh.texcoords.size() != mesh.positions.size())) {
    throw std::invalid_argument("Compositor: the mesh's arrays have inconsistent sizes");
  }

  planes = manifest.planes;
  for (std::size_t j = 0; j < planes.size(); ++j) {
    const std::string& name = planes[j].plane.name;
    const auto found = std::find_if(site.planes.begin(), site.planes.end(),
                                    [&](const geom::Plane& p) { return p.name == name; });
    if (found == site.planes.end()) {
      throw InputError(input_message(site.file, -1, -1, "planes",
                                     "the bake has a plane '" + name + "' that the site does not (site planes: " +
                                         plane_list(site) + ")",
                                     rebake));
    }
    const scene::PlaneSurface surface = site.surface_of(static_cast<std::size_t>(found - site.planes.begin()));
    surfaces.push_back(surface);
    (surface == scene::PlaneSurface::Real ? real_planes : virtual_planes).push_back(static_cast<int>(j));
    if (planes[j].unoccluded.size() != static_cast<std::size_t>(layer_count)) {
      throw InputError(input_message(manifest_file, -1, -1, "planes[" + std::to_string(j) + "].unoccluded",
                                     "the plane has " + std::to_string(planes[j].unoccluded.size()) +
                                         " unoccluded values for " + std::to_string(layer_count) + " layers",
                                     rebake));
    }
  }
  if (static_cast<int>(virtual_planes.size()) > kMaxVirtualPlanes ||
      static_cast<int>(real_planes.size()) > kMaxRealPlanes) {
    throw InputError(input_message(site.file, -1, -1, "planes",
                                   "the site has " + std::to_string(virtual_planes.size()) + " virtual and " +
                                       std::to_string(real_planes.size()) + " real planes; the compositor draws at most " +
                                       std::to_string(kMaxVirtualPlanes) + " of each",
                                   "merge planes that lie in one surface, or leave out the least visible ones"));
  }
}

void Compositor::State::upload_building(const scene::Mesh& mesh) {
  const std::size_t vertex_count = mesh.vertex_count();
  vertices = static_cast<int>(vertex_count);
  vertex_irradiance.assign(3 * vertex_count, 0.0f);
  sky_sum.assign(3 * vertex_count, 0.0f);
  irradiance_sky.clear();
  vertex_normals = mesh.normals;
  vertex_normals.resize(vertex_count, Eigen::Vector3f::UnitZ());
  draw_vertices = render::draw_vertices(mesh, building_light->light_map_layout());
  const std::size_t drawn = draw_vertices.model_vertex.size();

  // Vertices (texcoords zero when the model has none) and indices grouped by material.
  building_vertices = gpu::make_vertex_array();
  glBindVertexArray(building_vertices.get());
  auto attribute = [](gpu::Buffer& buffer, GLuint location, int components, const float* data, std::size_t count) {
    buffer = gpu::make_buffer();
    glBindBuffer(GL_ARRAY_BUFFER, buffer.get());
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(count * static_cast<std::size_t>(components) * sizeof(float)),
                 data, GL_STATIC_DRAW);
    glEnableVertexAttribArray(location);
    glVertexAttribPointer(location, components, GL_FLOAT, GL_FALSE, 0, nullptr);
  };
  const auto floats = [&](const auto& vectors, int components) {
    return per_draw_vertex(draw_vertices, std::span<const float>(vectors.front().data(), vertex_count * static_cast<std::size_t>(components)), components);
  };
  attribute(positions, 0, 3, floats(mesh.positions, 3).data(), drawn);
  attribute(normals, 1, 3, floats(mesh.normals, 3).data(), drawn);
  std::vector<Eigen::Vector2f> uv = mesh.texcoords;
  uv.resize(vertex_count, Eigen::Vector2f::Zero());
  attribute(texcoords, 2, 2, floats(uv, 2).data(), drawn);
  const std::vector<float> zero(3 * drawn, 0.0f);  // until a sky lights the building
  attribute(irradiance_values, 3, 3, zero.data(), drawn);
  attribute(ground_irradiance_values, 4, 3, zero.data(), drawn);
  attribute(atlas_coordinates, 5, 2, draw_vertices.atlas.front().data(), drawn);

  std::vector<std::uint32_t> grouped;
  grouped.reserve(mesh.indices.size());
  const std::size_t material_count = std::max<std::size_t>(mesh.materials.size(), 1);
  for (std::size_t m = 0; m < material_count; ++m) {
    MaterialDraw draw;
    draw.first = static_cast<GLsizei>(grouped.size());
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
      const std::size_t material = std::min<std::size_t>(mesh.triangle_material[t], material_count - 1);
      if (material != m) continue;
      grouped.insert(grouped.end(), draw_vertices.indices.begin() + static_cast<std::ptrdiff_t>(3 * t),
                     draw_vertices.indices.begin() + static_cast<std::ptrdiff_t>(3 * t + 3));
    }
    draw.count = static_cast<GLsizei>(grouped.size()) - draw.first;
    if (m < mesh.materials.size()) {
      draw.base_colour = mesh.materials[m].base_colour.head<3>().cast<double>();
      const int texture = mesh.materials[m].base_colour_texture;
      if (texture >= 0 && static_cast<std::size_t>(texture) < mesh.textures.size() &&
          !mesh.textures[static_cast<std::size_t>(texture)].rgba.empty()) {
        draw.texture = texture;
      }
    }
    if (draw.count > 0) draws.push_back(draw);
  }
  indices = gpu::make_buffer();
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, indices.get());
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(grouped.size() * sizeof(std::uint32_t)),
               grouped.data(), GL_STATIC_DRAW);
  glBindVertexArray(0);

  // Base-colour textures: sRGB, decoded by the sampler before filtering, mipmapped, repeating
  // (glTF's default sampler).
  for (const scene::TextureImage& image : mesh.textures) {
    gpu::Texture texture = gpu::make_texture();
    if (!image.rgba.empty()) {
      glBindTexture(GL_TEXTURE_2D, texture.get());
      const int levels = 1 + static_cast<int>(std::floor(std::log2(std::max(image.width, image.height))));
      glTexStorage2D(GL_TEXTURE_2D, levels, GL_SRGB8_ALPHA8, image.width, image.height);
      glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
      glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, image.width, image.height, GL_RGBA, GL_UNSIGNED_BYTE, image.rgba.data());
      glGenerateMipmap(GL_TEXTURE_2D);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    }
    albedo_textures.push_back(std::move(texture));
  }
  const std::array<std::uint8_t, 4> white_texel{255, 255, 255, 255};
  white = texture_2d(GL_SRGB8_ALPHA8, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, white_texel.data());
  const std::array<float, 4> one_texel{1.0f, 1.0f, 1.0f, 1.0f};
  ones = texture_2d(GL_RGBA32F, 1, 1, GL_RGBA, GL_FLOAT, one_texel.data());
  check_gl_error("Compositor: uploading the building");
}

void Compositor::State::make_targets() {
  const PinholeCamera& pinhole = remap.pinhole;
  building = texture_2d(GL_RGBA32F, pinhole.width, pinhole.height, GL_RGBA, GL_FLOAT, nullptr);
  building_camera_depth = texture_2d(GL_R32F, pinhole.width, pinhole.height, GL_RED, GL_FLOAT, nullptr);
  building_depth = gpu::make_renderbuffer();
  glBindRenderbuffer(GL_RENDERBUFFER, building_depth.get());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, pinhole.width, pinhole.height);
  building_target = gpu::make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, building_target.get());
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, building.get(), 0);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, building_camera_depth.get(), 0);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, building_depth.get());
  const std::array<GLenum, 2> building_buffers{GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, building_buffers.data());
  gpu::check_framebuffer_complete(GL_FRAMEBUFFER, "Compositor: the building's RGBA32F and R32F targets");

  const int width = lens.calibration().image_width;
  const int height = lens.calibration().image_height;
  rays = texture_2d(GL_RGBA32F, width, height, GL_RGBA, GL_FLOAT, remap.rays.ptr<float>());
  linear = texture_2d(GL_RGBA32F, width, height, GL_RGBA, GL_FLOAT, nullptr);
  display = texture_2d(GL_RGBA8, width, height, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  composite_target = gpu::make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, composite_target.get());
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, linear.get(), 0);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, display.get(), 0);
  const std::array<GLenum, 2> buffers{GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, buffers.data());
  gpu::check_framebuffer_complete(GL_FRAMEBUFFER, "Compositor: the composite's targets");
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  empty_vertices = gpu::make_vertex_array();
  check_gl_error("Compositor: allocating targets");
}

void Compositor::State::upload_camera(const cv::Mat& frame) {
  const int width = frame.cols;
  const int height = frame.rows;
  const bool srgb = frame.type() == CV_8UC3;
  cv::Mat rgba;
  if (srgb) {
    cv::cvtColor(frame, rgba, cv::COLOR_BGR2RGBA);
  } else {
    // Bad values never reach the GPU: NaN, ±Inf and negatives become 0 (and are counted).
    cv::Mat clean = frame.clone();
    for (int y = 0; y < height; ++y) {
      float* value = clean.ptr<float>(y);
      for (int k = 0; k < 3 * width; ++k) {
        if (!std::isfinite(value[k]) || value[k] < 0.0f) {
          value[k] = 0.0f;
          ++stats.camera_values_replaced;
        }
      }
    }
    cv::cvtColor(clean, rgba, cv::COLOR_BGR2RGBA);
  }
  const GLenum format = srgb ? GL_SRGB8_ALPHA8 : GL_RGBA32F;
  if (!camera_image || camera_format != format) {
    camera_image = texture_2d(format, width, height, GL_RGBA, srgb ? GL_UNSIGNED_BYTE : GL_FLOAT, nullptr);
    camera_format = format;
  }
  glBindTexture(GL_TEXTURE_2D, camera_image.get());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, height, GL_RGBA, srgb ? GL_UNSIGNED_BYTE : GL_FLOAT, rgba.data);
  check_gl_error("Compositor: uploading the camera frame");
}

void Compositor::State::update_irradiance(const std::vector<Eigen::Vector3d>& sky_values, const CompositeInput& input) {
  const auto count = static_cast<std::size_t>(vertices);
  if (!input.lamp_vertex_visibility.empty() && input.lamp_vertex_visibility.size() != input.lamps.size()) {
    throw InputError(input_message({}, -1, -1, "lamp_vertex_visibility",
                                   std::to_string(input.lamp_vertex_visibility.size()) + " visibilities for " +
                                       std::to_string(input.lamps.size()) + " lamps",
                                   "pass one per lamp (SunShadowMap::read_vertex_visibility), or none"));
  }
  for (std::size_t k = 0; k < input.lamp_vertex_visibility.size(); ++k) {
    const std::size_t size = input.lamp_vertex_visibility[k].size();
    if (size != 0 && size != count) {
      throw InputError(input_message({}, -1, -1, "lamp_vertex_visibility[" + std::to_string(k) + "]",
                                     std::to_string(size) + " values for a model of " + std::to_string(count) + " vertices",
                                     "read it from the shadow map drawn for this model"));
    }
  }
  std::vector<Eigen::Vector3d> ground_values = building_light->ground_coefficients(sky_values, input.sun, input.lamps);
  const bool sky_changed = irradiance_sky.empty() || irradiance_sky != sky_values || irradiance_ground != ground_values;
  const auto upload = [](const gpu::Buffer& buffer, const std::vector<float>& values) {
    glBindBuffer(GL_ARRAY_BUFFER, buffer.get());
    glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(values.size() * sizeof(float)), values.data());
    glBindBuffer(GL_ARRAY_BUFFER, 0);
  };
  if (sky_changed) {
    // The sums made ahead for this sky when the input brings them (and they are this compositor's),
    // else summed here (BuildingIrradiance::sum: the sky's layers and the ground's, per vertex and
    // per light-map texel).
    const SkyIrradiance* sums = input.irradiance.get();
    std::optional<SkyIrradiance> summed;
    if (sums == nullptr || sums->summed_by != building_light.get() || sums->sky != sky_values || sums->ground != ground_values) {
      summed = building_light->sum(sky_values, input.sun, input.lamps);
      sums = &*summed;
      stats.building_light_summed = true;
    }
    sky_sum = sums->vertices;
    // The ground on its own for the fragments a virtual plane covers (T_j D_j holds the sky, not
    // the ground).
    if (!sums->ground_vertices.empty()) upload(ground_irradiance_values, per_draw_vertex(draw_vertices, sums->ground_vertices, 3));
    if (light_map) light_map->upload(sums->atlas);
    irradiance_sky = sky_values;
    irradiance_ground = std::move(ground_values);
  }
  // The lamps change with every sky frame and their visibility with every map: added each frame
  // they light (vertices × lamps multiply-adds).
  const bool lamps = !input.lamps.empty();
  if (!sky_changed && !lamps && !lamps_added) return;
  vertex_irradiance = sky_sum;
  for (std::size_t k = 0; k < input.lamps.size(); ++k) {
    const blend::SunLight& lamp = input.lamps[k];
    const double length = lamp.direction.norm();
    if (!lamp.direction.allFinite() || !(length > 0.0)) continue;
    const Eigen::Vector3f w = (lamp.direction / length).cast<float>();
    const Eigen::Vector3f energy = finite_nonnegative(lamp.energy, &stats.sky_values_replaced).cast<float>();
    if (energy.isZero(0)) continue;
    const std::vector<float>* visibility =
        k < input.lamp_vertex_visibility.size() && !input.lamp_vertex_visibility[k].empty() ? &input.lamp_vertex_visibility[k]
                                                                                              : nullptr;
    for (std::size_t v = 0; v < count; ++v) {
      float facing = std::max(0.0f, vertex_normals[v].dot(w));
      if (facing == 0.0f) continue;
      if (visibility != nullptr) {
        const float x = (*visibility)[v];
        facing *= x > 1.0f ? 1.0f : (x >= 0.0f ? x : 0.0f);  // NaN counts as 0
      }
      for (int c = 0; c < 3; ++c) vertex_irradiance[3 * v + static_cast<std::size_t>(c)] += facing * energy[c];
    }
  }
  lamps_added = lamps;
  // On a chart the light map holds the sky and the ground: its corners carry the lamps alone.
  upload(irradiance_values,
         per_draw_vertex(draw_vertices, vertex_irradiance, 3, light_map ? std::span<const float>(sky_sum) : std::span<const float>()));
}

GLuint Compositor::State::ratio_texture(const CompositeInput& input, int plane) const {
  const auto index = static_cast<std::size_t>(plane);
  if (index < input.shadow_ratios.size() && input.shadow_ratios[index] != 0) return input.shadow_ratios[index];
  return ones.get();
}

void Compositor::State::draw_building(const CompositeInput& input, const std::vector<Eigen::Vector3d>& sky_values,
                                      const PhotometricMatch& photometric) {
  update_irradiance(sky_values, input);

  // Camera: site → camera → the pinhole's clip space, with image row y at window row y (so that
  // texel row 0 is the image's top row, like every other image here).
  const PinholeCamera& pinhole = remap.pinhole;
  const Eigen::Matrix3d R = input.pose.R_site_from_camera;
  Eigen::Matrix4d camera_from_site = Eigen::Matrix4d::Identity();
  camera_from_site.topLeftCorner<3, 3>() = R.transpose();
  camera_from_site.topRightCorner<3, 1>() = -R.transpose() * input.pose.t_site_from_camera;
  const double n = options.near;
  const double f = options.far;
  Eigen::Matrix4d clip_from_camera = Eigen::Matrix4d::Zero();
  clip_from_camera(0, 0) = 2.0 * pinhole.fx / pinhole.width;
  clip_from_camera(0, 2) = 2.0 * (pinhole.cx + 0.5) / pinhole.width - 1.0;
  clip_from_camera(1, 1) = 2.0 * pinhole.fy / pinhole.height;
  clip_from_camera(1, 2) = 2.0 * (pinhole.cy + 0.5) / pinhole.height - 1.0;
  clip_from_camera(2, 2) = (f + n) / (f - n);
  clip_from_camera(2, 3) = -2.0 * f * n / (f - n);
  clip_from_camera(3, 2) = 1.0;

  Eigen::Vector3d sun_direction = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d sun_energy = Eigen::Vector3d::Zero();
  if (input.sun && input.sun->direction.allFinite() && input.sun->direction.norm() > 0.0) {
    sun_direction = input.sun->direction.normalized();
    sun_energy = finite_nonnegative(input.sun->energy, &stats.sky_values_replaced);
  }
  const bool shadow_map = input.sun_shadow != nullptr;
  stats.sun_without_shadow_map = sun_energy.maxCoeff() > 0.0 && !shadow_map;
  // The shadow map's program only where the sun shines and has a map.
  const GLuint program = building_program(shadow_map && sun_energy.maxCoeff() > 0.0);

  std::vector<GLuint> virtual_textures;
  for (int plane : virtual_planes) virtual_textures.push_back(ratio_texture(input, plane));
  virtual_ratios->gather(virtual_textures);

  glBindFramebuffer(GL_FRAMEBUFFER, building_target.get());
  glViewport(0, 0, pinhole.width, pinhole.height);
  const std::array<float, 4> nothing{0.0f, 0.0f, 0.0f, 0.0f};
  const std::array<float, 4> far_away{kNothingDrawn, 0.0f, 0.0f, 0.0f};
  glClearBufferfv(GL_COLOR, 0, nothing.data());
  glClearBufferfv(GL_COLOR, 1, far_away.data());
  glClearDepthf(1.0f);
  glClear(GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);  // models need not be closed; the depth test orders what is seen
  const auto clip = column_major<4>(Eigen::Matrix4d(clip_from_camera * camera_from_site));
  glBindVertexArray(building_vertices.get());
  // Depth first, then the colour pass shades only the fragments that pass GL_LEQUAL against it:
  // the nearest surface of every pixel, once, whatever the model's overdraw (a software renderer
  // pays for every fragment shaded).
  glDepthFunc(GL_LESS);
  glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
  glUseProgram(depth_program.get());
  glUniformMatrix4fv(uniform(depth_program.get(), "clip_from_site"), 1, GL_FALSE, clip.data());
  for (const MaterialDraw& draw : draws) {
    glDrawElements(GL_TRIANGLES, draw.count, GL_UNSIGNED_INT,
                   reinterpret_cast<const void*>(static_cast<std::uintptr_t>(draw.first) * sizeof(std::uint32_t)));
  }
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glDepthMask(GL_FALSE);
  glDepthFunc(GL_LEQUAL);
  glUseProgram(program);

  const auto camera = column_major<4>(camera_from_site);
  glUniformMatrix4fv(uniform(program, "clip_from_site"), 1, GL_FALSE, clip.data());
  glUniformMatrix4fv(uniform(program, "camera_from_site"), 1, GL_FALSE, camera.data());
  set_vec3(uniform(program, "photometric_scale"), finite_nonnegative(photometric.scale, nullptr));

  set_vec3(uniform(program, "sun_direction"), sun_direction);
  set_vec3(uniform(program, "sun_energy"), sun_energy);
  if (program == building_programs[1].get()) {
    input.sun_shadow->bind(program, static_cast<int>(kSunShadowUnit), static_cast<int>(kSunMinmaxUnit));
  }
  glUniform1f(uniform(program, "cover_distance"), static_cast<float>(options.cover_distance));
  glUniform1f(uniform(program, "cover_cos"),
              static_cast<float>(std::cos(options.cover_max_angle_deg * std::numbers::pi / 180.0)));

  std::vector<Eigen::Vector3f> origin, s_axis, t_axis, normal, irradiance;
  std::vector<float> texels;
  for (int plane : virtual_planes) {
    const bake_format::PlaneRecord& record = planes[static_cast<std::size_t>(plane)];
    texels.push_back(static_cast<float>(record.plane.width));
    texels.push_back(static_cast<float>(record.plane.height));
    const PlaneGeometry g = plane_geometry(record.plane);
    origin.push_back(g.origin);
    s_axis.push_back(g.s_axis);
    t_axis.push_back(g.t_axis);
    normal.push_back(g.normal);
    irradiance.push_back(plane_irradiance(record, sky_values, input.sun, input.lamps).cast<float>());
  }
  set_vec3_array(program, "plane_origin", origin);
  set_vec3_array(program, "plane_s_axis", s_axis);
  set_vec3_array(program, "plane_t_axis", t_axis);
  set_vec3_array(program, "plane_normal", normal);
  set_vec3_array(program, "plane_irradiance", irradiance);
  if (!texels.empty()) glUniform2fv(uniform(program, "plane_texels[0]"), static_cast<GLsizei>(texels.size() / 2), texels.data());

  glActiveTexture(GL_TEXTURE0 + kVirtualRatioUnit);
  glBindTexture(GL_TEXTURE_2D_ARRAY, virtual_ratios->texture());
  glBindSampler(kVirtualRatioUnit, filtered_lookups ? bilinear.get() : 0);
  if (light_map) {
    glActiveTexture(GL_TEXTURE0 + kLightMapUnit);
    glBindTexture(GL_TEXTURE_2D, light_map->get());
    glBindSampler(kLightMapUnit, filtered_lookups ? bilinear.get() : 0);
    glUniform2f(uniform(program, "light_map_size"), static_cast<float>(building_light->atlas_width()),
                static_cast<float>(building_light->atlas_height()));
  }

  const GLint base_colour = uniform(program, "base_colour");
  for (const MaterialDraw& draw : draws) {
    set_vec3(base_colour, draw.base_colour);
    glActiveTexture(GL_TEXTURE0 + kAlbedoUnit);
    glBindTexture(GL_TEXTURE_2D, draw.texture >= 0 ? albedo_textures[static_cast<std::size_t>(draw.texture)].get()
                                                   : white.get());
    glDrawElements(GL_TRIANGLES, draw.count, GL_UNSIGNED_INT,
                   reinterpret_cast<const void*>(static_cast<std::uintptr_t>(draw.first) * sizeof(std::uint32_t)));
  }
  glBindVertexArray(0);
  glDepthMask(GL_TRUE);
  glDisable(GL_DEPTH_TEST);
  glBindSampler(kVirtualRatioUnit, 0);
  glBindSampler(kLightMapUnit, 0);
  check_gl_error("Compositor: drawing the building");
}

GLuint Compositor::State::building_program(bool sun_shadows) {
  gpu::Program& program = building_programs[sun_shadows ? 1 : 0];
  if (!program) {
    program = load_specialised(shader_dir, {"compose_building.vert", "compose_building.frag"},
                               define("VIRTUAL_PLANES", static_cast<int>(virtual_planes.size())) +
                                   define("SUN_SHADOWS", sun_shadows ? 1 : 0) + define("LIGHT_MAP", light_map ? 1 : 0) +
                                   define("FILTERED_LOOKUPS", filtered_lookups ? 1 : 0));
  }
  return program.get();
}

void Compositor::State::draw_composite(const CompositeInput& input) {
  const GLuint program = composite_program.get();
  const int width = lens.calibration().image_width;
  const int height = lens.calibration().image_height;
  glBindFramebuffer(GL_FRAMEBUFFER, composite_target.get());
  glViewport(0, 0, width, height);
  glUseProgram(program);
  const auto site_from_camera = column_major<3>(input.pose.R_site_from_camera);
  glUniformMatrix3fv(uniform(program, "site_from_camera"), 1, GL_FALSE, site_from_camera.data());
  set_vec3(uniform(program, "camera_position"), input.pose.t_site_from_camera);
  const PinholeCamera& pinhole = remap.pinhole;
  glUniform4f(uniform(program, "pinhole"), static_cast<float>(pinhole.fx), static_cast<float>(pinhole.fy),
              static_cast<float>(pinhole.cx), static_cast<float>(pinhole.cy));
  glUniform1f(uniform(program, "occlusion_margin"), static_cast<float>(options.occlusion_margin));
  const double opacity = std::isnan(input.opacity) ? 0.0 : std::clamp(input.opacity, 0.0, 1.0);
  glUniform1f(uniform(program, "opacity"), static_cast<float>(opacity));

  std::vector<Eigen::Vector3f> origin, s_axis, t_axis, normal;
  for (int plane : real_planes) {
    const PlaneGeometry g = plane_geometry(planes[static_cast<std::size_t>(plane)].plane);
    origin.push_back(g.origin);
    s_axis.push_back(g.s_axis);
    t_axis.push_back(g.t_axis);
    normal.push_back(g.normal);
  }
  set_vec3_array(program, "plane_origin", origin);
  set_vec3_array(program, "plane_s_axis", s_axis);
  set_vec3_array(program, "plane_t_axis", t_axis);
  set_vec3_array(program, "plane_normal", normal);

  glActiveTexture(GL_TEXTURE0 + kCameraUnit);
  glBindTexture(GL_TEXTURE_2D, camera_image.get());
  glActiveTexture(GL_TEXTURE0 + kRaysUnit);
  glBindTexture(GL_TEXTURE_2D, rays.get());
  glActiveTexture(GL_TEXTURE0 + kBuildingUnit);
  glBindTexture(GL_TEXTURE_2D, building.get());
  glBindSampler(kBuildingUnit, filtered_lookups ? bilinear.get() : 0);
  glActiveTexture(GL_TEXTURE0 + kBuildingDepthUnit);
  glBindTexture(GL_TEXTURE_2D, building_camera_depth.get());
  for (int j = 0; j < static_cast<int>(real_planes.size()); ++j) {
    const GLuint unit = kRealRatioUnit + static_cast<GLuint>(j);
    glActiveTexture(GL_TEXTURE0 + unit);
    glBindTexture(GL_TEXTURE_2D, ratio_texture(input, real_planes[static_cast<std::size_t>(j)]));
    glBindSampler(unit, filtered_lookups ? bilinear.get() : 0);
  }
  glBindVertexArray(empty_vertices.get());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glBindSampler(kBuildingUnit, 0);
  for (int j = 0; j < static_cast<int>(real_planes.size()); ++j) glBindSampler(kRealRatioUnit + static_cast<GLuint>(j), 0);
  glActiveTexture(GL_TEXTURE0);
  check_gl_error("Compositor: compositing");
}

Compositor::Compositor(const scene::Site& site, const scene::Mesh& mesh, const bake_format::Manifest& manifest,
                       std::span<const float> transfer, const camera::CameraCalibration& hmd, CompositorOptions options)
    : state_(std::make_unique<State>(hmd, std::move(options))) {
  State& s = *state_;
  const CompositorOptions& o = s.options;
  if (!(o.near > 0.0 && o.far > o.near && std::isfinite(o.far)) || !(o.cover_distance >= 0.0) ||
      !(o.cover_max_angle_deg >= 0.0 && o.cover_max_angle_deg <= 90.0) || !(o.occlusion_margin >= 0.0) ||
      !o.photometric.scale.allFinite()) {
    throw InputError(input_message({}, -1, -1, "compositor options",
                                   "near and far must satisfy 0 < near < far, the cover distance and the "
                                   "occlusion margin must be >= 0, the cover angle in [0, 90] degrees and the "
                                   "photometric scale finite",
                                   "correct the compositor's settings in the config"));
  }
  s.check_inputs(site, mesh, manifest, transfer);
  if (o.building_irradiance) {
    // Another compositor's sums (a stereo HMD's other eye): the same model and bake.
    if (o.building_irradiance->vertex_count() != mesh.vertex_count() ||
        o.building_irradiance->layer_count() != static_cast<std::size_t>(s.layer_count)) {
      throw std::invalid_argument("Compositor: the shared building irradiance was made for " +
                                  std::to_string(o.building_irradiance->vertex_count()) + " vertices and " +
                                  std::to_string(o.building_irradiance->layer_count()) + " layers, not this model's and bake's");
    }
    s.building_light = o.building_irradiance;
  } else {
    s.building_light = std::make_shared<const BuildingIrradiance>(mesh, manifest, transfer, o.ground_albedo, o.ground_transfer,
                                                                  std::move(s.options.light_map), o.light_map_precision);
  }
  s.options.ground_transfer = {};
  s.options.light_map = {};
  if (s.building_light->light_map_layout() != nullptr) {
    s.light_map.emplace(s.building_light->atlas_width(), s.building_light->atlas_height());
  }
  s.shader_dir = gpu::find_shader_dir(s.options.shader_dir);
  s.filtered_lookups = has_gl_extension("GL_OES_texture_float_linear");
  if (s.filtered_lookups) s.bilinear = bilinear_clamped_sampler();
  s.building_program(false);  // shader errors show at construction
  s.depth_program = gpu::load_program(s.shader_dir, {"compose_depth.vert", "compose_depth.frag"});
  s.composite_program = load_specialised(s.shader_dir, {"compose_fullscreen.vert", "compose_final.frag"},
                                         define("REAL_PLANES", static_cast<int>(s.real_planes.size())) +
                                             define("FILTERED_LOOKUPS", s.filtered_lookups ? 1 : 0));
  s.upload_building(mesh);
  s.make_targets();
  std::vector<PlaneRatioArray::Size> virtual_sizes;
  for (int plane : s.virtual_planes) {
    const geom::Plane& p = s.planes[static_cast<std::size_t>(plane)].plane;
    virtual_sizes.push_back({p.width, p.height});
  }
  s.virtual_ratios.emplace(virtual_sizes);
}

Compositor::~Compositor() = default;
Compositor::Compositor(Compositor&&) noexcept = default;
Compositor& Compositor::operator=(Compositor&&) noexcept = default;

void Compositor::draw(const CompositeInput& input) {
  State& s = *state_;
  const camera::CameraCalibration& calibration = s.lens.calibration();
  if (input.camera.cols != calibration.image_width || input.camera.rows != calibration.image_height ||
      (input.camera.type() != CV_8UC3 && input.camera.type() != CV_32FC3)) {
    throw InputError(input_message(calibration.file, -1, -1, "image_width",
                                   "the camera frame is " + std::to_string(input.camera.cols) + "×" +
                                       std::to_string(input.camera.rows) + " (OpenCV type " +
                                       std::to_string(input.camera.type()) + "), the HMD calibration " +
                                       std::to_string(calibration.image_width) + "×" +
                                       std::to_string(calibration.image_height) + " (8-bit or float BGR expected)",
                                   "use the calibration of the camera that records the frames, at its resolution"));
  }
  if (static_cast<int>(input.sky.size()) != s.layer_count) {
    throw InputError(input_message("manifest.json", -1, -1, "dome.faces",
                                   "the sky has " + std::to_string(input.sky.size()) + " values, the bake " +
                                       std::to_string(s.layer_count) + " basis layers",
                                   "estimate the sky on the bake's dome (the same frequency and basis)"));
  }
  s.stats = {};
  const std::vector<Eigen::Vector3d> sky_values = s.building_light->cleaned_sky(input.sky, &s.stats.sky_values_replaced);
  const PhotometricMatch photometric = input.photometric.value_or(s.options.photometric);

  s.timings = {};
  StageClock clock(s.options.time_stages);
  s.upload_camera(input.camera);
  s.timings.upload = clock.lap();
  s.draw_building(input, sky_values, photometric);
  s.timings.building = clock.lap();
  s.draw_composite(input);
  s.timings.composite = clock.lap();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

cv::Mat Compositor::composite(const CompositeInput& input) {
  draw(input);
  State& s = *state_;
  const camera::CameraCalibration& calibration = s.lens.calibration();
  StageClock clock(s.options.time_stages);

  const int width = calibration.image_width;
  const int height = calibration.image_height;
  glBindFramebuffer(GL_FRAMEBUFFER, s.composite_target.get());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  cv::Mat result;
  if (s.camera_format == GL_SRGB8_ALPHA8) {
    cv::Mat rgba(height, width, CV_8UC4);
    glReadBuffer(GL_COLOR_ATTACHMENT1);
    glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
    cv::cvtColor(rgba, result, cv::COLOR_RGBA2BGR);
  } else {
    cv::Mat rgba(height, width, CV_32FC4);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glReadPixels(0, 0, width, height, GL_RGBA, GL_FLOAT, rgba.data);
    cv::cvtColor(rgba, result, cv::COLOR_RGBA2BGR);
  }
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  check_gl_error("Compositor: reading the composite back");
  s.timings.read_back = clock.lap();
  return result;
}

cv::Mat Compositor::read_linear() const {
  const camera::CameraCalibration& calibration = state_->lens.calibration();
  cv::Mat rgba(calibration.image_height, calibration.image_width, CV_32FC4);
  glBindFramebuffer(GL_FRAMEBUFFER, state_->composite_target.get());
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, rgba.cols, rgba.rows, GL_RGBA, GL_FLOAT, rgba.data);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  check_gl_error("Compositor: reading the linear composite");
  cv::Mat bgr;
  cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
  return bgr;
}

GLuint Compositor::linear_texture() const { return state_->linear.get(); }
GLuint Compositor::display_texture() const { return state_->display.get(); }
const CompositeStats& Compositor::last_stats() const { return state_->stats; }
std::shared_ptr<const BuildingIrradiance> Compositor::building_irradiance() const { return state_->building_light; }
const CompositeTimings& Compositor::last_timings() const { return state_->timings; }
const LensRemap& Compositor::lens_remap() const { return state_->remap; }
const camera::Lens& Compositor::lens() const { return state_->lens; }
const std::vector<scene::PlaneSurface>& Compositor::plane_surfaces() const { return state_->surfaces; }

cv::Mat Compositor::region_mask(int plane, double s0, double s1, double t0, double t1, const CameraPose& pose) const {
  const State& s = *state_;
  if (plane < 0 || plane >= static_cast<int>(s.planes.size())) {
    throw InputError(input_message("manifest.json", -1, -1, "planes",
                                   "there is no plane number " + std::to_string(plane),
                                   "choose a plane from 0 to " + std::to_string(static_cast<int>(s.planes.size()) - 1)));
  }
  const geom::Plane& p = s.planes[static_cast<std::size_t>(plane)].plane;
  const PlaneGeometry g = plane_geometry(p);
  const Eigen::Vector3d normal = p.normal();
  cv::Mat mask(s.remap.rays.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < mask.rows; ++y) {
    const auto* ray = s.remap.rays.ptr<cv::Vec4f>(y);
    auto* out = mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < mask.cols; ++x) {
      if (ray[x][3] < 0.5f) continue;
      const Eigen::Vector3d d = pose.R_site_from_camera * Eigen::Vector3d(ray[x][0], ray[x][1], ray[x][2]);
      const double facing = d.dot(normal);
      if (std::abs(facing) < 1e-12) continue;
      const double distance = (p.origin - pose.t_site_from_camera).dot(normal) / facing;
      if (!(distance > 0.0)) continue;
      const Eigen::Vector3d offset = pose.t_site_from_camera + distance * d - p.origin;
      const double u = offset.dot(g.s_axis.cast<double>());
      const double v = offset.dot(g.t_axis.cast<double>());
      if (u >= s0 && u <= s1 && v >= t0 && v <= t1) out[x] = 255;
    }
  }
  return mask;
}

}  // namespace skylit::render
