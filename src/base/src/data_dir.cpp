#include "skylit/base/data_dir.hpp"

#include <cstdlib>
#include <system_error>

namespace skylit {

std::filesystem::path data_dir() {
  if (const char* env = std::getenv("SKYLIT_DATA_DIR"); env != nullptr && *env != '\0') return env;
  std::error_code error;
  const std::filesystem::path executable = std::filesystem::read_symlink("/proc/self/exe", error);
  // Without /proc (a chroot without it), the folder a program is started from stands in.
  const std::filesystem::path bin = error ? std::filesystem::current_path() : executable.parent_path();
  return (bin / ".." / "share" / "skylit").lexically_normal();
}

}  // namespace skylit
