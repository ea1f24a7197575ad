// skylit-calib: calibration tools for installers (docs/calibration.md): `fisheye`, `camera` and
// `stereo` (lenses, and a stereo pair's relative pose, from board photos), `sky-orientation`
// (R_site_from_camera from the sun, or a level and a compass), `markers` (a marker map of AprilTags),
// `hid list` (HID devices, IMU profiles). YAML is written atomically (a failed run leaves an existing
// file as it was) with quality figures, advice and, but for `hid list`, a picture to check by eye.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "skylit/base/data_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/calib/board.hpp"
#include "skylit/calib/intrinsics.hpp"
#include "skylit/calib/marker_survey.hpp"
#include "skylit/calib/orientation.hpp"
#include "skylit/calib/stereo.hpp"
#include "skylit/calib/sun_frames.hpp"
#include "skylit/camera/calibration.hpp"
#include "skylit/camera/stereo_calibration.hpp"
#include "skylit/sky/image_io.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/track/hid_imu.hpp"
#include "skylit/track/marker_map.hpp"
#include "command_line.hpp"

namespace {

namespace fs = std::filesystem;
using skylit::input_message;
using skylit::InputError;
namespace calib = skylit::calib;
namespace camera = skylit::camera;
namespace sky = skylit::sky;
namespace track = skylit::track;

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
  command->add_option("photos", a.photos, "photos of the board (10–20, covering the whole image)")
      ->required()
      ->check(CLI::ExistingFile);
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

int run_intrinsics(const std::string& command, const IntrinsicsArgs& a, camera::LensModel model) {
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
  const camera::CameraCalibration& c = result.calibration;

  std::printf("  model %s, image %dx%d\n", model == camera::LensModel::Fisheye ? "fisheye" : "pinhole", c.image_width,
              c.image_height);
  std::printf("  fx %.3f  fy %.3f  cx %.3f  cy %.3f  (pixels)\n", c.fx, c.fy, c.cx, c.cy);
  std::string coefficients;
  for (double d : c.D) {
    if (!coefficients.empty()) coefficients += ", ";
    coefficients += std::to_string(d);
  }
  std::printf("  D [%s]  (%s)\n", coefficients.c_str(),
              model == camera::LensModel::Fisheye ? "k1, k2, k3, k4" : "k1, k2, p1, p2, k3");
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
// stereo

struct StereoArgs {
  IntrinsicsArgs board;  // the board options and -o; its photos and model unused
  std::vector<std::string> left, right;
  std::string model = "pinhole", left_model, right_model, image_out;
};

camera::LensModel lens_model(const std::string& name) {
  return name == "fisheye" ? camera::LensModel::Fisheye : camera::LensModel::Pinhole;
}

std::string model_name(camera::LensModel model) { return model == camera::LensModel::Fisheye ? "fisheye" : "pinhole"; }

void print_stereo_camera(const char* side, const calib::IntrinsicsResult& r) {
  const camera::CameraCalibration& c = r.calibration;
  std::printf("  %-6s %s %dx%d, fx %.3f fy %.3f cx %.3f cy %.3f, RMS %.3f px over %zu view(s)\n", side,
              model_name(c.model).c_str(), c.image_width, c.image_height, c.fx, c.fy, c.cx, c.cy, c.rms.value_or(0.0),
              r.used.size());
}

int run_stereo(const StereoArgs& a) {
  const calib::BoardSpec spec = board_spec(a.board);
  const fs::path output(a.board.output);
  skylit::ensure_writable_directory(output.parent_path().empty() ? fs::path(".") : output.parent_path());
  const calib::BoardDetector detector(spec);
  const std::vector<fs::path> left(a.left.begin(), a.left.end()), right(a.right.begin(), a.right.end());
  const calib::StereoPhotos photos = calib::detect_stereo_boards(left, right, detector);
  std::size_t both = 0, one = 0;
  for (const calib::PhotoPair& p : photos.pairs) {
    both += p.left && p.right ? 1 : 0;
    one += static_cast<bool>(p.left) != static_cast<bool>(p.right) ? 1 : 0;
  }
  std::printf("skylit-calib stereo: %zu pair(s); the board found in both photos of %zu, in one only of %zu (%s)\n",
              photos.pairs.size(), both, one, describe_board(spec).c_str());
  calib::StereoOptions options;
  options.left.model = lens_model(a.left_model.empty() ? a.model : a.left_model);
  options.right.model = lens_model(a.right_model.empty() ? a.model : a.right_model);
  const calib::StereoResult result = calib::calibrate_stereo(photos, options);
  const camera::StereoCalibration& s = result.calibration;

  print_stereo_camera("left:", result.left);
  print_stereo_camera("right:", result.right);
  const Eigen::Matrix3d& R = s.R_right_from_left;
  std::printf("  R_right_from_left [%.6f %.6f %.6f; %.6f %.6f %.6f; %.6f %.6f %.6f]  (turned %.3f° from the left camera)\n",
              R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2),
              Eigen::AngleAxisd(R).angle() / kDeg);
  const Eigen::Vector3d& t = s.t_right_from_left;
  std::printf("  t_right_from_left [%.5f %.5f %.5f] m: baseline %.2f mm\n", t.x(), t.y(), t.z(), 1000 * s.baseline_m());
  std::printf("  RMS reprojection error %.3f px over both cameras, %zu pair(s)\n", s.rms.value_or(0.0), result.used.size());
  std::printf("  rectified: the corners' rows differ by %.3f px on average, 95%% of them by under %.3f px\n",
              result.rectified_row_error_px, result.rectified_row_error_p95_px);
  std::vector<std::size_t> order(result.used.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return result.used[x].rms_px > result.used[y].rms_px; });
  std::printf("  per-pair errors, worst first:\n");
  for (std::size_t k : order) std::printf("    %-40s %.3f px\n", result.used[k].name.c_str(), result.used[k].rms_px);
  for (const calib::RejectedPair& r : result.rejected) std::printf("  not used: %s: %s\n", r.name.c_str(), r.reason.c_str());
  print_advice(result.advice);

  const std::string summary = "skylit-calib stereo (" + describe_board(spec) + ")";
  skylit::write_file_atomic(output, calib::stereo_yaml(result, photos, summary));
  const fs::path picture = a.image_out.empty() ? beside(output, ".rectified.jpg") : fs::path(a.image_out);
  const calib::PhotoPair& shown = photos.pairs[result.used.front().index];
  sky::write_image(picture, calib::draw_rectification(result, shown, sky::read_image(shown.left_file, cv::IMREAD_COLOR),
                                                      sky::read_image(shown.right_file, cv::IMREAD_COLOR)));
  std::printf("wrote %s and %s\n", output.string().c_str(), picture.string().c_str());
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
  double max_tilt = 10.0;  // degrees from the zenith a levelled sky camera's axis may lean
  bool in_place = false;
};

std::string orientation_yaml(const camera::CameraCalibration& c, const std::string& how) {
  return "# R_site_from_camera set by skylit-calib sky-orientation (" + how + ").\n" + camera::calibration_to_yaml(c);
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
  camera::CameraCalibration calibration = camera::load_calibration(a.calibration);
  // A calibration is never replaced without being told to.
  if (a.output.empty() && !a.in_place) {
    bad_option("-o", "no output given", "give -o OUT.yaml for the oriented calibration, or --in-place to update " + a.calibration);
  }
  if (!a.output.empty() && a.in_place) bad_option("--in-place", "given with -o", "keep one of them");
  if (!(std::isfinite(a.max_tilt) && a.max_tilt > 0 && a.max_tilt <= 180)) {
    bad_option("--max-tilt", "must be an angle in (0, 180]", "give degrees, e.g. --max-tilt 30");
  }
  const fs::path output = a.in_place ? fs::path(a.calibration) : fs::path(a.output);
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
  // A fit that fits the frames can still put the camera where no sky camera looks: the frames'
  // times and the sun's place disagree in a way one rotation absorbs (a longitude of the wrong
  // sign, a wrong zone or clock). Nothing is written then.
  if (const double tilt = calib::describe_pointing(calibration.R_site_from_camera).tilt_from_zenith_deg; tilt > a.max_tilt) {
    char text[160];
    std::snprintf(text, sizeof text, "the fit puts the sky camera's optical axis %.1f° from the zenith%s, more than --max-tilt %.0f°",
                  tilt, tilt > 90 ? " (below the horizon)" : "", a.max_tilt);
    throw InputError(std::string("sky-orientation: ") + text +
                     ". Likely: --lon with the wrong sign (east is positive), the frames' zone (--utc-offset, or the "
                     "zone in frames.csv), or the camera's clock. Fix: check those and run again; for a camera that "
                     "really leans that far, raise --max-tilt. Nothing was written");
  }

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


// ---------------------------------------------------------------------------------------------
// markers

struct MarkersArgs {
  std::string camera, output, image_out, family = "tag36h11";
  int origin = 0;
  std::vector<double> origin_pose;
  double size = 0;
  std::vector<std::string> tag_sizes;
  int min_photos = 2;
  double decimation = 1.0;
  std::vector<std::string> photos;
};

// "ID=METRES" → (id, metres).
std::pair<int, double> parse_tag_size(const std::string& text) {
  const std::size_t equals = text.find('=');
  const std::string fix = "write ID=METRES, the tag's id and the edge of its black square, e.g. --tag-size 3=0.16";
  if (equals == std::string::npos) bad_option("--tag-size", "'" + text + "' has no '='", fix);
  try {
    std::size_t used_id = 0, used_size = 0;
    const std::string id_text = text.substr(0, equals), size_text = text.substr(equals + 1);
    const int id = std::stoi(id_text, &used_id);
    const double size = std::stod(size_text, &used_size);
    if (used_id != id_text.size() || used_size != size_text.size() || id < 0 || !(size > 0)) {
      bad_option("--tag-size", "'" + text + "' is not a tag id and a positive size", fix);
    }
    return {id, size};
  } catch (const std::logic_error&) {
    bad_option("--tag-size", "'" + text + "' is not a tag id and a size", fix);
  }
}

calib::MarkerSurveyOptions survey_options(const MarkersArgs& a) {
  calib::MarkerSurveyOptions options;
  options.family = a.family;
  options.origin_id = a.origin;
  options.default_size = a.size;
  options.min_photos = a.min_photos;
  for (const std::string& entry : a.tag_sizes) {
    const auto [id, size] = parse_tag_size(entry);
    options.sizes[id] = size;
  }
  if (a.size <= 0 && options.sizes.empty()) {
    bad_option("--size", "no tag size given", "give --size METRES, the edge of the tags' black square (e.g. 0.2), and "
                                                 "--tag-size ID=METRES for tags of another size");
  }
  if (!a.origin_pose.empty()) {
    if (a.origin_pose.size() != 7) bad_option("--origin-pose", "needs 7 numbers", "give x,y,z,qw,qx,qy,qz");
    const auto& v = a.origin_pose;
    options.origin_pose.t_site_from_tag = Eigen::Vector3d(v[0], v[1], v[2]);
    options.origin_pose.R_site_from_tag = Eigen::Quaterniond(v[3], v[4], v[5], v[6]);
  }
  if (a.min_photos < 1) bad_option("--min-photos", "must be at least 1", "use 2 (the default) or more");
  return options;
}

int run_markers(const MarkersArgs& a) {
  calib::MarkerSurveyOptions options = survey_options(a);
  camera::CameraCalibration camera = camera::load_calibration(a.camera);
  const fs::path output(a.output);
  skylit::ensure_writable_directory(output.parent_path().empty() ? fs::path(".") : output.parent_path());
  track::TagDetectorOptions detector;
  detector.family = a.family;
  detector.decimation = a.decimation;
  if (std::find(track::tag_families().begin(), track::tag_families().end(), a.family) == track::tag_families().end()) {
    std::string known;
    for (std::string_view f : track::tag_families()) known.append(known.empty() ? "" : ", ").append(f);
    bad_option("--family", "unknown tag family '" + a.family + "'", "give one of " + known);
  }
  const std::vector<fs::path> files(a.photos.begin(), a.photos.end());
  const std::vector<calib::MarkerPhoto> photos = calib::detect_marker_photos(files, camera, detector);
  std::size_t with_tags = 0;
  for (const calib::MarkerPhoto& p : photos) with_tags += p.detections.empty() ? 0 : 1;
  std::printf("skylit-calib markers: tags found in %zu of %zu photo(s) (%s, origin tag %d)\n", with_tags, photos.size(),
              a.family.c_str(), a.origin);

  const calib::MarkerSurvey survey = calib::survey_markers(photos, camera, options);
  const std::size_t posed = static_cast<std::size_t>(
      std::count_if(survey.photos.begin(), survey.photos.end(), [](const calib::SurveyedPhoto& p) { return p.posed; }));
  std::printf("  %zu tag(s) mapped from %zu posed photo(s); RMS reprojection error %.3f px over %d corners (%d iterations)\n",
              survey.map.tags.size(), posed, survey.rms_px, survey.corners, survey.iterations);
  // Widths count bytes: ± and ° take two.
  std::printf("  %5s %6s %8s %10s %10s %9s   %s\n", "tag", "photos", "rms px", "±pos mm", "±rot °", "spread °",
              "position (m, x east, y north, z up)");
  for (std::size_t k = 0; k < survey.tags.size(); ++k) {
    const calib::SurveyedTag& t = survey.tags[k];
    const Eigen::Vector3d& p = survey.map.tags[k].t_site_from_tag;
    if (t.origin) {
      std::printf("  %5d %6d %8.3f %9s %8s %8.0f   %.3f %.3f %.3f  (origin, fixed)\n", t.id, t.photos, t.rms_px, "-", "-",
                  t.view_spread_deg, p.x(), p.y(), p.z());
    } else {
      std::printf("  %5d %6d %8.3f %9.1f %8.2f %8.0f   %.3f %.3f %.3f\n", t.id, t.photos, t.rms_px, 1000 * t.sigma_position_m,
                  t.sigma_rotation_deg, t.view_spread_deg, p.x(), p.y(), p.z());
    }
  }
  std::printf("  photos:\n");
  for (const calib::SurveyedPhoto& p : survey.photos) {
    if (p.posed) {
      std::string ids;
      for (int id : p.tags) ids.append(ids.empty() ? "" : " ").append(std::to_string(id));
      std::printf("    %-32s %.3f px  tags %s\n", p.name.c_str(), p.rms_px, ids.c_str());
    } else {
      std::printf("    %-32s not used: %s\n", p.name.c_str(), p.reason.c_str());
    }
  }
  for (const calib::LeftOutTag& t : survey.left_out) std::printf("  not mapped: tag %d: %s\n", t.id, t.reason.c_str());
  print_advice(survey.advice);

  track::MarkerMap map = survey.map;
  map.file = output;
  track::save_marker_map(map, output);
  const fs::path diagnostic = a.image_out.empty() ? beside(output, ".markers.png") : fs::path(a.image_out);
  sky::write_image(diagnostic, calib::draw_marker_survey(survey, options));
  std::printf("wrote %s and %s\n", output.string().c_str(), diagnostic.string().c_str());
  return 0;
}

// ---------------------------------------------------------------------------------------------
// hid list

struct HidListArgs {
  std::string profiles, output;
};

std::string hex4(unsigned value) {
  char text[8];
  std::snprintf(text, sizeof text, "%04x", value & 0xffffu);
  return text;
}

// YAML double-quoted scalar.
std::string yaml_quoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

int run_hid_list(const HidListArgs& a) {
  // The profiles: --profiles, else config/imu of the working directory (the source tree's or a
  // copy of the examples), else the installed examples' (share/skylit/examples/config/imu).
  fs::path folder = a.profiles;
  if (folder.empty() && fs::is_directory("config/imu")) folder = "config/imu";
  if (folder.empty() && fs::is_directory(skylit::data_dir() / "examples/config/imu")) {
    folder = skylit::data_dir() / "examples/config/imu";
  }
  if (!a.profiles.empty() && !fs::is_directory(folder)) {
    bad_option("--profiles", "'" + a.profiles + "' is not a folder", "give the folder of the IMU profiles (*.yaml), e.g. config/imu");
  }
  const std::vector<track::HidImuProfile> profiles =
      folder.empty() ? std::vector<track::HidImuProfile>{} : track::load_hid_imu_profiles(folder);
  const std::vector<track::HidDeviceInfo> devices = track::enumerate_hid_devices(profiles);
  const std::string from = folder.empty() ? std::string("no profile folder (give --profiles DIR)")
                                          : std::to_string(profiles.size()) + " IMU profile(s) from " + folder.string();
  std::vector<std::string> advice;
  std::string yaml = "# HID devices listed by skylit-calib hid list; profiles: " + from + "\ndevices:";
  if (devices.empty()) {
    std::printf("skylit-calib hid list: no HID devices found (%s)\n", from.c_str());
    advice.emplace_back("plug the IMU in; if it is plugged in, check that /dev/hidraw* exists and that this user may read "
                        "it (a udev rule, docs/imu.md)");
    yaml += " []\n";
  } else {
    std::printf("skylit-calib hid list: %zu HID device(s) (%s)\n", devices.size(), from.c_str());
    yaml += "\n";
    bool any_matched = false;
    for (const track::HidDeviceInfo& d : devices) {
      const std::string id = hex4(d.vendor_id) + ":" + hex4(d.product_id);
      std::string name = d.manufacturer;
      if (!d.product.empty()) name.append(name.empty() ? "" : " ").append(d.product);
      const std::string profile =
          d.profile.empty() ? std::string("no profile") : "profile \"" + d.profile + "\" (" + d.profile_file.string() + ")";
      std::printf("  %s  %-16s %-40s %s\n", id.c_str(), d.path.c_str(), name.empty() ? "(no name)" : name.c_str(), profile.c_str());
      any_matched = any_matched || !d.profile.empty();
      yaml += "  - id: " + yaml_quoted(id) + "\n    path: " + yaml_quoted(d.path) + "\n    name: " + yaml_quoted(name) +
              "\n    interface: " + std::to_string(d.interface_number) + "\n    profile: " +
              (d.profile.empty() ? std::string("null") : yaml_quoted(d.profile_file.string())) + "\n";
    }
    if (!any_matched) {
      advice.emplace_back("no device matches an IMU profile: plug the IMU in, or write a profile for it (docs/imu.md) "
                          "and give its folder with --profiles");
    }
  }
  print_advice(advice);
  if (!a.output.empty()) {
    skylit::write_file_atomic(a.output, yaml);
    std::printf("wrote %s\n", a.output.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"skylit-calib: calibration tools for installers (see docs/calibration.md)", "skylit-calib"};
  skylit::tools::add_version_flag(app);
  bool quiet = false;
  skylit::tools::add_quiet_flag(app, quiet);
  app.fallthrough();  // -q after a subcommand too, as a user types it
  app.require_subcommand(1);

  IntrinsicsArgs fisheye_args, camera_args;
  CLI::App* fisheye = app.add_subcommand("fisheye", "sky-camera intrinsics (fisheye model, k1..k4) from board photos");
  add_intrinsics_options(fisheye, fisheye_args, false);
  CLI::App* camera = app.add_subcommand("camera", "HMD camera intrinsics (pinhole, or --model fisheye) from board photos");
  add_intrinsics_options(camera, camera_args, true);

  StereoArgs st;
  CLI::App* stereo =
      app.add_subcommand("stereo", "a stereo camera: both cameras' lenses and the right camera's pose from pairs of board photos");
  stereo->add_option("--board", st.board.board, "chessboard: inner corners COLSxROWS (squares − 1), e.g. 9x6");
  stereo->add_option("--charuco", st.board.charuco, "ChArUco board: squares COLSxROWS, e.g. 5x7 (instead of --board)");
  stereo->add_option("--square", st.board.square, "side of one square, metres (e.g. 0.025)")->required();
  stereo->add_option("--marker", st.board.marker, "ChArUco: side of one marker, metres");
  stereo->add_option("--dict", st.board.dictionary, "ChArUco: the printed board's ArUco dictionary")->capture_default_str();
  stereo->add_option("--left", st.left, "the left camera's photos of the board, in the order of --right")
      ->required()
      ->check(CLI::ExistingFile);
  stereo->add_option("--right", st.right, "the right camera's photos, each taken at the same moment as its --left photo")
      ->required()
      ->check(CLI::ExistingFile);
  for (auto [option, value, what] : {std::tuple{"--model", &st.model, "both cameras' lens model"},
                                     std::tuple{"--left-model", &st.left_model, "the left camera's lens model (default --model)"},
                                     std::tuple{"--right-model", &st.right_model, "the right camera's lens model (default --model)"}}) {
    CLI::Option* added = stereo->add_option(option, *value, std::string(what) + ": pinhole or fisheye")
                             ->check(CLI::IsMember({"pinhole", "fisheye"}));
    if (value == &st.model) added->capture_default_str();
  }
  stereo->add_option("-o,--output", st.board.output, "stereo calibration to write (YAML); OUT.rectified.jpg goes beside it")
      ->required();
  stereo->add_option("--image-out", st.image_out, "the rectification check picture elsewhere than beside the YAML");

  OrientationArgs o;
  CLI::App* orientation = app.add_subcommand(
      "sky-orientation", "the sky camera's R_site_from_camera from the sun in timestamped frames, or a level and compass");
  orientation->add_option("--calib", o.calibration, "the sky camera's intrinsics (YAML from skylit-calib fisheye)")
      ->required()
      ->check(CLI::ExistingFile);
  orientation->add_option("-o,--output", o.output, "calibration to write; OUT.orientation.png beside it");
  orientation->add_flag("--in-place", o.in_place, "update the --calib file itself instead of writing -o");
  orientation->add_option("--max-tilt", o.max_tilt, "refuse a fit whose optical axis leans further from the zenith, degrees")
      ->capture_default_str();
  orientation->add_option("--frames", o.frames,
                          "CSV of sky frames: columns file,timestamp (ISO 8601 with zone), e.g. skylit-sky's frames.csv")
      ->check(CLI::ExistingFile);
  orientation->add_option("photos", o.photos,
                          "sky photos timed by their EXIF DateTimeOriginal (with --utc-offset when they lack a zone)")
      ->check(CLI::ExistingFile);
  orientation->add_option("--utc-offset", o.utc_offset, "zone of the photos' EXIF clock, e.g. +09:00 (Z for UTC)");
  orientation->add_option("--lat", o.latitude, "site latitude, degrees north");
  orientation->add_option("--lon", o.longitude, "site longitude, degrees east (negative west)");
  orientation->add_option("--response", o.response, "response curve of 8/16-bit frames (skylit-sky response); sRGB by default")
      ->check(CLI::ExistingFile);
  orientation->add_option("--max-residual", o.max_residual, "frames further than this from the fit are outliers, degrees")
      ->capture_default_str();
  orientation->add_option(
      "--level-compass", o.level_compass,
      "no sun: the camera is level, looks at the zenith, and its image x axis points at this compass bearing, degrees");
  orientation->add_option("--declination", o.declination, "magnetic declination to add to --level-compass, degrees east")
      ->capture_default_str();

  MarkersArgs m;
  CLI::App* markers = app.add_subcommand(
      "markers", "a marker map (the AprilTags' poses in the site) from photos of the site, one tag as the origin");
  markers->add_option("--camera", m.camera, "the photographing camera's calibration (YAML from skylit-calib camera)")
      ->required()
      ->check(CLI::ExistingFile);
  markers->add_option("--origin", m.origin, "id of the tag that is the site's origin")->capture_default_str();
  markers->add_option("--origin-pose", m.origin_pose,
                      "the origin tag's pose in the site: x,y,z,qw,qx,qy,qz (default: at 0,0,0, face up, top edge north)")
      ->expected(7)
      ->delimiter(',');
  markers->add_option("--size", m.size, "edge of the tags' black square, metres (e.g. 0.2)");
  markers->add_option("--tag-size", m.tag_sizes, "ID=METRES: a tag of another size (repeatable)")->allow_extra_args(false);
  markers->add_option("--family", m.family, "the printed tags' AprilTag family")->capture_default_str();
  markers->add_option("--min-photos", m.min_photos, "photos a tag must be seen in to be mapped")->capture_default_str();
  markers->add_option("--decimation", m.decimation, "detect quads in an image shrunk by this factor (faster on large photos)")
      ->capture_default_str();
  markers->add_option("-o,--output", m.output, "marker map to write (YAML); OUT.markers.png goes beside it")->required();
  markers->add_option("--image-out", m.image_out, "the diagnostic plan (PNG) elsewhere than beside the map");
  markers->add_option("photos", m.photos, "photos of the site, each showing two or more tags (10 or more, from all around)")
      ->required()
      ->check(CLI::ExistingFile);

  HidListArgs h;
  CLI::App* hid = app.add_subcommand("hid", "HID devices (IMUs)");
  hid->require_subcommand(1);
  CLI::App* hid_list = hid->add_subcommand("list", "the HID devices present, with the IMU profile that matches each");
  hid_list->add_option("--profiles", h.profiles, "folder of IMU profiles (*.yaml; default config/imu when it is here)");
  hid_list->add_option("-o,--output", h.output, "also write the list as YAML");

  if (const auto status = skylit::tools::parse_command_line(app, argc, argv)) return *status;
  if (quiet) skylit::tools::quiet_stdout();
  try {
    if (*fisheye) return run_intrinsics("fisheye", fisheye_args, camera::LensModel::Fisheye);
    if (*camera) {
      return run_intrinsics("camera", camera_args,
                            camera_args.model == "fisheye" ? camera::LensModel::Fisheye : camera::LensModel::Pinhole);
    }
    if (*stereo) return run_stereo(st);
    if (*orientation) return run_orientation(o);
    if (*markers) return run_markers(m);
    if (*hid_list) return run_hid_list(h);
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
