#pragma once
// Prometheus' own check of a /metrics text (`promtool check metrics`, Debian's prometheus): what
// it objects to, empty when it accepts the text.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "temp_dir.hpp"

namespace skylit::test {

inline std::string promtool_problems(const std::string& metrics) {
  if (!std::filesystem::exists("/usr/bin/promtool")) {
    return "/usr/bin/promtool is missing: install Debian's prometheus (scripts/install-deps.sh)";
  }
  const TempDir dir("skylit_promtool_");
  const auto file = dir.write("metrics.txt", metrics);
  const std::string command = "/usr/bin/promtool check metrics < '" + file.string() + "' 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return "cannot run promtool";
  std::string output;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe) != nullptr) output += buffer;
  const int status = ::pclose(pipe);
  return status == 0 ? std::string() : (output.empty() ? std::string("promtool failed") : output);
}

}  // namespace skylit::test
