// EquirectLights, the building's reference and estimate, and their errors.
#include "skylit/study/building_light.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "skylit/baker/visibility.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/sky/radiometry.hpp"

namespace skylit::study {

EquirectLights equirect_lights(const cv::Mat& equirect, int supersample) {
  EquirectLights lights;
  std::vector<Vec3>& directions = lights.directions;
  std::vector<Eigen::Vector3d>& weights = lights.weights;
  cv::Mat near_bright(equirect.size(), CV_8UC1, cv::Scalar(0));
  if (supersample > 1) {
    std::vector<double> all;
    for (int row = 0; row < equirect.rows / 2; ++row) {
      for (int col = 0; col < equirect.cols; ++col) {
        const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
        all.push_back(luminance(Eigen::Vector3d(l[2], l[1], l[0])));
      }
    }
    std::nth_element(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(all.size() / 2), all.end());
    const double median_y = all[all.size() / 2];
    for (int row = 0; row < equirect.rows; ++row) {
      for (int col = 0; col < equirect.cols; ++col) {
        const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
        if (luminance(Eigen::Vector3d(l[2], l[1], l[0])) <= kBrightOverMedian * median_y) continue;
        for (int dy = -2; dy <= 2; ++dy) {
          for (int dx = -2; dx <= 2; ++dx) {
            near_bright.at<std::uint8_t>(std::clamp(row + dy, 0, equirect.rows - 1),
                                         (col + dx + equirect.cols) % equirect.cols) = 255;
          }
        }
      }
    }
  }
  const auto bilinear = [&](double x, double y) {
    const int w = equirect.cols, h = equirect.rows;
    const double fx = std::floor(x), fy = std::floor(y);
    const double tx = x - fx, ty = y - fy;
    const int x0 = (static_cast<int>(fx) % w + w) % w, x1 = (x0 + 1) % w;
    const int y0 = std::clamp(static_cast<int>(fy), 0, h - 1), y1 = std::clamp(static_cast<int>(fy) + 1, 0, h - 1);
    Eigen::Vector3d rgb;
    for (int ch = 0; ch < 3; ++ch) {
      const double top = (1 - tx) * equirect.at<cv::Vec3f>(y0, x0)[ch] + tx * equirect.at<cv::Vec3f>(y0, x1)[ch];
      const double bottom = (1 - tx) * equirect.at<cv::Vec3f>(y1, x0)[ch] + tx * equirect.at<cv::Vec3f>(y1, x1)[ch];
      rgb[2 - ch] = (1 - ty) * top + ty * bottom;
    }
    return rgb;
  };
  for (int row = 0; row < equirect.rows; ++row) {
    const double solid_angle = sky::equirect_pixel_solid_angle(equirect.cols, equirect.rows, row);
    for (int col = 0; col < equirect.cols; ++col) {
      if (near_bright.at<std::uint8_t>(row, col)) {
        ++lights.supersampled;
        const int n = supersample;
        for (int j = 0; j < n; ++j) {
          const double y = row - 0.5 + (j + 0.5) / n;
          // Solid angle of the sub-row: the band between its edges, split over n columns.
          const double top = M_PI / 2 - M_PI * (y + 0.5 - 0.5 / n) / equirect.rows;
          const double bottom = M_PI / 2 - M_PI * (y + 0.5 + 0.5 / n) / equirect.rows;
          const double sub_angle = 2.0 * M_PI / equirect.cols / n * (std::sin(top) - std::sin(bottom));
          for (int i = 0; i < n; ++i) {
            const double x = col - 0.5 + (i + 0.5) / n;
            const Vec3 d = sky::equirect_direction(equirect.cols, equirect.rows, x, y);
            if (d.z() <= 0.0) continue;
            directions.push_back(d);
            weights.push_back(bilinear(x, y) * sub_angle);
          }
        }
        continue;
      }
      const Vec3 d = sky::equirect_direction(equirect.cols, equirect.rows, col, row);
      if (d.z() <= 0.0) continue;
      const cv::Vec3f& l = equirect.at<cv::Vec3f>(row, col);
      directions.push_back(d);
      weights.emplace_back(l[2] * solid_angle, l[1] * solid_angle, l[0] * solid_angle);
    }
  }
  return lights;
}

Eigen::Vector3d horizontal_irradiance(const EquirectLights& lights) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < lights.directions.size(); ++k) sum += std::max(0.0, lights.directions[k].z()) * lights.weights[k];
  return sum;
}

std::vector<Eigen::Vector3d> building_reference(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh) {
  std::vector<Eigen::Vector3d> out(mesh.vertex_count());
  baker::weighted_vertex_irradiance(mesh, site.planes, lights.directions, lights.weights, out);
  return out;
}

std::vector<Eigen::Vector3d> building_estimate(std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                                               std::span<const SourceLight> sources, const scene::Site& site,
                                               const scene::Mesh& mesh) {
  std::vector<blend::SunLight> lights;
  std::vector<std::vector<float>> visibility;
  for (const SourceLight& source : sources) {
    lights.push_back({source.direction, source.energy});
    visibility.emplace_back(mesh.vertex_count(), 1.0f);
    if (!source.disc_directions.empty()) {
      baker::area_light_vertex_visibility(mesh, site.planes, source.disc_directions, source.disc_weights, visibility.back());
    }
  }
  return blend::vertex_irradiance(transfer, S, mesh.normals, lights, visibility);
}

Errors building_errors(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                       const Eigen::Vector3d& horizontal) {
  if (estimate.size() != reference.size()) throw std::invalid_argument("building_errors: estimate and reference differ in length");
  std::vector<double> diffs;
  diffs.reserve(3 * estimate.size());
  for (std::size_t v = 0; v < estimate.size(); ++v) {
    for (int c = 0; c < 3; ++c) {
      if (horizontal[c] > 0) diffs.push_back(std::abs(estimate[v][c] - reference[v][c]) / horizontal[c]);
    }
  }
  return errors_of(std::move(diffs));
}

std::size_t worst_vertex(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                         const Eigen::Vector3d& horizontal) {
  std::size_t worst = 0;
  double largest = -1;
  for (std::size_t v = 0; v < std::min(estimate.size(), reference.size()); ++v) {
    for (int c = 0; c < 3; ++c) {
      const double e = horizontal[c] > 0 ? std::abs(estimate[v][c] - reference[v][c]) / horizontal[c] : 0.0;
      if (e > largest) {
        largest = e;
        worst = v;
      }
    }
  }
  return worst;
}

}  // namespace skylit::study
