// The published sky's codec: bit-exact round trips, and every kind of bad message dropped with
// its reason, never a crash (docs/site.md).
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "skylit/sky_link/sky_message.hpp"

namespace skylit::sky_link {
namespace {

SkyIdentity gate_identity() { return {"sample gate", 2, geom::DomeBasis::Faces, 40}; }

SkyMessage sample_message(std::uint64_t sequence = 7) {
  SkyMessage m;
  m.identity = gate_identity();
  m.sequence = sequence;
  m.frame_timestamp = 1234.5678901234567;
  m.utc = 1782000000;
  std::mt19937_64 random(42);
  std::uniform_real_distribution<double> value(0.0, 5000.0);
  for (int i = 0; i < m.identity.layers; ++i) m.S.emplace_back(value(random), value(random) * 1e-9, value(random) / 3);
  m.S[3] = Eigen::Vector3d(std::numeric_limits<double>::denorm_min(), 0.1, 1e308);
  m.sources.push_back({Eigen::Vector3d(0.3, -0.4, std::sqrt(1 - 0.25)), Eigen::Vector3d(812.25, 790.5, 700.125), 0.0046, true});
  m.sun_reason = "sun: contrast 412 over 37 pixels";
  m.unseen_faces = 2;
  m.bad_pixels = 17;
  m.clipped_pixels = 123456789012LL;
  return m;
}

std::uint64_t bits(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

TEST(SkyMessage, RoundTripsEveryBitOfEveryField) {
  const SkyMessage sent = sample_message();
  const std::vector<std::uint8_t> bytes = encode_sky_message(sent);
  const DecodedSky got = decode_sky_message(bytes, gate_identity(), std::nullopt);
  ASSERT_TRUE(got.message) << got.detail;
  const SkyMessage& m = *got.message;
  EXPECT_EQ(got.dropped, DropReason::None);
  EXPECT_EQ(m.sequence, sent.sequence);
  EXPECT_EQ(bits(m.frame_timestamp), bits(sent.frame_timestamp));
  EXPECT_EQ(m.utc, sent.utc);
  ASSERT_EQ(m.S.size(), sent.S.size());
  for (std::size_t i = 0; i < m.S.size(); ++i) {
    for (int c = 0; c < 3; ++c) EXPECT_EQ(bits(m.S[i][c]), bits(sent.S[i][c])) << "layer " << i << " channel " << c;
  }
  ASSERT_EQ(m.sources.size(), 1u);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(bits(m.sources[0].direction[c]), bits(sent.sources[0].direction[c]));
    EXPECT_EQ(bits(m.sources[0].energy[c]), bits(sent.sources[0].energy[c]));
  }
  EXPECT_EQ(bits(m.sources[0].angular_radius), bits(sent.sources[0].angular_radius));
  EXPECT_TRUE(m.sources[0].clipped);
  EXPECT_EQ(m.sun_reason, sent.sun_reason);
  EXPECT_EQ(m.unseen_faces, 2);
  EXPECT_EQ(m.bad_pixels, 17);
  EXPECT_EQ(m.clipped_pixels, 123456789012LL);
  EXPECT_EQ(m.identity.site, "sample gate");
  // 40 layers of RGB doubles and the rest (a source with how it was found and weighed): under 1.6 kB.
  EXPECT_LT(bytes.size(), 1600u);
}

TEST(SkyMessage, AMessageWithoutTimeOrSourcesRoundTrips) {
  SkyMessage sent = sample_message();
  sent.utc.reset();
  sent.sources.clear();
  const DecodedSky got = decode_sky_message(encode_sky_message(sent), gate_identity(), std::nullopt);
  ASSERT_TRUE(got.message) << got.detail;
  EXPECT_FALSE(got.message->utc);
  EXPECT_TRUE(got.message->sources.empty());
}

TEST(SkyMessage, LampsKeepTheirPlaceAndAnOlderSkyNodesSourceIsTheSun) {
  // A sky node with sky.max_sources > 1 publishes the sun and lamps, each saying which it is.
  SkyMessage sent = sample_message();
  sent.sources[0].sun = true;
  sent.sources.push_back({Eigen::Vector3d(0, 0.6, 0.8), Eigen::Vector3d(3, 2, 1), 0.05, false, false});
  sent.sources.push_back({Eigen::Vector3d(0.8, 0, 0.6), Eigen::Vector3d(1, 1, 1), 0.02, false, false, 0.035});
  const DecodedSky got = decode_sky_message(encode_sky_message(sent), gate_identity(), std::nullopt);
  ASSERT_TRUE(got.message) << got.detail;
  ASSERT_EQ(got.message->sources.size(), 3u);
  EXPECT_TRUE(got.message->sources[0].sun);
  EXPECT_FALSE(got.message->sources[1].sun);
  EXPECT_FALSE(got.message->sources[2].sun);
  EXPECT_EQ(bits(got.message->sources[2].angular_radius), bits(0.02));
  EXPECT_EQ(bits(got.message->sources[2].shadow_radius), bits(0.035));

  // No sun, lamps only: the first source is a lamp.
  SkyMessage lamps_only = sent;
  lamps_only.sources.erase(lamps_only.sources.begin());
  const DecodedSky lamps = decode_sky_message(encode_sky_message(lamps_only), gate_identity(), std::nullopt);
  ASSERT_TRUE(lamps.message) << lamps.detail;
  EXPECT_FALSE(lamps.message->sources[0].sun);

  // An older sky node's message has no "sun" field: it published the sun alone, first.
  nlohmann::json older = nlohmann::json::from_cbor(encode_sky_message(sent));
  for (auto& source : older["sources"]) {
    source.erase("sun");
    source.erase("shadow_radius");
  }
  const DecodedSky old = decode_sky_message(nlohmann::json::to_cbor(older), gate_identity(), std::nullopt);
  ASSERT_TRUE(old.message) << old.detail;
  EXPECT_TRUE(old.message->sources[0].sun);
  EXPECT_FALSE(old.message->sources[1].sun);
  EXPECT_EQ(old.message->sources[2].shadow_radius, 0.0);

  // A "sun" that is not true or false is malformed.
  nlohmann::json bad = nlohmann::json::from_cbor(encode_sky_message(sent));
  bad["sources"][1]["sun"] = 1;
  const DecodedSky refused = decode_sky_message(nlohmann::json::to_cbor(bad), gate_identity(), std::nullopt);
  EXPECT_FALSE(refused.message);
  EXPECT_EQ(refused.dropped, DropReason::Malformed);
  EXPECT_NE(refused.detail.find("sources.sun"), std::string::npos) << refused.detail;
}

TEST(SkyMessage, TheSunsColourFlagCrossesTheLinkAndOlderMessagesHaveNone) {
  SkyMessage sent = sample_message();
  sent.sources[0].sun = true;
  sent.sources[0].colour_corrected = true;
  const DecodedSky got = decode_sky_message(encode_sky_message(sent), gate_identity(), std::nullopt);
  ASSERT_TRUE(got.message) << got.detail;
  EXPECT_TRUE(got.message->sources[0].colour_corrected);
  nlohmann::json older = nlohmann::json::from_cbor(encode_sky_message(sent));
  older["sources"][0].erase("colour_corrected");
  const DecodedSky old = decode_sky_message(nlohmann::json::to_cbor(older), gate_identity(), std::nullopt);
  ASSERT_TRUE(old.message) << old.detail;
  EXPECT_FALSE(old.message->sources[0].colour_corrected);
  nlohmann::json bad = nlohmann::json::from_cbor(encode_sky_message(sent));
  bad["sources"][0]["colour_corrected"] = "yes";
  const DecodedSky refused = decode_sky_message(nlohmann::json::to_cbor(bad), gate_identity(), std::nullopt);
  EXPECT_FALSE(refused.message);
  EXPECT_EQ(refused.dropped, DropReason::Malformed);
  EXPECT_NE(refused.detail.find("sources.colour_corrected"), std::string::npos) << refused.detail;
}

// How a clipped sun was placed and weighed crosses the link; an older message says what older
// nodes did (the peak, measured, fully sure); values outside the vocabulary are malformed.
TEST(SkyMessage, AClippedSunsPlaceAndEstimatorCrossTheLink) {
  SkyMessage sent = sample_message();
  sent.sources[0].sun = true;
  sent.sources[0].clipped = true;
  sent.sources[0].located_by = "expected";
  sent.sources[0].energy_estimator = "clear_sky";
  sent.sources[0].energy_confidence = 0.75;
  const DecodedSky got = decode_sky_message(encode_sky_message(sent), gate_identity(), std::nullopt);
  ASSERT_TRUE(got.message) << got.detail;
  EXPECT_EQ(got.message->sources[0].located_by, "expected");
  EXPECT_EQ(got.message->sources[0].energy_estimator, "clear_sky");
  EXPECT_DOUBLE_EQ(got.message->sources[0].energy_confidence, 0.75);
  nlohmann::json older = nlohmann::json::from_cbor(encode_sky_message(sent));
  for (const char* key : {"located_by", "energy_estimator", "energy_confidence"}) older["sources"][0].erase(key);
  const DecodedSky old = decode_sky_message(nlohmann::json::to_cbor(older), gate_identity(), std::nullopt);
  ASSERT_TRUE(old.message) << old.detail;
  EXPECT_EQ(old.message->sources[0].located_by, "peak");
  EXPECT_EQ(old.message->sources[0].energy_estimator, "measured");
  EXPECT_DOUBLE_EQ(old.message->sources[0].energy_confidence, 1.0);
  for (const auto& [key, value] : std::vector<std::pair<std::string, nlohmann::json>>{
           {"located_by", "guessed"}, {"energy_estimator", "oracle"}, {"energy_confidence", 1.5}}) {
    nlohmann::json bad = nlohmann::json::from_cbor(encode_sky_message(sent));
    bad["sources"][0][key] = value;
    const DecodedSky refused = decode_sky_message(nlohmann::json::to_cbor(bad), gate_identity(), std::nullopt);
    EXPECT_FALSE(refused.message) << key;
    EXPECT_NE(refused.detail.find("sources." + key), std::string::npos) << refused.detail;
  }
}

TEST(SkyMessage, EveryTruncationIsDroppedAsMalformed) {
  const std::vector<std::uint8_t> bytes = encode_sky_message(sample_message());
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    const DecodedSky got = decode_sky_message(std::span(bytes.data(), n), gate_identity(), std::nullopt);
    ASSERT_FALSE(got.message) << n << " bytes";
    ASSERT_EQ(got.dropped, DropReason::Malformed) << n << " bytes: " << got.detail;
  }
}

TEST(SkyMessage, RandomBytesAndFlippedBytesNeverCrashOrPassUnchecked) {
  std::mt19937 random(7);
  for (int trial = 0; trial < 2000; ++trial) {
    std::vector<std::uint8_t> bytes(random() % 300);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(random());
    const DecodedSky got = decode_sky_message(bytes, gate_identity(), std::nullopt);
    ASSERT_FALSE(got.message);
    ASSERT_NE(got.dropped, DropReason::None);
  }
  // A flipped byte of a good message: either still a complete, checked sky or dropped.
  const std::vector<std::uint8_t> good = encode_sky_message(sample_message());
  for (std::size_t i = 0; i < good.size(); ++i) {
    std::vector<std::uint8_t> bytes = good;
    bytes[i] ^= static_cast<std::uint8_t>(1 + random() % 255);
    const DecodedSky got = decode_sky_message(bytes, gate_identity(), std::nullopt);
    if (got.message) {
      ASSERT_EQ(got.message->S.size(), 40u);
      for (const auto& s : got.message->S) ASSERT_TRUE(s.allFinite());
    } else {
      ASSERT_NE(got.dropped, DropReason::None);
    }
  }
}

TEST(SkyMessage, OversizedMessagesAreDroppedUnread) {
  const std::vector<std::uint8_t> bytes(kMaxSkyMessageBytes + 1, 0xa0);
  const DecodedSky got = decode_sky_message(bytes, gate_identity(), std::nullopt);
  EXPECT_EQ(got.dropped, DropReason::Oversized);
  EXPECT_NE(got.detail.find("67108865 bytes"), std::string::npos) << got.detail;
}

TEST(SkyMessage, NonFiniteOrNonUnitValuesAreMalformed) {
  SkyMessage nan_s = sample_message();
  nan_s.S[5].y() = std::numeric_limits<double>::quiet_NaN();
  DecodedSky got = decode_sky_message(encode_sky_message(nan_s), gate_identity(), std::nullopt);
  EXPECT_EQ(got.dropped, DropReason::Malformed);
  EXPECT_NE(got.detail.find("'S' is not finite"), std::string::npos) << got.detail;

  SkyMessage long_direction = sample_message();
  long_direction.sources[0].direction *= 1.01;
  got = decode_sky_message(encode_sky_message(long_direction), gate_identity(), std::nullopt);
  EXPECT_EQ(got.dropped, DropReason::Malformed);
  EXPECT_NE(got.detail.find("unit vector"), std::string::npos) << got.detail;

  SkyMessage short_s = sample_message();
  short_s.S.pop_back();
  got = decode_sky_message(encode_sky_message(short_s), gate_identity(), std::nullopt);
  EXPECT_EQ(got.dropped, DropReason::Malformed);
  EXPECT_NE(got.detail.find("each of the 40 layers"), std::string::npos) << got.detail;
}

TEST(SkyMessage, AnotherVersionSiteOrDomeIsRefusedNamingTheDifference) {
  nlohmann::json other_version = nlohmann::json::from_cbor(encode_sky_message(sample_message()));
  other_version["version"] = 2;
  DecodedSky got = decode_sky_message(nlohmann::json::to_cbor(other_version), gate_identity(), std::nullopt);
  EXPECT_EQ(got.dropped, DropReason::Version);
  EXPECT_EQ(got.detail, "version 2, this node reads 1");

  SkyIdentity bake = gate_identity();
  bake.site = "north hall";
  got = decode_sky_message(encode_sky_message(sample_message()), bake, std::nullopt);
  EXPECT_EQ(got.dropped, DropReason::OtherSite);
  EXPECT_EQ(got.detail, "site: sky 'sample gate', bake 'north hall'");

  bake = gate_identity();
  bake.dome_frequency = 4;
  got = decode_sky_message(encode_sky_message(sample_message()), bake, std::nullopt);
  EXPECT_EQ(got.dropped, DropReason::OtherDome);
  EXPECT_EQ(got.detail, "dome frequency: sky 2, bake 4");

  bake = gate_identity();
  bake.basis = geom::DomeBasis::Corners;
  got = decode_sky_message(encode_sky_message(sample_message()), bake, std::nullopt);
  EXPECT_EQ(got.detail, "dome basis: sky faces, bake corners");
  EXPECT_EQ(drop_reason_name(got.dropped), "other_dome");
}

TEST(SkyMessage, ASkyNeverGoesBackInTime) {
  const SkyIdentity id = gate_identity();
  EXPECT_TRUE(decode_sky_message(encode_sky_message(sample_message(8)), id, 7).message);
  for (std::uint64_t old : {7u, 3u, 0u}) {
    const DecodedSky got = decode_sky_message(encode_sky_message(sample_message(old)), id, 7);
    EXPECT_EQ(got.dropped, DropReason::OutOfOrder) << old;
    EXPECT_EQ(drop_reason_name(got.dropped), "out_of_order");
  }
}

}  // namespace
}  // namespace skylit::sky_link
