#include "skylit/sky/overlay.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "skylit/sky/image_io.hpp"
#include "skylit/sky/srgb.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {
namespace {

double luminance(const Eigen::Vector3d& rgb) { return 0.2126 * rgb.x() + 0.7152 * rgb.y() + 0.0722 * rgb.z(); }

// The face's outline in pixels: its three great-arc edges sampled finely enough to look round.
std::vector<cv::Point> outline(const camera::Lens& lens, const geom::SphericalTriangle& t) {
  constexpr int kStepsPerEdge = 24;
  const std::array<Vec3, 3> corners{t.a, t.b, t.c};
  std::vector<cv::Point> points;
  for (int e = 0; e < 3; ++e) {
    const Vec3& a = corners[static_cast<std::size_t>(e)];
    const Vec3& b = corners[static_cast<std::size_t>((e + 1) % 3)];
    for (int s = 0; s < kStepsPerEdge; ++s) {
      const double f = static_cast<double>(s) / kStepsPerEdge;
      // Nudged a hair above the horizon so that horizon edges still project.
      Vec3 d = ((1.0 - f) * a + f * b).normalized();
      d.z() = std::max(d.z(), 1e-6);
      const auto p = lens.site_to_pixel(d.normalized());
      if (!p) return {};
      points.emplace_back(static_cast<int>(std::lround((*p).x())), static_cast<int>(std::lround((*p).y())));
    }
  }
  return points;
}

}  // namespace

cv::Mat draw_sky_overlay(const camera::Lens& lens, const geom::Dome& dome, const cv::Mat& radiance,
                         const SkyEstimate& estimate) {
  cv::Mat picture = tone_map(radiance);
  const auto& faces = estimate.luminance.faces;

  // Tints share one scale: the brightest face is white-ish, a face of half its luminance half.
  double brightest = 0.0;
  for (const FaceLuminance& f : faces) brightest = std::max(brightest, luminance(f.rgb));
  const double scale = brightest > 0.0 ? 1.0 / brightest : 0.0;

  cv::Mat tint = picture.clone();
  cv::Mat unseen(picture.size(), CV_8UC1, cv::Scalar(0));
  std::vector<std::vector<cv::Point>> outlines(static_cast<std::size_t>(dome.face_count()));
  for (int i = 0; i < dome.face_count() && i < static_cast<int>(faces.size()); ++i) {
    auto& points = outlines[static_cast<std::size_t>(i)];
    points = outline(lens, dome.triangle(i));
    if (points.empty()) continue;
    const Eigen::Vector3d s = faces[static_cast<std::size_t>(i)].rgb * scale;
    cv::fillPoly(tint, std::vector<std::vector<cv::Point>>{points},
                 cv::Scalar(srgb_encode8(s.z()), srgb_encode8(s.y()), srgb_encode8(s.x())), cv::LINE_AA);
    if (faces[static_cast<std::size_t>(i)].flags & kFaceUnseen) {
      cv::fillPoly(unseen, std::vector<std::vector<cv::Point>>{points}, cv::Scalar(255));
    }
  }
  // Hatching marks the faces whose S was filled from their neighbours, not seen.
  cv::Mat hatch(picture.size(), CV_8UC1, cv::Scalar(0));
  for (int k = -picture.rows; k < picture.cols; k += 12) {
    cv::line(hatch, {k, 0}, {k + picture.rows, picture.rows}, cv::Scalar(255), 2);
  }
  tint.setTo(cv::Scalar(80, 80, 255), hatch & unseen);
  cv::addWeighted(picture, 0.45, tint, 0.55, 0.0, picture);

  const double font = std::max(0.35, picture.cols / 2400.0);
  for (int i = 0; i < dome.face_count(); ++i) {
    const auto& points = outlines[static_cast<std::size_t>(i)];
    if (points.empty()) continue;
    cv::polylines(picture, std::vector<std::vector<cv::Point>>{points}, true, cv::Scalar(235, 235, 235), 1, cv::LINE_AA);
    if (const auto c = lens.site_to_pixel(dome.face(i).centre)) {
      const std::string label = std::to_string(i);
      const cv::Size size = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, font, 1, nullptr);
      const cv::Point at(static_cast<int>((*c).x()) - size.width / 2, static_cast<int>((*c).y()) + size.height / 2);
      cv::putText(picture, label, at, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
      cv::putText(picture, label, at, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    }
  }
  if (estimate.sun) {
    if (const auto p = lens.site_to_pixel(estimate.sun->direction)) {
      const cv::Point centre(static_cast<int>(std::lround((*p).x())), static_cast<int>(std::lround((*p).y())));
      const int radius = std::max(8, picture.cols / 60);
      cv::circle(picture, centre, radius, cv::Scalar(0, 220, 255), 2, cv::LINE_AA);
      cv::putText(picture, "sun", centre + cv::Point(radius + 3, 0), cv::FONT_HERSHEY_SIMPLEX, font * 1.4,
                  cv::Scalar(0, 220, 255), 2, cv::LINE_AA);
    }
  }
  return picture;
}

}  // namespace skylit::sky
