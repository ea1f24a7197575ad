// `dome.basis` in the site file: optional, faces by default, corners on request, anything else
// an error naming the file, line, field and fix.
#include <gtest/gtest.h>

#include <string>

#include "skylit/base/error.hpp"
#include "skylit/scene/site.hpp"
#include "../support/temp_dir.hpp"

namespace skylit::scene {
namespace {

using skylit::test::TempDir;

// The site with `dome_lines` under "dome:" (or, with flow = true, `dome_lines` as the section).
std::string site_with_dome(const std::string& dome_lines, bool flow = false) {
  return "scene:\n  model: models/gate.glb\n  up: z\n" + std::string(flow ? "" : "dome:\n") + dome_lines +
         "planes:\n  - name: ground\n    origin: [-10, -10, 0.01]\n    u: [20, 0, 0]\n    v: [0, 20, 0]\n"
         "    resolution: [64, 64]\n";
}

std::string error_of(const std::filesystem::path& file) {
  try {
    load_site(file);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(SiteBasis, FacesByDefaultCornersOnRequest) {
  TempDir dir;
  EXPECT_EQ(load_site(dir.write("a.yaml", site_with_dome("  frequency: 2\n"))).dome_basis, geom::DomeBasis::Faces);
  EXPECT_EQ(load_site(dir.write("b.yaml", site_with_dome("  frequency: 2\n  basis: faces\n"))).dome_basis,
            geom::DomeBasis::Faces);
  const Site corners = load_site(dir.write("c.yaml", site_with_dome("  basis: corners\n  frequency: 4\n")));
  EXPECT_EQ(corners.dome_basis, geom::DomeBasis::Corners);
  EXPECT_EQ(corners.dome_frequency, 4);
  EXPECT_EQ(load_site(dir.write("d.yaml", site_with_dome("dome: {frequency: 2, basis: corners}\n", true))).dome_basis,
            geom::DomeBasis::Corners);
}

TEST(SiteBasis, AnUnknownBasisNamesTheFieldAndTheChoices) {
  TempDir dir;
  for (const char* bad : {"  basis: vertices\n", "  basis: [faces]\n", "  basis:\n", "  basis: Corners\n"}) {
    const std::string message = error_of(dir.write("bad.yaml", site_with_dome(std::string("  frequency: 2\n") + bad)));
    EXPECT_NE(message.find("bad.yaml:6"), std::string::npos) << message;
    EXPECT_NE(message.find("dome.basis"), std::string::npos) << message;
    EXPECT_NE(message.find("basis: corners"), std::string::npos) << message;
    EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
  }
  const std::string typo = error_of(dir.write("typo.yaml", site_with_dome("  frequency: 2\n  bases: corners\n")));
  EXPECT_NE(typo.find("dome.bases"), std::string::npos) << typo;
  EXPECT_NE(typo.find("basis"), std::string::npos) << typo;  // the fix suggests the right name
}

TEST(SiteBasis, WrittenBackOnlyWhenNotTheDefault) {
  TempDir dir;
  Site site = load_site(dir.write("s.yaml", site_with_dome("  frequency: 2\n")));
  EXPECT_EQ(site_to_yaml(site).find("basis"), std::string::npos);  // sites without it stay as they were
  site.dome_basis = geom::DomeBasis::Corners;
  const std::string yaml = site_to_yaml(site);
  EXPECT_NE(yaml.find("basis: corners"), std::string::npos) << yaml;
  EXPECT_EQ(load_site(dir.write("back.yaml", yaml)).dome_basis, geom::DomeBasis::Corners);
}

}  // namespace
}  // namespace skylit::scene
