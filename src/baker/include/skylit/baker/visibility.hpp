#pragma once
// Visibility engines: for a set of sample directions inside one dome face, the fraction of
// light from those directions that reaches each plane texel and each model vertex. Two engines,
// same contract: `raster` (OpenGL ES 3.1 shadow maps, headless EGL) and `raytrace` (Embree 3 on
// the CPU, the reference).
#include <array>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>

#include "skylit/geom/plane.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::baker {

using geom::Vec3;

// An engine weighs up to this many layers in one pass (a bake with more per face runs several).
inline constexpr std::size_t kEngineLayers = 3;
// The weights of one sample direction for up to kEngineLayers layers (unused layers: 0).
using SampleWeights = std::array<float, kEngineLayers>;

// With c_s = max(0, n·ω_s) and V_s = 1 when nothing of the model lies along ω_s, and per-sample
// weights w_{k,s} for the layers k of the face (the faces basis: one layer, w = 1; the corners
// basis: three layers, w = the sample's barycentric coordinates in the face):
//     f_k = Σ_s w_{k,s} c_s V_s / Σ_s w_{k,s} c_s,   or  Σ_s V_s / K  when Σ_s w_{k,s} c_s = 0,
// all layers in one pass. The baker stores B_{j,l} = A_{j,l} · f_l, with A_{j,l} the cosine
// integral of the layer's basis function over the face: an unoccluded texel gets B = A exactly,
// and a plane that faces away gets A = B = 0.
class VisibilityEngine {
 public:
  virtual ~VisibilityEngine() = default;
  virtual std::string name() const = 0;

  // Sets the sample directions (unit, site frame, pointing towards the sky) for the calls that
  // follow, with one layer of weight 1 (the faces basis); a raster engine renders its shadow
  // maps here.
  void set_directions(std::span<const Vec3> directions) { set_weighted_directions(directions, {}, 1); }
  // The same with `layers` (1 to 3) weighted layers: weights[s][k] ≥ 0 is the weight of
  // direction s in layer k. Empty weights: 1 in every layer.
  virtual void set_weighted_directions(std::span<const Vec3> directions, std::span<const SampleWeights> weights,
                                       int layers) = 0;
  // Layers set by the last set_*directions call.
  virtual int layers() const = 0;
  // f_k for every texel of planes[plane]: out[k * texels + row * width + col] (texel convention
  // of geom::Plane), layers() × width × height values.
  virtual void plane_fractions(int plane, std::span<float> out) = 0;
  // f_k for every mesh vertex, seen from the vertex (nudged off the surface along its normal)
  // with c_s = max(0, normal·ω_s): out[k * vertex_count + v].
  virtual void vertex_fractions(std::span<float> out) = 0;
};

struct RasterOptions {
  int shadow_map_resolution = 2048;   // texels along each side of a shadow map
  std::filesystem::path shader_dir;   // where shaders/*.glsl live; empty = search defaults
};

struct RaytraceOptions {
  int threads = 0;                    // 0 = all hardware threads
};

// The faster engine for this machine. A software GL renderer (llvmpipe, softpipe, swrast) draws
// shadow maps on the CPU, far slower than Embree traces rays there (the sample site with 16
// samples per face: 1 min 48 s against 4 s on two cores): raytrace then, and when no OpenGL ES
// context can be made; raster on a GPU driver. Makes and drops a headless context to ask.
struct EngineChoice {
  std::string method;  // raster | raytrace
  std::string reason;  // for the log, e.g. "the GL renderer llvmpipe (…) draws on the CPU"
};
EngineChoice choose_engine();
// The engines keep references to mesh and planes: both must outlive the engine.
std::unique_ptr<VisibilityEngine> make_raster_engine(const scene::Mesh& mesh,
                                                     std::span<const geom::Plane> planes,
                                                     const RasterOptions& options);
std::unique_ptr<VisibilityEngine> make_raytrace_engine(const scene::Mesh& mesh,
                                                       std::span<const geom::Plane> planes,
                                                       const RaytraceOptions& options);

// The dense reference (no dome): for every texel x of `plane`,
//     out[x] = Σ_k weights[k] · max(0, n·ω_k) · V(x, ω_k)        (per channel)
// with ω_k = directions[k] (unit after normalising). With weights = radiance × solid angle of
// every pixel of an environment map, out / Σ_k weights[k] max(0, n·ω_k) is the exact shadow
// ratio the dome approximates. Ray-cast with Embree like the raytrace engine.
void weighted_plane_visibility(const scene::Mesh& mesh, const geom::Plane& plane,
                               std::span<const Vec3> directions, std::span<const Eigen::Vector3d> weights,
                               std::span<Eigen::Vector3d> out, const RaytraceOptions& options = {});

// Visibility of an area light (a sun's disc, as directions and weights) for every texel:
//     out[x] = Σ_k w_k c_k V(x, ω_k) / Σ_k w_k c_k,   c_k = max(0, n·ω_k)
// and 1 where no part of the light faces the plane (it then carries no weight anyway).
void area_light_visibility(const scene::Mesh& mesh, const geom::Plane& plane, std::span<const Vec3> directions,
                           std::span<const double> weights, std::span<float> out,
                           const RaytraceOptions& options = {});

// The dense reference for the model itself: for every mesh vertex v, seen from the vertex
// (nudged off the surface along its normal n_v, as vertex_fractions does),
//     out[v] = Σ_k weights[k] · max(0, n_v·ω_k) · V(v, ω_k)        (per channel)
// the irradiance the model's own geometry lets reach it from lights of radiance × solid angle
// `weights` (the building's light, no dome). `planes`: the site's, which set the nudge as in the
// bake (surface_offset).
void weighted_vertex_irradiance(const scene::Mesh& mesh, std::span<const geom::Plane> planes, std::span<const Vec3> directions,
                                std::span<const Eigen::Vector3d> weights, std::span<Eigen::Vector3d> out,
                                const RaytraceOptions& options = {});

// The ground's light at the model's vertices: the ground is the plane z = 0 of the site frame, a
// lambertian reflector of radiance G(x, y) (RGB). For every vertex v (nudged as above),
//     out[v] = Σ_k weights[k] · max(0, n_v·ω_k) · G(g_k) · V_ground(v, ω_k)
// over the directions below the horizon (ω_z < 0; the others are skipped), where g_k is where the
// ray meets z = 0 and V_ground = 1 when the model does not stop it first. A vertex below the
// ground sees none of it, nor one on the ground facing down (it covers the ground it faces).
// weights: solid angles (≥ 0).
using GroundRadiance = std::function<Eigen::Vector3d(double x, double y)>;
// The rays behind it: visit(vertex, k, max(0, n_v·ω_k), x, y) for each direction k below the
// horizon whose ray from the vertex reaches the ground, at (x, y), before the model; called from
// worker threads, every visit of one vertex from the same thread.
using GroundVisit = std::function<void(std::size_t vertex, std::size_t direction, double cosine, double x, double y)>;
void ground_hits(const scene::Mesh& mesh, std::span<const geom::Plane> planes, std::span<const Vec3> directions,
                 const GroundVisit& visit, const RaytraceOptions& options = {});
void ground_vertex_irradiance(const scene::Mesh& mesh, std::span<const geom::Plane> planes, std::span<const Vec3> directions,
                              std::span<const double> weights, const GroundRadiance& ground, std::span<Eigen::Vector3d> out,
                              const RaytraceOptions& options = {});

// What each vertex sees, direction by direction, of a sky of radiance 1 over a ground of radiance
// `ground_radiance` (baker/refine.hpp compares these between a point and its neighbours):
//     out[v · K + k] = max(0, n_v·ω_k) · L_k · V(v, ω_k)
// with L_k = 1 and V = 1 when nothing of the model lies along ω_k above the horizon (ω_z ≥ 0),
// and below it L_k = ground_radiance and V = 1 when the ray meets z = 0 before the model (the
// rules of ground_hits). K = directions.size(), each unit after normalising.
void vertex_views(const scene::Mesh& mesh, std::span<const geom::Plane> planes, std::span<const Vec3> directions,
                  double ground_radiance, std::span<float> out, const RaytraceOptions& options = {});

// Visibility of an area light for every mesh vertex, as area_light_visibility for texels.
void area_light_vertex_visibility(const scene::Mesh& mesh, std::span<const geom::Plane> planes, std::span<const Vec3> directions,
                                  std::span<const double> weights, std::span<float> out,
                                  const RaytraceOptions& options = {});

// How far a ray origin is nudged off a surface, and the shadow-map depth bias: both scale with
// the size of the scene so that a 2 m model and a 200 m site behave alike.
double surface_offset(const scene::Mesh& mesh, std::span<const geom::Plane> planes);

}  // namespace skylit::baker
