#pragma once
// The composite the HMD shows: the camera image as the background, the virtual building's
// shadow on the real ground, and the building itself, sky-lit, drawn with depth from the camera
// pose through the HMD camera's calibrated lens (docs/live.md, "Rendering and compositing").
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <GLES3/gl31.h>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "skylit/bake_format/light_map.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/gpu/gl.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/render/building_irradiance.hpp"
#include "skylit/render/lens_remap.hpp"
#include "skylit/render/photometric.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/render/textures.hpp"  // upload_shadow_ratio, for the compositor's callers
#include "skylit/scene/mesh.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::render {

// Shader limits: texture units per pass (the ES 3.1 minimum is 16 per stage).
inline constexpr int kMaxVirtualPlanes = 8;
inline constexpr int kMaxRealPlanes = 8;

struct CompositorOptions {
  std::filesystem::path shader_dir;    // empty: gpu::find_shader_dir's default search
  double cover_distance = 0.05;        // m: how far a fragment may lie from a virtual plane it takes T from
  double cover_max_angle_deg = 15.0;   // and how far its normal may turn from the plane's
  double occlusion_margin = 0.05;      // m: a real plane hides the building when nearer by more than this
  double near = 0.05;                  // m: the building's clipping range from the camera
  double far = 5000.0;
  LensRemapOptions lens;
  PhotometricMatch photometric;        // k, unless a frame gives its own
  // Measure each stage's time (CompositeTimings) with a glFinish after each: this serialises
  // the GPU with the CPU, so it is for benchmarks and profiling, not for a display.
  bool time_stages = false;
  // The ground's light on the building (docs/method.md, "Light from the ground"): a lambertian
  // ground of this albedo (RGB, each in [0, 1]; zero: none) lit by the frame's sky and sources,
  // through the bake's ground layer: ground_transfer is its ground_transfer.npy (vertices ×
  // layers, as transfer). InputError when the albedo is set and the bake has no ground layer.
  Eigen::Vector3d ground_albedo = Eigen::Vector3d::Zero();
  std::vector<float> ground_transfer;
  // The bake's light map (bake_format/light_map.hpp; manifest.light_map; no texels: none): where a
  // triangle lies on one of its charts, the sky's light (and the ground's, with ground_albedo) comes
  // from its texels, bilinear, instead of from the triangle's corners (its ground transfer needed
  // with ground_albedo). InputError when it does not fit the model or the bake.
  bake_format::LightMapArrays light_map;
  // How the light map's values are held for its sums (render/building_irradiance.hpp).
  LightMapPrecision light_map_precision = LightMapPrecision::Float;
  // The building's sums per sky made already (another compositor's building_irradiance(): a
  // stereo HMD's other eye): used instead of making them from transfer, ground_albedo,
  // ground_transfer and light_map, which are then ignored. It must be of the same model and bake.
  std::shared_ptr<const BuildingIrradiance> building_irradiance;
};

// Where the camera is: the HMD camera frame (OpenCV's) in the site frame.
struct CameraPose {
  Eigen::Matrix3d R_site_from_camera = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_site_from_camera = Eigen::Vector3d::Zero();
};

struct CompositeInput {
  // CV_8UC3 (sRGB codes) or CV_32FC3 (linear), BGR, the HMD calibration's size.
  cv::Mat camera;
  CameraPose pose;
  // S_i, RGB, one per basis layer of the bake (per dome face with the faces basis; the layers
  // blend::blend_weights takes). Non-finite values count as 0 (and are counted in CompositeStats):
  // one bad sky frame must not blank the display; so do negative ones in a faces basis. A corner's
  // or quadratic's coefficient may be negative, a fit's undershoot beside a bright spot: it is
  // kept, as the blend keeps it, and the building's sums are clamped at 0
  // (BuildingIrradiance::cleaned_sky).
  std::span<const Eigen::Vector3d> sky;
  std::optional<blend::SunLight> sun;
  // One per bake plane (manifest order): a texture whose texel (col, row) holds T of plane texel
  // (col, row) in rgb (RGBA8, RGBA16F or RGBA32F), filtered bilinearly: through the compositor's
  // own sampler where float textures are filterable (OES_texture_float_linear), else in the
  // shader with texelFetch, so no format needs to be filterable and the texture's own filter
  // settings do not matter. 0 or an empty span: T = 1.
  std::span<const GLuint> shadow_ratios;
  // The sun's shadow map for the building's own sun shadows (penumbra included: the map's
  // sun_visibility, shaders/sun_shadow.glsl), updated for this sun. Null: the sun term is
  // unshadowed (CompositeStats says so).
  const SunShadowMap* sun_shadow = nullptr;
  // Separated sources after the sun (lamps: the sky stage's sources[1…]), with each one's visible
  // fraction at every model vertex (SunShadowMap::read_vertex_visibility(k + 1): one value per
  // vertex, or empty for 1). A lamp lights the building per vertex, E_k max(0, n_v·ω_k) V_k(v)
  // added to the transfer sum, and a virtual plane through its D_j; its shadow on the ground
  // comes with the shadow ratios (the GPU blend's separated terms). Bad energies count as 0.
  std::span<const blend::SunLight> lamps;
  std::span<const std::vector<float>> lamp_vertex_visibility;
  // This sky's sums, made ahead by the compositor's building_irradiance() (its sum(sky, sun,
  // lamps), e.g. on the thread that estimated the sky): taken when the sky changes, if they were
  // made by it for this frame's sky and sources; otherwise (or null) the compositor sums itself.
  std::shared_ptr<const SkyIrradiance> irradiance;
  std::optional<PhotometricMatch> photometric;   // overrides CompositorOptions::photometric
  // α: how much of the virtual content (the building and its shadows) is shown, a linear blend
  // of the composite towards the camera image (the live service fades the building out when
  // tracking is lost, and in again when it returns). Clamped to [0, 1]; NaN counts as 0, since
  // a building drawn where it may be wrong is worse than none.
  double opacity = 1.0;
};

struct CompositeStats {
  int sky_values_replaced = 0;            // non-finite S_i (or negative in a faces basis) or bad E_sun channels taken as 0
  std::int64_t camera_values_replaced = 0;  // non-finite or negative float camera values taken as 0
  bool sun_without_shadow_map = false;    // a sun and no shadow map: the building's sun term is unshadowed
  bool building_light_summed = false;     // the sky changed without sums made ahead for it: summed in this frame
};

// Time of each stage of the last frame, in milliseconds; all 0 unless
// CompositorOptions::time_stages is set. wall: elapsed time; cpu: CPU time of the whole process
// over the stage (all threads: on a software renderer such as llvmpipe, the work done, which
// depends far less than wall time on what else loads the machine).
struct CompositeTimings {
  struct Stage {
    double wall_ms = 0;
    double cpu_ms = 0;
  };
  Stage upload;      // the camera frame to the GPU (with its conversion on the CPU)
  Stage building;    // the building rendered at the pinhole size
  Stage composite;   // the pass over the camera pixels
  Stage read_back;   // composite() only: glReadPixels and the cv::Mat
};

// The unoccluded irradiance of plane `plane` (RGB): D_j = Σ_i S_i A_{j,i} + E_sun max(0, n_j·ω_sun)
// + Σ_k E_k max(0, n_j·ω_k) over the lamps, the denominator of its shadow ratio. Non-finite S_i
// count as 0 (a negative one is kept: a corner's or quadratic's coefficient may be negative, and
// the blend keeps it), non-finite or negative energies as 0; the sum is at least 0.
Eigen::Vector3d plane_irradiance(const bake_format::PlaneRecord& plane, std::span<const Eigen::Vector3d> sky,
                                 const std::optional<blend::SunLight>& sun, std::span<const blend::SunLight> lamps = {});

// Per output pixel p, with the ray the lens model gives p:
//   background  B = camera(p), linear (8-bit frames are sRGB-decoded; float frames are linear),
//               × T_j(x) where the ray meets a real plane j first (x the hit point);
//   building    radiance L = k ⊙ ρ/π · E (ρ the glTF base colour × texture, k the photometric
//               match), with
//                 E = T_j(x) ⊙ (Σ_i S_i A_{j,i} + E_sun max(0, n_j·ω_sun))  where a virtual
//                     plane j covers the fragment (within cover_distance of its rectangle,
//                     normals within cover_max_angle_deg): exact, and no double occlusion;
//                 E = Σ_i S_i t_{v,i} (interpolated) + E_sun max(0, n·ω_sun) V_sun  elsewhere,
//                     V_sun from the sun's shadow map (SunShadowMap; 1 without one), and each
//                     lamp's E_k max(0, n_v·ω_k) V_k(v) per vertex, interpolated with the sum;
//   output      L over B, except where a real plane is nearer than the building by more than
//               occlusion_margin (the real surface hides it);
//   faded       (1 − α) camera(p) + α output, α = CompositeInput::opacity: α = 1 is the output,
//               α = 0 the camera image unchanged (no building, no shadows).
// The building is rendered with a pinhole camera and distorted to the lens through a per-pixel
// ray table (lens_remap.hpp); the camera's pixels are never resampled.
//
// Speed (a software renderer, llvmpipe, runs every branch of a shader for a group of pixels):
// the shaders are compiled for the site (its numbers of real and virtual planes; with and
// without the sun's shadow map), the building gets a depth pre-pass so that each render texel
// is shaded once, and the sun's soft shadow is sampled through SunShadowMap's minimum/maximum
// pyramid (bench/RESULTS.md, "Compositor").
//
// Everything runs in the OpenGL ES context current when the Compositor is made (it must stay
// current for every call, and alive until the Compositor is destroyed). A Compositor owns every
// GL object it draws with or into (programs, the building's buffers and textures, the camera
// texture, its targets, display_texture) and sets all the GL state it draws with; it only reads
// the input's shadow-ratio textures and sun shadow map. So several Compositors (one per camera
// of a stereo HMD, stereo_camera.hpp) share one context and the same inputs, and one
// BuildingIrradiance (CompositorOptions::building_irradiance); the building's light is summed on
// the CPU once per sky, ahead on another thread (CompositeInput::irradiance), or else by each
// compositor for itself.
class Compositor {
 public:
  // transfer: the bake's transfer.npy, vertex_count × layer_count floats (vertex-major). The site
  // names each bake plane's surface (matched by name); the mesh must be the one the bake was made
  // from (same vertex order). InputError naming the file and the fix when they do not fit, or when
  // there are more than kMaxVirtualPlanes virtual or kMaxRealPlanes real planes.
  Compositor(const scene::Site& site, const scene::Mesh& mesh, const bake_format::Manifest& manifest,
             std::span<const float> transfer, const camera::CameraCalibration& hmd,
             CompositorOptions options = {});
  ~Compositor();
  Compositor(Compositor&&) noexcept;
  Compositor& operator=(Compositor&&) noexcept;
  Compositor(const Compositor&) = delete;
  Compositor& operator=(const Compositor&) = delete;

  // Draws one frame into linear_texture() and display_texture() (for a display: no read-back,
  // no wait for the GPU). InputError as composite. The building's light (per vertex and per
  // light-map texel) is summed on the CPU (calling thread) only when input.sky or its sources
  // differ from the last frame's, and input.irradiance does not bring the sums for them.
  void draw(const CompositeInput& input);
  // Draws one frame and reads it back: CV_8UC3 sRGB for an 8-bit camera frame, CV_32FC3 linear
  // for a float one (BGR, the camera's size). InputError for a frame of the wrong size or type,
  // or a sky with the wrong number of layers.
  cv::Mat composite(const CompositeInput& input);

  // The last composite, kept on the GPU: linear RGBA32F, and sRGB-encoded RGBA8 for display. Texel
  // row 0 is the image's top row.
  GLuint linear_texture() const;
  GLuint display_texture() const;
  cv::Mat read_linear() const;      // CV_32FC3 BGR of linear_texture()
  const CompositeStats& last_stats() const;
  // The building's sums per sky (thread-safe; shareable with another compositor of the same model
  // and bake, and with a thread that sums ahead for CompositeInput::irradiance).
  std::shared_ptr<const BuildingIrradiance> building_irradiance() const;
  const CompositeTimings& last_timings() const;

  const LensRemap& lens_remap() const;
  const camera::Lens& lens() const;
  // Which bake planes are real (manifest order).
  const std::vector<scene::PlaneSurface>& plane_surfaces() const;

  // CV_8U mask (255 inside) of the camera pixels whose ray meets bake plane `plane` inside the
  // rectangle s ∈ [s0, s1], t ∈ [t0, t1] of its coordinates (origin + s·u + t·v): the reference
  // region for estimate_photometric_match. The building is not tested: choose a region that it
  // neither hides nor shadows (the estimator's median tolerates a few such pixels).
  cv::Mat region_mask(int plane, double s0, double s1, double t0, double t1, const CameraPose& pose) const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace skylit::render
