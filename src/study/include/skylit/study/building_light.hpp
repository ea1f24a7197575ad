#pragma once
// The building's own light, measured: per model vertex, the irradiance the live path gives it
// (transfer vectors times S, plus each separated source through its visibility) against a dense
// reference (every pixel of the equirect sky a light, the model's self-occlusion ray-traced, no
// dome), as a share of the sky's horizontal irradiance.
#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "skylit/bake_format/light_map.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/geom/dome_basis.hpp"
#include "skylit/geom/plane.hpp"
#include "skylit/render/building_irradiance.hpp"
#include "skylit/scene/mesh.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/study/study.hpp"

namespace skylit::study {

// E_h = Σ_k w_k max(0, ω_k·z), RGB: the unoccluded horizontal irradiance, the scale the
// building's error is given in (as T's is a share of each plane's own irradiance).
Eigen::Vector3d horizontal_irradiance(const EquirectLights& lights);

// E_ref(v) = Σ_k w_k max(0, n_v·ω_k) V(v, ω_k), RGB, per mesh vertex: V ray-traced against the
// model (Embree), seen from the vertex as the bake sees it.
std::vector<Eigen::Vector3d> building_reference(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh);

// A separated source (a sun, a lamp) as the live path lights the building: its energy at normal
// incidence and its disc as an area light.
struct SourceLight {
  Vec3 direction = Vec3::UnitZ();
  Eigen::Vector3d energy = Eigen::Vector3d::Zero();
  std::vector<Vec3> disc_directions;
  std::vector<double> disc_weights;
};

// What the live path gives vertex v (blend::vertex_irradiance, the compositor's building term):
//     E(v) = Σ_i S_i t_{v,i} + Σ_k E_k max(0, n_v·ω_k) V_k(v)
// with t the bake's transfer vectors (vertex-major, S.size() per vertex) and V_k the source's
// disc ray-cast from the vertex: a perfect shadow map, so that this measures the transfer and the
// sky stage, not the shadow map's resolution. std::invalid_argument when the sizes do not fit.
// With ground.transfer set, plus L_g t_{v,g} (the ground layer).
std::vector<Eigen::Vector3d> building_estimate(std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                                               std::span<const SourceLight> sources, const scene::Site& site,
                                               const scene::Mesh& mesh, const blend::GroundLight& ground = {});

// Points inside the model's triangles, where the compositor shows E interpolated from the
// vertices: per triangle its centroid and the three points halfway from it to each corner
// (barycentric (2/3, 1/6, 1/6) and its turns), each with its triangle's corners and weights and
// the interpolated normal (normalised, as the fragment shader takes it). With `spacing` > 0 (m), a
// triangle of area A is first split into m² equal ones, m = ⌈√(2A) / spacing⌉ (a right isosceles
// triangle's legs over the spacing), each with those four points: the points' density then does
// not depend on how the model is tessellated, and a large triangle's edges are sampled too.
struct TrianglePoints {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;
  std::vector<std::array<std::uint32_t, 3>> corners;
  std::vector<Eigen::Vector3d> weights;  // barycentric, sum 1
  std::vector<double> areas;             // m²: the surface each point stands for (a quarter of its (sub-)triangle)
  std::vector<std::uint32_t> triangles;  // the triangle each lies in
};
TrianglePoints triangle_points(const scene::Mesh& mesh, double spacing = 0.0);

// E at the points as the compositor interpolates it from the vertices' E.
std::vector<Eigen::Vector3d> interpolated_at(const TrianglePoints& points, std::span<const Eigen::Vector3d> vertex_E);

// The sun's term at the points as the compositor takes it, per pixel: E max(0, n·ω) V with V its
// disc ray-cast from the point itself (a perfect shadow map). Add it to what interpolated_at gives
// from the vertices' E without the sun for what the building shows inside its triangles.
std::vector<Eigen::Vector3d> source_term_at(const TrianglePoints& points, const SourceLight& source, const scene::Site& site,
                                            const scene::Mesh& mesh);

// What the building shows at the points from its vertices, term by term: the sky's layers and
// every source but the sun, interpolated from the vertices' building_estimate; with sun_first,
// sources[0] (the sun) per point, as the compositor takes it from its map per fragment
// (source_term_at; zero otherwise); the ground's layer, interpolated.
struct InsideTerms {
  std::vector<Eigen::Vector3d> sky, sun, ground;
};
InsideTerms building_terms_inside(const TrianglePoints& points, std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                                  std::span<const SourceLight> sources, bool sun_first, const scene::Site& site,
                                  const scene::Mesh& mesh, const blend::GroundLight& ground = {});

// The building with a light map (bake_format/light_map.hpp), as the compositor shows it: at the
// points on its charts, the sky's and the ground's terms from its texels (bilinear, as the
// compositor's lookup) in place of the vertices'. `transfer`: the light map's (texel-major, S.size()
// per texel); `ground`: its ground transfer with S^g and ρ (empty transfer: no ground term);
// `vertex_sky`: the vertices' sky alone at the points (building_terms_inside without sources), so
// that what terms.sky holds beyond it (the lamps, per vertex in the compositor too) stays.
// `values`: Reconstructed for the PCA form's t̂ (light_map_as_shown), which the compositor sums
// as they are. std::invalid_argument when the sizes do not fit.
void use_light_map(const TrianglePoints& points, const bake_format::LightMapLayout& layout, std::span<const float> transfer,
                   std::span<const Eigen::Vector3d> S, const blend::GroundLight& ground, std::span<const Eigen::Vector3d> vertex_sky,
                   InsideTerms& terms, bake_format::LightMapValues values = bake_format::LightMapValues::Full);

// The bake's light map as the compositor sums it: its PCA form where the bake has one, t̂
// expanded into transfer and ground (texel-major, as the full form) for use_light_map; else the
// full form. InputError as bake_format::read_light_map.
// `precision`: as the compositor holds the values it sums (render.light_map_precision).
bake_format::LightMapArrays light_map_as_shown(const std::filesystem::path& bake_dir, const bake_format::Manifest& manifest,
                                               render::LightMapPrecision precision = render::LightMapPrecision::Float);

// The light map's values as the compositor holds them at `precision`: Half rounds each value (the
// full form's, or the PCA form's weights and vectors) to the nearest half float; Float keeps them.
void hold_light_map(bake_format::LightMapArrays& map, render::LightMapPrecision precision);

// The sky the dome holds, L(ω) = Σ_l S_l φ_l(ω), as `directions` lights of equal solid angle over
// the upper hemisphere: traced at a point, Σ_l S_l t_l with the point's own transfer, no
// interpolation. std::invalid_argument unless S has one value per layer of the dome.
EquirectLights dome_sky_lights(int frequency, geom::DomeBasis basis, std::span<const Eigen::Vector3d> S, int directions);

// Which of `planes` (virtual ones) covers each point, as the compositor decides it for a fragment
// (render::CompositorOptions): within distance of the plane, its normal within max_angle_deg of
// the plane's, inside its rectangle; the nearest such. plane −1: none; (s, t) in [0, 1].
struct PlaneCover {
  int plane = -1;
  double s = 0, t = 0;
};
std::vector<PlaneCover> covering_planes(const TrianglePoints& points, std::span<const geom::Plane> planes, double distance = 0.05,
                                        double max_angle_deg = 15.0);

// T at plane coordinates (s, t) as the compositor's shader reads it: bilinear between texel
// centres, clamped to the edge texels; a NaN is 1 and the rest clamped to [0, 1]. T: RGB per
// texel, rows of `width`.
Eigen::Vector3d bilinear_ratio(std::span<const float> T, int width, int height, double s, double t);

// A virtual plane as the compositor shades the building with it: its T (RGB per texel) and D_j.
struct PlaneShading {
  geom::Plane plane;
  std::span<const float> T;
  Eigen::Vector3d D = Eigen::Vector3d::Zero();
};
// What the building shows at the points: the terms' sum, and where one of `planes` covers a point
// (covering_planes), T_j D_j from the plane plus the ground's term instead.
std::vector<Eigen::Vector3d> shown_inside(const TrianglePoints& points, const InsideTerms& terms, std::span<const PlaneShading> planes);

// The site's virtual planes among a bake's (by name), with their T and D_j in the bake's order.
std::vector<PlaneShading> virtual_shading(const scene::Site& site, std::span<const geom::Plane> bake_planes,
                                          std::span<const std::vector<float>> T, std::span<const Eigen::Vector3d> D);

// E_ref at the points: building_reference's integral with the point's normal, the model's
// occlusion ray-traced (the points ride along as vertices no triangle uses).
std::vector<Eigen::Vector3d> building_reference_at(const EquirectLights& lights, const scene::Site& site,
                                                   const scene::Mesh& mesh, const TrianglePoints& points);

// The ground in the reference (docs/method.md, "Light from the ground"): a lambertian ground, the
// plane z = 0, of albedo ρ (RGB) lit by the same lights, seen from every vertex past the model:
//     E_g(v) = Σ_k Ω_k max(0, n_v·ω_k) ρ/π E(g_k) V_ground(v, ω_k)
// over `directions` equal-area directions below the horizon (baker::ground_directions), g_k where
// the ray meets the ground, and E(g) the ground's irradiance: T(g) E_h where a horizontal plane
// of the site with its dense reference T covers g (the model's shadow on the ground), E_h (the
// unoccluded horizontal irradiance, what the live path assumes) elsewhere or without one.
struct GroundReferenceOptions {
  Eigen::Vector3d albedo = Eigen::Vector3d::Constant(0.2);
  int directions = 4096;
  const geom::Plane* shadow_plane = nullptr;       // null: E_h everywhere
  std::span<const Eigen::Vector3d> shadow_ratio;   // its T per texel (row-major), RGB
};
std::vector<Eigen::Vector3d> ground_reference(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh,
                                              const GroundReferenceOptions& options);
// The options for a site's own ground: lit as `dense` lights the site's first plane that faces up
// within 5 cm of z = 0 (uniformly, E_h, without one).
GroundReferenceOptions site_ground(const scene::Site& site, const DenseReference& dense, const Eigen::Vector3d& albedo);
// The same at points inside the triangles (triangle_points).
std::vector<Eigen::Vector3d> ground_reference_at(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh,
                                                 const TrianglePoints& points, const GroundReferenceOptions& options);

// |E(v) − E_ref(v)| / E_h over every vertex and channel. A vertex that sees nothing of the sky in
// either counts with its (zero) error: the model's hidden faces are part of what it shows.
Errors building_errors(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                       const Eigen::Vector3d& horizontal);
// The same with each estimate standing for areas[k] of the surface (study::errors_of weighted).
Errors building_errors(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                       const Eigen::Vector3d& horizontal, std::span<const double> areas);
// The vertex with the largest such error (0 when there are none).
std::size_t worst_vertex(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                         const Eigen::Vector3d& horizontal);

}  // namespace skylit::study
