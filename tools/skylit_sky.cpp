// skylit-sky: simulated sky-camera frames. What a calibrated fisheye would record under a real
// HDR sky (an equirect) or an analytic one (Preetham clear sky with the sun where it stands at
// a place and time, or CIE overcast), as float OpenEXR and clipped 8-bit PNG, one frame or a
// time-lapse with a frames.csv. See docs/sky.md, "Sky simulator".
#include <algorithm>
#include <chrono>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/progress.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/image_io.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_model.hpp"
#include "skylit/sky/solar.hpp"
#include "command_line.hpp"

namespace {

namespace fs = std::filesystem;
using skylit::InputError;
using skylit::input_message;
using skylit::camera::Lens;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr long long kMaxFrames = 100000;  // a typo in --every should not fill a disk

struct Options {
  std::string calib, equirect, output, start, end, every;
  bool clear = false, overcast = false, quiet = false;
  std::optional<double> exposure, lat, lon;
  int supersample = 4;
  double azimuth_offset_deg = 0;
  double turbidity = 3.0;
  double zenith_radiance = 5.0;
};

[[noreturn]] void bad_option(const std::string& option, const std::string& problem, const std::string& fix) {
  throw InputError(input_message("", -1, -1, option, problem, fix));
}

std::string lower_extension(const fs::path& file) {
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

std::chrono::seconds parse_interval(const std::string& text) {
  try {
    return skylit::sky::parse_interval(text);
  } catch (const InputError& e) {
    throw InputError("option --every: " + std::string(e.what()));
  }
}

std::chrono::sys_seconds parse_time(const std::string& option, const std::string& text) {
  try {
    return skylit::sky::parse_utc(text);
  } catch (const InputError& e) {
    throw InputError("option " + option + ": " + e.what());
  }
}

void check_range(const std::string& option, const std::optional<double>& value, double lo, double hi,
                 const std::string& fix) {
  if (value && !(std::isfinite(*value) && *value >= lo && *value <= hi)) {
    bad_option(option, "got " + std::to_string(*value) + ", outside [" + std::to_string(lo) + ", " +
                           std::to_string(hi) + "]", fix);
  }
}

void validate(const Options& o) {
  const int sources = (o.equirect.empty() ? 0 : 1) + (o.clear ? 1 : 0) + (o.overcast ? 1 : 0);
  if (sources != 1) {
    bad_option("--equirect/--clear/--overcast", sources == 0 ? "no sky given" : "more than one sky given",
               "pass exactly one of --equirect SKY.exr, --clear or --overcast");
  }
  if (o.calib.empty()) bad_option("--calib", "missing", "pass the sky camera's calibration, e.g. --calib config/sky_camera.yaml");
  std::error_code ec;
  if (!fs::is_regular_file(o.calib, ec)) {
    bad_option("--calib", "'" + o.calib + "' is not a file", "pass an existing calibration (YAML), e.g. config/sky_camera.yaml");
  }
  if (o.output.empty()) bad_option("-o", "missing", "pass -o OUT.exr, -o OUT.png, or -o DIR for a time-lapse");
  if (o.supersample < 1 || o.supersample > 16) {
    bad_option("--supersample", "got " + std::to_string(o.supersample) + ", outside 1..16", "use 1 (fast) to 8 (smooth); 4 is the default");
  }
  if (o.exposure && !(std::isfinite(*o.exposure) && *o.exposure > 0)) {
    bad_option("--exposure", "got " + std::to_string(*o.exposure) + ", not a positive number",
               "give the scale from radiance to the 8-bit white point, e.g. 0.1 for a clear sky");
  }
  if (!std::isfinite(o.azimuth_offset_deg)) bad_option("--azimuth-offset", "not a number", "give degrees, e.g. 90");
  if (o.azimuth_offset_deg != 0 && o.equirect.empty()) {
    bad_option("--azimuth-offset", "applies to --equirect only", "leave it out for --clear and --overcast");
  }
  check_range("--lat", o.lat, -90, 90, "give degrees north (negative south), e.g. --lat 34.68");
  check_range("--lon", o.lon, -180, 180, "give degrees east (negative west), e.g. --lon 135.84");
  if (o.clear && (!o.lat || !o.lon || o.start.empty())) {
    bad_option("--clear", "needs the place and the time of the sun", "add --lat, --lon and --start (and --end, --every for a time-lapse)");
  }
  if (!o.end.empty()) {
    if (!o.equirect.empty()) bad_option("--end", "a time-lapse needs an analytic sky", "use --clear or --overcast, or drop --end");
    if (o.start.empty() || o.every.empty() || !o.lat || !o.lon) {
      bad_option("--end", "a time-lapse needs --start, --end, --every, --lat and --lon", "add the missing options");
    }
  } else if (!o.every.empty()) {
    bad_option("--every", "given without --end", "add --end for a time-lapse, or drop --every");
  }
}

cv::Mat load_equirect(const fs::path& file) {
  cv::Mat radiance = skylit::sky::read_equirect(file);
  if (radiance.cols != 2 * radiance.rows) {
    spdlog::warn("{}: {}x{} is not 2:1; taking it as an equirect all the same", file.string(), radiance.cols,
                 radiance.rows);
  }
  return radiance;
}

void write_frame(const fs::path& file, const cv::Mat& radiance, const std::optional<double>& exposure) {
  const std::string ext = lower_extension(file);
  if (ext == ".png") {
    skylit::sky::write_image(file, skylit::sky::to_8bit(radiance, *exposure));
  } else {
    skylit::sky::write_sky_exr(file, radiance);
  }
}

skylit::sky::AnalyticSkySettings analytic_settings(const Options& o) {
  skylit::sky::AnalyticSkySettings settings;
  settings.kind = o.overcast ? skylit::sky::AnalyticSkySettings::Kind::Overcast
                             : skylit::sky::AnalyticSkySettings::Kind::Clear;
  settings.turbidity = o.turbidity;
  settings.zenith_radiance = o.zenith_radiance;
  settings.latitude_deg = o.lat.value_or(0.0);
  settings.longitude_deg = o.lon.value_or(0.0);
  return settings;
}

int run_single(const Options& o, const Lens& lens) {
  const fs::path out(o.output);
  const std::string ext = lower_extension(out);
  if (ext != ".exr" && ext != ".png") {
    bad_option("-o", "'" + o.output + "' is neither .exr nor .png", "name the frame OUT.exr (float) or OUT.png (8-bit, with --exposure)");
  }
  if (ext == ".png" && !o.exposure) {
    bad_option("--exposure", "missing for a PNG frame", "add --exposure X (radiance × X = 1 is white; 0.1 suits a clear sky)");
  }
  if (ext == ".exr" && o.exposure) spdlog::warn("--exposure only applies to PNG output; the EXR keeps radiance");
  skylit::ensure_writable_directory(out.parent_path().empty() ? fs::path(".") : out.parent_path());
  skylit::sky::RenderOptions render;
  render.supersample = o.supersample;
  cv::Mat frame;
  if (!o.equirect.empty()) {
    render.azimuth_offset = o.azimuth_offset_deg * kDeg;
    frame = skylit::sky::render_fisheye(lens, load_equirect(o.equirect), render);
  } else {
    // An overcast sky needs no time; a clear one has --start (validate checked).
    const auto utc = o.start.empty() ? std::chrono::sys_seconds{} : parse_time("--start", o.start);
    if (o.lat && o.lon && !o.start.empty()) {
      const auto sun = skylit::sky::solar_position(utc, *o.lat, *o.lon);
      spdlog::info("sun at azimuth {:.2f}°, elevation {:.2f}°", sun.azimuth_rad / kDeg, sun.elevation_rad / kDeg);
    }
    frame = skylit::sky::render_fisheye(lens, skylit::sky::analytic_sky(analytic_settings(o), utc), render);
  }
  write_frame(out, frame, o.exposure);
  spdlog::info("wrote {} ({}x{})", out.string(), frame.cols, frame.rows);
  return 0;
}

int run_time_lapse(const Options& o, const Lens& lens) {
  const auto start = parse_time("--start", o.start);
  const auto end = parse_time("--end", o.end);
  const auto step = parse_interval(o.every);
  if (end < start) {
    bad_option("--end", "'" + o.end + "' is before --start '" + o.start + "'", "give an --end after --start");
  }
  const long long frames = (end - start) / step + 1;
  if (frames > kMaxFrames) {
    bad_option("--every", std::to_string(frames) + " frames from --start to --end",
               "use a longer --every or a shorter span (at most " + std::to_string(kMaxFrames) + " frames)");
  }
  const fs::path dir(o.output);
  skylit::ensure_writable_directory(dir);
  skylit::sky::RenderOptions render;
  render.supersample = o.supersample;
  const skylit::sky::AnalyticSkySettings settings = analytic_settings(o);

  std::string csv = "timestamp,file,sun_azimuth_deg,sun_elevation_deg\n";
  skylit::Progress progress("skylit-sky", frames, o.quiet ? nullptr : stderr);
  for (long long k = 0; k < frames; ++k) {
    const auto t = start + k * step;
    const auto sun = skylit::sky::solar_position(t, *o.lat, *o.lon);
    const cv::Mat frame = skylit::sky::render_fisheye(lens, skylit::sky::analytic_sky(settings, t), render);
    char name[32];
    std::snprintf(name, sizeof name, "frame_%04lld", k);
    const std::string exr = std::string(name) + ".exr";
    skylit::sky::write_sky_exr(dir / exr, frame);
    if (o.exposure) skylit::sky::write_image(dir / (std::string(name) + ".png"), skylit::sky::to_8bit(frame, *o.exposure));
    char row[160];
    std::snprintf(row, sizeof row, ",%.4f,%.4f\n", sun.azimuth_rad / kDeg, sun.elevation_rad / kDeg);
    csv += skylit::sky::format_utc(t) + "," + exr + row;
    progress.advance();
  }
  progress.finish();
  skylit::write_file_atomic(dir / "frames.csv", csv);
  spdlog::info("wrote {} frame(s) and frames.csv to {}", frames, dir.string());
  return 0;
}


// `skylit-sky response`: the camera's response curve from an exposure bracket of a static scene
// (Debevec), saved as YAML for skylit-shade --response, with a plot beside it.
int run_response(const std::vector<std::string>& images, const std::vector<double>& times, double gain,
                 const std::string& output) {
  if (images.size() < 2) {
    throw InputError("response: " + std::to_string(images.size()) +
                     " image(s). Fix: give at least 2 frames of one static scene at different exposure times");
  }
  if (times.size() != images.size()) {
    throw InputError("response: option --exposure: " + std::to_string(times.size()) + " time(s) for " +
                     std::to_string(images.size()) + " image(s). Fix: give one exposure time (seconds) per image, in order");
  }
  std::vector<cv::Mat> frames;
  std::vector<skylit::sky::Exposure> exposures;
  for (std::size_t k = 0; k < images.size(); ++k) {
    frames.push_back(skylit::sky::read_sky_image(images[k]));
    exposures.push_back({times[k], gain});
  }
  const skylit::sky::ResponseCurve curve = skylit::sky::calibrate_response(frames, exposures);
  skylit::sky::save_response(curve, output);

  // The curve against sRGB's, log exposure over code, one colour per channel.
  constexpr int kSize = 512, kMargin = 40;
  cv::Mat plot(kSize, kSize, CV_8UC3, cv::Scalar(30, 30, 30));
  const skylit::sky::ResponseCurve srgb = skylit::sky::ResponseCurve::srgb(curve.bits);
  const auto top = static_cast<double>(curve.bgr[0].size() - 1);
  double lo = 1e30, hi = -1e30;
  for (const auto& channel : curve.bgr) {
    for (float v : channel) {
      if (v > 0) {
        lo = std::min(lo, std::log10(static_cast<double>(v)));
        hi = std::max(hi, std::log10(static_cast<double>(v)));
      }
    }
  }
  const auto point = [&](std::size_t code, float value) {
    const double x = kMargin + (kSize - 2 * kMargin) * static_cast<double>(code) / top;
    const double y = kSize - kMargin - (kSize - 2 * kMargin) * (std::log10(std::max(value, 1e-30f)) - lo) / std::max(hi - lo, 1e-9);
    return cv::Point(static_cast<int>(x), static_cast<int>(std::clamp(y, 0.0, static_cast<double>(kSize))));
  };
  const cv::Scalar colours[3] = {{255, 120, 60}, {60, 220, 60}, {60, 60, 255}};
  for (std::size_t c = 0; c < 3; ++c) {
    for (std::size_t code = 2; code < curve.bgr[c].size(); ++code) {
      cv::line(plot, point(code - 1, srgb.bgr[c][code - 1]), point(code, srgb.bgr[c][code]), cv::Scalar(110, 110, 110), 1);
      cv::line(plot, point(code - 1, curve.bgr[c][code - 1]), point(code, curve.bgr[c][code]), colours[c], 1, cv::LINE_AA);
    }
  }
  cv::putText(plot, "code ->   (grey: sRGB)", {kMargin, kSize - 12}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(220, 220, 220));
  cv::putText(plot, "log exposure", {6, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(220, 220, 220));
  const fs::path plot_file = fs::path(output).replace_extension(".png");
  skylit::sky::write_image(plot_file, plot);
  spdlog::info("response curve of {} frame(s) written to {} (plot: {})", images.size(), output, plot_file.string());
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"skylit-sky: simulated sky-camera frames from an HDR equirect or an analytic sky", "skylit-sky"};
  skylit::tools::add_version_flag(app);
  Options o;
  app.add_option("--calib", o.calib, "sky camera calibration (YAML, see docs/sky.md)");
  app.add_option("--equirect", o.equirect, "HDR equirect of the sky (EXR/HDR; 8/16-bit taken as sRGB)")
      ->check(CLI::ExistingFile);
  app.add_flag("--clear", o.clear, "Preetham clear sky with the sun of --lat, --lon at --start");
  app.add_flag("--overcast", o.overcast, "CIE standard overcast sky");
  app.add_option("-o,--output", o.output, "OUT.exr or OUT.png (one frame), or a directory (time-lapse)");
  app.add_option("--exposure", o.exposure, "8-bit output: radiance × X = 1 is white (clipped above)");
  app.add_option("--supersample", o.supersample, "samples per pixel and axis, 1..16")->capture_default_str();
  app.add_option("--azimuth-offset", o.azimuth_offset_deg,
                 "degrees east of north that the equirect's centre column looks at")->capture_default_str();
  app.add_option("--lat", o.lat, "site latitude, degrees north");
  app.add_option("--lon", o.lon, "site longitude, degrees east");
  app.add_option("--start", o.start, "time of the frame, or the first of a time-lapse (ISO 8601 with zone)");
  app.add_option("--end", o.end, "last time of a time-lapse (ISO 8601 with zone)");
  app.add_option("--every", o.every, "time-lapse interval: 30s, 10min, 1h");
  app.add_option("--turbidity", o.turbidity, "clear sky haze, 2 (very clear) to 10")->capture_default_str();
  app.add_option("--zenith-radiance", o.zenith_radiance, "overcast zenith radiance (kcd/m²)")->capture_default_str();
  app.add_flag("-q,--quiet", o.quiet, "only warnings and errors");
  auto* response = app.add_subcommand("response", "calibrate the camera's response curve from an exposure bracket");
  std::vector<std::string> response_images;
  std::vector<double> response_times;
  double response_gain = 1.0;
  std::string response_out;
  response->add_option("images", response_images, "8-bit frames of one static scene")
      ->required()
      ->check(CLI::ExistingFile);
  response->add_option("--exposure", response_times, "exposure time of each frame, seconds")->required();
  response->add_option("--gain", response_gain, "sensor gain (linear), the same for every frame")->capture_default_str();
  response->add_option("-o,--output", response_out, "curve to write (YAML; a .png plot goes beside it)")->required();
  response->add_flag("-q,--quiet", o.quiet, "only warnings and errors");
  if (const auto status = skylit::tools::parse_command_line(app, argc, argv)) return *status;
  spdlog::set_level(o.quiet ? spdlog::level::warn : spdlog::level::info);
  spdlog::set_pattern("skylit-sky: %^%l%$: %v");

  try {
    if (*response) return run_response(response_images, response_times, response_gain, response_out);
    validate(o);
    const Lens lens(skylit::camera::load_calibration(o.calib));
    // The models check their parameters: before any frame is rendered.
    if (o.clear) (void)skylit::sky::ClearSky(Eigen::Vector3d::UnitZ(), o.turbidity);
    if (o.overcast) (void)skylit::sky::OvercastSky(o.zenith_radiance);
    return o.end.empty() ? run_single(o, lens) : run_time_lapse(o, lens);
  } catch (const InputError& e) {
    std::fprintf(stderr, "skylit-sky: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-sky: internal error: %s\n", e.what());
    return 3;
  }
}
