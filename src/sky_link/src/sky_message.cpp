#include "skylit/sky_link/sky_message.hpp"

#include <cmath>
#include <new>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace skylit::sky_link {
namespace {

using nlohmann::json;

// A field that is missing, of the wrong type or out of range: the message is malformed.
struct BadField : std::runtime_error {
  using std::runtime_error::runtime_error;
};

const json& field(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end()) throw BadField(std::string("no field '") + key + "'");
  return *it;
}

double finite_number(const json& value, const std::string& name) {
  if (!value.is_number()) throw BadField("'" + name + "' is not a number");
  const double x = value.get<double>();
  if (!std::isfinite(x)) throw BadField("'" + name + "' is not finite");
  return x;
}

std::int64_t integer(const json& value, const std::string& name, std::int64_t lo, std::int64_t hi) {
  if (!value.is_number_integer()) throw BadField("'" + name + "' is not an integer");
  const std::int64_t n = value.get<std::int64_t>();
  if (n < lo || n > hi) throw BadField("'" + name + "' is " + std::to_string(n) + ", outside its range");
  return n;
}

std::string text(const json& value, const std::string& name) {
  if (!value.is_string()) throw BadField("'" + name + "' is not text");
  return value.get<std::string>();
}

Eigen::Vector3d vector3(const json& value, const std::string& name) {
  if (!value.is_array() || value.size() != 3) throw BadField("'" + name + "' is not three numbers");
  return {finite_number(value[0], name), finite_number(value[1], name), finite_number(value[2], name)};
}

json to_json(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

SkyMessage parse(const json& root) {
  if (!root.is_object()) throw BadField("not a map");
  SkyMessage m;
  const json& identity = field(root, "identity");
  m.identity.site = text(field(identity, "site"), "identity.site");
  m.identity.dome_frequency = static_cast<int>(integer(field(identity, "frequency"), "identity.frequency", 1, 64));
  const json& basis = field(identity, "basis");
  const auto parsed_basis = basis.is_string() ? geom::parse_basis(basis.get<std::string>()) : std::nullopt;
  if (!parsed_basis) throw BadField("'identity.basis' is not faces, corners or quadratics");
  m.identity.basis = *parsed_basis;
  m.identity.layers = static_cast<int>(integer(field(identity, "layers"), "identity.layers", 1, 1 << 20));

  m.sequence = static_cast<std::uint64_t>(integer(field(root, "sequence"), "sequence", 0, INT64_MAX));
  if (const auto it = root.find("run"); it != root.end() && !it->is_null()) m.run = integer(*it, "run", 0, INT64_MAX);
  m.frame_timestamp = finite_number(field(root, "frame_timestamp"), "frame_timestamp");
  if (const auto it = root.find("utc"); it != root.end() && !it->is_null()) {
    m.utc = integer(*it, "utc", INT64_MIN, INT64_MAX);
  }
  if (const auto it = root.find("published"); it != root.end() && !it->is_null()) {
    m.published = finite_number(*it, "published");
  }
  const json& S = field(root, "S");
  if (!S.is_array() || S.size() != 3 * static_cast<std::size_t>(m.identity.layers)) {
    throw BadField("'S' does not hold 3 numbers for each of the " + std::to_string(m.identity.layers) + " layers");
  }
  m.S.resize(static_cast<std::size_t>(m.identity.layers));
  for (std::size_t i = 0; i < m.S.size(); ++i) {
    for (int c = 0; c < 3; ++c) m.S[i][c] = finite_number(S[3 * i + static_cast<std::size_t>(c)], "S");
  }
  const json& sources = field(root, "sources");
  if (!sources.is_array() || sources.size() > 1024) throw BadField("'sources' is not a list of at most 1024");
  for (const json& s : sources) {
    PublishedSource p;
    // "sun" came with lamps; before, the one source published was the sun.
    if (s.is_object() && s.contains("sun")) {
      if (!s["sun"].is_boolean()) throw BadField("'sources.sun' is not true or false");
      p.sun = s["sun"].get<bool>();
    } else {
      p.sun = m.sources.empty();
    }
    p.direction = vector3(field(s, "direction"), "sources.direction");
    if (std::abs(p.direction.norm() - 1.0) > 1e-6) throw BadField("'sources.direction' is not a unit vector");
    p.energy = vector3(field(s, "energy"), "sources.energy");
    p.angular_radius = finite_number(field(s, "angular_radius"), "sources.angular_radius");
    if (p.angular_radius < 0) throw BadField("'sources.angular_radius' is negative");
    if (!field(s, "clipped").is_boolean()) throw BadField("'sources.clipped' is not true or false");
    p.clipped = field(s, "clipped").get<bool>();
    if (s.is_object() && s.contains("shadow_radius")) {  // came with lamps; absent in older messages
      p.shadow_radius = finite_number(s["shadow_radius"], "sources.shadow_radius");
      if (p.shadow_radius < 0) throw BadField("'sources.shadow_radius' is negative");
    }
    if (s.is_object() && s.contains("colour_corrected")) {  // came with the sun's colour; absent in older messages
      if (!s["colour_corrected"].is_boolean()) throw BadField("'sources.colour_corrected' is not true or false");
      p.colour_corrected = s["colour_corrected"].get<bool>();
    }
    if (s.is_object() && s.contains("located_by")) {  // came with clipped suns; absent in older messages
      p.located_by = text(s["located_by"], "sources.located_by");
      if (p.located_by != "peak" && p.located_by != "expected" && p.located_by != "clipped shape") {
        throw BadField("'sources.located_by' is not peak, expected or clipped shape");
      }
    }
    if (s.is_object() && s.contains("energy_estimator")) {
      p.energy_estimator = text(s["energy_estimator"], "sources.energy_estimator");
      if (p.energy_estimator != "measured" && p.energy_estimator != "clear_sky") {
        throw BadField("'sources.energy_estimator' is not measured or clear_sky");
      }
    }
    if (s.is_object() && s.contains("energy_confidence")) {
      p.energy_confidence = finite_number(s["energy_confidence"], "sources.energy_confidence");
      if (p.energy_confidence < 0 || p.energy_confidence > 1) throw BadField("'sources.energy_confidence' is outside [0, 1]");
    }
    m.sources.push_back(p);
  }
  m.sun_reason = text(field(root, "sun_reason"), "sun_reason");
  m.unseen_faces = static_cast<int>(integer(field(root, "unseen_faces"), "unseen_faces", 0, 1 << 24));
  m.bad_pixels = integer(field(root, "bad_pixels"), "bad_pixels", 0, INT64_MAX);
  m.clipped_pixels = integer(field(root, "clipped_pixels"), "clipped_pixels", 0, INT64_MAX);
  return m;
}

// The first difference between the sky's identity and the node's, as "what: sky X, bake Y".
std::optional<std::pair<DropReason, std::string>> identity_difference(const SkyIdentity& sky,
                                                                      const SkyIdentity& expected) {
  if (sky.site != expected.site) {
    return std::pair{DropReason::OtherSite, "site: sky '" + sky.site + "', bake '" + expected.site + "'"};
  }
  if (sky.dome_frequency != expected.dome_frequency) {
    return std::pair{DropReason::OtherDome, "dome frequency: sky " + std::to_string(sky.dome_frequency) + ", bake " +
                                                std::to_string(expected.dome_frequency)};
  }
  if (sky.basis != expected.basis) {
    return std::pair{DropReason::OtherDome, "dome basis: sky " + std::string(geom::basis_name(sky.basis)) +
                                                ", bake " + std::string(geom::basis_name(expected.basis))};
  }
  if (sky.layers != expected.layers) {
    return std::pair{DropReason::OtherDome, "layers: sky " + std::to_string(sky.layers) + ", bake " +
                                                std::to_string(expected.layers)};
  }
  return std::nullopt;
}

}  // namespace

std::vector<std::uint8_t> encode_sky_message(const SkyMessage& m) {
  json S = json::array();
  for (const Eigen::Vector3d& s : m.S) {
    for (int c = 0; c < 3; ++c) S.push_back(s[c]);
  }
  json sources = json::array();
  for (const PublishedSource& p : m.sources) {
    sources.push_back({{"direction", to_json(p.direction)},
                       {"energy", to_json(p.energy)},
                       {"angular_radius", p.angular_radius},
                       {"clipped", p.clipped},
                       {"sun", p.sun},
                       {"shadow_radius", p.shadow_radius},
                       {"colour_corrected", p.colour_corrected},
                       {"located_by", p.located_by},
                       {"energy_estimator", p.energy_estimator},
                       {"energy_confidence", p.energy_confidence}});
  }
  const json root = {
      {"version", kSkyMessageVersion},
      {"identity",
       {{"site", m.identity.site},
        {"frequency", m.identity.dome_frequency},
        {"basis", std::string(geom::basis_name(m.identity.basis))},
        {"layers", m.identity.layers}}},
      {"sequence", m.sequence},
      {"run", m.run},
      {"frame_timestamp", m.frame_timestamp},
      {"utc", m.utc ? json(*m.utc) : json(nullptr)},
      {"published", m.published ? json(*m.published) : json(nullptr)},
      {"S", std::move(S)},
      {"sources", std::move(sources)},
      {"sun_reason", m.sun_reason},
      {"unseen_faces", m.unseen_faces},
      {"bad_pixels", m.bad_pixels},
      {"clipped_pixels", m.clipped_pixels},
  };
  return json::to_cbor(root);
}

std::string_view drop_reason_name(DropReason reason) {
  switch (reason) {
    case DropReason::None: return "none";
    case DropReason::Oversized: return "oversized";
    case DropReason::Malformed: return "malformed";
    case DropReason::Version: return "version";
    case DropReason::OtherSite: return "other_site";
    case DropReason::OtherDome: return "other_dome";
    case DropReason::OutOfOrder: return "out_of_order";
  }
  return "unknown";
}

DecodedSky decode_sky_message(std::span<const std::uint8_t> bytes, const SkyIdentity& expected,
                              std::optional<SkyOrder> last) {
  DecodedSky result;
  const auto drop = [&result](DropReason reason, std::string detail) {
    result.dropped = reason;
    result.detail = std::move(detail);
    return result;
  };
  if (bytes.size() > kMaxSkyMessageBytes) {
    return drop(DropReason::Oversized, std::to_string(bytes.size()) + " bytes, more than " +
                                           std::to_string(kMaxSkyMessageBytes));
  }
  json root;
  try {
    // Without exceptions for syntax errors; a declared size beyond what fits still throws.
    root = json::from_cbor(bytes.begin(), bytes.end(), /*strict=*/true, /*allow_exceptions=*/false);
  } catch (const json::exception& e) {
    return drop(DropReason::Malformed, std::string("not CBOR: ") + e.what());
  } catch (const std::bad_alloc&) {
    return drop(DropReason::Malformed, "not CBOR: a size beyond memory");
  } catch (const std::length_error&) {
    return drop(DropReason::Malformed, "not CBOR: a size beyond memory");
  }
  if (root.is_discarded()) return drop(DropReason::Malformed, "not CBOR, or truncated");
  if (!root.is_object()) return drop(DropReason::Malformed, "not a map");
  const auto version = root.find("version");
  if (version == root.end() || !version->is_number_integer()) return drop(DropReason::Malformed, "no version");
  if (version->get<std::int64_t>() != kSkyMessageVersion) {
    return drop(DropReason::Version, "version " + std::to_string(version->get<std::int64_t>()) + ", this node reads " +
                                         std::to_string(kSkyMessageVersion));
  }
  SkyMessage message;
  try {
    message = parse(root);
  } catch (const BadField& e) {
    return drop(DropReason::Malformed, e.what());
  }
  if (const auto difference = identity_difference(message.identity, expected)) {
    return drop(difference->first, difference->second);
  }
  if (last && message.run < last->run) {
    return drop(DropReason::OutOfOrder, "from the sky node's run " + std::to_string(message.run) + ", after run " +
                                            std::to_string(last->run));
  }
  if (last && message.run == last->run && message.sequence <= last->sequence) {
    return drop(DropReason::OutOfOrder, "sequence " + std::to_string(message.sequence) + " after " +
                                            std::to_string(last->sequence));
  }
  result.message = std::move(message);
  return result;
}

}  // namespace skylit::sky_link
