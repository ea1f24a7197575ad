// EquirectLights, the building's reference and estimate, and their errors.
#include "skylit/study/building_light.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <string>

#include "skylit/baker/ground_transfer.hpp"
#include "skylit/baker/vertex_fit.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/sky/radiometry.hpp"

namespace skylit::study {

Eigen::Vector3d horizontal_irradiance(const EquirectLights& lights) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < lights.directions.size(); ++k) sum += std::max(0.0, lights.directions[k].z()) * lights.weights[k];
  return sum;
}

std::vector<Eigen::Vector3d> building_reference(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh) {
  std::vector<Eigen::Vector3d> out(mesh.vertex_count());
  baker::weighted_vertex_irradiance(mesh, site.planes, lights.directions, lights.weights, out);
  return out;
}

std::vector<Eigen::Vector3d> building_estimate(std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                                               std::span<const SourceLight> sources, const scene::Site& site,
                                               const scene::Mesh& mesh, const blend::GroundLight& ground) {
  std::vector<blend::SunLight> lights;
  std::vector<std::vector<float>> visibility;
  for (const SourceLight& source : sources) {
    lights.push_back({source.direction, source.energy});
    visibility.emplace_back(mesh.vertex_count(), 1.0f);
    if (!source.disc_directions.empty()) {
      baker::area_light_vertex_visibility(mesh, site.planes, source.disc_directions, source.disc_weights, visibility.back());
    }
  }
  return blend::vertex_irradiance(transfer, S, mesh.normals, lights, visibility, ground);
}

namespace {

// The same triangles, and the points as vertices none of them uses: traced as vertices are.
scene::Mesh mesh_with_points(const scene::Mesh& mesh, const TrianglePoints& points) {
  return baker::with_points(mesh, points.positions, points.normals);
}

}  // namespace

TrianglePoints triangle_points(const scene::Mesh& mesh, double spacing) {
  TrianglePoints points;
  const std::array<Eigen::Vector3d, 4> pattern{Eigen::Vector3d(1.0, 1.0, 1.0) / 3.0, Eigen::Vector3d(4.0, 1.0, 1.0) / 6.0,
                                               Eigen::Vector3d(1.0, 4.0, 1.0) / 6.0, Eigen::Vector3d(1.0, 1.0, 4.0) / 6.0};
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const std::array<std::uint32_t, 3> c{mesh.indices[t], mesh.indices[t + 1], mesh.indices[t + 2]};
    const std::array<Eigen::Vector3f, 3> q{mesh.positions[c[0]], mesh.positions[c[1]], mesh.positions[c[2]]};
    const double area = 0.5 * static_cast<double>((q[1] - q[0]).cross(q[2] - q[0]).norm());
    // By area, not by the longest side: a long thin triangle (a beam's side) would otherwise take
    // thousands of points across its width.
    const int m = spacing > 0.0 ? std::max(1, static_cast<int>(std::ceil(std::sqrt(2.0 * area) / spacing - 1e-9))) : 1;
    // Sub-triangle corners in the triangle's barycentric grid of step 1/m: the upward ones
    // (i, j), (i+1, j), (i, j+1) and the downward ones (i+1, j), (i, j+1), (i+1, j+1).
    const auto grid = [m](int i, int j) -> Eigen::Vector3d { return Eigen::Vector3d(m - i - j, i, j) / m; };
    const auto add = [&](const std::array<Eigen::Vector3d, 3>& sub) {
      for (const Eigen::Vector3d& b : pattern) {
        const Eigen::Vector3d w = b[0] * sub[0] + b[1] * sub[1] + b[2] * sub[2];
        Eigen::Vector3f p = Eigen::Vector3f::Zero(), n = Eigen::Vector3f::Zero();
        for (int k = 0; k < 3; ++k) {
          p += static_cast<float>(w[k]) * q[static_cast<std::size_t>(k)];
          n += static_cast<float>(w[k]) * mesh.normals[c[static_cast<std::size_t>(k)]];
        }
        if (!(n.norm() > 0.0f)) continue;  // opposite normals cancel: no surface to light
        points.positions.push_back(p);
        points.normals.push_back(n.normalized());
        points.corners.push_back(c);
        points.weights.push_back(w);
        points.areas.push_back(area / (4.0 * m * m));
        points.triangles.push_back(static_cast<std::uint32_t>(t / 3));
      }
    };
    for (int i = 0; i < m; ++i) {
      for (int j = 0; i + j < m; ++j) {
        add({grid(i, j), grid(i + 1, j), grid(i, j + 1)});
        if (i + j + 1 < m) add({grid(i + 1, j), grid(i, j + 1), grid(i + 1, j + 1)});
      }
    }
  }
  return points;
}

std::vector<Eigen::Vector3d> interpolated_at(const TrianglePoints& points, std::span<const Eigen::Vector3d> vertex_E) {
  std::vector<Eigen::Vector3d> out(points.positions.size(), Eigen::Vector3d::Zero());
  for (std::size_t k = 0; k < out.size(); ++k) {
    for (int c = 0; c < 3; ++c) out[k] += points.weights[k][c] * vertex_E[points.corners[k][static_cast<std::size_t>(c)]];
  }
  return out;
}

std::vector<Eigen::Vector3d> source_term_at(const TrianglePoints& points, const SourceLight& source, const scene::Site& site,
                                            const scene::Mesh& mesh) {
  const scene::Mesh with_points = mesh_with_points(mesh, points);
  std::vector<float> visibility(with_points.vertex_count(), 1.0f);
  if (!source.disc_directions.empty()) {
    baker::area_light_vertex_visibility(with_points, site.planes, source.disc_directions, source.disc_weights, visibility);
  }
  const Vec3 w = source.direction.normalized();
  std::vector<Eigen::Vector3d> out(points.positions.size());
  for (std::size_t k = 0; k < out.size(); ++k) {
    const double facing = std::max(0.0, points.normals[k].cast<double>().dot(w));
    out[k] = facing * static_cast<double>(visibility[mesh.vertex_count() + k]) * source.energy;
  }
  return out;
}

InsideTerms building_terms_inside(const TrianglePoints& points, std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                                  std::span<const SourceLight> sources, bool sun_first, const scene::Site& site,
                                  const scene::Mesh& mesh, const blend::GroundLight& ground) {
  const bool sun = sun_first && !sources.empty();
  InsideTerms terms;
  terms.sky = interpolated_at(points, building_estimate(transfer, S, sun ? sources.subspan(1) : sources, site, mesh));
  terms.sun = sun ? source_term_at(points, sources.front(), site, mesh)
                  : std::vector<Eigen::Vector3d>(points.positions.size(), Eigen::Vector3d::Zero());
  terms.ground = std::vector<Eigen::Vector3d>(points.positions.size(), Eigen::Vector3d::Zero());
  if (!ground.transfer.empty()) {
    const std::vector<Eigen::Vector3d> no_sky(S.size(), Eigen::Vector3d::Zero());
    terms.ground = interpolated_at(points, building_estimate(transfer, no_sky, {}, site, mesh, ground));
  }
  return terms;
}

void use_light_map(const TrianglePoints& points, const bake_format::LightMapLayout& layout, std::span<const float> transfer,
                   std::span<const Eigen::Vector3d> S, const blend::GroundLight& ground, std::span<const Eigen::Vector3d> vertex_sky,
                   InsideTerms& terms, bake_format::LightMapValues values) {
  const std::size_t count = points.positions.size();
  if (points.triangles.size() != count || vertex_sky.size() != count || terms.sky.size() != count || terms.ground.size() != count) {
    throw std::invalid_argument("use_light_map: the points, their triangles, the vertices' sky and the terms differ in size");
  }
  const std::vector<Eigen::Vector3d> sky = bake_format::light_map_atlas(layout, transfer, S, values);
  std::vector<Eigen::Vector3d> ground_light;
  if (!ground.transfer.empty()) {
    ground_light = bake_format::light_map_atlas(layout, ground.transfer, ground.coefficients, values);
    for (Eigen::Vector3d& g : ground_light) g = g.cwiseProduct(ground.albedo);
  }
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t t = points.triangles[k];
    if (t >= layout.triangle_chart.size()) throw std::invalid_argument("use_light_map: a point's triangle is not the layout's");
    const int chart = layout.triangle_chart[t];
    if (chart < 0) continue;
    const Eigen::Vector2d a = layout.atlas_coordinates(chart, points.positions[k].cast<double>());
    terms.sky[k] += bake_format::sample_light_map(sky, layout.width, layout.height, a) - vertex_sky[k];
    if (!ground_light.empty()) terms.ground[k] = bake_format::sample_light_map(ground_light, layout.width, layout.height, a);
  }
}

EquirectLights dome_sky_lights(int frequency, geom::DomeBasis basis, std::span<const Eigen::Vector3d> S, int directions) {
  const geom::Dome dome(frequency);
  const geom::CornerWeights corners(dome);
  const int per_face = geom::layers_per_face(basis);
  if (S.size() != static_cast<std::size_t>(dome.face_count() * per_face)) {
    throw std::invalid_argument("dome_sky_lights: " + std::to_string(S.size()) + " sky values for a dome of " +
                                std::to_string(dome.face_count() * per_face) + " layers");
  }
  EquirectLights out;
  const double solid_angle = 2.0 * std::numbers::pi / directions;
  for (Vec3 d : baker::ground_directions(directions)) {
    d.z() = -d.z();
    const int face = dome.face_of(d);
    if (face < 0) continue;
    const geom::LayerValues phi = basis == geom::DomeBasis::Faces ? geom::LayerValues{1.0} : geom::layer_values(basis, corners(face, d));
    Eigen::Vector3d radiance = Eigen::Vector3d::Zero();
    for (int k = 0; k < per_face; ++k) radiance += phi[static_cast<std::size_t>(k)] * S[static_cast<std::size_t>(face * per_face + k)];
    out.directions.push_back(d);
    out.weights.push_back(solid_angle * radiance);
  }
  return out;
}

std::vector<PlaneCover> covering_planes(const TrianglePoints& points, std::span<const geom::Plane> planes, double distance,
                                        double max_angle_deg) {
  const double cos_max = std::cos(max_angle_deg * std::numbers::pi / 180.0);
  std::vector<PlaneCover> out(points.positions.size());
  std::vector<double> nearest(out.size(), distance);
  for (std::size_t j = 0; j < planes.size(); ++j) {
    const Vec3 n = planes[j].normal();
    for (std::size_t k = 0; k < out.size(); ++k) {
      const geom::PlanePoint at = geom::locate_on_plane(planes[j], points.positions[k].cast<double>());
      const double away = std::abs(at.distance);
      if (away <= nearest[k] && points.normals[k].cast<double>().dot(n) >= cos_max && at.s >= 0.0 && at.s <= 1.0 && at.t >= 0.0 &&
          at.t <= 1.0) {
        out[k] = {static_cast<int>(j), at.s, at.t};
        nearest[k] = away;
      }
    }
  }
  return out;
}

Eigen::Vector3d bilinear_ratio(std::span<const float> T, int width, int height, double s, double t) {
  if (T.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3) {
    throw std::invalid_argument("bilinear_ratio: " + std::to_string(T.size()) + " values for " + std::to_string(width) + "×" +
                                std::to_string(height) + " RGB texels");
  }
  const double cx = s * width - 0.5, cy = t * height - 0.5;
  const double bx = std::floor(cx), by = std::floor(cy), fx = cx - bx, fy = cy - by;
  const auto texel = [&](double col, double row) {
    const auto c = static_cast<std::size_t>(std::clamp(static_cast<int>(col), 0, width - 1));
    const auto r = static_cast<std::size_t>(std::clamp(static_cast<int>(row), 0, height - 1));
    Eigen::Vector3d value;
    for (int ch = 0; ch < 3; ++ch) {
      const float x = T[(r * static_cast<std::size_t>(width) + c) * 3 + static_cast<std::size_t>(ch)];
      value[ch] = std::isnan(x) ? 1.0 : std::clamp(static_cast<double>(x), 0.0, 1.0);
    }
    return value;
  };
  return (1 - fy) * ((1 - fx) * texel(bx, by) + fx * texel(bx + 1, by)) + fy * ((1 - fx) * texel(bx, by + 1) + fx * texel(bx + 1, by + 1));
}

std::vector<Eigen::Vector3d> shown_inside(const TrianglePoints& points, const InsideTerms& terms, std::span<const PlaneShading> planes) {
  std::vector<Eigen::Vector3d> out(points.positions.size());
  for (std::size_t k = 0; k < out.size(); ++k) out[k] = terms.sky[k] + terms.sun[k] + terms.ground[k];
  if (planes.empty()) return out;
  std::vector<geom::Plane> geometry;
  for (const PlaneShading& p : planes) geometry.push_back(p.plane);
  const std::vector<PlaneCover> covers = covering_planes(points, geometry);
  for (std::size_t k = 0; k < out.size(); ++k) {
    if (covers[k].plane < 0) continue;
    const PlaneShading& p = planes[static_cast<std::size_t>(covers[k].plane)];
    out[k] = bilinear_ratio(p.T, p.plane.width, p.plane.height, covers[k].s, covers[k].t).cwiseProduct(p.D) + terms.ground[k];
  }
  return out;
}

std::vector<PlaneShading> virtual_shading(const scene::Site& site, std::span<const geom::Plane> bake_planes,
                                          std::span<const std::vector<float>> T, std::span<const Eigen::Vector3d> D) {
  if (T.size() != bake_planes.size() || D.size() != bake_planes.size()) {
    throw std::invalid_argument("virtual_shading: T and D need one entry per plane of the bake");
  }
  std::vector<PlaneShading> out;
  for (std::size_t j = 0; j < bake_planes.size(); ++j) {
    for (std::size_t i = 0; i < site.planes.size(); ++i) {
      if (site.planes[i].name == bake_planes[j].name && site.surface_of(i) == scene::PlaneSurface::Virtual) {
        out.push_back({bake_planes[j], T[j], D[j]});
      }
    }
  }
  return out;
}

std::vector<Eigen::Vector3d> building_reference_at(const EquirectLights& lights, const scene::Site& site,
                                                   const scene::Mesh& mesh, const TrianglePoints& points) {
  const scene::Mesh with_points = mesh_with_points(mesh, points);
  std::vector<Eigen::Vector3d> all(with_points.vertex_count());
  baker::weighted_vertex_irradiance(with_points, site.planes, lights.directions, lights.weights, all);
  return {all.begin() + static_cast<std::ptrdiff_t>(mesh.vertex_count()), all.end()};
}

std::vector<Eigen::Vector3d> ground_reference(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh,
                                              const GroundReferenceOptions& options) {
  const Eigen::Vector3d horizontal = horizontal_irradiance(lights);
  const Eigen::Vector3d scale = options.albedo / std::numbers::pi;
  const geom::Plane* plane = options.shadow_plane;
  if (plane != nullptr && options.shadow_ratio.size() != static_cast<std::size_t>(plane->width) * static_cast<std::size_t>(plane->height)) {
    throw std::invalid_argument("ground_reference: the shadow ratio has " + std::to_string(options.shadow_ratio.size()) +
                                " texels, not the plane's " + std::to_string(plane->width) + "×" + std::to_string(plane->height));
  }
  const auto radiance = [&](double x, double y) -> Eigen::Vector3d {
    Eigen::Vector3d ratio = Eigen::Vector3d::Ones();
    if (plane != nullptr) {
      const Vec3 d = Vec3(x, y, plane->origin.z()) - plane->origin;
      const double s = d.dot(plane->u) / plane->u.squaredNorm(), t = d.dot(plane->v) / plane->v.squaredNorm();
      if (s >= 0.0 && s < 1.0 && t >= 0.0 && t < 1.0) {
        const auto col = static_cast<std::size_t>(s * plane->width), row = static_cast<std::size_t>(t * plane->height);
        ratio = options.shadow_ratio[row * static_cast<std::size_t>(plane->width) + col];
      }
    }
    return scale.cwiseProduct(ratio).cwiseProduct(horizontal);
  };
  const std::vector<Vec3> directions = baker::ground_directions(options.directions);
  const std::vector<double> weights(directions.size(), 2.0 * std::numbers::pi / options.directions);
  std::vector<Eigen::Vector3d> out(mesh.vertex_count());
  baker::ground_vertex_irradiance(mesh, site.planes, directions, weights, radiance, out);
  return out;
}

GroundReferenceOptions site_ground(const scene::Site& site, const DenseReference& dense, const Eigen::Vector3d& albedo) {
  GroundReferenceOptions options;
  options.albedo = albedo;
  for (std::size_t j = 0; j < site.planes.size() && j < dense.planes.size(); ++j) {
    const geom::Plane& p = site.planes[j];
    if (p.normal().z() > 0.999 && std::abs(p.origin.z()) < 0.05) {
      options.shadow_plane = &p;
      options.shadow_ratio = dense.planes[j];
      break;
    }
  }
  return options;
}

std::vector<Eigen::Vector3d> ground_reference_at(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh,
                                                 const TrianglePoints& points, const GroundReferenceOptions& options) {
  const scene::Mesh with_points = mesh_with_points(mesh, points);
  const std::vector<Eigen::Vector3d> all = ground_reference(lights, site, with_points, options);
  return {all.begin() + static_cast<std::ptrdiff_t>(mesh.vertex_count()), all.end()};
}

Errors building_errors(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                       const Eigen::Vector3d& horizontal) {
  if (estimate.size() != reference.size()) throw std::invalid_argument("building_errors: estimate and reference differ in length");
  std::vector<double> diffs;
  diffs.reserve(3 * estimate.size());
  for (std::size_t v = 0; v < estimate.size(); ++v) {
    for (int c = 0; c < 3; ++c) {
      if (horizontal[c] > 0) diffs.push_back(std::abs(estimate[v][c] - reference[v][c]) / horizontal[c]);
    }
  }
  return errors_of(std::move(diffs));
}

Errors building_errors(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                       const Eigen::Vector3d& horizontal, std::span<const double> areas) {
  if (estimate.size() != reference.size() || estimate.size() != areas.size()) {
    throw std::invalid_argument("building_errors: estimate, reference and areas differ in length");
  }
  std::vector<double> diffs, weights;
  for (std::size_t v = 0; v < estimate.size(); ++v) {
    for (int c = 0; c < 3; ++c) {
      if (!(horizontal[c] > 0)) continue;
      diffs.push_back(std::abs(estimate[v][c] - reference[v][c]) / horizontal[c]);
      weights.push_back(areas[v]);
    }
  }
  return errors_of(diffs, weights);
}

std::size_t worst_vertex(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                         const Eigen::Vector3d& horizontal) {
  std::size_t worst = 0;
  double largest = -1;
  for (std::size_t v = 0; v < std::min(estimate.size(), reference.size()); ++v) {
    for (int c = 0; c < 3; ++c) {
      const double e = horizontal[c] > 0 ? std::abs(estimate[v][c] - reference[v][c]) / horizontal[c] : 0.0;
      if (e > largest) {
        largest = e;
        worst = v;
      }
    }
  }
  return worst;
}

void hold_light_map(bake_format::LightMapArrays& map, render::LightMapPrecision precision) {
  if (precision == render::LightMapPrecision::Float) return;
  const auto round = [](std::vector<float>& values) {
    for (float& v : values) v = blend::half_to_float(blend::float_to_half(v));
  };
  round(map.transfer);
  round(map.ground);
  if (map.pca) {
    for (bake_format::LightMapComponents* c : {&map.pca->sky, &map.pca->ground}) {
      round(c->weights);
      round(c->vectors);
    }
  }
}

bake_format::LightMapArrays light_map_as_shown(const std::filesystem::path& bake_dir, const bake_format::Manifest& manifest,
                                               render::LightMapPrecision precision) {
  if (!manifest.light_map || !manifest.light_map->pca) {
    bake_format::LightMapArrays map = bake_format::read_light_map(bake_dir, manifest);
    hold_light_map(map, precision);
    return map;
  }
  bake_format::LightMapArrays map = bake_format::read_light_map(bake_dir, manifest, bake_format::LightMapForm::Pca);
  hold_light_map(map, precision);
  map.transfer = bake_format::expand_light_map(map.layout, map.pca->sky);
  if (manifest.ground) map.ground = bake_format::expand_light_map(map.layout, map.pca->ground);
  return map;
}

}  // namespace skylit::study
