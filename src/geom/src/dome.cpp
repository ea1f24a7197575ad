#include "skylit/geom/dome.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>

namespace skylit::geom {
namespace {

// Icosahedron with a vertex at the zenith: 0 = top, 1..5 = upper ring (z = 1/√5, azimuth 72°k),
// 6..10 = lower ring (z = −1/√5, azimuth 36° + 72°k). The bottom vertex never reaches z ≥ 0.
constexpr int kIcoVertexCount = 11;

std::array<Vec3, kIcoVertexCount> icosahedron_vertices() {
  const double ring_z = 1.0 / std::sqrt(5.0);
  const double ring_r = 2.0 * ring_z;
  std::array<Vec3, kIcoVertexCount> v;
  v[0] = Vec3(0.0, 0.0, 1.0);
  for (int k = 0; k < 5; ++k) {
    const double upper = 2.0 * std::numbers::pi * k / 5.0;
    const double lower = upper + std::numbers::pi / 5.0;
    v[static_cast<std::size_t>(1 + k)] = Vec3(ring_r * std::cos(upper), ring_r * std::sin(upper), ring_z);
    v[static_cast<std::size_t>(6 + k)] = Vec3(ring_r * std::cos(lower), ring_r * std::sin(lower), -ring_z);
  }
  return v;
}

// Sign of z for each icosahedron vertex; a grid point's z has the sign of Σ weight·sign exactly
// (the top vertex only meets the upper ring, and both rings sit at z = ±1/√5).
int ico_z_sign(int vertex) { return vertex <= 5 ? 1 : -1; }

// The 15 icosahedron faces that reach the upper hemisphere: 5 around the top, 10 in the band.
std::vector<std::array<int, 3>> upper_icosahedron_faces() {
  std::vector<std::array<int, 3>> faces;
  for (int k = 0; k < 5; ++k) faces.push_back({0, 1 + k, 1 + (k + 1) % 5});
  for (int k = 0; k < 5; ++k) {
    faces.push_back({1 + k, 6 + k, 1 + (k + 1) % 5});
    faces.push_back({6 + k, 6 + (k + 1) % 5, 1 + (k + 1) % 5});
  }
  return faces;
}

// A grid point identified exactly: its integer weights on the icosahedron vertices (summing to
// ν), as (vertex, weight) pairs sorted by vertex, unused slots (-1, 0). Shared edge points of
// neighbouring icosahedron faces get the same key.
using GridKey = std::array<int, 6>;

GridKey grid_key(const std::array<int, 3>& ico_face, const std::array<int, 3>& weight) {
  std::array<std::pair<int, int>, 3> entries;
  for (std::size_t k = 0; k < 3; ++k) {
    entries[k] = weight[k] > 0 ? std::pair{ico_face[k], weight[k]} : std::pair{kIcoVertexCount, 0};
  }
  std::sort(entries.begin(), entries.end());
  GridKey key;
  for (std::size_t k = 0; k < 3; ++k) {
    const bool used = entries[k].second > 0;
    key[2 * k] = used ? entries[k].first : -1;
    key[2 * k + 1] = used ? entries[k].second : 0;
  }
  return key;
}

int z_sign(const GridKey& key) {
  int sum = 0;
  for (std::size_t k = 0; k < 3; ++k) {
    if (key[2 * k] >= 0) sum += key[2 * k + 1] * ico_z_sign(key[2 * k]);
  }
  return (sum > 0) - (sum < 0);
}

Vec3 grid_position(const GridKey& key, const std::array<Vec3, kIcoVertexCount>& ico) {
  Vec3 p = Vec3::Zero();
  for (std::size_t k = 0; k < 3; ++k) {
    if (key[2 * k] >= 0) p += key[2 * k + 1] * ico[static_cast<std::size_t>(key[2 * k])];
  }
  if (z_sign(key) == 0) p.z() = 0.0;  // on the horizon exactly, not within rounding
  return p.normalized();
}

// The cell's three grid points (i, j) → weights (ν−i−j, i, j), counter-clockwise like the face.
std::array<std::array<int, 3>, 3> cell_weights(int nu, int i, int j, bool down) {
  const auto w = [nu](int a, int b) { return std::array<int, 3>{nu - a - b, a, b}; };
  if (down) return {w(i + 1, j), w(i + 1, j + 1), w(i, j + 1)};
  return {w(i, j), w(i + 1, j), w(i, j + 1)};
}

int cell_index(int nu, int i, int j, bool down) { return 2 * (i * nu + j) + (down ? 1 : 0); }

struct FaceDraft {
  std::array<GridKey, 3> keys;
  int ico_face;
  int cell;
  Vec3 centre;
  long long zenith_key;
  long long azimuth_key;
};

}  // namespace

Dome::Dome(int frequency) : frequency_(frequency) {
  if (frequency < 2 || frequency > 64 || frequency % 2 != 0) {
    throw std::invalid_argument("Dome: frequency must be even and in [2, 64], got " +
                                std::to_string(frequency));
  }
  const int nu = frequency;
  const auto ico = icosahedron_vertices();
  auto ico_faces = upper_icosahedron_faces();

  std::vector<FaceDraft> drafts;
  for (std::size_t f = 0; f < ico_faces.size(); ++f) {
    auto& corner = ico_faces[f];
    const Vec3& a = ico[static_cast<std::size_t>(corner[0])];
    const Vec3& b = ico[static_cast<std::size_t>(corner[1])];
    const Vec3& c = ico[static_cast<std::size_t>(corner[2])];
    if ((b - a).cross(c - a).dot(a + b + c) < 0.0) std::swap(corner[1], corner[2]);
    for (int i = 0; i < nu; ++i) {
      for (int j = 0; i + j < nu; ++j) {
        for (const bool down : {false, true}) {
          if (down && i + j > nu - 2) continue;
          FaceDraft draft;
          const auto weights = cell_weights(nu, i, j, down);
          bool upper = true;
          for (std::size_t k = 0; k < 3; ++k) {
            draft.keys[k] = grid_key(corner, weights[k]);
            upper = upper && z_sign(draft.keys[k]) >= 0;
          }
          if (!upper) continue;
          draft.ico_face = static_cast<int>(f);
          draft.cell = cell_index(nu, i, j, down);
          draft.centre = (grid_position(draft.keys[0], ico) + grid_position(draft.keys[1], ico) +
                          grid_position(draft.keys[2], ico))
                             .normalized();
          // Order: zenith angle, then azimuth from east counter-clockwise, both rounded so
          // that rounding noise cannot reorder faces in the same ring.
          const double zenith = std::atan2(std::hypot(draft.centre.x(), draft.centre.y()), draft.centre.z());
          draft.zenith_key = std::llround(zenith * 1e9);
          const long long full_turn = std::llround(2.0 * std::numbers::pi * 1e9);
          long long azimuth = std::llround(std::atan2(draft.centre.y(), draft.centre.x()) * 1e9);
          if (azimuth < 0) azimuth += full_turn;
          if (azimuth >= full_turn) azimuth -= full_turn;
          draft.azimuth_key = azimuth;
          drafts.push_back(draft);
        }
      }
    }
  }
  std::stable_sort(drafts.begin(), drafts.end(), [](const FaceDraft& x, const FaceDraft& y) {
    return std::pair(x.zenith_key, x.azimuth_key) < std::pair(y.zenith_key, y.azimuth_key);
  });

  // Vertices numbered in order of first use by the sorted faces (zenith first).
  std::map<GridKey, int> vertex_of_key;
  faces_.reserve(drafts.size());
  for (const FaceDraft& draft : drafts) {
    DomeFace face{};
    for (std::size_t k = 0; k < 3; ++k) {
      auto [it, inserted] = vertex_of_key.try_emplace(draft.keys[k], static_cast<int>(vertices_.size()));
      if (inserted) vertices_.push_back(grid_position(draft.keys[k], ico));
      face.vertex[k] = it->second;
    }
    face.centre = draft.centre;
    face.solid_angle = solid_angle(triangle_of(face));
    face.neighbour = {-1, -1, -1};
    faces_.push_back(face);
  }

  // Neighbours: the other face on each edge (none across the horizon).
  std::map<std::pair<int, int>, std::vector<int>> faces_on_edge;
  for (std::size_t f = 0; f < faces_.size(); ++f) {
    const auto& v = faces_[f].vertex;
    for (std::size_t k = 0; k < 3; ++k) {
      faces_on_edge[std::minmax(v[k], v[(k + 1) % 3])].push_back(static_cast<int>(f));
    }
  }
  for (std::size_t f = 0; f < faces_.size(); ++f) {
    auto& face = faces_[f];
    for (std::size_t k = 0; k < 3; ++k) {
      for (const int other : faces_on_edge.at(std::minmax(face.vertex[k], face.vertex[(k + 1) % 3]))) {
        if (other != static_cast<int>(f)) face.neighbour[k] = other;
      }
    }
  }

  edge_normal_.reserve(faces_.size());
  for (const DomeFace& face : faces_) {
    std::array<Vec3, 3> normals;
    for (std::size_t k = 0; k < 3; ++k) {
      normals[k] = vertices_[static_cast<std::size_t>(face.vertex[k])]
                       .cross(vertices_[static_cast<std::size_t>(face.vertex[(k + 1) % 3])])
                       .normalized();
    }
    edge_normal_.push_back(normals);
  }

  ico_faces_.resize(ico_faces.size());
  for (std::size_t f = 0; f < ico_faces.size(); ++f) {
    const auto& corner = ico_faces[f];
    std::array<Vec3, 3> p;
    for (std::size_t k = 0; k < 3; ++k) p[k] = ico[static_cast<std::size_t>(corner[k])];
    IcoFace& target = ico_faces_[f];
    target.normal = (p[1] - p[0]).cross(p[2] - p[0]).normalized();
    for (std::size_t k = 0; k < 3; ++k) target.opposite_edge[k] = p[(k + 1) % 3].cross(p[(k + 2) % 3]);
    target.cell_face.assign(static_cast<std::size_t>(2 * nu * nu), -1);
  }
  for (std::size_t i = 0; i < drafts.size(); ++i) {
    IcoFace& target = ico_faces_[static_cast<std::size_t>(drafts[i].ico_face)];
    target.cell_face[static_cast<std::size_t>(drafts[i].cell)] = static_cast<int>(i);
    target.faces.push_back(static_cast<int>(i));
  }
}

SphericalTriangle Dome::triangle(int i) const { return triangle_of(face(i)); }

SphericalTriangle Dome::triangle_of(const DomeFace& f) const {
  return {vertices_[static_cast<std::size_t>(f.vertex[0])], vertices_[static_cast<std::size_t>(f.vertex[1])],
          vertices_[static_cast<std::size_t>(f.vertex[2])]};
}

int Dome::face_of(const Vec3& direction) const {
  if (!direction.allFinite() || direction.z() < 0.0 || direction.isZero(0.0)) return -1;
  // The icosahedron is convex: the ray leaves through the face whose plane it meets first,
  // i.e. the one maximizing d·normal (all faces are at the same distance from the centre).
  const IcoFace* ico = &ico_faces_.front();
  double best = ico->normal.dot(direction);
  for (const IcoFace& candidate : ico_faces_) {
    const double score = candidate.normal.dot(direction);
    if (score > best) {
      best = score;
      ico = &candidate;
    }
  }
  // Barycentric coordinates of the ray's hit point on the flat face, scaled to the ν grid.
  const double b0 = std::max(0.0, ico->opposite_edge[0].dot(direction));
  const double b1 = std::max(0.0, ico->opposite_edge[1].dot(direction));
  const double b2 = std::max(0.0, ico->opposite_edge[2].dot(direction));
  const double sum = b0 + b1 + b2;
  const int nu = frequency_;
  const double x = sum > 0.0 ? nu * b1 / sum : 0.0;
  const double y = sum > 0.0 ? nu * b2 / sum : 0.0;
  const int i = std::clamp(static_cast<int>(std::floor(x)), 0, nu - 1);
  const int j = std::clamp(static_cast<int>(std::floor(y)), 0, nu - 1 - i);
  const bool down = (x - i) + (y - j) > 1.0 && i + j <= nu - 2;
  const int found = ico->cell_face[static_cast<std::size_t>(cell_index(nu, i, j, down))];
  if (found >= 0) return found;
  // Only a horizon direction can round into a cell below the horizon.
  return most_inside_face(*ico, direction.normalized());
}

int Dome::most_inside_face(const IcoFace& ico, const Vec3& unit) const {
  int best_face = ico.faces.front();
  double best_depth = -std::numeric_limits<double>::infinity();
  for (const int f : ico.faces) {
    const auto& normals = edge_normal_[static_cast<std::size_t>(f)];
    const double depth = std::min({normals[0].dot(unit), normals[1].dot(unit), normals[2].dot(unit)});
    if (depth > best_depth) {
      best_depth = depth;
      best_face = f;
    }
  }
  return best_face;
}

}  // namespace skylit::geom
