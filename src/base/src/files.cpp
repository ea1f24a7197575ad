#include "skylit/base/files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <openssl/evp.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <system_error>

#include "skylit/base/error.hpp"

namespace fs = std::filesystem;

namespace skylit {
namespace {

// Owns a POSIX file descriptor.
class FileDescriptor {
 public:
  explicit FileDescriptor(int fd = -1) : fd_(fd) {}
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  FileDescriptor(FileDescriptor&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  FileDescriptor& operator=(FileDescriptor&&) = delete;
  int get() const { return fd_; }
  // Closes now and reports close's errno (0 on success): close can report a failed write-back.
  int close_now() {
    const int result = ::close(fd_);
    fd_ = -1;
    return result == 0 ? 0 : errno;
  }

 private:
  int fd_;
};

// Removes the temporary file unless released (the rename consumed it).
class TemporaryFile {
 public:
  explicit TemporaryFile(fs::path path) : path_(std::move(path)) {}
  ~TemporaryFile() {
    if (!path_.empty()) ::unlink(path_.c_str());
  }
  TemporaryFile(const TemporaryFile&) = delete;
  TemporaryFile& operator=(const TemporaryFile&) = delete;
  const fs::path& path() const { return path_; }
  void release() { path_.clear(); }

 private:
  fs::path path_;
};

[[noreturn]] void throw_write_error(const fs::path& path, int error_number) {
  throw InputError(input_message(path, -1, -1, "",
                                 "cannot write the file: " + std::string(std::strerror(error_number)),
                                 "check that the directory exists, is writable and has free space"));
}

// Creates an empty, unique temporary file beside `path` that keeps its extension (some
// libraries pick the format from it). Created with 0666 so the umask applies as for any file.
std::pair<fs::path, FileDescriptor> create_temporary_beside(const fs::path& path) {
  const fs::path directory = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::random_device entropy;
  std::mt19937_64 generator((static_cast<std::uint64_t>(entropy()) << 32) ^ entropy() ^
                            static_cast<std::uint64_t>(::getpid()));
  for (int attempt = 0; attempt < 100; ++attempt) {
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, "%016llx",
                  static_cast<unsigned long long>(generator()));
    // Built by appending: GCC 12 warns falsely (-Wrestrict) on "." + std::string.
    std::string name(1, '.');
    name.append(path.stem().string()).append(".tmp-").append(suffix).append(path.extension().string());
    const fs::path candidate = directory / name;
    const int fd = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) return {candidate, FileDescriptor(fd)};
    if (errno != EEXIST) throw_write_error(path, errno);
  }
  throw_write_error(path, EEXIST);
}

void sync_directory_of(const fs::path& path) {
  const fs::path directory = path.has_parent_path() ? path.parent_path() : fs::path(".");
  FileDescriptor fd(::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  // Some file systems cannot sync a directory (EINVAL); the rename has happened either way.
  if (fd.get() >= 0 && ::fsync(fd.get()) != 0 && errno != EINVAL && errno != EROFS) {
    throw_write_error(path, errno);
  }
}

void write_all(int fd, std::span<const std::byte> data, const fs::path& path) {
  std::size_t written = 0;
  while (written < data.size()) {
    const ssize_t n = ::write(fd, data.data() + written, data.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw_write_error(path, errno);
    }
    written += static_cast<std::size_t>(n);
  }
}

void commit(TemporaryFile& temporary, const fs::path& path) {
  if (::rename(temporary.path().c_str(), path.c_str()) != 0) throw_write_error(path, errno);
  temporary.release();
  sync_directory_of(path);
}

struct DigestContextDeleter {
  void operator()(EVP_MD_CTX* context) const { EVP_MD_CTX_free(context); }
};
using DigestContext = std::unique_ptr<EVP_MD_CTX, DigestContextDeleter>;

DigestContext new_sha256() {
  DigestContext context(EVP_MD_CTX_new());
  if (!context || EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("OpenSSL: cannot initialise SHA-256");
  }
  return context;
}

std::string finish_hex(EVP_MD_CTX* context) {
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int length = 0;
  if (EVP_DigestFinal_ex(context, digest.data(), &length) != 1) {
    throw std::runtime_error("OpenSSL: SHA-256 failed");
  }
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  hex.reserve(2 * length);
  for (unsigned int i = 0; i < length; ++i) {
    hex += kHex[digest[i] >> 4];
    hex += kHex[digest[i] & 0xF];
  }
  return hex;
}

// Owns a C stream.
struct FileCloser {
  void operator()(std::FILE* file) const { std::fclose(file); }
};
using UniqueFile = std::unique_ptr<std::FILE, FileCloser>;

UniqueFile open_for_reading(const fs::path& path) {
  UniqueFile file(std::fopen(path.c_str(), "rb"));
  if (!file) {
    throw InputError(input_message(path, -1, -1, "",
                                   "cannot read the file: " + std::string(std::strerror(errno)),
                                   "check that the path is right and the file is readable"));
  }
  return file;
}

[[noreturn]] void throw_read_error(const fs::path& path, int error_number) {
  throw InputError(input_message(path, -1, -1, "",
                                 "cannot read the file: " + std::string(std::strerror(error_number)),
                                 "check that the path names a readable regular file"));
}

// Streams a file in chunks to `consume`.
template <typename Consume>
void read_chunks(const fs::path& path, Consume&& consume) {
  UniqueFile file = open_for_reading(path);
  std::vector<char> buffer(1 << 16);
  for (;;) {
    errno = 0;
    const std::size_t n = std::fread(buffer.data(), 1, buffer.size(), file.get());
    if (n > 0) consume(buffer.data(), n);
    if (n < buffer.size()) {
      if (std::ferror(file.get())) throw_read_error(path, errno != 0 ? errno : EIO);
      return;
    }
  }
}

}  // namespace

void write_file_atomic(const fs::path& path, std::span<const std::byte> data) {
  auto [temporary_path, fd] = create_temporary_beside(path);
  TemporaryFile temporary(temporary_path);
  write_all(fd.get(), data, path);
  if (::fsync(fd.get()) != 0) throw_write_error(path, errno);
  if (const int error_number = fd.close_now(); error_number != 0) throw_write_error(path, error_number);
  commit(temporary, path);
}

void write_file_atomic(const fs::path& path, const std::string& text) {
  write_file_atomic(path, std::as_bytes(std::span<const char>(text.data(), text.size())));
}

void write_file_atomic_with(const fs::path& path,
                            const std::function<void(const fs::path& tmp)>& write) {
  auto [temporary_path, created] = create_temporary_beside(path);
  TemporaryFile temporary(temporary_path);
  if (const int error_number = created.close_now(); error_number != 0) {
    throw_write_error(path, error_number);
  }
  write(temporary.path());  // an exception leaves `path` untouched; the temporary is removed
  // The callback closed its own stream; sync what it wrote before the rename publishes it.
  FileDescriptor written(::open(temporary.path().c_str(), O_RDONLY | O_CLOEXEC));
  if (written.get() < 0) throw_write_error(path, errno);
  if (::fsync(written.get()) != 0) throw_write_error(path, errno);
  written.close_now();
  commit(temporary, path);
}

std::string read_file(const fs::path& path, std::uint64_t max_bytes) {
  std::error_code ignored;
  if (fs::is_directory(path, ignored)) throw_read_error(path, EISDIR);
  // Counted while reading, not from the size: a device or a pipe (/dev/zero) has none.
  const auto too_large = [&] {
    throw InputError(input_message(path, -1, -1, "",
                                   "the file is larger than " + std::to_string(max_bytes >> 20) +
                                       " MiB, more than any file of its kind holds",
                                   "check that the path names the right file"));
  };
  if (const std::uintmax_t size = fs::file_size(path, ignored); !ignored && size > max_bytes) too_large();
  std::string content;
  read_chunks(path, [&](const char* data, std::size_t n) {
    if (content.size() + n > max_bytes) too_large();
    content.append(data, n);
  });
  return content;
}

void check_readable(const fs::path& path) {
  std::error_code ignored;
  if (fs::is_directory(path, ignored)) throw_read_error(path, EISDIR);
  open_for_reading(path);
}

std::string sha256_file(const fs::path& path) {
  std::error_code ignored;
  if (fs::is_directory(path, ignored)) throw_read_error(path, EISDIR);
  DigestContext context = new_sha256();
  read_chunks(path, [&](const char* data, std::size_t n) {
    if (EVP_DigestUpdate(context.get(), data, n) != 1) {
      throw std::runtime_error("OpenSSL: SHA-256 failed");
    }
  });
  return finish_hex(context.get());
}

std::string sha256_hex(std::span<const std::byte> data) {
  DigestContext context = new_sha256();
  if (EVP_DigestUpdate(context.get(), data.data(), data.size()) != 1) {
    throw std::runtime_error("OpenSSL: SHA-256 failed");
  }
  return finish_hex(context.get());
}

void ensure_writable_directory(const fs::path& dir) {
  const auto fail = [&](const std::string& cause) {
    throw InputError("cannot write to output directory '" + dir.string() + "': " + cause +
                     ". Fix: choose a directory you can write to with -o");
  };
  std::error_code error;
  fs::create_directories(dir, error);
  if (error) fail(error.message());
  if (!fs::is_directory(dir, error)) fail("it is not a directory");
  // Permissions alone do not tell (read-only mounts, ACLs, root): create and remove a file.
  std::random_device entropy;
  char name[48];
  std::snprintf(name, sizeof name, ".skylit-write-probe-%08x%08x", entropy(), entropy());
  const fs::path probe = dir / name;
  FileDescriptor fd(::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600));
  if (fd.get() < 0) fail(std::strerror(errno));
  fd.close_now();
  if (::unlink(probe.c_str()) != 0) fail(std::strerror(errno));
}

}  // namespace skylit
