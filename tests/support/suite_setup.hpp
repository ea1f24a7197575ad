#pragma once
// A suite's shared setup whose failure fails every test of the suite. gtest turns an exception
// thrown in SetUpTestSuite into skipped tests, and ctest counts skipped tests as passed: a bake
// that breaks in a suite's setup would go unseen.
#include <gtest/gtest.h>

#include <exception>
#include <functional>
#include <string>

namespace skylit::test {

class SuiteSetup {
 public:
  // Runs `setup` (in SetUpTestSuite), keeping the message of anything it throws.
  void run(const std::function<void()>& setup) {
    error_.clear();
    try {
      setup();
    } catch (const std::exception& e) {
      error_ = e.what();
    } catch (...) {
      error_ = "an exception that is not a std::exception";
    }
  }
  // In SetUp(): a fatal failure, so that the test body does not run, when the setup failed.
  void require() const { ASSERT_TRUE(error_.empty()) << "the suite's setup failed: " << error_; }

 private:
  std::string error_;
};

}  // namespace skylit::test
