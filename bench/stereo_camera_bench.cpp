// The second camera's cost (issue 22): today's stereo HMD frame (one camera image shared, the
// building drawn per eye) against a stereo camera's frame (each eye its own camera image, ROIs of
// one side-by-side frame, and its own Compositor), and the mono frame, on the generic profile,
// the sample gate under compose_bench's sky and sun. The frames alternate run by run, so that a
// load on the machine weighs on all alike; medians of wall and process CPU time.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <memory>
#include <numbers>
#include <string>
#include <unistd.h>
#include <vector>

#include <opencv2/core.hpp>

#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/model.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/blend/basis.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/render/hmd_distortion.hpp"
#include "skylit/render/stereo_camera.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/study/study.hpp"

namespace stereo_camera_bench {

namespace fs = std::filesystem;
using namespace skylit;

// The sample gate baked once (ray-traced), its shadow ratios for a clear sky with the sun at
// azimuth 140°, 35° up, and the sun's shadow map: compose_bench's scene.
struct Scene {
  fs::path dir = fs::temp_directory_path() / ("skylit-stereo-camera-bench-" + std::to_string(::getpid()));
  gpu::HeadlessContext context;
  scene::Site site;
  scene::Mesh mesh;
  bake_format::Manifest manifest;
  std::vector<float> transfer;
  std::vector<Eigen::Vector3d> sky;
  blend::SunLight sun;
  std::vector<gpu::Texture> ratios;
  std::vector<GLuint> ratio_names;
  std::unique_ptr<render::SunShadowMap> shadow_map;

  Scene() {
    baker::BakeOptions options;
    options.site_file = fs::path(SKYLIT_SOURCE_DIR) / "config/sample_site.yaml";
    options.out_dir = dir;
    options.method = "raytrace";
    options.previews = false;
    options.force = true;
    std::FILE* quiet = std::fopen("/dev/null", "w");
    baker::run_bake(options, quiet);
    std::fclose(quiet);
    manifest = bake_format::read_manifest(dir);
    site = scene::load_site(options.site_file);
    mesh = bake_format::load_baked_model(site, dir, manifest);
    std::vector<std::size_t> shape;
    transfer = bake_format::read_npy(dir / manifest.transfer_file, &shape);
    sky.assign(transfer.size() / mesh.vertex_count(), Eigen::Vector3d(0.3, 0.4, 0.6));
    const double az = 140 * std::numbers::pi / 180, el = 35 * std::numbers::pi / 180;
    sun = {Eigen::Vector3d(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)), Eigen::Vector3d::Constant(3.0)};
    std::vector<geom::Plane> planes;
    for (const auto& record : manifest.planes) planes.push_back(record.plane);
    shadow_map = std::make_unique<render::SunShadowMap>(mesh, planes);
    shadow_map->update(sun.direction, 0.0047);
    for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
      const blend::BasisImages basis = blend::load_basis(dir, manifest, static_cast<int>(j));
      const std::vector<float> visibility = shadow_map->read_visibility(static_cast<int>(j));
      std::vector<float> T(basis.texel_count() * 3);
      blend::blend_cpu(basis, blend::blend_weights(basis, sky, sun), visibility, T);
      ratios.push_back(render::upload_shadow_ratio(T, basis.width, basis.height));
      ratio_names.push_back(ratios.back().get());
    }
  }
  ~Scene() {
    std::error_code ignored;
    fs::remove_all(dir, ignored);
  }
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  render::CompositeInput input(const cv::Mat& image, const render::CameraPose& pose) const {
    render::CompositeInput in;
    in.camera = image;
    in.pose = pose;
    in.sky = sky;
    in.sun = sun;
    in.shadow_ratios = ratio_names;
    in.sun_shadow = shadow_map.get();
    return in;
  }
};

double process_cpu_ms() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return 1e3 * static_cast<double>(now.tv_sec) + 1e-6 * static_cast<double>(now.tv_nsec);
}

struct Timing {
  std::vector<double> wall_ms, cpu_ms;
};

// One frame, glFinish included (what a display waits for).
template <typename Frame>
void time_frame(Timing& timing, Frame&& frame) {
  glFinish();
  const auto wall = std::chrono::steady_clock::now();
  const double cpu = process_cpu_ms();
  frame();
  glFinish();
  timing.wall_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall).count());
  timing.cpu_ms.push_back(process_cpu_ms() - cpu);
}

int run(int width, int height, int runs) {
  const Scene scene;
  const camera::CameraCalibration calibration =
      study::scaled_camera(fs::path(SKYLIT_SOURCE_DIR) / "config/hmd_camera.yaml", width, height);
  render::HmdProfile profile = render::load_hmd_profile(fs::path(SKYLIT_SOURCE_DIR) / "config/hmd/generic.yaml");
  render::HmdDistortion hmd(profile);

  // Today: one camera between the eyes, its image shared.
  cv::Mat mono_image(height, width, CV_8UC3);
  cv::randu(mono_image, cv::Scalar::all(0), cv::Scalar::all(256));
  render::Compositor shared(scene.site, scene.mesh, scene.manifest, scene.transfer, calibration);
  const render::CompositeInput shared_input = scene.input(mono_image, study::visitor_pose());

  // A stereo camera: the same lens twice, the right camera the profile's IPD to the left's right,
  // both images in one side-by-side frame.
  camera::StereoCalibration stereo;
  stereo.left = stereo.right = calibration;
  stereo.t_right_from_left = Eigen::Vector3d(-profile.ipd, 0, 0);
  cv::Mat side_by_side(height, 2 * width, CV_8UC3);
  cv::randu(side_by_side, cv::Scalar::all(0), cv::Scalar::all(256));
  const std::array<render::CameraPose, 2> poses = render::stereo_camera_poses(render::eye_pose(study::visitor_pose(), profile.ipd, 0), stereo);
  const std::array<render::CompositeInput, 2> eye_inputs{scene.input(side_by_side(cv::Rect(0, 0, width, height)), poses[0]),
                                                         scene.input(side_by_side(cv::Rect(width, 0, width, height)), poses[1])};
  render::Compositor left(scene.site, scene.mesh, scene.manifest, scene.transfer, stereo.left);
  render::Compositor right(scene.site, scene.mesh, scene.manifest, scene.transfer, stereo.right);
  const std::array<render::Compositor*, 2> eyes{&left, &right};

  auto mono_frame = [&] { render::draw_hmd_frame(shared, hmd, shared_input, render::StereoMode::mono); };
  auto shared_frame = [&] { render::draw_hmd_frame(shared, hmd, shared_input, render::StereoMode::stereo); };
  auto stereo_frame = [&] { render::draw_hmd_frame(eyes, hmd, eye_inputs); };
  shared_frame();  // warm-up: first-use allocations in the driver, the sky's irradiance sums
  stereo_frame();
  Timing mono, today, two_cameras;
  for (int k = 0; k < runs; ++k) {
    time_frame(mono, mono_frame);
    time_frame(today, shared_frame);
    time_frame(two_cameras, stereo_frame);
  }
  std::array<double, 1> load{};
  if (getloadavg(load.data(), 1) != 1) load[0] = -1;
  const double today_wall = study::median(today.wall_ms), today_cpu = study::median(today.cpu_ms);
  const double two_wall = study::median(two_cameras.wall_ms), two_cpu = study::median(two_cameras.cpu_ms);
  std::printf("HMD panel %d×%d (%s), camera %d×%d, medians of %d runs each, load average %.1f at the end\n",
              profile.panel_width, profile.panel_height, profile.name.c_str(), width, height, runs, load[0]);
  std::printf("| frame | wall ms | process CPU ms |\n|---|---|---|\n");
  std::printf("| mono frame (one composite, both eyes) | %.0f | %.0f |\n", study::median(mono.wall_ms),
              study::median(mono.cpu_ms));
  std::printf("| today's stereo frame (one camera image shared) | %.0f | %.0f |\n", today_wall, today_cpu);
  std::printf("| stereo camera frame (a camera image per eye) | %.0f | %.0f |\n", two_wall, two_cpu);
  std::printf("| stereo camera / today's stereo | %.3f | %.3f |\n", two_wall / today_wall, two_cpu / today_cpu);
  return 0;
}

}  // namespace stereo_camera_bench

int main(int argc, char** argv) {
  if (argc != 1 && argc != 3 && argc != 4) {
    std::fprintf(stderr, "usage: %s [WIDTH HEIGHT [RUNS]]  (default 1920 1080 9)\n", argv[0]);
    return 2;
  }
  const int width = argc >= 3 ? std::atoi(argv[1]) : 1920;
  const int height = argc >= 3 ? std::atoi(argv[2]) : 1080;
  const int runs = argc == 4 ? std::atoi(argv[3]) : 9;
  if (width < 16 || height < 16 || runs < 1) {
    std::fprintf(stderr, "stereo_camera_bench: WIDTH and HEIGHT at least 16, RUNS at least 1\n");
    return 2;
  }
  return stereo_camera_bench::run(width, height, runs);
}
