// Virtual planes where the vertices cannot carry the light (wall_planes.hpp).
#include "skylit/baker/wall_planes.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <map>
#include <numbers>
#include <numeric>
#include <string>

#include "flat_regions.hpp"
#include "skylit/base/error.hpp"
#include "skylit/baker/preview.hpp"
#include "skylit/baker/refine.hpp"
#include "skylit/baker/vertex_fit.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/base/files.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/sky/sky_model.hpp"

namespace skylit::baker {
namespace wall_planes_detail {

struct Region : FlatRegion {
  double squared_error = 0.0;  // Σ area × error² over its points
};

// The test skies along `directions` (each of solid angle 4π/K), scaled so that each gives E_h = 1:
// clear skies (Preetham, turbidity 3, without the disc: the sun is the shadow map's, per pixel)
// with the sun at 10°, 30° and 60° up every 45° of azimuth, and an overcast one. Nothing below the
// horizon: the ground's layer interpolates well between vertices (bench/RESULTS.md, "Where the
// building's error lies"), and a ground lit uniformly would light ceilings that the model's
// shadow keeps dark.
std::vector<std::vector<double>> test_sky_radiances(std::span<const Vec3> directions) {
  std::vector<std::function<double(const Vec3&)>> radiance;
  for (const double elevation : {10.0, 30.0, 60.0}) {
    for (int azimuth = 0; azimuth < 360; azimuth += 45) {
      const double e = elevation * std::numbers::pi / 180.0, a = azimuth * std::numbers::pi / 180.0;
      const auto clear = std::make_shared<sky::ClearSky>(Vec3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)));
      radiance.push_back([clear](const Vec3& w) { return sky::rgb_luminance(clear->sky_radiance(w)); });
    }
  }
  const auto overcast = std::make_shared<sky::OvercastSky>();
  radiance.push_back([overcast](const Vec3& w) { return sky::rgb_luminance(overcast->radiance(w)); });
  const double solid_angle = 4.0 * std::numbers::pi / static_cast<double>(directions.size());
  std::vector<std::vector<double>> out;
  for (const auto& L : radiance) {
    std::vector<double> sky(directions.size(), 0.0);
    double horizontal = 0.0;
    for (std::size_t d = 0; d < directions.size(); ++d) {
      if (directions[d].z() <= 0.0) continue;
      sky[d] = L(directions[d].normalized()) * solid_angle;
      horizontal += sky[d] * directions[d].normalized().z();
    }
    if (!(horizontal > 0.0)) continue;
    for (std::size_t d = 0; d < directions.size(); ++d) {
      sky[d] /= horizontal;
    }
    out.push_back(std::move(sky));
  }
  return out;
}

void validate(const WallPlaneOptions& o) {
  const auto fail = [](const std::string& option, const std::string& problem, const std::string& fix) {
    return InputError(option + ": " + problem + ". Fix: " + fix);
  };
  if (o.count < 1 || o.count > 8) throw fail("--count", "must be 1 to 8 (the compositor's virtual planes)", "give e.g. --count 4");
  if (!(o.texel > 0.0) || !std::isfinite(o.texel)) throw fail("--texel", "must be a length > 0 in metres", "give e.g. --texel 0.05");
  if (!(o.min_area >= 0.0) || !std::isfinite(o.min_area)) throw fail("--min-area", "must be m² ≥ 0", "give e.g. --min-area 2");
  if (!(o.min_error >= 0.0) || !std::isfinite(o.min_error)) throw fail("--min-error", "must be a share ≥ 0", "give e.g. --min-error 0.05");
  if (o.max_resolution < 1 || o.max_resolution > 16384) throw fail("--max-resolution", "must be 1 to 16384", "give e.g. 1024");
  if (o.directions < 16 || o.directions > 16384) throw fail("wall plane directions", "must be 16 to 16384", "give e.g. 256");
  validate_refine_options(o.refine);
}

}  // namespace wall_planes_detail

std::vector<WallPlane> find_wall_planes(const scene::Mesh& model, std::span<const geom::Plane> planes,
                                        std::span<const geom::Plane> virtual_planes, const WallPlaneOptions& options,
                                        std::FILE* log, WallErrorMap* map) {
  using namespace wall_planes_detail;
  validate(options);
  scene::Mesh mesh = model;
  if (options.refine.tolerance > 0.0) refine_where_light_changes(mesh, planes, options.refine);
  const std::size_t triangles = mesh.triangle_count();
  const auto corner = [&](std::size_t t, std::size_t k) { return mesh.positions[mesh.indices[3 * t + k]].cast<double>(); };
  const FlatFaces faces = flat_faces(mesh);
  const std::vector<Vec3>& face_normal = faces.normal;
  const std::vector<double>& face_area = faces.area;
  std::vector<Region> regions;
  for (FlatRegion& r : flat_regions(mesh, faces)) regions.push_back({std::move(r)});
  // Only regions large enough, and not covered by a virtual plane already.
  const double cos_cover = std::cos(15.0 * std::numbers::pi / 180.0);
  std::vector<Region*> candidates;
  for (Region& r : regions) {
    if (r.area < options.min_area) continue;
    double covered = 0.0;
    for (const std::size_t t : r.triangles) {
      const Vec3 centroid = (corner(t, 0) + corner(t, 1) + corner(t, 2)) / 3.0;
      for (const geom::Plane& p : virtual_planes) {
        const geom::PlanePoint at = geom::locate_on_plane(p, centroid);
        if (std::abs(at.distance) <= 0.05 && face_normal[t].dot(p.normal()) >= cos_cover && at.s >= 0 && at.s <= 1 && at.t >= 0 &&
            at.t <= 1) {
          covered += face_area[t];
          break;
        }
      }
    }
    if (covered < 0.5 * r.area) candidates.push_back(&r);
  }
  if (map != nullptr) {
    map->mesh = mesh;
    map->error.assign(triangles, std::numeric_limits<double>::quiet_NaN());
    map->plane.assign(triangles, -1);
  }
  if (candidates.empty()) return {};

  // The vertices' error at four points per candidate triangle (its centroid and halfway from it to
  // each corner): the light there against the corners' interpolated, under each test sky, as a
  // share of its E_h.
  // With --vertex-fit, the fit's points follow the vertices and the probes follow them.
  const FitPoints fit = options.vertex_fit > 0 ? fit_points(mesh, options.vertex_fit) : FitPoints{};
  scene::Mesh probed = with_points(mesh, fit.positions, fit.normals);
  const std::size_t first_probe = probed.vertex_count();
  struct Point {
    Region* region;
    std::size_t triangle;
    Eigen::Vector3d weights;
  };
  std::vector<Point> points;
  const std::array<Eigen::Vector3d, 4> barycentric{Eigen::Vector3d(1.0, 1.0, 1.0) / 3.0, Eigen::Vector3d(4.0, 1.0, 1.0) / 6.0,
                                                   Eigen::Vector3d(1.0, 4.0, 1.0) / 6.0, Eigen::Vector3d(1.0, 1.0, 4.0) / 6.0};
  for (Region* r : candidates) {
    for (const std::size_t t : r->triangles) {
      for (const Eigen::Vector3d& b : barycentric) {
        Eigen::Vector3f p = Eigen::Vector3f::Zero();
        for (std::size_t k = 0; k < 3; ++k) p += static_cast<float>(b[static_cast<Eigen::Index>(k)]) * mesh.positions[mesh.indices[3 * t + k]];
        probed.positions.push_back(p);
        probed.normals.push_back(face_normal[t].cast<float>());
        points.push_back({r, t, b});
      }
    }
  }
  const std::vector<Vec3> directions = sphere_directions(options.directions);
  const std::size_t count = directions.size();
  if (log != nullptr) {
    std::fprintf(log, "walls: %zu flat region(s) of at least %.1f m² on a model of %zu vertices; tracing %zu points along %zu directions\n",
                 candidates.size(), options.min_area, mesh.vertex_count(), probed.vertex_count(), count);
  }
  std::vector<float> views(probed.vertex_count() * count);
  RaytraceOptions trace;
  trace.threads = options.threads;
  vertex_views(probed, planes, directions, 0.0, views, trace);
  if (options.vertex_fit > 0) {
    // Each direction's view is one layer of the fit, as each dome layer is in the bake.
    const std::vector<float> fitted =
        fit_vertex_values(mesh, fit, std::span<const float>(views).first(first_probe * count), count);
    std::copy(fitted.begin(), fitted.end(), views.begin());
  }
  // Each test sky's radiance along the directions.
  const std::vector<std::vector<double>> skies = test_sky_radiances(directions);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const float* at = views.data() + (first_probe + i) * count;
    std::array<const float*, 3> corners;
    for (std::size_t k = 0; k < 3; ++k) corners[k] = views.data() + mesh.indices[3 * points[i].triangle + k] * count;
    std::vector<double> differs(count);
    double seen = 0.0;
    for (std::size_t d = 0; d < count; ++d) {
      double interpolated = 0.0;
      for (std::size_t k = 0; k < 3; ++k) interpolated += points[i].weights[static_cast<Eigen::Index>(k)] * corners[k][d];
      seen += at[d];
      differs[d] = at[d] - interpolated;
    }
    if (seen == 0.0) continue;  // inside another part: nobody sees it
    double squared = 0.0;       // mean over the skies of (ΔE / E_h)²
    for (const std::vector<double>& sky : skies) {
      double delta = 0.0;
      for (std::size_t d = 0; d < count; ++d) delta += differs[d] * sky[d];
      squared += delta * delta / static_cast<double>(skies.size());
    }
    points[i].region->squared_error += face_area[points[i].triangle] / 4.0 * squared;
  }
  if (map != nullptr) {
    for (const Region* r : candidates) {
      for (const std::size_t t : r->triangles) map->error[t] = std::sqrt(r->squared_error / r->area);
    }
  }
  std::vector<Region*> chosen;
  for (Region* r : candidates) {
    if (std::sqrt(r->squared_error / r->area) >= options.min_error) chosen.push_back(r);
  }
  std::sort(chosen.begin(), chosen.end(), [](const Region* a, const Region* b) { return a->squared_error > b->squared_error; });
  if (chosen.size() > static_cast<std::size_t>(options.count)) chosen.resize(static_cast<std::size_t>(options.count));

  std::vector<WallPlane> out;
  for (const Region* r : chosen) {
    const Vec3 n = r->normal;
    // u along the ground for a wall, along x for a roof or a floor; v = n × u, so that u × v = n.
    Vec3 u = std::abs(n.z()) < 0.9 ? Vec3(Vec3::UnitZ().cross(n)) : Vec3(Vec3::UnitX() - n.x() * n);
    u.normalize();
    const Vec3 v = n.cross(u);
    const Vec3 anchor = corner(r->triangles.front(), 0);
    double s0 = 1e300, s1 = -1e300, t0 = 1e300, t1 = -1e300, offset = 0.0;
    for (const std::size_t t : r->triangles) {
      for (std::size_t k = 0; k < 3; ++k) {
        const Vec3 d = corner(t, k) - anchor;
        s0 = std::min(s0, d.dot(u)), s1 = std::max(s1, d.dot(u));
        t0 = std::min(t0, d.dot(v)), t1 = std::max(t1, d.dot(v));
        offset += d.dot(n) / (3.0 * static_cast<double>(r->triangles.size()));
      }
    }
    // One texel of margin all round, so that the faces' edges lie inside.
    s0 -= options.texel, s1 += options.texel, t0 -= options.texel, t1 += options.texel;
    WallPlane w;
    w.plane.name = "wall-auto-" + std::to_string(out.size() + 1);
    w.plane.origin = anchor + s0 * u + t0 * v + (offset + options.offset) * n;
    w.plane.u = (s1 - s0) * u;
    w.plane.v = (t1 - t0) * v;
    w.plane.width = std::clamp(static_cast<int>(std::ceil((s1 - s0) / options.texel)), 1, options.max_resolution);
    w.plane.height = std::clamp(static_cast<int>(std::ceil((t1 - t0) / options.texel)), 1, options.max_resolution);
    w.area = r->area;
    w.triangles = r->triangles.size();
    w.error = std::sqrt(r->squared_error / r->area);
    if (map != nullptr) {
      for (const std::size_t t : r->triangles) map->plane[t] = static_cast<int>(out.size());
    }
    out.push_back(std::move(w));
  }
  return out;
}

void write_wall_picture(const std::filesystem::path& file, const WallErrorMap& map, double min_error) {
  const scene::Mesh& mesh = map.mesh;
  const std::size_t triangles = mesh.triangle_count();
  if (map.error.size() != triangles || map.plane.size() != triangles || !(min_error > 0.0)) {
    throw std::invalid_argument("write_wall_picture: one error and one plane per triangle, and a positive min_error");
  }
  // Each triangle its own corners, so that each takes its region's colour whole.
  scene::Mesh flat;
  std::vector<Eigen::Vector3d> colour;
  const auto ramp = [](double x) -> Eigen::Vector3d {  // 0 → dark blue, 0.5 → yellow, 1 → red (linear RGB)
    x = std::clamp(x, 0.0, 1.0);
    if (x < 0.5) return Eigen::Vector3d(0.05, 0.05, 0.4) + (x / 0.5) * Eigen::Vector3d(0.85, 0.75, -0.38);
    return Eigen::Vector3d(0.9, 0.8, 0.02) + ((x - 0.5) / 0.5) * Eigen::Vector3d(0.05, -0.75, 0.0);
  };
  for (std::size_t t = 0; t < triangles; ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Constant(0.18);  // not measured
    if (!std::isnan(map.error[t])) {
      c = ramp(map.error[t] / (2.0 * min_error));
      if (map.plane[t] < 0) c = 0.35 * c + 0.65 * Eigen::Vector3d::Constant(0.18);  // no plane over it: faded
    }
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.indices[3 * t + k];
      flat.positions.push_back(mesh.positions[v]);
      flat.normals.push_back(mesh.normals[v]);
      flat.indices.push_back(static_cast<std::uint32_t>(3 * t + k));
      colour.push_back(c);
    }
  }
  char caption[200];
  std::snprintf(caption, sizeof caption, "vertex error by flat region: blue 0, yellow %.3f, red %.3f of E_h; bright: a plane, "
                                         "grey: not measured", min_error, 2.0 * min_error);
  write_vertex_picture(file, flat, colour, 1.0, caption);
}

std::vector<WallPlane> add_wall_planes(const std::filesystem::path& site_file, const std::filesystem::path& out_file,
                                       WallPlaneOptions options, std::FILE* log) {
  namespace fs = std::filesystem;
  if (fs::weakly_canonical(site_file) == fs::weakly_canonical(out_file)) {
    throw InputError("-o " + out_file.string() + ": that is the site itself. Fix: write the site with its planes to another "
                     "file, e.g. -o " + (site_file.parent_path() / (site_file.stem().string() + "_walls.yaml")).string());
  }
  scene::Site site = scene::load_site(site_file);
  const scene::Mesh mesh = scene::load_site_model(site);
  std::vector<geom::Plane> virtual_planes;
  for (std::size_t j = 0; j < site.planes.size(); ++j) {
    if (site.surface_of(j) == scene::PlaneSurface::Virtual) virtual_planes.push_back(site.planes[j]);
  }
  const int room = 8 - static_cast<int>(virtual_planes.size());
  if (room <= 0) {
    throw InputError(site_file.string() + ": planes: the site has " + std::to_string(virtual_planes.size()) +
                     " virtual planes, the compositor's most. Fix: remove one to make room");
  }
  options.count = std::min(options.count, room);
  WallErrorMap map;
  std::vector<WallPlane> found = find_wall_planes(mesh, site.planes, virtual_planes, options, log, &map);
  site.plane_surfaces.resize(site.planes.size(), scene::PlaneSurface::Virtual);
  int next = 1;
  for (WallPlane& w : found) {
    const auto taken = [&](const std::string& name) {
      return std::any_of(site.planes.begin(), site.planes.end(), [&](const geom::Plane& p) { return p.name == name; });
    };
    while (taken("wall-auto-" + std::to_string(next))) ++next;
    w.plane.name = "wall-auto-" + std::to_string(next);
    site.planes.push_back(w.plane);
    site.plane_surfaces.push_back(scene::PlaneSurface::Virtual);
  }
  if (log != nullptr) {
    std::fprintf(log, "walls: %zu plane(s) where the vertices cannot carry the light (of flat regions of at least %.1f m² with "
                      "the vertices' error at least %.3f):\n", found.size(), options.min_area, options.min_error);
    for (const WallPlane& w : found) {
      const Vec3 n = w.plane.normal();
      std::fprintf(log, "  %s: %.1f m² of faces (%zu triangles), facing (%.2f, %.2f, %.2f), the vertices' error %.3f; "
                        "%.1f × %.1f m at %d × %d texels\n",
                   w.plane.name.c_str(), w.area, w.triangles, n.x(), n.y(), n.z(), w.error, w.plane.u.norm(), w.plane.v.norm(),
                   w.plane.width, w.plane.height);
    }
  }
  // The model's (and root's) path as seen from the new file's folder.
  const fs::path folder = fs::absolute(out_file).parent_path();
  site.model = fs::absolute(site.model).lexically_relative(folder);
  // Files the site names stay where they were allowed to be: under its root, or its own folder.
  site.root = fs::absolute(site.root.empty() ? site_file.parent_path() : site.root).lexically_normal().lexically_relative(folder);
  site.file.clear();
  write_file_atomic(out_file, scene::site_to_yaml(site));
  const fs::path picture = fs::path(out_file).replace_extension(".png");
  write_wall_picture(picture, map, options.min_error);
  if (log != nullptr) std::fprintf(log, "walls: wrote %s and %s\n", out_file.string().c_str(), picture.string().c_str());
  return found;
}

}  // namespace skylit::baker
