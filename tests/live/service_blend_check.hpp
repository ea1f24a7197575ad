#pragma once
// Shared by the tests of blend.basis (pca_basis_test.cpp, fitted_basis_test.cpp): the service run
// for 20 recorded frames on a rig's config with a given bake, site and `blend:` section, and each
// recorded frame after the first sky checked against the compositor driven directly, without the
// service: the same sky (SkyEstimator → layer_radiances, with the bake's dome basis), T of each
// plane from blend_cpu over one form of its basis with the sun's shadow map's visibility (as the
// service blends), composited over the rig's camera frames.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "live_fixture.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/track/pose.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::live_test {

// The rig's config with `bake:` pointing at `bake_dir`, `site:` at `site_file` (where given; else
// the tests' site) and `blend` (YAML) appended.
inline void write_config_with_bake(const Rig& rig, const fs::path& bake_dir, const std::string& blend,
                                   const fs::path& site_file = {}) {
  std::string text = rig.config_text();
  const auto replace = [&text](const std::string& original, const std::string& replacement) {
    const std::size_t at = text.find(original);
    ASSERT_NE(at, std::string::npos) << text;
    text.replace(at, original.size(), replacement);
  };
  replace("bake: " + quoted(BakedSite::get().dir / "bake") + "\n", "bake: " + quoted(bake_dir) + "\n");
  if (!site_file.empty()) replace("site: " + quoted(BakedSite::get().dir / "site.yaml") + "\n", "site: " + quoted(site_file) + "\n");
  std::ofstream(rig.config_file()) << text << blend;
}

// What the service runs on, and which form of the basis the direct composites blend.
struct ServiceBlendSetup {
  fs::path bake_dir;
  fs::path site_file;                                // empty: the tests' site
  std::string blend;                                 // the config's `blend:` section (YAML)
  blend::BasisForm form = blend::BasisForm::Full;  // the form whose T the direct composites use
  std::string label;                                 // what the "measured:" line names
};

// What came of it.
struct ServiceBlendResult {
  nlohmann::json status;                          // the service's, after its last frame
  bake_format::Manifest manifest;
  std::vector<Vector3d> sky;                      // S of the sky frame, one per dome layer
  blend::SunLight sun;
  std::vector<std::vector<float>> visibility;     // per plane: the sun's shadow map's
  std::vector<std::vector<float>> shadow_ratios;  // per plane: T (RGB) of the setup's form
  int worst = 255;                                // largest |recorded − nearest direct composite|, codes
  int compared = 0;                               // recorded frames compared
};

// Runs the service (until 6 frames with the sky, recorded) with the setup in the rig's config and
// compares its frames: each one after the sky came against the nearest direct composite (the
// frame it was made from), within 2 codes. Prints a "measured:" line. Checks what all forms
// share: the status' planes (name, source layers) and blends run.
inline void check_service_blend(const Rig& rig, const ServiceBlendSetup& setup, ServiceBlendResult& out) {
  ASSERT_NO_FATAL_FAILURE(write_config_with_bake(rig, setup.bake_dir, setup.blend, setup.site_file));
  const live::LiveConfig config = rig.config();
  live::ServiceOptions options = quiet_options();
  options.frames_with_sky = 6;  // however long the first sky takes on a loaded machine
  options.frames = 1000;
  options.record = rig.dir() / "recorded";
  {
    RunningService running(config, options);
    running.join();
    ASSERT_EQ(running.error(), "");
    out.status = running.status();
  }

  out.manifest = bake_format::read_manifest(setup.bake_dir);
  const bake_format::Manifest& manifest = out.manifest;
  const nlohmann::json& blend = out.status["blend"];
  ASSERT_EQ(blend["planes"].size(), manifest.planes.size()) << blend.dump(2);
  for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
    EXPECT_EQ(blend["planes"][j]["name"], manifest.planes[j].plane.name);
    EXPECT_EQ(blend["planes"][j]["source_layers"], manifest.layer_count());
  }
  EXPECT_GT(out.status["blends"]["run"].get<std::int64_t>(), 0);

  // The same sky without the service.
  const gpu::HeadlessContext context;
  const scene::Site site = scene::load_site(config.site);
  const scene::Mesh mesh = scene::load_site_model(site);
  std::vector<std::size_t> shape;
  const std::vector<float> transfer = bake_format::read_npy(setup.bake_dir / manifest.transfer_file, &shape);
  const geom::Dome dome(manifest.plan.frequency);
  sky::SkyEstimateOptions estimate_options;
  estimate_options.table.basis = manifest.plan.basis;
  const sky::SkyEstimator estimator(camera::load_calibration(config.sky.calibration), dome, estimate_options);
  const sky::SkyEstimate estimate =
      estimator.estimate(sky::linearise(sky::read_sky_image(rig.dir() / "sky" / "frame_0000.exr"), sky::ResponseCurve::linear(8), {}));
  ASSERT_TRUE(estimate.sun) << estimate.sun_reason;
  out.sky = sky::layer_radiances(estimate.luminance);
  ASSERT_EQ(out.sky.size(), manifest.layer_count());
  out.sun = blend::SunLight{estimate.sun->direction, estimate.sun->energy};
  std::vector<geom::Plane> planes;
  for (const auto& record : manifest.planes) planes.push_back(record.plane);
  render::SunShadowMap shadow_map(mesh, planes);
  shadow_map.update(out.sun.direction, std::max(estimate.sun->angular_radius, 0.0047));

  // T of each plane from the setup's form, and the composites with it.
  std::vector<gpu::Texture> textures;
  std::vector<GLuint> names;
  out.visibility.clear();
  out.shadow_ratios.clear();
  for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
    const int plane = static_cast<int>(j);
    const blend::BasisImages basis = blend::load_basis(setup.bake_dir, manifest, plane, setup.form);
    out.visibility.push_back(shadow_map.read_visibility(plane));
    std::vector<float> rgb(basis.texel_count() * 3);
    blend::blend_cpu(basis, blend::blend_weights(basis, out.sky, out.sun), out.visibility.back(), rgb);
    textures.push_back(render::upload_shadow_ratio(rgb, basis.width, basis.height));
    names.push_back(textures.back().get());
    out.shadow_ratios.push_back(std::move(rgb));
  }
  const auto pose = track::open_pose_source(config.pose)->pose_at(0.0);
  ASSERT_TRUE(pose);
  render::CompositeInput input;
  input.pose.R_site_from_camera = pose->R_site_from_camera.toRotationMatrix();
  input.pose.t_site_from_camera = pose->t_site_from_camera;
  input.sky = out.sky;
  input.sun = out.sun;
  input.shadow_ratios = names;
  input.sun_shadow = &shadow_map;
  render::Compositor compositor(site, mesh, manifest, transfer, camera::load_calibration(config.camera.calibration));
  std::vector<cv::Mat> direct;
  for (const cv::Mat& camera : rig.camera_frames()) {
    input.camera = camera;
    direct.push_back(compositor.composite(input));
  }

  out.worst = 0;
  out.compared = 0;
  const std::int64_t without_sky = out.status["frames_without_sky"].get<std::int64_t>();
  for (int k = static_cast<int>(without_sky); k < static_cast<int>(without_sky) + 6; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06d.png", k);
    const cv::Mat recorded = cv::imread((rig.dir() / "recorded" / name).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(recorded.empty()) << name;
    int nearest = 255;
    for (const cv::Mat& d : direct) nearest = std::min(nearest, max_difference(recorded, d));
    out.worst = std::max(out.worst, nearest);
    ++out.compared;
  }
  const std::string device = blend["device"].is_string() ? blend["device"].get<std::string>() : "?";
  std::printf("measured: %s, blend on the %s: %d frames, max |service − direct composite| %d codes\n", setup.label.c_str(),
              device.c_str(), out.compared, out.worst);
  EXPECT_GT(out.compared, 4);
  EXPECT_LE(out.worst, 2);
}

}  // namespace skylit::live_test
