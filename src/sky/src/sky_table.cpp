#include "skylit/sky/sky_table.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <thread>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <opencv2/imgcodecs.hpp>

#include "skylit/base/error.hpp"
#include "skylit/base/parallel_for.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/radiometry.hpp"

namespace skylit::sky {
namespace {

constexpr int kMaxThreads = 8;
constexpr int kMinBlockRowsPerThread = 8;  // below this a thread costs more than it saves

// Solid angle of the quadrilateral d00 → d10 → d11 → d01 (unit vectors), as two spherical
// triangles sharing the diagonal d00–d11. The sign depends on the image's handedness only.
double quad_solid_angle(const Vec3& d00, const Vec3& d10, const Vec3& d11, const Vec3& d01) {
  return std::abs(geom::solid_angle({d00, d10, d11}) + geom::solid_angle({d00, d11, d01}));
}

std::string size_text(int width, int height) {
  return std::to_string(width) + "×" + std::to_string(height);
}

// The calibration's mask file, as 8-bit (anything OpenCV reads is converted to grey).
cv::Mat read_mask(const camera::CameraCalibration& c) {
  const std::string fix = "point 'mask' at an 8-bit image of " +
                          size_text(c.image_width, c.image_height) +
                          " pixels, 0 where the mount hides the sky (or remove the field)";
  std::error_code error;
  if (!std::filesystem::is_regular_file(c.mask, error)) {
    throw InputError(input_message(c.file, -1, -1, "mask",
                                   "the mask image '" + c.mask.string() + "' does not exist", fix));
  }
  cv::Mat mask;
  try {
    mask = read_image(c.mask, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception&) {
    mask.release();  // reported below like any unreadable image
  }
  if (mask.empty()) {
    throw InputError(input_message(c.file, -1, -1, "mask",
                                   "cannot read the mask image '" + c.mask.string() + "'", fix));
  }
  if (mask.cols != c.image_width || mask.rows != c.image_height) {
    throw InputError(input_message(
        c.file, -1, -1, "mask",
        "the mask image '" + c.mask.string() + "' is " + size_text(mask.cols, mask.rows) +
            " pixels, the calibration's image " + size_text(c.image_width, c.image_height),
        fix));
  }
  return mask;
}

// The sampling grid along one image axis (see sky_table.hpp): samples at pixels
// b·step + ⌊step/2⌋, each the centre of its block; the blocks meet halfway between samples, and
// the first and last reach out to the image's edges.
class Axis {
 public:
  Axis(int size, int step)
      : size_(size),
        step_(step),
        blocks_(size - 1 < step / 2 ? 1 : (size - 1 - step / 2) / step + 1) {}
  int blocks() const { return blocks_; }
  int sample(int b) const { return std::min(b * step_ + step_ / 2, size_ - 1); }
  // The edge between block b−1 and block b (b = 0: the image's first edge, b = blocks(): its last).
  double edge(int b) const {
    if (b <= 0) return -0.5;
    if (b >= blocks_) return size_ - 0.5;
    return sample(b) - step_ / 2.0;
  }

 private:
  int size_;
  int step_;
  int blocks_;
};

struct Band {
  std::vector<PixelRun> runs;
  std::vector<float> weights;
  std::vector<std::uint16_t> corner_weights;  // corners basis: λ0, λ1 per sample, 16-bit
};

// The hats' mass matrix needs only a coarse quadrature: it sets a threshold, not a value.
constexpr int kFullMassSubdivisions = 16;

// Rows of blocks [by_begin, by_end). Corner directions are shared by neighbouring blocks, so
// they are unprojected once per corner row and kept for the next block row.
void build_band(const camera::Lens& lens, const geom::Dome& dome, const geom::CornerWeights* corners, const cv::Mat& mask,
                const Axis& ax, const Axis& ay, int by_begin, int by_end, Band& band) {
  const int nbx = ax.blocks();
  const auto unproject_corners = [&](double y, std::vector<std::optional<Vec3>>& row) {
    for (int bx = 0; bx <= nbx; ++bx)
      row[static_cast<std::size_t>(bx)] = lens.unproject(Vec2(ax.edge(bx), y));
  };
  std::vector<std::optional<Vec3>> top(static_cast<std::size_t>(nbx) + 1);
  std::vector<std::optional<Vec3>> bottom(top.size());
  unproject_corners(ay.edge(by_begin), top);

  for (int by = by_begin; by < by_end; ++by) {
    unproject_corners(ay.edge(by + 1), bottom);
    const int row = ay.sample(by);
    const std::uint8_t* mask_row = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(row);
    PixelRun* open = nullptr;  // the run the next sample may extend
    for (int bx = 0; bx < nbx; ++bx) {
      const int col = ax.sample(bx);
      const auto b = static_cast<std::size_t>(bx);
      int face = -1;
      Vec3 seen = Vec3::UnitZ();
      if ((!mask_row || mask_row[col] != 0) && top[b] && top[b + 1] && bottom[b] && bottom[b + 1]) {
        if (const std::optional<Vec3> direction = lens.pixel_to_site(Vec2(col, row))) {
          face = dome.face_of(*direction);  // -1 below the horizon
          seen = *direction;
        }
      }
      if (face < 0) {
        open = nullptr;
        continue;
      }
      const double weight = quad_solid_angle(*top[b], *top[b + 1], *bottom[b + 1], *bottom[b]);
      if (open && open->face == face) {
        ++open->count;
      } else {
        PixelRun run;
        run.row = row;
        run.col_begin = col;
        run.count = 1;
        run.face = face;
        run.weight_offset = static_cast<std::uint32_t>(band.weights.size());
        band.runs.push_back(run);
        open = &band.runs.back();
      }
      band.weights.push_back(static_cast<float>(weight));
      if (corners) {
        const std::array<double, 3> lambda = (*corners)(face, seen);
        auto q0 = static_cast<std::uint16_t>(std::lround(lambda[0] / kCornerWeightUnit));
        auto q1 = static_cast<std::uint16_t>(std::lround(lambda[1] / kCornerWeightUnit));
        if (q0 + q1 > 65535) --(q0 > q1 ? q0 : q1);  // keep λ2 = 1 − λ0 − λ1 ≥ 0 after rounding
        band.corner_weights.push_back(q0);
        band.corner_weights.push_back(q1);
      }
    }
    top.swap(bottom);
  }
}

// Mass matrices and their inverses from the stored (float) weights, in one fixed order.
void add_corner_matrices(const geom::Dome& dome, SkyTable& table) {
  const auto faces = static_cast<std::size_t>(dome.face_count());
  const int layers = geom::layers_per_face(table.basis);
  table.corner_mass.assign(faces, Eigen::MatrixXd::Zero(layers, layers));
  for (const PixelRun& run : table.runs) {
    Eigen::MatrixXd& m = table.corner_mass[static_cast<std::size_t>(run.face)];
    for (std::int32_t k = 0; k < run.count; ++k) {
      const std::size_t at = run.weight_offset + static_cast<std::uint32_t>(k);
      const double w = table.weights[at];
      const double l0 = table.corner_weights[2 * at] * kCornerWeightUnit;
      const double l1 = table.corner_weights[2 * at + 1] * kCornerWeightUnit;
      const geom::LayerValues phi = geom::layer_values(table.basis, {l0, l1, 1.0 - l0 - l1});
      const Eigen::Map<const Eigen::VectorXd> v(phi.data(), layers);
      m.noalias() += w * v * v.transpose();
    }
  }
  table.corner_inverse.resize(faces);
  table.corner_full_mass.resize(faces);
  table.corner_conditioning.resize(faces);
  for (std::size_t i = 0; i < faces; ++i) {
    table.corner_full_mass[i] =
        geom::face_quadrature(dome, static_cast<int>(i), kFullMassSubdivisions, table.basis).mass;
    table.corner_conditioning[i] = corner_conditioning(table.corner_mass[i], table.corner_full_mass[i]);
    table.corner_inverse[i] = table.corner_conditioning[i] > 0.0 ? Eigen::MatrixXd(table.corner_mass[i].inverse())
                                                                 : Eigen::MatrixXd::Zero(layers, layers);
  }
}

}  // namespace

double corner_conditioning(const Eigen::MatrixXd& m, const Eigen::MatrixXd& full) {
  if (m.rows() == 0 || m.rows() != m.cols() || full.rows() != m.rows() || full.cols() != m.cols()) return 0.0;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> seen(m, Eigen::EigenvaluesOnly);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> whole(full, Eigen::EigenvaluesOnly);
  const double low = seen.eigenvalues().minCoeff(), reference = whole.eigenvalues().minCoeff();
  if (!(low > 0.0) || !(reference > 0.0)) return 0.0;
  return low / reference;
}

double block_solid_angle(const camera::Lens& lens, double x0, double y0, double x1, double y1) {
  const std::optional<Vec3> d00 = lens.unproject(Vec2(x0, y0));
  const std::optional<Vec3> d10 = lens.unproject(Vec2(x1, y0));
  const std::optional<Vec3> d11 = lens.unproject(Vec2(x1, y1));
  const std::optional<Vec3> d01 = lens.unproject(Vec2(x0, y1));
  if (!d00 || !d10 || !d11 || !d01) return 0.0;
  return quad_solid_angle(*d00, *d10, *d11, *d01);
}

SkyTable build_sky_table(const camera::Lens& lens, const geom::Dome& dome, const SkyTableOptions& options) {
  return build_sky_table(lens, dome, cv::Mat(), options);
}

SkyTable build_sky_table(const camera::Lens& lens, const geom::Dome& dome, const cv::Mat& mask_in,
                         const SkyTableOptions& options) {
  const camera::CameraCalibration& c = lens.calibration();
  if (options.step < 1) {
    throw InputError(input_message(
        c.file, -1, -1, "step",
        "the sampling step " + std::to_string(options.step) + " is not a positive integer",
        "sample every pixel with step 1, or every s-th with step s > 1"));
  }
  cv::Mat mask = mask_in;
  if (mask.empty() && !c.mask.empty()) mask = read_mask(c);
  if (!mask.empty() &&
      (mask.type() != CV_8UC1 || mask.cols != c.image_width || mask.rows != c.image_height)) {
    throw InputError(input_message(
        c.file, -1, -1, "mask",
        "the sky mask is " + size_text(mask.cols, mask.rows) + " with " +
            std::to_string(mask.channels()) + " channel(s) of depth " +
            std::to_string(mask.depth()) + "; the calibration's image is " +
            size_text(c.image_width, c.image_height),
        "give an 8-bit, one-channel mask of the calibration's image size (0 = hidden)"));
  }

  const Axis ax(c.image_width, options.step);
  const Axis ay(c.image_height, options.step);
  const int nby = ay.blocks();
  const int hardware = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int threads = std::clamp(std::min(hardware, nby / kMinBlockRowsPerThread), 1, kMaxThreads);
  std::optional<geom::CornerWeights> corners;
  if (options.basis != geom::DomeBasis::Faces) corners.emplace(dome);

  // One band of block rows per thread, each built into its own Band and joined in order below.
  std::vector<Band> bands(static_cast<std::size_t>(threads));
  parallel_for(threads, threads, [&](int t) {
    const int begin = static_cast<int>(static_cast<long long>(nby) * t / threads);
    const int end = static_cast<int>(static_cast<long long>(nby) * (t + 1) / threads);
    build_band(lens, dome, corners ? &*corners : nullptr, mask, ax, ay, begin, end, bands[static_cast<std::size_t>(t)]);
  });

  SkyTable table;
  table.image_width = c.image_width;
  table.image_height = c.image_height;
  table.step = options.step;
  std::size_t run_total = 0, weight_total = 0;
  for (const Band& band : bands) {
    run_total += band.runs.size();
    weight_total += band.weights.size();
  }
  table.runs.reserve(run_total);
  table.weights.reserve(weight_total);
  for (const Band& band : bands) {
    const auto offset = static_cast<std::uint32_t>(table.weights.size());
    for (PixelRun run : band.runs) {
      run.weight_offset += offset;
      table.runs.push_back(run);
    }
    table.weights.insert(table.weights.end(), band.weights.begin(), band.weights.end());
    table.corner_weights.insert(table.corner_weights.end(), band.corner_weights.begin(), band.corner_weights.end());
  }
  table.basis = options.basis;

  // From the stored (float) weights, in one fixed order: the same sums the luminance pass sees,
  // independent of the thread count.
  const auto faces = static_cast<std::size_t>(dome.face_count());
  table.face_solid_angle.assign(faces, 0.0);
  for (const PixelRun& run : table.runs) {
    double sum = 0;
    for (std::int32_t k = 0; k < run.count; ++k)
      sum += table.weights[run.weight_offset + static_cast<std::uint32_t>(k)];
    table.face_solid_angle[static_cast<std::size_t>(run.face)] += sum;
  }
  table.coverage.resize(faces);
  for (std::size_t i = 0; i < faces; ++i) {
    table.coverage[i] = table.face_solid_angle[i] / dome.faces()[i].solid_angle;
  }
  if (table.basis != geom::DomeBasis::Faces) add_corner_matrices(dome, table);
  return table;
}

}  // namespace skylit::sky
