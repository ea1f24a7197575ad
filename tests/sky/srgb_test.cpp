#include "skylit/sky/srgb.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "skylit/sky/radiometry.hpp"

// Outside skylit::sky: radiometry_test.cpp keeps its own reference srgb_encode there, and the two
// may share a translation unit.
namespace skylit::srgb_test {
namespace {

using sky::ResponseCurve;

// Published values of IEC 61966-2-1: mid grey, 18 % grey, the break points, the ends.
TEST(Srgb, EncodesAndDecodesKnownValues) {
  EXPECT_DOUBLE_EQ(sky::srgb_encode(0.0), 0.0);
  EXPECT_NEAR(sky::srgb_encode(1.0), 1.0, 1e-15);
  EXPECT_NEAR(sky::srgb_encode(0.5), 0.7353569830524495, 1e-15);
  EXPECT_NEAR(sky::srgb_encode(0.18), 0.46135612950044164, 1e-15);
  EXPECT_NEAR(sky::srgb_encode(0.0031308), 0.040449936, 1e-12);  // the linear segment's end
  EXPECT_NEAR(sky::srgb_encode(0.001), 0.01292, 1e-15);
  EXPECT_NEAR(sky::srgb_decode(0.5), 0.21404114048223255, 1e-15);
  EXPECT_NEAR(sky::srgb_decode(128.0 / 255.0), 0.21586050011389926, 1e-15);
  EXPECT_NEAR(sky::srgb_decode(0.04045), 0.0031308049535603713, 1e-15);
  EXPECT_NEAR(sky::srgb_decode(1.0), 1.0, 1e-15);
  EXPECT_EQ(sky::srgb_encode8(0.5), 188);
  EXPECT_EQ(sky::srgb_encode8(0.18), 118);
  EXPECT_EQ(sky::srgb_encode8(1.0), 255);
}

TEST(Srgb, ClampsOutOfRangeAndNotANumber) {
  EXPECT_EQ(sky::srgb_encode(-0.5), 0.0);
  EXPECT_EQ(sky::srgb_encode(2.0), sky::srgb_encode(1.0));
  EXPECT_EQ(sky::srgb_encode(std::numeric_limits<double>::infinity()), sky::srgb_encode(1.0));
  EXPECT_EQ(sky::srgb_encode(std::numeric_limits<double>::quiet_NaN()), 0.0);
  EXPECT_EQ(sky::srgb_encode(std::numeric_limits<float>::quiet_NaN()), 0.0f);
  EXPECT_EQ(sky::srgb_decode(-1.0), 0.0);
  EXPECT_EQ(sky::srgb_decode(7.0), sky::srgb_decode(1.0));
}

TEST(Srgb, TheInverseAndTheFloatFormAgree) {
  for (int i = 0; i <= 1000; ++i) {
    const double v = i / 1000.0;
    EXPECT_NEAR(sky::srgb_decode(sky::srgb_encode(v)), v, 1e-12) << v;
    EXPECT_NEAR(sky::srgb_encode(static_cast<float>(v)), sky::srgb_encode(v), 2e-7) << v;
  }
}

// Every 8-bit code of the sRGB response curve is the decoded code, and encodes back to itself.
TEST(Srgb, TheResponseCurveIsTheDecoding) {
  const ResponseCurve curve = ResponseCurve::srgb(8);
  for (int z = 0; z < 256; ++z) {
    EXPECT_EQ(curve.bgr[1][static_cast<std::size_t>(z)], static_cast<float>(sky::srgb_decode(z / 255.0))) << z;
    EXPECT_EQ(sky::srgb_encode8(sky::srgb_decode(z / 255.0)), z) << z;
  }
}

}  // namespace
}  // namespace skylit::srgb_test
