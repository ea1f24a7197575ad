#pragma once
// A sky as the sky node publishes it to the HMD nodes (docs/site.md): S per layer, the separated
// sources, times, flags and what it was computed for, in CBOR (RFC 8949) with every double's bits.
// Decoding never throws on bad bytes: it says why a message was dropped.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "skylit/geom/dome_basis.hpp"

namespace skylit::sky_link {

// Bumped when a field changes meaning; a node refuses messages of another version.
inline constexpr int kSkyMessageVersion = 1;
// Larger messages are dropped unread: 64 MiB is far above any dome (ν 16 quadratics: 1.2 MB).
inline constexpr std::size_t kMaxSkyMessageBytes = 64u << 20;

// A separated source (the sun first when there is one): the blend's SunLight and its disc.
struct PublishedSource {
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // unit, site frame, towards the source
  Eigen::Vector3d energy = Eigen::Vector3d::Zero();      // E, RGB: irradiance facing the source
  double angular_radius = 0;                             // radians
  bool clipped = false;                                  // E is a lower bound
  bool sun = false;                                      // the sun (first when there is one); else a lamp
  double shadow_radius = 0;                              // radians: the disc its shadow map draws (sky::Sun::shadow_radius); 0: angular_radius
  bool colour_corrected = false;                         // sky::Sun::colour_corrected; absent in older messages: false
  // sky::Sun::located_by, energy_estimator, energy_confidence; absent in older messages: "peak",
  // "measured", 1 (what those nodes did).
  std::string located_by = "peak";
  std::string energy_estimator = "measured";
  double energy_confidence = 1.0;
};

// What the sky was computed for: a node whose bake differs refuses it.
struct SkyIdentity {
  std::string site;                    // the site's name (site YAML), e.g. "sample gate"
  int dome_frequency = 0;              // ν
  geom::DomeBasis basis = geom::DomeBasis::Faces;
  int layers = 0;                      // S's length: the bake's layer count
};

struct SkyMessage {
  SkyIdentity identity;
  std::uint64_t sequence = 0;          // increases with every sky the node publishes
  // The sky node's run: its start, microseconds since 1970. A sky node that replaces another (or
  // restarts) starts its sequence again under a later run.
  std::int64_t run = 0;
  double frame_timestamp = 0;          // the sky frame's own time, seconds
  std::optional<std::int64_t> utc;     // its wall-clock time, seconds since 1970, when known
  // When the sky node published it (system clock, seconds since 1970): a node on a synchronised
  // clock measures sky to screen from it. Optional (absent in a message of an older sky node).
  std::optional<double> published;
  std::vector<Eigen::Vector3d> S;      // one RGB per layer
  std::vector<PublishedSource> sources;
  std::string sun_reason;              // why there is (no) sun
  int unseen_faces = 0;
  std::int64_t bad_pixels = 0;
  std::int64_t clipped_pixels = 0;
};

std::vector<std::uint8_t> encode_sky_message(const SkyMessage& message);

// Why a message was dropped; None when it was taken.
enum class DropReason { None, Oversized, Malformed, Version, OtherSite, OtherDome, OutOfOrder };
std::string_view drop_reason_name(DropReason reason);  // "malformed", "other_dome", ... (metrics labels)

struct DecodedSky {
  std::optional<SkyMessage> message;   // set when taken
  DropReason dropped = DropReason::None;
  std::string detail;                  // for the log: what was wrong, e.g. "dome frequency: sky 4, bake 2"
};

// Where a sky stands in time: a later run, or the same run and a higher sequence, is newer.
struct SkyOrder {
  SkyOrder(std::uint64_t sequence_ = 0, std::int64_t run_ = 0) : sequence(sequence_), run(run_) {}  // NOLINT: a sequence alone reads as one
  std::uint64_t sequence;
  std::int64_t run;
};

// Decodes and checks a message against the node's own identity and the last sky it took (none
// yet: nullopt); a sky not newer than that is dropped (OutOfOrder). Every field is checked (types,
// sizes, finite values, unit directions).
DecodedSky decode_sky_message(std::span<const std::uint8_t> bytes, const SkyIdentity& expected,
                              std::optional<SkyOrder> last);

}  // namespace skylit::sky_link
