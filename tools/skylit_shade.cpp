// skylit-shade: shadow ratios of every plane of a bake under one sky frame (or exposure
// bracket), and the building's irradiance per vertex, computed on the CPU: the offline preview,
// the reference for the GPU path, and the tool installers use to check a sky camera against a bake.
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

// GCC 12 inlines CLI11's string splitting into this file at -O3 and then warns about a null
// dereference inside libstdc++'s string move that cannot happen (a known false positive).
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/model.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/baker/preview.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/scene/ply.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/camera/calibration.hpp"
#include "skylit/sky/image_io.hpp"
#include "skylit/sky/overlay.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/sky/srgb.hpp"
#include "command_line.hpp"

namespace {

namespace fs = std::filesystem;
using skylit::InputError;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

struct Options {
  std::string bake_dir;
  std::vector<std::string> sky;
  std::string sky_calib;
  std::string out_dir;
  std::string sun = "auto";
  int sources = 1;                // separated sources at most: the sun, then compact lamps
  std::vector<double> exposure;   // seconds, one per frame
  double gain = 1.0;
  std::string response = "srgb";  // srgb | linear | FILE.yaml
  std::string site;               // overrides the site recorded in the bake (for the sun's shadows)
  int step = 1;
  double min_coverage = 0.05;
  int threads = 0;
  double ground_albedo = 0.0;     // > 0: the building also lit by the ground (the bake's ground layer)
  std::string sun_colour = "daylight";  // daylight: an impossible sun colour corrected; measured: kept
  std::string utc;                // the frame's time (ISO 8601): with the site's location, where the sun is
  std::string clipped_sun_energy = "measured";  // measured | clear_sky (docs/sky.md, "A clipped sun")
};

// Where the site's location and the frame's time (--utc) put the sun; none without --utc.
std::optional<skylit::sky::Vec3> expected_sun(const Options& o, const skylit::bake_format::Manifest& manifest) {
  if (o.utc.empty()) return std::nullopt;
  const std::chrono::sys_seconds utc = skylit::sky::parse_utc(o.utc);
  const fs::path site_file = o.site.empty() ? fs::path(manifest.plan.site_file) : fs::path(o.site);
  if (!fs::exists(site_file)) {
    throw InputError("option --utc: the site " + site_file.string() + " is not here to say where on Earth it is. "
                     "Fix: pass --site SITE.yaml");
  }
  const skylit::scene::Site site = skylit::scene::load_site(site_file);
  if (!site.location) {
    throw InputError("option --utc: the site " + site_file.string() + " has no location. Fix: add 'location: "
                     "{latitude: DEG, longitude: DEG}' to it (docs/site-format.md), or leave --utc out");
  }
  return skylit::sky::solar_position(utc, site.location->latitude_deg, site.location->longitude_deg).direction();
}

// The frames as one linear radiance image: a single frame linearised, a bracket merged.
skylit::sky::RadianceFrame load_sky(const Options& o, const skylit::camera::CameraCalibration& calibration) {
  std::vector<cv::Mat> frames;
  for (const std::string& file : o.sky) {
    cv::Mat frame = skylit::sky::read_sky_image(file);
    if (frame.cols != calibration.image_width || frame.rows != calibration.image_height) {
      throw InputError(file + ": the sky frame is " + std::to_string(frame.cols) + "×" + std::to_string(frame.rows) +
                       ", the calibration " + calibration.file.string() + " is for " +
                       std::to_string(calibration.image_width) + "×" + std::to_string(calibration.image_height) +
                       ". Fix: use the calibration of the camera (and mode) that took the frame");
    }
    frames.push_back(std::move(frame));
  }
  if (!o.exposure.empty() && o.exposure.size() != frames.size()) {
    throw InputError("option --exposure: " + std::to_string(o.exposure.size()) + " time(s) for " +
                     std::to_string(frames.size()) + " frame(s). Fix: give one exposure time per --sky image, in order");
  }
  std::vector<skylit::sky::Exposure> exposures;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    if (!o.exposure.empty()) {
      exposures.push_back({o.exposure[k], o.gain});
    } else if (auto meta = skylit::sky::read_exposure_metadata(o.sky[k])) {
      exposures.push_back(*meta);
    } else if (frames.size() == 1) {
      exposures.push_back({1.0, o.gain});
    } else {
      throw InputError(o.sky[k] + ": no exposure time in the file's metadata, and a bracket needs one per frame. "
                                  "Fix: give --exposure T1 T2 ... (seconds)");
    }
  }
  const int depth = frames.front().depth();
  const int bits = depth == CV_8U ? 8 : depth == CV_16U ? 16 : 0;
  if (frames.size() == 1) {
    return skylit::sky::linearise(
        frames.front(), bits ? skylit::sky::response_for(o.response, bits) : skylit::sky::ResponseCurve::linear(8),
        exposures.front());
  }
  if (!bits) {
    throw InputError(o.sky.front() + ": an exposure bracket must be 8- or 16-bit frames. Fix: pass one float (EXR) "
                                     "frame alone, it is already HDR");
  }
  return skylit::sky::merge_bracket(frames, exposures, skylit::sky::response_for(o.response, bits));
}

std::vector<std::string> face_flag_names(std::uint32_t flags) {
  std::vector<std::string> names;
  if (flags & skylit::sky::kFaceUnseen) names.emplace_back("unseen");
  if (flags & skylit::sky::kFaceClipped) names.emplace_back("clipped");
  if (flags & skylit::sky::kFaceBadPixels) names.emplace_back("bad_pixels");
  if (flags & skylit::sky::kFaceSunRemoved) names.emplace_back("sun_removed");
  if (flags & skylit::sky::kFaceCornersFromMean) names.emplace_back("corners_from_mean");
  if (flags & skylit::sky::kFaceFitLinear) names.emplace_back("fit_linear");
  return names;
}

nlohmann::json vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// The site model the bake was made from, for the separated sources' shadows.
skylit::scene::Mesh site_mesh(const Options& o, const skylit::bake_format::Manifest& manifest) {
  const fs::path site_file = o.site.empty() ? fs::path(manifest.plan.site_file) : fs::path(o.site);
  if (!fs::exists(site_file)) {
    throw InputError(site_file.string() + ": the site this bake was made from is not here, and the sun's shadows "
                                          "need its model. Fix: pass --site SITE.yaml, or --sun off");
  }
  const skylit::scene::Site site = skylit::scene::load_site(site_file);
  if (skylit::sha256_file(site.model) == manifest.plan.model_sha256) {
    return skylit::bake_format::load_baked_model(site, o.bake_dir, manifest);
  }
  spdlog::warn("the model {} changed since the bake was made: the sun's shadows follow the new model",
               site.model.string());
  return skylit::scene::load_site_model(site);
}

// Visibility of a separated source (the sun, a lamp) for every texel of every plane: its disc as
// an area light (soft shadows), ray-cast with Embree against the site model.
std::vector<std::vector<float>> sun_visibility(const Options& o, const skylit::bake_format::Manifest& manifest,
                                               const skylit::scene::Mesh& mesh, const skylit::sky::Sun& sun) {
  std::vector<skylit::geom::Vec3> directions = sun.disc_directions;
  std::vector<double> weights = sun.disc_weights;
  if (directions.empty()) {
    directions = {sun.direction};
    weights = {1.0};
  }
  std::vector<std::vector<float>> visibility;
  for (const auto& p : manifest.planes) {
    std::vector<float> v(static_cast<std::size_t>(p.plane.width) * static_cast<std::size_t>(p.plane.height));
    skylit::baker::area_light_visibility(mesh, p.plane, directions, weights, v, {o.threads});
    visibility.push_back(std::move(v));
  }
  return visibility;
}

// InputError for option values that contradict each other.
void check_options(const Options& o) {
  if (o.sun != "auto" && o.sun != "off") {
    throw InputError("option --sun: got '" + o.sun + "'. Fix: use --sun auto (separate a compact sun) or --sun off");
  }
  if (o.sources < 1 || (o.sources > 1 && o.sun == "off")) {
    throw InputError("option --sources: got " + std::to_string(o.sources) + (o.sun == "off" ? " with --sun off" : "") +
                     ". Fix: use --sources 1 (the sun alone), or N > 1 with --sun auto to separate further compact "
                     "sources");
  }
}

// The bake's manifest, after verify has found nothing wrong with it (InputError listing every problem).
skylit::bake_format::Manifest verified_manifest(const Options& o) {
  skylit::bake_format::VerifyReport report = skylit::bake_format::verify(o.bake_dir);
  if (!report.ok) {
    std::string problems;
    for (const std::string& p : report.problems) problems += "\n  - " + p;
    throw InputError(o.bake_dir + ": not a valid bake:" + problems);
  }
  return std::move(report.manifest);
}

// The building's irradiance per vertex (blend::vertex_irradiance: the transfer vectors times S,
// each source through its disc's visibility from the vertex), written as building.ply (vertex
// colours for a viewer, the linear RGB irradiance and the sun's visibility as properties) and
// building.png (a picture from a default view); summarised for sky.json.
nlohmann::json shade_building(const Options& o, const skylit::bake_format::Manifest& manifest,
                              const skylit::scene::Mesh& mesh, std::span<const Eigen::Vector3d> S,
                              const skylit::sky::SkyEstimate& estimate) {
  const fs::path transfer_file = fs::path(o.bake_dir) / manifest.transfer_file;
  std::vector<std::size_t> shape;
  const std::vector<float> transfer = skylit::bake_format::read_npy(transfer_file, &shape);
  if (shape.size() != 2 || shape[0] != mesh.vertex_count() || shape[1] != S.size()) {
    throw InputError(transfer_file.string() + ": the transfer array is not one row of " + std::to_string(S.size()) +
                     " layers per vertex of the site's model (" + std::to_string(mesh.vertex_count()) +
                     " vertices). Fix: bake the site again, or pass --site with the model the bake was made from");
  }
  std::vector<skylit::geom::Plane> planes;
  for (const auto& p : manifest.planes) planes.push_back(p.plane);
  std::vector<skylit::blend::SunLight> lights;
  std::vector<std::vector<float>> visibility;
  for (const skylit::sky::Sun& source : estimate.sources) {
    lights.push_back({source.direction, source.energy});
    visibility.emplace_back(mesh.vertex_count(), 1.0f);
    std::vector<skylit::geom::Vec3> directions = source.disc_directions;
    std::vector<double> weights = source.disc_weights;
    if (directions.empty()) {
      directions = {source.direction};
      weights = {1.0};
    }
    skylit::baker::area_light_vertex_visibility(mesh, planes, directions, weights, visibility.back(), {o.threads});
  }
  std::vector<float> ground_transfer;
  skylit::blend::GroundLight ground;
  if (o.ground_albedo > 0.0) {
    if (!manifest.ground) {
      throw InputError("option --ground-albedo: the bake " + o.bake_dir + " has no ground layer. Fix: bake it again with "
                       "skylit-bake --ground-samples 256 (the default), or leave --ground-albedo out");
    }
    ground_transfer = skylit::bake_format::read_npy(fs::path(o.bake_dir) / manifest.ground->file, &shape);
    const skylit::blend::GroundLayers layers(manifest.plan.frequency, manifest.plan.basis, manifest.ground->horizontal_unoccluded);
    ground = {ground_transfer, layers.coefficients(S, lights), Eigen::Vector3d::Constant(o.ground_albedo)};
  }
  const std::vector<Eigen::Vector3d> E = skylit::blend::vertex_irradiance(transfer, S, mesh.normals, lights, visibility, ground);

  // White: the 99th percentile of the vertices' brightest channel, so that a few sunlit
  // vertices do not darken the rest.
  std::vector<double> brightest;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& e : E) {
    brightest.push_back(e.maxCoeff());
    sum += e;
  }
  std::vector<double> sorted = brightest;
  std::sort(sorted.begin(), sorted.end());
  const double white = sorted.empty() ? 1.0 : std::max(sorted[static_cast<std::size_t>(0.99 * static_cast<double>(sorted.size() - 1))], 1e-12);
  std::vector<std::array<std::uint8_t, 3>> colours;
  std::vector<skylit::scene::VertexProperty> properties{{"irradiance_r", {}}, {"irradiance_g", {}}, {"irradiance_b", {}}};
  for (const Eigen::Vector3d& e : E) {
    std::array<std::uint8_t, 3> c{};
    for (int k = 0; k < 3; ++k) {
      c[static_cast<std::size_t>(k)] = skylit::sky::srgb_encode8(e[k] / white);
      properties[static_cast<std::size_t>(k)].values.push_back(static_cast<float>(e[k]));
    }
    colours.push_back(c);
  }
  if (estimate.sun) properties.push_back({"sun_visibility", visibility.front()});
  const fs::path out_dir = o.out_dir;
  skylit::scene::write_ply(out_dir / "building.ply", mesh, colours, properties);
  char caption[160];
  std::snprintf(caption, sizeof caption, "irradiance per vertex, linear; white = %.4g (the 99th percentile)%s", white,
                estimate.sun ? ", the sun's shadows included" : "");
  skylit::baker::write_vertex_picture(out_dir / "building.png", mesh, E, white, caption);
  const double n = static_cast<double>(std::max<std::size_t>(1, E.size()));
  nlohmann::json building{{"vertices", mesh.vertex_count()},
                          {"ply", "building.ply"},
                          {"picture", "building.png"},
                          {"mean_irradiance", vec(sum / n)},
                          {"white", white}};
  if (o.ground_albedo > 0.0) building["ground_albedo"] = o.ground_albedo;
  if (estimate.sun) {
    double lit = 0;
    for (float v : visibility.front()) lit += v;
    building["mean_sun_visibility"] = lit / n;
  }
  spdlog::info("building: {} vertices, mean irradiance RGB {:.4g} {:.4g} {:.4g}", mesh.vertex_count(), sum.x() / n, sum.y() / n,
               sum.z() / n);
  return building;
}

// One plane's T under the sky: blended, written as EXR and PNG, summarised for sky.json.
nlohmann::json shade_plane(const Options& o, const skylit::bake_format::Manifest& manifest, std::size_t j,
                           std::span<const Eigen::Vector3d> S, std::span<const skylit::blend::SunLight> lights,
                           const std::vector<std::vector<std::vector<float>>>& visibility, double& blend_ms) {
  const fs::path out_dir = o.out_dir;
  skylit::blend::BlendOptions blend_options;
  blend_options.threads = o.threads;
  const skylit::blend::BasisImages basis = skylit::blend::load_basis(o.bake_dir, manifest, static_cast<int>(j));
  const auto t = Clock::now();
  const skylit::blend::BlendWeights weights = skylit::blend::blend_weights_sources(basis, S, lights, blend_options);
  std::vector<float> rgb(basis.texel_count() * 3);
  std::vector<std::span<const float>> v;
  for (const auto& source : visibility) v.emplace_back(source[j]);
  const skylit::blend::BlendStats stats = skylit::blend::blend_cpu_sources(basis, weights, v, rgb, blend_options);
  const double ms = ms_since(t);
  blend_ms += ms;

  cv::Mat image(basis.height, basis.width, CV_32FC3);
  double sum = 0, lowest = 1;
  for (int row = 0; row < basis.height; ++row) {
    auto* out = image.ptr<cv::Vec3f>(row);
    for (int col = 0; col < basis.width; ++col) {
      const float* texel = &rgb[(static_cast<std::size_t>(row) * basis.width + col) * 3];
      out[col] = cv::Vec3f(texel[2], texel[1], texel[0]);
      const double y = 0.2126 * texel[0] + 0.7152 * texel[1] + 0.0722 * texel[2];
      sum += y;
      lowest = std::min(lowest, y);
    }
  }
  skylit::sky::write_sky_exr(out_dir / (basis.name + ".exr"), image);
  skylit::sky::write_image(out_dir / (basis.name + ".png"), skylit::sky::to_8bit_linear(image));
  const bool no_light = weights.no_light[0] || weights.no_light[1] || weights.no_light[2];
  nlohmann::json plane{{"name", basis.name},
                       {"width", basis.width},
                       {"height", basis.height},
                       {"mean_T", sum / static_cast<double>(basis.texel_count())},
                       {"min_T", lowest},
                       {"denominator", vec(weights.denominator)},
                       {"no_light", {weights.no_light[0], weights.no_light[1], weights.no_light[2]}},
                       {"active_faces", weights.active.size()},
                       {"clamped", stats.clamped},
                       {"max_above_one", stats.max_above_one},
                       {"blend_ms", ms}};
  spdlog::info("plane '{}': mean T {:.3f}, min {:.3f}{}", basis.name, sum / static_cast<double>(basis.texel_count()),
               lowest, no_light ? " (no light reaches it: T = 1)" : "");
  return plane;
}

// Each face's S (and its corner or quadratic coefficients), as sky.json lists them.
nlohmann::json faces_json(const skylit::geom::Dome& dome, const skylit::sky::SkyEstimate& estimate,
                          skylit::geom::DomeBasis basis) {
  nlohmann::json faces = nlohmann::json::array();
  for (int i = 0; i < dome.face_count(); ++i) {
    const auto& f = estimate.luminance.faces[static_cast<std::size_t>(i)];
    nlohmann::json face{{"index", i},
                        {"direction", vec(dome.face(i).centre)},
                        {"solid_angle", dome.face(i).solid_angle},
                        {"S", vec(f.rgb)},
                        {"coverage", f.coverage},
                        {"clipped_fraction", f.clipped_fraction},
                        {"flags", face_flag_names(f.flags)}};
    if (basis == skylit::geom::DomeBasis::Corners) {
      // S at the face's vertices (layers 3i, 3i+1, 3i+2), with where each vertex is.
      nlohmann::json corners = nlohmann::json::array();
      for (std::size_t k = 0; k < 3; ++k) {
        const auto vertex = static_cast<std::size_t>(dome.face(i).vertex[k]);
        corners.push_back({{"vertex", vertex}, {"direction", vec(dome.vertices()[vertex])}, {"S", vec(f.coefficients[k])}});
      }
      face["corners"] = std::move(corners);
    } else if (basis == skylit::geom::DomeBasis::Quadratics) {
      // The six coefficients (layers 6i..6i+5): λ_k² at vertex k, then 2λ_kλ_l on the edges.
      static constexpr std::array<const char*, 6> kFunctions{"vertex 0", "vertex 1", "vertex 2",
                                                             "edge 01",  "edge 12",  "edge 20"};
      nlohmann::json quadratics = nlohmann::json::array();
      for (std::size_t k = 0; k < kFunctions.size(); ++k) {
        quadratics.push_back({{"function", kFunctions[k]}, {"S", vec(f.coefficients[k])}});
      }
      face["quadratics"] = std::move(quadratics);
    }
    faces.push_back(std::move(face));
  }
  return faces;
}

// A separated source as sky.json lists it: where, how large and how bright.
nlohmann::json source_json(const skylit::sky::Sun& s) {
  const double elevation = std::asin(std::clamp(s.direction.z(), -1.0, 1.0)) * 180.0 / 3.141592653589793;
  const double azimuth = std::fmod(std::atan2(s.direction.x(), s.direction.y()) * 180.0 / 3.141592653589793 + 360.0, 360.0);
  nlohmann::json out{{"direction", vec(s.direction)},
                        {"azimuth_deg", azimuth},
                        {"elevation_deg", elevation},
                        {"angular_radius_deg", s.angular_radius * 180.0 / 3.141592653589793},
                        {"energy", vec(s.energy)},
                        {"background", vec(s.background)},
                        {"contrast", s.contrast},
                        {"pixels", s.pixel_count},
                        {"clipped", s.clipped},
                        {"colour_corrected", s.colour_corrected},
                        {"located_by", s.located_by},
                        {"energy_estimator", s.energy_estimator},
                        {"energy_confidence", s.energy_confidence}};
  if (s.colour_corrected || s.energy_estimator != "measured") out["measured_energy"] = vec(s.measured_energy);
  return out;
}

// What the sky stage counted that a user should know about.
void report_pixels_and_faces(const skylit::sky::Luminance& l) {
  if (l.nan_pixels + l.inf_pixels + l.negative_pixels > 0) {
    spdlog::warn("{} NaN, {} Inf and {} negative pixel(s) counted as 0", l.nan_pixels, l.inf_pixels, l.negative_pixels);
  }
  if (l.unseen_faces > 0) spdlog::warn("{} face(s) the lens does not see were filled from their neighbours", l.unseen_faces);
  if (l.corners_from_mean > 0) {
    spdlog::info("{} face(s) seen too little to fit their functions carry their mean in each", l.corners_from_mean);
  }
  if (l.linear_fits > 0) {
    spdlog::info("{} face(s) seen too little for a quadratic fit carry a linear one", l.linear_fits);
  }
  if (l.no_face_seen) spdlog::warn("the frame sees no face of the dome: every S is 0 and T = 1");
  if (l.clipped_pixels > 0) spdlog::warn("{} clipped pixel(s): the sky there is brighter than measured", l.clipped_pixels);
}

int run(const Options& o) {
  const auto start = Clock::now();
  const fs::path out_dir = o.out_dir;
  check_options(o);
  // The small inputs first: a sky frame or calibration that cannot be read is named before the
  // bake is verified (which reads every file of it).
  const skylit::camera::CameraCalibration calibration = skylit::camera::load_calibration(o.sky_calib);
  auto t = Clock::now();
  const skylit::sky::RadianceFrame frame = load_sky(o, calibration);
  const double load_ms = ms_since(t);

  const skylit::bake_format::Manifest manifest = verified_manifest(o);
  skylit::ensure_writable_directory(out_dir);
  const skylit::geom::Dome dome(manifest.plan.frequency);

  t = Clock::now();
  skylit::sky::SkyEstimateOptions sky_options;
  sky_options.table.step = o.step;
  sky_options.table.basis = manifest.plan.basis;  // S per layer of the bake
  sky_options.luminance.min_coverage = o.min_coverage;
  sky_options.sun_mode = o.sun == "auto" ? skylit::sky::SunMode::Auto : skylit::sky::SunMode::Off;
  sky_options.max_sources = o.sources;
  sky_options.correct_sun_colour = o.sun_colour == "daylight";
  sky_options.clipped_sun_energy = skylit::sky::parse_clipped_sun_energy(o.clipped_sun_energy, "--clipped-sun-energy");
  const skylit::sky::SkyEstimator estimator(calibration, dome, sky_options);
  const double table_ms = ms_since(t);
  const skylit::sky::SkyEstimate estimate = estimator.estimate(frame, expected_sun(o, manifest));

  const std::vector<Eigen::Vector3d> S = skylit::sky::layer_radiances(estimate.luminance);
  // One separated term per source (with --sources 1: the sun, when there is one).
  std::vector<skylit::blend::SunLight> lights;
  std::vector<std::vector<std::vector<float>>> visibility;  // [source][plane][texel]
  double visibility_ms = 0;
  // The site's model: for the sources' shadows and the building's light. Without it (a bake
  // moved away from its site) the planes are still shaded when no source needs shadows.
  const fs::path site_file = o.site.empty() ? fs::path(manifest.plan.site_file) : fs::path(o.site);
  std::optional<skylit::scene::Mesh> mesh;
  if (!estimate.sources.empty() || fs::exists(site_file)) mesh = site_mesh(o, manifest);
  if (!estimate.sources.empty()) {
    t = Clock::now();
    for (const skylit::sky::Sun& source : estimate.sources) {
      lights.push_back(skylit::blend::SunLight{source.direction, source.energy});
      visibility.push_back(sun_visibility(o, manifest, *mesh, source));
    }
    visibility_ms = ms_since(t);
  }

  nlohmann::json planes_json = nlohmann::json::array();
  double blend_ms = 0;
  for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
    planes_json.push_back(shade_plane(o, manifest, j, S, lights, visibility, blend_ms));
  }

  nlohmann::json building = nullptr;
  double building_ms = 0;
  if (mesh) {
    t = Clock::now();
    building = shade_building(o, manifest, *mesh, S, estimate);
    building_ms = ms_since(t);
  } else {
    spdlog::warn("{}: the site is not here: the building's light is left out (pass --site SITE.yaml)", site_file.string());
  }

  const nlohmann::json faces = faces_json(dome, estimate, manifest.plan.basis);
  const auto& l = estimate.luminance;
  nlohmann::json sky{{"bake", o.bake_dir},
                     {"frames", o.sky},
                     {"calibration", o.sky_calib},
                     {"dome_frequency", dome.frequency()},
                     {"basis", skylit::geom::basis_name(manifest.plan.basis)},
                     {"faces", faces},
                     {"samples", l.samples},
                     {"pixels", {{"nan", l.nan_pixels}, {"inf", l.inf_pixels}, {"negative", l.negative_pixels},
                                 {"clipped", l.clipped_pixels}}},
                     {"unseen_faces", l.unseen_faces},
                     {"corners_from_mean", l.corners_from_mean},
                     {"linear_fits", l.linear_fits},
                     {"no_face_seen", l.no_face_seen},
                     {"sun_mode", o.sun},
                     {"sun_reason", estimate.sun_reason},
                     {"max_sources", o.sources},
                     {"planes", planes_json},
                     {"building", building}};
  sky["sun"] = estimate.sun ? source_json(*estimate.sun) : nlohmann::json(nullptr);
  // Every separated source, the sun first when there is one ("sun": true on it).
  nlohmann::json sources_json = nlohmann::json::array();
  for (std::size_t k = 0; k < estimate.sources.size(); ++k) {
    nlohmann::json s = source_json(estimate.sources[k]);
    s["sun"] = k == 0 && estimate.sun.has_value();
    sources_json.push_back(std::move(s));
  }
  sky["sources"] = std::move(sources_json);
  if (o.sources > 1) sky["sources_reason"] = estimate.sources_reason;
  sky["timings_ms"] = {{"load_frames", load_ms},  {"table", table_ms},         {"sun", estimate.sun_ms},
                       {"luminance", estimate.luminance_ms}, {"sun_visibility", visibility_ms},
                       {"blend", blend_ms},       {"building", building_ms}, {"total", ms_since(start)}};
  skylit::write_file_atomic(out_dir / "sky.json", sky.dump(2) + "\n");
  skylit::sky::write_image(out_dir / "sky_overlay.png",
                           skylit::sky::draw_sky_overlay(estimator.lens(), dome, frame.radiance, estimate));

  report_pixels_and_faces(l);
  spdlog::info("sun: {}", estimate.sun_reason);
  if (estimate.sun && estimate.sun->colour_corrected) {
    const Eigen::Vector3d& m = estimate.sun->measured_energy;
    const Eigen::Vector3d& e = estimate.sun->energy;
    spdlog::warn("the sun's colour, RGB {:.3g} {:.3g} {:.3g}, is impossible for daylight (a lossy capture keeps one "
                 "channel): taken as a clear sky's sun at its elevation, {:.3g} {:.3g} {:.3g} (--sun-colour measured "
                 "keeps it)", m.x(), m.y(), m.z(), e.x(), e.y(), e.z());
  }
  if (o.sources > 1) {
    spdlog::info("{} separated source(s) (at most {}): {}", estimate.sources.size(), o.sources, estimate.sources_reason);
  }
  spdlog::info("wrote {} plane(s), {}sky.json and sky_overlay.png to {} in {:.0f} ms", manifest.planes.size(),
               mesh ? "building.ply, building.png, " : "", out_dir.string(), ms_since(start));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"skylit-shade: shadow ratios of a bake's planes under a sky frame (CPU reference)", "skylit-shade"};
  skylit::tools::add_version_flag(app);
  Options o;
  app.add_option("--bake", o.bake_dir, "bake directory (from skylit-bake)")->required()->check(CLI::ExistingDirectory);
  app.add_option("--sky", o.sky, "sky frame; several form one exposure bracket")->required()->check(CLI::ExistingFile);
  app.add_option("--sky-calib", o.sky_calib, "sky-camera calibration (YAML, or OpenCV FileStorage)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("-o,--output", o.out_dir, "output directory")->required();
  app.add_option("--sun", o.sun, "auto: separate a compact sun as a directional light; off: dome only")
      ->capture_default_str();
  app.add_option("--sources", o.sources,
                 "separated sources at most: 1 the sun alone; N > 1 also up to N − 1 further compact sources "
                 "(lamps), each with its own shadows")
      ->capture_default_str();
  app.add_option("--exposure", o.exposure, "exposure time per frame, seconds (default: from EXIF, or 1)");
  app.add_option("--gain", o.gain, "sensor gain (linear) when --exposure is given")->capture_default_str();
  app.add_option("--response", o.response, "camera response for 8/16-bit frames: srgb, linear or a YAML curve")
      ->capture_default_str();
  app.add_option("--site", o.site, "site YAML for the sun's shadows (default: the one the bake records)")
      ->check(CLI::ExistingFile);
  app.add_option("--step", o.step, "sky table: sample every N-th pixel")->capture_default_str();
  app.add_option("--min-coverage", o.min_coverage, "faces seen less than this are filled from neighbours")
      ->capture_default_str();
  app.add_option("--sun-colour", o.sun_colour,
                 "daylight: a sun whose colour is impossible for daylight (one channel kept by a lossy capture) gets a "
                 "clear sky's sun colour at its elevation, flagged in sky.json; measured: as the pixels say")
      ->check(CLI::IsMember({"daylight", "measured"}))
      ->capture_default_str();
  app.add_option("--ground-albedo", o.ground_albedo,
                 "the building also lit by a ground of this albedo (the bake's ground layer; render.ground_light)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--utc", o.utc,
                 "the sky frame's time (ISO 8601, e.g. 2026-06-21T09:30:00+09:00): with the site's location, a clipped "
                 "blob where the sun should be is the sun");
  app.add_option("--clipped-sun-energy", o.clipped_sun_energy,
                 "a clipped sun's energy: measured (its pixels, a lower bound) or clear_sky (a clear-sky model fitted to "
                 "the unclipped sky)")
      ->check(CLI::IsMember({"measured", "clear_sky"}))
      ->capture_default_str();
  app.add_option("--threads", o.threads, "threads for the blend and ray casting (0 = all)")->capture_default_str();
  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "only warnings and errors");
  if (const auto status = skylit::tools::parse_command_line(app, argc, argv)) return *status;
  spdlog::set_level(quiet ? spdlog::level::warn : spdlog::level::info);
  spdlog::set_pattern("skylit-shade: %^%l%$: %v");
  try {
    return run(o);
  } catch (const skylit::InputError& e) {
    std::fprintf(stderr, "skylit-shade: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-shade: internal error: %s\n", e.what());
    return 3;
  }
}
