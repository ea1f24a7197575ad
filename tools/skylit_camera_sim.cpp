// skylit-camera-sim: a synthetic HMD camera recording of a site's real ground, with the camera
// path it was taken from, for demos and tests before real footage exists.
//
//     skylit-camera-sim --calib config/hmd_camera.yaml -o OUT_DIR [--frames 120] [--fps 30]
//                       [--centre 0,0] [--radius 18] [--height 1.6] [--sweep 60] [--look-at 0,0,3]
//
// The camera walks an arc of `sweep` degrees at `radius` metres around `centre`, at eye height,
// looking at `look-at`. Each frame sees what the site has without the virtual building: a flat
// ground of paving stones and gravel (z = 0) up to the horizon and a plain sky above it, imaged
// through the calibrated lens (distortion included), written as 8-bit sRGB PNG. Beside them:
// frames.csv (file,timestamp) and poses.csv (timestamp,x,y,z,qw,qx,qy,qz: R_site_from_camera,
// the format skylit-live reads).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/progress.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/srgb.hpp"
#include "skylit/track/pose.hpp"
#include "command_line.hpp"

namespace {

namespace fs = std::filesystem;
using Vec3 = Eigen::Vector3d;

// Smooth value noise in [0, 1] (deterministic: the recording is the same on every machine).
double hash01(int x, int y) {
  std::uint32_t h = static_cast<std::uint32_t>(x) * 374761393u + static_cast<std::uint32_t>(y) * 668265263u;
  h = (h ^ (h >> 13)) * 1274126177u;
  return static_cast<double>((h ^ (h >> 16)) & 0xFFFFFFu) / static_cast<double>(0xFFFFFF);
}

double value_noise(double x, double y) {
  const int ix = static_cast<int>(std::floor(x)), iy = static_cast<int>(std::floor(y));
  const double fx = x - ix, fy = y - iy;
  const double sx = fx * fx * (3 - 2 * fx), sy = fy * fy * (3 - 2 * fy);
  const double a = hash01(ix, iy), b = hash01(ix + 1, iy), c = hash01(ix, iy + 1), d = hash01(ix + 1, iy + 1);
  return (a + (b - a) * sx) + ((c + (d - c) * sx) - (a + (b - a) * sx)) * sy;
}

// Linear RGB albedo of the ground at site point (x, y): a 4 m path of 0.8 × 1.2 m stones running
// north-south to the gate, gravel elsewhere.
Vec3 ground_albedo(double x, double y) {
  const double grain = 0.6 * value_noise(x * 9.0, y * 9.0) + 0.4 * value_noise(x * 37.0, y * 37.0);
  if (std::abs(x) < 2.0) {
    const double v = y / 1.2, u = x / 0.8 + (std::fmod(std::floor(v) + 100.0, 2.0) * 0.5);
    const double joint = std::min(std::abs(u - std::round(u)) * 0.8, std::abs(v - std::round(v)) * 1.2);
    const double stone = 0.30 + 0.08 * hash01(static_cast<int>(std::floor(u)), static_cast<int>(std::floor(v)));
    const double shade = joint < 0.02 ? 0.45 : 1.0;
    return Vec3(1.0, 0.97, 0.92) * (stone * shade * (0.9 + 0.2 * grain));
  }
  return Vec3(0.95, 0.9, 0.8) * (0.18 + 0.10 * grain);
}

std::vector<double> parse_numbers(const std::string& text, std::size_t count, const std::string& option) {
  std::vector<double> values;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    try {
      std::size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) values.clear();
    } catch (const std::exception&) {
      values.clear();
    }
    if (values.empty() || comma == std::string::npos) break;
    start = comma + 1;
  }
  if (values.size() != count) {
    throw skylit::InputError("option " + option + ": '" + text + "' is not " + std::to_string(count) +
                             " comma-separated numbers. Fix: e.g. " + (count == 2 ? "0,0" : "0,0,3"));
  }
  return values;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"skylit-camera-sim: a synthetic HMD camera recording of the real ground, and its camera path",
               "skylit-camera-sim"};
  skylit::tools::add_version_flag(app);
  bool quiet = false;
  skylit::tools::add_quiet_flag(app, quiet);
  std::string calib_file, out_dir, centre_text = "0,0", target_text = "0,0,3";
  int frames = 120;
  double fps = 30, radius = 18, height = 1.6, sweep = 60, start_azimuth = -90, exposure = 1.0;
  app.add_option("--calib", calib_file, "the HMD camera's calibration (YAML)")->required()->check(CLI::ExistingFile);
  app.add_option("-o,--out", out_dir, "output folder")->required();
  app.add_option("--frames", frames, "frames to write")->capture_default_str()->check(CLI::Range(1, 100000));
  app.add_option("--fps", fps, "frames per second of the recording")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--centre", centre_text, "x,y (metres) the path circles")->capture_default_str();
  app.add_option("--radius", radius, "metres from the centre")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--height", height, "eye height, metres")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--start-azimuth", start_azimuth, "where the path starts, degrees from east towards north")
      ->capture_default_str();
  app.add_option("--sweep", sweep, "degrees of arc walked over the whole recording")->capture_default_str();
  app.add_option("--look-at", target_text, "x,y,z the camera looks at")->capture_default_str();
  app.add_option("--exposure", exposure, "scale from the ground's radiance to pixel values")->capture_default_str();
  if (const auto status = skylit::tools::parse_command_line(app, argc, argv)) return *status;
  if (quiet) skylit::tools::quiet_stdout();

  try {
    const auto centre = parse_numbers(centre_text, 2, "--centre");
    const auto target_values = parse_numbers(target_text, 3, "--look-at");
    const Vec3 target(target_values[0], target_values[1], target_values[2]);
    const skylit::camera::CameraCalibration calibration = skylit::camera::load_calibration(calib_file);
    const skylit::camera::Lens lens(calibration);
    skylit::ensure_writable_directory(out_dir);

    // Each pixel's ray in the camera frame, once (the lens does not move).
    const int width = calibration.image_width, height_px = calibration.image_height;
    std::vector<Vec3> rays(static_cast<std::size_t>(width) * height_px, Vec3::Zero());
    for (int row = 0; row < height_px; ++row) {
      for (int col = 0; col < width; ++col) {
        if (auto d = lens.unproject({col, row})) rays[static_cast<std::size_t>(row) * width + col] = *d;
      }
    }

    std::string frames_csv = "file,timestamp\n", poses_csv = "timestamp,x,y,z,qw,qx,qy,qz\n";
    const Vec3 sun_light(1.0, 0.98, 0.94);  // the ground's irradiance / π, relative (the sky above)
    // A bar on a terminal, plain lines in a log; nothing with -q.
    std::optional<skylit::Progress> progress;
    if (!quiet) progress.emplace("skylit-camera-sim: frames", frames);
    for (int k = 0; k < frames; ++k) {
      const double t = k / fps;
      const double azimuth = (start_azimuth + sweep * (frames > 1 ? k / double(frames - 1) : 0.0)) * M_PI / 180.0;
      const Vec3 eye(centre[0] + radius * std::cos(azimuth), centre[1] + radius * std::sin(azimuth), height);
      const Eigen::Quaterniond q = skylit::track::look_at(eye, target);
      const Eigen::Matrix3d R = q.toRotationMatrix();
      cv::Mat image(height_px, width, CV_8UC3);
      for (int row = 0; row < height_px; ++row) {
        auto* out = image.ptr<cv::Vec3b>(row);
        for (int col = 0; col < width; ++col) {
          const Vec3& ray = rays[static_cast<std::size_t>(row) * width + col];
          Vec3 radiance;
          if (ray.isZero()) {
            radiance.setZero();
          } else {
            const Vec3 d = R * ray;
            if (d.z() < -1e-6) {
              const double s = -eye.z() / d.z();
              const Vec3 p = eye + s * d;
              // Distant ground fades into haze, as it does outdoors.
              const double haze = 1.0 - std::exp(-s / 400.0);
              radiance = ground_albedo(p.x(), p.y()).cwiseProduct(sun_light) * (1 - haze) + Vec3(0.55, 0.6, 0.7) * haze;
            } else {
              const double elevation = std::asin(std::clamp(d.z(), 0.0, 1.0));
              radiance = Vec3(0.35, 0.5, 0.8) + (Vec3(0.75, 0.78, 0.8) - Vec3(0.35, 0.5, 0.8)) * std::exp(-elevation * 6);
            }
          }
          for (int c = 0; c < 3; ++c) {
            out[col][2 - c] = skylit::sky::srgb_encode8(exposure * radiance[c]);
          }
        }
      }
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05d.png", k);
      const fs::path file = fs::path(out_dir) / name;
      if (!cv::imwrite(file.string(), image)) throw skylit::InputError("cannot write " + file.string());
      char line[256];
      std::snprintf(line, sizeof line, "%s,%.6f\n", name, t);
      frames_csv += line;
      std::snprintf(line, sizeof line, "%.6f,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f\n", t, eye.x(), eye.y(), eye.z(), q.w(),
                    q.x(), q.y(), q.z());
      poses_csv += line;
      if (progress) progress->advance();
    }
    if (progress) progress->finish();
    skylit::write_file_atomic(fs::path(out_dir) / "frames.csv", frames_csv);
    skylit::write_file_atomic(fs::path(out_dir) / "poses.csv", poses_csv);
    std::printf("skylit-camera-sim: %d frames of %d×%d in %s (frames.csv, poses.csv)\n", frames, width, height_px,
                out_dir.c_str());
  } catch (const skylit::InputError& e) {
    std::fprintf(stderr, "skylit-camera-sim: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skylit-camera-sim: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}
