#include "skylit/scene/site.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "skylit/base/error.hpp"
#include "../support/temp_dir.hpp"

namespace skylit::scene {
namespace {

using skylit::test::error_of;
using skylit::test::TempDir;

// A valid site; the bad cases below change one thing in it.
//  1 scene:
//  2   model: models/gate.glb
//  3   up: z
//  4   scale: 0.5
//  5 dome:
//  6   frequency: 4
//  7 planes:
//  8   - name: ground
//  9     origin: [-10, -10, 0.01]
// 10     u: [20, 0, 0]
// 11     v: [0, 20, 0]
// 12     resolution: [512, 256]
// 13   - name: wall_2-b
// 14     origin: [1, 2, 0]
// 15     u: [3, 0, 0]
// 16     v: [0, 0, 2.5]
// 17     resolution: [64, 32]
const std::vector<std::string> kGoodLines = {
    "scene:",
    "  model: models/gate.glb",
    "  up: z",
    "  scale: 0.5",
    "dome:",
    "  frequency: 4",
    "planes:",
    "  - name: ground",
    "    origin: [-10, -10, 0.01]",
    "    u: [20, 0, 0]",
    "    v: [0, 20, 0]",
    "    resolution: [512, 256]",
    "  - name: wall_2-b",
    "    origin: [1, 2, 0]",
    "    u: [3, 0, 0]",
    "    v: [0, 0, 2.5]",
    "    resolution: [64, 32]",
};

std::string join(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  return text;
}

// The good site with line `line` (1-based) replaced; an empty replacement removes the line.
std::string good_with(int line, const std::string& replacement) {
  std::vector<std::string> lines = kGoodLines;
  if (replacement.empty()) {
    lines.erase(lines.begin() + (line - 1));
  } else {
    lines[static_cast<std::size_t>(line - 1)] = replacement;
  }
  return join(lines);
}

// The good site without lines first..last (1-based, inclusive).
std::string without_lines(int first, int last) {
  std::vector<std::string> lines = kGoodLines;
  lines.erase(lines.begin() + (first - 1), lines.begin() + last);
  return join(lines);
}

TEST(LoadSite, ParsesEveryFieldExactly) {
  TempDir dir;
  const auto file = dir.write("site.yaml", join(kGoodLines));
  const Site site = load_site(file);
  EXPECT_EQ(site.file, file);
  EXPECT_EQ(site.model, dir.path() / "models/gate.glb");
  EXPECT_EQ(site.up, UpAxis::Z);
  EXPECT_EQ(site.scale, 0.5);
  EXPECT_EQ(site.dome_frequency, 4);
  ASSERT_EQ(site.planes.size(), 2u);
  EXPECT_EQ(site.planes[0].name, "ground");
  EXPECT_EQ(site.planes[0].origin, geom::Vec3(-10, -10, 0.01));
  EXPECT_EQ(site.planes[0].u, geom::Vec3(20, 0, 0));
  EXPECT_EQ(site.planes[0].v, geom::Vec3(0, 20, 0));
  EXPECT_EQ(site.planes[0].width, 512);
  EXPECT_EQ(site.planes[0].height, 256);
  EXPECT_EQ(site.planes[1].name, "wall_2-b");
  EXPECT_EQ(site.planes[1].origin, geom::Vec3(1, 2, 0));
  EXPECT_EQ(site.planes[1].v, geom::Vec3(0, 0, 2.5));
  EXPECT_EQ(site.planes[1].width, 64);
  EXPECT_EQ(site.planes[1].height, 32);
  EXPECT_EQ(site.planes[1].normal(), geom::Vec3(0, -1, 0));  // u east × v up = south
}

TEST(LoadSite, UpAndScaleDefaultByModelType) {
  TempDir dir;
  const Site gltf = load_site(dir.write("a.yaml", good_with(3, "")));  // no `up`
  EXPECT_EQ(gltf.up, UpAxis::Y);  // .glb is y-up by the glTF standard
  std::string obj_site = join(kGoodLines);
  obj_site.replace(obj_site.find("models/gate.glb"), 15, "models/gate.OBJ");
  obj_site.erase(obj_site.find("  up: z\n"), 8);
  obj_site.erase(obj_site.find("  scale: 0.5\n"), 13);
  const Site obj = load_site(dir.write("b.yaml", obj_site));
  EXPECT_EQ(obj.up, UpAxis::Z);
  EXPECT_EQ(obj.scale, 1.0);
  const Site explicit_y = load_site(dir.write("c.yaml", good_with(3, "  up: y")));
  EXPECT_EQ(explicit_y.up, UpAxis::Y);
}

TEST(LoadSite, AbsoluteModelPathIsKeptInsideTheRoot) {
  TempDir dir;
  const Site site = load_site(dir.write("s.yaml", "root: /srv\n" + good_with(2, "  model: /srv/models/x.obj")));
  EXPECT_EQ(site.model, std::filesystem::path("/srv/models/x.obj"));
  EXPECT_EQ(site.root, std::filesystem::path("/srv"));
}

// The site names its model inside its root (its own folder unless `root:` says otherwise):
// absolute, through '..', or a root that does not hold it, each an error naming the field.
TEST(LoadSite, AModelOutsideTheRootIsRefusedNamingTheField) {
  TempDir dir;
  for (const std::string model : {"/srv/models/x.obj", "../x.obj", "models/../../x.obj"}) {
    SCOPED_TRACE(model);
    const std::string message = error_of([&] { load_site(dir.write("s.yaml", good_with(2, "  model: " + model))); });
    EXPECT_NE(message.find("field 'scene.model': '" + model + "' is outside the folder this file may name files in, '" +
                           dir.path().lexically_normal().string() + "'"), std::string::npos) << message;
    EXPECT_NE(message.find("Fix: move the file under that folder, or make the folder wider with 'root: FOLDER'"),
              std::string::npos) << message;
  }
  // `root: ..` widens it to the parent; a root elsewhere holds nothing of the site's.
  EXPECT_EQ(load_site(dir.write("s.yaml", "root: ..\n" + good_with(2, "  model: ../x.obj"))).model,
            (dir.path() / "../x.obj").lexically_normal());
  EXPECT_THROW(load_site(dir.write("s.yaml", "root: /srv\n" + good_with(2, "  model: models/gate.glb"))), InputError);
}

struct BadCase {
  std::string label;
  std::string yaml;
  int line;               // 1-based line the message must name
  std::string field;      // field path the message must name ("" for syntax errors)
  std::string problem;    // a part of the message that says what is wrong
};

std::vector<BadCase> bad_cases() {
  std::string duplicate_names = join(kGoodLines);
  duplicate_names.replace(duplicate_names.find("wall_2-b"), 8, "ground");
  std::string duplicate_key = join(kGoodLines);
  duplicate_key.insert(duplicate_key.find("planes:"), "  frequency: 2\n");
  return {
      {"syntax error", good_with(9, "    origin: [-10, -10, 0.01"), 10, "", "YAML syntax error"},
      {"bad indentation", good_with(4, "    scale: 0.5: 3"), 4, "", "YAML syntax error"},
      {"top level not a map", "- scene\n- dome\n", 1, "", "must be a map"},
      {"missing model", good_with(2, ""), 2, "scene.model", "missing"},
      {"missing scene", join({kGoodLines.begin() + 4, kGoodLines.end()}), 1, "scene.model",
       "missing"},
      {"missing dome", without_lines(5, 6), 1, "dome.frequency", "missing"},
      {"latitude out of range", good_with(7, "location: {latitude: 91, longitude: 10}\nplanes:"), 7, "location.latitude", "outside [-90, 90]"},
      {"longitude out of range", good_with(7, "location: {latitude: 1, longitude: -180.5}\nplanes:"), 7, "location.longitude", "outside [-180, 180]"},
      {"location without longitude", good_with(7, "location: {latitude: 1}\nplanes:"), 7, "location.longitude", "missing"},
      {"missing frequency", good_with(6, "  # none"), 5, "dome.frequency", "missing"},
      {"frequency without value", good_with(6, "  frequency:"), 6, "dome.frequency",
       "has no value"},
      {"origin without value", good_with(14, "    origin:"), 14, "planes[1].origin",
       "has no value"},
      {"missing planes", join({kGoodLines.begin(), kGoodLines.begin() + 6}), 1, "planes",
       "missing"},
      {"planes not a list", join({kGoodLines.begin(), kGoodLines.begin() + 6}) + "planes: 3\n", 7,
       "planes", "expected a list"},
      {"planes empty", join({kGoodLines.begin(), kGoodLines.begin() + 6}) + "planes: []\n", 7,
       "planes", "empty"},
      {"missing name", good_with(13, "  -"), 14, "planes[1].name", "missing"},
      {"missing origin", good_with(9, ""), 8, "planes[0].origin", "missing"},
      {"missing u", good_with(10, ""), 8, "planes[0].u", "missing"},
      {"missing v", good_with(16, ""), 13, "planes[1].v", "missing"},
      {"missing resolution", good_with(12, ""), 8, "planes[0].resolution", "missing"},
      {"origin too short", good_with(9, "    origin: [-10, -10]"), 9, "planes[0].origin",
       "expected a list of 3 numbers"},
      {"origin not a list", good_with(9, "    origin: 5"), 9, "planes[0].origin",
       "expected a list of 3 numbers"},
      {"origin has text", good_with(9, "    origin: [-10, east, 0]"), 9, "planes[0].origin",
       "element 1 is not a finite number"},
      {"origin nan", good_with(9, "    origin: [.nan, 0, 0]"), 9, "planes[0].origin",
       "not a finite number"},
      {"u infinite", good_with(15, "    u: [.inf, 0, 0]"), 15, "planes[1].u",
       "not a finite number"},
      {"unknown plane key", good_with(12, "    resoluton: [512, 256]"), 12,
       "planes[0].resoluton", "did you mean 'resolution'"},
      {"unknown top key", good_with(7, "plane:"), 7, "plane", "did you mean 'planes'"},
      {"unknown scene key", good_with(3, "  upaxis: z"), 3, "scene.upaxis", "unknown field"},
      {"duplicate key", duplicate_key, 7, "dome.frequency", "appears twice"},
      {"odd frequency", good_with(6, "  frequency: 3"), 6, "dome.frequency", "not an even"},
      {"zero frequency", good_with(6, "  frequency: 0"), 6, "dome.frequency", "not an even"},
      {"negative frequency", good_with(6, "  frequency: -2"), 6, "dome.frequency",
       "not an even"},
      {"huge frequency", good_with(6, "  frequency: 66"), 6, "dome.frequency", "not an even"},
      {"fractional frequency", good_with(6, "  frequency: 2.5"), 6, "dome.frequency",
       "expected an integer"},
      {"text frequency", good_with(6, "  frequency: two"), 6, "dome.frequency",
       "expected an integer"},
      {"zero resolution", good_with(12, "    resolution: [0, 256]"), 12,
       "planes[0].resolution", "outside 1..16384"},
      {"resolution too large", good_with(17, "    resolution: [64, 16385]"), 17,
       "planes[1].resolution", "outside 1..16384"},
      {"resolution negative", good_with(17, "    resolution: [-64, 32]"), 17,
       "planes[1].resolution", "outside 1..16384"},
      {"resolution fraction", good_with(12, "    resolution: [512.5, 256]"), 12,
       "planes[0].resolution", "expected an integer"},
      {"resolution written as float", good_with(12, "    resolution: [512.0, 256]"), 12,
       "planes[0].resolution", "expected an integer"},
      {"resolution one number", good_with(12, "    resolution: [512]"), 12,
       "planes[0].resolution", "expected a list of 2 integers"},
      {"zero u", good_with(10, "    u: [0, 0, 0]"), 10, "planes[0].u", "zero length"},
      {"zero v", good_with(11, "    v: [0, 0, 0]"), 11, "planes[0].v", "zero length"},
      {"parallel u v", good_with(11, "    v: [-40, 0, 0]"), 11, "planes[0].v", "parallel"},
      {"nearly parallel u v", good_with(11, "    v: [20, 1e-10, 0]"), 11, "planes[0].v",
       "parallel"},
      {"duplicate plane names", duplicate_names, 13, "planes[1].name", "used twice"},
      {"empty plane name", good_with(8, "  - name: \"\""), 8, "planes[0].name", "empty"},
      {"plane name with space", good_with(8, "  - name: my plane"), 8, "planes[0].name",
       "not a safe file name"},
      {"plane name with path", good_with(13, "  - name: ../evil"), 13, "planes[1].name",
       "not a safe file name"},
      {"zero scale", good_with(4, "  scale: 0"), 4, "scene.scale", "must be positive"},
      {"negative scale", good_with(4, "  scale: -1"), 4, "scene.scale", "must be positive"},
      {"infinite scale", good_with(4, "  scale: .inf"), 4, "scene.scale", "not finite"},
      {"text scale", good_with(4, "  scale: big"), 4, "scene.scale", "'big' is not a number"},
      {"up x", good_with(3, "  up: x"), 3, "scene.up", "expected 'y' or 'z'"},
      {"empty model", good_with(2, "  model: \"\""), 2, "scene.model", "expected a file name"},
      {"scene not a map", "scene: 3\n" + without_lines(1, 4), 1, "scene", "expected a map"},
      {"unknown surface", good_with(12, "    resolution: [512, 256]\n    surface: ground"), 13,
       "planes[0].surface", "expected 'real' or 'virtual', got 'ground'"},
      {"surface not text", good_with(17, "    resolution: [64, 32]\n    surface: [real]"), 18,
       "planes[1].surface", "expected 'real' or 'virtual'"},
  };
}

TEST(LoadSite, EveryBadInputNamesFileLineAndField) {
  TempDir dir;
  int index = 0;
  for (const BadCase& bad : bad_cases()) {
    SCOPED_TRACE(bad.label);
    const auto file = dir.write("bad" + std::to_string(index++) + ".yaml", bad.yaml);
    try {
      (void)load_site(file);
      ADD_FAILURE() << "no error for:\n" << bad.yaml;
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(file.string() + ":" + std::to_string(bad.line) + ":"),
                std::string::npos)
          << message;
      if (!bad.field.empty()) {
        EXPECT_NE(message.find("field '" + bad.field + "'"), std::string::npos) << message;
      }
      EXPECT_NE(message.find(bad.problem), std::string::npos) << message;
      EXPECT_NE(message.find("Fix: "), std::string::npos) << message;
    }
  }
}

TEST(LoadSite, EmptyAndMissingFilesAreInputErrors) {
  TempDir dir;
  const auto empty = dir.write("empty.yaml", "");
  try {
    (void)load_site(empty);
    ADD_FAILURE() << "no error for an empty file";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(empty.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  }
  const auto missing = dir.path() / "missing.yaml";
  try {
    (void)load_site(missing);
    ADD_FAILURE() << "no error for a missing file";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(missing.string()), std::string::npos) << e.what();
  }
}

TEST(LoadSite, PlaneSurfaceIsOptionalAndVirtualByDefault) {
  TempDir dir;
  // Without the field (a file from before it existed) every plane is virtual.
  const Site old = load_site(dir.write("old.yaml", join(kGoodLines)));
  ASSERT_EQ(old.plane_surfaces.size(), 2u);
  EXPECT_EQ(old.surface_of(0), PlaneSurface::Virtual);
  EXPECT_EQ(old.surface_of(1), PlaneSurface::Virtual);
  EXPECT_EQ(old.surface_of(7), PlaneSurface::Virtual);  // past the end: virtual, as documented

  std::vector<std::string> lines = kGoodLines;
  lines.insert(lines.begin() + 12, "    surface: real");
  lines.push_back("    surface: virtual");
  const Site both = load_site(dir.write("both.yaml", join(lines)));
  EXPECT_EQ(both.surface_of(0), PlaneSurface::Real);
  EXPECT_EQ(both.surface_of(1), PlaneSurface::Virtual);
}

TEST(SiteToYaml, RoundTripsExactly) {
  TempDir dir;
  Site site;
  site.file = dir.path() / "config" / "site.yaml";
  site.model = dir.path() / "config" / ".." / "models" / "a model #1.obj";
  site.root = dir.path();  // written as "..": the model lies beside the site's folder
  site.up = UpAxis::Y;
  site.scale = 0.1 + 0.2;  // not representable in few digits
  site.dome_frequency = 6;
  geom::Plane plane;
  plane.name = "null";  // a YAML keyword: must come back as the name
  plane.origin = geom::Vec3(1.0 / 3.0, -2.5e-7, 1e300);
  plane.u = geom::Vec3(std::nextafter(1.0, 2.0), 0, 0);
  plane.v = geom::Vec3(0, 0.7, 0.7);
  plane.width = 16384;
  plane.height = 1;
  site.planes = {plane};
  plane.name = "second";
  plane.origin = geom::Vec3(0, 0, 0);
  site.planes.push_back(plane);
  site.plane_surfaces = {PlaneSurface::Real};  // the second is left out: virtual
  site.location = GeoLocation{-33.8567844, 151.2152967};

  const auto file = dir.write("config/site.yaml", site_to_yaml(site));
  const Site back = load_site(file);
  EXPECT_EQ(back.file, site.file);
  EXPECT_EQ(back.model, site.model.lexically_normal());
  EXPECT_EQ(back.root, site.root);
  EXPECT_EQ(back.up, site.up);
  EXPECT_EQ(back.scale, site.scale);
  EXPECT_EQ(back.dome_frequency, site.dome_frequency);
  ASSERT_EQ(back.planes.size(), site.planes.size());
  for (std::size_t k = 0; k < site.planes.size(); ++k) {
    EXPECT_EQ(back.planes[k].name, site.planes[k].name);
    EXPECT_EQ(back.planes[k].origin, site.planes[k].origin);
    EXPECT_EQ(back.planes[k].u, site.planes[k].u);
    EXPECT_EQ(back.planes[k].v, site.planes[k].v);
    EXPECT_EQ(back.planes[k].width, site.planes[k].width);
    EXPECT_EQ(back.planes[k].height, site.planes[k].height);
    EXPECT_EQ(back.surface_of(k), site.surface_of(k));
  }
  EXPECT_EQ(back.surface_of(0), PlaneSurface::Real);
  EXPECT_EQ(back.surface_of(1), PlaneSurface::Virtual);
  ASSERT_TRUE(back.location);
  EXPECT_EQ(back.location->latitude_deg, site.location->latitude_deg);
  EXPECT_EQ(back.location->longitude_deg, site.location->longitude_deg);
}

// The writer's quoting once escaped only quotes and backslashes: a newline came back as a space.
TEST(SiteToYaml, AModelPathWithANewlineAColonAndQuotesRoundTrips) {
  TempDir dir;
  Site site = load_site(dir.write("site.yaml", join(kGoodLines)));
  site.model = dir.path() / "models" / "gate: \"east\" \\ wing\n#2\t.glb";
  const Site back = load_site(dir.write("back.yaml", site_to_yaml(site)));
  EXPECT_EQ(back.model, site.model.lexically_normal());
  EXPECT_EQ(back.root, site.root);
  EXPECT_EQ(site_to_yaml(back), site_to_yaml(site));
}

}  // namespace
}  // namespace skylit::scene
