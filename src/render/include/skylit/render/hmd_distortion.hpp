#pragma once
// The HMD's lens correction: each eye's image is drawn onto the panel through a mesh that
// pre-distorts it (barrel) so that the lens (pincushion) shows it straight, per colour channel, so
// that the lens's chromatic aberration is cancelled too (docs/hmd.md).
#include <array>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <GLES3/gl31.h>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "skylit/gpu/gl.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/render/hmd_profile.hpp"

namespace skylit::render {

// The mapping, for a panel point p in eye e's viewport (pixels from its top-left), lens centre c
// and radius R (HmdProfile): channel ch of p shows the eye image at
//     q_ch = c + (p − c) · (1 + k1 r² + k2 r⁴ + k3 r⁶),   r = |p − c| / R
// in viewport pixels; the eye image is fitted into the viewport with its aspect ratio kept and its
// centre on the lens centre. A point that falls outside the image shows black.
//
// Where channel `channel` (0 red, 1 green, 2 blue) of the panel point `p` (pixels of eye `eye`'s
// viewport, from its top-left corner; a pixel's centre is at +0.5) samples an eye image of
// image_width × image_height: texture coordinates, (0, 0) the image's top-left corner, (1, 1) its
// bottom-right. Outside [0, 1]² the point shows black.
Eigen::Vector2d eye_image_coordinate(const HmdProfile& profile, int eye, int channel, const Eigen::Vector2d& p,
                                     int image_width, int image_height);

// The inverse: the viewport point whose channel `channel` shows the eye image's point `uv`
// (texture coordinates), or nullopt when the lens does not show that point (the radial mapping
// does not reach it).
std::optional<Eigen::Vector2d> panel_point_of(const HmdProfile& profile, int eye, int channel,
                                              const Eigen::Vector2d& uv, int image_width, int image_height);

// The GPU pass evaluates the mapping at the vertices of a grid per eye (texture coordinates per
// channel computed on the CPU) and interpolates it linearly between them; the fragment shader
// samples the eye image once per channel. distort_reference is the exact mapping per pixel on the
// CPU, the pass's reference.
//
// One vertex of the distortion mesh: its panel position in pixels (x across the whole panel,
// y from the top) and a texture coordinate per channel.
struct DistortionVertex {
  float x = 0;
  float y = 0;
  std::array<float, 6> uv{};  // red u, v, green u, v, blue u, v
};

// The mesh of eye `eye`: (grid + 1)² vertices over its viewport, row by row from the top.
std::vector<DistortionVertex> make_distortion_mesh(const HmdProfile& profile, int eye, int image_width,
                                                   int image_height, int grid);

// The exact mapping on the CPU: the panel (CV_8UC3 BGR, panel_width × panel_height) showing
// eye_images (CV_8UC3 BGR, all of one size; one per eye, or one shown to every eye), each channel
// sampled bilinearly at its coordinate as GL samples a texture (texel centres at +0.5, edges
// clamped). The eye images' rows start at the top.
cv::Mat distort_reference(const HmdProfile& profile, std::span<const cv::Mat> eye_images);

// An RGBA8 texture of a CV_8UC3 BGR image, texel row 0 the image's top (as the compositor's
// display texture): for tests and benchmarks, and for showing images that come from the CPU.
gpu::Texture upload_eye_image(const cv::Mat& bgr);

struct HmdDistortionOptions {
  std::filesystem::path shader_dir;  // empty: gpu::find_shader_dir's default search
  // Cells per side of each eye's mesh. The linear interpolation's error falls as 1/grid²: on the
  // generic profile, up to 1.7 image pixels at 40, 0.17 at 128 (where the lens bends hardest).
  int grid = 128;
};

// The distortion pass (the context must be current while it lives). Draws into its own RGBA8
// texture of the panel's size; texel row 0 is the panel's top row, as WindowContext::present takes.
class HmdDistortion {
 public:
  explicit HmdDistortion(const HmdProfile& profile, HmdDistortionOptions options = {});
  ~HmdDistortion();
  HmdDistortion(HmdDistortion&&) noexcept;
  HmdDistortion& operator=(HmdDistortion&&) noexcept;
  HmdDistortion(const HmdDistortion&) = delete;
  HmdDistortion& operator=(const HmdDistortion&) = delete;

  // Clears the panel to black.
  void begin_frame();
  // Draws `texture` (width × height, texel row 0 the image's top, e.g. Compositor::display_texture)
  // through eye `eye`'s mesh into its viewport: one draw. The mesh is rebuilt when the size changes.
  void draw_eye(int eye, GLuint texture, int width, int height);
  // begin_frame and every eye: one texture per eye, or one shown to every eye.
  void draw(std::span<const GLuint> textures, int width, int height);

  const HmdProfile& profile() const;
  GLuint panel_texture() const;
  cv::Mat read_panel() const;  // CV_8UC3 BGR of panel_texture(), row 0 the top

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// What each eye sees with one HMD camera. A stereo camera (a camera per eye) has its own frame:
// draw_hmd_frame of stereo_camera.hpp.
enum class StereoMode {
  mono,    // one composite, shown to every eye
  // One composite per eye, each from its own eye's position, over the one camera image both
  // share: the compromise of a single camera, whose real world has no parallax.
  stereo,
};

// The pose of eye `eye` (0 left, 1 right) of a head whose camera is at `camera`: shifted by half
// the IPD along the camera's x axis (OpenCV's: right), left eye −ipd/2, right eye +ipd/2.
CameraPose eye_pose(const CameraPose& camera, double ipd, int eye);

// One HMD frame: the composite (mono), or one per eye from eye_pose with the profile's IPD
// (stereo: the building and its shadows drawn per eye, the camera image shared), each drawn
// through its eye's distortion mesh into hmd.panel_texture(). No read-back, no wait for the GPU.
// A single-layout profile shows one image whatever the mode.
void draw_hmd_frame(Compositor& compositor, HmdDistortion& hmd, const CompositeInput& input, StereoMode mode);

}  // namespace skylit::render
