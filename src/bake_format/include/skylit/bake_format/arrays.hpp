#pragma once
// A bake's images and arrays: multi-layer half-float OpenEXR stacks and NumPy .npy files,
// written, read and inspected without reading their data.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace skylit::bake_format {


// Layer-major float stack: data[(layer * height + row) * width + col].
struct ImageStack {
  int width = 0;
  int height = 0;
  int layers = 0;
  std::vector<float> data;
  std::span<float> layer(int i);
  std::span<const float> layer(int i) const;
};

// Multi-layer half-float OpenEXR (ZIP compressed), channel "<layer_names[i]>.Y" per layer.
void write_exr_stack(const std::filesystem::path& file, const ImageStack& stack,
                     std::span<const std::string> layer_names);
ImageStack read_exr_stack(const std::filesystem::path& file,
                          std::vector<std::string>* layer_names = nullptr);

// The same stack as stored: IEEE binary16 bits, no float round trip (the live blend reads these
// directly, at half the memory). Layout and errors as read_exr_stack.
struct ImageStackHalf {
  int width = 0;
  int height = 0;
  int layers = 0;
  std::vector<std::uint16_t> data;        // data[(layer * height + row) * width + col]
};
ImageStackHalf read_exr_stack_half(const std::filesystem::path& file,
                                   std::vector<std::string>* layer_names = nullptr);

// NumPy .npy, little-endian float32, C order.
void write_npy(const std::filesystem::path& file, std::span<const float> data,
               std::span<const std::size_t> shape);
std::vector<float> read_npy(const std::filesystem::path& file, std::vector<std::size_t>* shape);
// The same for little-endian uint32 ('<u4'): indices, such as a refinement's edges.
void write_npy_u32(const std::filesystem::path& file, std::span<const std::uint32_t> data,
                   std::span<const std::size_t> shape);
std::vector<std::uint32_t> read_npy_u32(const std::filesystem::path& file, std::vector<std::size_t>* shape);

// Inspection without reading the data (cheap; used by verify). Both throw InputError naming the
// file for an unreadable or foreign file. read_npy_info also refuses a file size other than the
// shape requires; read_exr_info sees a cut-off header or offset table, but not missing pixel data
// (read_exr_stack does; verify compares sizes and hashes).
struct ExrInfo {
  int width = 0;
  int height = 0;
  std::vector<std::string> layer_names;   // of the "*.Y" channels, in the order read_exr_stack uses
};
ExrInfo read_exr_info(const std::filesystem::path& file);

struct NpyInfo {
  std::string descr;                      // '<f4' or '<u4' (four bytes per element)
  std::vector<std::size_t> shape;
  std::uint64_t data_offset = 0;          // bytes before the float32 data
};
NpyInfo read_npy_info(const std::filesystem::path& file);

}  // namespace skylit::bake_format
