#pragma once
// The small scene several suites bake: a 2 m cube standing on the ground (box.obj), in a fresh
// directory of the suite's own, with a site file whose dome and planes each suite gives.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

namespace skylit::test {

// A new directory under the system temp dir, unique to this process and moment (for suites that
// keep one across their tests; removed by the caller).
inline std::filesystem::path make_suite_dir(const std::string& prefix) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      (prefix + "-" + std::to_string(::getpid()) + "-" +
       std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  std::filesystem::create_directories(dir);
  return dir;
}

// dir/box.obj (the cube, x and y in [-1, 1], z in [0, 2]) and dir/site.yaml with
// `dome_and_planes` (the YAML of the site's dome: and planes: sections) after its scene.
inline void write_box_site(const std::filesystem::path& dir, const std::string& dome_and_planes) {
  std::ofstream(dir / "box.obj") << "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                                    "v -1 -1 2\nv 1 -1 2\nv 1 1 2\nv -1 1 2\n"
                                    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
  std::ofstream(dir / "site.yaml") << "scene:\n  model: box.obj\n  up: z\n  scale: 1\n" << dome_and_planes;
}

}  // namespace skylit::test
