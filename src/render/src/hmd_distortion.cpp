// The HMD's lens-correction pass and its CPU reference (see hmd_distortion.hpp).
#include "skylit/render/hmd_distortion.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

#include "skylit/gpu/shader.hpp"

namespace skylit::render {

namespace {

// The eye image fitted into the viewport, aspect ratio kept, centred on the lens centre: its
// top-left corner and its scale (viewport pixels per image pixel).
struct ImagePlacement {
  Eigen::Vector2d origin;
  double scale = 1;
};

ImagePlacement place_image(const HmdProfile& profile, int eye, int image_width, int image_height) {
  const double scale = std::min(static_cast<double>(profile.eye_width()) / image_width,
                                static_cast<double>(profile.eye_height()) / image_height);
  const Eigen::Vector2d centre = profile.lens_center[static_cast<std::size_t>(eye)];
  return {centre - 0.5 * scale * Eigen::Vector2d(image_width, image_height), scale};
}

void check_eye(const HmdProfile& profile, int eye) {
  if (eye < 0 || eye >= profile.eye_count()) {
    throw std::invalid_argument("HMD distortion: eye " + std::to_string(eye) + " of a profile with " +
                                std::to_string(profile.eye_count()) + " eye(s)");
  }
}

// GL's bilinear sample of channel `c` of a CV_8UC3 image at texture coordinates uv (texel centres
// at +0.5, edges clamped), in code values.
double sample_bilinear(const cv::Mat& image, int c, const Eigen::Vector2d& uv) {
  const double x = uv.x() * image.cols - 0.5, y = uv.y() * image.rows - 0.5;
  const double fx = std::floor(x), fy = std::floor(y);
  const double ax = x - fx, ay = y - fy;
  auto at = [&](double col, double row) {
    const int i = std::clamp(static_cast<int>(col), 0, image.cols - 1);
    const int j = std::clamp(static_cast<int>(row), 0, image.rows - 1);
    return static_cast<double>(image.at<cv::Vec3b>(j, i)[c]);
  };
  return (1 - ay) * ((1 - ax) * at(fx, fy) + ax * at(fx + 1, fy)) + ay * ((1 - ax) * at(fx, fy + 1) + ax * at(fx + 1, fy + 1));
}

using gpu::Sampler;

}  // namespace

Eigen::Vector2d eye_image_coordinate(const HmdProfile& profile, int eye, int channel, const Eigen::Vector2d& p,
                                     int image_width, int image_height) {
  check_eye(profile, eye);
  const Eigen::Vector2d centre = profile.lens_center[static_cast<std::size_t>(eye)];
  const Eigen::Vector2d offset = p - centre;
  const double r2 = offset.squaredNorm() / (profile.lens_radius * profile.lens_radius);
  const Eigen::Vector2d q = centre + offset * profile.distortion[static_cast<std::size_t>(channel)].scale(r2);
  const ImagePlacement placement = place_image(profile, eye, image_width, image_height);
  const Eigen::Vector2d image = (q - placement.origin) / placement.scale;
  return {image.x() / image_width, image.y() / image_height};
}

std::optional<Eigen::Vector2d> panel_point_of(const HmdProfile& profile, int eye, int channel,
                                              const Eigen::Vector2d& uv, int image_width, int image_height) {
  check_eye(profile, eye);
  const ImagePlacement placement = place_image(profile, eye, image_width, image_height);
  const Eigen::Vector2d centre = profile.lens_center[static_cast<std::size_t>(eye)];
  const Eigen::Vector2d q = placement.origin + placement.scale * Eigen::Vector2d(uv.x() * image_width, uv.y() * image_height);
  const Eigen::Vector2d offset = q - centre;
  const double target = offset.norm() / profile.lens_radius;  // normalised radius of q
  if (target == 0) return centre;
  // g(ρ) = ρ · (1 + k1 ρ² + k2 ρ⁴ + k3 ρ⁶) = target, by bisection over the rising part of g.
  const RadialDistortion& lens = profile.distortion[static_cast<std::size_t>(channel)];
  auto g = [&](double rho) { return rho * lens.scale(rho * rho); };
  double lo = 0, hi = 0;
  const double step = 1e-3;
  while (g(hi + step) > g(hi) && g(hi) < target) {
    hi += step;
    if (hi > 100) return std::nullopt;
  }
  if (g(hi) < target) return std::nullopt;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (g(mid) < target ? lo : hi) = mid;
  }
  const double rho = 0.5 * (lo + hi);
  return centre + offset * (rho / target);
}

std::vector<DistortionVertex> make_distortion_mesh(const HmdProfile& profile, int eye, int image_width,
                                                   int image_height, int grid) {
  check_eye(profile, eye);
  if (grid < 1) throw std::invalid_argument("HMD distortion: the mesh needs at least one cell");
  std::vector<DistortionVertex> vertices;
  vertices.reserve(static_cast<std::size_t>(grid + 1) * static_cast<std::size_t>(grid + 1));
  const double width = profile.eye_width(), height = profile.eye_height();
  for (int row = 0; row <= grid; ++row) {
    for (int col = 0; col <= grid; ++col) {
      const Eigen::Vector2d p(width * col / grid, height * row / grid);
      DistortionVertex v;
      v.x = static_cast<float>(p.x() + profile.eye_left(eye));
      v.y = static_cast<float>(p.y());
      for (int c = 0; c < 3; ++c) {
        const Eigen::Vector2d uv = eye_image_coordinate(profile, eye, c, p, image_width, image_height);
        v.uv[static_cast<std::size_t>(2 * c)] = static_cast<float>(uv.x());
        v.uv[static_cast<std::size_t>(2 * c + 1)] = static_cast<float>(uv.y());
      }
      vertices.push_back(v);
    }
  }
  return vertices;
}

cv::Mat distort_reference(const HmdProfile& profile, std::span<const cv::Mat> eye_images) {
  if (eye_images.empty()) throw std::invalid_argument("distort_reference: no eye image");
  cv::Mat panel(profile.panel_height, profile.panel_width, CV_8UC3, cv::Scalar::all(0));
  for (int eye = 0; eye < profile.eye_count(); ++eye) {
    const cv::Mat& image = eye_images[std::min<std::size_t>(static_cast<std::size_t>(eye), eye_images.size() - 1)];
    if (image.type() != CV_8UC3) throw std::invalid_argument("distort_reference: eye images are CV_8UC3");
    for (int y = 0; y < profile.eye_height(); ++y) {
      for (int x = 0; x < profile.eye_width(); ++x) {
        cv::Vec3b& out = panel.at<cv::Vec3b>(y, x + profile.eye_left(eye));
        for (int c = 0; c < 3; ++c) {
          const Eigen::Vector2d uv = eye_image_coordinate(profile, eye, c, Eigen::Vector2d(x + 0.5, y + 0.5),
                                                          image.cols, image.rows);
          if (uv.x() < 0 || uv.x() > 1 || uv.y() < 0 || uv.y() > 1) continue;
          // Channel c is red, green, blue; the image is BGR.
          out[2 - c] = cv::saturate_cast<std::uint8_t>(sample_bilinear(image, 2 - c, uv));
        }
      }
    }
  }
  return panel;
}

gpu::Texture upload_eye_image(const cv::Mat& bgr) {
  if (bgr.type() != CV_8UC3) throw std::invalid_argument("upload_eye_image: a CV_8UC3 BGR image");
  cv::Mat rgba;
  cv::cvtColor(bgr, rgba, cv::COLOR_BGR2RGBA);
  gpu::Texture texture = gpu::make_texture();
  glBindTexture(GL_TEXTURE_2D, texture.get());
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, rgba.cols, rgba.rows);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, rgba.cols, rgba.rows, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
  gpu::check_gl_error("upload_eye_image");
  return texture;
}

struct HmdDistortion::State {
  HmdProfile profile;
  HmdDistortionOptions options;
  gpu::Program program;
  GLint panel_size_location = -1;
  Sampler sampler;
  gpu::Texture panel;
  gpu::Framebuffer target;
  gpu::Buffer indices;
  GLsizei index_count = 0;
  struct EyeMesh {
    gpu::VertexArray vertex_array;
    gpu::Buffer vertices;
    int image_width = 0;
    int image_height = 0;
  };
  std::array<EyeMesh, 2> eyes;
};

HmdDistortion::HmdDistortion(const HmdProfile& profile, HmdDistortionOptions options)
    : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.profile = profile;
  s.options = std::move(options);
  if (s.options.grid < 1) throw std::invalid_argument("HmdDistortion: grid must be at least 1");
  s.program = gpu::load_program(gpu::find_shader_dir(s.options.shader_dir), {"hmd_distortion.vert", "hmd_distortion.frag"});
  s.panel_size_location = glGetUniformLocation(s.program.get(), "panel_size");

  GLuint sampler = 0;
  glGenSamplers(1, &sampler);
  s.sampler = Sampler(sampler);
  glSamplerParameteri(sampler, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glSamplerParameteri(sampler, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glSamplerParameteri(sampler, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glSamplerParameteri(sampler, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);

  s.panel = gpu::make_texture();
  glBindTexture(GL_TEXTURE_2D, s.panel.get());
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, profile.panel_width, profile.panel_height);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  s.target = gpu::make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, s.target.get());
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, s.panel.get(), 0);
  gpu::check_framebuffer_complete(GL_FRAMEBUFFER, "HmdDistortion");
  glBindFramebuffer(GL_FRAMEBUFFER, 0);

  // Two triangles per cell, shared by both eyes' meshes.
  const int grid = s.options.grid;
  std::vector<GLuint> indices;
  for (int row = 0; row < grid; ++row) {
    for (int col = 0; col < grid; ++col) {
      const auto v = static_cast<GLuint>(row * (grid + 1) + col);
      const auto below = v + static_cast<GLuint>(grid + 1);
      indices.insert(indices.end(), {v, v + 1, below, v + 1, below + 1, below});
    }
  }
  s.index_count = static_cast<GLsizei>(indices.size());
  s.indices = gpu::make_buffer();
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, s.indices.get());
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(indices.size() * sizeof(GLuint)), indices.data(), GL_STATIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, 0);
  for (State::EyeMesh& eye : s.eyes) {
    eye.vertex_array = gpu::make_vertex_array();
    eye.vertices = gpu::make_buffer();
  }
  gpu::check_gl_error("HmdDistortion");
}

HmdDistortion::~HmdDistortion() = default;
HmdDistortion::HmdDistortion(HmdDistortion&&) noexcept = default;
HmdDistortion& HmdDistortion::operator=(HmdDistortion&&) noexcept = default;

void HmdDistortion::begin_frame() {
  glBindFramebuffer(GL_FRAMEBUFFER, state_->target.get());
  glViewport(0, 0, state_->profile.panel_width, state_->profile.panel_height);
  glClearColor(0, 0, 0, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void HmdDistortion::draw_eye(int eye, GLuint texture, int width, int height) {
  State& s = *state_;
  check_eye(s.profile, eye);
  if (width < 1 || height < 1) throw std::invalid_argument("HmdDistortion::draw_eye: an empty eye image");
  State::EyeMesh& mesh = s.eyes[static_cast<std::size_t>(eye)];
  if (mesh.image_width != width || mesh.image_height != height) {
    const std::vector<DistortionVertex> vertices = make_distortion_mesh(s.profile, eye, width, height, s.options.grid);
    glBindVertexArray(mesh.vertex_array.get());
    glBindBuffer(GL_ARRAY_BUFFER, mesh.vertices.get());
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(DistortionVertex)), vertices.data(),
                 GL_STATIC_DRAW);
    constexpr auto stride = static_cast<GLsizei>(sizeof(DistortionVertex));
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(DistortionVertex, x)));
    for (GLuint c = 0; c < 3; ++c) {
      glEnableVertexAttribArray(1 + c);
      glVertexAttribPointer(1 + c, 2, GL_FLOAT, GL_FALSE, stride,
                            reinterpret_cast<const void*>(offsetof(DistortionVertex, uv) + 2 * c * sizeof(float)));
    }
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, s.indices.get());
    glBindVertexArray(0);
    mesh.image_width = width;
    mesh.image_height = height;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, s.target.get());
  glViewport(0, 0, s.profile.panel_width, s.profile.panel_height);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glUseProgram(s.program.get());
  glUniform2f(s.panel_size_location, static_cast<float>(s.profile.panel_width), static_cast<float>(s.profile.panel_height));
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, texture);
  glBindSampler(0, s.sampler.get());
  glBindVertexArray(mesh.vertex_array.get());
  glDrawElements(GL_TRIANGLES, s.index_count, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  glBindSampler(0, 0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gpu::check_gl_error("HmdDistortion::draw_eye");
}

void HmdDistortion::draw(std::span<const GLuint> textures, int width, int height) {
  if (textures.empty()) throw std::invalid_argument("HmdDistortion::draw: no eye texture");
  begin_frame();
  for (int eye = 0; eye < state_->profile.eye_count(); ++eye) {
    draw_eye(eye, textures[std::min<std::size_t>(static_cast<std::size_t>(eye), textures.size() - 1)], width, height);
  }
}

const HmdProfile& HmdDistortion::profile() const { return state_->profile; }

GLuint HmdDistortion::panel_texture() const { return state_->panel.get(); }

cv::Mat HmdDistortion::read_panel() const {
  const State& s = *state_;
  cv::Mat rgba(s.profile.panel_height, s.profile.panel_width, CV_8UC4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, s.target.get());
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, rgba.cols, rgba.rows, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  gpu::check_gl_error("HmdDistortion::read_panel");
  cv::Mat bgr;
  cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
  return bgr;
}

CameraPose eye_pose(const CameraPose& camera, double ipd, int eye) {
  if (eye != 0 && eye != 1) throw std::invalid_argument("eye_pose: eye 0 (left) or 1 (right)");
  CameraPose pose = camera;
  const double side = eye == 0 ? -0.5 : 0.5;
  pose.t_site_from_camera += camera.R_site_from_camera.col(0) * (side * ipd);
  return pose;
}

void draw_hmd_frame(Compositor& compositor, HmdDistortion& hmd, const CompositeInput& input, StereoMode mode) {
  const HmdProfile& profile = hmd.profile();
  const int width = input.camera.cols, height = input.camera.rows;
  hmd.begin_frame();
  if (mode == StereoMode::mono || profile.eye_count() == 1) {
    compositor.draw(input);
    for (int eye = 0; eye < profile.eye_count(); ++eye) hmd.draw_eye(eye, compositor.display_texture(), width, height);
    return;
  }
  // The compositor keeps one display texture: each eye is drawn through its mesh before the
  // next eye's composite overwrites it.
  CompositeInput eye_input = input;
  for (int eye = 0; eye < 2; ++eye) {
    eye_input.pose = eye_pose(input.pose, profile.ipd, eye);
    compositor.draw(eye_input);
    hmd.draw_eye(eye, compositor.display_texture(), width, height);
  }
}

}  // namespace skylit::render
