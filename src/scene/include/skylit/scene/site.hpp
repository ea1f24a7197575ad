#pragma once
// The site description: a YAML file (the schema is a contract, see docs/site-format.md).
//
//   scene:  {model: models/gate.glb, up: z|y, scale: 1.0}
//   dome:   {frequency: 2}
//   planes: [{name, origin: [x,y,z], u: [..], v: [..], resolution: [W, H]}, ...]
#include <filesystem>
#include <string>
#include <vector>

#include "skylit/geom/plane.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::scene {

inline constexpr int kMaxPlaneResolution = 16384;

struct Site {
  std::filesystem::path file;    // the YAML it came from
  std::filesystem::path model;   // resolved against the YAML's directory
  UpAxis up = UpAxis::Z;         // default z for OBJ, y for glTF when `up` is absent
  double scale = 1.0;
  int dome_frequency = 2;
  std::vector<geom::Plane> planes;
};

// Parses and validates a site file. Any problem (missing or mistyped field, unknown field, odd
// or zero frequency, resolution 0 or over 16384, degenerate or non-finite plane, duplicate plane
// names) throws InputError with file, line, column, field and fix. The model is not loaded.
Site load_site(const std::filesystem::path& file);

// Writes a site back as YAML (for tools and tests that produce sites).
std::string site_to_yaml(const Site& site);

}  // namespace skylit::scene
