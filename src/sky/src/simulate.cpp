// Sky simulation: equirect geometry, rendering a sky camera's view of an equirect or of an
// analytic sky (with the sun's disc deposited by overlap), 8-bit clipping.
#include "skylit/sky/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/sky_table.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/sky/srgb.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/geom/angles.hpp"

namespace skylit::sky {
namespace {

using geom::kPi;
constexpr int kMaxSupersample = 16;

void check_options(const RenderOptions& options) {
  if (options.supersample < 1 || options.supersample > kMaxSupersample) {
    throw std::invalid_argument("render: supersample " + std::to_string(options.supersample) +
                                " outside 1.." + std::to_string(kMaxSupersample));
  }
  if (!std::isfinite(options.azimuth_offset)) throw std::invalid_argument("render: azimuth offset not finite");
}

// Sub-pixel offset of sample i of s along one axis, from the pixel centre.
double sub_offset(int i, int s) { return (i + 0.5) / s - 0.5; }

// Rotation about z that lowers a direction's azimuth by `offset` (azimuth is clockwise from
// above, so this is a counter-clockwise turn by `offset`).
Vec3 turn_azimuth(const Vec3& d, double offset) {
  const double c = std::cos(offset);
  const double s = std::sin(offset);
  return {d.x() * c - d.y() * s, d.y() * c + d.x() * s, d.z()};
}

// Bilinear lookup, wrapped in azimuth (columns) and clamped in elevation (rows); RGB.
Eigen::Vector3d sample_equirect(const cv::Mat& equirect, const Vec2& p) {
  const int w = equirect.cols;
  const int h = equirect.rows;
  const double fx0 = std::floor(p.x());
  const double fy0 = std::floor(p.y());
  const double tx = p.x() - fx0;
  const double ty = p.y() - fy0;
  const auto wrap = [w](long long x) { return static_cast<int>(((x % w) + w) % w); };
  const int x0 = wrap(static_cast<long long>(fx0));
  const int x1 = wrap(static_cast<long long>(fx0) + 1);
  const int y0 = std::clamp(static_cast<int>(fy0), 0, h - 1);
  const int y1 = std::clamp(static_cast<int>(fy0) + 1, 0, h - 1);
  const auto* r0 = equirect.ptr<cv::Vec3f>(y0);
  const auto* r1 = equirect.ptr<cv::Vec3f>(y1);
  Eigen::Vector3d rgb;
  for (int c = 0; c < 3; ++c) {
    const double top = (1 - tx) * r0[x0][c] + tx * r0[x1][c];
    const double bottom = (1 - tx) * r1[x0][c] + tx * r1[x1][c];
    rgb[2 - c] = (1 - ty) * top + ty * bottom;  // BGR → RGB
  }
  return rgb;
}

void store_rgb(cv::Vec3f& pixel, const Eigen::Vector3d& rgb) {
  pixel = cv::Vec3f(static_cast<float>(rgb.z()), static_cast<float>(rgb.y()), static_cast<float>(rgb.x()));
}

// Where the disc lands: integer pixel of a direction (nullopt when it cannot be imaged or
// falls outside the image), and the solid angle of that pixel.
struct DiscTarget {
  int width = 0;
  int height = 0;
  std::function<std::optional<Vec2>(const Vec3&)> project;   // continuous pixel position
  std::function<double(int x, int y)> pixel_solid_angle;     // 0: the pixel cannot take energy
  bool wrap_x = false;                                       // equirect: azimuth wraps
};

// Deposits the disc's irradiance into `image` (CV_32FC3 BGR): the disc is cut into N equal
// solid-angle cells (rings uniform in cos α, sectors in φ), each cell's share E/N goes to the
// pixel its centre falls in, as radiance share / Ω_p. So Σ L_p Ω_p over the disc's pixels is E
// times the fraction of cells that land (1 when the disc is above the horizon and in view).
void deposit_disc(cv::Mat& image, const SunDisc& disc, const DiscTarget& target) {
  const Vec3 d = disc.direction.normalized();
  const Vec3 helper = std::abs(d.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX();
  const Vec3 u = d.cross(helper).normalized();
  const Vec3 v = d.cross(u);
  const double r = disc.angular_radius;

  // Enough cells for ≥ 64 per pixel the disc touches, never fewer than 64².
  double radius_px = 1.0;
  if (const auto centre = target.project(d)) {
    for (const Vec3& edge : {Vec3(std::cos(r) * d + std::sin(r) * u), Vec3(std::cos(r) * d + std::sin(r) * v)}) {
      if (const auto p = target.project(edge)) radius_px = std::max(radius_px, (*p - *centre).norm());
    }
  }
  const double cells = 64.0 * kPi * (radius_px + 1.0) * (radius_px + 1.0);
  const int n = std::clamp(static_cast<int>(std::ceil(std::sqrt(cells))), 64, 2048);
  const double cos_r = std::cos(r);

  std::map<std::pair<int, int>, int> hits;  // (y, x) → cells
  for (int i = 0; i < n; ++i) {
    const double cos_a = 1.0 - (i + 0.5) / n * (1.0 - cos_r);
    const double sin_a = std::sqrt(std::max(0.0, 1.0 - cos_a * cos_a));
    for (int j = 0; j < n; ++j) {
      // Alternate rings are turned by half a sector so that cells do not line up radially.
      const double phi = 2.0 * kPi * (j + 0.5 + 0.5 * (i % 2)) / n;
      const Vec3 dir = cos_a * d + sin_a * (std::cos(phi) * u + std::sin(phi) * v);
      if (dir.z() <= 0) continue;  // the part of the disc below the horizon is not seen
      const auto p = target.project(dir);
      if (!p) continue;
      int x = static_cast<int>(std::floor(p->x() + 0.5));
      const int y = static_cast<int>(std::floor(p->y() + 0.5));
      if (target.wrap_x) x = ((x % target.width) + target.width) % target.width;
      if (x < 0 || y < 0 || x >= target.width || y >= target.height) continue;
      ++hits[{y, x}];
    }
  }
  const double total = static_cast<double>(n) * n;
  for (const auto& [pixel, count] : hits) {
    const double omega = target.pixel_solid_angle(pixel.second, pixel.first);
    if (!(omega > 0)) continue;
    const Eigen::Vector3d add = disc.irradiance * (count / total / omega);
    cv::Vec3f& out = image.at<cv::Vec3f>(pixel.first, pixel.second);
    for (int c = 0; c < 3; ++c) out[c] += static_cast<float>(add[2 - c]);
  }
}

// Each pixel of the lens's image whose centre unprojects: the mean radiance over its
// sub-pixel site directions that unproject; other pixels stay 0. Rows run in parallel, so
// `radiance` is called from several threads at once.
cv::Mat render_lens(const camera::Lens& lens, const RenderOptions& options,
                    const std::function<Eigen::Vector3d(const Vec3&)>& radiance) {
  check_options(options);
  const auto& cal = lens.calibration();
  if (cal.image_width <= 0 || cal.image_height <= 0) throw std::invalid_argument("render_fisheye: empty calibration");
  cv::Mat out(cal.image_height, cal.image_width, CV_32FC3, cv::Scalar::all(0));
  const int s = options.supersample;
  cv::parallel_for_(cv::Range(0, out.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      auto* row = out.ptr<cv::Vec3f>(y);
      for (int x = 0; x < out.cols; ++x) {
        if (!lens.pixel_to_site(Vec2(x, y))) continue;
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        int count = 0;
        for (int j = 0; j < s; ++j) {
          for (int i = 0; i < s; ++i) {
            const auto d = lens.pixel_to_site(Vec2(x + sub_offset(i, s), y + sub_offset(j, s)));
            if (!d) continue;
            sum += radiance(*d);
            ++count;
          }
        }
        if (count > 0) store_rgb(row[x], sum / count);
      }
    }
  });
  return out;
}

double lens_pixel_solid_angle(const camera::Lens& lens, int x, int y) {
  return block_solid_angle(lens, x - 0.5, y - 0.5, x + 0.5, y + 0.5);
}

void check_equirect(const cv::Mat& equirect) {
  if (equirect.empty() || equirect.type() != CV_32FC3 || equirect.cols < 2 || equirect.rows < 2) {
    throw std::invalid_argument("render_fisheye: the equirect must be a CV_32FC3 image of at least 2 x 2 pixels");
  }
}

}  // namespace

Vec3 equirect_direction(int width, int height, double x, double y) {
  const double azimuth = 2.0 * kPi * (x + 0.5) / width - kPi;
  const double elevation = kPi / 2 - kPi * (y + 0.5) / height;
  const double c = std::cos(elevation);
  return {std::sin(azimuth) * c, std::cos(azimuth) * c, std::sin(elevation)};
}

Vec2 equirect_pixel(int width, int height, const Vec3& site_direction) {
  const double length = site_direction.norm();
  const double elevation = std::asin(std::clamp(site_direction.z() / length, -1.0, 1.0));
  double azimuth = std::atan2(site_direction.x(), site_direction.y());  // from north towards east
  double x = (azimuth + kPi) / (2.0 * kPi) * width - 0.5;
  if (x >= width - 0.5) x -= width;  // azimuth π and −π are the same column edge
  const double y = (kPi / 2 - elevation) / kPi * height - 0.5;
  return {x, y};
}

double equirect_pixel_solid_angle(int width, int height, int row) {
  const double top = kPi / 2 - kPi * row / height;
  const double bottom = kPi / 2 - kPi * (row + 1) / height;
  return 2.0 * kPi / width * (std::sin(top) - std::sin(bottom));
}

SkyFunction sky_function(const ClearSky& sky) {
  SkyFunction f;
  f.sky = [sky](const Vec3& d) { return sky.sky_radiance(d); };
  if (sky.sun().irradiance.maxCoeff() > 0) f.sun = sky.sun();
  return f;
}

SkyFunction sky_function(const OvercastSky& sky) {
  SkyFunction f;
  f.sky = [sky](const Vec3& d) { return sky.radiance(d); };
  return f;
}

SkyFunction analytic_sky(const AnalyticSkySettings& settings, std::chrono::sys_seconds utc) {
  if (settings.kind == AnalyticSkySettings::Kind::Overcast) {
    return sky_function(OvercastSky(settings.zenith_radiance));
  }
  const SolarPosition sun = solar_position(utc, settings.latitude_deg, settings.longitude_deg);
  return sky_function(ClearSky(sun.direction(), settings.turbidity));
}

cv::Mat read_equirect(const std::filesystem::path& file) {
  const cv::Mat image = read_sky_image(file);
  if (image.depth() == CV_32F) return image;
  const int bits = image.depth() == CV_16U ? 16 : 8;
  return linearise(image, ResponseCurve::srgb(bits), Exposure{}).radiance;
}

cv::Mat render_fisheye(const camera::Lens& lens, const cv::Mat& equirect, const RenderOptions& options) {
  check_equirect(equirect);
  const double offset = options.azimuth_offset;
  return render_lens(lens, options, [&](const Vec3& d) {
    return sample_equirect(equirect, equirect_pixel(equirect.cols, equirect.rows, turn_azimuth(d, offset)));
  });
}

cv::Mat render_fisheye(const camera::Lens& lens, const SkyFunction& sky, const RenderOptions& options) {
  if (!sky.sky) throw std::invalid_argument("render_fisheye: the sky function is empty");
  cv::Mat out = render_lens(lens, options, sky.sky);
  if (sky.sun) {
    DiscTarget target;
    target.width = out.cols;
    target.height = out.rows;
    target.project = [&](const Vec3& d) { return lens.site_to_pixel(d); };
    target.pixel_solid_angle = [&](int x, int y) {
      return lens.pixel_to_site(Vec2(x, y)) ? lens_pixel_solid_angle(lens, x, y) : 0.0;
    };
    deposit_disc(out, *sky.sun, target);
  }
  return out;
}

cv::Mat render_equirect(const SkyFunction& sky, int width, int height, const RenderOptions& options) {
  check_options(options);
  if (!sky.sky) throw std::invalid_argument("render_equirect: the sky function is empty");
  if (width < 2 || height < 2) throw std::invalid_argument("render_equirect: size under 2 x 2");
  cv::Mat out(height, width, CV_32FC3, cv::Scalar::all(0));
  const int s = options.supersample;
  cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      auto* row = out.ptr<cv::Vec3f>(y);
      for (int x = 0; x < width; ++x) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (int j = 0; j < s; ++j) {
          for (int i = 0; i < s; ++i) {
            sum += sky.sky(equirect_direction(width, height, x + sub_offset(i, s), y + sub_offset(j, s)));
          }
        }
        store_rgb(row[x], sum / (s * s));
      }
    }
  });
  if (sky.sun) {
    DiscTarget target;
    target.width = width;
    target.height = height;
    target.wrap_x = true;
    target.project = [&](const Vec3& d) { return std::optional<Vec2>(equirect_pixel(width, height, d)); };
    target.pixel_solid_angle = [&](int, int y) { return equirect_pixel_solid_angle(width, height, y); };
    deposit_disc(out, *sky.sun, target);
  }
  return out;
}

double auto_exposure_scale(const cv::Mat& radiance, const cv::Mat& sky, double median_fraction) {
  if (!(median_fraction > 0.0 && median_fraction <= 1.0)) throw std::invalid_argument("auto_exposure_scale: fraction outside (0, 1]");
  if (radiance.type() != CV_32FC3 || sky.type() != CV_8UC1 || sky.size() != radiance.size()) {
    throw std::invalid_argument("auto_exposure_scale: a CV_32FC3 frame and a CV_8U sky mask of its size");
  }
  std::vector<double> values;
  for (int y = 0; y < radiance.rows; ++y) {
    const auto* in = radiance.ptr<cv::Vec3f>(y);
    const auto* seen = sky.ptr<std::uint8_t>(y);
    for (int x = 0; x < radiance.cols; ++x) {
      if (!seen[x]) continue;
      const double l = 0.0722 * in[x][0] + 0.7152 * in[x][1] + 0.2126 * in[x][2];
      if (std::isfinite(l)) values.push_back(l);
    }
  }
  if (values.empty()) throw std::invalid_argument("auto_exposure_scale: no sky pixels");
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  if (!(*mid > 0.0)) throw std::invalid_argument("auto_exposure_scale: the sky's median is not above 0");
  return median_fraction / *mid;
}

cv::Mat to_8bit(const cv::Mat& radiance, double exposure_scale) {
  if (radiance.empty() || radiance.type() != CV_32FC3) throw std::invalid_argument("to_8bit: not a CV_32FC3 image");
  if (!std::isfinite(exposure_scale) || exposure_scale <= 0) {
    throw std::invalid_argument("to_8bit: exposure scale must be finite and > 0");
  }
  // sRGB encoding of every 16-bit linear level: a table, instead of pow per channel.
  constexpr int kLevels = 1 << 16;
  std::vector<std::uint8_t> encode(kLevels);
  for (int i = 0; i < kLevels; ++i) {
    encode[static_cast<std::size_t>(i)] = srgb_encode8(static_cast<double>(i) / (kLevels - 1));
  }
  cv::Mat out(radiance.size(), CV_8UC3);
  for (int y = 0; y < radiance.rows; ++y) {
    const auto* in = radiance.ptr<cv::Vec3f>(y);
    auto* o = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < radiance.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        const double v = in[x][c] * exposure_scale;
        const double clipped = v > 0 ? std::min(v, 1.0) : 0.0;  // NaN and negatives → 0
        o[x][c] = encode[static_cast<std::size_t>(std::lround(clipped * (kLevels - 1)))];
      }
    }
  }
  return out;
}

Eigen::Vector3d fisheye_hemisphere_energy(const camera::Lens& lens, const cv::Mat& radiance) {
  const auto& cal = lens.calibration();
  if (radiance.type() != CV_32FC3 || radiance.cols != cal.image_width || radiance.rows != cal.image_height) {
    throw std::invalid_argument("fisheye_hemisphere_energy: not a CV_32FC3 image of the calibration's size");
  }
  std::vector<Eigen::Vector3d> row_sums(static_cast<std::size_t>(radiance.rows), Eigen::Vector3d::Zero());
  cv::parallel_for_(cv::Range(0, radiance.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const auto* row = radiance.ptr<cv::Vec3f>(y);
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (int x = 0; x < radiance.cols; ++x) {
        const auto d = lens.pixel_to_site(Vec2(x, y));
        if (!d || d->z() <= 0) continue;
        const Eigen::Vector3d rgb(row[x][2], row[x][1], row[x][0]);
        if (!rgb.allFinite()) continue;
        sum += rgb * lens_pixel_solid_angle(lens, x, y);
      }
      row_sums[static_cast<std::size_t>(y)] = sum;
    }
  });
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (const auto& s : row_sums) total += s;
  return total;
}

Eigen::Vector3d equirect_hemisphere_energy(const cv::Mat& equirect) {
  check_equirect(equirect);
  const int w = equirect.cols;
  const int h = equirect.rows;
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (int y = 0; y < h; ++y) {
    const double top = kPi / 2 - kPi * y / h;
    const double bottom = std::max(0.0, kPi / 2 - kPi * (y + 1) / h);
    if (top <= 0) break;
    const double omega = 2.0 * kPi / w * (std::sin(top) - std::sin(bottom));
    const auto* row = equirect.ptr<cv::Vec3f>(y);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int x = 0; x < w; ++x) sum += Eigen::Vector3d(row[x][2], row[x][1], row[x][0]);
    total += sum * omega;
  }
  return total;
}

}  // namespace skylit::sky
