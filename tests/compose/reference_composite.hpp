#pragma once
// The CPU reference composite: per camera pixel, the ray through the lens model, exact ray casts
// against the real planes and the mesh (Embree), and the compositor's formulas in double
// precision (compositor.hpp). The GPU composite is compared with it.
#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <span>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/scene/mesh.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::compose_test {

using Eigen::Vector3d;

inline double srgb_decode(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }
inline double srgb_encode(double l) { return l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055; }

// Embree scene of a mesh: nearest hits and occlusion.
class RayCaster {
 public:
  explicit RayCaster(const scene::Mesh& mesh) : device_(rtcNewDevice(nullptr), &rtcReleaseDevice) {
    if (!device_) throw std::runtime_error("rtcNewDevice failed");
    scene_ = std::unique_ptr<RTCSceneTy, void (*)(RTCScene)>(rtcNewScene(device_.get()), &rtcReleaseScene);
    rtcSetSceneFlags(scene_.get(), RTC_SCENE_FLAG_ROBUST);
    RTCGeometry geometry = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                                 3 * sizeof(float), mesh.vertex_count()));
    for (std::size_t k = 0; k < mesh.vertex_count(); ++k) {
      for (int c = 0; c < 3; ++c) vertices[3 * k + static_cast<std::size_t>(c)] = mesh.positions[k][c];
    }
    auto* triangles = static_cast<std::uint32_t*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(std::uint32_t), mesh.triangle_count()));
    std::copy(mesh.indices.begin(), mesh.indices.end(), triangles);
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_.get(), geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(scene_.get());
  }

  struct Hit {
    double distance = 0;
    unsigned triangle = 0;
    double u = 0, v = 0;  // barycentric weights of corners 1 and 2
  };

  std::optional<Hit> intersect(const Vector3d& origin, const Vector3d& direction) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit query{};
    query.ray.org_x = static_cast<float>(origin.x());
    query.ray.org_y = static_cast<float>(origin.y());
    query.ray.org_z = static_cast<float>(origin.z());
    query.ray.dir_x = static_cast<float>(direction.x());
    query.ray.dir_y = static_cast<float>(direction.y());
    query.ray.dir_z = static_cast<float>(direction.z());
    query.ray.tnear = 0.0f;
    query.ray.tfar = std::numeric_limits<float>::infinity();
    query.ray.mask = 0xffffffffu;
    query.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_.get(), &context, &query);
    if (query.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    return Hit{query.ray.tfar, query.hit.primID, query.hit.u, query.hit.v};
  }

  bool occluded(const Vector3d& origin, const Vector3d& direction) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay ray{};
    ray.org_x = static_cast<float>(origin.x());
    ray.org_y = static_cast<float>(origin.y());
    ray.org_z = static_cast<float>(origin.z());
    ray.dir_x = static_cast<float>(direction.x());
    ray.dir_y = static_cast<float>(direction.y());
    ray.dir_z = static_cast<float>(direction.z());
    ray.tnear = 0.0f;
    ray.tfar = std::numeric_limits<float>::infinity();
    ray.mask = 0xffffffffu;
    rtcOccluded1(scene_.get(), &context, &ray);
    return ray.tfar < 0.0f;
  }

 private:
  std::unique_ptr<RTCDeviceTy, void (*)(RTCDevice)> device_;
  std::unique_ptr<RTCSceneTy, void (*)(RTCScene)> scene_{nullptr, &rtcReleaseScene};
};

// Shadow ratios of one plane as blend_cpu writes them (W × H × 3, RGB); empty: T = 1.
struct PlaneRatios {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;

  // Bilinear at (s, t), texel centres at ((col + ½)/W, (row + ½)/H), clamped to the edge texels:
  // what the shaders do with texelFetch.
  Vector3d at(double s, double t) const {
    if (rgb.empty()) return Vector3d::Ones();
    const double cx = s * width - 0.5;
    const double cy = t * height - 0.5;
    const double bx = std::floor(cx);
    const double by = std::floor(cy);
    const double fx = cx - bx;
    const double fy = cy - by;
    auto texel = [&](double col, double row) {
      const int c = std::clamp(static_cast<int>(col), 0, width - 1);
      const int r = std::clamp(static_cast<int>(row), 0, height - 1);
      const float* p = &rgb[3 * (static_cast<std::size_t>(r) * static_cast<std::size_t>(width) + static_cast<std::size_t>(c))];
      return Vector3d(p[0], p[1], p[2]);
    };
    const Vector3d top = (1 - fx) * texel(bx, by) + fx * texel(bx + 1, by);
    const Vector3d bottom = (1 - fx) * texel(bx, by + 1) + fx * texel(bx + 1, by + 1);
    return ((1 - fy) * top + fy * bottom).cwiseMax(0.0).cwiseMin(1.0);
  }
};

struct ReferenceInputs {
  const scene::Site* site = nullptr;
  const scene::Mesh* mesh = nullptr;
  const bake_format::Manifest* manifest = nullptr;
  std::span<const float> transfer;
  std::vector<PlaneRatios> ratios;                 // per bake plane
  std::vector<Vector3d> sky;                       // S_i
  std::optional<blend::SunLight> sun;
  Vector3d photometric = Vector3d::Ones();
  render::CompositorOptions options;
  bool sun_shadows = true;                         // false: the building's sun term is unshadowed
  double opacity = 1.0;                            // CompositeInput::opacity, in [0, 1]
};

// (s, t) of a point in a plane's coordinates (the dual basis of u, v).
inline Eigen::Vector2d plane_st(const geom::Plane& plane, const Vector3d& x) {
  Eigen::Matrix<double, 3, 2> basis;
  basis << plane.u, plane.v;
  return (basis.transpose() * basis).inverse() * basis.transpose() * (x - plane.origin);
}

// Texture lookup as the GPU does it at mip level 0: bilinear over sRGB-decoded texels, repeating.
inline Vector3d texture_at(const scene::TextureImage& image, const Eigen::Vector2d& uv) {
  const double cx = uv.x() * image.width - 0.5;
  const double cy = uv.y() * image.height - 0.5;
  const double bx = std::floor(cx), by = std::floor(cy);
  const double fx = cx - bx, fy = cy - by;
  auto texel = [&](double col, double row) {
    auto wrap = [](long long k, int n) { return static_cast<std::size_t>(((k % n) + n) % n); };
    const std::size_t c = wrap(static_cast<long long>(col), image.width);
    const std::size_t r = wrap(static_cast<long long>(row), image.height);
    const std::uint8_t* p = &image.rgba[4 * (r * static_cast<std::size_t>(image.width) + c)];
    return Vector3d(srgb_decode(p[0] / 255.0), srgb_decode(p[1] / 255.0), srgb_decode(p[2] / 255.0));
  };
  const Vector3d top = (1 - fx) * texel(bx, by) + fx * texel(bx + 1, by);
  const Vector3d bottom = (1 - fx) * texel(bx, by + 1) + fx * texel(bx + 1, by + 1);
  return (1 - fy) * top + fy * bottom;
}

// The reference composite, CV_32FC3 BGR linear, and per pixel what it shows (for the tests'
// masks): 0 camera only, 1 a real plane, 2 the building.
struct ReferenceResult {
  cv::Mat linear;
  cv::Mat what;  // CV_8U
};

inline ReferenceResult reference_composite(const ReferenceInputs& in, const camera::Lens& lens, const RayCaster& caster,
                                           const cv::Mat& camera, const render::CameraPose& pose) {
  const scene::Mesh& mesh = *in.mesh;
  const bake_format::Manifest& manifest = *in.manifest;
  const std::size_t faces = manifest.faces.size();
  // Per-vertex sky irradiance Σ S_i t_{v,i}.
  std::vector<Vector3d> vertex_irradiance(mesh.vertex_count(), Vector3d::Zero());
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    for (std::size_t i = 0; i < faces; ++i) vertex_irradiance[v] += in.transfer[v * faces + i] * in.sky[i];
  }
  std::vector<int> real, virtual_planes;
  for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
    const std::string& name = manifest.planes[j].plane.name;
    std::size_t site_index = 0;
    while (in.site->planes[site_index].name != name) ++site_index;
    (in.site->surface_of(site_index) == scene::PlaneSurface::Real ? real : virtual_planes).push_back(static_cast<int>(j));
  }
  const double cover_cos = std::cos(in.options.cover_max_angle_deg * std::numbers::pi / 180.0);
  const double min_z = std::cos(std::clamp(in.options.lens.max_angle_deg, 1.0, 89.0) * std::numbers::pi / 180.0);

  ReferenceResult result;
  result.linear = cv::Mat(camera.size(), CV_32FC3);
  result.what = cv::Mat(camera.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < camera.rows; ++y) {
    for (int x = 0; x < camera.cols; ++x) {
      Vector3d background;
      if (camera.type() == CV_8UC3) {
        const cv::Vec3b p = camera.at<cv::Vec3b>(y, x);
        background = Vector3d(srgb_decode(p[2] / 255.0), srgb_decode(p[1] / 255.0), srgb_decode(p[0] / 255.0));
      } else {
        const cv::Vec3f p = camera.at<cv::Vec3f>(y, x);
        background = Vector3d(p[2], p[1], p[0]);
        for (int c = 0; c < 3; ++c) {
          if (!std::isfinite(background[c]) || background[c] < 0) background[c] = 0;
        }
      }
      const Vector3d camera_linear = background;
      Vector3d colour = background;
      const std::optional<Vector3d> ray = lens.unproject(Eigen::Vector2d(x, y));
      if (ray && ray->z() >= min_z) {
        const Vector3d d_camera = ray->normalized();
        const Vector3d d = pose.R_site_from_camera * d_camera;
        const Vector3d& o = pose.t_site_from_camera;
        double plane_distance = -1;
        Vector3d ratio = Vector3d::Ones();
        for (int j : real) {
          const geom::Plane& plane = manifest.planes[static_cast<std::size_t>(j)].plane;
          const Vector3d n = plane.normal();
          const double facing = d.dot(n);
          if (std::abs(facing) < 1e-9) continue;
          const double distance = (plane.origin - o).dot(n) / facing;
          if (distance <= 0 || (plane_distance > 0 && distance >= plane_distance)) continue;
          const Eigen::Vector2d st = plane_st(plane, o + distance * d);
          if (st.minCoeff() < 0 || st.maxCoeff() > 1) continue;
          plane_distance = distance;
          ratio = in.ratios[static_cast<std::size_t>(j)].at(st.x(), st.y());
        }
        background = background.cwiseProduct(ratio);
        colour = background;
        if (plane_distance > 0) result.what.at<std::uint8_t>(y, x) = 1;

        const std::optional<RayCaster::Hit> hit = caster.intersect(o, d);
        const bool hidden = hit && plane_distance > 0 &&
                            plane_distance * d_camera.z() < hit->distance * d_camera.z() - in.options.occlusion_margin;
        if (hit && !hidden) {
          const std::uint32_t* corner = &mesh.indices[3 * hit->triangle];
          const double w[3] = {1 - hit->u - hit->v, hit->u, hit->v};
          Vector3d normal = Vector3d::Zero(), sky_e = Vector3d::Zero();
          Eigen::Vector2d uv = Eigen::Vector2d::Zero();
          for (int k = 0; k < 3; ++k) {
            normal += w[k] * mesh.normals[corner[k]].cast<double>();
            sky_e += w[k] * vertex_irradiance[corner[k]];
            if (!mesh.texcoords.empty()) uv += w[k] * mesh.texcoords[corner[k]].cast<double>();
          }
          normal.normalize();
          const Vector3d point = o + hit->distance * d;
          int covering = -1;
          double nearest = in.options.cover_distance;
          Eigen::Vector2d covering_st;
          for (int j : virtual_planes) {
            const geom::Plane& plane = manifest.planes[static_cast<std::size_t>(j)].plane;
            const double distance = std::abs((point - plane.origin).dot(plane.normal()));
            const Eigen::Vector2d st = plane_st(plane, point);
            if (distance <= nearest && normal.dot(plane.normal()) >= cover_cos && st.minCoeff() >= 0 && st.maxCoeff() <= 1) {
              covering = j;
              nearest = distance;
              covering_st = st;
            }
          }
          Vector3d irradiance;
          if (covering >= 0) {
            const auto plane = static_cast<std::size_t>(covering);
            irradiance = in.ratios[plane].at(covering_st.x(), covering_st.y())
                             .cwiseProduct(render::plane_irradiance(manifest.planes[plane], in.sky, in.sun));
          } else {
            irradiance = sky_e;
            if (in.sun) {
              const Vector3d towards = in.sun->direction.normalized();
              const double c = std::max(0.0, normal.dot(towards));
              if (c > 0 && !(in.sun_shadows && caster.occluded(point + 1e-3 * normal, towards))) {
                irradiance += c * in.sun->energy;
              }
            }
          }
          const scene::Material& material = mesh.materials[mesh.triangle_material[hit->triangle]];
          Vector3d albedo = material.base_colour.head<3>().cast<double>();
          if (material.base_colour_texture >= 0) {
            albedo = albedo.cwiseProduct(texture_at(mesh.textures[static_cast<std::size_t>(material.base_colour_texture)], uv));
          }
          colour = in.photometric.cwiseProduct(albedo / std::numbers::pi).cwiseProduct(irradiance);
          result.what.at<std::uint8_t>(y, x) = 2;
        }
      }
      colour = (1.0 - in.opacity) * camera_linear + in.opacity * colour;
      result.linear.at<cv::Vec3f>(y, x) =
          cv::Vec3f(static_cast<float>(colour.z()), static_cast<float>(colour.y()), static_cast<float>(colour.x()));
    }
  }
  return result;
}

}  // namespace skylit::compose_test
