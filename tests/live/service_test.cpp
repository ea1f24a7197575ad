// The service end to end: recorded sky and camera frames in, composited frames out, against the
// compositor driven directly with the same inputs (the sky estimate of the same sky frame, the CPU
// blend of T with the same sun visibility), with the service's blend on the CPU and on the GPU,
// with the sun alone and with lamps besides (sky.max_sources); the box's shadow on the ground
// where geometry puts it. Measured figures are printed
// ("measured:" lines).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>

#include <gtest/gtest.h>

#include "live_fixture.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/sky/sky_smoothing.hpp"
#include "skylit/track/pose.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/bake_format/arrays.hpp"

namespace skylit::live_test {
namespace {

// The service's output for the rig's frames, and the compositor's output for the same inputs
// with the service taken out: made once, shared by the tests below.
struct Outputs {
  std::vector<cv::Mat> recorded;       // the service's frames, in order
  std::int64_t frames_without_sky = 0; // the first frames, composited before the sky came
  nlohmann::json status;               // the service's, after the run
  std::vector<cv::Mat> direct;         // per camera frame of the rig
  std::vector<cv::Mat> inputs;         // the rig's camera frames
  render::CameraPose pose;
  camera::CameraCalibration hmd;
  Vector3d sun_direction = Vector3d::Zero();
  std::size_t lamps = 0;               // separated besides the sun
  std::string error;

  // run: the service's blend.device, "cpu" or "gpu", and "_lamps" for sky.max_sources 4.
  static const Outputs& get(const std::string& run) {
    static std::map<std::string, Outputs> made;
    if (!made.count(run)) made.emplace(run, make(run.substr(0, 3), run.ends_with("_lamps") ? 4 : 1));
    return made.at(run);
  }

 private:
  static Outputs make(const std::string& device, int max_sources) {
    Outputs out;
    RigOptions rig_options;
    rig_options.extra = "blend:\n  device: " + device + "\n";
    rig_options.max_sources = max_sources;
    const Rig rig(rig_options);
    const live::LiveConfig config = rig.config();
    live::ServiceOptions options = quiet_options();
    options.frames_with_sky = 10;  // however long the first sky takes on a loaded machine
    options.frames = 1000;
    options.record = rig.dir() / "recorded";
    {
      RunningService running(config, options);
      running.join();
      if (!running.error().empty()) {
        out.error = running.error();
        return out;
      }
      out.status = running.status();
      out.frames_without_sky = out.status["frames_without_sky"].get<std::int64_t>();
    }
    for (int k = 0;; ++k) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%06d.png", k);
      if (!fs::exists(rig.dir() / "recorded" / name)) break;
      out.recorded.push_back(cv::imread((rig.dir() / "recorded" / name).string(), cv::IMREAD_UNCHANGED));
    }
    out.inputs = rig.camera_frames();

    // The same inputs, without the service: sky estimate → CPU blend with the sun's shadow map's
    // visibility → compositor.
    const gpu::HeadlessContext context;
    const scene::Site site = scene::load_site(config.site);
    const scene::Mesh mesh = scene::load_site_model(site);
    const bake_format::Manifest manifest = bake_format::read_manifest(config.bake);
    std::vector<std::size_t> shape;
    const std::vector<float> transfer = bake_format::read_npy(config.bake / manifest.transfer_file, &shape);
    const geom::Dome dome(manifest.plan.frequency);
    sky::SkyEstimateOptions estimate_options;
    estimate_options.table.basis = manifest.plan.basis;
    estimate_options.max_sources = max_sources;
    const sky::SkyEstimator estimator(camera::load_calibration(config.sky.calibration), dome, estimate_options);
    const cv::Mat sky_frame = sky::read_sky_image(rig.dir() / "sky" / "frame_0000.exr");
    const sky::SkyEstimate estimate =
        estimator.estimate(sky::linearise(sky_frame, sky::ResponseCurve::linear(8), {}));
    if (!estimate.sun) {
      out.error = "no sun in the sky frame: " + estimate.sun_reason;
      return out;
    }
    const std::vector<Vector3d> S = sky::layer_radiances(estimate.luminance);
    const blend::SunLight sun{estimate.sun->direction, estimate.sun->energy};
    out.sun_direction = sun.direction;
    // The sun (its disc at least the real sun's, as the service draws it), then the lamps (their
    // shadow radius).
    std::vector<blend::SunLight> sources{sun};
    std::vector<render::ShadowSource> drawn{{sun.direction, std::max(estimate.sun->angular_radius, 0.0047)}};
    std::vector<blend::SunLight> lamps;
    for (std::size_t k = 1; k < estimate.sources.size(); ++k) {
      lamps.push_back({estimate.sources[k].direction, estimate.sources[k].energy});
      sources.push_back(lamps.back());
      drawn.push_back({estimate.sources[k].direction, estimate.sources[k].shadow_radius});
    }
    out.lamps = lamps.size();

    std::vector<geom::Plane> planes;
    for (const auto& record : manifest.planes) planes.push_back(record.plane);
    render::SunShadowOptions map_options;
    map_options.max_sources = max_sources;
    render::SunShadowMap shadow_map(mesh, planes, map_options);
    shadow_map.update(drawn);
    std::vector<std::vector<float>> lamp_vertex_visibility;
    for (std::size_t k = 1; k < drawn.size(); ++k) lamp_vertex_visibility.push_back(shadow_map.read_vertex_visibility(static_cast<int>(k)));
    std::vector<gpu::Texture> textures;
    std::vector<GLuint> names;
    for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
      const blend::BasisImages basis = blend::load_basis(config.bake, manifest, static_cast<int>(j));
      const blend::BlendWeights weights = blend::blend_weights_sources(basis, S, sources);
      std::vector<std::vector<float>> visibility;
      for (std::size_t k = 0; k < drawn.size(); ++k) visibility.push_back(shadow_map.read_visibility(static_cast<int>(j), static_cast<int>(k)));
      const std::vector<std::span<const float>> views(visibility.begin(), visibility.end());
      std::vector<float> rgb(basis.texel_count() * 3);
      blend::blend_cpu_sources(basis, weights, views, rgb);
      textures.push_back(render::upload_shadow_ratio(rgb, basis.width, basis.height));
      names.push_back(textures.back().get());
    }

    const auto pose = track::open_pose_source(config.pose)->pose_at(0.0);
    out.pose.R_site_from_camera = pose->R_site_from_camera.toRotationMatrix();
    out.pose.t_site_from_camera = pose->t_site_from_camera;
    out.hmd = camera::load_calibration(config.camera.calibration);
    render::Compositor compositor(site, mesh, manifest, transfer, out.hmd);
    for (const cv::Mat& camera : out.inputs) {
      render::CompositeInput input;
      input.camera = camera;
      input.pose = out.pose;
      input.sky = S;
      input.sun = sun;
      input.shadow_ratios = names;
      input.sun_shadow = &shadow_map;
      input.lamps = lamps;
      input.lamp_vertex_visibility = lamp_vertex_visibility;
      out.direct.push_back(compositor.composite(input));
    }
    return out;
  }
};

// The camera frame an output frame was made from: the direct composite nearest to it.
struct Match {
  std::size_t index = 0;
  int max_difference = 255;
  int runner_up = 255;  // the max difference to the next nearest direct composite
};
Match nearest(const cv::Mat& recorded, const std::vector<cv::Mat>& direct) {
  Match m;
  for (std::size_t k = 0; k < direct.size(); ++k) {
    const int d = max_difference(recorded, direct[k]);
    if (d < m.max_difference) {
      m.runner_up = m.max_difference;
      m.max_difference = d;
      m.index = k;
    } else {
      m.runner_up = std::min(m.runner_up, d);
    }
  }
  return m;
}

class ServiceBlend : public ::testing::TestWithParam<std::string> {};

TEST_P(ServiceBlend, RecordedFramesMatchTheCompositorDrivenDirectly) {
  const Outputs& out = Outputs::get(GetParam());
  ASSERT_TRUE(out.error.empty()) << out.error;
  ASSERT_EQ(out.recorded.size(), static_cast<std::size_t>(out.frames_without_sky + 10)) << "frames with the sky: 10";
  const std::string device = GetParam().substr(0, 3);
  EXPECT_EQ(out.status["blend"]["device"], device) << out.status["blend"].dump();
  EXPECT_EQ(out.status["blend"]["setting"], device);
  // With sky.max_sources 4 the clear sky's lamp detector finds further sources (patches of the
  // bright circumsolar sky): each gets its shadow map and its term, as the direct path does.
  if (GetParam().ends_with("_lamps")) {
    EXPECT_GE(out.lamps, 1u) << "the test needs lamps to mean anything";
    EXPECT_EQ(out.status["sky"]["lamps"].size(), out.lamps) << out.status["sky"].dump();
  } else {
    EXPECT_EQ(out.lamps, 0u);
    EXPECT_TRUE(out.status["sky"]["lamps"].empty());
  }
  // The sun's shadow map is drawn on the sky thread, never on the render thread: a frame that
  // takes a new sky switches to the finished map (sun_shadow_exchange.hpp).
  const auto& maps = out.status["sun_shadow_maps"];
  EXPECT_EQ(maps["drawn_on"], "sky thread") << out.status.dump();
  EXPECT_GE(maps["drawn"].get<std::int64_t>(), 1);
  EXPECT_GE(maps["taken"].get<std::int64_t>(), 1);
  EXPECT_LE(maps["taken"].get<std::int64_t>(), maps["drawn"].get<std::int64_t>());
  int worst = 0, nearest_other = 255;
  for (std::size_t k = static_cast<std::size_t>(out.frames_without_sky); k < out.recorded.size(); ++k) {
    const cv::Mat& frame = out.recorded[k];
    ASSERT_EQ(frame.type(), CV_8UC3);
    ASSERT_EQ(frame.size(), out.inputs[0].size());
    const Match m = nearest(frame, out.direct);
    worst = std::max(worst, m.max_difference);
    nearest_other = std::min(nearest_other, m.runner_up);
  }
  // Before the sky came, the camera image alone (the building is not drawn unlit).
  for (std::size_t k = 0; k < static_cast<std::size_t>(out.frames_without_sky); ++k) {
    int to_input = 255;
    for (const cv::Mat& input : out.inputs) to_input = std::min(to_input, max_difference(out.recorded[k], input));
    EXPECT_EQ(to_input, 0) << "frame " << k << ", composited before the sky came";
  }
  std::printf("measured: blend on the %s (%zu lamps besides the sun): %zu frames with the sky (%lld before it came): "
              "max |service − direct| %d codes of 255; to the other camera frames' composites ≥ %d codes\n",
              GetParam().c_str(), out.lamps, out.recorded.size() - static_cast<std::size_t>(out.frames_without_sky),
              static_cast<long long>(out.frames_without_sky), worst, nearest_other);
  // The direct composite blends on the CPU into a float texture. The service's CPU blend is the
  // same sum over the same halves with the same sun visibility; its GPU blend sums in fp32 and
  // stores T as half (≤ 2^-11): a code at most after sRGB encoding.
  EXPECT_LE(worst, 2);
  // And each output is told apart from the composites of the other camera frames.
  EXPECT_GE(nearest_other, 10);
}

INSTANTIATE_TEST_SUITE_P(Device, ServiceBlend, ::testing::Values("cpu", "gpu", "cpu_lamps", "gpu_lamps"),
                         [](const auto& param_info) { return param_info.param; });

// The two blends give the same composited frames: per camera frame of the rig, the service's
// output with T blended on the CPU against its output with T blended on the GPU.
TEST(Service, BlendOnTheCpuAndOnTheGpuGiveTheSameFrames) {
  const Outputs& cpu = Outputs::get("cpu");
  const Outputs& gpu = Outputs::get("gpu");
  ASSERT_TRUE(cpu.error.empty()) << cpu.error;
  ASSERT_TRUE(gpu.error.empty()) << gpu.error;
  int worst = 0, compared = 0;
  double sum = 0;
  for (std::size_t k = static_cast<std::size_t>(cpu.frames_without_sky); k < cpu.recorded.size(); ++k) {
    const std::size_t index = nearest(cpu.recorded[k], cpu.direct).index;
    for (std::size_t g = static_cast<std::size_t>(gpu.frames_without_sky); g < gpu.recorded.size(); ++g) {
      if (nearest(gpu.recorded[g], gpu.direct).index != index) continue;
      cv::Mat difference;
      cv::absdiff(cpu.recorded[k], gpu.recorded[g], difference);
      worst = std::max(worst, max_difference(cpu.recorded[k], gpu.recorded[g]));
      sum += cv::mean(difference.reshape(1))[0];
      ++compared;
      break;
    }
  }
  std::printf("measured: %d frame pairs (same camera frame, blend on the CPU / on the GPU): max difference %d codes "
              "of 255, mean %.4f codes\n",
              compared, worst, compared > 0 ? sum / compared : 0.0);
  ASSERT_GE(compared, 3);
  // T half-float rounding on the GPU (≤ 2^-11): a code at most after sRGB encoding, rarely.
  EXPECT_LE(worst, 2);
  EXPECT_LT(sum / compared, 0.05);
}

// Ground points in the shadow the buildings cast with the sun towards `sun`: the convex hull of
// each box's corners projected along the sun onto the ground plane; signed distance (m) to the
// nearest hull edge, positive inside.
double shadow_depth(const Vector3d& sun, const Eigen::Vector2d& ground_point, double plane_height) {
  const std::array<std::pair<Vector3d, Vector3d>, 2> boxes{{{{-1, -1, 0}, {1, 1, 4}}, {{1, -1, 0}, {4, 1, 1.5}}}};
  double best = -std::numeric_limits<double>::infinity();
  for (const auto& [low, high] : boxes) {
    std::vector<cv::Point2f> corners;
    for (int k = 0; k < 8; ++k) {
      const Vector3d p((k & 1) ? high.x() : low.x(), (k & 2) ? high.y() : low.y(), (k & 4) ? high.z() : low.z());
      const Vector3d q = p - (p.z() - plane_height) / sun.z() * sun;
      corners.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()));
    }
    std::vector<cv::Point2f> hull;
    cv::convexHull(corners, hull);
    best = std::max(best, cv::pointPolygonTest(hull, cv::Point2f(static_cast<float>(ground_point.x()),
                                                                 static_cast<float>(ground_point.y())),
                                               true));
  }
  return best;
}

TEST(Service, TheBoxShadowLandsOnTheGroundWhereGeometryPutsIt) {
  const Outputs& out = Outputs::get("cpu");
  ASSERT_TRUE(out.error.empty()) << out.error;
  ASSERT_FALSE(out.recorded.empty());
  const cv::Mat& frame = out.recorded.back();
  const cv::Mat& input = out.inputs[nearest(frame, out.direct).index];
  const BakedSite& baked = BakedSite::get();
  const scene::Mesh mesh = scene::load_site_model(baked.site);
  const compose_test::RayCaster caster(mesh);
  const camera::Lens lens(out.hmd);
  const geom::Plane& ground = baked.manifest.planes[0].plane;
  const auto& R = out.pose.R_site_from_camera;
  const Vector3d& eye = out.pose.t_site_from_camera;

  // Every real-ground pixel clear of the building (1-pixel margin) and more than 0.3 m from a
  // shadow's edge: the ratio of the output to the camera's own pixel (linear, green) is T there.
  double shadowed_sum = 0, lit_sum = 0;
  int shadowed = 0, lit = 0, agree = 0;
  for (int y = 0; y < frame.rows; ++y) {
    for (int x = 0; x < frame.cols; ++x) {
      const auto ray = lens.unproject(Eigen::Vector2d(x, y));
      if (!ray) continue;
      const Vector3d d = R * ray->normalized();
      if (d.z() >= -1e-6) continue;
      const Vector3d g = eye + (ground.origin.z() - eye.z()) / d.z() * d;
      const Eigen::Vector2d st = compose_test::plane_st(ground, g);
      if (st.minCoeff() < 0.02 || st.maxCoeff() > 0.98) continue;
      bool clear = true;
      for (int dy = -1; dy <= 1 && clear; ++dy) {
        for (int dx = -1; dx <= 1 && clear; ++dx) {
          const auto r = lens.unproject(Eigen::Vector2d(x + dx, y + dy));
          if (r && caster.intersect(eye, R * r->normalized())) clear = false;
        }
      }
      if (!clear) continue;
      const double depth = shadow_depth(out.sun_direction, g.head<2>(), ground.origin.z());
      if (std::abs(depth) < 0.3) continue;
      const double ratio = compose_test::srgb_decode(frame.at<cv::Vec3b>(y, x)[1] / 255.0) /
                           compose_test::srgb_decode(input.at<cv::Vec3b>(y, x)[1] / 255.0);
      const bool geometry_says_shadow = depth > 0;
      (geometry_says_shadow ? shadowed_sum : lit_sum) += ratio;
      (geometry_says_shadow ? shadowed : lit) += 1;
      agree += geometry_says_shadow == (ratio < 0.6) ? 1 : 0;
    }
  }
  const double in_shadow = shadowed_sum / std::max(1, shadowed), outside = lit_sum / std::max(1, lit);
  const double agreement = static_cast<double>(agree) / std::max(1, shadowed + lit);
  std::printf("measured: sun at azimuth %.1f°, elevation %.1f°: %d ground pixels in the analytic shadow, mean T %.3f; "
              "%d outside it, mean T %.3f; %.1f%% agree with the geometry (T < 0.6 inside)\n",
              std::atan2(out.sun_direction.x(), out.sun_direction.y()) * 180 / std::numbers::pi,
              std::asin(out.sun_direction.z()) * 180 / std::numbers::pi, shadowed, in_shadow, lit, outside,
              100 * agreement);
  cv::Mat enlarged;
  cv::resize(frame, enlarged, {}, 4, 4, cv::INTER_NEAREST);
  compose_test::save_picture("live_service_frame_x4", enlarged);
  EXPECT_GT(shadowed, 100);
  EXPECT_GT(lit, 500);
  EXPECT_LT(in_shadow, 0.5 * outside);
  EXPECT_GT(outside, 0.85);
  EXPECT_GT(agreement, 0.97);
}

}  // namespace
}  // namespace skylit::live_test
