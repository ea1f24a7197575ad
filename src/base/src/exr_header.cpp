#include "skylit/base/exr_header.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "skylit/base/error.hpp"

namespace fs = std::filesystem;

namespace skylit {
namespace {

// Reads the header bytes in order, never past the file's end.
class HeaderCursor {
 public:
  HeaderCursor(const fs::path& file, const char* fix) : file_(file), fix_(fix), in_(file, std::ios::binary) {
    std::error_code error;
    size_ = static_cast<std::int64_t>(fs::file_size(file, error));
    if (error || !in_) fail("cannot be read");
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(input_message(file_, -1, -1, "", "not a readable OpenEXR image: " + problem, fix_));
  }
  std::int64_t left() const { return size_ - at_; }
  void read(void* out, std::int64_t n) {
    if (n < 0 || n > left()) fail("its header runs past the end of the file");
    in_.read(static_cast<char*>(out), n);
    if (!in_) fail("its header cannot be read");
    at_ += n;
  }
  std::int32_t int32() {
    unsigned char b[4];
    read(b, 4);
    return static_cast<std::int32_t>(std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 | std::uint32_t(b[2]) << 16 |
                                     std::uint32_t(b[3]) << 24);
  }
  // A NUL-terminated name of at most `longest` characters.
  std::string name(std::size_t longest) {
    std::string text;
    for (char c = 0;;) {
      read(&c, 1);
      if (c == '\0') return text;
      if (text.size() == longest) fail("a header name is longer than " + std::to_string(longest) + " characters");
      text += c;
    }
  }
  void skip(std::int64_t n) {
    if (n < 0 || n > left()) fail("an attribute is larger than the rest of the file");
    in_.seekg(n, std::ios::cur);
    at_ += n;
  }

 private:
  const fs::path& file_;
  const char* fix_;
  std::ifstream in_;
  std::int64_t size_ = 0;
  std::int64_t at_ = 0;
};

// Lines per scanline block of each compression (OpenEXR's Compression enum order).
int lines_per_block(int compression) {
  switch (compression) {
    case 0: case 1: case 2: return 1;   // none, RLE, ZIPS
    case 3: case 5: case 7: case 8: return compression == 3 ? 16 : 32;  // ZIP 16; PIZ, B44, B44A 32
    case 4: return 16;                  // PXR24
    case 6: return 32;
    case 9: return 256;                 // DWAB
    default: return 32;                 // DWAA and anything later
  }
}

// Steps over an attribute's value as OpenEXR 3.1 reads it: a known type reads its own layout
// whatever the size field says (a channel list up to its empty name, a fixed-size value, a
// preview image's width × height pixels), anything else `size` bytes. Where the two disagree
// OpenEXR's reading drifts, and a later size field is garbage: so the walk follows OpenEXR's.
void skip_value(HeaderCursor& cursor, const std::string& attribute, const std::string& type, std::int32_t size) {
  static constexpr std::pair<const char*, int> kFixed[] = {
      {"box2i", 16}, {"box2f", 16}, {"chromaticities", 32}, {"compression", 1}, {"double", 8}, {"envmap", 1},
      {"float", 4}, {"int", 4}, {"keycode", 28}, {"lineOrder", 1}, {"m33f", 36}, {"m33d", 72}, {"m44f", 64},
      {"m44d", 128}, {"rational", 8}, {"tiledesc", 9}, {"timecode", 8}, {"v2i", 8}, {"v2f", 8}, {"v2d", 16},
      {"v3i", 12}, {"v3f", 12}, {"v3d", 24}, {"deepImageState", 1}};
  for (const auto& [name, bytes] : kFixed) {
    if (type == name) {
      cursor.skip(bytes);
      return;
    }
  }
  if (type == "chlist") {
    while (!cursor.name(255).empty()) cursor.skip(16);  // pixel type, linear, reserved, x and y sampling
    return;
  }
  if (type == "preview") {
    const auto width = static_cast<std::uint32_t>(cursor.int32());
    const auto height = static_cast<std::uint32_t>(cursor.int32());
    // Compared by division: width × height × 4 of two 32-bit sides overflows 64 bits.
    if (height != 0 && std::int64_t{width} > cursor.left() / 4 / std::int64_t{height}) {
      cursor.fail("attribute '" + attribute + "' holds a preview larger than the file");
    }
    cursor.skip(std::int64_t{width} * height * 4);
    return;
  }
  if (type == "stringvector") {
    if (size > cursor.left()) cursor.fail("attribute '" + attribute + "' is larger than the rest of the file");
    for (std::int64_t read = 0; read < size;) {
      const std::int32_t length = cursor.int32();
      if (length < 0 || length > size - read - 4) cursor.fail("attribute '" + attribute + "' holds a string past its end");
      cursor.skip(length);
      read += 4 + length;
    }
    return;
  }
  if (size > cursor.left()) {
    cursor.fail("attribute '" + attribute + "' says it is " + std::to_string(size) + " bytes, more than the rest of the file");
  }
  cursor.skip(size);
}

}  // namespace

void check_exr_header(const fs::path& file, const ExrHeaderLimits& limits, const char* fix) {
  HeaderCursor cursor(file, fix);
  unsigned char magic[4];
  cursor.read(magic, 4);
  if (magic[0] != 0x76 || magic[1] != 0x2f || magic[2] != 0x31 || magic[3] != 0x01) cursor.fail("no OpenEXR magic number");
  const std::uint32_t version = static_cast<std::uint32_t>(cursor.int32());
  if ((version & 0xff) != 2) cursor.fail("OpenEXR version " + std::to_string(version & 0xff) + ", not 2");
  const bool tiled = version & 0x200, long_names = version & 0x400, deep = version & 0x800, multipart = version & 0x1000;
  if (deep) cursor.fail("deep data, not an image");
  const std::size_t longest = long_names ? 255 : 31;
  for (int part = 0;; ++part) {
    bool any = false, has_window = false, part_tiled = tiled && !multipart;
    std::int32_t window[4] = {0, 0, 0, 0};
    std::uint32_t tile_x = 0, tile_y = 0;
    int compression = 0;
    std::int64_t chunk_count = -1;
    for (;;) {
      const std::string attribute = cursor.name(longest);
      if (attribute.empty()) break;
      any = true;
      const std::string type = cursor.name(longest);
      const std::int32_t size = cursor.int32();
      if (size < 0) cursor.fail("attribute '" + attribute + "' has a negative size");
      if (attribute == "dataWindow" && type == "box2i" && size == 16) {
        for (std::int32_t& corner : window) corner = cursor.int32();
        has_window = true;
      } else if (attribute == "compression" && type == "compression" && size == 1) {
        unsigned char c = 0;
        cursor.read(&c, 1);
        compression = c;
      } else if (attribute == "tiles" && type == "tiledesc" && size == 9) {
        tile_x = static_cast<std::uint32_t>(cursor.int32());
        tile_y = static_cast<std::uint32_t>(cursor.int32());
        cursor.skip(1);
        part_tiled = true;
      } else if (attribute == "chunkCount" && type == "int" && size == 4) {
        chunk_count = cursor.int32();
      } else if (attribute == "type" && type == "string") {
        std::string kind(static_cast<std::size_t>(std::min<std::int64_t>(size, cursor.left())), '\0');
        cursor.read(kind.data(), size);
        if (kind == "tiledimage") part_tiled = true;
        if (kind.rfind("deep", 0) == 0) cursor.fail("part " + std::to_string(part) + " holds deep data, not an image");
      } else {
        skip_value(cursor, attribute, type, size);
      }
    }
    if (!any) {
      if (part == 0) cursor.fail("an empty header");
      break;  // the empty header that ends a multi-part file's headers
    }
    if (!has_window) cursor.fail("part " + std::to_string(part) + " has no data window");
    const std::int64_t width = std::int64_t{window[2]} - window[0] + 1, height = std::int64_t{window[3]} - window[1] + 1;
    if (width < 1 || height < 1) cursor.fail("an empty data window");
    if (width > limits.max_side || height > limits.max_side) {
      cursor.fail("its data window is " + std::to_string(width) + "x" + std::to_string(height) + ", larger than " +
                  std::to_string(limits.max_side) + " on a side");
    }
    std::int64_t chunks = 0;
    if (part_tiled) {
      if (tile_x < 1 || tile_y < 1) cursor.fail("tiles of no size");
      chunks = ((width + tile_x - 1) / tile_x) * ((height + tile_y - 1) / tile_y);
    } else {
      chunks = (height + lines_per_block(compression) - 1) / lines_per_block(compression);
    }
    if (chunk_count > chunks) chunks = chunk_count;
    if (chunks > limits.max_chunks) {
      cursor.fail("part " + std::to_string(part) + " has " + std::to_string(chunks) + " blocks, more than " +
                  std::to_string(limits.max_chunks));
    }
    if (!multipart) break;
  }
}

}  // namespace skylit
