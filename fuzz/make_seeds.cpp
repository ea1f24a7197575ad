// skylit-fuzz-seeds SOURCE_DIR: writes the seed inputs of the binary formats under
// SOURCE_DIR/fuzz/corpus (run by hand when a format changes; its outputs are committed): small,
// valid files from skylit's own writers, from which libFuzzer mutates.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "skylit/bake_format/arrays.hpp"
#include "skylit/camera/calibration.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky_link/sky_message.hpp"
#include "skylit/track/imu.hpp"
#include "skylit/track/marker_map.hpp"

namespace fs = std::filesystem;
using namespace skylit;

namespace {

void write_bytes(const fs::path& file, const std::string& prefix, const std::vector<std::uint8_t>& bytes) {
  fs::create_directories(file.parent_path());
  std::ofstream out(file, std::ios::binary);
  out << prefix;
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

std::vector<std::uint8_t> file_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: skylit-fuzz-seeds SOURCE_DIR\n");
    return 2;
  }
  const fs::path corpus = fs::path(argv[1]) / "fuzz" / "corpus";
  const fs::path scratch = fs::temp_directory_path() / "skylit-fuzz-seeds";
  fs::create_directories(scratch);

  // NPY: a 3x4 array and a 1-D one.
  fs::create_directories(corpus / "npy");
  std::vector<float> values(12);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = 0.25f * float(i);
  const std::size_t shape2[] = {3, 4};
  bake_format::write_npy(corpus / "npy" / "seed_3x4.npy", values, shape2);
  const std::size_t shape1[] = {5};
  bake_format::write_npy(corpus / "npy" / "seed_5.npy", std::span<const float>(values).first(5), shape1);

  // EXR: a bake's two-layer stack (half floats) and a sky frame (RGB floats).
  fs::create_directories(corpus / "exr");
  bake_format::ImageStack stack{4, 3, 2, std::vector<float>(24)};
  for (std::size_t i = 0; i < stack.data.size(); ++i) stack.data[i] = float(i) / 24.0f;
  const std::vector<std::string> layers = {"face_000", "face_001"};
  bake_format::write_exr_stack(corpus / "exr" / "seed_stack.exr", stack, layers);
  cv::Mat sky(6, 8, CV_32FC3, cv::Scalar(0.2, 0.5, 1.0));
  sky.at<cv::Vec3f>(2, 3) = cv::Vec3f(5000, 5000, 5000);
  sky::write_sky_exr(corpus / "exr" / "seed_sky.exr", sky);
  sky::write_sky_exr(corpus / "exr" / "seed_sky_half.exr", sky, true);

  // The sky message the harness's identity takes: the sample gate, ν = 2 faces (80 layers).
  sky_link::SkyMessage message;
  message.identity = {"sample gate", 2, geom::DomeBasis::Faces, 80};
  message.sequence = 7;
  message.run = 1780000000000000;
  message.frame_timestamp = 12.5;
  message.utc = 1782000000;
  message.published = 1782000000.25;
  message.S.assign(80, Eigen::Vector3d(0.1, 0.2, 0.3));
  message.sources.push_back({Eigen::Vector3d(0.3, 0.4, 0.866).normalized(), Eigen::Vector3d(800, 790, 760), 0.0047, false});
  message.sun_reason = "found";
  write_bytes(corpus / "sky_message" / "seed_sun.cbor", "", sky_link::encode_sky_message(message));
  message.sources.clear();
  message.sun_reason = "overcast";
  message.published.reset();
  message.utc.reset();
  write_bytes(corpus / "sky_message" / "seed_overcast.cbor", "", sky_link::encode_sky_message(message));

  // A calibration as skylit writes it, behind the harness's first byte (0: .yaml).
  camera::CameraCalibration calibration;
  calibration.image_width = 640;
  calibration.image_height = 480;
  calibration.model = camera::LensModel::Pinhole;
  calibration.fx = calibration.fy = 500;
  calibration.cx = 319.5;
  calibration.cy = 239.5;
  calibration.D = {0.01, -0.02, 0, 0, 0};
  write_bytes(corpus / "calibration" / "seed_pinhole.yaml", std::string(1, '\0') + camera::calibration_to_yaml(calibration), {});

  // A marker map with two tags, a response curve and an IMU recording.
  track::MarkerMap map;
  map.tags.push_back({0, 0.2, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 3, 1.5)});
  map.tags.push_back({5, 0.16, Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ())), Eigen::Vector3d(2, 3, 1.2)});
  const std::string map_text = track::marker_map_to_yaml(map);
  write_bytes(corpus / "marker_map" / "seed_two_tags.yaml", map_text, {});
  sky::ResponseCurve curve = sky::ResponseCurve::srgb(8);
  sky::save_response(curve, scratch / "response.yaml");
  write_bytes(corpus / "response" / "seed_srgb8.yaml", "", file_bytes(scratch / "response.yaml"));
  std::vector<track::ImuSample> samples;
  for (int i = 0; i < 4; ++i) {
    samples.push_back({0.005 * i, Eigen::Vector3d(0.01, -0.02, 0.03 * i), Eigen::Vector3d(0.1, 9.8, -0.2)});
  }
  track::save_imu_csv(scratch / "imu.csv", samples);
  write_bytes(corpus / "csv" / "seed_imu.csv", "", file_bytes(scratch / "imu.csv"));

  fs::remove_all(scratch);
  std::printf("seeds written under %s\n", corpus.c_str());
  return 0;
}
