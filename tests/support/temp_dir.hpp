#pragma once
// Test helpers shared across test folders: the one temporary directory of the tests (per test, or
// per suite), and the message of the InputError an action throws.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <unistd.h>

#include "skylit/base/error.hpp"

namespace skylit::test {

// A path under the system temp dir that no other directory of this or another run has: the
// running test (or suite) for people reading /tmp, the process, and a count within it.
inline std::filesystem::path unique_temp_path(const std::string& prefix) {
  static std::atomic<int> count{0};
  const ::testing::UnitTest* unit = ::testing::UnitTest::GetInstance();
  std::string name = prefix;
  if (const ::testing::TestInfo* info = unit->current_test_info()) {
    name += std::string(info->test_suite_name()) + "_" + info->name() + "_";
  } else if (const ::testing::TestSuite* suite = unit->current_test_suite()) {
    name += std::string(suite->name()) + "_";
  }
  name += std::to_string(::getpid()) + "_" + std::to_string(count++);
  std::replace(name.begin(), name.end(), '/', '_');  // parameterised tests: Suite/Case
  return std::filesystem::temp_directory_path() / name;
}

// A fresh directory, removed with everything in it at scope end. Made in a test, in a suite's
// setup (held by a static pointer) or outside gtest's runs alike.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "skylit_") : path_(unique_temp_path(prefix)) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path file(const std::filesystem::path& name) const { return path_ / name; }
  std::filesystem::path operator/(const std::filesystem::path& name) const { return path_ / name; }
  // Writes `content` to `name` (its folders made) and returns its path.
  std::filesystem::path write(const std::filesystem::path& name, const std::string& content) const {
    const std::filesystem::path file = path_ / name;
    std::filesystem::create_directories(file.parent_path());
    std::ofstream(file, std::ios::binary) << content;
    return file;
  }

 private:
  std::filesystem::path path_;
};

// The message of the InputError `action` throws, or "(no InputError)".
template <typename Action>
std::string error_of(Action action) {
  try {
    action();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

}  // namespace skylit::test
