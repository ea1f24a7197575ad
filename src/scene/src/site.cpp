#include "skylit/scene/site.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>

#include <yaml-cpp/yaml.h>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit::scene {
namespace {

namespace fs = std::filesystem;

constexpr int kMaxDomeFrequency = 64;       // the geodesic dome's own limit (geom::Dome)
constexpr double kMinPlaneArea = 1e-9;      // m²; below this a plane has no texels to speak of
constexpr double kMinPlaneSine = 1e-9;      // sin(angle between u and v); below: parallel
constexpr std::size_t kMaxPlaneNameLength = 128;

const std::array<std::string_view, 3> kTopKeys{"scene", "dome", "planes"};
const std::array<std::string_view, 3> kSceneKeys{"model", "up", "scale"};
const std::array<std::string_view, 2> kDomeKeys{"frequency", "basis"};
const std::array<std::string_view, 6> kPlaneKeys{"name", "origin", "u", "v", "resolution", "surface"};


// Reads one site file; every error names the file, the line and column of the offending node
// (1-based), the field path and the fix.
class SiteParser {
 public:
  explicit SiteParser(fs::path file) : file_(std::move(file)) {}

  Site parse() {
    const std::string text = read_file(file_);
    YAML::Node root;
    try {
      root = YAML::Load(text);
    } catch (const YAML::ParserException& e) {
      throw InputError(input_message(file_, e.mark.line + 1, e.mark.column + 1, "",
                                     "YAML syntax error: " + e.msg,
                                     "correct the YAML syntax at that line (indentation, colons, "
                                     "brackets); see docs/site-format.md"));
    }
    if (!root.IsDefined() || root.IsNull()) {
      fail(root, "", "the site file is empty",
           "write the scene, dome and planes sections; see docs/site-format.md");
    }
    if (!root.IsMap()) {
      fail(root, "", "the site file must be a map with scene, dome and planes",
           "write the scene, dome and planes sections; see docs/site-format.md");
    }
    check_keys(root, "", kTopKeys);

    Site site;
    site.file = file_;
    parse_scene(root, site);
    parse_dome(root, site);
    parse_planes(root, site);
    return site;
  }

 private:
  [[noreturn]] void fail(const YAML::Node& node, const std::string& field,
                         const std::string& problem, const std::string& fix) const {
    int line = -1;
    int column = -1;
    if (node.IsDefined()) {
      const YAML::Mark mark = node.Mark();
      if (mark.line >= 0) {
        line = mark.line + 1;
        column = mark.column + 1;
      }
    }
    throw InputError(input_message(file_, line, column, field, problem, fix));
  }

  static std::string join(const std::string& parent, std::string_view key) {
    return parent.empty() ? std::string(key) : parent + "." + std::string(key);
  }

  template <std::size_t N>
  void check_keys(const YAML::Node& map, const std::string& path,
                  const std::array<std::string_view, N>& allowed) const {
    std::set<std::string> seen;
    for (const auto& entry : map) {
      const YAML::Node& key_node = entry.first;
      const std::string key = key_node.IsScalar() ? key_node.Scalar() : std::string("?");
      const std::string field = join(path, key);
      if (!key_node.IsScalar()) {
        fail(key_node, path, "a key is not a plain name", "use plain names as keys");
      }
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        const std::string fix = unknown_key_fix(key, std::span<const std::string_view>(allowed));
        fail(key_node, field, "unknown field", fix);
      }
      if (!seen.insert(key).second) {
        fail(key_node, field, "the field appears twice", "keep one of them");
      }
    }
  }

  // A required field's node; a missing one is reported at its parent map.
  YAML::Node require(const YAML::Node& map, std::string_view key, const std::string& path,
                     const std::string& fix) const {
    const YAML::Node node = map[std::string(key)];
    if (!node.IsDefined()) fail(map, join(path, key), "required field is missing", fix);
    if (node.IsNull()) fail(key_node(map, key), join(path, key), "the field has no value", fix);
    return node;
  }

  // The key node of `key` in `map` (a null value's own mark points past it, at the next line).
  static YAML::Node key_node(const YAML::Node& map, std::string_view key) {
    for (const auto& entry : map) {
      if (entry.first.IsScalar() && entry.first.Scalar() == key) return entry.first;
    }
    return map;
  }

  // A map section; a missing one is reported at the root as its first required field.
  YAML::Node section(const YAML::Node& root, std::string_view key, std::string_view first_field,
                     const std::string& fix) const {
    const YAML::Node node = root[std::string(key)];
    if (!node.IsDefined()) {
      fail(root, join(std::string(key), first_field), "required field is missing", fix);
    }
    if (node.IsNull()) {  // "dome:" with nothing under it: point at the key
      fail(key_node(root, key), join(std::string(key), first_field), "required field is missing",
           fix);
    }
    if (!node.IsMap()) {
      fail(node, std::string(key), "expected a map of fields", fix);
    }
    return node;
  }

  std::optional<double> as_number(const YAML::Node& node) const {
    if (!node.IsScalar()) return std::nullopt;
    try {
      return node.as<double>();
    } catch (const YAML::BadConversion&) {
      return std::nullopt;
    }
  }

  double number(const YAML::Node& node, const std::string& field, const std::string& fix) const {
    const std::optional<double> value = as_number(node);
    if (!value) fail(node, field, "expected a number", fix);
    if (!std::isfinite(*value)) fail(node, field, "the number is not finite", fix);
    return *value;
  }

  // An integer written as an integer ("512", not "512.0" or "5e2").
  long long integer(const YAML::Node& node, const std::string& field,
                    const std::string& fix) const {
    if (node.IsScalar()) {
      const std::string& text = node.Scalar();
      long long value = 0;
      const char* first = text.data();
      const char* last = text.data() + text.size();
      if (first != last && *first == '+') ++first;
      const auto [end, error] = std::from_chars(first, last, value);
      if (error == std::errc() && end == last) return value;
      if (error == std::errc::result_out_of_range) fail(node, field, "the integer is too large", fix);
      if (as_number(node)) fail(node, field, "expected an integer, got '" + text + "'", fix);
    }
    fail(node, field, "expected an integer", fix);
  }

  Eigen::Vector3d vector3(const YAML::Node& node, const std::string& field,
                          const std::string& fix) const {
    if (!node.IsSequence() || node.size() != 3) {
      fail(node, field, "expected a list of 3 numbers", fix);
    }
    Eigen::Vector3d value;
    for (std::size_t k = 0; k < 3; ++k) {
      const YAML::Node element = node[k];
      const std::optional<double> x = as_number(element);
      if (!x) fail(element, field, "expected a list of 3 numbers", fix);
      if (!std::isfinite(*x)) {
        fail(element, field, "element " + std::to_string(k) + " is not a finite number", fix);
      }
      value[static_cast<Eigen::Index>(k)] = *x;
    }
    return value;
  }

  void parse_scene(const YAML::Node& root, Site& site) const {
    const YAML::Node scene =
        section(root, "scene", "model", "add 'scene: {model: models/building.glb}'");
    check_keys(scene, "scene", kSceneKeys);

    const YAML::Node model = require(scene, "model", "scene",
                                     "add 'model: <file>' (a .glb, .gltf or .obj path relative to "
                                     "this YAML file)");
    if (!model.IsScalar() || model.Scalar().empty()) {
      fail(model, "scene.model", "expected a file name",
           "write the model's path relative to this YAML file, e.g. models/gate.glb");
    }
    const fs::path model_path(model.Scalar());
    site.model = model_path.is_absolute() ? model_path : file_.parent_path() / model_path;

    std::string extension = model_path.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    site.up = (extension == ".gltf" || extension == ".glb") ? UpAxis::Y : UpAxis::Z;
    if (const YAML::Node up = scene["up"]; up.IsDefined() && !up.IsNull()) {
      const std::string text = up.IsScalar() ? up.Scalar() : std::string();
      if (text == "z" || text == "Z") {
        site.up = UpAxis::Z;
      } else if (text == "y" || text == "Y") {
        site.up = UpAxis::Y;
      } else {
        fail(up, "scene.up", "expected 'y' or 'z'" + (text.empty() ? "" : ", got '" + text + "'"),
             "write 'up: z' for a z-up model or 'up: y' for a y-up model (glTF is y-up)");
      }
    }

    if (const YAML::Node scale = scene["scale"]; scale.IsDefined() && !scale.IsNull()) {
      const std::string fix = "write the length of one model unit in metres, e.g. 'scale: 0.01' "
                              "for a model in centimetres";
      site.scale = number(scale, "scene.scale", fix);
      if (site.scale <= 0.0) fail(scale, "scene.scale", "the scale must be positive", fix);
    }
  }

  void parse_dome(const YAML::Node& root, Site& site) const {
    const std::string fix = "write an even integer from 2 to " +
                            std::to_string(kMaxDomeFrequency) +
                            " (2: 40 sky faces, 4: 160, 6: 360, 8: 640)";
    const YAML::Node dome = section(root, "dome", "frequency", "add 'dome: {frequency: 2}'");
    check_keys(dome, "dome", kDomeKeys);
    const YAML::Node frequency = require(dome, "frequency", "dome", "add 'frequency: 2'");
    const long long value = integer(frequency, "dome.frequency", fix);
    if (value < 2 || value > kMaxDomeFrequency || value % 2 != 0) {
      fail(frequency, "dome.frequency",
           "the frequency " + std::to_string(value) + " is not an even integer from 2 to " +
               std::to_string(kMaxDomeFrequency) + " (even keeps the horizon on dome edges)",
           fix);
    }
    site.dome_frequency = static_cast<int>(value);
    if (const YAML::Node basis = dome["basis"]; basis.IsDefined()) {
      const std::string basis_fix =
          "write 'basis: faces' (one radiance per sky face), 'basis: corners' (three per face, "
          "linear across it) or 'basis: quadratics' (six per face, quadratic across it), or leave the "
          "field out for faces";
      if (!basis.IsScalar()) fail(basis.IsNull() ? key_node(dome, "basis") : basis, "dome.basis", "expected a name", basis_fix);
      const std::optional<geom::DomeBasis> parsed = geom::parse_basis(basis.Scalar());
      if (!parsed) fail(basis, "dome.basis", "unknown basis '" + basis.Scalar() + "'", basis_fix);
      site.dome_basis = *parsed;
    }
  }

  void parse_planes(const YAML::Node& root, Site& site) const {
    const std::string example =
        "add 'planes:' with entries like '- {name: ground, origin: [-10, -10, 0.01], "
        "u: [20, 0, 0], v: [0, 20, 0], resolution: [512, 512]}'";
    const YAML::Node planes = root["planes"];
    if (!planes.IsDefined() || planes.IsNull()) {
      fail(root, "planes", "required field is missing", example);
    }
    if (!planes.IsSequence()) fail(planes, "planes", "expected a list of planes", example);
    if (planes.size() == 0) fail(planes, "planes", "the list of planes is empty", example);

    std::set<std::string> names;
    for (std::size_t index = 0; index < planes.size(); ++index) {
      const YAML::Node entry = planes[index];
      const std::string path = "planes[" + std::to_string(index) + "]";
      if (!entry.IsMap()) {
        fail(entry, path, "expected a map with name, origin, u, v and resolution", example);
      }
      check_keys(entry, path, kPlaneKeys);
      geom::Plane plane = parse_plane(entry, path);
      if (!names.insert(plane.name).second) {
        fail(entry["name"], path + ".name", "the plane name '" + plane.name + "' is used twice",
             "give every plane its own name (names become file names of the bake)");
      }
      site.planes.push_back(std::move(plane));
      site.plane_surfaces.push_back(parse_surface(entry, path));
    }
  }

  // Optional; absent means virtual (files written before the field existed keep their meaning).
  PlaneSurface parse_surface(const YAML::Node& entry, const std::string& path) const {
    const YAML::Node surface = entry["surface"];
    if (!surface.IsDefined() || surface.IsNull()) return PlaneSurface::Virtual;
    const std::string text = surface.IsScalar() ? surface.Scalar() : std::string();
    if (text == "real") return PlaneSurface::Real;
    if (text == "virtual") return PlaneSurface::Virtual;
    std::string problem = "expected 'real' or 'virtual'";
    if (!text.empty()) problem.append(", got '").append(text).append("'");
    fail(surface, path + ".surface", problem,
         "write 'surface: real' for a real surface the camera sees (the ground) or "
         "'surface: virtual' for a surface of the virtual building (a wall, a roof)");
  }

  geom::Plane parse_plane(const YAML::Node& entry, const std::string& path) const {
    geom::Plane plane;
    const std::string name_fix =
        "use letters, digits, '_' and '-' only (the name becomes a file name), e.g. 'ground'";
    const YAML::Node name = require(entry, "name", path, "add 'name: <plane name>'");
    if (!name.IsScalar() || name.Scalar().empty()) {
      fail(name, path + ".name", "the plane name is empty or not text", name_fix);
    }
    plane.name = name.Scalar();
    const bool safe = std::all_of(plane.name.begin(), plane.name.end(), [](char c) {
      return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
             c == '_' || c == '-';
    });
    if (!safe) {
      fail(name, path + ".name", "the plane name '" + plane.name + "' is not a safe file name",
           name_fix);
    }
    if (plane.name.size() > kMaxPlaneNameLength) {
      fail(name, path + ".name", "the plane name is longer than " +
                                     std::to_string(kMaxPlaneNameLength) + " characters",
           "use a shorter name");
    }

    const std::string vector_fix = "write three numbers in metres, e.g. [0, 0, 0.01]";
    const YAML::Node origin = require(entry, "origin", path, "add 'origin: [x, y, z]' (metres)");
    plane.origin = vector3(origin, path + ".origin", vector_fix);
    const YAML::Node u = require(entry, "u", path, "add 'u: [x, y, z]' (the first edge, metres)");
    plane.u = vector3(u, path + ".u", vector_fix);
    const YAML::Node v = require(entry, "v", path, "add 'v: [x, y, z]' (the second edge, metres)");
    plane.v = vector3(v, path + ".v", vector_fix);

    const std::string edge_fix =
        "give u and v non-zero lengths and different directions (the plane's normal is u × v)";
    if (plane.u.norm() * plane.u.norm() < kMinPlaneArea) {
      fail(u, path + ".u", "the edge u has (almost) zero length", edge_fix);
    }
    if (plane.v.norm() * plane.v.norm() < kMinPlaneArea) {
      fail(v, path + ".v", "the edge v has (almost) zero length", edge_fix);
    }
    const double area = plane.u.cross(plane.v).norm();
    if (area < kMinPlaneArea || area < kMinPlaneSine * plane.u.norm() * plane.v.norm()) {
      fail(v, path + ".v", "u and v are parallel (the plane has no area)", edge_fix);
    }

    const std::string resolution_fix =
        "write two integers [W, H] from 1 to " + std::to_string(kMaxPlaneResolution) +
        ", texels along u and v, e.g. [512, 512]";
    const YAML::Node resolution =
        require(entry, "resolution", path, "add 'resolution: [W, H]' (texels along u and v)");
    const std::string resolution_field = path + ".resolution";
    if (!resolution.IsSequence() || resolution.size() != 2) {
      fail(resolution, resolution_field, "expected a list of 2 integers", resolution_fix);
    }
    std::array<int, 2> size{};
    for (std::size_t k = 0; k < 2; ++k) {
      const YAML::Node element = resolution[k];
      const long long value = integer(element, resolution_field, resolution_fix);
      if (value < 1 || value > kMaxPlaneResolution) {
        fail(element, resolution_field,
             "the resolution " + std::to_string(value) + " is outside 1.." +
                 std::to_string(kMaxPlaneResolution),
             resolution_fix);
      }
      size[k] = static_cast<int>(value);
    }
    plane.width = size[0];
    plane.height = size[1];
    return plane;
  }

  fs::path file_;
};

// Shortest text that reads back as exactly the same double.
std::string format_number(double value) {
  std::array<char, 64> buffer{};
  const auto [end, error] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  (void)error;  // 64 characters hold any double
  return std::string(buffer.data(), end);
}

std::string format_vector(const Eigen::Vector3d& v) {
  std::string text = "[";  // appended piecewise: GCC 12 misreports chained '+' (-Wrestrict)
  text += format_number(v.x());
  text += ", ";
  text += format_number(v.y());
  text += ", ";
  text += format_number(v.z());
  text += "]";
  return text;
}

// A YAML double-quoted scalar (paths may hold spaces, colons or '#').
std::string quote(const std::string& text) {
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') quoted += '\\';
    quoted += c;
  }
  return quoted + "\"";
}

}  // namespace

Site load_site(const std::filesystem::path& file) {
  try {
    return SiteParser(file).parse();
  } catch (const YAML::Exception& e) {  // a construct the checks above did not foresee
    const int line = e.mark.line >= 0 ? e.mark.line + 1 : -1;
    const int column = e.mark.column >= 0 ? e.mark.column + 1 : -1;
    throw InputError(input_message(file, line, column, "", "cannot read the site: " + e.msg,
                                   "follow the schema in docs/site-format.md"));
  }
}

std::string site_to_yaml(const Site& site) {
  // The model is written relative to the YAML's directory when the YAML's place is known, so
  // that load_site of the written file resolves it to the same file.
  std::filesystem::path model = site.model;
  if (!site.file.empty() && model.is_relative()) {
    const std::filesystem::path relative = model.lexically_relative(site.file.parent_path());
    if (!relative.empty()) model = relative;
  }

  std::ostringstream out;
  out << "# skylit site (format: docs/site-format.md). Site frame: metres, x east, y north, z up.\n"
      << "scene:\n"
      << "  model: " << quote(model.generic_string())
      << "  # glTF 2.0 (.glb/.gltf) or OBJ, relative to this file\n"
      << "  up: " << (site.up == UpAxis::Y ? "y" : "z")
      << "  # the model's up axis: y (glTF standard) or z\n"
      << "  scale: " << format_number(site.scale) << "  # metres per model unit\n"
      << "dome:\n"
      << "  frequency: " << site.dome_frequency
      << "  # geodesic sky dome, even: 2 = 40 faces, 4 = 160, 6 = 360, 8 = 640\n";
  if (site.dome_basis != geom::DomeBasis::Faces) {
    out << "  basis: " << geom::basis_name(site.dome_basis) << "  # radiance per face: faces (constant), corners (linear) or quadratics\n";
  }
  out
      << "# Shadowing planes: rectangles origin + s·u + t·v (s, t in [0, 1]), normal = u × v.\n"
      << "# Texel (col, row) has its centre at origin + (col+0.5)/W·u + (row+0.5)/H·v.\n"
      << "planes:\n";
  for (std::size_t index = 0; index < site.planes.size(); ++index) {
    const geom::Plane& plane = site.planes[index];
    out << "  - name: " << quote(plane.name) << "  # letters, digits, '_' and '-': it names bake files\n"
        << "    origin: " << format_vector(plane.origin) << "  # one corner, metres\n"
        << "    u: " << format_vector(plane.u) << "  # first edge: columns run along it\n"
        << "    v: " << format_vector(plane.v) << "  # second edge: rows run along it\n"
        << "    resolution: [" << plane.width << ", " << plane.height
        << "]  # texels along u and v (1 to " << kMaxPlaneResolution << ")\n"
        << "    surface: " << (site.surface_of(index) == PlaneSurface::Real ? "real" : "virtual")
        << "  # real: seen by the camera (ground); virtual: on the virtual building\n";
  }
  return out.str();
}

}  // namespace skylit::scene
