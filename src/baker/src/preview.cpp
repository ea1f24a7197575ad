#include "skylit/baker/preview.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "skylit/base/files.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/sky/srgb.hpp"

namespace skylit::baker {
namespace fs = std::filesystem;

namespace {

// Map view of the dome: zenith in the middle, horizon on the rim, north up, east right
// (azimuthal equidistant projection).
cv::Point2d project(const geom::Vec3& d, cv::Point2d centre, double radius) {
  const double zenith = std::acos(std::clamp(d.z(), -1.0, 1.0));
  const double horizontal = std::hypot(d.x(), d.y());
  const double r = radius * zenith / (std::numbers::pi / 2);
  if (horizontal < 1e-12) return centre;
  return {centre.x + r * d.x() / horizontal, centre.y - r * d.y() / horizontal};
}

void write_png(const fs::path& file, const cv::Mat& image) {
  std::vector<unsigned char> png;
  cv::imencode(".png", image, png);
  write_file_atomic(file, std::span(reinterpret_cast<const std::byte*>(png.data()), png.size()));
}

// Visible fraction B/A as 8-bit grey, texel row 0 at the top (the bake's texel convention).
cv::Mat fraction_image(std::span<const float> layer, int width, int height, double unoccluded) {
  cv::Mat grey(height, width, CV_8UC1);
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      const double f = layer[static_cast<std::size_t>(row) * width + col] / unoccluded;
      grey.at<unsigned char>(row, col) = cv::saturate_cast<unsigned char>(255.0 * std::clamp(f, 0.0, 1.0));
    }
  }
  return grey;
}

void draw_arc(cv::Mat& canvas, const geom::Vec3& a, const geom::Vec3& b, cv::Point2d centre, double radius,
              const cv::Scalar& colour) {
  constexpr int kSteps = 16;
  cv::Point2d previous = project(a, centre, radius);
  for (int s = 1; s <= kSteps; ++s) {
    const double t = static_cast<double>(s) / kSteps;
    const geom::Vec3 p = ((1 - t) * a + t * b).normalized();
    const cv::Point2d next = project(p, centre, radius);
    cv::line(canvas, previous, next, colour, 1, cv::LINE_AA);
    previous = next;
  }
}

}  // namespace

void write_plane_previews(const fs::path& preview_dir, const bake_format::Manifest& manifest, int plane,
                          const bake_format::ImageStack& layers) {
  const bake_format::PlaneRecord& layer_record = manifest.planes.at(static_cast<std::size_t>(plane));
  const int n = static_cast<int>(manifest.faces.size());
  // One picture per face: a corners bake shows the sum of its three layers (B_f = Σ_k B_{f,k}).
  const int per_face = manifest.plan.layers_per_face();
  bake_format::ImageStack summed;
  bake_format::PlaneRecord record = layer_record;
  if (per_face > 1) {
    summed.width = layers.width;
    summed.height = layers.height;
    summed.layers = n;
    summed.data.assign(static_cast<std::size_t>(layers.width) * layers.height * static_cast<std::size_t>(n), 0.0f);
    record.unoccluded.assign(static_cast<std::size_t>(n), 0.0);
    for (int l = 0; l < layers.layers; ++l) {
      const std::span<const float> from = layers.layer(l);
      const std::span<float> to = summed.layer(l / per_face);
      for (std::size_t t = 0; t < to.size(); ++t) to[t] += from[t];
      record.unoccluded[static_cast<std::size_t>(l / per_face)] += layer_record.unoccluded[static_cast<std::size_t>(l)];
    }
  }
  const bake_format::ImageStack& basis = per_face > 1 ? summed : layers;

  // Contact sheet: each face's basis image at its place on the dome.
  const int nu = manifest.plan.frequency;
  const int size = std::min(4200, 500 + 330 * nu);
  const double radius = size * 0.44;
  const cv::Point2d centre(size / 2.0, size / 2.0 + 20);
  cv::Mat canvas(size + 40, size, CV_8UC3, cv::Scalar(40, 40, 40));

  double nearest = std::numeric_limits<double>::infinity();
  std::vector<cv::Point2d> centres;
  for (const bake_format::FaceRecord& f : manifest.faces) centres.push_back(project(f.direction, centre, radius));
  for (std::size_t a = 0; a < centres.size(); ++a) {
    for (std::size_t b = a + 1; b < centres.size(); ++b) nearest = std::min(nearest, cv::norm(centres[a] - centres[b]));
  }
  const double tile = std::max(12.0, 0.78 * nearest);
  const double aspect = static_cast<double>(basis.width) / basis.height;
  const cv::Size thumb_size = aspect >= 1 ? cv::Size(static_cast<int>(tile), std::max(1, static_cast<int>(tile / aspect)))
                                          : cv::Size(std::max(1, static_cast<int>(tile * aspect)), static_cast<int>(tile));

  for (const bake_format::FaceRecord& f : manifest.faces) {
    for (int k = 0; k < 3; ++k) {
      draw_arc(canvas, f.vertices[static_cast<std::size_t>(k)], f.vertices[static_cast<std::size_t>((k + 1) % 3)],
               centre, radius, cv::Scalar(90, 90, 90));
    }
  }
  cv::circle(canvas, centre, static_cast<int>(radius), cv::Scalar(140, 140, 140), 1, cv::LINE_AA);
  for (int i = 0; i < n; ++i) {
    const double a = record.unoccluded[static_cast<std::size_t>(i)];
    cv::Mat thumb;
    if (a > 0) {
      cv::resize(fraction_image(basis.layer(i), basis.width, basis.height, a), thumb, thumb_size, 0, 0, cv::INTER_AREA);
      cv::cvtColor(thumb, thumb, cv::COLOR_GRAY2BGR);
    } else {
      // The plane faces away from this face: no light, no image.
      thumb = cv::Mat(thumb_size, CV_8UC3, cv::Scalar(30, 30, 90));
      cv::line(thumb, {0, 0}, {thumb.cols - 1, thumb.rows - 1}, cv::Scalar(60, 60, 160), 1);
      cv::line(thumb, {thumb.cols - 1, 0}, {0, thumb.rows - 1}, cv::Scalar(60, 60, 160), 1);
    }
    const cv::Point top_left(static_cast<int>(centres[static_cast<std::size_t>(i)].x - thumb.cols / 2.0),
                             static_cast<int>(centres[static_cast<std::size_t>(i)].y - thumb.rows / 2.0));
    const cv::Rect target = cv::Rect(top_left, thumb.size()) & cv::Rect(0, 0, canvas.cols, canvas.rows);
    thumb(cv::Rect(target.tl() - top_left, target.size())).copyTo(canvas(target));
    cv::rectangle(canvas, target, cv::Scalar(0, 160, 220), 1);
    cv::putText(canvas, std::to_string(i), target.tl() + cv::Point(2, 11), cv::FONT_HERSHEY_PLAIN, 0.8,
                cv::Scalar(0, 200, 255), 1, cv::LINE_AA);
  }
  const auto label = [&](const char* text, const geom::Vec3& d) {
    const cv::Point2d p = project(d, centre, radius * 1.06);
    cv::putText(canvas, text, p - cv::Point2d(6, -6), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(220, 220, 220), 1,
                cv::LINE_AA);
  };
  label("N", {0, 1, 0});
  label("E", {1, 0, 0});
  label("S", {0, -1, 0});
  label("W", {-1, 0, 0});
  const std::string title = "plane '" + record.plane.name + "'  " + std::to_string(basis.width) + "x" +
                            std::to_string(basis.height) + "  dome nu=" + std::to_string(nu) + " (" +
                            std::to_string(n) + " faces)  " + std::to_string(manifest.plan.samples) +
                            " sample(s)/face  " + manifest.plan.method + "  " +
                            std::string(geom::basis_name(manifest.plan.basis)) + "   white = lit (B/A = 1)";
  cv::putText(canvas, title, {12, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(235, 235, 235), 1, cv::LINE_AA);
  write_png(preview_dir / (record.plane.name + ".png"), canvas);

  // The plane under a uniform sky: T = Σ_i B_i / Σ_i A_i.
  double total_a = 0;
  for (double a : record.unoccluded) total_a += a;
  cv::Mat uniform(basis.height, basis.width, CV_8UC1, cv::Scalar(0));
  if (total_a > 0) {
    std::vector<double> sum(static_cast<std::size_t>(basis.width) * basis.height, 0.0);
    for (int i = 0; i < n; ++i) {
      const std::span<const float> layer = basis.layer(i);
      for (std::size_t t = 0; t < sum.size(); ++t) sum[t] += layer[t];
    }
    for (int row = 0; row < basis.height; ++row) {
      for (int col = 0; col < basis.width; ++col) {
        const double t = sum[static_cast<std::size_t>(row) * basis.width + col] / total_a;
        uniform.at<unsigned char>(row, col) = cv::saturate_cast<unsigned char>(255.0 * std::clamp(t, 0.0, 1.0));
      }
    }
  }
  write_png(preview_dir / (record.plane.name + "_uniform_sky.png"), uniform);
}

void write_vertex_picture(const fs::path& file, const scene::Mesh& mesh, std::span<const Eigen::Vector3d> linear_rgb,
                          double white, const std::string& caption, int width) {
  if (linear_rgb.size() != mesh.vertex_count()) throw std::invalid_argument("write_vertex_picture: one colour per vertex");
  const int height = width * 3 / 4, caption_rows = 28;
  cv::Mat image(height + caption_rows, width, CV_8UC3, cv::Scalar(48, 48, 48));
  if (mesh.vertex_count() > 0) {
    // The camera: on a sphere round the model's box, from the south-west and 20° up, looking at
    // its centre with a 40° vertical field of view.
    const Eigen::Vector3d lo = mesh.bounds_min().cast<double>(), hi = mesh.bounds_max().cast<double>();
    const Eigen::Vector3d centre = 0.5 * (lo + hi);
    const double radius = std::max(0.5 * (hi - lo).norm(), 1e-6);
    const double fov = 40 * std::numbers::pi / 180, elevation = 20 * std::numbers::pi / 180;
    const double azimuth = 225 * std::numbers::pi / 180;  // from north towards east: south-west
    const Eigen::Vector3d back(std::sin(azimuth) * std::cos(elevation), std::cos(azimuth) * std::cos(elevation), std::sin(elevation));
    const Eigen::Vector3d eye = centre + back * (radius / std::sin(fov / 2));
    const Eigen::Vector3d forward = (centre - eye).normalized();
    const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d up = right.cross(forward);
    const double focal = 0.5 * height / std::tan(fov / 2);
    std::vector<Eigen::Vector3d> screen(mesh.vertex_count());  // x, y pixels; z depth
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
      const Eigen::Vector3d d = mesh.positions[v].cast<double>() - eye;
      const double z = d.dot(forward);
      screen[v] = Eigen::Vector3d(0.5 * width + focal * d.dot(right) / z, 0.5 * height - focal * d.dot(up) / z, z);
    }
    std::vector<double> depth(static_cast<std::size_t>(width) * height, std::numeric_limits<double>::infinity());
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
      const std::uint32_t* index = &mesh.indices[3 * t];
      const Eigen::Vector3d &a = screen[index[0]], &b = screen[index[1]], &c = screen[index[2]];
      if (a.z() <= 1e-6 || b.z() <= 1e-6 || c.z() <= 1e-6) continue;  // behind the camera: the view holds the model
      const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
      if (std::abs(area) < 1e-12) continue;
      const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x(), b.x(), c.x()}))));
      const int x1 = std::min(width - 1, static_cast<int>(std::ceil(std::max({a.x(), b.x(), c.x()}))));
      const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y(), b.y(), c.y()}))));
      const int y1 = std::min(height - 1, static_cast<int>(std::ceil(std::max({a.y(), b.y(), c.y()}))));
      for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) {
          const double px = x + 0.5, py = y + 0.5;
          const double wa = ((b.x() - px) * (c.y() - py) - (b.y() - py) * (c.x() - px)) / area;
          const double wb = ((c.x() - px) * (a.y() - py) - (c.y() - py) * (a.x() - px)) / area;
          const double wc = 1 - wa - wb;
          if (wa < 0 || wb < 0 || wc < 0) continue;
          // Perspective-correct: interpolate 1/z and the colour over z.
          const double inverse_z = wa / a.z() + wb / b.z() + wc / c.z();
          const double z = 1 / inverse_z;
          double& nearest = depth[static_cast<std::size_t>(y) * width + x];
          if (z >= nearest) continue;
          nearest = z;
          const Eigen::Vector3d rgb = z * (wa / a.z() * linear_rgb[index[0]] + wb / b.z() * linear_rgb[index[1]] +
                                           wc / c.z() * linear_rgb[index[2]]);
          image.at<cv::Vec3b>(y, x) =
              cv::Vec3b(sky::srgb_encode8(rgb.z() / white), sky::srgb_encode8(rgb.y() / white), sky::srgb_encode8(rgb.x() / white));
        }
      }
    }
  }
  cv::putText(image, caption, {8, height + 19}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(230, 230, 230), 1, cv::LINE_AA);
  write_png(file, image);
}

}  // namespace skylit::baker
