// Multi-layer half-float OpenEXR stacks: one "<layer>.Y" channel per layer.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <stdexcept>

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/exr_header.hpp"
#include "skylit/base/files.hpp"

namespace skylit::bake_format {
namespace {

namespace fs = std::filesystem;

constexpr const char* kLuminanceSuffix = ".Y";
// ZIP compresses blocks of 16 scanlines; converting that many rows at a time bounds the half
// buffer to layers × width × 16 values however tall the image is.
constexpr int kRowsPerBlock = 16;

bool ends_with_luminance(const std::string& name) {
  return name.size() > 2 && name.compare(name.size() - 2, 2, kLuminanceSuffix) == 0;
}

// Natural order ("face_99" < "face_100"), equal to plain order for same-width numbers, so that
// a stack with more than 1000 layers still reads back in face order.
bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0;
  std::size_t j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])) != 0;
    const bool db = std::isdigit(static_cast<unsigned char>(b[j])) != 0;
    if (da && db) {
      std::size_t ei = i;
      std::size_t ej = j;
      while (ei < a.size() && std::isdigit(static_cast<unsigned char>(a[ei]))) ++ei;
      while (ej < b.size() && std::isdigit(static_cast<unsigned char>(b[ej]))) ++ej;
      // Compare digit runs by value: strip leading zeros, then length, then text.
      std::size_t si = i;
      std::size_t sj = j;
      while (si + 1 < ei && a[si] == '0') ++si;
      while (sj + 1 < ej && b[sj] == '0') ++sj;
      if (ei - si != ej - sj) return ei - si < ej - sj;
      const int c = a.compare(si, ei - si, b, sj, ej - sj);
      if (c != 0) return c < 0;
      if (ei - i != ej - j) return ei - i < ej - j;  // fewer leading zeros first
      i = ei;
      j = ej;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

constexpr const char* kExrFix = "re-bake, or restore the file from the bake it belongs to";

[[noreturn]] void unreadable(const fs::path& file, const std::string& cause) {
  throw InputError(file.string() + ": not a readable OpenEXR image (" + cause +
                   "). Fix: re-bake, or restore the file from the bake it belongs to");
}

// The largest stack a bake file may hold: planes up to scene::kMaxPlaneResolution on a side, and
// 2^30 values in all (a 512x512 plane under a ν=12 dome, 1440 layers, is 0.35 of it).
constexpr long long kMaxSide = 16384;
constexpr unsigned long long kMaxValues = 1ull << 30;

struct Layout {
  Imath::Box2i window;
  std::vector<std::string> channels;  // full channel names, "<layer>.Y", in layer order
};

Layout layout_of(const Imf::Header& header, const fs::path& file) {
  Layout layout;
  layout.window = header.dataWindow();
  if (layout.window.isEmpty()) unreadable(file, "empty data window");
  // Checked before anything is allocated from them (in 64 bits: the corners are any ints).
  const long long width = static_cast<long long>(layout.window.max.x) - layout.window.min.x + 1;
  const long long height = static_cast<long long>(layout.window.max.y) - layout.window.min.y + 1;
  if (width > kMaxSide || height > kMaxSide) {
    unreadable(file, "data window " + std::to_string(width) + "x" + std::to_string(height) + " is larger than " +
                         std::to_string(kMaxSide) + " texels on a side, the largest plane a site may have");
  }
  for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
    const std::string name = it.name();
    if (!ends_with_luminance(name)) continue;
    if (it.channel().xSampling != 1 || it.channel().ySampling != 1) {
      unreadable(file, "channel '" + name + "' is subsampled");
    }
    layout.channels.push_back(name);
  }
  if (static_cast<unsigned long long>(width * height) * layout.channels.size() > kMaxValues) {
    unreadable(file, std::to_string(width) + "x" + std::to_string(height) + " texels in " +
                         std::to_string(layout.channels.size()) + " layers are more than the largest bake holds (" +
                         std::to_string(kMaxValues) + " values)");
  }
  std::sort(layout.channels.begin(), layout.channels.end(), natural_less);
  return layout;
}

std::string layer_of(const std::string& channel) { return channel.substr(0, channel.size() - 2); }

}  // namespace

std::span<float> ImageStack::layer(int i) {
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  return std::span<float>(data).subspan(static_cast<std::size_t>(i) * n, n);
}

std::span<const float> ImageStack::layer(int i) const {
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  return std::span<const float>(data).subspan(static_cast<std::size_t>(i) * n, n);
}

std::string face_layer_name(int face) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "face_%03d", face);
  return buffer;
}

std::string layer_name(geom::DomeBasis basis, int layer) {
  if (basis == geom::DomeBasis::Faces) return face_layer_name(layer);
  const int per_face = geom::layers_per_face(basis);
  return face_layer_name(layer / per_face) + "_" + std::to_string(layer % per_face);
}

std::vector<std::string> layer_names(geom::DomeBasis basis, int face_count) {
  std::vector<std::string> names;
  const int layers = face_count * geom::layers_per_face(basis);
  names.reserve(static_cast<std::size_t>(layers));
  for (int l = 0; l < layers; ++l) names.push_back(layer_name(basis, l));
  return names;
}

void write_exr_stack(const fs::path& file, const ImageStack& stack, std::span<const std::string> layer_names) {
  if (stack.width <= 0 || stack.height <= 0 || stack.layers <= 0) {
    throw std::invalid_argument("write_exr_stack: empty image " + std::to_string(stack.width) + "x" +
                                std::to_string(stack.height));
  }
  const std::size_t texels = static_cast<std::size_t>(stack.width) * static_cast<std::size_t>(stack.height);
  if (layer_names.size() != static_cast<std::size_t>(stack.layers) ||
      stack.data.size() != texels * static_cast<std::size_t>(stack.layers)) {
    throw std::invalid_argument("write_exr_stack: " + std::to_string(layer_names.size()) + " names and " +
                                std::to_string(stack.data.size()) + " values for " + std::to_string(stack.layers) +
                                " layers of " + std::to_string(stack.width) + "x" + std::to_string(stack.height));
  }

  Imf::Header header(stack.width, stack.height);  // data and display window (0,0)-(W-1,H-1)
  header.compression() = Imf::ZIP_COMPRESSION;
  header.lineOrder() = Imf::INCREASING_Y;
  for (const std::string& name : layer_names) header.channels().insert(name + kLuminanceSuffix, Imf::Channel(Imf::HALF));
  {
    std::vector<std::string> unique(layer_names.begin(), layer_names.end());
    std::sort(unique.begin(), unique.end());
    if (std::adjacent_find(unique.begin(), unique.end()) != unique.end()) {
      throw std::invalid_argument("write_exr_stack: duplicate layer names");
    }
  }

  write_file_atomic_with(file, [&](const fs::path& tmp) {
    try {
      Imf::OutputFile out(tmp.c_str(), header);
      const std::size_t width = static_cast<std::size_t>(stack.width);
      const std::size_t block_values = width * kRowsPerBlock;
      std::vector<half> block(block_values * static_cast<std::size_t>(stack.layers));
      for (int y0 = 0; y0 < stack.height; y0 += kRowsPerBlock) {
        const int rows = std::min(kRowsPerBlock, stack.height - y0);
        Imf::FrameBuffer frame;
        for (int l = 0; l < stack.layers; ++l) {
          half* target = block.data() + static_cast<std::size_t>(l) * block_values;
          const float* source = stack.data.data() + static_cast<std::size_t>(l) * texels +
                                static_cast<std::size_t>(y0) * width;
          std::transform(source, source + static_cast<std::size_t>(rows) * width, target,
                         [](float x) { return half(x); });
          frame.insert(layer_names[static_cast<std::size_t>(l)] + kLuminanceSuffix,
                       Imf::Slice::Make(Imf::HALF, target, Imath::V2i(0, y0), stack.width, rows, sizeof(half),
                                        sizeof(half) * width));
        }
        out.setFrameBuffer(frame);
        out.writePixels(rows);
      }
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw InputError(file.string() + ": cannot write the OpenEXR image (" + e.what() +
                       "). Fix: check free space and permissions of the bake directory");
    }
  });
}

ExrInfo read_exr_info(const fs::path& file) {
  if (!fs::is_regular_file(file)) unreadable(file, "no such file");
  try {
    check_exr_header(file, {kMaxSide, 1 << 20}, kExrFix);
    Imf::InputFile in(file.c_str());
    if (!in.isComplete()) unreadable(file, "the file is truncated");
    const Layout layout = layout_of(in.header(), file);
    ExrInfo info;
    info.width = layout.window.max.x - layout.window.min.x + 1;
    info.height = layout.window.max.y - layout.window.min.y + 1;
    for (const std::string& c : layout.channels) info.layer_names.push_back(layer_of(c));
    return info;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    unreadable(file, e.what());
  }
}

namespace {

// Both stacks read the same way; only the sample type differs. A HALF slice gets the file's half
// bits as they are, a FLOAT slice gets them converted.
template <typename Stack>
Stack read_stack(const fs::path& file, std::vector<std::string>* layer_names, Imf::PixelType type) {
  using Sample = typename decltype(Stack::data)::value_type;
  static_assert(sizeof(half) == sizeof(std::uint16_t), "OpenEXR HALF slices are 16-bit words");
  if (!fs::is_regular_file(file)) unreadable(file, "no such file");
  try {
    check_exr_header(file, {kMaxSide, 1 << 20}, kExrFix);
    Imf::InputFile in(file.c_str());
    // A file cut short still opens; its missing scanlines would silently read as zero.
    if (!in.isComplete()) unreadable(file, "the file is truncated");
    const Layout layout = layout_of(in.header(), file);
    Stack stack;
    stack.width = layout.window.max.x - layout.window.min.x + 1;
    stack.height = layout.window.max.y - layout.window.min.y + 1;
    stack.layers = static_cast<int>(layout.channels.size());
    const std::size_t texels = static_cast<std::size_t>(stack.width) * static_cast<std::size_t>(stack.height);
    stack.data.assign(texels * layout.channels.size(), Sample{});
    Imf::FrameBuffer frame;
    for (std::size_t l = 0; l < layout.channels.size(); ++l) {
      frame.insert(layout.channels[l],
                   Imf::Slice::Make(type, stack.data.data() + l * texels, layout.window, sizeof(Sample),
                                    sizeof(Sample) * static_cast<std::size_t>(stack.width)));
    }
    in.setFrameBuffer(frame);
    in.readPixels(layout.window.min.y, layout.window.max.y);
    if (layer_names) {
      layer_names->clear();
      for (const std::string& c : layout.channels) layer_names->push_back(layer_of(c));
    }
    return stack;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    unreadable(file, e.what());
  }
}

}  // namespace

ImageStack read_exr_stack(const fs::path& file, std::vector<std::string>* layer_names) {
  return read_stack<ImageStack>(file, layer_names, Imf::FLOAT);
}

ImageStackHalf read_exr_stack_half(const fs::path& file, std::vector<std::string>* layer_names) {
  return read_stack<ImageStackHalf>(file, layer_names, Imf::HALF);
}

}  // namespace skylit::bake_format
