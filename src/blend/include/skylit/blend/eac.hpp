#pragma once
// EAC R11 block compression (OpenGL ES 3.0 core: GL_COMPRESSED_R11_EAC, every ES 3 driver
// decodes it), for basis layers on the GPU (gpu_blend.hpp, BasisStorage::Eac11).
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace skylit::blend {

// A 4×4 block of one channel is 64 bits: a base codeword b (8 bits), a multiplier m (4), a
// modifier table t (4) and a 3-bit index j per texel; the decoded 11-bit value is
//
//     clamp(8b + 4 + M[t][j] · 8m, 0, 2047)      (m = 0: 8b + 4 + M[t][j])
//
// extended to 16 bits ((v << 5) | (v >> 6)) and read as unorm16. 0.5 byte per texel, a quarter
// of a half-float layer.
inline constexpr std::size_t kEacBlockBytes = 8;

// Blocks of a width × height image: ceil(width / 4) × ceil(height / 4), row-major.
std::size_t eac_block_count(int width, int height);

// Encodes `values` (width × height, row-major, each in [0, 1]; outside is clamped, NaN taken as
// 0) into R11 EAC blocks as glCompressedTexSubImage3D takes them (big-endian 64-bit words, block
// rows top to bottom). Texels past the image's edge repeat its last row and column.
// The encoder searches every table and, per table, the multipliers and base codewords around the
// block's range (least squares, each texel at its nearest level): flat blocks (most of a basis
// image) and shadow edges between 0 and 1 come back within half an 11-bit step; a steep smooth
// block holds eight levels, so its error grows with its range (within 1% of an exhaustive
// search's on the test's layers). About 0.5 s per 512² layer of smooth content on one core,
// 0.03 s for flat content.
std::vector<std::uint8_t> encode_eac_r11(std::span<const float> values, int width, int height);

// What a driver decodes from the blocks: width × height values in [0, 1] (unorm16 steps).
std::vector<float> decode_eac_r11(std::span<const std::uint8_t> blocks, int width, int height);

}  // namespace skylit::blend
