// basis_study: which representation of the sky's radiance over the dome leaves the least error
// in T, with everything else exact.
//
// In one discrete world (the sky as N equirectangular pixels above the horizon, visibility of
// every texel towards every pixel ray-cast once with Embree), the exact shadow ratio is
//     T(x) = Σ_p L_p Ω_p c_p(x) V(x, p) / Σ_p L_p Ω_p c_p,      c_p = max(0, n·ω_p)
// and a basis {φ_k} over the dome approximates L(ω) ≈ Σ_k S_k φ_k(ω), giving
//     T(x) ≈ Σ_k S_k B_k(x) / Σ_k S_k A_k,   B_k = Σ_p φ_k(p) Ω_p c_p V(x,p),  A_k likewise with V = 1.
// Compared: the paper's piecewise-constant faces (φ = indicator, S = mean over the face), and
// piecewise-linear hats on the dome's vertices (φ = barycentric weight within the face) with S
// the hat-weighted mean (positive, total energy preserved) or the L2 projection (mass matrix),
// their discontinuous per-face form (three hats per face), and per-face quadratics (the six
// quadratic Bernstein polynomials of the barycentric coordinates, L2 projection).
// The sun (pixels near a peak over 100× the median) is optionally taken out and added exactly,
// as the sun separation does. Visibility sampling, the fisheye and the half-float storage are
// left out on purpose: what remains is the basis alone.
//
//     basis_study [--skies data/hdri] [--site config/sample_site.yaml] [--texel-scale 8]
//                 [--sky-width 256] [--frequencies 2,4]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "skylit/baker/visibility.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"

namespace {

namespace fs = std::filesystem;
using skylit::geom::Vec3;

// Up to six (basis index, weight) pairs per sky pixel.
constexpr int kMaxMembers = 6;
struct Membership {
  std::array<int, kMaxMembers> index{-1, -1, -1, -1, -1, -1};
  std::array<double, kMaxMembers> weight{0, 0, 0, 0, 0, 0};
};

struct Basis {
  std::string name;
  int count = 0;
  std::vector<Membership> of_pixel;
  bool l2 = false;  // coefficients by L2 projection instead of the φ-weighted mean
};

// Barycentric coordinates of `d` in the flat triangle (a, b, c) along the ray: the gnomonic
// projection, so a direction on an edge has weight only on that edge's two vertices.
std::array<double, 3> barycentric(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  Eigen::Matrix3d m;
  m.col(0) = a;
  m.col(1) = b;
  m.col(2) = c;
  Eigen::Vector3d l = m.colPivHouseholderQr().solve(d);
  for (int k = 0; k < 3; ++k) l[k] = std::max(0.0, l[k]);
  const double sum = l.sum();
  return {l[0] / sum, l[1] / sum, l[2] / sum};
}

// The barycentric coordinates of `d` in face `face`'s flat triangle.
std::array<double, 3> face_barycentric(const skylit::geom::Dome& dome, int face, const Vec3& d) {
  const auto& f = dome.face(face);
  const auto& vs = dome.vertices();
  return barycentric(vs[f.vertex[0]], vs[f.vertex[1]], vs[f.vertex[2]], d);
}

Basis face_basis(const skylit::geom::Dome& dome, const std::vector<Vec3>& dirs) {
  Basis b{"faces ν=" + std::to_string(dome.frequency()), dome.face_count(), {}, false};
  for (const Vec3& d : dirs) {
    Membership m;
    m.index[0] = dome.face_of(d);
    m.weight[0] = 1.0;
    b.of_pixel.push_back(m);
  }
  return b;
}

Basis vertex_basis(const skylit::geom::Dome& dome, const std::vector<Vec3>& dirs, bool l2) {
  std::map<int, int> compact;  // dome vertex → basis index (vertices of upper faces only)
  for (const auto& f : dome.faces()) {
    for (int v : f.vertex) compact.emplace(v, 0);
  }
  int n = 0;
  for (auto& [v, k] : compact) k = n++;
  Basis b{std::string(l2 ? "vertices (L2) ν=" : "vertices ν=") + std::to_string(dome.frequency()), n, {}, l2};
  for (const Vec3& d : dirs) {
    const auto& f = dome.face(dome.face_of(d));
    const auto& vs = dome.vertices();
    const auto w = barycentric(vs[f.vertex[0]], vs[f.vertex[1]], vs[f.vertex[2]], d);
    Membership m;
    for (int k = 0; k < 3; ++k) {
      m.index[k] = compact.at(f.vertex[k]);
      m.weight[k] = w[k];
    }
    b.of_pixel.push_back(m);
  }
  return b;
}

// Discontinuous piecewise-linear: three hats per face, zero outside it (3 × faces coefficients,
// L2 projection decouples into one 3×3 system per face).
Basis corner_basis(const skylit::geom::Dome& dome, const std::vector<Vec3>& dirs) {
  Basis b{"face corners ν=" + std::to_string(dome.frequency()), 3 * dome.face_count(), {}, true};
  for (const Vec3& d : dirs) {
    const int face = dome.face_of(d);
    const auto w = face_barycentric(dome, face, d);
    Membership m;
    for (int k = 0; k < 3; ++k) {
      m.index[k] = 3 * face + k;
      m.weight[k] = w[k];
    }
    b.of_pixel.push_back(m);
  }
  return b;
}

// Discontinuous piecewise-quadratic: per face the six quadratic Bernstein polynomials of the
// barycentric coordinates (λ_a², λ_b², λ_c², 2λ_aλ_b, 2λ_bλ_c, 2λ_cλ_a: non-negative, summing to
// 1), zero outside the face; coefficients by L2 projection.
Basis quadratic_basis(const skylit::geom::Dome& dome, const std::vector<Vec3>& dirs) {
  Basis b{"face quadratics ν=" + std::to_string(dome.frequency()), 6 * dome.face_count(), {}, true};
  for (const Vec3& d : dirs) {
    const int face = dome.face_of(d);
    const auto w = face_barycentric(dome, face, d);
    Membership m;
    for (int k = 0; k < 3; ++k) {
      m.index[k] = 6 * face + k;
      m.weight[k] = w[k] * w[k];
      m.index[3 + k] = 6 * face + 3 + k;
      m.weight[3 + k] = 2.0 * w[k] * w[(k + 1) % 3];
    }
    b.of_pixel.push_back(m);
  }
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"basis_study: faces, vertex hats, per-face linear hats and per-face quadratics, all else exact"};
  std::string skies_dir = "data/hdri", site_file = "config/sample_site.yaml", only_sky;
  int texel_scale = 8, sky_width = 256;
  std::vector<int> frequencies{2, 4};
  app.add_option("--skies", skies_dir)->capture_default_str();
  app.add_option("--site", site_file)->capture_default_str();
  app.add_option("--texel-scale", texel_scale)->capture_default_str();
  app.add_option("--sky-width", sky_width, "equirect width the skies are reduced to")->capture_default_str();
  app.add_option("--frequencies", frequencies)->delimiter(',');
  app.add_option("--sky", only_sky, "only this sky (file stem)");
  CLI11_PARSE(app, argc, argv);

  skylit::scene::Site site = skylit::scene::load_site(site_file);
  for (auto& p : site.planes) {
    p.width = std::max(4, p.width / texel_scale);
    p.height = std::max(4, p.height / texel_scale);
  }
  const skylit::scene::Mesh mesh = skylit::scene::load_site_model(site);
  const int sky_height = sky_width / 2;

  // Sky pixels above the horizon.
  std::vector<Vec3> dirs;
  std::vector<double> omega;
  std::vector<std::pair<int, int>> pixel;
  for (int row = 0; row < sky_height; ++row) {
    for (int col = 0; col < sky_width; ++col) {
      const Vec3 d = skylit::sky::equirect_direction(sky_width, sky_height, col, row);
      if (d.z() <= 0.0) continue;
      dirs.push_back(d);
      omega.push_back(skylit::sky::equirect_pixel_solid_angle(sky_width, sky_height, row));
      pixel.emplace_back(row, col);
    }
  }
  const std::size_t n_dirs = dirs.size();

  // Visibility of every texel towards every pixel, once.
  auto engine = skylit::baker::make_raytrace_engine(mesh, site.planes, {});
  std::vector<std::vector<std::uint8_t>> visible(site.planes.size());
  std::vector<std::size_t> texels(site.planes.size());
  for (std::size_t j = 0; j < site.planes.size(); ++j) {
    texels[j] = static_cast<std::size_t>(site.planes[j].width) * site.planes[j].height;
    visible[j].resize(texels[j] * n_dirs);
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<float> f;
  for (std::size_t p = 0; p < n_dirs; ++p) {
    engine->set_directions(std::span<const Vec3>(&dirs[p], 1));
    for (std::size_t j = 0; j < site.planes.size(); ++j) {
      f.assign(texels[j], 0.0f);
      engine->plane_fractions(static_cast<int>(j), f);
      for (std::size_t x = 0; x < texels[j]; ++x) visible[j][x * n_dirs + p] = f[x] > 0.5f ? 1 : 0;
    }
  }
  std::fprintf(stderr, "visibility: %zu directions × %zu planes in %.1f s\n", n_dirs, site.planes.size(),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());

  std::vector<Basis> bases;
  for (int nu : frequencies) {
    const skylit::geom::Dome dome(nu);
    bases.push_back(face_basis(dome, dirs));
    bases.push_back(vertex_basis(dome, dirs, false));
    bases.push_back(vertex_basis(dome, dirs, true));
    bases.push_back(corner_basis(dome, dirs));
    bases.push_back(quadratic_basis(dome, dirs));
  }

  // Per basis and plane: B_k(x) and A_k (radiance-independent).
  struct Baked {
    std::vector<std::vector<double>> B;  // [plane][x * count + k]
    std::vector<std::vector<double>> A;  // [plane][k]
  };
  std::vector<Baked> baked(bases.size());
  for (std::size_t b = 0; b < bases.size(); ++b) {
    const Basis& basis = bases[b];
    for (std::size_t j = 0; j < site.planes.size(); ++j) {
      const Vec3 n = site.planes[j].normal();
      std::vector<double> B(texels[j] * static_cast<std::size_t>(basis.count), 0.0);
      std::vector<double> A(static_cast<std::size_t>(basis.count), 0.0);
      for (std::size_t p = 0; p < n_dirs; ++p) {
        const double c = std::max(0.0, n.dot(dirs[p])) * omega[p];
        if (c == 0.0) continue;
        const Membership& m = basis.of_pixel[p];
        for (int k = 0; k < kMaxMembers && m.index[k] >= 0; ++k) A[static_cast<std::size_t>(m.index[k])] += m.weight[k] * c;
        for (std::size_t x = 0; x < texels[j]; ++x) {
          if (!visible[j][x * n_dirs + p]) continue;
          for (int k = 0; k < kMaxMembers && m.index[k] >= 0; ++k) {
            B[x * static_cast<std::size_t>(basis.count) + static_cast<std::size_t>(m.index[k])] += m.weight[k] * c;
          }
        }
      }
      baked[b].B.push_back(std::move(B));
      baked[b].A.push_back(std::move(A));
    }
  }

  std::vector<fs::path> skies;
  for (const auto& entry : fs::directory_iterator(skies_dir)) {
    if (entry.path().extension() == ".exr" && (only_sky.empty() || entry.path().stem() == only_sky)) skies.push_back(entry.path());
  }
  std::sort(skies.begin(), skies.end());

  std::printf("| sky | sun | basis | coefficients | RMS | max |\n|---|---|---|---|---|---|\n");
  for (const fs::path& sky_file : skies) {
    cv::Mat full = skylit::sky::read_sky_image(sky_file), sky;
    for (int row = 0; row < full.rows; ++row) {
      for (auto* v = full.ptr<float>(row), *end = v + 3 * full.cols; v != end; ++v) *v = std::isfinite(*v) && *v > 0 ? *v : 0.0f;
    }
    cv::resize(full, sky, cv::Size(sky_width, sky_height), 0, 0, cv::INTER_AREA);
    std::vector<Eigen::Vector3d> L(n_dirs);
    std::vector<double> lum(n_dirs);
    for (std::size_t p = 0; p < n_dirs; ++p) {
      const cv::Vec3f& v = sky.at<cv::Vec3f>(pixel[p].first, pixel[p].second);
      L[p] = Eigen::Vector3d(v[2], v[1], v[0]);
      lum[p] = L[p].dot(Eigen::Vector3d(0.2126, 0.7152, 0.0722));
    }
    // The sun: pixels within 4° of the brightest when it outshines the median 100×.
    std::vector<double> sorted = lum;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(n_dirs / 2), sorted.end());
    const double median = sorted[n_dirs / 2];
    const std::size_t peak = static_cast<std::size_t>(std::max_element(lum.begin(), lum.end()) - lum.begin());
    std::vector<char> is_sun(n_dirs, 0);
    const bool sun_found = lum[peak] > 100.0 * median;
    if (sun_found) {
      for (std::size_t p = 0; p < n_dirs; ++p) is_sun[p] = dirs[p].dot(dirs[peak]) > std::cos(4.0 * M_PI / 180.0);
    }

    // Exact T per plane, texel, channel.
    std::vector<std::vector<Eigen::Vector3d>> ref(site.planes.size());
    for (std::size_t j = 0; j < site.planes.size(); ++j) {
      const Vec3 n = site.planes[j].normal();
      Eigen::Vector3d total = Eigen::Vector3d::Zero();
      ref[j].assign(texels[j], Eigen::Vector3d::Zero());
      for (std::size_t p = 0; p < n_dirs; ++p) {
        const double c = std::max(0.0, n.dot(dirs[p])) * omega[p];
        if (c == 0.0) continue;
        total += c * L[p];
        for (std::size_t x = 0; x < texels[j]; ++x) {
          if (visible[j][x * n_dirs + p]) ref[j][x] += c * L[p];
        }
      }
      for (auto& r : ref[j]) {
        for (int ch = 0; ch < 3; ++ch) r[ch] = total[ch] > 0 ? r[ch] / total[ch] : 1.0;
      }
    }

    for (int separate = 0; separate <= (sun_found ? 1 : 0); ++separate) {
      for (std::size_t b = 0; b < bases.size(); ++b) {
        const Basis& basis = bases[b];
        const auto count = static_cast<std::size_t>(basis.count);
        // Coefficients S_k from the sky without its sun (when separated).
        std::vector<Eigen::Vector3d> num(count, Eigen::Vector3d::Zero());
        std::vector<double> den(count, 0.0);
        Eigen::MatrixXd mass = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(count), static_cast<Eigen::Index>(count));
        for (std::size_t p = 0; p < n_dirs; ++p) {
          const Membership& m = basis.of_pixel[p];
          const Eigen::Vector3d l = separate && is_sun[p] ? Eigen::Vector3d::Zero() : L[p];
          for (int k = 0; k < kMaxMembers && m.index[k] >= 0; ++k) {
            const auto i = static_cast<std::size_t>(m.index[k]);
            num[i] += m.weight[k] * omega[p] * l;
            den[i] += m.weight[k] * omega[p];
            for (int q = 0; q < kMaxMembers && m.index[q] >= 0; ++q) mass(m.index[k], m.index[q]) += m.weight[k] * m.weight[q] * omega[p];
          }
        }
        std::vector<Eigen::Vector3d> S(count, Eigen::Vector3d::Zero());
        if (basis.l2) {
          Eigen::MatrixXd rhs(static_cast<Eigen::Index>(count), 3);
          for (std::size_t i = 0; i < count; ++i) rhs.row(static_cast<Eigen::Index>(i)) = num[i].transpose();
          const Eigen::MatrixXd s = mass.ldlt().solve(rhs);
          for (std::size_t i = 0; i < count; ++i) S[i] = s.row(static_cast<Eigen::Index>(i)).transpose();
        } else {
          for (std::size_t i = 0; i < count; ++i) S[i] = den[i] > 0 ? Eigen::Vector3d(num[i] / den[i]) : Eigen::Vector3d::Zero();
        }
        double sum_sq = 0, max_err = 0;
        std::size_t samples = 0;
        for (std::size_t j = 0; j < site.planes.size(); ++j) {
          const Vec3 n = site.planes[j].normal();
          Eigen::Vector3d sun_total = Eigen::Vector3d::Zero();
          std::vector<Eigen::Vector3d> sun_visible(texels[j], Eigen::Vector3d::Zero());
          if (separate) {
            for (std::size_t p = 0; p < n_dirs; ++p) {
              if (!is_sun[p]) continue;
              const double c = std::max(0.0, n.dot(dirs[p])) * omega[p];
              sun_total += c * L[p];
              for (std::size_t x = 0; x < texels[j]; ++x) {
                if (visible[j][x * n_dirs + p]) sun_visible[x] += c * L[p];
              }
            }
          }
          Eigen::Vector3d denominator = sun_total;
          for (std::size_t i = 0; i < count; ++i) denominator += S[i] * baked[b].A[j][i];
          for (std::size_t x = 0; x < texels[j]; ++x) {
            Eigen::Vector3d t = sun_visible[x];
            for (std::size_t i = 0; i < count; ++i) t += S[i] * baked[b].B[j][x * count + i];
            for (int ch = 0; ch < 3; ++ch) {
              const double value = denominator[ch] > 0 ? std::clamp(t[ch] / denominator[ch], 0.0, 1.0) : 1.0;
              const double e = std::abs(value - ref[j][x][ch]);
              sum_sq += e * e;
              max_err = std::max(max_err, e);
              ++samples;
            }
          }
        }
        std::printf("| %s | %s | %s | %s | %.4f | %.3f |\n", sky_file.stem().c_str(),
                    separate ? "separated" : (sun_found ? "in the dome" : "none found"), basis.name.c_str(),
                    basis.l2 ? "L2 projection" : "φ-weighted mean", std::sqrt(sum_sq / static_cast<double>(samples)), max_err);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
