#include "skylit/calib/intrinsics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>
#include <utility>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "skylit/base/error.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/radiometry.hpp"
#include "printf_text.hpp"

namespace skylit::calib {
namespace {

namespace fs = std::filesystem;

std::string names_of(const std::vector<RejectedView>& rejected) {
  std::string text;
  for (const RejectedView& r : rejected) {
    if (!text.empty()) text += "; ";
    text += r.name + " (" + r.reason + ")";
  }
  return text;
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

struct Solution {
  camera::CameraCalibration calibration;
  std::vector<double> view_rms;  // per view, pixels
  double rms = 0;
};

// The view index in OpenCV's "CALIB_CHECK_COND - Ill-conditioned matrix for input array N".
std::optional<std::size_t> ill_conditioned_view(const cv::Exception& e) {
  const std::string marker = "input array ";
  const std::size_t at = e.err.find(marker);
  if (e.err.find("CALIB_CHECK_COND") == std::string::npos || at == std::string::npos) return std::nullopt;
  try {
    return static_cast<std::size_t>(std::stoul(e.err.substr(at + marker.size())));
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// One run of the optimiser; the per-view errors are recomputed by projecting the board through
// the result (OpenCV's definition: RMS over the view's corners of the pixel distance).
Solution solve(const std::vector<NamedView>& views, cv::Size image_size, camera::LensModel model) {
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> image;
  for (const NamedView& v : views) {
    object.push_back(v.view.object);
    image.push_back(v.view.image);
  }
  cv::Mat K, D;
  std::vector<cv::Mat> rvecs, tvecs;
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12);
  if (model == camera::LensModel::Fisheye) {
    // CHECK_COND names an ill-conditioned view (a board too small, too far or seen edge-on)
    // instead of letting it spoil the others: the caller drops it and runs again.
    const int flags = cv::fisheye::CALIB_RECOMPUTE_EXTRINSIC | cv::fisheye::CALIB_FIX_SKEW | cv::fisheye::CALIB_CHECK_COND;
    cv::fisheye::calibrate(object, image, image_size, K, D, rvecs, tvecs, flags, criteria);
  } else {
    cv::calibrateCamera(object, image, image_size, K, D, rvecs, tvecs, 0, criteria);
  }
  Solution s;
  camera::CameraCalibration& c = s.calibration;
  c.image_width = image_size.width;
  c.image_height = image_size.height;
  c.model = model;
  c.fx = K.at<double>(0, 0);
  c.fy = K.at<double>(1, 1);
  c.cx = K.at<double>(0, 2);
  c.cy = K.at<double>(1, 2);
  const cv::Mat d = D.reshape(1, 1);
  for (int k = 0; k < d.cols; ++k) c.D.push_back(d.at<double>(0, k));
  double total = 0;
  std::size_t count = 0;
  for (std::size_t v = 0; v < views.size(); ++v) {
    std::vector<cv::Point2f> projected;
    if (model == camera::LensModel::Fisheye) {
      cv::fisheye::projectPoints(object[v], projected, rvecs[v], tvecs[v], K, D);
    } else {
      cv::projectPoints(object[v], rvecs[v], tvecs[v], K, D, projected);
    }
    double sum = 0;
    for (std::size_t i = 0; i < projected.size(); ++i) {
      const cv::Point2f e = projected[i] - image[v][i];
      sum += static_cast<double>(e.x) * e.x + static_cast<double>(e.y) * e.y;
    }
    s.view_rms.push_back(std::sqrt(sum / static_cast<double>(std::max<std::size_t>(projected.size(), 1))));
    total += sum;
    count += projected.size();
  }
  s.rms = std::sqrt(total / static_cast<double>(std::max<std::size_t>(count, 1)));
  return s;
}

bool finite(const Solution& s) {
  bool ok = std::isfinite(s.rms) && std::isfinite(s.calibration.fx) && std::isfinite(s.calibration.fy) &&
            std::isfinite(s.calibration.cx) && std::isfinite(s.calibration.cy) && s.calibration.fx > 0 && s.calibration.fy > 0;
  for (double d : s.calibration.D) ok = ok && std::isfinite(d);
  return ok;
}

const char* const kMorePhotosFix =
    "take 10–20 sharp photos of the whole board, flat and rigid, from different angles and "
    "covering every part of the image (the corners and, for a fisheye, the rim), and check "
    "--board/--charuco and --square against the printed board";

[[noreturn]] void too_few(std::size_t usable, std::size_t total, int min_views, const std::vector<RejectedView>& rejected) {
  std::string problem = std::to_string(usable) + " usable view(s) of " + std::to_string(total) +
                        " photo(s); the calibration needs at least " + std::to_string(min_views);
  if (!rejected.empty()) problem += ". Not used: " + names_of(rejected);
  throw InputError(problem + ". Fix: " + kMorePhotosFix);
}

// The calibration with ill-conditioned views dropped one by one.
Solution solve_dropping_degenerate(std::vector<NamedView>& views, std::vector<RejectedView>& rejected, cv::Size image_size,
                                   const IntrinsicsOptions& options, std::size_t total) {
  for (;;) {
    if (static_cast<int>(views.size()) < options.min_views) too_few(views.size(), total, options.min_views, rejected);
    try {
      Solution s = solve(views, image_size, options.model);
      if (!finite(s)) {
        throw InputError("the optimiser did not converge (non-finite parameters) on " + std::to_string(views.size()) +
                         " view(s). Fix: " + kMorePhotosFix);
      }
      return s;
    } catch (const cv::Exception& e) {
      const std::optional<std::size_t> bad = ill_conditioned_view(e);
      if (!bad || *bad >= views.size()) {
        throw InputError("the calibration failed (" + e.err + ") on " + std::to_string(views.size()) +
                         " view(s). Fix: " + kMorePhotosFix);
      }
      rejected.push_back({views[*bad].name, "ill-conditioned: the board is too small, too far or seen edge-on"});
      views.erase(views.begin() + static_cast<std::ptrdiff_t>(*bad));
    }
  }
}

cv::Scalar view_colour(std::size_t index, std::size_t count) {
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(static_cast<double>(170 * index / std::max<std::size_t>(count, 1)), 230, 255));
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
  return {static_cast<double>(c[0]), static_cast<double>(c[1]), static_cast<double>(c[2])};
}

// 255 inside the convex hull of some view's corners.
cv::Mat covered_mask(cv::Size size, std::span<const NamedView> views) {
  cv::Mat covered(size, CV_8UC1, cv::Scalar(0));
  for (const NamedView& v : views) {
    std::vector<cv::Point2f> hull;
    cv::convexHull(v.view.image, hull);
    std::vector<cv::Point> polygon;
    for (const cv::Point2f& p : hull) polygon.emplace_back(cvRound(p.x), cvRound(p.y));
    if (polygon.size() >= 3) cv::fillConvexPoly(covered, polygon, cv::Scalar(255));
  }
  return covered;
}

}  // namespace

BoardPhotos detect_boards(std::span<const fs::path> photos, const BoardDetector& detector) {
  // Every photo is read and searched; then the size most photos have is the camera's, and a
  // stray picture of another size among them is listed as not used rather than failing them all.
  struct Seen {
    std::string name;
    cv::Size size;
    std::optional<BoardView> view;
    std::string reason;  // no board: why
  };
  std::vector<Seen> seen;
  BoardPhotos out;
  std::vector<std::pair<cv::Size, int>> counts;  // sizes in the order met, with their photos
  std::vector<cv::Mat> first_of_size;
  for (const fs::path& photo : photos) {
    const std::string name = photo.filename().string();
    cv::Mat image;
    try {
      image = sky::read_image(photo, cv::IMREAD_COLOR);
    } catch (const cv::Exception& e) {
      out.rejected.push_back({name, "unreadable: " + e.err});
      continue;
    }
    if (image.empty()) {
      out.rejected.push_back({name, fs::exists(photo) ? "not an image OpenCV can read" : "no such file"});
      continue;
    }
    const auto known = std::find_if(counts.begin(), counts.end(), [&](const auto& c) { return c.first == image.size(); });
    if (known == counts.end()) {
      counts.emplace_back(image.size(), 1);
      first_of_size.push_back(image);
    } else {
      ++known->second;
    }
    BoardDetection found = detector.detect(image);
    seen.push_back({name, image.size(), std::move(found.view), found.reason});
  }
  if (counts.empty()) return out;
  // The most common size; on a tie, the one met first.
  std::size_t chosen = 0;
  for (std::size_t k = 1; k < counts.size(); ++k) {
    if (counts[k].second > counts[chosen].second) chosen = k;
  }
  out.image_size = counts[chosen].first;
  out.first_image = first_of_size[chosen];
  const auto size_text = [](cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); };
  for (Seen& photo : seen) {
    if (photo.size != out.image_size) {
      out.rejected.push_back({photo.name, "its size " + size_text(photo.size) + " differs from the size most photos have, " +
                                              size_text(out.image_size) + " (" + std::to_string(counts[chosen].second) + " photos)"});
    } else if (!photo.view) {
      out.rejected.push_back({photo.name, photo.reason});
    } else {
      out.views.push_back({photo.name, std::move(*photo.view)});
    }
  }
  return out;
}

IntrinsicsResult calibrate_intrinsics(std::vector<NamedView> views, std::vector<RejectedView> rejected, cv::Size image_size,
                                      const IntrinsicsOptions& options) {
  const std::size_t total = views.size() + rejected.size();
  if (image_size.width < 1 || image_size.height < 1) too_few(0, total, options.min_views, rejected);
  Solution s = solve_dropping_degenerate(views, rejected, image_size, options, total);

  // Outlier views, once: their errors are measured against a solution they took part in.
  const double limit = std::max(options.outlier_factor * median(s.view_rms), options.outlier_floor_px);
  std::vector<NamedView> kept;
  std::vector<RejectedView> outliers;
  for (std::size_t v = 0; v < views.size(); ++v) {
    if (s.view_rms[v] > limit) {
      outliers.push_back(
          {views[v].name, format("reprojection error %.2f px", s.view_rms[v]) +
                              format(", over %.2f px (3× the median): blurred, or the board moved or bent", limit)});
    } else {
      kept.push_back(views[v]);
    }
  }
  if (!outliers.empty() && static_cast<int>(kept.size()) >= options.min_views) {
    rejected.insert(rejected.end(), outliers.begin(), outliers.end());
    views = std::move(kept);
    s = solve_dropping_degenerate(views, rejected, image_size, options, total);
  }

  IntrinsicsResult result;
  result.calibration = s.calibration;
  result.calibration.rms = s.rms;
  result.calibration.per_view_errors = s.view_rms;
  result.used = std::move(views);
  result.rejected = std::move(rejected);
  result.coverage = board_coverage(result.calibration, result.used);

  if (static_cast<int>(result.used.size()) < options.recommended_views) {
    result.advice.push_back("only " + std::to_string(result.used.size()) + " view(s) were used: take at least " +
                            std::to_string(options.recommended_views) +
                            " sharp photos of the board from different angles and distances");
  }
  if (result.coverage < options.min_coverage) {
    result.advice.push_back(
        format("the boards covered %.0f%% of the image", 100.0 * result.coverage) +
        format(" (aim for %.0f%% or more): add photos with the board near the edges and corners", 100.0 * options.min_coverage) +
        (options.model == camera::LensModel::Fisheye ? " and near the rim of the image circle" : "") +
        ", where the distortion is strongest (see the coverage image)");
  }
  if (s.rms > options.max_rms_px) {
    result.advice.push_back(format("the RMS reprojection error %.2f px", s.rms) +
                            format(" is above %.1f px: ", options.max_rms_px) +
                            "check that the board is flat and rigid and --square matches it, retake blurred or "
                            "out-of-focus photos (the worst views are listed first), and for a lens wider than about "
                            "120° use the fisheye model");
  }
  if (!result.rejected.empty()) {
    result.advice.push_back(std::to_string(result.rejected.size()) + " photo(s) were not used: " + names_of(result.rejected) +
                            "; retake them with the whole board in view, sharp and evenly lit");
  }
  return result;
}

double board_coverage(const camera::CameraCalibration& calibration, std::span<const NamedView> views) {
  const cv::Size size(calibration.image_width, calibration.image_height);
  const cv::Mat covered = covered_mask(size, views);
  // The pixels the lens sees, on a grid (about 200 samples across).
  const camera::Lens lens(calibration);
  const int step = std::max(1, std::min(size.width, size.height) / 200);
  std::size_t seen = 0, inside = 0;
  for (int y = step / 2; y < size.height; y += step) {
    for (int x = step / 2; x < size.width; x += step) {
      const auto d = lens.unproject(camera::Vec2(x, y));
      if (!d || d->z() <= 0.0) continue;
      ++seen;
      if (covered.at<std::uint8_t>(y, x)) ++inside;
    }
  }
  return seen ? static_cast<double>(inside) / static_cast<double>(seen) : 0.0;
}

cv::Mat draw_coverage(const IntrinsicsResult& result, const cv::Mat& background) {
  const camera::CameraCalibration& c = result.calibration;
  cv::Mat canvas(c.image_height, c.image_width, CV_8UC3, cv::Scalar(0, 0, 0));
  if (!background.empty() && background.cols == c.image_width && background.rows == c.image_height) {
    cv::Mat bgr;
    if (background.channels() == 1) {
      cv::cvtColor(background, bgr, cv::COLOR_GRAY2BGR);
    } else {
      bgr = background;
    }
    bgr.convertTo(canvas, CV_8UC3, 0.35);
  }
  // The covered area tinted, so that the gaps stand out.
  const cv::Mat covered = covered_mask(canvas.size(), result.used);
  cv::Mat tinted;
  cv::addWeighted(canvas, 0.75, cv::Mat(canvas.size(), CV_8UC3, cv::Scalar(40, 110, 40)), 0.25, 0.0, tinted);
  tinted.copyTo(canvas, covered);
  const double scale = std::max(c.image_width, c.image_height) / 1000.0;
  const int thick = std::max(1, static_cast<int>(std::lround(2 * scale)));
  cv::rectangle(canvas, cv::Point(0, 0), cv::Point(c.image_width - 1, c.image_height - 1), cv::Scalar(255, 255, 255), thick);
  if (c.model == camera::LensModel::Fisheye) {
    // The lens's 90° circle (its horizon when it looks at the zenith).
    const camera::Lens lens(c);
    std::vector<cv::Point> circle;
    for (int k = 0; k < 360; ++k) {
      const double a = k * std::numbers::pi / 180.0;
      if (const auto p = lens.project(camera::Vec3(std::cos(a), std::sin(a), 1e-9)))
        circle.emplace_back(cvRound(p->x()), cvRound(p->y()));
    }
    if (circle.size() > 2) cv::polylines(canvas, circle, true, cv::Scalar(160, 160, 160), thick, cv::LINE_AA);
  }
  const int radius = std::max(2, static_cast<int>(std::lround(3 * scale)));
  for (std::size_t v = 0; v < result.used.size(); ++v) {
    const cv::Scalar colour = view_colour(v, result.used.size());
    for (const cv::Point2f& p : result.used[v].view.image) cv::circle(canvas, p, radius, colour, cv::FILLED, cv::LINE_AA);
  }
  const std::string line1 =
      format("coverage %.0f%%", 100.0 * result.coverage) + " of the image, " + std::to_string(result.used.size()) + " view(s)";
  const std::string line2 =
      format("RMS %.3f px", c.rms.value_or(0.0)) + ", " + (c.model == camera::LensModel::Fisheye ? "fisheye" : "pinhole");
  const double font = 0.6 * std::max(scale, 0.6);
  const int text_thick = std::max(1, thick);
  const int height = static_cast<int>(std::lround(30 * std::max(scale, 0.6)));
  cv::putText(canvas, line1, {height / 2, height}, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(255, 255, 255), text_thick,
              cv::LINE_AA);
  cv::putText(canvas, line2, {height / 2, 2 * height}, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(255, 255, 255), text_thick,
              cv::LINE_AA);
  return canvas;
}

std::string intrinsics_yaml(const IntrinsicsResult& result, const std::string& summary) {
  std::ostringstream out;
  out << "# Written by " << summary << ", from " << result.used.size() << " view(s).\n"
      << "# R_site_from_camera is the identity here: `skylit-calib sky-orientation` sets it (from the\n"
      << "# sun in timestamped sky frames, or from a level and a compass bearing).\n"
      << camera::calibration_to_yaml(result.calibration) << "# per_view_errors follow the photos in this order:";
  for (const NamedView& v : result.used) out << " " << v.name;
  out << "\n";
  if (!result.rejected.empty()) {
    out << "# not used:\n";
    for (const RejectedView& r : result.rejected) out << "#   " << r.name << ": " << r.reason << "\n";
  }
  return out.str();
}

}  // namespace skylit::calib
