// The ray-traced visibility engine (Embree 3): the reference the raster engine is tested against.
#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

// geom::Plane::normal() uses cross(), which lives in Eigen/Geometry.
#include <Eigen/Geometry>

#include "skylit/base/parallel_for.hpp"
#include "skylit/baker/visibility.hpp"

namespace skylit::baker {

namespace {

// Embree reports errors through a callback invoked from inside its C API; throwing there would
// unwind through C frames, so the callback only records the first message and the engine
// throws after the call returns.
class DeviceErrors {
 public:
  static void record(void* self, RTCError code, const char* message) {
    static_cast<DeviceErrors*>(self)->store(code, message);
  }

  void throw_if_any(const char* during) {
    std::lock_guard lock(mutex_);
    if (message_.empty()) return;
    std::string text = "Embree error during " + std::string(during) + ": " + message_;
    message_.clear();
    throw std::runtime_error(text);
  }

 private:
  void store(RTCError code, const char* message) {
    std::lock_guard lock(mutex_);
    if (!message_.empty()) return;
    message_ = "code " + std::to_string(static_cast<int>(code)) + " (" +
               (message != nullptr ? message : "no message") + ")";
  }

  std::mutex mutex_;
  std::string message_;
};

struct DeviceReleaser {
  void operator()(RTCDevice device) const { rtcReleaseDevice(device); }
};
struct SceneReleaser {
  void operator()(RTCScene scene) const { rtcReleaseScene(scene); }
};
using DeviceHandle = std::unique_ptr<RTCDeviceTy, DeviceReleaser>;
using SceneHandle = std::unique_ptr<RTCSceneTy, SceneReleaser>;

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// A sample direction with the weights w_{k,s} c_s it carries in each layer for the surface at hand.
struct WeightedDirection {
  float x, y, z;
  std::array<double, 3> weight;
};

// The rays to trace for a surface with normal n and what each is worth per layer.
struct Weighing {
  std::vector<WeightedDirection> rays;
  std::array<double, 3> total{0.0, 0.0, 0.0};  // Σ_s w_{k,s} c_s per layer
  // Some layer has no weight facing the surface: every ray is traced and also counted, for that
  // layer's Σ V / K (the contract's fallback).
  bool count_all = false;

  // f_k from the sums of one sample point.
  float fraction(int layer, double visible_weight, double visible_count) const {
    const auto k = static_cast<std::size_t>(layer);
    if (total[k] > 0.0) return static_cast<float>(visible_weight / total[k]);
    return static_cast<float>(visible_count / static_cast<double>(rays.size()));
  }
};

Weighing weigh(const std::vector<Vec3>& directions, const std::vector<SampleWeights>& weights, int layers,
               const Vec3& normal) {
  Weighing w;
  w.rays.reserve(directions.size());
  const auto add = [&](bool all) {
    for (std::size_t s = 0; s < directions.size(); ++s) {
      const Vec3& d = directions[s];
      const double c = std::max(0.0, normal.dot(d));
      if (c <= 0.0 && !all) continue;
      WeightedDirection ray{static_cast<float>(d.x()), static_cast<float>(d.y()), static_cast<float>(d.z()),
                            {0.0, 0.0, 0.0}};
      for (int k = 0; k < layers; ++k) {
        const double wk = weights.empty() ? 1.0 : weights[s][static_cast<std::size_t>(k)];
        ray.weight[static_cast<std::size_t>(k)] = wk * c;
        w.total[static_cast<std::size_t>(k)] += wk * c;
      }
      w.rays.push_back(ray);
    }
  };
  add(false);
  for (int k = 0; k < layers; ++k) w.count_all = w.count_all || !(w.total[static_cast<std::size_t>(k)] > 0.0);
  if (w.count_all) {
    w.rays.clear();
    w.total = {0.0, 0.0, 0.0};
    add(true);
  }
  return w;
}

class RaytraceEngine final : public VisibilityEngine {
 public:
  RaytraceEngine(const scene::Mesh& mesh, std::span<const geom::Plane> planes,
                 const RaytraceOptions& options)
      : mesh_(mesh), planes_(planes), offset_(surface_offset(mesh, planes)) {
    if (options.threads < 0) {
      throw std::invalid_argument("raytrace engine: threads must be ≥ 0 (0 = all hardware threads)");
    }
    threads_ = options.threads > 0 ? options.threads
                                   : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    validate_mesh();
    for (const geom::Plane& plane : planes_) {
      if (plane.width <= 0 || plane.height <= 0) {
        throw std::invalid_argument("raytrace engine: plane '" + plane.name + "' has no texels");
      }
    }
    build_scene();
  }

  std::string name() const override {
    return "raytrace (Embree " RTC_VERSION_STRING ", " + std::to_string(threads_) + " thread" +
           (threads_ == 1 ? "" : "s") + ")";
  }

  int layers() const override { return layers_; }

  void set_weighted_directions(std::span<const Vec3> directions, std::span<const SampleWeights> weights,
                               int layers) override {
    if (directions.empty()) throw std::invalid_argument("raytrace engine: no sample directions");
    if (layers < 1 || layers > 3) throw std::invalid_argument("raytrace engine: 1 to 3 layers");
    if (!weights.empty() && weights.size() != directions.size()) {
      throw std::invalid_argument("raytrace engine: one weight triple per sample direction");
    }
    for (const SampleWeights& w : weights) {
      for (float x : w) {
        if (!(x >= 0.0f) || !std::isfinite(x)) throw std::invalid_argument("raytrace engine: weights must be finite, >= 0");
      }
    }
    std::vector<Vec3> unit;
    unit.reserve(directions.size());
    for (const Vec3& w : directions) {
      const double length = w.norm();
      if (!std::isfinite(length) || length == 0.0) {
        throw std::invalid_argument("raytrace engine: a sample direction is zero or not finite");
      }
      unit.push_back(w / length);
    }
    directions_ = std::move(unit);
    weights_.assign(weights.begin(), weights.end());
    layers_ = layers;
  }

  void plane_fractions(int plane_index, std::span<float> out) override {
    if (plane_index < 0 || static_cast<std::size_t>(plane_index) >= planes_.size()) {
      throw std::out_of_range("raytrace engine: plane index " + std::to_string(plane_index) +
                              " out of range");
    }
    const geom::Plane& plane = planes_[static_cast<std::size_t>(plane_index)];
    const std::size_t width = static_cast<std::size_t>(plane.width);
    const std::size_t texels = width * static_cast<std::size_t>(plane.height);
    if (out.size() != static_cast<std::size_t>(layers_) * texels) {
      throw std::invalid_argument("raytrace engine: output for plane '" + plane.name +
                                  "' must hold layers × width × height values");
    }
    require_directions();
    // The cosine weight is the same for every texel of a plane.
    const Weighing weighing = weigh(directions_, weights_, layers_, plane.normal());
    const std::vector<WeightedDirection>& weighted = weighing.rays;
    const float tnear = static_cast<float>(offset_);

    parallel_for(plane.height, threads_, [&](int row) {
      // One row, one direction at a time: the rays of a row are parallel and neighbouring, the
      // coherent case Embree's stream traversal is built for (measured on 3000 triangles, 2 cores:
      // ~140 M rays/s, against ~60 M with rtcOccluded1 per ray and ~130 M with rtcOccluded16).
      std::vector<RTCRay> rays(width);
      std::vector<std::array<double, 3>> visible_weight(width, {0.0, 0.0, 0.0});
      std::vector<double> visible_count(width, 0.0);
      for (std::size_t col = 0; col < width; ++col) {
        const Vec3 centre = plane.texel_centre(static_cast<int>(col), row);
        rays[col].org_x = static_cast<float>(centre.x());
        rays[col].org_y = static_cast<float>(centre.y());
        rays[col].org_z = static_cast<float>(centre.z());
      }
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
      for (const WeightedDirection& w : weighted) {
        for (RTCRay& ray : rays) {
          ray.dir_x = w.x;
          ray.dir_y = w.y;
          ray.dir_z = w.z;
          ray.tnear = tnear;
          ray.tfar = kInfinity;
          ray.time = 0.0f;
          ray.mask = ~0u;
          ray.id = 0;
          ray.flags = 0;
        }
        rtcOccluded1M(scene_.get(), &context, rays.data(), static_cast<unsigned>(width),
                      sizeof(RTCRay));
        // An occluded ray comes back with tfar = -inf.
        for (std::size_t col = 0; col < width; ++col) {
          if (rays[col].tfar < 0.0f) continue;
          for (std::size_t k = 0; k < 3; ++k) visible_weight[col][k] += w.weight[k];
          visible_count[col] += 1.0;
        }
      }
      for (int k = 0; k < layers_; ++k) {
        float* row_out = out.data() + static_cast<std::size_t>(k) * texels + static_cast<std::size_t>(row) * width;
        for (std::size_t col = 0; col < width; ++col) {
          row_out[col] = weighing.fraction(k, visible_weight[col][static_cast<std::size_t>(k)], visible_count[col]);
        }
      }
    });
    errors_->throw_if_any("plane_fractions");
  }

  // Σ_k weight_k c_k V(x, ω_k) per texel and channel (the dense reference; see visibility.hpp).
  void weighted_plane_visibility(int plane_index, std::span<const Vec3> directions,
                                 std::span<const Eigen::Vector3d> weights, std::span<Eigen::Vector3d> out) {
    const geom::Plane& plane = planes_[static_cast<std::size_t>(plane_index)];
    const std::size_t width = static_cast<std::size_t>(plane.width);
    if (directions.size() != weights.size() || out.size() != width * static_cast<std::size_t>(plane.height)) {
      throw std::invalid_argument("weighted_plane_visibility: one weight per direction, one output per texel");
    }
    const Vec3 normal = plane.normal();
    struct Light {
      float x, y, z;
      Eigen::Vector3d weight;
    };
    std::vector<Light> lights;
    for (std::size_t k = 0; k < directions.size(); ++k) {
      const double length = directions[k].norm();
      if (!std::isfinite(length) || length == 0.0) {
        throw std::invalid_argument("weighted_plane_visibility: a direction is zero or not finite");
      }
      const Vec3 w = directions[k] / length;
      const double c = normal.dot(w);
      if (c <= 0.0 || weights[k].isZero()) continue;
      lights.push_back({static_cast<float>(w.x()), static_cast<float>(w.y()), static_cast<float>(w.z()), c * weights[k]});
    }
    const float tnear = static_cast<float>(offset_);
    parallel_for(plane.height, threads_, [&](int row) {
      std::vector<RTCRay> rays(width);
      Eigen::Vector3d* row_out = out.data() + static_cast<std::size_t>(row) * width;
      for (std::size_t col = 0; col < width; ++col) row_out[col].setZero();
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
      for (const Light& light : lights) {
        for (std::size_t col = 0; col < width; ++col) {
          const Vec3 centre = plane.texel_centre(static_cast<int>(col), row);
          RTCRay& ray = rays[col];
          ray = RTCRay{};
          ray.org_x = static_cast<float>(centre.x());
          ray.org_y = static_cast<float>(centre.y());
          ray.org_z = static_cast<float>(centre.z());
          ray.dir_x = light.x;
          ray.dir_y = light.y;
          ray.dir_z = light.z;
          ray.tnear = tnear;
          ray.tfar = kInfinity;
          ray.mask = ~0u;
        }
        rtcOccluded1M(scene_.get(), &context, rays.data(), static_cast<unsigned>(width), sizeof(RTCRay));
        for (std::size_t col = 0; col < width; ++col) {
          if (rays[col].tfar >= 0.0f) row_out[col] += light.weight;
        }
      }
    });
    errors_->throw_if_any("weighted_plane_visibility");
  }

  // Σ_k weight_k max(0, n_v·ω_k) V(v, ω_k) per vertex and channel (see visibility.hpp).
  void weighted_vertex_irradiance(std::span<const Vec3> directions, std::span<const Eigen::Vector3d> weights,
                                  std::span<Eigen::Vector3d> out) {
    if (directions.size() != weights.size() || out.size() != mesh_.vertex_count()) {
      throw std::invalid_argument("weighted_vertex_irradiance: one weight per direction, one output per vertex");
    }
    std::vector<Vec3> unit(directions.size());
    for (std::size_t k = 0; k < directions.size(); ++k) {
      const double length = directions[k].norm();
      if (!std::isfinite(length) || length == 0.0) {
        throw std::invalid_argument("weighted_vertex_irradiance: a direction is zero or not finite");
      }
      unit[k] = directions[k] / length;
    }
    constexpr int kVerticesPerTask = 16;
    constexpr std::size_t kBatch = 256;
    const int vertex_count = static_cast<int>(mesh_.vertex_count());
    const int tasks = (vertex_count + kVerticesPerTask - 1) / kVerticesPerTask;
    const float offset = static_cast<float>(offset_);
    parallel_for(tasks, threads_, [&](int task) {
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      std::vector<RTCRay> rays(kBatch);
      std::vector<std::pair<std::size_t, double>> batch;  // light, cosine
      batch.reserve(kBatch);
      const int end = std::min(vertex_count, (task + 1) * kVerticesPerTask);
      for (int v = task * kVerticesPerTask; v < end; ++v) {
        const auto index = static_cast<std::size_t>(v);
        const Eigen::Vector3f& normal = mesh_.normals[index];
        const Vec3 normal_d = normal.cast<double>();
        const Eigen::Vector3f origin = mesh_.positions[index] + offset * normal;
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        const auto flush = [&] {
          for (std::size_t r = 0; r < batch.size(); ++r) {
            const Eigen::Vector3f w = unit[batch[r].first].cast<float>();
            RTCRay& ray = rays[r];
            ray = RTCRay{};
            ray.org_x = origin.x();
            ray.org_y = origin.y();
            ray.org_z = origin.z();
            ray.dir_x = w.x();
            ray.dir_y = w.y();
            ray.dir_z = w.z();
            // Nudged off its own surface, and past any other the vertex lies on (a column's
            // foot on its plinth: a hit at t = 0 would shade every ray above the plinth).
            ray.tnear = offset;
            ray.tfar = kInfinity;
            ray.mask = ~0u;
          }
          rtcOccluded1M(scene_.get(), &context, rays.data(), static_cast<unsigned>(batch.size()), sizeof(RTCRay));
          for (std::size_t r = 0; r < batch.size(); ++r) {
            if (rays[r].tfar >= 0.0f) sum += batch[r].second * weights[batch[r].first];
          }
          batch.clear();
        };
        for (std::size_t k = 0; k < unit.size(); ++k) {
          const double c = normal_d.dot(unit[k]);
          if (c <= 0.0 || weights[k].isZero()) continue;
          batch.emplace_back(k, c);
          if (batch.size() == kBatch) flush();
        }
        if (!batch.empty()) flush();
        out[index] = sum;
      }
    });
    errors_->throw_if_any("weighted_vertex_irradiance");
  }

  // Every direction below the horizon whose ray from a vertex reaches the ground z = 0 before
  // the model (ground_hits).
  void ground_hits(std::span<const Vec3> directions, const GroundVisit& visit) {
    std::vector<Vec3> unit;
    std::vector<std::size_t> index_of;
    for (std::size_t k = 0; k < directions.size(); ++k) {
      const double length = directions[k].norm();
      if (!std::isfinite(length) || length == 0.0) throw std::invalid_argument("ground_hits: a direction is zero or not finite");
      const Vec3 w = directions[k] / length;
      if (w.z() >= 0.0) continue;  // never reaches the ground
      unit.push_back(w);
      index_of.push_back(k);
    }
    for_each_vertex(16, [&](RTCIntersectContext& context, std::size_t index, const Eigen::Vector3f& normal,
                            const Eigen::Vector3f& origin) {
      const Vec3 normal_d = normal.cast<double>();
      if (!sees_ground(index, normal, origin)) return;
      for (std::size_t k = 0; k < unit.size(); ++k) {
        const double c = normal_d.dot(unit[k]);
        if (c <= 0.0) continue;
        const double reach = ground_reach(origin, unit[k]);
        if (!unobstructed(context, origin, unit[k], static_cast<float>(reach))) continue;
        const Vec3 at = origin.cast<double>() + reach * unit[k];
        visit(index, index_of[k], c, at.x(), at.y());
      }
    });
    errors_->throw_if_any("ground_hits");
  }

  void vertex_views(std::span<const Vec3> directions, double ground_radiance, std::span<float> out) {
    const std::size_t count = directions.size();
    if (out.size() != count * mesh_.vertex_count()) {
      throw std::invalid_argument("vertex_views: output must hold one value per vertex and direction");
    }
    std::vector<Vec3> unit;
    for (const Vec3& d : directions) {
      const double length = d.norm();
      if (!std::isfinite(length) || length == 0.0) throw std::invalid_argument("vertex_views: a direction is zero or not finite");
      unit.push_back(d / length);
    }
    for_each_vertex(16, [&](RTCIntersectContext& context, std::size_t index, const Eigen::Vector3f& normal,
                            const Eigen::Vector3f& origin) {
      const Vec3 normal_d = normal.cast<double>();
      const bool ground_seen = sees_ground(index, normal, origin);
      float* row = out.data() + index * count;
      for (std::size_t k = 0; k < count; ++k) {
        row[k] = 0.0f;
        const double c = normal_d.dot(unit[k]);
        const bool below = unit[k].z() < 0.0;
        if (c <= 0.0 || (below && !ground_seen)) continue;
        const float tfar = below ? static_cast<float>(ground_reach(origin, unit[k])) : kInfinity;
        if (!unobstructed(context, origin, unit[k], tfar)) continue;
        row[k] = static_cast<float>(c * (below ? ground_radiance : 1.0));
      }
    });
    errors_->throw_if_any("vertex_views");
  }

  void vertex_fractions(std::span<float> out) override {
    const std::size_t vertices = mesh_.vertex_count();
    if (out.size() != static_cast<std::size_t>(layers_) * vertices) {
      throw std::invalid_argument("raytrace engine: output must hold layers × one value per mesh vertex");
    }
    require_directions();
    const float offset = static_cast<float>(offset_);
    for_each_vertex(256, [&](RTCIntersectContext& context, std::size_t index, const Eigen::Vector3f& normal,
                             const Eigen::Vector3f& origin) {
      const Weighing weighing = weigh(directions_, weights_, layers_, normal.cast<double>());
      std::array<double, 3> visible_weight{0.0, 0.0, 0.0};
      double visible_count = 0.0;
      for (const WeightedDirection& w : weighing.rays) {
        RTCRay ray{};
        ray.org_x = origin.x();
        ray.org_y = origin.y();
        ray.org_z = origin.z();
        ray.dir_x = w.x;
        ray.dir_y = w.y;
        ray.dir_z = w.z;
        // Nudged off its own surface, and past any other the vertex lies on (a column's foot
        // on its plinth: a hit at t = 0 would shade every ray above the plinth).
        ray.tnear = offset;
        ray.tfar = kInfinity;
        ray.mask = ~0u;
        rtcOccluded1(scene_.get(), &context, &ray);
        if (ray.tfar < 0.0f) continue;
        for (std::size_t k = 0; k < 3; ++k) visible_weight[k] += w.weight[k];
        visible_count += 1.0;
      }
      for (int k = 0; k < layers_; ++k) {
        out[static_cast<std::size_t>(k) * vertices + index] =
            weighing.fraction(k, visible_weight[static_cast<std::size_t>(k)], visible_count);
      }
    });
    errors_->throw_if_any("vertex_fractions");
  }

 private:
  // A vertex below the ground is buried: it sees none of it (a foundation, a cellar). One on it
  // facing down (a plinth's underside) faces the ground it covers: none either.
  bool sees_ground(std::size_t index, const Eigen::Vector3f& normal, const Eigen::Vector3f& origin) const {
    const float offset = static_cast<float>(offset_);
    return !(origin.z() < -offset || (normal.z() < 0.0f && mesh_.positions[index].z() <= offset));
  }

  // Where a ray down from `origin` meets z = 0: t = z / −ω_z; a vertex on it (z ≤ offset) meets it at once.
  static double ground_reach(const Eigen::Vector3f& origin, const Vec3& down) {
    return std::max(static_cast<double>(origin.z()), 0.0) / -down.z();
  }

  // Whether nothing of the model lies along the unit direction from `origin` between the nudge
  // and `tfar` (an empty span counts as unobstructed).
  bool unobstructed(RTCIntersectContext& context, const Eigen::Vector3f& origin, const Vec3& direction, float tfar) const {
    RTCRay ray{};
    ray.org_x = origin.x();
    ray.org_y = origin.y();
    ray.org_z = origin.z();
    ray.dir_x = static_cast<float>(direction.x());
    ray.dir_y = static_cast<float>(direction.y());
    ray.dir_z = static_cast<float>(direction.z());
    ray.tnear = static_cast<float>(offset_);
    ray.tfar = tfar;
    ray.mask = ~0u;
    if (!(ray.tfar > ray.tnear)) return true;
    rtcOccluded1(scene_.get(), &context, &ray);
    return ray.tfar >= 0.0f;
  }

  // visit(context, vertex, normal, origin) for every mesh vertex, `per_task` vertices to a task
  // across the engine's threads; origin is the vertex nudged off its surface along its normal.
  template <class Visit>
  void for_each_vertex(int per_task, Visit&& visit) {
    const int vertex_count = static_cast<int>(mesh_.vertex_count());
    const int tasks = (vertex_count + per_task - 1) / per_task;
    const float offset = static_cast<float>(offset_);
    parallel_for(tasks, threads_, [&](int task) {
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      const int end = std::min(vertex_count, (task + 1) * per_task);
      for (int v = task * per_task; v < end; ++v) {
        const auto index = static_cast<std::size_t>(v);
        const Eigen::Vector3f& normal = mesh_.normals[index];
        visit(context, index, normal, Eigen::Vector3f(mesh_.positions[index] + offset * normal));
      }
    });
  }

  void require_directions() const {
    if (directions_.empty()) {
      throw std::logic_error("raytrace engine: set_directions must be called before tracing");
    }
  }

  void validate_mesh() const {
    if (mesh_.indices.size() % 3 != 0) {
      throw std::invalid_argument("raytrace engine: mesh index count is not a multiple of 3");
    }
    if (mesh_.normals.size() != mesh_.positions.size()) {
      throw std::invalid_argument("raytrace engine: mesh needs exactly one normal per position");
    }
    if (mesh_.positions.size() > std::numeric_limits<std::uint32_t>::max()) {
      throw std::invalid_argument("raytrace engine: mesh has too many vertices for 32-bit indices");
    }
    for (std::uint32_t index : mesh_.indices) {
      if (index >= mesh_.positions.size()) {
        throw std::invalid_argument("raytrace engine: mesh index " + std::to_string(index) +
                                    " is past the last vertex");
      }
    }
  }

  void build_scene() {
    device_.reset(rtcNewDevice(nullptr));
    if (!device_) {
      throw std::runtime_error("Embree error: could not create a device (code " +
                               std::to_string(static_cast<int>(rtcGetDeviceError(nullptr))) + ")");
    }
    rtcSetDeviceErrorFunction(device_.get(), &DeviceErrors::record, errors_.get());
    scene_.reset(rtcNewScene(device_.get()));
    errors_->throw_if_any("scene creation");
    rtcSetSceneFlags(scene_.get(), RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(scene_.get(), RTC_BUILD_QUALITY_HIGH);

    // An empty scene is valid: every ray is then unoccluded.
    if (mesh_.triangle_count() > 0) {
      RTCGeometry geometry = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
      errors_->throw_if_any("geometry creation");
      // Copied rather than shared: Embree wants padding after the last vertex that a
      // std::vector does not promise.
      auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
          geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
          mesh_.vertex_count()));
      auto* triangles = static_cast<std::uint32_t*>(rtcSetNewGeometryBuffer(
          geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(std::uint32_t),
          mesh_.triangle_count()));
      if (vertices == nullptr || triangles == nullptr) {
        rtcReleaseGeometry(geometry);
        errors_->throw_if_any("buffer allocation");
        throw std::runtime_error("Embree error: could not allocate the mesh buffers");
      }
      for (std::size_t v = 0; v < mesh_.vertex_count(); ++v) {
        for (int axis = 0; axis < 3; ++axis) vertices[3 * v + static_cast<std::size_t>(axis)] = mesh_.positions[v][axis];
      }
      std::copy(mesh_.indices.begin(), mesh_.indices.end(), triangles);
      rtcCommitGeometry(geometry);
      rtcAttachGeometry(scene_.get(), geometry);
      rtcReleaseGeometry(geometry);  // the scene holds its own reference
      errors_->throw_if_any("geometry setup");
    }
    rtcCommitScene(scene_.get());
    errors_->throw_if_any("scene build");
  }

  const scene::Mesh& mesh_;
  std::span<const geom::Plane> planes_;
  double offset_;
  int threads_ = 1;
  std::vector<Vec3> directions_;
  std::vector<SampleWeights> weights_;  // empty: 1 in every layer
  int layers_ = 1;
  // Declared before the device so that it outlives every callback the device might make.
  std::unique_ptr<DeviceErrors> errors_ = std::make_unique<DeviceErrors>();
  DeviceHandle device_;
  SceneHandle scene_;  // after device_: released first
};

}  // namespace

std::unique_ptr<VisibilityEngine> make_raytrace_engine(const scene::Mesh& mesh,
                                                       std::span<const geom::Plane> planes,
                                                       const RaytraceOptions& options) {
  return std::make_unique<RaytraceEngine>(mesh, planes, options);
}

void weighted_plane_visibility(const scene::Mesh& mesh, const geom::Plane& plane,
                               std::span<const Vec3> directions, std::span<const Eigen::Vector3d> weights,
                               std::span<Eigen::Vector3d> out, const RaytraceOptions& options) {
  const std::vector<geom::Plane> planes{plane};
  RaytraceEngine engine(mesh, planes, options);
  engine.weighted_plane_visibility(0, directions, weights, out);
}

void weighted_vertex_irradiance(const scene::Mesh& mesh, std::span<const geom::Plane> planes, std::span<const Vec3> directions,
                                std::span<const Eigen::Vector3d> weights, std::span<Eigen::Vector3d> out,
                                const RaytraceOptions& options) {
  RaytraceEngine engine(mesh, planes, options);
  engine.weighted_vertex_irradiance(directions, weights, out);
}

void ground_hits(const scene::Mesh& mesh, std::span<const geom::Plane> planes, std::span<const Vec3> directions,
                 const GroundVisit& visit, const RaytraceOptions& options) {
  RaytraceEngine engine(mesh, planes, options);
  engine.ground_hits(directions, visit);
}

void ground_vertex_irradiance(const scene::Mesh& mesh, std::span<const geom::Plane> planes, std::span<const Vec3> directions,
                              std::span<const double> weights, const GroundRadiance& ground, std::span<Eigen::Vector3d> out,
                              const RaytraceOptions& options) {
  if (directions.size() != weights.size() || out.size() != mesh.vertex_count()) {
    throw std::invalid_argument("ground_vertex_irradiance: one weight per direction, one output per vertex");
  }
  std::fill(out.begin(), out.end(), Eigen::Vector3d::Zero());
  ground_hits(mesh, planes, directions,
              [&](std::size_t vertex, std::size_t k, double cosine, double x, double y) {
                out[vertex] += (weights[k] * cosine) * ground(x, y);
              },
              options);
}

void vertex_views(const scene::Mesh& mesh, std::span<const geom::Plane> planes, std::span<const Vec3> directions,
                  double ground_radiance, std::span<float> out, const RaytraceOptions& options) {
  RaytraceEngine engine(mesh, planes, options);
  engine.vertex_views(directions, ground_radiance, out);
}

void area_light_vertex_visibility(const scene::Mesh& mesh, std::span<const geom::Plane> planes, std::span<const Vec3> directions,
                                  std::span<const double> weights, std::span<float> out, const RaytraceOptions& options) {
  if (directions.size() != weights.size() || directions.empty() || out.size() != mesh.vertex_count()) {
    throw std::invalid_argument("area_light_vertex_visibility: one weight per direction, at least one direction, one output per vertex");
  }
  std::vector<Eigen::Vector3d> weight3;
  for (double w : weights) weight3.push_back(Eigen::Vector3d::Constant(w));
  std::vector<Eigen::Vector3d> visible(out.size());
  weighted_vertex_irradiance(mesh, planes, directions, weight3, visible, options);
  for (std::size_t v = 0; v < out.size(); ++v) {
    double facing = 0.0;
    for (std::size_t k = 0; k < directions.size(); ++k) {
      facing += weights[k] * std::max(0.0, mesh.normals[v].cast<double>().dot(directions[k].normalized()));
    }
    out[v] = facing > 0.0 ? static_cast<float>(std::clamp(visible[v].x() / facing, 0.0, 1.0)) : 1.0f;
  }
}

void area_light_visibility(const scene::Mesh& mesh, const geom::Plane& plane, std::span<const Vec3> directions,
                           std::span<const double> weights, std::span<float> out, const RaytraceOptions& options) {
  if (directions.size() != weights.size() || directions.empty()) {
    throw std::invalid_argument("area_light_visibility: one weight per direction, at least one direction");
  }
  std::vector<Eigen::Vector3d> weight3;
  double facing = 0.0;
  for (std::size_t k = 0; k < directions.size(); ++k) {
    weight3.push_back(Eigen::Vector3d::Constant(weights[k]));
    facing += weights[k] * std::max(0.0, plane.normal().dot(directions[k].normalized()));
  }
  std::vector<Eigen::Vector3d> visible(out.size());
  weighted_plane_visibility(mesh, plane, directions, weight3, visible, options);
  for (std::size_t x = 0; x < out.size(); ++x) {
    out[x] = facing > 0.0 ? static_cast<float>(std::clamp(visible[x].x() / facing, 0.0, 1.0)) : 1.0f;
  }
}

}  // namespace skylit::baker
