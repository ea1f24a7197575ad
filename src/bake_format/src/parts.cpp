// Parts of a bake in progress: parts/plan.json and one checksummed file per dome face.
//
// Part file layout (all integers little-endian):
//   char[8]   "SKYLITPT"
//   uint32    part format version: 1 (one layer per face), 2 (the layer count follows)
//   int32     face index
//   uint32    version 2 only: layers per face L (3 for corners, 6 for quadratics)
//   uint32    plane count P
//   P × (uint32 width, uint32 height)
//   uint64    vertex count V
//   byte[32]  SHA-256 of the payload
//   payload:  float32 plane fractions (plane 0: layer 0 row-major, layer 1, ...; plane 1, ...),
//             then L × V float32 vertex fractions (layer-major)
// A faces bake writes version 1, so that its parts are those of earlier bakers.
#include <array>
#include <bit>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string_view>

#include <nlohmann/json.hpp>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/parts.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit::bake_format {
namespace {

namespace fs = std::filesystem;

static_assert(std::endian::native == std::endian::little, "part files are written as little-endian");

constexpr char kPartMagic[8] = {'S', 'K', 'Y', 'L', 'I', 'T', 'P', 'T'};
constexpr std::uint32_t kPartVersionOneLayer = 1;
constexpr std::uint32_t kPartVersionLayers = 2;
constexpr std::size_t kHashSize = 32;

struct PartHeader {
  std::uint32_t version = 0;
  std::int32_t face = 0;
  std::uint32_t layers = 1;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> resolutions;
  std::uint64_t vertex_count = 0;
  std::array<unsigned char, kHashSize> sha256{};
  std::uint64_t header_size = 0;

  std::uint64_t payload_floats() const {
    std::uint64_t n = vertex_count;
    for (const auto& [w, h] : resolutions) n += static_cast<std::uint64_t>(w) * h;
    return n * layers;
  }
};

std::uint64_t header_size_for(std::size_t planes) { return 8 + 4 + 4 + 4 + 4 + 8 * planes + 8 + kHashSize; }

template <typename T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

// Sequential little-endian fields from a byte buffer; false when the buffer is too short.
class HeaderReader {
 public:
  explicit HeaderReader(std::string_view bytes) : bytes_(bytes) {}
  template <typename T>
  bool get(T& value) {
    if (bytes_.size() - at_ < sizeof(T)) return false;
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return true;
  }
  bool get(unsigned char* out, std::size_t n) {
    if (bytes_.size() - at_ < n) return false;
    std::memcpy(out, bytes_.data() + at_, n);
    at_ += n;
    return true;
  }
  std::size_t position() const { return at_; }

 private:
  std::string_view bytes_;
  std::size_t at_ = 0;
};

// The header's planes are bounded so that a corrupt count cannot make us read megabytes.
constexpr std::uint32_t kMaxPlanes = 4096;

std::optional<PartHeader> parse_header(std::string_view bytes) {
  HeaderReader r(bytes);
  char magic[8];
  if (bytes.size() < 8) return std::nullopt;
  std::memcpy(magic, bytes.data(), 8);
  if (std::memcmp(magic, kPartMagic, 8) != 0) return std::nullopt;
  std::uint64_t skip = 0;
  if (!r.get(skip)) return std::nullopt;  // the magic, already compared
  PartHeader h;
  std::uint32_t planes = 0;
  if (!r.get(h.version) || !r.get(h.face)) return std::nullopt;
  if (h.version == kPartVersionLayers && (!r.get(h.layers) || h.layers == 0 ||
                                           h.layers > static_cast<std::uint32_t>(geom::kMaxLayersPerFace))) {
    return std::nullopt;
  }
  if (!r.get(planes) || planes > kMaxPlanes) return std::nullopt;
  for (std::uint32_t j = 0; j < planes; ++j) {
    std::uint32_t w = 0;
    std::uint32_t height = 0;
    if (!r.get(w) || !r.get(height)) return std::nullopt;
    h.resolutions.emplace_back(w, height);
  }
  if (!r.get(h.vertex_count) || !r.get(h.sha256.data(), kHashSize)) return std::nullopt;
  h.header_size = r.position();
  return h;
}

// Reads the first bytes of a part file: enough for a header with kMaxPlanes planes at most.
std::string read_prefix(const fs::path& file, std::size_t max_bytes) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return {};
  std::string bytes(max_bytes, '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(max_bytes));
  bytes.resize(static_cast<std::size_t>(in.gcount()));
  return bytes;
}

// Why the header does not fit `plan` for `face`, or empty when it does.
std::string mismatch(const PartHeader& h, int face, const Plan& plan) {
  if (h.version != kPartVersionOneLayer && h.version != kPartVersionLayers) {
    return "part format version " + std::to_string(h.version) + ", expected " + std::to_string(kPartVersionOneLayer) +
           " or " + std::to_string(kPartVersionLayers);
  }
  if (h.face != face) return "holds face " + std::to_string(h.face) + ", expected " + std::to_string(face);
  if (h.layers != static_cast<std::uint32_t>(plan.layers_per_face())) {
    return std::to_string(h.layers) + " layer(s) per face, the plan's " + std::string(geom::basis_name(plan.basis)) +
           " basis has " + std::to_string(plan.layers_per_face());
  }
  if (h.resolutions.size() != plan.planes.size()) {
    return std::to_string(h.resolutions.size()) + " planes, the plan has " + std::to_string(plan.planes.size());
  }
  for (std::size_t j = 0; j < plan.planes.size(); ++j) {
    const geom::Plane& p = plan.planes[j];
    const auto [w, height] = h.resolutions[j];
    if (static_cast<std::int64_t>(w) != p.width || static_cast<std::int64_t>(height) != p.height) {
      return "plane " + std::to_string(j) + " is " + std::to_string(w) + "x" + std::to_string(height) +
             ", the plan's '" + p.name + "' is " + std::to_string(p.width) + "x" + std::to_string(p.height);
    }
  }
  if (h.vertex_count != plan.traced_count()) {
    return std::to_string(h.vertex_count) + " vertices and points, the plan has " + std::to_string(plan.traced_count());
  }
  return {};
}

std::string hex(const std::array<unsigned char, kHashSize>& digest) {
  static constexpr char digits[] = "0123456789abcdef";
  std::string s;
  for (unsigned char c : digest) {
    s += digits[c >> 4];
    s += digits[c & 15];
  }
  return s;
}

std::array<unsigned char, kHashSize> from_hex(const std::string& text) {
  if (text.size() != 2 * kHashSize) throw std::logic_error("sha256_hex returned " + text);
  const auto nibble = [&](char c) -> unsigned {
    if (c >= '0' && c <= '9') return static_cast<unsigned>(c - '0');
    if (c >= 'a' && c <= 'f') return static_cast<unsigned>(c - 'a' + 10);
    if (c >= 'A' && c <= 'F') return static_cast<unsigned>(c - 'A' + 10);
    throw std::logic_error("sha256_hex returned " + text);
  };
  std::array<unsigned char, kHashSize> digest{};
  for (std::size_t i = 0; i < kHashSize; ++i) {
    digest[i] = static_cast<unsigned char>(nibble(text[2 * i]) << 4 | nibble(text[2 * i + 1]));
  }
  return digest;
}

}  // namespace

PartStore::PartStore(fs::path dir) : dir_(std::move(dir)) {}

fs::path PartStore::path_of(int face) const {
  char name[32];
  std::snprintf(name, sizeof name, "face_%03d.part", face);
  return dir_ / name;
}

void PartStore::write_plan(const Plan& plan) const {
  fs::create_directories(dir_);
  write_file_atomic(dir_ / "plan.json", to_json(plan).dump(2) + "\n");
}

std::optional<Plan> PartStore::read_plan() const {
  const fs::path file = dir_ / "plan.json";
  if (!fs::exists(file)) return std::nullopt;
  const std::string text = read_file(file);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {  // parse_error, or out_of_range for a number like 1e999
    throw InputError(file.string() + ": not valid JSON (" + e.what() +
                     "). Fix: delete the directory's parts/ and rerun skylit-bake (or pass --force)");
  }
  return plan_from_json(j, file);
}

void PartStore::write(const FacePart& part) const {
  // The header records each plane's width and height, which only the plan knows.
  const std::optional<Plan> plan = read_plan();
  if (!plan) throw std::logic_error("PartStore::write: " + (dir_ / "plan.json").string() + " is not written yet");
  const std::size_t layers = static_cast<std::size_t>(plan->layers_per_face());
  if (part.plane_fractions.size() != plan->planes.size() ||
      part.vertex_fractions.size() != layers * plan->traced_count()) {
    throw std::invalid_argument("PartStore::write: face " + std::to_string(part.face) + " has " +
                                std::to_string(part.plane_fractions.size()) + " planes and " +
                                std::to_string(part.vertex_fractions.size()) + " vertex values; the plan has " +
                                std::to_string(plan->planes.size()) + " planes and " + std::to_string(layers) + " × " +
                                std::to_string(plan->traced_count()) + " vertex values");
  }
  std::string payload;
  for (std::size_t j = 0; j < plan->planes.size(); ++j) {
    const geom::Plane& p = plan->planes[j];
    const std::vector<float>& f = part.plane_fractions[j];
    if (f.size() != layers * static_cast<std::size_t>(p.width) * static_cast<std::size_t>(p.height)) {
      throw std::invalid_argument("PartStore::write: plane '" + p.name + "' of face " + std::to_string(part.face) +
                                  " has " + std::to_string(f.size()) + " values, expected " + std::to_string(layers) +
                                  " × " + std::to_string(p.width) + "x" + std::to_string(p.height));
    }
    payload.append(reinterpret_cast<const char*>(f.data()), f.size() * sizeof(float));
  }
  payload.append(reinterpret_cast<const char*>(part.vertex_fractions.data()),
                 part.vertex_fractions.size() * sizeof(float));

  std::string bytes(kPartMagic, sizeof kPartMagic);
  put(bytes, layers == 1 ? kPartVersionOneLayer : kPartVersionLayers);
  put(bytes, static_cast<std::int32_t>(part.face));
  if (layers != 1) put(bytes, static_cast<std::uint32_t>(layers));
  put(bytes, static_cast<std::uint32_t>(plan->planes.size()));
  for (const geom::Plane& p : plan->planes) {
    put(bytes, static_cast<std::uint32_t>(p.width));
    put(bytes, static_cast<std::uint32_t>(p.height));
  }
  put(bytes, static_cast<std::uint64_t>(plan->traced_count()));
  const std::array<unsigned char, kHashSize> digest =
      from_hex(sha256_hex(std::as_bytes(std::span<const char>(payload))));
  bytes.append(reinterpret_cast<const char*>(digest.data()), digest.size());
  bytes += payload;
  fs::create_directories(dir_);
  write_file_atomic(path_of(part.face), bytes);
}

bool PartStore::has(int face, const Plan& plan) const {
  const fs::path file = path_of(face);
  std::error_code error;
  const std::uintmax_t size = fs::file_size(file, error);
  if (error) return false;
  const std::optional<PartHeader> header = parse_header(read_prefix(file, header_size_for(plan.planes.size())));
  if (!header || !mismatch(*header, face, plan).empty()) return false;
  return size == header->header_size + header->payload_floats() * sizeof(float);
}

FacePart PartStore::read(int face, const Plan& plan) const {
  const fs::path file = path_of(face);
  // The full path: merge reads parts from several shard directories.
  const std::string name = file.string();
  const std::string fix = "delete it and rerun with --resume";
  const std::string bytes = read_file(file);
  const std::optional<PartHeader> header = parse_header(bytes);
  if (!header) throw InputError(name + " is not a skylit part file (bad header). Fix: " + fix);
  if (const std::string why = mismatch(*header, face, plan); !why.empty()) {
    throw InputError(name + " does not belong to this bake (" + why + "). Fix: " + fix);
  }
  const std::uint64_t expected = header->header_size + header->payload_floats() * sizeof(float);
  if (bytes.size() != expected) {
    throw InputError(name + " is corrupt (" + std::to_string(bytes.size()) + " bytes, expected " +
                     std::to_string(expected) + "). Fix: " + fix);
  }
  const std::string_view payload(bytes.data() + header->header_size, bytes.size() - header->header_size);
  const std::string actual = sha256_hex(std::as_bytes(std::span<const char>(payload.data(), payload.size())));
  if (actual != hex(header->sha256)) throw InputError(name + " is corrupt (checksum mismatch). Fix: " + fix);

  FacePart part;
  part.face = face;
  const char* at = payload.data();
  const std::size_t layers = static_cast<std::size_t>(plan.layers_per_face());
  for (const geom::Plane& p : plan.planes) {
    std::vector<float> f(layers * static_cast<std::size_t>(p.width) * static_cast<std::size_t>(p.height));
    std::memcpy(f.data(), at, f.size() * sizeof(float));
    at += f.size() * sizeof(float);
    part.plane_fractions.push_back(std::move(f));
  }
  part.vertex_fractions.resize(layers * plan.traced_count());
  if (!part.vertex_fractions.empty()) {
    std::memcpy(part.vertex_fractions.data(), at, part.vertex_fractions.size() * sizeof(float));
  }
  return part;
}

}  // namespace skylit::bake_format
