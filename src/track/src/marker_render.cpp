// Synthetic frames of tags by inverse mapping through the lens model.
#include "skylit/track/marker_render.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>

#include "skylit/track/tag_detector.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::track {
namespace {

using Vec2 = Eigen::Vector2d;

struct PixelBox {
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // inclusive
};

// The tag's paper outline in the frame (points along its edges, padded), or the whole frame when
// part of it cannot be projected.
PixelBox tag_box(const std::array<Vec3, 4>& paper_corners, const Eigen::Matrix3d& camera_from_site, const Vec3& centre,
                 const camera::Lens& lens, int width, int height) {
  constexpr int kPointsPerEdge = 16;
  constexpr double kPadPx = 3;
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (int e = 0; e < 4; ++e) {
    const Vec3& a = paper_corners[static_cast<std::size_t>(e)];
    const Vec3& b = paper_corners[static_cast<std::size_t>((e + 1) % 4)];
    for (int i = 0; i < kPointsPerEdge; ++i) {
      const Vec3 point = a + (b - a) * (static_cast<double>(i) / kPointsPerEdge);
      const Vec3 direction = camera_from_site * (point - centre);
      const std::optional<Vec2> pixel = direction.z() > 0 ? lens.project(direction) : std::nullopt;
      if (!pixel) return {0, 0, width - 1, height - 1};
      x0 = std::min(x0, pixel->x());
      y0 = std::min(y0, pixel->y());
      x1 = std::max(x1, pixel->x());
      y1 = std::max(y1, pixel->y());
    }
  }
  PixelBox box;
  box.x0 = static_cast<int>(std::clamp(std::floor(x0 - kPadPx), 0.0, width - 1.0));
  box.y0 = static_cast<int>(std::clamp(std::floor(y0 - kPadPx), 0.0, height - 1.0));
  box.x1 = static_cast<int>(std::clamp(std::ceil(x1 + kPadPx), -1.0, width - 1.0));
  box.y1 = static_cast<int>(std::clamp(std::ceil(y1 + kPadPx), -1.0, height - 1.0));
  if (x1 < 0 || y1 < 0 || x0 > width - 1 || y0 > height - 1) box.x1 = box.y1 = -1;  // outside the frame
  return box;
}

}  // namespace

cv::Mat render_markers(const MarkerMap& map, const camera::Lens& lens, const Pose& camera, const MarkerRenderOptions& options) {
  if (options.supersampling < 1) throw std::invalid_argument("render_markers: supersampling must be ≥ 1");
  const camera::CameraCalibration& calibration = lens.calibration();
  const int width = calibration.image_width, height = calibration.image_height;
  cv::Mat1f grey(height, width, static_cast<float>(options.background));

  const Eigen::Matrix3d site_from_camera = camera.R_site_from_camera.toRotationMatrix();
  const Eigen::Matrix3d camera_from_site = site_from_camera.transpose();
  const Vec3& centre = camera.t_site_from_camera;
  const TagFamilyLayout layout = tag_family_layout(map.family);
  const double half_pattern_cells = layout.total_width / 2.0;

  // Far tags first, so that a nearer one covers them.
  std::vector<const MarkerTag*> order;
  for (const MarkerTag& tag : map.tags) order.push_back(&tag);
  std::stable_sort(order.begin(), order.end(), [&](const MarkerTag* a, const MarkerTag* b) {
    return (a->t_site_from_tag - centre).norm() > (b->t_site_from_tag - centre).norm();
  });

  const int S = options.supersampling;
  for (const MarkerTag* tag : order) {
    const Eigen::Matrix3d R_st = tag->R_site_from_tag.toRotationMatrix();
    const Vec3 normal = R_st.col(2);
    if (normal.dot(centre - tag->t_site_from_tag) <= 0) continue;  // seen from behind
    const std::vector<unsigned char> pattern = tag_pattern(map.family, tag->id);
    const double cell = tag->size / layout.width_at_border;
    const double half_paper = (half_pattern_cells + options.paper_margin_cells) * cell;
    std::array<Vec3, 4> paper;
    for (int k = 0; k < 4; ++k) {
      paper[static_cast<std::size_t>(k)] = R_st * tag_corner_in_tag(2 * half_paper, k) + tag->t_site_from_tag;
    }
    const PixelBox box = tag_box(paper, camera_from_site, centre, lens, width, height);
    const double plane_offset = normal.dot(tag->t_site_from_tag - centre);
    if (box.x1 < box.x0 || box.y1 < box.y0) continue;
    // The rays through the pixels' corners (one unprojection each); a sample's ray is the
    // bilinear blend of its pixel's four: over one pixel the lens mapping is linear to far below
    // a thousandth of a pixel, and the lens model is 16 times cheaper to call.
    const int lattice_width = box.x1 - box.x0 + 2, lattice_height = box.y1 - box.y0 + 2;
    std::vector<Vec3> rays(static_cast<std::size_t>(lattice_width) * static_cast<std::size_t>(lattice_height));
    std::vector<unsigned char> valid(rays.size(), 0);
    for (int j = 0; j < lattice_height; ++j) {
      for (int i = 0; i < lattice_width; ++i) {
        const std::size_t index = static_cast<std::size_t>(j) * static_cast<std::size_t>(lattice_width) + static_cast<std::size_t>(i);
        if (const std::optional<Vec3> ray = lens.unproject(Vec2(box.x0 - 0.5 + i, box.y0 - 0.5 + j))) {
          rays[index] = site_from_camera * *ray;
          valid[index] = 1;
        }
      }
    }
    for (int y = box.y0; y <= box.y1; ++y) {
      for (int x = box.x0; x <= box.x1; ++x) {
        const std::size_t corner = static_cast<std::size_t>(y - box.y0) * static_cast<std::size_t>(lattice_width) +
                                   static_cast<std::size_t>(x - box.x0);
        const std::size_t below = corner + static_cast<std::size_t>(lattice_width);
        const double before = grey(y, x);
        if (!(valid[corner] && valid[corner + 1] && valid[below] && valid[below + 1])) continue;
        const Vec3 &r00 = rays[corner], &r10 = rays[corner + 1], &r01 = rays[below], &r11 = rays[below + 1];
        double sum = 0;
        for (int sy = 0; sy < S; ++sy) {
          const double v = (sy + 0.5) / S;
          for (int sx = 0; sx < S; ++sx) {
            const double u = (sx + 0.5) / S;
            const Vec3 direction = (1 - v) * ((1 - u) * r00 + u * r10) + v * ((1 - u) * r01 + u * r11);
            double value = before;
            const double along = normal.dot(direction);
            const double distance = along != 0 ? plane_offset / along : -1;
            if (distance > 0) {
              const Vec3 local = R_st.transpose() * (centre + distance * direction - tag->t_site_from_tag);
              if (std::abs(local.x()) <= half_paper && std::abs(local.y()) <= half_paper) {
                value = options.white;
                const double column = local.x() / cell + half_pattern_cells;
                const double row = half_pattern_cells - local.y() / cell;  // row 0 at the top
                if (column >= 0 && column < layout.total_width && row >= 0 && row < layout.total_width) {
                  const std::size_t index = static_cast<std::size_t>(row) * static_cast<std::size_t>(layout.total_width) +
                                            static_cast<std::size_t>(column);
                  value = pattern[index] != 0 ? options.white : options.black;
                }
              }
            }
            sum += value;
          }
        }
        grey(y, x) = static_cast<float>(sum / (S * S));
      }
    }
  }
  if (options.noise_sigma > 0) {
    cv::Mat1f noise(height, width);
    cv::RNG rng(options.seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_sigma);
    grey += noise;
  }
  cv::Mat frame;
  grey.convertTo(frame, CV_8U);  // rounds and saturates
  return frame;
}

}  // namespace skylit::track
