// skylit-calib: calibration tools for installers. `fisheye` and `camera`: intrinsics from photos
// of a chessboard or ChArUco board; `sky-orientation`: the sky camera's R_site_from_camera from
// the sun in timestamped sky frames, or from a level and a compass. Each writes its YAML
// atomically (a failed run leaves an existing file as it was), prints its quality figures,
// writes a diagnostic image beside the YAML and says what to do when the data are not good
// enough. See docs/calibration.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/calib/board.hpp"
#include "skylit/calib/intrinsics.hpp"
#include "skylit/calib/orientation.hpp"
#include "skylit/calib/sun_frames.hpp"
#include "skylit/sky/calibration.hpp"
#include "skylit/sky/image_io.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/solar.hpp"

namespace {

namespace fs = std::filesystem;
using skylit::input_message;
using skylit::InputError;
namespace calib = skylit::calib;
namespace sky = skylit::sky;

constexpr double kDeg = std::numbers::pi / 180.0;

[[noreturn]] void bad_option(const std::string& option, const std::string& problem, const std::string& fix) {
  throw InputError(input_message("", -1, -1, option, problem, fix));
}

// OUT.yaml → OUT.<suffix> beside it.
fs::path beside(const fs::path& output, const std::string& suffix) {
  fs::path path = output;
  return path.replace_extension(suffix);
}

void print_advice(const std::vector<std::string>& advice) {
  for (const std::string& line : advice) std::printf("advice: %s\n", line.c_str());
}

// ---------------------------------------------------------------------------------------------
// fisheye, camera

struct IntrinsicsArgs {
  std::string board, charuco, dictionary = "DICT_4X4_50", output, model;
  double square = 0, marker = 0;
  std::vector<std::string> photos;
};

void add_intrinsics_options(CLI::App* command, IntrinsicsArgs& a, bool with_model) {
  command->add_option("--board", a.board, "chessboard: inner corners COLSxROWS (squares − 1), e.g. 9x6");
  command->add_option("--charuco", a.charuco, "ChArUco board: squares COLSxROWS, e.g. 5x7 (instead of --board)");
  command->add_option("--square", a.square, "side of one square, metres (e.g. 0.025)")->required();
  command->add_option("--marker", a.marker, "ChArUco: side of one marker, metres");
  command->add_option("--dict", a.dictionary, "ChArUco: the printed board's ArUco dictionary")->capture_default_str();
  command->add_option("-o,--output", a.output, "calibration to write (YAML); OUT.coverage.png goes beside it")->required();
  if (with_model) {
    a.model = "pinhole";
    command->add_option("--model", a.model, "pinhole (k1, k2, p1, p2, k3) or fisheye (k1..k4)")
        ->check(CLI::IsMember({"pinhole", "fisheye"}))
        ->capture_default_str();
  }
  command->add_option("photos", a.photos, "photos of the board (10–20, covering the whole image)")->required();
}

calib::BoardSpec board_spec(const IntrinsicsArgs& a) {
  if (a.board.empty() == a.charuco.empty()) {
    bad_option("--board", a.board.empty() ? "no board given" : "both --board and --charuco given",
               "give --board COLSxROWS (inner corners of a chessboard) or --charuco COLSxROWS with --marker and --dict");
  }
  calib::BoardSpec spec;
  spec.square_m = a.square;
  if (!a.board.empty()) {
    spec.kind = calib::BoardSpec::Kind::Chessboard;
    spec.grid = calib::parse_grid(a.board, "--board", 3);
  } else {
    spec.kind = calib::BoardSpec::Kind::Charuco;
    spec.grid = calib::parse_grid(a.charuco, "--charuco", 3);
    spec.marker_m = a.marker;
    spec.dictionary = a.dictionary;
  }
  calib::validate(spec);
  return spec;
}

std::string describe_board(const calib::BoardSpec& spec) {
  std::ostringstream text;
  if (spec.kind == calib::BoardSpec::Kind::Chessboard) {
    text << "chessboard of " << spec.grid.width << "x" << spec.grid.height << " inner corners, " << spec.square_m << " m squares";
  } else {
    text << "ChArUco board of " << spec.grid.width << "x" << spec.grid.height << " squares, " << spec.square_m << " m squares, "
         << spec.marker_m << " m markers, " << spec.dictionary;
  }
  return text.str();
}

int run_intrinsics(const std::string& command, const IntrinsicsArgs& a, sky::LensModel model) {
  const calib::BoardSpec spec = board_spec(a);
  const fs::path output(a.output);
  skylit::ensure_writable_directory(output.parent_path().empty() ? fs::path(".") : output.parent_path());
  const calib::BoardDetector detector(spec);
  std::vector<fs::path> photos(a.photos.begin(), a.photos.end());
  calib::BoardPhotos found = calib::detect_boards(photos, detector);
  std::printf("skylit-calib %s: board found in %zu of %zu photo(s) (%s)\n", command.c_str(), found.views.size(), photos.size(),
              describe_board(spec).c_str());
  calib::IntrinsicsOptions options;
  options.model = model;
  const calib::IntrinsicsResult result = calib::calibrate_intrinsics(found.views, found.rejected, found.image_size, options);
  const sky::CameraCalibration& c = result.calibration;

  std::printf("  model %s, image %dx%d\n", model == sky::LensModel::Fisheye ? "fisheye" : "pinhole", c.image_width,
              c.image_height);
  std::printf("  fx %.3f  fy %.3f  cx %.3f  cy %.3f  (pixels)\n", c.fx, c.fy, c.cx, c.cy);
  std::string coefficients;
  for (double d : c.D) {
    if (!coefficients.empty()) coefficients += ", ";
    coefficients += std::to_string(d);
  }
  std::printf("  D [%s]  (%s)\n", coefficients.c_str(),
              model == sky::LensModel::Fisheye ? "k1, k2, k3, k4" : "k1, k2, p1, p2, k3");
  std::printf("  RMS reprojection error %.3f px over %zu view(s)\n", c.rms.value_or(0.0), result.used.size());
  std::vector<std::size_t> order(result.used.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(),
            [&](std::size_t x, std::size_t y) { return c.per_view_errors[x] > c.per_view_errors[y]; });
  std::printf("  per-view errors, worst first:\n");
  for (std::size_t k : order) std::printf("    %-32s %.3f px\n", result.used[k].name.c_str(), c.per_view_errors[k]);
  std::printf("  coverage: the boards cover %.0f%% of the image the lens sees\n", 100.0 * result.coverage);
  for (const calib::RejectedView& r : result.rejected) std::printf("  not used: %s: %s\n", r.name.c_str(), r.reason.c_str());
  print_advice(result.advice);

  const std::string summary = "skylit-calib " + command + " (" + describe_board(spec) + ")";
  skylit::write_file_atomic(output, calib::intrinsics_yaml(result, summary));
  const fs::path coverage = beside(output, ".coverage.png");
  sky::write_image(coverage, calib::draw_coverage(result, found.first_image));
  std::printf("wrote %s and %s\n", output.string().c_str(), coverage.string().c_str());
  return 0;
}

// ---------------------------------------------------------------------------------------------
// sky-orientation

struct OrientationArgs {
  std::string calibration, output, frames, utc_offset, response;
  std::vector<std::string> photos;
  std::optional<double> latitude, longitude, level_compass;
  double declination = 0;
  double max_residual = 2.0;
};

std::string orientation_yaml(const sky::CameraCalibration& c, const std::string& how) {
  return "# R_site_from_camera set by skylit-calib sky-orientation (" + how + ").\n" + sky::calibration_to_yaml(c);
}

void print_rotation(const Eigen::Matrix3d& R) {
  const calib::Pointing pointing = calib::describe_pointing(R);
  std::printf("  R_site_from_camera [%.6f %.6f %.6f; %.6f %.6f %.6f; %.6f %.6f %.6f]\n", R(0, 0), R(0, 1), R(0, 2), R(1, 0),
              R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2));
  std::printf("  the optical axis is %.2f° from the zenith; the image's x axis points at bearing %.1f° (true north)\n",
              pointing.tilt_from_zenith_deg, pointing.image_x_bearing_deg);
}

std::vector<calib::TimedFrame> collect_frames(const OrientationArgs& a) {
  std::vector<calib::TimedFrame> frames;
  if (!a.frames.empty()) frames = calib::read_frame_list(a.frames);
  for (const std::string& photo : a.photos) frames.push_back({photo, calib::photo_time(photo, a.utc_offset)});
  return frames;
}

void print_frames(const std::vector<calib::FrameSun>& suns, const calib::OrientationFit* fit) {
  std::size_t observation = 0;
  std::printf("  %-28s %-20s %8s %8s  %s\n", "frame", "time (UTC)", "sun az", "sun el", "result");
  for (const calib::FrameSun& f : suns) {
    std::string result = f.reason;
    if (f.observation && fit && observation < fit->residual_deg.size()) {
      char text[96];
      std::snprintf(text, sizeof text, "residual %.2f°%s", fit->residual_deg[observation],
                    fit->inlier[observation] ? "" : " (outlier, left out)");
      result = text;
    }
    if (f.observation) ++observation;
    std::printf("  %-28s %-20s %7.2f° %7.2f°  %s\n", f.frame.file.filename().string().c_str(),
                sky::format_utc(f.frame.utc).c_str(), f.solar.azimuth_rad / kDeg, f.solar.elevation_rad / kDeg, result.c_str());
  }
}

int run_orientation(const OrientationArgs& a) {
  sky::CameraCalibration calibration = sky::load_calibration(a.calibration);
  const fs::path output = a.output.empty() ? fs::path(a.calibration) : fs::path(a.output);
  calib::OrientationOptions options;
  options.outlier_threshold_deg = a.max_residual;
  if (!(std::isfinite(a.max_residual) && a.max_residual > 0)) {
    bad_option("--max-residual", "must be a positive angle", "give degrees, e.g. --max-residual 2");
  }
  calib::SunSearchOptions search;
  if (!a.response.empty()) search.response = sky::load_response(a.response);
  const bool have_frames = !a.frames.empty() || !a.photos.empty();
  if (have_frames && (!a.latitude || !a.longitude)) {
    bad_option(a.latitude ? "--lon" : "--lat", "the site's position is needed for the sun's",
               "give --lat (degrees north) and --lon (degrees east, negative west) of the site");
  }

  std::string how;
  std::optional<calib::OrientationFit> fit;
  std::vector<calib::FrameSun> suns;
  if (have_frames) {
    const std::vector<calib::TimedFrame> frames = collect_frames(a);
    suns = calib::find_sun(calibration, frames, *a.latitude, *a.longitude, search);
  }
  const std::vector<calib::SunObservation> observations = calib::observations_of(suns);

  if (a.level_compass) {
    const double bearing = *a.level_compass + a.declination;
    calibration.R_site_from_camera = calib::level_compass_rotation(bearing);
    char text[128];
    std::snprintf(text, sizeof text, "level, image x axis at bearing %.2f° true (compass %.2f°, declination %.2f°)", bearing,
                  *a.level_compass, a.declination);
    how = text;
    std::printf("skylit-calib sky-orientation: %s\n", how.c_str());
    if (!suns.empty()) {
      // A check of the level and compass against the sun, when frames are given.
      calib::OrientationFit check;
      check.R_site_from_camera = calibration.R_site_from_camera;
      for (const calib::SunObservation& o : observations) {
        check.residual_deg.push_back(calib::angle_deg(o.site_direction, calibration.R_site_from_camera * o.camera_direction));
        check.inlier.push_back(true);
      }
      print_frames(suns, &check);
    }
  } else {
    if (!have_frames) {
      bad_option("--frames", "no sky frames and no --level-compass",
                 "give timestamped sky frames (--frames frames.csv, or photos with EXIF times) with --lat and --lon, or "
                 "--level-compass BEARING for a level camera looking at the zenith");
    }
    if (observations.size() < 2) {
      std::string reasons;
      std::size_t listed = 0;
      for (const calib::FrameSun& f : suns) {
        if (f.observation || listed >= 5) continue;
        if (listed++ > 0) reasons += "; ";
        reasons.append(f.frame.file.filename().string()).append(": ").append(f.reason);
      }
      throw InputError("sky-orientation: no sun seen in " + std::to_string(suns.size() - observations.size()) + " of " +
                       std::to_string(suns.size()) + " frame(s) (" + reasons +
                       "). Fix: take frames under a clear sky with the sun in view at 2 or more times, 2–3 hours "
                       "apart (a short exposure keeps the sun compact), or use --level-compass BEARING");
    }
    fit = calib::fit_orientation(observations, options);
    calibration.R_site_from_camera = fit->R_site_from_camera;
    char text[160];
    std::snprintf(text, sizeof text, "sun in %d of %zu frames, residual RMS %.3f°, sun path %.1f°, at lat %.5f lon %.5f",
                  fit->inliers, suns.size(), fit->rms_deg, fit->spread_deg, *a.latitude, *a.longitude);
    how = text;
    std::printf("skylit-calib sky-orientation: %s\n", how.c_str());
    print_frames(suns, &*fit);
  }
  print_rotation(calibration.R_site_from_camera);
  if (fit) print_advice(fit->advice);

  calibration.file = output;
  skylit::write_file_atomic(output, orientation_yaml(calibration, how));
  std::string wrote = output.string();
  if (!suns.empty()) {
    // The background: the first frame where the sun was found (the first frame otherwise).
    const calib::FrameSun* shown = &suns.front();
    for (const calib::FrameSun& f : suns) {
      if (f.pixel) {
        shown = &f;
        break;
      }
    }
    const cv::Mat background = sky::tone_map(calib::read_radiance(shown->frame.file, search).radiance);
    const fs::path diagnostic = beside(output, ".orientation.png");
    sky::write_image(diagnostic, calib::draw_orientation(calibration, background, suns, fit ? fit->inlier : std::vector<bool>{}));
    wrote += " and " + diagnostic.string();
  }
  std::printf("wrote %s\n", wrote.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"skylit-calib: calibration tools for installers (see docs/calibration.md)", "skylit-calib"};
  app.set_version_flag("--version", "skylit-calib 0.1.0");
  app.require_subcommand(1);

  IntrinsicsArgs fisheye_args, camera_args;
  CLI::App* fisheye = app.add_subcommand("fisheye", "sky-camera intrinsics (fisheye model, k1..k4) from board photos");
  add_intrinsics_options(fisheye, fisheye_args, false);
  CLI::App* camera = app.add_subcommand("camera", "HMD camera intrinsics (pinhole, or --model fisheye) from board photos");
  add_intrinsics_options(camera, camera_args, true);

  OrientationArgs o;
  CLI::App* orientation = app.add_subcommand(
      "sky-orientation", "the sky camera's R_site_from_camera from the sun in timestamped frames, or a level and compass");
  orientation->add_option("--calib", o.calibration, "the sky camera's intrinsics (YAML from skylit-calib fisheye)")->required();
  orientation->add_option("-o,--output", o.output,
                          "calibration to write (default: --calib itself); OUT.orientation.png beside it");
  orientation->add_option("--frames", o.frames,
                          "CSV of sky frames: columns file,timestamp (ISO 8601 with zone), e.g. skylit-sky's frames.csv");
  orientation->add_option("photos", o.photos,
                          "sky photos timed by their EXIF DateTimeOriginal (with --utc-offset when they lack a zone)");
  orientation->add_option("--utc-offset", o.utc_offset, "zone of the photos' EXIF clock, e.g. +09:00 (Z for UTC)");
  orientation->add_option("--lat", o.latitude, "site latitude, degrees north");
  orientation->add_option("--lon", o.longitude, "site longitude, degrees east (negative west)");
  orientation->add_option("--response", o.response, "response curve of 8/16-bit frames (skylit-sky response); sRGB by default");
  orientation->add_option("--max-residual", o.max_residual, "frames further than this from the fit are outliers, degrees")
      ->capture_default_str();
  orientation->add_option(
      "--level-compass", o.level_compass,
      "no sun: the camera is level, looks at the zenith, and its image x axis points at this compass bearing, degrees");
  orientation->add_option("--declination", o.declination, "magnetic declination to add to --level-compass, degrees east")
      ->capture_default_str();

  CLI11_PARSE(app, argc, argv);
  try {
    if (*fisheye) return run_intrinsics("fisheye", fisheye_args, sky::LensModel::Fisheye);
    if (*camera) {
      return run_intrinsics("camera", camera_args,
                            camera_args.model == "fisheye" ? sky::LensModel::Fisheye : sky::LensModel::Pinhole);
    }
    if (*orientation) return run_orientation(o);
  } catch (const InputError& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "skylit-calib: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "skylit-calib: internal error: %s\n", e.what());
    return 3;
  }
  return 0;
}
