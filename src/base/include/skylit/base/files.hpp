#pragma once
// File helpers shared by every writer: atomic writes and content hashes.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>

namespace skylit {

// Writes `path` atomically: the data goes to a temporary file beside it, is flushed and
// fsync'ed, then renamed over `path` (and the directory fsync'ed). On any failure (full disk,
// permissions) the temporary file is removed, `path` is left as it was, and InputError is
// thrown naming the path and the cause.
void write_file_atomic(const std::filesystem::path& path, std::span<const std::byte> data);
void write_file_atomic(const std::filesystem::path& path, const std::string& text);

// Atomic write through a callback that writes to a temporary path (for libraries that insist on
// writing files themselves, like OpenEXR). The callback gets the temporary path.
void write_file_atomic_with(const std::filesystem::path& path,
                            const std::function<void(const std::filesystem::path& tmp)>& write);

// The whole file. InputError naming it when it cannot be read or holds more than `max_bytes`
// (the default is more than any config, manifest, CSV or token holds; a caller that knows a
// larger size to expect passes it).
inline constexpr std::uint64_t kMaxReadBytes = std::uint64_t{256} << 20;
std::string read_file(const std::filesystem::path& path, std::uint64_t max_bytes = kMaxReadBytes);

// InputError naming the file and the cause (permissions, a missing file) when it cannot be opened
// for reading: before a path goes to a library that cannot tell why it failed (OpenCV's imread).
void check_readable(const std::filesystem::path& path);

// Lower-case hex SHA-256 of a file's contents or of a buffer.
std::string sha256_file(const std::filesystem::path& path);
std::string sha256_hex(std::span<const std::byte> data);

// Makes `dir` (and parents) and checks that a file can be created in it; InputError otherwise.
void ensure_writable_directory(const std::filesystem::path& dir);

}  // namespace skylit
