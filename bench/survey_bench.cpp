// The marker survey's bundle adjustment on a courtyard with known truth: 50 tags on four walls
// and the ground, 100 photos from a walk around it, 0.3 px corner noise and a few misdetected
// corners. Prints the survey's time (median of runs) and its error against the truth.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>

#include "skylit/calib/marker_survey.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/track/marker_map.hpp"
#include "skylit/track/pose.hpp"

namespace {

namespace calib = skylit::calib;
namespace track = skylit::track;
using Vec3 = Eigen::Vector3d;
constexpr double kDeg = std::numbers::pi / 180;

skylit::camera::CameraCalibration hand_camera() {  // 77° across 1280 px, mild barrel distortion
  skylit::camera::CameraCalibration c;
  c.image_width = 1280;
  c.image_height = 720;
  c.model = skylit::camera::LensModel::Pinhole;
  c.fx = c.fy = 800;
  c.cx = 639.5;
  c.cy = 359.5;
  c.D = {-0.06, 0.02, 0.0004, -0.0002, 0.0};
  return c;
}

// A tag whose face (its +z) points along `normal`, its top edge up (or north on the ground).
track::MarkerTag tag(int id, const Vec3& position, const Vec3& normal) {
  const Vec3 z = normal.normalized();
  const Vec3 y = std::abs(z.z()) > 0.9 ? Vec3::UnitY() : Vec3::UnitZ();
  const Vec3 x = y.cross(z).normalized();
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  track::MarkerTag t;
  t.id = id;
  t.size = 0.2;
  t.R_site_from_tag = Eigen::Quaterniond(R);
  t.t_site_from_tag = position;
  return t;
}

// A 16 m × 10 m courtyard: 12 tags along each long wall, 8 along each short one (at 0.8–1.6 m),
// 10 on the ground, tag 0 at the origin.
track::MarkerMap courtyard() {
  track::MarkerMap map;
  std::mt19937 random(3);
  std::uniform_real_distribution<double> height(0.8, 1.6);
  int id = 0;
  map.tags.push_back(tag(id++, Vec3::Zero(), Vec3::UnitZ()));
  for (int k = 0; k < 9; ++k) {
    const double a = 2 * std::numbers::pi * k / 9;
    map.tags.push_back(tag(id++, Vec3(3.5 * std::cos(a), 2.2 * std::sin(a), 0), Vec3::UnitZ()));
  }
  for (int k = 0; k < 12; ++k) {
    const double x = -7.3 + 14.6 * k / 11;
    map.tags.push_back(tag(id++, Vec3(x, 5, height(random)), -Vec3::UnitY()));
    map.tags.push_back(tag(id++, Vec3(x, -5, height(random)), Vec3::UnitY()));
  }
  for (int k = 0; k < 8; ++k) {
    const double y = -4.4 + 8.8 * k / 7;
    map.tags.push_back(tag(id++, Vec3(8, y, height(random)), -Vec3::UnitX()));
    map.tags.push_back(tag(id++, Vec3(-8, y, height(random)), Vec3::UnitX()));
  }
  return map;
}

// 100 photos from a walk round an ellipse inside the courtyard, 1.4–1.8 m up: most look out at
// the nearest walls (to either side of straight out), every fourth down at the ground's tags.
std::vector<track::Pose> walk() {
  std::vector<track::Pose> poses;
  for (int k = 0; k < 100; ++k) {
    const double a = 2 * std::numbers::pi * k / 100;
    track::Pose pose;
    pose.t_site_from_camera = Vec3(4.5 * std::cos(a), 2.6 * std::sin(a), 1.4 + 0.4 * ((k * 7) % 5) / 4.0);
    Vec3 target;
    if (k % 4 == 3) {
      target = Vec3(1.5 * std::cos(a + 0.4), 1.0 * std::sin(a + 0.4), 0);
    } else {
      const double look = a + (k % 4 - 1) * 40 * kDeg;
      target = pose.t_site_from_camera + 6 * Vec3(std::cos(look), std::sin(look), -0.12);
    }
    pose.R_site_from_camera = track::look_at(pose.t_site_from_camera, target);
    poses.push_back(pose);
  }
  return poses;
}

// The tags each photo sees (in the image, facing it, at least 16 px across), their corners with
// Gaussian noise; `outliers` of the detections get one corner misdetected by 5–15 px.
std::vector<calib::MarkerPhoto> photograph(const track::MarkerMap& site, const skylit::camera::CameraCalibration& camera,
                                           double noise_px, double outliers, unsigned seed) {
  const skylit::camera::Lens lens(camera);
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0, noise_px);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<calib::MarkerPhoto> photos;
  int k = 0;
  for (const track::Pose& pose : walk()) {
    calib::MarkerPhoto photo{"walk" + std::to_string(k++) + ".png", {}};
    const Eigen::Matrix3d camera_from_site = pose.R_site_from_camera.toRotationMatrix().transpose();
    for (const track::MarkerTag& t : site.tags) {
      const Vec3 normal = t.R_site_from_tag * Vec3::UnitZ();
      if (normal.dot(pose.t_site_from_camera - t.t_site_from_tag) <= 0) continue;
      track::TagDetection d;
      d.id = t.id;
      bool seen = true;
      const auto corners = track::tag_corners_in_site(t);
      for (std::size_t c = 0; c < 4 && seen; ++c) {
        const Vec3 in_camera = camera_from_site * (corners[c] - pose.t_site_from_camera);
        const auto pixel = in_camera.z() > 0.3 ? lens.project(in_camera) : std::nullopt;
        seen = pixel && pixel->x() >= 0 && pixel->y() >= 0 && pixel->x() <= camera.image_width - 1 &&
               pixel->y() <= camera.image_height - 1;
        if (seen) d.corners[c] = *pixel + Eigen::Vector2d(noise(random), noise(random));
      }
      if (!seen || (d.corners[0] - d.corners[2]).norm() < 16 * std::sqrt(2.0)) continue;
      if (unit(random) < outliers) {
        const double angle = 2 * std::numbers::pi * unit(random), length = 5 + 10 * unit(random);
        d.corners[static_cast<std::size_t>(random() % 4)] += length * Eigen::Vector2d(std::cos(angle), std::sin(angle));
      }
      photo.detections.push_back(d);
    }
    photos.push_back(photo);
  }
  return photos;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The marker survey on 50 tags and 100 photos with known truth: time and error."};
  int runs = 5;
  double noise_px = 0.3, outliers = 0.02;
  app.add_option("--runs", runs, "surveys timed (the median is quoted)")->check(CLI::PositiveNumber);
  app.add_option("--noise", noise_px, "corner noise, pixels (σ per axis)");
  app.add_option("--outliers", outliers, "fraction of detections with one corner misdetected by 5-15 px");
  std::string loss = "cauchy";
  app.add_option("--loss", loss, "the robust loss: cauchy or huber")->check(CLI::IsMember({"cauchy", "huber"}));
  CLI11_PARSE(app, argc, argv);

  const track::MarkerMap site = courtyard();
  const skylit::camera::CameraCalibration camera = hand_camera();
  const std::vector<calib::MarkerPhoto> photos = photograph(site, camera, noise_px, outliers, 11);
  std::size_t detections = 0;
  for (const calib::MarkerPhoto& p : photos) detections += p.detections.size();
  calib::MarkerSurveyOptions options;
  options.default_size = 0.2;
  options.loss = loss == "huber" ? calib::MarkerSurveyOptions::RobustLoss::Huber : calib::MarkerSurveyOptions::RobustLoss::Cauchy;

  std::vector<double> seconds;
  calib::MarkerSurvey survey;
  for (int r = 0; r < runs; ++r) {
    const auto start = std::chrono::steady_clock::now();
    survey = calib::survey_markers(photos, camera, options);
    seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::vector<double> position_mm, rotation_deg;
  for (const track::MarkerTag& truth : site.tags) {
    const track::MarkerTag* found = survey.map.find(truth.id);
    if (!found || truth.id == 0) continue;
    position_mm.push_back(1000 * (found->t_site_from_tag - truth.t_site_from_tag).norm());
    rotation_deg.push_back(found->R_site_from_tag.angularDistance(truth.R_site_from_tag) / kDeg);
  }
  int posed = 0;
  for (const calib::SurveyedPhoto& p : survey.photos) posed += p.posed ? 1 : 0;
  double sigma_mm = 0;
  for (const calib::SurveyedTag& t : survey.tags) sigma_mm = std::max(sigma_mm, 1000 * t.sigma_position_m);
  std::printf("photos %zu (posed %d), tags %zu (mapped %zu), detections %zu, corners %d\n", photos.size(), posed, site.tags.size(),
              survey.map.tags.size(), detections, survey.corners);
  std::printf("time: median %.3f s over %d runs (min %.3f, max %.3f); %d iterations\n", median(seconds), runs,
              *std::min_element(seconds.begin(), seconds.end()), *std::max_element(seconds.begin(), seconds.end()),
              survey.iterations);
  std::printf("tag position error: median %.2f mm, max %.2f mm; rotation: median %.3f°, max %.3f°; largest stated 1σ %.2f mm\n",
              median(position_mm), position_mm.empty() ? 0.0 : *std::max_element(position_mm.begin(), position_mm.end()),
              median(rotation_deg), rotation_deg.empty() ? 0.0 : *std::max_element(rotation_deg.begin(), rotation_deg.end()),
              sigma_mm);
  std::printf("RMS reprojection %.3f px\n", survey.rms_px);
  return 0;
}
