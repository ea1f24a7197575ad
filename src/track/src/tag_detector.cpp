// AprilTag detection through libapriltag.
#include "skylit/track/tag_detector.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h10.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagCircle21h7.h>
#include <apriltag/tagCircle49h12.h>
#include <apriltag/tagCustom48h12.h>
#include <apriltag/tagStandard41h12.h>
#include <apriltag/tagStandard52h13.h>
}

namespace skylit::track {
namespace {

struct FamilyEntry {
  std::string_view name;
  apriltag_family_t* (*create)();
  void (*destroy)(apriltag_family_t*);
};

constexpr std::array<FamilyEntry, 9> kFamilies{{
    {"tag36h11", tag36h11_create, tag36h11_destroy},
    {"tag25h9", tag25h9_create, tag25h9_destroy},
    {"tag16h5", tag16h5_create, tag16h5_destroy},
    {"tag36h10", tag36h10_create, tag36h10_destroy},
    {"tagStandard41h12", tagStandard41h12_create, tagStandard41h12_destroy},
    {"tagStandard52h13", tagStandard52h13_create, tagStandard52h13_destroy},
    {"tagCircle21h7", tagCircle21h7_create, tagCircle21h7_destroy},
    {"tagCircle49h12", tagCircle49h12_create, tagCircle49h12_destroy},
    {"tagCustom48h12", tagCustom48h12_create, tagCustom48h12_destroy},
}};

constexpr std::array<std::string_view, 9> kFamilyNames{
    kFamilies[0].name, kFamilies[1].name, kFamilies[2].name, kFamilies[3].name, kFamilies[4].name,
    kFamilies[5].name, kFamilies[6].name, kFamilies[7].name, kFamilies[8].name};

// libapriltag's pixel centres are at +0.5 (a pixel covers [i, i+1)); OpenCV's at integers.
constexpr double kPixelCentreShift = 0.5;
// Largest decode table accepted (libapriltag allocates it at once and exits when that fails).
constexpr double kMaxDecodeTableBytes = 512.0 * 1024 * 1024;

const FamilyEntry& find_family(std::string_view name) {
  for (const FamilyEntry& entry : kFamilies) {
    if (entry.name == name) return entry;
  }
  std::string known;
  for (const FamilyEntry& entry : kFamilies) known += (known.empty() ? "" : ", ") + std::string(entry.name);
  throw std::invalid_argument(std::string("unknown AprilTag family '").append(name).append("' (known: ").append(known).append(")"));
}

// The family object libapriltag hands out, destroyed by its own function.
class Family {
 public:
  explicit Family(std::string_view name) : entry_(&find_family(name)), family_(entry_->create()) {
    if (family_ == nullptr) throw std::runtime_error("libapriltag could not create the family");
  }
  ~Family() {
    if (family_ != nullptr) entry_->destroy(family_);
  }
  Family(const Family&) = delete;
  Family& operator=(const Family&) = delete;
  apriltag_family_t* get() const { return family_; }

 private:
  const FamilyEntry* entry_;
  apriltag_family_t* family_;
};

// Bytes of libapriltag's quick-decode table (apriltag.c, quick_decode_init): three slots of 16
// bytes per code and per error pattern up to max_hamming.
double decode_table_bytes(const apriltag_family_t& family, int max_hamming) {
  const double n = family.nbits;
  double per_code = 1;
  if (max_hamming >= 1) per_code += n;
  if (max_hamming >= 2) per_code += n * (n - 1);
  if (max_hamming >= 3) per_code += n * (n - 1) * (n - 2);
  return 3.0 * 16.0 * family.ncodes * per_code;
}

}  // namespace

std::span<const std::string_view> tag_families() { return kFamilyNames; }

TagFamilyLayout tag_family_layout(std::string_view family) {
  const Family f(family);
  return TagFamilyLayout{f.get()->width_at_border, f.get()->total_width, static_cast<int>(f.get()->ncodes),
                         f.get()->reversed_border};
}

std::vector<unsigned char> tag_pattern(std::string_view family, int id) {
  const Family f(family);
  const apriltag_family_t& fam = *f.get();
  if (id < 0 || static_cast<std::uint32_t>(id) >= fam.ncodes) {
    throw std::out_of_range("tag id " + std::to_string(id) + " is outside " + std::string(family) + " (0.." +
                            std::to_string(fam.ncodes - 1) + ")");
  }
  // The layout of libapriltag's apriltag_to_image (not exported by every build of the library):
  // black everywhere, a one-cell white ring just outside the border square (at it for families
  // with a reversed border), and the code's bits, most significant first, at (bit_x, bit_y)
  // from the border square's corner (negative for the bits outside it).
  const int width = fam.total_width;
  std::vector<unsigned char> cells(static_cast<std::size_t>(width) * static_cast<std::size_t>(width), 0);
  const auto set_white = [&](int row, int column) {
    if (row >= 0 && row < width && column >= 0 && column < width) {
      cells[static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(column)] = 255;
    }
  };
  const int ring = fam.width_at_border + (fam.reversed_border ? 0 : 2);
  const int ring_start = (width - ring) / 2;
  for (int i = 0; i < ring - 1; ++i) {
    set_white(ring_start, ring_start + i);
    set_white(ring_start + i, width - 1 - ring_start);
    set_white(width - 1 - ring_start, ring_start + i + 1);
    set_white(ring_start + 1 + i, ring_start);
  }
  const int border_start = (width - fam.width_at_border) / 2;
  const std::uint64_t code = fam.codes[id];
  for (std::uint32_t i = 0; i < fam.nbits; ++i) {
    if ((code >> (fam.nbits - i - 1)) & 1u) {
      set_white(static_cast<std::int32_t>(fam.bit_y[i]) + border_start, static_cast<std::int32_t>(fam.bit_x[i]) + border_start);
    }
  }
  return cells;
}

struct TagDetector::Impl {
  TagDetectorOptions options;
  Family family;
  apriltag_detector_t* detector = nullptr;
  cv::Mat grey;  // conversion buffer, reused between frames

  explicit Impl(const TagDetectorOptions& o) : options(o), family(o.family) {
    if (!(options.decimation >= 1.0) || !std::isfinite(options.decimation)) {
      throw std::invalid_argument("AprilTag decimation must be ≥ 1, got " + std::to_string(options.decimation));
    }
    if (!std::isfinite(options.blur_sigma)) throw std::invalid_argument("AprilTag blur sigma must be finite");
    if (options.threads < 1) throw std::invalid_argument("AprilTag threads must be ≥ 1");
    if (options.min_contrast < 0 || options.min_contrast > 255) throw std::invalid_argument("AprilTag min_contrast must be 0..255");
    if (options.max_hamming < 0 || options.max_hamming > 3) {
      throw std::invalid_argument("AprilTag max_hamming must be 0..3, got " + std::to_string(options.max_hamming));
    }
    if (decode_table_bytes(*family.get(), options.max_hamming) > kMaxDecodeTableBytes) {
      int fits = options.max_hamming;
      while (fits > 0 && decode_table_bytes(*family.get(), fits) > kMaxDecodeTableBytes) --fits;
      throw std::invalid_argument("AprilTag family " + options.family + " with max_hamming " +
                                  std::to_string(options.max_hamming) + " needs a decode table of " +
                                  std::to_string(static_cast<long long>(decode_table_bytes(*family.get(), options.max_hamming) / (1 << 20))) +
                                  " MiB; use max_hamming " + std::to_string(fits) + " or less");
    }
    detector = apriltag_detector_create();
    if (detector == nullptr) throw std::runtime_error("libapriltag could not create a detector");
    detector->quad_decimate = static_cast<float>(options.decimation);
    detector->quad_sigma = static_cast<float>(options.blur_sigma);
    detector->refine_edges = options.refine_edges;
    detector->decode_sharpening = options.decode_sharpening;
    detector->qtp.min_white_black_diff = options.min_contrast;
    detector->nthreads = options.threads;
    apriltag_detector_add_family_bits(detector, family.get(), options.max_hamming);
  }
  ~Impl() {
    // The detector first: it frees the decode table it hung on the family.
    if (detector != nullptr) apriltag_detector_destroy(detector);
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
};

TagDetector::TagDetector(const TagDetectorOptions& options) : impl_(std::make_unique<Impl>(options)) {}
TagDetector::~TagDetector() = default;
TagDetector::TagDetector(TagDetector&&) noexcept = default;
TagDetector& TagDetector::operator=(TagDetector&&) noexcept = default;

const TagDetectorOptions& TagDetector::options() const { return impl_->options; }

std::vector<TagDetection> TagDetector::detect(const cv::Mat& frame) {
  Impl& s = *impl_;
  cv::Mat grey;
  if (frame.type() == CV_8UC3) {
    cv::cvtColor(frame, s.grey, cv::COLOR_BGR2GRAY);
    grey = s.grey;
  } else if (frame.type() == CV_8UC1) {
    // Without decimation libapriltag blurs the caller's image in place: give it a copy then.
    if (s.options.decimation <= 1.0 && s.options.blur_sigma != 0.0) {
      frame.copyTo(s.grey);
      grey = s.grey;
    } else {
      grey = frame;
    }
  } else {
    throw std::invalid_argument("TagDetector: expected an 8-bit grey or BGR frame, got OpenCV type " +
                                std::to_string(frame.type()));
  }
  if (grey.empty()) return {};
  image_u8_t image{grey.cols, grey.rows, static_cast<int32_t>(grey.step[0]), grey.data};
  zarray_t* found = apriltag_detector_detect(s.detector, &image);
  std::vector<TagDetection> detections;
  if (found == nullptr) return detections;
  detections.reserve(static_cast<std::size_t>(zarray_size(found)));
  for (int i = 0; i < zarray_size(found); ++i) {
    apriltag_detection_t* d = nullptr;
    zarray_get(found, i, &d);
    if (d->decision_margin < s.options.min_decision_margin) continue;
    TagDetection detection;
    detection.id = d->id;
    detection.hamming = d->hamming;
    detection.decision_margin = d->decision_margin;
    for (int k = 0; k < 4; ++k) {
      detection.corners[static_cast<std::size_t>(k)] =
          Eigen::Vector2d(d->p[k][0] - kPixelCentreShift, d->p[k][1] - kPixelCentreShift);
    }
    detection.center = Eigen::Vector2d(d->c[0] - kPixelCentreShift, d->c[1] - kPixelCentreShift);
    detections.push_back(detection);
  }
  apriltag_detections_destroy(found);
  std::stable_sort(detections.begin(), detections.end(),
                   [](const TagDetection& a, const TagDetection& b) { return a.id < b.id; });
  return detections;
}

}  // namespace skylit::track
