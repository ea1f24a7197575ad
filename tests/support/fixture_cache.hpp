#pragma once
// Expensive fixtures (bakes) made once per build of a test program and shared by its tests.
// CTest runs every test suite in a process of its own, so a fixture kept in a static is made
// again by each suite; this keeps it on disk instead, in the build tree, keyed by the test program's own
// size and modification time (a rebuilt program makes its fixtures anew). The first process to
// ask makes it under a lock; the others wait for it and reuse it.
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <system_error>

namespace skylit::test {

namespace cache_detail {

// This test program's file name: each program keeps its own fixtures (two programs may name
// fixtures alike, and neither may remove the other's while it reads them).
inline std::string program_name() {
  return std::filesystem::read_symlink("/proc/self/exe").filename().string();
}

// "<size>-<mtime ns>" of this test program: what a fixture made by it is valid for.
inline std::string program_key() {
  struct stat st{};
  if (::stat("/proc/self/exe", &st) != 0) throw std::runtime_error("fixture cache: cannot stat /proc/self/exe");
  return std::to_string(st.st_size) + "-" +
         std::to_string(static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec);
}

// An exclusive lock on a file, held while the object lives.
class FileLock {
 public:
  explicit FileLock(const std::filesystem::path& file) {
    fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0 || ::flock(fd_, LOCK_EX) != 0) {
      throw std::system_error(errno, std::generic_category(), "fixture cache: cannot lock " + file.string());
    }
  }
  ~FileLock() {
    if (fd_ >= 0) ::close(fd_);  // releases the lock
  }
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace cache_detail

// The folder of fixture `name` (letters, digits and '_'), made by `make(folder)` when this
// build of the test program has not made it yet. `make` writes into the empty folder it is given;
// the folder is published only when `make` returns, so a failed or killed maker leaves nothing
// that a later test would trust. Fixtures of earlier builds of this program are removed.
inline std::filesystem::path cached_fixture(const std::string& name,
                                            const std::function<void(const std::filesystem::path&)>& make) {
  namespace fs = std::filesystem;
  const fs::path root = fs::path(SKYLIT_BINARY_DIR) / "test-fixtures" / cache_detail::program_name();
  fs::create_directories(root);
  const cache_detail::FileLock lock(root / (name + ".lock"));
  const std::string key = cache_detail::program_key();
  const fs::path ready = root / (name + "-" + key);
  if (fs::is_directory(ready)) return ready;
  for (const auto& entry : fs::directory_iterator(root)) {
    const std::string other = entry.path().filename().string();
    if (entry.is_directory() && other.rfind(name + "-", 0) == 0) fs::remove_all(entry.path());
  }
  const fs::path partial = root / (name + ".partial");
  fs::remove_all(partial);
  fs::create_directories(partial);
  make(partial);
  fs::rename(partial, ready);
  return ready;
}

}  // namespace skylit::test
