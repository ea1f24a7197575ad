// A sky that crossed the link blends as the sky it was (docs/site.md): S and the sun decode bit
// for bit, so a node's T is the sky stage's in-process T, byte for byte, with a sun and without.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "skylit/blend/cpu_blend.hpp"
#include "skylit/sky_link/sky_message.hpp"
#include "../blend/blend_fixtures.hpp"

namespace skylit::sky_link {
namespace sky_blend_identity_test {  // named, not anonymous: the test program is one unity build

SkyIdentity dome_identity() { return {"sample gate", 2, geom::DomeBasis::Faces, 40}; }

// 40 layers of values whose bits a text or float round trip would change: thirds, the tiniest
// normal and subnormal doubles, long mantissas and their neighbours one ulp away, and zeros.
std::vector<Eigen::Vector3d> awkward_sky() {
  const double tiny = std::numeric_limits<double>::denorm_min();
  std::vector<Eigen::Vector3d> S;
  for (int i = 0; i < 40; ++i) {
    const double k = i + 1;
    const double third = k / 3.0;
    S.emplace_back(third, std::nextafter(7.123456789e5 / k, 1e9), std::nextafter(third, 0.0));
  }
  S[1] = Eigen::Vector3d(1e-300, 1.0 / 3.0, 7.123456789e5);
  S[2] = Eigen::Vector3d(tiny, std::numeric_limits<double>::min(), std::nextafter(1.0, 2.0));
  S[3] = Eigen::Vector3d(0.0, std::nextafter(0.1, 1.0), 2.0 / 3.0);
  S[4] = Eigen::Vector3d::Zero();
  return S;
}

SkyMessage message_of(const std::vector<Eigen::Vector3d>& S, const std::optional<blend::SunLight>& sun) {
  SkyMessage m;
  m.identity = dome_identity();
  m.sequence = 11;
  m.frame_timestamp = 86400.0 / 7.0;
  m.S = S;
  if (sun) {
    m.sources.push_back({sun->direction, sun->energy, 0.0046, false});
    m.sun_reason = "sun: a test sun";
  } else {
    m.sun_reason = "no sun: a test sky";
  }
  return m;
}

// The blend a node makes of what it decoded, beside the one made of what was sent.
void expect_same_blend(const std::optional<blend::SunLight>& sun) {
  // A 16 × 8 plane of 40 random half layers, some faces unseen, the sun partly shadowed.
  const blend::test::RandomScene scene = blend::test::random_scene(40, 16, 8, 2024);
  const std::vector<Eigen::Vector3d> S = awkward_sky();
  const SkyMessage sent = message_of(S, sun);

  const DecodedSky got = decode_sky_message(encode_sky_message(sent), dome_identity(), std::nullopt);
  ASSERT_TRUE(got.message) << got.detail;
  const SkyMessage& m = *got.message;
  ASSERT_EQ(m.S.size(), S.size());
  for (std::size_t i = 0; i < S.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_EQ(std::bit_cast<std::uint64_t>(m.S[i][c]), std::bit_cast<std::uint64_t>(S[i][c]))
          << "layer " << i << " channel " << c;
    }
  }
  std::optional<blend::SunLight> decoded_sun;
  ASSERT_EQ(m.sources.size(), sun ? 1u : 0u);
  if (sun) {
    decoded_sun = blend::SunLight{m.sources[0].direction, m.sources[0].energy};
    for (int c = 0; c < 3; ++c) {
      ASSERT_EQ(std::bit_cast<std::uint64_t>(decoded_sun->direction[c]), std::bit_cast<std::uint64_t>(sun->direction[c]));
      ASSERT_EQ(std::bit_cast<std::uint64_t>(decoded_sun->energy[c]), std::bit_cast<std::uint64_t>(sun->energy[c]));
    }
  }

  const std::span<const float> visibility = sun ? std::span<const float>(scene.visibility) : std::span<const float>();
  const auto blend_of = [&](const std::vector<Eigen::Vector3d>& sky, const std::optional<blend::SunLight>& light) {
    const blend::BlendWeights weights = blend::blend_weights(scene.basis, sky, light);
    std::vector<float> T(3 * scene.basis.texel_count());
    blend::blend_cpu(scene.basis, weights, visibility, T);
    return T;
  };
  const std::vector<float> in_process = blend_of(S, sun);
  const std::vector<float> on_node = blend_of(m.S, decoded_sun);
  ASSERT_EQ(on_node.size(), in_process.size());
  EXPECT_EQ(std::memcmp(on_node.data(), in_process.data(), in_process.size() * sizeof(float)), 0);
  // Not trivially equal: the sky lights the plane unevenly.
  EXPECT_NE(*std::min_element(in_process.begin(), in_process.end()),
            *std::max_element(in_process.begin(), in_process.end()));
}

TEST(SkyBlendIdentity, ANodesBlendOfADecodedSkyWithASunIsTheSkyStagesBitForBit) {
  blend::SunLight sun;
  sun.direction = Eigen::Vector3d(0.3, -0.4, std::sqrt(2.0) / 3.0).normalized();
  sun.energy = Eigen::Vector3d(812.0 / 3.0, std::nextafter(790.5, 0.0), 7.123456789e2);
  expect_same_blend(sun);
}

TEST(SkyBlendIdentity, ANodesBlendOfADecodedSkyWithoutASunIsTheSkyStagesBitForBit) {
  expect_same_blend(std::nullopt);
}

}  // namespace sky_blend_identity_test
}  // namespace skylit::sky_link
