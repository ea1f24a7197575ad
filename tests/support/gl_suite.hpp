#pragma once
// A test fixture whose suite shares one headless OpenGL ES context: made before the suite's
// first test, destroyed after its last (the tests' GL objects die before it). Derive a suite's
// fixture from it: class GpuBlend : public skylit::test::GlSuite {};
#include <gtest/gtest.h>

#include "skylit/gpu/egl_context.hpp"

namespace skylit::test {

class GlSuite : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { context_ = new gpu::HeadlessContext(); }
  static void TearDownTestSuite() {
    delete context_;
    context_ = nullptr;
  }

 private:
  static inline gpu::HeadlessContext* context_ = nullptr;
};

}  // namespace skylit::test
