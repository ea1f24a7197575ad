#pragma once
// The small scene several suites bake: a 2 m cube standing on the ground (box.obj), in a fresh
// directory of the suite's own (a TempDir, which this brings), with a site file whose dome and
// planes each suite gives.
#include <filesystem>
#include <fstream>
#include <string>

#include "temp_dir.hpp"

namespace skylit::test {

// dir/box.obj (the cube, x and y in [-1, 1], z in [0, 2]) and dir/site.yaml with
// `dome_and_planes` (the YAML of the site's dome: and planes: sections) after its scene.
inline void write_box_site(const std::filesystem::path& dir, const std::string& dome_and_planes) {
  std::ofstream(dir / "box.obj") << "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                                    "v -1 -1 2\nv 1 -1 2\nv 1 1 2\nv -1 1 2\n"
                                    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
  std::ofstream(dir / "site.yaml") << "scene:\n  model: box.obj\n  up: z\n  scale: 1\n" << dome_and_planes;
}

}  // namespace skylit::test
