// Plan and Manifest as JSON (manifest.json, parts/plan.json).
#include <charconv>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

// Plane::normal() uses cross(), which Eigen defines in <Eigen/Geometry>, not in <Eigen/Core>.
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit::bake_format {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Where a value comes from, so every parse error names the file, the field and the fix.
struct Source {
  const fs::path& file;
  std::string fix;

  [[noreturn]] void fail(const std::string& field, const std::string& problem) const {
    throw InputError(input_message(file, -1, -1, field, problem, fix));
  }
};

std::string join(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}
std::string index(const std::string& parent, std::size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

// Sizes a manifest may state, checked before anything is allocated from them: the site file's own
// limits (scene::kMaxPlaneResolution, the dome's frequency) and generous ones for the rest.
constexpr int kMaxPlaneTexels = 16384;
constexpr int kMaxDomeFrequency = 64;
constexpr int kMaxSamples = 1 << 20;
constexpr int kMaxVertexFit = 16;  // points per triangle side of the vertex fit
constexpr int kMaxPcaComponents = 4096;

const json& member(const Source& src, const json& object, const std::string& parent,
                   const std::string& key) {
  if (!object.is_object()) src.fail(parent.empty() ? "(top level)" : parent, "expected a JSON object");
  const auto it = object.find(key);
  if (it == object.end()) src.fail(join(parent, key), "missing");
  return *it;
}

const json& array_of(const Source& src, const json& value, const std::string& field,
                     std::optional<std::size_t> size = std::nullopt) {
  if (!value.is_array()) src.fail(field, std::string("expected an array, got ") + value.type_name());
  if (size && value.size() != *size) {
    src.fail(field, "expected " + std::to_string(*size) + " elements, got " + std::to_string(value.size()));
  }
  return value;
}

double to_double(const Source& src, const json& value, const std::string& field) {
  if (!value.is_number()) src.fail(field, std::string("expected a number, got ") + value.type_name());
  return value.get<double>();
}

std::int64_t to_integer(const Source& src, const json& value, const std::string& field, std::int64_t low,
                        std::int64_t high) {
  if (!value.is_number_integer()) {
    src.fail(field, std::string("expected an integer, got ") +
                        (value.is_number() ? value.dump() : std::string(value.type_name())));
  }
  if (value.is_number_unsigned() && value.get<std::uint64_t>() > static_cast<std::uint64_t>(high)) {
    src.fail(field, "value " + value.dump() + " is out of range");
  }
  const std::int64_t x = value.get<std::int64_t>();
  if (x < low || x > high) {
    src.fail(field, "value " + std::to_string(x) + " is out of range [" + std::to_string(low) + ", " +
                        std::to_string(high) + "]");
  }
  return x;
}

int to_int(const Source& src, const json& value, const std::string& field, int low,
           int high = std::numeric_limits<int>::max()) {
  return static_cast<int>(to_integer(src, value, field, low, high));
}

std::uint64_t to_count(const Source& src, const json& value, const std::string& field) {
  return static_cast<std::uint64_t>(
      to_integer(src, value, field, 0, std::numeric_limits<std::int64_t>::max()));
}

std::string to_string(const Source& src, const json& value, const std::string& field) {
  if (!value.is_string()) src.fail(field, std::string("expected a string, got ") + value.type_name());
  return value.get<std::string>();
}

Vec3 to_vec3(const Source& src, const json& value, const std::string& field) {
  const json& a = array_of(src, value, field, 3);
  return {to_double(src, a[0], index(field, 0)), to_double(src, a[1], index(field, 1)),
          to_double(src, a[2], index(field, 2))};
}

json vec3_json(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }

// ---- planes ----

json plane_json(const geom::Plane& p) {
  return {{"name", p.name},
          {"origin", vec3_json(p.origin)},
          {"u", vec3_json(p.u)},
          {"v", vec3_json(p.v)},
          {"resolution", json::array({p.width, p.height})}};
}

geom::Plane plane_from(const Source& src, const json& j, const std::string& field) {
  geom::Plane p;
  p.name = to_string(src, member(src, j, field, "name"), join(field, "name"));
  if (p.name.empty()) src.fail(join(field, "name"), "empty plane name");
  p.origin = to_vec3(src, member(src, j, field, "origin"), join(field, "origin"));
  p.u = to_vec3(src, member(src, j, field, "u"), join(field, "u"));
  p.v = to_vec3(src, member(src, j, field, "v"), join(field, "v"));
  const std::string res_field = join(field, "resolution");
  const json& res = array_of(src, member(src, j, field, "resolution"), res_field, 2);
  p.width = to_int(src, res[0], index(res_field, 0), 1, kMaxPlaneTexels);
  p.height = to_int(src, res[1], index(res_field, 1), 1, kMaxPlaneTexels);
  return p;
}

// ---- plan ----

// `basis` is optional: bakes from before the corners basis have none and are faces.
geom::DomeBasis basis_from(const Source& src, const json& object, const std::string& parent) {
  if (!object.is_object() || !object.contains("basis")) return geom::DomeBasis::Faces;
  const std::string field = join(parent, "basis");
  const std::string name = to_string(src, object["basis"], field);
  const std::optional<geom::DomeBasis> basis = geom::parse_basis(name);
  if (!basis) src.fail(field, "got '" + name + "', expected " + std::string(geom::kBasisNames));
  return *basis;
}

Plan plan_from(const Source& src, const json& j, const std::string& field) {
  Plan plan;
  const auto get = [&](const char* key) -> const json& { return member(src, j, field, key); };
  const auto name = [&](const char* key) { return join(field, key); };
  plan.site_file = to_string(src, get("site_file"), name("site_file"));
  plan.site_sha256 = to_string(src, get("site_sha256"), name("site_sha256"));
  plan.model_file = to_string(src, get("model_file"), name("model_file"));
  plan.model_sha256 = to_string(src, get("model_sha256"), name("model_sha256"));
  plan.frequency = to_int(src, get("frequency"), name("frequency"), 1, kMaxDomeFrequency);
  plan.basis = basis_from(src, j, field);
  plan.samples = to_int(src, get("samples"), name("samples"), 1, kMaxSamples);
  plan.method = to_string(src, get("method"), name("method"));
  if (plan.method != "raster" && plan.method != "raytrace") {
    src.fail(name("method"), "got '" + plan.method + "', expected 'raster' or 'raytrace'");
  }
  plan.shadow_map_resolution = to_int(src, get("shadow_map_resolution"), name("shadow_map_resolution"), 0, kMaxPlaneTexels);
  // `preset` is optional: bakes made without skylit-bake --preset have none.
  if (j.is_object() && j.contains("preset")) plan.preset = to_string(src, j["preset"], name("preset"));
  // `ground_samples` is optional: bakes made before the ground layer have none.
  if (j.is_object() && j.contains("ground_samples")) {
    plan.ground_samples = to_int(src, j["ground_samples"], name("ground_samples"), 0, kMaxSamples);
  }
  // `refine` is optional: bakes without a refinement of the model have none.
  if (j.is_object() && j.contains("refine")) {
    const std::string rfield = name("refine");
    const json& r = j["refine"];
    plan.refine.tolerance = to_double(src, member(src, r, rfield, "tolerance"), join(rfield, "tolerance"));
    plan.refine.rounds = to_int(src, member(src, r, rfield, "rounds"), join(rfield, "rounds"), 1, 12);
    plan.refine.min_edge = to_double(src, member(src, r, rfield, "min_edge"), join(rfield, "min_edge"));
    if (!(plan.refine.tolerance > 0.0) || !(plan.refine.min_edge > 0.0)) {
      src.fail(rfield, "needs tolerance > 0 and min_edge > 0");
    }
  }
  // `vertex_fit` is optional: bakes whose vertices take their own values have none.
  if (j.is_object() && j.contains("vertex_fit")) plan.vertex_fit = to_int(src, j["vertex_fit"], name("vertex_fit"), 0, kMaxVertexFit);
  // `light_map` is optional: bakes without a light map have none.
  if (j.is_object() && j.contains("light_map")) {
    const std::string lfield = name("light_map");
    const json& l = j["light_map"];
    plan.light_map.texel = to_double(src, member(src, l, lfield, "texel"), join(lfield, "texel"));
    plan.light_map.min_area = to_double(src, member(src, l, lfield, "min_area"), join(lfield, "min_area"));
    if (l.contains("min_across")) plan.light_map.min_across = to_int(src, l["min_across"], join(lfield, "min_across"), 0, 1024);
    plan.light_map.texels = to_count(src, member(src, l, lfield, "texels"), join(lfield, "texels"));
    if (!(plan.light_map.texel > 0.0) || !std::isfinite(plan.light_map.texel) || !(plan.light_map.min_area >= 0.0)) {
      src.fail(lfield, "needs texel > 0 and min_area >= 0");
    }
  }
  const json& planes = array_of(src, get("planes"), name("planes"));
  for (std::size_t i = 0; i < planes.size(); ++i) {
    plan.planes.push_back(plane_from(src, planes[i], index(name("planes"), i)));
  }
  plan.vertex_count = to_count(src, get("vertex_count"), name("vertex_count"));
  plan.triangle_count = to_count(src, get("triangle_count"), name("triangle_count"));
  return plan;
}

// Shortest text that reads back as the same double.
std::string exact(double x) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, x);
  return std::string(buffer, result.ptr);
}
std::string exact(const Vec3& v) {
  std::string s = "(";
  s.append(exact(v.x())).append(", ").append(exact(v.y())).append(", ").append(exact(v.z())).append(")");
  return s;
}
std::string quoted(const std::string& s) { return "'" + s + "'"; }

bool same_plane(const geom::Plane& a, const geom::Plane& b) {
  return a.name == b.name && a.origin == b.origin && a.u == b.u && a.v == b.v && a.width == b.width &&
         a.height == b.height;
}

std::string location_of(const fs::path& source) { return source.string(); }

// The line and column of a byte offset, for JSON syntax errors.
std::pair<int, int> line_and_column(const std::string& text, std::size_t byte) {
  int line = 1;
  int column = 1;
  for (std::size_t i = 0; i < byte && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return {line, column};
}

constexpr const char* kManifestFix = "re-bake, or restore manifest.json from the bake it belongs to";

}  // namespace

// ---- Plan ----

std::uint64_t Manifest::Refinement::edge_count() const {
  std::uint64_t n = 0;
  for (std::uint64_t r : round_sizes) n += r;
  return n;
}

bool Plan::operator==(const Plan& other) const {
  if (planes.size() != other.planes.size()) return false;
  for (std::size_t i = 0; i < planes.size(); ++i) {
    if (!same_plane(planes[i], other.planes[i])) return false;
  }
  return site_file == other.site_file && site_sha256 == other.site_sha256 && model_file == other.model_file &&
         model_sha256 == other.model_sha256 && frequency == other.frequency && basis == other.basis &&
         samples == other.samples &&
         method == other.method && shadow_map_resolution == other.shadow_map_resolution && preset == other.preset &&
         ground_samples == other.ground_samples && refine == other.refine && vertex_fit == other.vertex_fit && light_map == other.light_map && vertex_count == other.vertex_count && triangle_count == other.triangle_count;
}

std::string Plan::difference(const Plan& other) const {
  std::vector<std::string> items;
  const auto text = [&](const char* field, const std::string& a, const std::string& b) {
    if (a != b) items.push_back(std::string(field) + ": " + quoted(a) + " vs " + quoted(b));
  };
  const auto number = [&](const char* field, auto a, auto b) {
    if (a != b) items.push_back(std::string(field) + ": " + std::to_string(a) + " vs " + std::to_string(b));
  };
  text("site_file", site_file, other.site_file);
  if (site_sha256 != other.site_sha256) items.push_back("site file contents (SHA-256) differ");
  text("model_file", model_file, other.model_file);
  if (model_sha256 != other.model_sha256) items.push_back("model file contents (SHA-256) differ");
  number("frequency", frequency, other.frequency);
  text("basis", std::string(geom::basis_name(basis)), std::string(geom::basis_name(other.basis)));
  number("samples", samples, other.samples);
  text("method", method, other.method);
  number("shadow_map_resolution", shadow_map_resolution, other.shadow_map_resolution);
  text("preset", preset, other.preset);
  number("ground_samples", ground_samples, other.ground_samples);
  if (!(refine == other.refine)) {
    const auto words = [](const Refine& r) {
      return r.tolerance > 0.0 ? "tolerance " + exact(r.tolerance) + ", " + std::to_string(r.rounds) + " rounds, min_edge " + exact(r.min_edge)
                               : std::string("none");
    };
    items.push_back("refine: " + words(refine) + " vs " + words(other.refine));
  }
  number("vertex_fit", vertex_fit, other.vertex_fit);
  if (!(light_map == other.light_map)) {
    const auto words = [](const LightMap& l) {
      return l.texel > 0.0 ? "texel " + exact(l.texel) + " m, min_area " + exact(l.min_area) + " m², min_across " +
                                 std::to_string(l.min_across) + ", " + std::to_string(l.texels) + " texels"
                           : std::string("none");
    };
    items.push_back("light_map: " + words(light_map) + " vs " + words(other.light_map));
  }
  number("vertex_count", vertex_count, other.vertex_count);
  number("triangle_count", triangle_count, other.triangle_count);
  if (planes.size() != other.planes.size()) {
    const auto names = [](const std::vector<geom::Plane>& ps) {
      std::string s;
      for (const geom::Plane& p : ps) s += (s.empty() ? "" : ", ") + quoted(p.name);
      return "[" + s + "]";
    };
    items.push_back("planes: " + std::to_string(planes.size()) + " " + names(planes) + " vs " +
                    std::to_string(other.planes.size()) + " " + names(other.planes));
  } else {
    for (std::size_t i = 0; i < planes.size(); ++i) {
      const geom::Plane& a = planes[i];
      const geom::Plane& b = other.planes[i];
      const std::string label = "plane " + quoted(a.name);
      if (a.name != b.name) {
        items.push_back("plane " + std::to_string(i) + " name: " + quoted(a.name) + " vs " + quoted(b.name));
      }
      if (a.origin != b.origin) items.push_back(label + " origin: " + exact(a.origin) + " vs " + exact(b.origin));
      if (a.u != b.u) items.push_back(label + " u: " + exact(a.u) + " vs " + exact(b.u));
      if (a.v != b.v) items.push_back(label + " v: " + exact(a.v) + " vs " + exact(b.v));
      if (a.width != b.width || a.height != b.height) {
        items.push_back(label + " resolution: " + std::to_string(a.width) + "x" + std::to_string(a.height) +
                        " vs " + std::to_string(b.width) + "x" + std::to_string(b.height));
      }
    }
  }
  if (items.empty()) return "no differences";
  std::string out;
  for (const std::string& item : items) out += (out.empty() ? "" : "; ") + item;
  return out;
}

json to_json(const Plan& plan) {
  json planes = json::array();
  for (const geom::Plane& p : plan.planes) planes.push_back(plane_json(p));
  json j = {{"site_file", plan.site_file},
            {"site_sha256", plan.site_sha256},
            {"model_file", plan.model_file},
            {"model_sha256", plan.model_sha256},
            {"frequency", plan.frequency},
            {"basis", geom::basis_name(plan.basis)},
            {"samples", plan.samples},
            {"method", plan.method},
            {"shadow_map_resolution", plan.shadow_map_resolution},
            {"planes", std::move(planes)},
            {"vertex_count", plan.vertex_count},
            {"triangle_count", plan.triangle_count}};
  if (!plan.preset.empty()) j["preset"] = plan.preset;
  if (plan.ground_samples > 0) j["ground_samples"] = plan.ground_samples;
  if (plan.vertex_fit > 0) j["vertex_fit"] = plan.vertex_fit;
  if (plan.light_map.texel > 0.0) {
    j["light_map"] = {{"texel", plan.light_map.texel}, {"min_area", plan.light_map.min_area}, {"texels", plan.light_map.texels}};
    if (plan.light_map.min_across > 0) j["light_map"]["min_across"] = plan.light_map.min_across;
  }
  if (plan.refine.tolerance > 0.0) {
    j["refine"] = {{"tolerance", plan.refine.tolerance}, {"rounds", plan.refine.rounds}, {"min_edge", plan.refine.min_edge}};
  }
  return j;
}

Plan plan_from_json(const json& j, const fs::path& source) {
  const Source src{source, "delete it and rerun skylit-bake (use --force to start the bake over)"};
  return plan_from(src, j, "");
}

// ---- Manifest ----

json to_json(const Manifest& m) {
  json faces = json::array();
  for (const FaceRecord& f : m.faces) {
    faces.push_back({{"index", f.index},
                     {"direction", vec3_json(f.direction)},
                     {"solid_angle", f.solid_angle},
                     {"vertices", json::array({vec3_json(f.vertices[0]), vec3_json(f.vertices[1]),
                                               vec3_json(f.vertices[2])})},
                     {"neighbours", json::array({f.neighbours[0], f.neighbours[1], f.neighbours[2]})}});
  }
  json planes = json::array();
  for (const PlaneRecord& r : m.planes) {
    json p = plane_json(r.plane);
    p["normal"] = vec3_json(r.plane.normal());
    // NaN/inf have no JSON form (nlohmann writes null); verify reports them either way.
    p["unoccluded"] = r.unoccluded;
    p["file"] = r.file;
    if (r.pca) {
      p["pca"] = {{"file", r.pca->file},
                  {"coefficients", r.pca->coefficients},
                  {"components", r.pca->components},
                  {"max_error", r.pca->max_error},
                  {"rms_error", r.pca->rms_error},
                  {"variance_kept", r.pca->variance_kept},
                  {"sky_correlation_deg", r.pca->sky_correlation_deg}};
      if (r.pca->tile > 0) p["pca"]["tile"] = r.pca->tile;
    }
    planes.push_back(std::move(p));
  }
  json files = json::array();
  for (const FileRecord& f : m.files) files.push_back({{"path", f.path}, {"size", f.size}, {"sha256", f.sha256}});
  const std::uint64_t layer_count = m.layer_count();
  json out = {{"format", kFormatName},
          {"schema_version", m.schema_version},
          {"generator", m.generator},
          {"created_utc", m.created_utc},
          {"plan", to_json(m.plan)},
          {"dome", {{"frequency", m.plan.frequency}, {"basis", geom::basis_name(m.plan.basis)}, {"faces", std::move(faces)}}},
          {"planes", std::move(planes)},
          {"transfer", {{"file", m.transfer_file}, {"shape", json::array({m.plan.vertex_count, layer_count})}}},
          {"vertices", {{"file", m.vertices_file}, {"shape", json::array({m.plan.vertex_count, 6})}}},
          {"timings", {{"bake_seconds", m.bake_seconds}, {"finalize_seconds", m.finalize_seconds}}},
          {"files", std::move(files)}};
  if (m.ground) {
    out["ground"] = {{"file", m.ground->file},
                     {"shape", json::array({m.plan.vertex_count, layer_count})},
                     {"horizontal_unoccluded", m.ground->horizontal_unoccluded}};
  }
  if (m.refinement) {
    out["refinement"] = {{"file", m.refinement->file},
                         {"shape", json::array({m.refinement->edge_count(), 2})},
                         {"rounds", m.refinement->round_sizes}};
  }
  if (m.light_map) {
    const Manifest::LightMap& l = *m.light_map;
    out["light_map"] = {{"width", l.width},
                        {"height", l.height},
                        {"charts", {{"file", l.charts_file}, {"shape", json::array({l.chart_count, 15})}}},
                        {"triangles", {{"file", l.triangles_file}, {"shape", json::array({m.plan.triangle_count})}}},
                        {"texels", {{"file", l.texels_file}, {"shape", json::array({m.plan.light_map.texels})}}}};
    if (l.has_full_form()) {
      out["light_map"]["transfer"] = {{"file", l.transfer_file}, {"shape", json::array({m.plan.light_map.texels, layer_count})}};
    }
    if (!l.ground_file.empty()) {
      out["light_map"]["ground"] = {{"file", l.ground_file}, {"shape", json::array({m.plan.light_map.texels, layer_count})}};
    }
    if (l.pca) {
      const Manifest::LightMap::Pca& p = *l.pca;
      const auto k = static_cast<std::uint64_t>(p.components);
      const json weights_shape = json::array({m.plan.light_map.texels, k});
      const json vectors_shape = json::array({l.chart_count, k + 1, layer_count});
      json& pca = out["light_map"]["pca"];
      pca = {{"components", p.components},
             {"sky_correlation_deg", p.sky_correlation_deg},
             {"rms_error", p.rms_error},
             {"max_error", p.max_error},
             {"weights", {{"file", p.weights_file}, {"shape", weights_shape}}},
             {"vectors", {{"file", p.vectors_file}, {"shape", vectors_shape}}}};
      if (!p.ground_weights_file.empty()) {
        pca["ground_weights"] = {{"file", p.ground_weights_file}, {"shape", weights_shape}};
        pca["ground_vectors"] = {{"file", p.ground_vectors_file}, {"shape", vectors_shape}};
        pca["ground_rms_error"] = p.ground_rms_error;
        pca["ground_max_error"] = p.ground_max_error;
      }
    }
  }
  return out;
}

namespace {

// A file the manifest names must lie inside the bake directory: relative, and not through "..".
// Every loader joins these to the bake's folder, so one that escapes would read anywhere.
bool inside_bake(const std::string& path) {
  const fs::path p(path);
  if (path.empty() || p.is_absolute() || p.has_root_name()) return false;
  for (const fs::path& part : p) {
    if (part == "..") return false;
  }
  return true;
}

}  // namespace

Manifest manifest_from_json(const json& j, const fs::path& source) {
  const Source src{source, kManifestFix};
  const auto get = [&](const json& object, const std::string& parent, const char* key) -> const json& {
    return member(src, object, parent, key);
  };
  Manifest m;

  // Identity first: a foreign or newer file gets a message about that, not about its fields.
  if (!j.is_object() || !j.contains("format")) {
    throw InputError(location_of(source) + " is not a skylit bake manifest (no \"format\": \"" +
                     kFormatName + "\"). Fix: point to the directory that skylit-bake wrote");
  }
  const std::string format = to_string(src, j["format"], "format");
  if (format != kFormatName) {
    throw InputError(location_of(source) + " is a '" + format + "' file, not a skylit bake manifest ('" +
                     kFormatName + "'). Fix: point to the directory that skylit-bake wrote");
  }
  m.schema_version = to_int(src, get(j, "", "schema_version"), "schema_version", std::numeric_limits<int>::min());
  if (m.schema_version != kSchemaVersion) {
    throw InputError(location_of(source) + " was written by schema version " + std::to_string(m.schema_version) +
                     " of the bake format; this skylit reads version " + std::to_string(kSchemaVersion) +
                     ". Fix: re-bake with this skylit-bake (or use the skylit that wrote it)");
  }
  m.generator = to_string(src, get(j, "", "generator"), "generator");
  m.created_utc = to_string(src, get(j, "", "created_utc"), "created_utc");
  m.plan = plan_from(src, get(j, "", "plan"), "plan");

  const json& dome = get(j, "", "dome");
  const int dome_frequency = to_int(src, get(dome, "dome", "frequency"), "dome.frequency", 1, kMaxDomeFrequency);
  if (dome_frequency != m.plan.frequency) {
    src.fail("dome.frequency", "is " + std::to_string(dome_frequency) + " but plan.frequency is " +
                                   std::to_string(m.plan.frequency));
  }
  if (const geom::DomeBasis dome_basis = basis_from(src, dome, "dome"); dome_basis != m.plan.basis) {
    src.fail("dome.basis", std::string("is '")
                               .append(geom::basis_name(dome_basis))
                               .append("' but plan.basis is '")
                               .append(geom::basis_name(m.plan.basis))
                               .append("'"));
  }
  const json& faces = array_of(src, get(dome, "dome", "faces"), "dome.faces");
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const std::string field = index("dome.faces", i);
    FaceRecord f;
    f.index = to_int(src, get(faces[i], field, "index"), join(field, "index"), 0);
    f.direction = to_vec3(src, get(faces[i], field, "direction"), join(field, "direction"));
    f.solid_angle = to_double(src, get(faces[i], field, "solid_angle"), join(field, "solid_angle"));
    const std::string vfield = join(field, "vertices");
    const json& vertices = array_of(src, get(faces[i], field, "vertices"), vfield, 3);
    for (std::size_t k = 0; k < 3; ++k) f.vertices[k] = to_vec3(src, vertices[k], index(vfield, k));
    const std::string nfield = join(field, "neighbours");
    const json& neighbours = array_of(src, get(faces[i], field, "neighbours"), nfield, 3);
    for (std::size_t k = 0; k < 3; ++k) f.neighbours[k] = to_int(src, neighbours[k], index(nfield, k), -1);
    m.faces.push_back(f);
  }

  const json& planes = array_of(src, get(j, "", "planes"), "planes");
  const auto contained = [&](const std::string& field, const std::string& file) {
    if (!inside_bake(file)) src.fail(field, "'" + file + "' names a file outside the bake directory (absolute, or through '..')");
  };
  for (std::size_t i = 0; i < planes.size(); ++i) {
    const std::string field = index("planes", i);
    PlaneRecord r;
    r.plane = plane_from(src, planes[i], field);
    const std::string ufield = join(field, "unoccluded");
    const json& unoccluded = array_of(src, get(planes[i], field, "unoccluded"), ufield);
    for (std::size_t k = 0; k < unoccluded.size(); ++k) {
      // null is how a non-finite value was written; keep it as NaN so verify can name it.
      r.unoccluded.push_back(unoccluded[k].is_null() ? std::numeric_limits<double>::quiet_NaN()
                                                      : to_double(src, unoccluded[k], index(ufield, k)));
    }
    r.file = to_string(src, get(planes[i], field, "file"), join(field, "file"));
    contained(join(field, "file"), r.file);
    if (planes[i].contains("pca")) {
      const std::string pfield = join(field, "pca");
      const json& pca = get(planes[i], field, "pca");
      PcaRecord record;
      record.file = to_string(src, get(pca, pfield, "file"), join(pfield, "file"));
      record.coefficients = to_string(src, get(pca, pfield, "coefficients"), join(pfield, "coefficients"));
      contained(join(pfield, "file"), record.file);
      contained(join(pfield, "coefficients"), record.coefficients);
      record.components = to_int(src, get(pca, pfield, "components"), join(pfield, "components"), 0, kMaxPcaComponents);
      record.max_error = to_double(src, get(pca, pfield, "max_error"), join(pfield, "max_error"));
      record.rms_error = to_double(src, get(pca, pfield, "rms_error"), join(pfield, "rms_error"));
      record.variance_kept = to_double(src, get(pca, pfield, "variance_kept"), join(pfield, "variance_kept"));
      if (pca.contains("sky_correlation_deg")) {
        record.sky_correlation_deg =
            to_double(src, pca["sky_correlation_deg"], join(pfield, "sky_correlation_deg"));
      }
      if (pca.contains("tile")) record.tile = to_int(src, pca["tile"], join(pfield, "tile"), 0, kMaxPlaneTexels);
      r.pca = std::move(record);
    }
    m.planes.push_back(std::move(r));
  }

  const auto array_file = [&](const char* key, std::uint64_t columns, std::string& file) {
    const json& section = get(j, "", key);
    file = to_string(src, get(section, key, "file"), join(key, "file"));
    contained(join(key, "file"), file);
    const std::string sfield = join(key, "shape");
    const json& shape = array_of(src, get(section, key, "shape"), sfield, 2);
    const std::uint64_t rows = to_count(src, shape[0], index(sfield, 0));
    const std::uint64_t cols = to_count(src, shape[1], index(sfield, 1));
    if (rows != m.plan.vertex_count || cols != columns) {
      src.fail(sfield, "is [" + std::to_string(rows) + ", " + std::to_string(cols) + "] but the plan has " +
                           std::to_string(m.plan.vertex_count) + " vertices and " + std::to_string(columns) +
                           " columns are expected");
    }
  };
  array_file("transfer", m.layer_count(), m.transfer_file);
  array_file("vertices", 6, m.vertices_file);
  if (j.contains("ground")) {
    Manifest::Ground ground;
    array_file("ground", m.layer_count(), ground.file);
    const json& horizontal = array_of(src, get(get(j, "", "ground"), "ground", "horizontal_unoccluded"),
                                      "ground.horizontal_unoccluded", m.layer_count());
    for (std::size_t k = 0; k < horizontal.size(); ++k) {
      ground.horizontal_unoccluded.push_back(to_double(src, horizontal[k], index("ground.horizontal_unoccluded", k)));
    }
    m.ground = std::move(ground);
  }
  if (j.contains("refinement")) {
    Manifest::Refinement refinement;
    const json& section = get(j, "", "refinement");
    refinement.file = to_string(src, get(section, "refinement", "file"), "refinement.file");
    contained("refinement.file", refinement.file);
    const json& rounds = array_of(src, get(section, "refinement", "rounds"), "refinement.rounds");
    for (std::size_t k = 0; k < rounds.size(); ++k) refinement.round_sizes.push_back(to_count(src, rounds[k], index("refinement.rounds", k)));
    const json& shape = array_of(src, get(section, "refinement", "shape"), "refinement.shape", 2);
    if (to_count(src, shape[0], "refinement.shape[0]") != refinement.edge_count() || to_count(src, shape[1], "refinement.shape[1]") != 2) {
      src.fail("refinement.shape", "must be [" + std::to_string(refinement.edge_count()) + ", 2], the rounds' edges");
    }
    m.refinement = std::move(refinement);
  }
  if (m.refinement.has_value() != (m.plan.refine.tolerance > 0.0)) {
    src.fail("refinement", m.refinement ? "is there but plan.refine is not" : "is missing but plan.refine is set");
  }
  if (m.ground.has_value() != (m.plan.ground_samples > 0)) {
    src.fail("ground", m.ground ? "is there but plan.ground_samples is 0" : "is missing but plan.ground_samples is set");
  }
  if (j.contains("light_map")) {
    const json& section = get(j, "", "light_map");
    Manifest::LightMap l;
    l.width = to_int(src, get(section, "light_map", "width"), "light_map.width", 1, kMaxPlaneTexels);
    l.height = to_int(src, get(section, "light_map", "height"), "light_map.height", 1, kMaxPlaneTexels);
    // Each file with the rows the plan gives it (charts: as many as the section says).
    const auto file_of = [&](const char* key, std::optional<std::uint64_t> rows, std::optional<std::uint64_t> columns,
                             std::string& file) -> std::uint64_t {
      const std::string field = join("light_map", key);
      const json& entry = get(section, "light_map", key);
      file = to_string(src, get(entry, field, "file"), join(field, "file"));
      contained(join(field, "file"), file);
      const std::string sfield = join(field, "shape");
      const json& shape = array_of(src, get(entry, field, "shape"), sfield, columns ? 2 : 1);
      const std::uint64_t r = to_count(src, shape[0], index(sfield, 0));
      if (rows && r != *rows) src.fail(index(sfield, 0), "is " + std::to_string(r) + " but " + std::to_string(*rows) + " are expected");
      if (columns && to_count(src, shape[1], index(sfield, 1)) != *columns) {
        src.fail(index(sfield, 1), "must be " + std::to_string(*columns));
      }
      return r;
    };
    l.chart_count = file_of("charts", std::nullopt, 15, l.charts_file);
    file_of("triangles", m.plan.triangle_count, std::nullopt, l.triangles_file);
    file_of("texels", m.plan.light_map.texels, std::nullopt, l.texels_file);
    // The full form may be left out where the PCA form is there (skylit-bake --light-map-pca-only).
    const bool full_form = section.contains("transfer") || !section.contains("pca");
    if (full_form) {
      file_of("transfer", m.plan.light_map.texels, m.layer_count(), l.transfer_file);
    } else {
      l.transfer_file.clear();
    }
    if (section.contains("ground")) file_of("ground", m.plan.light_map.texels, m.layer_count(), l.ground_file);
    if (!full_form && !l.ground_file.empty()) src.fail("light_map.ground", "is there but light_map.transfer is not");
    if (full_form && l.ground_file.empty() != !m.ground) {
      src.fail("light_map.ground", m.ground ? "is missing but the bake has a ground layer" : "is there but the bake has no ground layer");
    }
    if (section.contains("pca")) {
      const std::string pfield = "light_map.pca";
      const json& pca = get(section, "light_map", "pca");
      Manifest::LightMap::Pca p;
      p.components = to_int(src, get(pca, pfield, "components"), join(pfield, "components"), 1, kMaxPcaComponents);
      p.sky_correlation_deg = to_double(src, get(pca, pfield, "sky_correlation_deg"), join(pfield, "sky_correlation_deg"));
      p.rms_error = to_double(src, get(pca, pfield, "rms_error"), join(pfield, "rms_error"));
      p.max_error = to_double(src, get(pca, pfield, "max_error"), join(pfield, "max_error"));
      const auto k = static_cast<std::uint64_t>(p.components);
      // Each file with the shape the plan, the charts and K give it.
      const auto pca_file = [&](const char* key, const std::vector<std::uint64_t>& expected, std::string& file) {
        const std::string field = join(pfield, key);
        const json& entry = get(pca, pfield, key);
        file = to_string(src, get(entry, field, "file"), join(field, "file"));
        contained(join(field, "file"), file);
        const std::string sfield = join(field, "shape");
        const json& shape = array_of(src, get(entry, field, "shape"), sfield, expected.size());
        for (std::size_t d = 0; d < expected.size(); ++d) {
          const std::uint64_t size = to_count(src, shape[d], index(sfield, d));
          if (size != expected[d]) src.fail(index(sfield, d), "is " + std::to_string(size) + " but " + std::to_string(expected[d]) + " is expected");
        }
      };
      pca_file("weights", {m.plan.light_map.texels, k}, p.weights_file);
      pca_file("vectors", {l.chart_count, k + 1, m.layer_count()}, p.vectors_file);
      if (pca.contains("ground_weights") || pca.contains("ground_vectors")) {
        pca_file("ground_weights", {m.plan.light_map.texels, k}, p.ground_weights_file);
        pca_file("ground_vectors", {l.chart_count, k + 1, m.layer_count()}, p.ground_vectors_file);
        p.ground_rms_error = to_double(src, get(pca, pfield, "ground_rms_error"), join(pfield, "ground_rms_error"));
        p.ground_max_error = to_double(src, get(pca, pfield, "ground_max_error"), join(pfield, "ground_max_error"));
      }
      if (p.ground_weights_file.empty() != !m.ground) {
        src.fail("light_map.pca.ground_weights", m.ground ? "is missing but the bake has a ground layer" : "is there but the bake has no ground layer");
      }
      l.pca = std::move(p);
    }
    m.light_map = std::move(l);
  }
  if (m.light_map.has_value() != (m.plan.light_map.texel > 0.0)) {
    src.fail("light_map", m.light_map ? "is there but plan.light_map is not" : "is missing but plan.light_map is set");
  }

  const json& timings = get(j, "", "timings");
  m.bake_seconds = to_double(src, get(timings, "timings", "bake_seconds"), "timings.bake_seconds");
  m.finalize_seconds = to_double(src, get(timings, "timings", "finalize_seconds"), "timings.finalize_seconds");

  const json& files = array_of(src, get(j, "", "files"), "files");
  for (std::size_t i = 0; i < files.size(); ++i) {
    const std::string field = index("files", i);
    FileRecord f;
    f.path = to_string(src, get(files[i], field, "path"), join(field, "path"));
    f.size = to_count(src, get(files[i], field, "size"), join(field, "size"));
    f.sha256 = to_string(src, get(files[i], field, "sha256"), join(field, "sha256"));
    m.files.push_back(std::move(f));
  }
  return m;
}

Manifest read_manifest(const fs::path& bake_dir) {
  const fs::path path = bake_dir / "manifest.json";
  if (!fs::exists(path)) {
    throw InputError(location_of(path) + " does not exist: '" + bake_dir.string() +
                     "' is not a finished bake. Fix: run skylit-bake (or finish it with --resume or merge), "
                     "or point to the right directory");
  }
  const std::string text = read_file(path);
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    const auto [line, column] = line_and_column(text, e.byte > 0 ? e.byte - 1 : 0);
    throw InputError(location_of(path) + ":" + std::to_string(line) + ":" + std::to_string(column) +
                     ": not valid JSON (" + e.what() + "). Fix: " + kManifestFix);
  } catch (const json::exception& e) {  // out_of_range: a number like 1e999 that no double holds
    throw InputError(location_of(path) + ": not valid JSON (" + e.what() + "). Fix: " + kManifestFix);
  }
  return manifest_from_json(j, path);
}

void write_manifest(const fs::path& bake_dir, Manifest manifest) {
  for (FileRecord& f : manifest.files) {
    const fs::path file = bake_dir / f.path;
    std::error_code error;
    const std::uintmax_t size = fs::file_size(file, error);
    if (error) {
      throw InputError(file.string() + ": cannot be listed in the manifest (" + error.message() +
                       "). Fix: check that the bake directory is writable and not changed by another process");
    }
    f.size = size;
    f.sha256 = sha256_file(file);
  }
  write_file_atomic(bake_dir / "manifest.json", to_json(manifest).dump(2) + "\n");
}

}  // namespace skylit::bake_format
