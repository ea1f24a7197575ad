// analyse_footprint: which layers of a plane hold a shadow, and the rectangle each one shadows.
#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>

#include "skylit/bake_format/footprint.hpp"

namespace skylit::bake_format {
namespace {

// Five layers of 10 × 6: dark, unshadowed, unshadowed but for half-float rounding, shadowed in
// one rectangle, and shadowed by a hair (less than the tolerance) everywhere.
struct Fixture {
  ImageStack stack;
  std::vector<double> unoccluded{0.0, 0.2, 0.3, 0.25, 0.1};
  Fixture() {
    stack.width = 10;
    stack.height = 6;
    stack.layers = 5;
    stack.data.assign(5 * 60, 0.0f);
    for (int l = 1; l < 5; ++l) {
      for (float& b : stack.layer(l)) b = static_cast<float>(unoccluded[static_cast<std::size_t>(l)]);
    }
    for (float& b : stack.layer(2)) b *= 1.0f - 3e-4f;  // under the rounding of half floats
    for (int row = 2; row <= 4; ++row) {
      for (int col = 3; col <= 7; col += 4) stack.layer(3)[static_cast<std::size_t>(row * 10 + col)] = 0.1f;
    }
    for (float& b : stack.layer(4)) b *= 1.0f - 5e-4f;  // a hair of shadow, below the tolerance
  }
};

TEST(Footprint, SortsLayersAndFindsTheShadowedRectangle) {
  const Fixture f;
  const PlaneFootprint footprint = analyse_footprint(f.stack, f.unoccluded);
  ASSERT_EQ(footprint.layers.size(), 5u);
  EXPECT_EQ(footprint.layers[0].kind, LayerFootprint::Kind::Dark);
  EXPECT_EQ(footprint.layers[1].kind, LayerFootprint::Kind::Unshadowed);
  EXPECT_EQ(footprint.layers[2].kind, LayerFootprint::Kind::Unshadowed);
  EXPECT_EQ(footprint.layers[4].kind, LayerFootprint::Kind::Unshadowed);
  const LayerFootprint& shadowed = footprint.layers[3];
  ASSERT_EQ(shadowed.kind, LayerFootprint::Kind::Shadowed);
  EXPECT_EQ(shadowed.col, 3);
  EXPECT_EQ(shadowed.row, 2);
  EXPECT_EQ(shadowed.cols, 5);
  EXPECT_EQ(shadowed.rows, 3);
  EXPECT_EQ(footprint.dark, 1);
  EXPECT_EQ(footprint.unshadowed, 3);
  EXPECT_EQ(footprint.shadowed, 1);
  EXPECT_EQ(footprint.shadowed_texels, 15u);
  EXPECT_EQ(footprint.texels, 60u);
  EXPECT_EQ(footprint.needed_layers(), 2);  // the shadowed layer and one of ones
}

TEST(Footprint, ATighterToleranceSeesTheHair) {
  const Fixture f;
  const PlaneFootprint footprint = analyse_footprint(f.stack, f.unoccluded, 1e-4);
  EXPECT_EQ(footprint.layers[4].kind, LayerFootprint::Kind::Shadowed);
  EXPECT_EQ(footprint.layers[4].cols * footprint.layers[4].rows, 60);
}

TEST(Footprint, HalfFloatsGiveTheSameAnswer) {
  const Fixture f;
  ImageStackHalf half;
  half.width = f.stack.width;
  half.height = f.stack.height;
  half.layers = f.stack.layers;
  // Bits of 0.1 (0x2E66), 0.2 (0x3266), 0.3 (0x34CD), 0.25 (0x3400) as half floats.
  const std::uint16_t bits[] = {0x0000, 0x3266, 0x34CD, 0x3400, 0x2E66};
  for (int l = 0; l < 5; ++l) half.data.insert(half.data.end(), 60, bits[l]);
  half.data[3 * 60 + 25] = 0x2E66;  // layer 3, texel (col 5, row 2): shadowed
  const PlaneFootprint footprint = analyse_footprint(half, f.unoccluded);
  EXPECT_EQ(footprint.dark, 1);
  EXPECT_EQ(footprint.unshadowed, 3);
  ASSERT_EQ(footprint.layers[3].kind, LayerFootprint::Kind::Shadowed);
  EXPECT_EQ(footprint.layers[3].col, 5);
  EXPECT_EQ(footprint.layers[3].row, 2);
  EXPECT_EQ(footprint.layers[3].cols * footprint.layers[3].rows, 1);
}

TEST(Footprint, NaNStaysInTheData) {
  Fixture f;
  f.stack.layer(1)[7] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(analyse_footprint(f.stack, f.unoccluded).layers[1].kind, LayerFootprint::Kind::Shadowed);
}

TEST(Footprint, BadInputIsRefused) {
  const Fixture f;
  const std::vector<double> short_a(4, 0.1);
  EXPECT_THROW(analyse_footprint(f.stack, short_a), std::invalid_argument);
  EXPECT_THROW(analyse_footprint(f.stack, f.unoccluded, 1.0), std::invalid_argument);
  EXPECT_THROW(analyse_footprint(f.stack, f.unoccluded, -0.1), std::invalid_argument);
}

}  // namespace
}  // namespace skylit::bake_format
