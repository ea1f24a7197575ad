// skylit::read_file for the standalone GPU benchmark build (bench/gpu_standalone.sh): the GPU
// module's shader loader needs only this function of src/base/src/files.cpp, whose other
// functions need OpenSSL for their hashes.
#include <fstream>
#include <sstream>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit {

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(input_message(path, -1, -1, "file", "cannot be read", "check the path and permissions"));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace skylit
