#include "synthetic_sky.hpp"

#include <cstdio>
#include <numbers>

#include "skylit/base/files.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::calib_test {

camera::CameraCalibration small_sky_camera(int size) {
  camera::CameraCalibration c;
  c.image_width = size;
  c.image_height = size;
  c.model = camera::LensModel::Fisheye;
  c.fx = c.fy = size / std::numbers::pi;  // θ = 90° at the image's edge
  c.cx = c.cy = 0.5 * (size - 1);
  c.D = {0, 0, 0, 0};
  return c;
}

std::filesystem::path write_sky_frames(const std::filesystem::path& dir, const camera::CameraCalibration& camera,
                                       double latitude_deg, double longitude_deg,
                                       const std::vector<std::chrono::sys_seconds>& times, bool clear,
                                       const std::vector<std::string>& csv_times) {
  const camera::Lens lens(camera);
  sky::AnalyticSkySettings settings;
  settings.kind = clear ? sky::AnalyticSkySettings::Kind::Clear : sky::AnalyticSkySettings::Kind::Overcast;
  settings.latitude_deg = latitude_deg;
  settings.longitude_deg = longitude_deg;
  sky::RenderOptions options;
  options.supersample = 2;
  std::string csv = "timestamp,file\n";
  for (std::size_t k = 0; k < times.size(); ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%02zu.exr", k);
    sky::write_sky_exr(dir / name, sky::render_fisheye(lens, sky::analytic_sky(settings, times[k]), options));
    csv += (csv_times.empty() ? sky::format_utc(times[k]) : csv_times[k]) + "," + name + "\n";
  }
  const std::filesystem::path file = dir / "frames.csv";
  write_file_atomic(file, csv);
  return file;
}

}  // namespace skylit::calib_test
