// skylit-bake verify: every check a reader relies on, reported as a list instead of thrown.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/parts.hpp"
#include "skylit/bake_format/pca.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit::bake_format {
namespace {

namespace fs = std::filesystem;

constexpr const char* kRestore = "Fix: re-bake, or restore the file";
constexpr const char* kRebake = "Fix: re-bake with skylit-bake";

std::string shape_words(std::span<const std::size_t> shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + ")";
}

// A manifest path must stay inside the bake directory.
bool safe_relative(const std::string& path) {
  const fs::path p(path);
  if (path.empty() || p.is_absolute() || p.has_root_name()) return false;
  for (const fs::path& part : p) {
    if (part == "..") return false;
  }
  return true;
}

class Checker {
 public:
  Checker(const fs::path& dir, VerifyReport& report) : dir_(dir), report_(report) {}

  void problem(std::string line) { report_.problems.push_back(std::move(line)); }

  void check_dome(const Manifest& m) {
    const std::size_t n = m.faces.size();
    const std::size_t expected = 10 * static_cast<std::size_t>(m.plan.frequency) * m.plan.frequency;
    if (n != expected) {
      problem("manifest.json: the dome has " + std::to_string(n) + " faces, but frequency ν=" +
              std::to_string(m.plan.frequency) + " needs 10·ν² = " + std::to_string(expected) + ". " + kRebake);
    }
    double total = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const FaceRecord& f = m.faces[i];
      const std::string label = "manifest.json: dome face " + std::to_string(i);
      if (f.index != static_cast<int>(i)) {
        problem(label + " has index " + std::to_string(f.index) + ". " + kRebake);
      }
      if (!std::isfinite(f.solid_angle) || f.solid_angle <= 0.0) {
        problem(label + " has solid angle " + std::to_string(f.solid_angle) + " sr (must be positive). " + kRebake);
      }
      for (int neighbour : f.neighbours) {
        if (neighbour < -1 || neighbour >= static_cast<int>(n)) {
          problem(label + " names neighbour " + std::to_string(neighbour) + ", not a face. " + kRebake);
        }
      }
      total += f.solid_angle;
    }
    // The dome tiles the upper hemisphere exactly: Σ Ω_i = 2π.
    if (n == expected && n > 0 && std::abs(total - 2.0 * std::numbers::pi) > 1e-6 * 2.0 * std::numbers::pi) {
      problem("manifest.json: the face solid angles sum to " + std::to_string(total) +
              " sr, not 2π (the hemisphere). " + kRebake);
    }
  }

  void check_planes(const Manifest& m) {
    if (m.planes.size() != m.plan.planes.size()) {
      problem("manifest.json: " + std::to_string(m.planes.size()) + " plane records but the plan has " +
              std::to_string(m.plan.planes.size()) + " planes. " + kRebake);
    }
    std::set<std::string> names;
    for (std::size_t j = 0; j < m.planes.size(); ++j) {
      const PlaneRecord& r = m.planes[j];
      const std::string label = "manifest.json: plane '" + r.plane.name + "'";
      if (!names.insert(r.plane.name).second) problem(label + " appears twice. " + kRebake);
      if (j < m.plan.planes.size()) {
        const geom::Plane& p = m.plan.planes[j];
        if (p.name != r.plane.name || p.width != r.plane.width || p.height != r.plane.height) {
          problem(label + " (" + std::to_string(r.plane.width) + "x" + std::to_string(r.plane.height) +
                  ") differs from the plan's plane " + std::to_string(j) + " '" + p.name + "' (" +
                  std::to_string(p.width) + "x" + std::to_string(p.height) + "). " + kRebake);
        }
      }
      const std::size_t per_face = static_cast<std::size_t>(m.plan.layers_per_face());
      if (r.unoccluded.size() != m.layer_count()) {
        problem(label + " has " + std::to_string(r.unoccluded.size()) + " unoccluded values for " +
                std::to_string(m.faces.size()) + " faces" +
                (per_face == 1 ? std::string()
                               : " × " + std::to_string(per_face) + " " + std::string(geom::basis_name(m.plan.basis)) +
                                     " functions") + ". " + kRebake);
      }
      for (std::size_t i = 0; i < r.unoccluded.size(); ++i) {
        const double a = r.unoccluded[i];
        // 0 ≤ A_l ≤ Ω_i because 0 ≤ λ · max(0, n·ω) ≤ 1 (layer l of face i = l / per_face).
        const std::size_t face = i / per_face;
        const bool bounded = face >= m.faces.size() || a <= m.faces[face].solid_angle * (1.0 + 1e-9) + 1e-12;
        if (!std::isfinite(a) || a < 0.0 || !bounded) {
          problem(label + " unoccluded[" + std::to_string(i) + "] = " + std::to_string(a) +
                  " sr is not in [0, Ω_i]. " + kRebake);
          break;  // one line per plane is enough
        }
      }
      if (!safe_relative(r.file)) {
        problem(label + " file '" + r.file + "' is not a path inside the bake directory. " + kRebake);
      }
    }
  }

  // Presence, size and SHA-256 of every listed file; returns the paths that are present.
  std::set<std::string> check_files(const Manifest& m) {
    std::set<std::string> present;
    std::set<std::string> listed;
    for (const FileRecord& f : m.files) {
      if (!listed.insert(f.path).second) {
        problem("manifest.json: '" + f.path + "' is listed twice. " + kRebake);
        continue;
      }
      if (!safe_relative(f.path)) {
        problem("manifest.json: file '" + f.path + "' is not a path inside the bake directory. " + kRebake);
        continue;
      }
      const fs::path file = dir_ / f.path;
      std::error_code error;
      if (!fs::is_regular_file(file, error)) {
        problem(f.path + ": missing. " + kRestore);
        continue;
      }
      const std::uintmax_t size = fs::file_size(file, error);
      if (error) {
        problem(f.path + ": cannot be read (" + error.message() + "). " + kRestore);
        continue;
      }
      present.insert(f.path);
      if (size != f.size) {
        problem(f.path + ": " + std::to_string(size) + " bytes, the manifest says " + std::to_string(f.size) +
                (size < f.size ? " (truncated). " : " (file changed). ") + kRestore);
        continue;
      }
      try {
        if (sha256_file(file) != f.sha256) {
          problem(f.path + ": SHA-256 differs from the manifest (file changed or corrupt). " + kRestore);
        }
      } catch (const InputError& e) {
        problem(f.path + ": cannot be hashed (" + e.what() + "). " + kRestore);
      }
    }
    const auto require_listed = [&](const std::string& path, const std::string& what) {
      if (!listed.count(path)) {
        problem("manifest.json: the " + what + " '" + path + "' is not in the list of hashed files. " + kRebake);
      }
    };
    for (const PlaneRecord& r : m.planes) {
      require_listed(r.file, "image of plane '" + r.plane.name + "'");
      if (r.pca) {
        require_listed(r.pca->file, "PCA image of plane '" + r.plane.name + "'");
        require_listed(r.pca->coefficients, "PCA coefficients of plane '" + r.plane.name + "'");
      }
    }
    require_listed(m.transfer_file, "transfer array");
    require_listed(m.vertices_file, "vertex array");
    if (m.ground) require_listed(m.ground->file, "ground transfer array");
    if (m.light_map) {
      require_listed(m.light_map->charts_file, "light map charts");
      require_listed(m.light_map->triangles_file, "light map triangles");
      require_listed(m.light_map->texels_file, "light map texels");
      if (m.light_map->has_full_form()) require_listed(m.light_map->transfer_file, "light map transfer array");
      if (!m.light_map->ground_file.empty()) require_listed(m.light_map->ground_file, "light map ground transfer array");
      if (const auto& pca = m.light_map->pca) {
        require_listed(pca->weights_file, "light map PCA weights");
        require_listed(pca->vectors_file, "light map PCA vectors");
        if (!pca->ground_weights_file.empty()) {
          require_listed(pca->ground_weights_file, "light map PCA ground weights");
          require_listed(pca->ground_vectors_file, "light map PCA ground vectors");
        }
      }
    }
    return present;
  }

  void check_images(const Manifest& m, const std::set<std::string>& present) {
    for (const PlaneRecord& r : m.planes) {
      if (!present.count(r.file)) continue;  // already reported
      try {
        const ExrInfo info = read_exr_info(dir_ / r.file);
        if (info.width != r.plane.width || info.height != r.plane.height) {
          problem(r.file + ": image is " + std::to_string(info.width) + "x" + std::to_string(info.height) +
                  ", the manifest says " + std::to_string(r.plane.width) + "x" + std::to_string(r.plane.height) +
                  ". " + kRestore);
        }
        if (info.layer_names.size() != m.layer_count()) {
          problem(r.file + ": " + std::to_string(info.layer_names.size()) + " layers, the dome has " +
                  std::to_string(m.faces.size()) + " faces" +
                  (m.plan.layers_per_face() == 1
                       ? std::string()
                       : " and the " + std::string(geom::basis_name(m.plan.basis)) + " basis " +
                             std::to_string(m.plan.layers_per_face()) + " layers per face (" +
                             std::to_string(m.layer_count()) + ")") +
                  ". " + kRestore);
        } else {
          for (std::size_t i = 0; i < info.layer_names.size(); ++i) {
            const std::string expected = layer_name(m.plan.basis, static_cast<int>(i));
            if (info.layer_names[i] != expected) {
              problem(r.file + ": layer " + std::to_string(i) + " is named '" + info.layer_names[i] +
                      "', expected '" + expected + "'. " + kRestore);
              break;
            }
          }
        }
      } catch (const InputError& e) {
        problem(e.what());
      }
    }
  }

  // The PCA form beside a plane: K + 1 layers named as pca_layer_names, coefficients [n, K]
  // ([tiles, n, K] for clustered PCA).
  void check_pca(const Manifest& m, const std::set<std::string>& present) {
    for (const PlaneRecord& r : m.planes) {
      if (!r.pca) continue;
      const std::string label = "manifest.json: plane '" + r.plane.name + "' pca";
      if (!safe_relative(r.pca->file) || !safe_relative(r.pca->coefficients)) {
        problem(label + " names a file outside the bake directory. " + kRebake);
        continue;
      }
      if (r.pca->components < 0) problem(label + ".components is negative. " + kRebake);
      const std::vector<std::string> names = pca_layer_names(std::max(r.pca->components, 0));
      if (present.count(r.pca->file)) {
        try {
          const ExrInfo info = read_exr_info(dir_ / r.pca->file);
          if (info.width != r.plane.width || info.height != r.plane.height || info.layer_names != names) {
            problem(r.pca->file + ": " + std::to_string(info.width) + "x" + std::to_string(info.height) + " with " +
                    std::to_string(info.layer_names.size()) + " layers, the manifest says " +
                    std::to_string(r.plane.width) + "x" + std::to_string(r.plane.height) + " with " +
                    std::to_string(names.size()) + " (mean, pc_001 … ). " + kRestore);
          }
        } catch (const InputError& e) {
          problem(e.what());
        }
      }
      if (r.pca->tile == 1) problem(label + ".tile is 1; a tile holds at least 2 × 2 texels. " + kRebake);
      const auto components = static_cast<std::size_t>(std::max(r.pca->components, 0));
      if (r.pca->tile > 0) {
        const auto tiles = static_cast<std::size_t>(r.pca->tiles_x(r.plane.width)) *
                           static_cast<std::size_t>(r.pca->tiles_y(r.plane.height));
        check_array(r.pca->coefficients, {tiles, m.layer_count(), components}, "(tiles × layers × components)", present);
      } else {
        check_array(r.pca->coefficients, {m.layer_count(), components}, "(layers × components)", present);
      }
    }
  }

  void check_array(const std::string& path, const std::vector<std::size_t>& expected, const std::string& meaning,
                   const std::set<std::string>& present, const std::string& descr = "<f4") {
    if (!present.count(path)) return;
    try {
      const NpyInfo info = read_npy_info(dir_ / path);
      if (info.descr != descr) {
        problem(path + ": elements of type '" + info.descr + "', expected '" + descr + "'. " + kRestore);
      } else if (info.shape != expected) {
        problem(path + ": shape " + shape_words(info.shape) + ", expected " + shape_words(expected) + " " + meaning +
                ". " + kRestore);
      }
    } catch (const InputError& e) {
      problem(e.what());
    }
  }

  void check_parts_dir() {
    const fs::path parts = dir_ / "parts";
    std::error_code error;
    if (!fs::is_directory(parts, error)) {
      problem("manifest.json: missing, so '" + dir_.string() +
              "' is not a finished bake. Fix: run skylit-bake SITE -o DIR, or point to the directory it wrote");
      return;
    }
    std::size_t count = 0;
    for (const fs::directory_entry& e : fs::directory_iterator(parts, error)) {
      const std::string name = e.path().filename().string();
      if (name.starts_with("face_") && e.path().extension() == ".part") ++count;
    }
    std::string of;
    try {
      if (const std::optional<Plan> plan = PartStore(parts).read_plan()) {
        of = " of " + std::to_string(10 * plan->frequency * plan->frequency);
      }
    } catch (const InputError&) {
      // The count alone still tells the user what happened.
    }
    problem("manifest.json: missing — the bake is incomplete (" + std::to_string(count) + of +
            " face parts in parts/). Fix: rerun skylit-bake with --resume, or merge the shards "
            "(skylit-bake merge DIR... -o OUT)");
  }

 private:
  const fs::path& dir_;
  VerifyReport& report_;
};

}  // namespace

VerifyReport verify(const fs::path& bake_dir) {
  VerifyReport report;
  Checker check(bake_dir, report);
  std::error_code error;
  if (!fs::is_directory(bake_dir, error)) {
    check.problem(bake_dir.string() + ": no such directory. Fix: name the directory that skylit-bake wrote");
    return report;
  }
  if (!fs::exists(bake_dir / "manifest.json", error)) {
    check.check_parts_dir();
    return report;
  }
  try {
    report.manifest = read_manifest(bake_dir);
  } catch (const InputError& e) {
    check.problem(e.what());
    return report;
  }
  const Manifest& m = report.manifest;
  check.check_dome(m);
  check.check_planes(m);
  const std::set<std::string> present = check.check_files(m);
  check.check_images(m, present);
  check.check_pca(m, present);
  const std::size_t vertices = static_cast<std::size_t>(m.plan.vertex_count);
  check.check_array(m.transfer_file, {vertices, m.layer_count()},
                    m.plan.layers_per_face() == 1
                        ? "(vertex_count, face_count)"
                        : "(vertex_count, " + std::to_string(m.plan.layers_per_face()) + " × face_count)",
                    present);
  check.check_array(m.vertices_file, {vertices, 6}, "(vertex_count, 6: position, normal)", present);
  if (m.ground) {
    check.check_array(m.ground->file, {vertices, m.layer_count()}, "(vertex_count, layer_count)", present);
    for (std::size_t l = 0; l < m.ground->horizontal_unoccluded.size(); ++l) {
      const double a = m.ground->horizontal_unoccluded[l];
      if (!std::isfinite(a) || a < 0.0) {
        check.problem("manifest.json: ground.horizontal_unoccluded[" + std::to_string(l) + "] is " + std::to_string(a) +
                      ", not a finite solid angle ≥ 0. Fix: re-bake");
      }
    }
  }
  if (m.refinement) {
    check.check_array(m.refinement->file, {static_cast<std::size_t>(m.refinement->edge_count()), 2},
                      "(edges split, 2: their vertices)", present, "<u4");
  }
  if (m.light_map) {
    const auto texels = static_cast<std::size_t>(m.plan.light_map.texels);
    check.check_array(m.light_map->charts_file, {static_cast<std::size_t>(m.light_map->chart_count), 15},
                      "(charts, 15: x, y, width, height, origin, u, v, texel_u, texel_v)", present);
    check.check_array(m.light_map->triangles_file, {static_cast<std::size_t>(m.plan.triangle_count)}, "(triangle_count)", present, "<u4");
    check.check_array(m.light_map->texels_file, {texels}, "(light map texels)", present, "<u4");
    if (m.light_map->has_full_form()) {
      check.check_array(m.light_map->transfer_file, {texels, m.layer_count()}, "(light map texels, layer_count)", present);
    }
    if (!m.light_map->ground_file.empty()) {
      check.check_array(m.light_map->ground_file, {texels, m.layer_count()}, "(light map texels, layer_count)", present);
    }
  }
  report.ok = report.problems.empty();
  return report;
}

}  // namespace skylit::bake_format
