#pragma once
// A first look at an OpenEXR file's headers, before OpenEXR reads them: OpenEXR allocates what
// an attribute's size field or a data window says (an opaque attribute of 1.6 GB, an offset
// table of a billion lines) before anything is checked. InputError naming the file instead.
#include <cstdint>
#include <filesystem>

namespace skylit {

struct ExrHeaderLimits {
  std::int64_t max_side = 16384;        // data window, each side
  std::int64_t max_chunks = 1 << 20;    // scanline blocks or tiles of one part
};

// Walks every header of the file (attributes by name, type and size, each within the file),
// and checks each part's data window and chunk count against `limits`. `fix` ends the message.
void check_exr_header(const std::filesystem::path& file, const ExrHeaderLimits& limits, const char* fix);

}  // namespace skylit
