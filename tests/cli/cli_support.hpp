#pragma once
// Shared by the end-to-end tests: run a program from build/bin as a user would, and the tests'
// temporary directory.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>

#include "../support/temp_dir.hpp"

namespace skylit::cli_test {

namespace fs = std::filesystem;

inline const fs::path kBin = fs::path(SKYLIT_BINARY_DIR) / "bin";
inline const fs::path kSource = fs::path(SKYLIT_SOURCE_DIR);

struct Result {
  int status = -1;
  std::string output;  // stdout and stderr together
};

inline Result run_program(const fs::path& program, const std::string& args) {
  const std::string command = program.string() + " " + args + " 2>&1";
  Result r;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe)) r.output += buffer.data();
  const int raw = pclose(pipe);
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return r;
}

using skylit::test::TempDir;

}  // namespace skylit::cli_test
