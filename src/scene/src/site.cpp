#include "skylit/scene/site.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <limits>
#include <optional>
#include <set>
#include <span>
#include <string_view>

#include <yaml-cpp/yaml.h>

#include "skylit/base/error.hpp"
#include "skylit/base/yaml_reader.hpp"
#include "skylit/base/yaml_writer.hpp"

namespace skylit::scene {
namespace {

namespace fs = std::filesystem;

constexpr int kMaxDomeFrequency = 64;       // the geodesic dome's own limit (geom::Dome)
constexpr double kMinPlaneArea = 1e-9;      // m²; below this a plane has no texels to speak of
constexpr double kMinPlaneSine = 1e-9;      // sin(angle between u and v); below: parallel
constexpr std::size_t kMaxPlaneNameLength = 128;

const std::array<std::string_view, 5> kTopKeys{"scene", "dome", "location", "planes", "root"};
const std::array<std::string_view, 2> kLocationKeys{"latitude", "longitude"};
const std::array<std::string_view, 4> kSceneKeys{"model", "up", "scale", "max_edge"};
const std::array<std::string_view, 2> kDomeKeys{"frequency", "basis"};
const std::array<std::string_view, 6> kPlaneKeys{"name", "origin", "u", "v", "resolution", "surface"};


// Reads one site file; every error names the file, the line and column of the offending node
// (1-based), the field path and the fix.
class SiteParser {
 public:
  explicit SiteParser(fs::path file) : r_(std::move(file)) {}

  Site parse() {
    const YAML::Node root =
        r_.load("correct the YAML syntax at that line (indentation, colons, brackets); see docs/site-format.md");
    if (root.IsNull()) {
      fail(root, "", "the site file is empty", "write the scene, dome and planes sections; see docs/site-format.md");
    }
    if (!root.IsMap()) {
      fail(root, "", "the site file must be a map with scene, dome and planes",
           "write the scene, dome and planes sections; see docs/site-format.md");
    }
    r_.check_keys(root, "", kTopKeys);
    r_.read_root(root);

    Site site;
    site.file = r_.file();
    if (YamlReader::optional(root, "root")) site.root = r_.root();
    parse_scene(root, site);
    parse_dome(root, site);
    parse_location(root, site);
    parse_planes(root, site);
    return site;
  }

 private:
  void parse_location(const YAML::Node& root, Site& site) const {
    const YAML::Node location = root["location"];
    if (!location.IsDefined()) return;
    const std::string fix = "write 'location: {latitude: 34.69, longitude: 135.80}' (degrees north and east)";
    if (!location.IsMap()) fail(location.IsNull() ? YamlReader::key_node(root, "location") : location, "location", "expected a map", fix);
    r_.check_keys(location, "location.", kLocationKeys);
    GeoLocation g;
    g.latitude_deg = r_.number(r_.require(location, "latitude", "location.latitude", fix), "location.latitude", fix);
    g.longitude_deg = r_.number(r_.require(location, "longitude", "location.longitude", fix), "location.longitude", fix);
    if (!(g.latitude_deg >= -90 && g.latitude_deg <= 90)) fail(location["latitude"], "location.latitude", "outside [-90, 90]", fix);
    if (!(g.longitude_deg >= -180 && g.longitude_deg <= 180)) {
      fail(location["longitude"], "location.longitude", "outside [-180, 180]", fix);
    }
    site.location = g;
  }

  [[noreturn]] void fail(const YAML::Node& node, const std::string& field, const std::string& problem,
                         const std::string& fix) const {
    r_.fail(node, field, problem, fix);
  }

  // A map section; a missing one is reported at the root as its first required field.
  YAML::Node section(const YAML::Node& root, const std::string& key, const std::string& first_field,
                     const std::string& fix) const {
    const YAML::Node node = root[key];
    if (!node.IsDefined()) fail(root, key + "." + first_field, "required field is missing", fix);
    if (node.IsNull()) {  // "dome:" with nothing under it: point at the key
      fail(YamlReader::key_node(root, key), key + "." + first_field, "required field is missing", fix);
    }
    if (!node.IsMap()) fail(node, key, "expected a map of fields", fix);
    return node;
  }

  Eigen::Vector3d vector3(const YAML::Node& node, const std::string& field, const std::string& fix) const {
    const std::vector<double> v = r_.numbers(node, 3, field, fix);
    return {v[0], v[1], v[2]};
  }

  void parse_scene(const YAML::Node& root, Site& site) const {
    const YAML::Node scene =
        section(root, "scene", "model", "add 'scene: {model: models/building.glb}'");
    r_.check_keys(scene, "scene.", kSceneKeys);

    const YAML::Node model = r_.require(scene, "model", "scene.model",
                                        "'model: <file>' (a .glb, .gltf or .obj path relative to this YAML file)");
    if (!model.IsScalar() || model.Scalar().empty()) {
      fail(model, "scene.model", "expected a file name",
           "write the model's path relative to this YAML file, e.g. models/gate.glb");
    }
    const fs::path model_path(model.Scalar());
    site.model = r_.path(model, "scene.model", "keep the model with the site's files");

    std::string extension = model_path.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    site.up = (extension == ".gltf" || extension == ".glb") ? UpAxis::Y : UpAxis::Z;
    if (const YAML::Node up = YamlReader::optional(scene, "up")) {
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

    if (const YAML::Node scale = YamlReader::optional(scene, "scale")) {
      site.scale = r_.positive(scale, "scene.scale",
                               "write the length of one model unit in metres, e.g. 'scale: 0.01' for a model in "
                               "centimetres");
    }
    if (const YAML::Node max_edge = YamlReader::optional(scene, "max_edge")) {
      site.max_edge = r_.non_negative(max_edge, "scene.max_edge",
                                      "write the longest triangle edge in metres, e.g. 'max_edge: 1', or 0 for the model as it is");
    }
  }

  void parse_dome(const YAML::Node& root, Site& site) const {
    const std::string fix = "write an even integer from 2 to " +
                            std::to_string(kMaxDomeFrequency) +
                            " (2: 40 sky faces, 4: 160, 6: 360, 8: 640)";
    const YAML::Node dome = section(root, "dome", "frequency", "add 'dome: {frequency: 2}'");
    r_.check_keys(dome, "dome.", kDomeKeys);
    const YAML::Node frequency = r_.require(dome, "frequency", "dome.frequency", "'frequency: 2'");
    const long long value = r_.integer(frequency, "dome.frequency", std::numeric_limits<long long>::min(),
                                       std::numeric_limits<long long>::max(), fix);
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
      if (!basis.IsScalar()) {
        fail(basis.IsNull() ? YamlReader::key_node(dome, "basis") : basis, "dome.basis", "expected a name", basis_fix);
      }
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
      r_.check_keys(entry, path + ".", kPlaneKeys);
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
    const YAML::Node surface = YamlReader::optional(entry, "surface");
    if (!surface) return PlaneSurface::Virtual;
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
    const YAML::Node name = r_.require(entry, "name", path + ".name", "'name: <plane name>'");
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
    const YAML::Node origin = r_.require(entry, "origin", path + ".origin", "'origin: [x, y, z]' (metres)");
    plane.origin = vector3(origin, path + ".origin", vector_fix);
    const YAML::Node u = r_.require(entry, "u", path + ".u", "'u: [x, y, z]' (the first edge, metres)");
    plane.u = vector3(u, path + ".u", vector_fix);
    const YAML::Node v = r_.require(entry, "v", path + ".v", "'v: [x, y, z]' (the second edge, metres)");
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
    const std::string resolution_field = path + ".resolution";
    const YAML::Node resolution =
        r_.require(entry, "resolution", resolution_field, "'resolution: [W, H]' (texels along u and v)");
    if (!resolution.IsSequence() || resolution.size() != 2) {
      fail(resolution, resolution_field, "expected a list of 2 integers", resolution_fix);
    }
    std::array<int, 2> size{};
    for (std::size_t k = 0; k < 2; ++k) {
      size[k] = static_cast<int>(r_.integer(resolution[k], resolution_field, 1, kMaxPlaneResolution, resolution_fix));
    }
    plane.width = size[0];
    plane.height = size[1];
    return plane;
  }

  YamlReader r_;
};

YamlNumbers numbers(const Eigen::Vector3d& v) { return {std::span<const double>(v.data(), 3)}; }

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
  std::filesystem::path root = site.root;
  if (!site.file.empty() && root.is_relative()) {
    const std::filesystem::path relative = root.lexically_relative(site.file.parent_path());
    if (!relative.empty()) root = relative;
  }

  using YAML::Key, YAML::Value, YAML::Comment;
  YAML::Emitter out;
  out << YamlCommentLine{"skylit site (format: docs/site-format.md). Site frame: metres, x east, y north, z up."}
      << YAML::BeginMap;
  if (!root.empty()) {
    out << Key << "root" << Value << YamlText{root.generic_string()}
        << Comment("the folder every file named here lies in, relative to this file");
  }
  out << Key << "scene" << Value << YAML::BeginMap
      << Key << "model" << Value << YamlText{model.generic_string()}
      << Comment("glTF 2.0 (.glb/.gltf) or OBJ, relative to this file")
      << Key << "up" << Value << (site.up == UpAxis::Y ? "y" : "z")
      << Comment("the model's up axis: y (glTF standard) or z")
      << Key << "scale" << Value << YamlNumber{site.scale} << Comment("metres per model unit");
  if (site.max_edge > 0.0) {
    out << Key << "max_edge" << Value << YamlNumber{site.max_edge} << Comment("metres: longer triangle edges are split");
  }
  out << YAML::EndMap << Key << "dome" << Value << YAML::BeginMap
      << Key << "frequency" << Value << site.dome_frequency
      << Comment("geodesic sky dome, even: 2 = 40 faces, 4 = 160, 6 = 360, 8 = 640");
  if (site.dome_basis != geom::DomeBasis::Faces) {
    out << Key << "basis" << Value << std::string(geom::basis_name(site.dome_basis))
        << Comment("radiance per face: faces (constant), corners (linear) or quadratics");
  }
  out << YAML::EndMap;
  if (site.location) {
    out << Key << "location" << Value << YAML::BeginMap << Key << "latitude" << Value
        << YamlNumber{site.location->latitude_deg} << Key << "longitude" << Value << YamlNumber{site.location->longitude_deg}
        << YAML::EndMap << Comment("degrees north and east: where the sun should be, for the console's aim check");
  }
  out << YamlCommentLine{"Shadowing planes: rectangles origin + s·u + t·v (s, t in [0, 1]), normal = u × v.\n"
                         "Texel (col, row) has its centre at origin + (col+0.5)/W·u + (row+0.5)/H·v."}
      << Key << "planes" << Value << YAML::BeginSeq;
  for (std::size_t index = 0; index < site.planes.size(); ++index) {
    const geom::Plane& plane = site.planes[index];
    out << YAML::BeginMap
        << Key << "name" << Value << YamlText{plane.name} << Comment("letters, digits, '_' and '-': it names bake files")
        << Key << "origin" << Value << numbers(plane.origin) << Comment("one corner, metres")
        << Key << "u" << Value << numbers(plane.u) << Comment("first edge: columns run along it")
        << Key << "v" << Value << numbers(plane.v) << Comment("second edge: rows run along it")
        << Key << "resolution" << Value << YAML::Flow << YAML::BeginSeq << plane.width << plane.height << YAML::EndSeq
        << Comment("texels along u and v (1 to " + std::to_string(kMaxPlaneResolution) + ")")
        << Key << "surface" << Value << (site.surface_of(index) == PlaneSurface::Real ? "real" : "virtual")
        << Comment("real: seen by the camera (ground); virtual: on the virtual building") << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return yaml_document(out);
}

}  // namespace skylit::scene
