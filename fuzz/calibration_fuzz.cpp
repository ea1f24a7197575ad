// A camera calibration (camera::load_calibration): our YAML or OpenCV's FileStorage as YAML, XML
// or JSON (the first byte picks the extension, which picks the reader); an accepted one must
// make a lens that projects and unprojects promptly.
#include <array>
#include <cmath>

#include "fuzz_target.hpp"
#include "skylit/camera/calibration.hpp"
#include "skylit/camera/lens.hpp"

SKYLIT_FUZZ_TARGET(calibration) {
  if (size == 0) return 0;
  constexpr std::array<const char*, 4> kNames = {"calib/camera.yaml", "calib/camera.yml", "calib/camera.xml",
                                                 "calib/camera.json"};
  const auto file = skylit::fuzz::write_input(kNames[data[0] % kNames.size()], data + 1, size - 1);
  skylit::fuzz::refuse_only_with_input_error([&] {
    const skylit::camera::CameraCalibration calibration = skylit::camera::load_calibration(file);
    const skylit::camera::Lens lens(calibration);
    const double w = calibration.image_width, h = calibration.image_height;
    for (const skylit::camera::Vec2& pixel : {skylit::camera::Vec2(0, 0), skylit::camera::Vec2(w / 2, h / 2), skylit::camera::Vec2(w - 1, h - 1)}) {
      if (const auto direction = lens.unproject(pixel)) {
        skylit::fuzz::require(std::abs(direction->norm() - 1.0) < 1e-6, "unproject gives a unit direction");
        (void)lens.project(*direction);
      }
    }
  });
  return 0;
}
