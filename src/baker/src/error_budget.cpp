#include "skylit/baker/error_budget.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/core/mat.hpp>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/base/error.hpp"
#include "skylit/baker/preview.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/geom/spherical.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/luminance.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_model.hpp"
#include "skylit/sky/sky_table.hpp"
#include "skylit/sky/solar.hpp"

namespace skylit::baker {
namespace fs = std::filesystem;

namespace {

// fprintf to the log, which -q leaves null.
[[gnu::format(printf, 2, 3)]] void say(std::FILE* log, const char* format, ...) {
  if (!log) return;
  std::va_list args;
  va_start(args, format);
  std::vfprintf(log, format, args);
  va_end(args);
}

// The sky camera the luminance parameters are measured with, as the live path measures them: an
// ideal equidistant fisheye looking at the zenith whose image edge lies 92° off its axis (the
// horizon inside, with a margin), 64ν_ref pixels wide (at least 512): about 250 pixels per face
// of the reference dome, each the mean of 2 × 2 sub-pixel directions.
constexpr double kCameraEdgeDegrees = 92.0;
constexpr int kCameraPixelsPerFrequency = 64;
constexpr int kCameraMinSize = 512;
constexpr int kCameraSupersample = 2;

struct TestSky {
  std::string name;
  sky::SkyFunction function;   // the disc, when up, is `function.sun`, not in `function.sky`
};

// Clear skies through a day on the equinox and both solstices, plus an overcast sky. Times are
// UTC at longitude 0, i.e. mean solar time: the equation of time (±16 min) does not matter here.
std::vector<TestSky> test_skies(const ErrorBudgetOptions& options) {
  std::vector<TestSky> skies;
  sky::AnalyticSkySettings clear;
  clear.kind = sky::AnalyticSkySettings::Kind::Clear;
  clear.turbidity = options.turbidity;
  clear.latitude_deg = options.latitude_deg;
  clear.longitude_deg = 0.0;
  for (const char* date : {"2026-03-20", "2026-06-21", "2026-12-21"}) {
    for (const int hour : {8, 10, 12, 14, 16}) {
      const std::string when = fmt::format("{}T{:02d}:00:00Z", date, hour);
      const std::chrono::sys_seconds utc = sky::parse_utc(when);
      const sky::SolarPosition sun = sky::solar_position(utc, options.latitude_deg, 0.0);
      if (sun.elevation_rad <= 0.0) continue;  // a night or twilight sky tests nothing
      skies.push_back({fmt::format("clear {} {:02d}:00 solar", date, hour), sky::analytic_sky(clear, utc)});
    }
  }
  sky::AnalyticSkySettings overcast;
  overcast.kind = sky::AnalyticSkySettings::Kind::Overcast;
  skies.push_back({"CIE overcast", sky::analytic_sky(overcast, std::chrono::sys_seconds{})});
  return skies;
}

camera::Lens sky_camera(int reference_frequency) {
  const int size = std::max(kCameraMinSize, kCameraPixelsPerFrequency * reference_frequency);
  camera::CameraCalibration c;
  c.image_width = size;
  c.image_height = size;
  c.model = camera::LensModel::Fisheye;
  c.cx = (size - 1) / 2.0;
  c.cy = c.cx;
  c.fx = (size / 2.0) / (kCameraEdgeDegrees * std::numbers::pi / 180.0);
  c.fy = c.fx;
  c.D = {0.0, 0.0, 0.0, 0.0};  // equidistant
  return camera::Lens(c);
}

// The camera's linear frame of each test sky without its disc (the disc is the sun term, not
// part of the dome).
std::vector<cv::Mat> sky_frames(const camera::Lens& lens, const std::vector<TestSky>& skies) {
  sky::RenderOptions render;
  render.supersample = kCameraSupersample;
  std::vector<cv::Mat> frames;
  for (const TestSky& s : skies) {
    const sky::SkyFunction without_disc{s.function.sky, std::nullopt};
    frames.push_back(sky::render_fisheye(lens, without_disc, render));
  }
  return frames;
}

// S per layer of a bake of `basis` on `dome` (S_i for faces, S_{i,k} for corners, …), per sky:
// the frames through a sky table of that basis, as the live service computes them.
std::vector<std::vector<Eigen::Vector3d>> layer_radiances(const geom::Dome& dome, geom::DomeBasis basis,
                                                          const camera::Lens& lens, const std::vector<cv::Mat>& frames) {
  sky::SkyTableOptions table_options;
  table_options.step = 1;
  table_options.basis = basis;
  const sky::SkyTable table = sky::build_sky_table(lens, dome, cv::Mat(), table_options);
  std::vector<std::vector<Eigen::Vector3d>> S;
  for (const cv::Mat& frame : frames) {
    const sky::Luminance luminance = sky::compute_luminance(table, dome, frame, cv::Mat(), cv::Mat());
    S.push_back(sky::layer_radiances(luminance));
    const std::size_t expected =
        static_cast<std::size_t>(dome.face_count()) * static_cast<std::size_t>(geom::layers_per_face(basis));
    if (S.back().size() != expected) {
      throw std::logic_error(fmt::format("error budget: {} luminance values for a {} basis of {} layers",
                                         S.back().size(), geom::basis_name(basis), expected));
    }
  }
  return S;
}

// The solar disc as seven equal directions (centre and a ring), for its penumbra.
void disc_directions(const sky::SunDisc& sun, std::vector<geom::Vec3>& directions, std::vector<double>& weights) {
  const geom::Vec3 axis = sun.direction.normalized();
  const geom::Vec3 helper = std::abs(axis.z()) < 0.9 ? geom::Vec3::UnitZ() : geom::Vec3::UnitX();
  const geom::Vec3 e1 = axis.cross(helper).normalized();
  const geom::Vec3 e2 = axis.cross(e1);
  directions.assign(1, axis);
  const double ring = 0.7 * sun.angular_radius;
  for (int k = 0; k < 6; ++k) {
    const double phi = k * std::numbers::pi / 3.0;
    directions.push_back((axis + std::tan(ring) * (std::cos(phi) * e1 + std::sin(phi) * e2)).normalized());
  }
  weights.assign(directions.size(), 1.0 / static_cast<double>(directions.size()));
}

// What every bake is blended with: per sky, the sun term and its visibility on every plane.
struct SkyInputs {
  std::optional<blend::SunLight> sun;
  std::vector<std::vector<float>> sun_visibility;   // per plane; empty without a sun
};

std::vector<SkyInputs> sky_inputs(const std::vector<TestSky>& skies, const scene::Mesh& mesh,
                                  const std::vector<geom::Plane>& planes, int threads) {
  RaytraceOptions raytrace;
  raytrace.threads = threads;
  std::vector<SkyInputs> inputs;
  for (const TestSky& s : skies) {
    SkyInputs in;
    if (s.function.sun && s.function.sun->irradiance.maxCoeff() > 0.0) {
      blend::SunLight light;
      light.direction = s.function.sun->direction.normalized();
      light.energy = s.function.sun->irradiance;
      in.sun = light;
      std::vector<geom::Vec3> directions;
      std::vector<double> weights;
      disc_directions(*s.function.sun, directions, weights);
      for (const geom::Plane& p : planes) {
        std::vector<float> v(static_cast<std::size_t>(p.width) * static_cast<std::size_t>(p.height));
        area_light_visibility(mesh, p, directions, weights, v, raytrace);
        in.sun_visibility.push_back(std::move(v));
      }
    }
    inputs.push_back(std::move(in));
  }
  return inputs;
}

// T of every plane under every test sky: [sky][plane] → width × height × 3 floats.
using ShadowRatios = std::vector<std::vector<std::vector<float>>>;

// The bake's own basis (its manifest) picks the sky table.
ShadowRatios shadow_ratios(const fs::path& bake_dir, const bake_format::Manifest& manifest, const camera::Lens& lens,
                           const std::vector<cv::Mat>& frames, const std::vector<SkyInputs>& inputs, int threads) {
  const geom::Dome dome(manifest.plan.frequency);
  const std::vector<std::vector<Eigen::Vector3d>> S = layer_radiances(dome, manifest.plan.basis, lens, frames);
  blend::BlendOptions blend;
  blend.threads = threads;
  ShadowRatios T(frames.size());
  for (int j = 0; j < static_cast<int>(manifest.planes.size()); ++j) {
    const blend::BasisImages basis = blend::load_basis(bake_dir, manifest, j);
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const blend::BlendWeights weights = blend::blend_weights(basis, S[k], inputs[k].sun, blend);
      std::vector<float> out(basis.texel_count() * 3);
      const std::span<const float> visibility =
          inputs[k].sun ? std::span<const float>(inputs[k].sun_visibility[static_cast<std::size_t>(j)])
                        : std::span<const float>();
      blend::blend_cpu(basis, weights, visibility, out, blend);
      T[k].push_back(std::move(out));
    }
  }
  return T;
}

void compare(const ShadowRatios& T, const ShadowRatios& reference, CandidateResult& result) {
  double sum_squares = 0;
  double largest = 0;
  std::size_t count = 0;
  for (std::size_t k = 0; k < T.size(); ++k) {
    for (std::size_t j = 0; j < T[k].size(); ++j) {
      const std::vector<float>& a = T[k][j];
      const std::vector<float>& b = reference[k][j];
      for (std::size_t t = 0; t < a.size(); ++t) {
        const double d = std::abs(static_cast<double>(a[t]) - static_cast<double>(b[t]));
        sum_squares += d * d;
        largest = std::max(largest, d);
      }
      count += a.size();
    }
  }
  result.rms = count ? std::sqrt(sum_squares / static_cast<double>(count)) : 0.0;
  result.max_abs = largest;
}

std::string describe(const CandidateResult& c) { return fmt::format("ν={}, samples={}", c.frequency, c.samples); }

std::string describe_all(const std::vector<CandidateResult>& candidates) {
  std::string text;
  for (const CandidateResult& c : candidates) text += (text.empty() ? "" : "; ") + describe(c);
  return text;
}

void print_table(std::FILE* log, const ErrorBudgetReport& report) {
  say(log, "skylit-bake: error budget E = %g on the RMS of |T − T_ref|, %s basis (reference ν=%d, %d "
           "samples, %s basis, raytrace, %.1f s; %zu test skies)\n",
      report.budget, std::string(geom::basis_name(report.basis)).c_str(), report.reference_frequency,
      report.reference_samples, std::string(geom::basis_name(report.reference_basis)).c_str(),
      report.reference_seconds, report.skies.size());
  if (!report.skipped.empty()) {
    say(log, "  skipped (the %s basis needs at least %d samples per face): %s\n",
        std::string(geom::basis_name(report.basis)).c_str(), min_samples_per_face(report.basis),
        describe_all(report.skipped).c_str());
  }
  say(log, "     ν  samples  layers        RMS        max     bake\n");
  for (const CandidateResult& c : report.tried) {
    say(log, "  %4d  %7d  %6d  %9.5f  %9.5f  %6.1f s%s\n", c.frequency, c.samples, c.layers, c.rms, c.max_abs,
        c.bake_seconds, c.within_budget ? "  ≤ E" : "");
  }
}

void check_options(const BakeOptions& bake, const ErrorBudgetOptions& o) {
  if (!std::isfinite(o.budget) || o.budget <= 0.0) {
    throw InputError(fmt::format("option --error-budget: got {}. Fix: give the largest RMS error of the shadow "
                                 "ratios you accept, a number above 0 such as 0.01",
                                 o.budget));
  }
  if (!std::isfinite(o.latitude_deg) || o.latitude_deg < -90.0 || o.latitude_deg > 90.0) {
    throw InputError(fmt::format("option --latitude: got {}. Fix: give the site's latitude in degrees, "
                                 "-90 (south) to 90 (north)",
                                 o.latitude_deg));
  }
  if (bake.frequency) {
    throw InputError("options --error-budget and --frequency: the budget picks the frequency. Fix: drop one");
  }
  if (bake.shard || bake.resume) {
    throw InputError("option --error-budget bakes several domes in one run and cannot be sharded or resumed. "
                     "Fix: drop --shard/--resume (and unset the array-job variables), or bake with --frequency");
  }
  if (o.frequencies.empty() || o.samples.empty()) {
    throw InputError("option --error-budget: no candidate frequencies or samples. Fix: give at least one of each");
  }
  if (!bake.force && fs::exists(bake.out_dir) && !fs::is_empty(bake.out_dir)) {
    throw InputError("output directory '" + bake.out_dir.string() +
                     "' is not empty. Fix: pass --force to replace it, or choose another directory with -o");
  }
}

// The scratch folder, removed however the run ends.
class ScratchFolder {
 public:
  explicit ScratchFolder(fs::path dir) : dir_(std::move(dir)) { fs::create_directories(dir_); }
  ~ScratchFolder() {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  ScratchFolder(const ScratchFolder&) = delete;
  ScratchFolder& operator=(const ScratchFolder&) = delete;
  const fs::path& dir() const { return dir_; }

 private:
  fs::path dir_;
};

fs::path default_scratch(const fs::path& out_dir) {
  const fs::path absolute = fs::absolute(out_dir).lexically_normal();
  const fs::path name = absolute.has_filename() ? absolute.filename() : absolute.parent_path().filename();
  const fs::path parent = absolute.has_filename() ? absolute.parent_path() : absolute.parent_path().parent_path();
  return parent / fmt::format(".{}.budget-{}", name.string(), ::getpid());
}

BakeSummary bake_into(const BakeOptions& base, geom::DomeBasis basis, const fs::path& dir, int frequency,
                      int samples, const std::string& method, std::FILE* log) {
  BakeOptions o = base;
  o.out_dir = dir;
  o.frequency = frequency;
  o.samples = samples;
  o.method = method;
  o.basis = basis;
  o.force = true;
  o.previews = false;
  o.pca.reset();
  o.light_map_pca.reset();
  return run_bake(o, log);
}

}  // namespace

std::vector<CandidateResult> budget_candidates(const ErrorBudgetOptions& options, geom::DomeBasis basis) {
  std::vector<CandidateResult> candidates;
  for (const int f : options.frequencies) {
    for (const int s : options.samples) {
      CandidateResult c;
      c.frequency = f;
      c.samples = s;
      c.faces = 10 * f * f;  // faces of the upper hemisphere (geom/dome.hpp)
      c.layers = c.faces * geom::layers_per_face(basis);
      candidates.push_back(c);
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const CandidateResult& a, const CandidateResult& b) {
    if (a.cost() != b.cost()) return a.cost() < b.cost();
    return a.layers < b.layers;
  });
  return candidates;
}

ErrorBudgetReport run_error_budget_bake(const BakeOptions& bake, const ErrorBudgetOptions& options, std::FILE* log) {
  check_options(bake, options);
  ErrorBudgetReport report;
  report.budget = options.budget;
  const int largest = *std::max_element(options.frequencies.begin(), options.frequencies.end());
  report.reference_frequency = options.reference_frequency ? options.reference_frequency : largest + 2;
  report.reference_samples = options.reference_samples;
  if (report.reference_frequency <= largest) {
    throw InputError(fmt::format("error budget: the reference frequency {} is not above the largest candidate {}. "
                                 "Fix: use a denser reference",
                                 report.reference_frequency, largest));
  }

  // The basis as the bake resolves it: --basis, else the site's dome.basis.
  const scene::Site site = scene::load_site(bake.site_file);
  report.basis = bake.basis.value_or(site.dome_basis);
  const std::string basis_name(geom::basis_name(report.basis));
  const int min_samples = min_samples_per_face(report.basis);
  if (report.reference_samples < min_samples) {
    throw InputError(fmt::format("error budget: the reference has {} sample(s) per face; the {} basis needs at least "
                                 "{}. Fix: use a reference with more samples",
                                 report.reference_samples, basis_name, min_samples));
  }
  std::vector<CandidateResult> candidates;
  for (const CandidateResult& c : budget_candidates(options, report.basis)) {
    (c.samples < min_samples ? report.skipped : candidates).push_back(c);
  }
  if (candidates.empty()) {
    throw InputError(fmt::format("option --error-budget: every candidate has fewer than {} samples per face, which "
                                 "the {} basis needs. Fix: give candidates with more samples, or use --basis faces",
                                 min_samples, basis_name));
  }
  if (!report.skipped.empty()) {
    say(log, "skylit-bake: error budget: the %s basis needs at least %d samples per face: skipping %s\n",
        basis_name.c_str(), min_samples, describe_all(report.skipped).c_str());
  }
  // Every candidate on one engine, chosen once.
  const std::string method = resolve_method(bake);

  const std::vector<TestSky> skies = test_skies(options);
  for (const TestSky& s : skies) report.skies.push_back(s.name);
  const ScratchFolder scratch(options.scratch_dir.empty() ? default_scratch(bake.out_dir) : options.scratch_dir);

  say(log, "skylit-bake: error budget: %zu test skies at latitude %g°; baking the reference (ν=%d, %d "
           "samples, %s basis, raytrace)\n",
      skies.size(), options.latitude_deg, report.reference_frequency, report.reference_samples, basis_name.c_str());
  const fs::path reference_dir = scratch.dir() / "reference";
  report.reference_seconds = bake_into(bake, report.basis, reference_dir, report.reference_frequency,
                                       report.reference_samples, "raytrace", log)
                                 .seconds;

  const bake_format::Manifest reference_manifest = bake_format::read_manifest(reference_dir);
  report.reference_basis = reference_manifest.plan.basis;
  const scene::Mesh mesh = scene::load_site_model(site);
  std::vector<geom::Plane> planes;
  for (const bake_format::PlaneRecord& r : reference_manifest.planes) planes.push_back(r.plane);
  say(log, "skylit-bake: error budget: sun visibility for %zu skies on %zu plane(s), sky frames\n", skies.size(),
      planes.size());
  const std::vector<SkyInputs> inputs = sky_inputs(skies, mesh, planes, bake.threads);
  const camera::Lens camera = sky_camera(report.reference_frequency);
  const std::vector<cv::Mat> frames = sky_frames(camera, skies);
  const ShadowRatios reference =
      shadow_ratios(reference_dir, reference_manifest, camera, frames, inputs, bake.threads);
  fs::remove_all(reference_dir);

  fs::path picked_dir;
  for (CandidateResult candidate : candidates) {
    say(log, "skylit-bake: error budget: trying %s (%d layers, %s basis)\n", describe(candidate).c_str(),
        candidate.layers, basis_name.c_str());
    const fs::path dir = scratch.dir() / fmt::format("nu{}_s{}", candidate.frequency, candidate.samples);
    candidate.bake_seconds =
        bake_into(bake, report.basis, dir, candidate.frequency, candidate.samples, method, log).seconds;
    const bake_format::Manifest manifest = bake_format::read_manifest(dir);
    compare(shadow_ratios(dir, manifest, camera, frames, inputs, bake.threads), reference, candidate);
    candidate.within_budget = candidate.rms <= options.budget;
    say(log, "skylit-bake: error budget: %s: RMS %.5f, max %.5f\n", describe(candidate).c_str(), candidate.rms,
        candidate.max_abs);
    report.tried.push_back(candidate);
    if (candidate.within_budget) {
      report.picked = report.tried.size() - 1;
      picked_dir = dir;
      break;
    }
    fs::remove_all(dir);
  }
  print_table(log, report);

  if (!report.picked) {
    const auto best = std::min_element(report.tried.begin(), report.tried.end(),
                                       [](const CandidateResult& a, const CandidateResult& b) { return a.rms < b.rms; });
    throw InputError(fmt::format("option --error-budget: no candidate meets E = {} ({} basis): the best, {}, has RMS "
                                 "{:.5f} (max {:.5f}). Fix: allow a larger budget, or bake with --frequency and "
                                 "--samples",
                                 options.budget, basis_name, describe(*best), best->rms, best->max_abs));
  }
  const CandidateResult& picked = report.tried[*report.picked];
  report.verdict = fmt::format("picked {} ({} basis): RMS {:.5f} ≤ E ({})", describe(picked), basis_name, picked.rms,
                               options.budget);
  if (*report.picked > 0) {
    const CandidateResult& previous = report.tried[*report.picked - 1];
    report.verdict += fmt::format("; {} would not do (RMS {:.5f})", describe(previous), previous.rms);
  } else {
    report.verdict += "; it is the cheapest candidate";
  }
  if (!report.skipped.empty()) {
    report.verdict += fmt::format("; skipped for too few samples: {}", describe_all(report.skipped));
  }
  say(log, "skylit-bake: %s\n", report.verdict.c_str());

  // The picked bake becomes the output: same filesystem (the scratch folder sits beside it), so
  // a rename; previews and the PCA form, left out of the candidates, are added now.
  if (fs::exists(bake.out_dir)) fs::remove_all(bake.out_dir);
  if (bake.out_dir.has_parent_path()) fs::create_directories(bake.out_dir.parent_path());
  try {
    fs::rename(picked_dir, bake.out_dir);
  } catch (const fs::filesystem_error&) {
    fs::copy(picked_dir, bake.out_dir, fs::copy_options::recursive);  // a scratch folder elsewhere
  }
  const bake_format::Manifest manifest = bake_format::read_manifest(bake.out_dir);
  if (bake.previews) {
    fs::create_directories(bake.out_dir / "preview");
    for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
      write_plane_previews(bake.out_dir / "preview", manifest, static_cast<int>(j),
                           bake_format::read_exr_stack(bake.out_dir / manifest.planes[j].file));
    }
  }
  if (bake.pca || bake.light_map_pca) compress_bake(bake.out_dir, bake.pca, bake.light_map_pca, log);
  report.final_bake.complete = true;
  report.final_bake.faces_total = picked.faces;
  report.final_bake.faces_baked = picked.faces;
  report.final_bake.seconds = picked.bake_seconds;
  say(log, "skylit-bake: %s: the picked bake (ν=%d, %d sample(s)/face, %s basis, %s)\n", bake.out_dir.string().c_str(),
      picked.frequency, picked.samples, basis_name.c_str(), method.c_str());
  return report;
}

}  // namespace skylit::baker
