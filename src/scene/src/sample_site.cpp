// The sample site: a chūmon (middle gate) of an ancient temple with its corridors (kairō), built
// from closed convex solids with flat, outward normals.
#include "skylit/scene/sample_site.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include <Eigen/Geometry>

namespace skylit::scene {
namespace {

using Vec3 = Eigen::Vector3d;

enum MaterialSlot : std::uint32_t { kVermilion = 0, kPlaster = 1, kRoofTile = 2, kStone = 3 };

// Dimensions in metres. The gate: 3 × 2 bays of pillars, a hipped roof.
constexpr double kGatePillarX[] = {-5.0, -1.8, 1.8, 5.0};
constexpr double kGatePillarY[] = {-3.0, 0.0, 3.0};
constexpr double kGatePillarRadius = 0.25;
constexpr double kGateBaseHalf = 0.4;      // square stone base, 0.8 m wide
constexpr double kGateBaseTop = 0.3;
constexpr double kGatePillarTop = 4.5;
constexpr double kGateBeamXBottom = 4.25;  // beams along x rest on the pillar tops...
constexpr double kGateBeamXTop = 4.6;
constexpr double kGateBeamYTop = 4.95;     // ...and the beams along y on them
constexpr double kGateBeamHalf = 0.15;
constexpr double kGateEaveOverhang = 1.5;
constexpr double kGateRoofBottom = kGateBeamYTop;
constexpr double kGateEaveTop = 5.2;
constexpr double kGateRidge = 8.5;

// The corridors, east and west of the gate (mirrored): two lines of pillars, a gabled roof, and a
// plaster wall behind the north line (clear of the pillars so a plane fits in front of it).
constexpr double kCorridorStart = 5.3;  // |x| where the corridor roof and wall begin
constexpr double kCorridorEnd = 13.3;
constexpr double kCorridorPillarX[] = {7.0, 9.0, 11.0, 13.0};
constexpr double kCorridorPillarY[] = {-1.5, 1.5};
constexpr double kCorridorPillarRadius = 0.18;
constexpr double kCorridorBaseHalf = 0.25;
constexpr double kCorridorBaseTop = 0.2;
constexpr double kCorridorBeamXBottom = 3.0;
constexpr double kCorridorBeamXTop = 3.3;
constexpr double kCorridorBeamYTop = 3.5;
constexpr double kCorridorBeamHalf = 0.12;
constexpr double kCorridorRoofBottom = kCorridorBeamYTop;
constexpr double kCorridorEaveHalfWidth = 2.6;
constexpr double kCorridorEaveTop = 3.65;
constexpr double kCorridorRidge = 4.6;
constexpr double kWallSouth = 1.8;  // pillars reach y = 1.5 + 0.25 (base) < 1.8
constexpr double kWallNorth = 2.0;

constexpr double kPlaneOffset = 0.01;  // planes float 1 cm above the surfaces they stand for
constexpr int kPillarSides = 12;

class SolidBuilder {
 public:
  // A convex planar polygon, counter-clockwise seen from outside: its own vertices (flat normal).
  void face(const std::vector<Vec3>& corners, std::uint32_t material) {
    Vec3 newell = Vec3::Zero();
    for (std::size_t k = 0; k < corners.size(); ++k) {
      newell += corners[k].cross(corners[(k + 1) % corners.size()]);
    }
    const Eigen::Vector3f normal = newell.normalized().cast<float>();
    const auto first = static_cast<std::uint32_t>(mesh_.positions.size());
    for (const Vec3& corner : corners) {
      mesh_.positions.push_back(corner.cast<float>());
      mesh_.normals.push_back(normal);
    }
    for (std::uint32_t k = 1; k + 1 < corners.size(); ++k) {
      mesh_.indices.insert(mesh_.indices.end(), {first, first + k, first + k + 1});
      mesh_.triangle_material.push_back(material);
    }
  }

  // A convex cross-section (counter-clockwise seen from where `extrusion` points) swept along
  // `extrusion`; `with_far_cap` false leaves the far end open for a solid that continues there.
  void prism(const std::vector<Vec3>& section, const Vec3& extrusion, std::uint32_t material,
             bool with_far_cap = true) {
    std::vector<Vec3> near(section.rbegin(), section.rend());
    face(near, material);
    std::vector<Vec3> far;
    for (const Vec3& p : section) far.push_back(p + extrusion);
    if (with_far_cap) face(far, material);
    for (std::size_t k = 0; k < section.size(); ++k) {
      const std::size_t next = (k + 1) % section.size();
      face({section[k], section[next], far[next], far[k]}, material);
    }
  }

  void box(const Vec3& low, const Vec3& high, std::uint32_t material) {
    prism({{low.x(), low.y(), low.z()},
           {high.x(), low.y(), low.z()},
           {high.x(), high.y(), low.z()},
           {low.x(), high.y(), low.z()}},
          {0.0, 0.0, high.z() - low.z()}, material);
  }

  void pillar(double x, double y, double radius, double bottom, double top) {
    std::vector<Vec3> section;
    for (int k = 0; k < kPillarSides; ++k) {
      const double angle = 2.0 * std::numbers::pi * (k + 0.5) / kPillarSides;
      section.emplace_back(x + radius * std::cos(angle), y + radius * std::sin(angle), bottom);
    }
    prism(section, {0.0, 0.0, top - bottom}, kVermilion);
  }

  // Sorted by material so a glTF round trip (one primitive per material) keeps the order.
  Mesh take() {
    std::vector<std::size_t> order(mesh_.triangle_count());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return mesh_.triangle_material[a] < mesh_.triangle_material[b];
    });
    Mesh sorted = mesh_;
    for (std::size_t k = 0; k < order.size(); ++k) {
      for (std::size_t c = 0; c < 3; ++c) sorted.indices[3 * k + c] = mesh_.indices[3 * order[k] + c];
      sorted.triangle_material[k] = mesh_.triangle_material[order[k]];
    }
    return sorted;
  }

  Mesh& mesh() { return mesh_; }

 private:
  Mesh mesh_;
};

void add_gate(SolidBuilder& builder) {
  for (double x : kGatePillarX) {
    for (double y : kGatePillarY) {
      builder.box({x - kGateBaseHalf, y - kGateBaseHalf, 0.0},
                  {x + kGateBaseHalf, y + kGateBaseHalf, kGateBaseTop}, kStone);
      builder.pillar(x, y, kGatePillarRadius, kGateBaseTop, kGatePillarTop);
    }
  }
  const double beam_x_end = kGatePillarX[3] + kGatePillarRadius + 0.05;
  for (double y : kGatePillarY) {
    builder.box({-beam_x_end, y - kGateBeamHalf, kGateBeamXBottom},
                {beam_x_end, y + kGateBeamHalf, kGateBeamXTop}, kVermilion);
  }
  const double beam_y_end = kGatePillarY[2] + kGatePillarRadius + 0.05;
  for (double x : kGatePillarX) {
    builder.box({x - kGateBeamHalf, -beam_y_end, kGateBeamXTop},
                {x + kGateBeamHalf, beam_y_end, kGateBeamYTop}, kVermilion);
  }

  // Hipped roof (yosemune): a flat soffit, a vertical fascia up to the eave line, four slopes of
  // equal pitch meeting the ridge, which runs along x.
  const double half_x = kGatePillarX[3] + kGateEaveOverhang;
  const double half_y = kGatePillarY[2] + kGateEaveOverhang;
  const double ridge_half = half_x - half_y;
  builder.prism({{-half_x, -half_y, kGateRoofBottom},
                 {half_x, -half_y, kGateRoofBottom},
                 {half_x, half_y, kGateRoofBottom},
                 {-half_x, half_y, kGateRoofBottom}},
                {0.0, 0.0, kGateEaveTop - kGateRoofBottom}, kRoofTile, /*with_far_cap=*/false);
  const Vec3 south_west(-half_x, -half_y, kGateEaveTop);
  const Vec3 south_east(half_x, -half_y, kGateEaveTop);
  const Vec3 north_east(half_x, half_y, kGateEaveTop);
  const Vec3 north_west(-half_x, half_y, kGateEaveTop);
  const Vec3 ridge_west(-ridge_half, 0.0, kGateRidge);
  const Vec3 ridge_east(ridge_half, 0.0, kGateRidge);
  builder.face({south_west, south_east, ridge_east, ridge_west}, kRoofTile);
  builder.face({north_east, north_west, ridge_west, ridge_east}, kRoofTile);
  builder.face({south_east, north_east, ridge_east}, kRoofTile);
  builder.face({north_west, south_west, ridge_west}, kRoofTile);
}

// One corridor; side = +1 east of the gate, −1 west.
void add_corridor(SolidBuilder& builder, double side) {
  const double start = side * kCorridorStart;
  const double end = side * kCorridorEnd;
  const double low_x = std::min(start, end);
  const double high_x = std::max(start, end);
  for (double px : kCorridorPillarX) {
    const double x = side * px;
    for (double y : kCorridorPillarY) {
      builder.box({x - kCorridorBaseHalf, y - kCorridorBaseHalf, 0.0},
                  {x + kCorridorBaseHalf, y + kCorridorBaseHalf, kCorridorBaseTop}, kStone);
      builder.pillar(x, y, kCorridorPillarRadius, kCorridorBaseTop, kCorridorBeamXBottom + 0.1);
    }
    builder.box({x - kCorridorBeamHalf, kCorridorPillarY[0] - kCorridorBeamHalf, kCorridorBeamXTop},
                {x + kCorridorBeamHalf, kCorridorPillarY[1] + kCorridorBeamHalf, kCorridorBeamYTop},
                kVermilion);
  }
  for (double y : kCorridorPillarY) {
    builder.box({low_x, y - kCorridorBeamHalf, kCorridorBeamXBottom},
                {high_x, y + kCorridorBeamHalf, kCorridorBeamXTop}, kVermilion);
  }
  builder.box({low_x, kWallSouth, 0.0}, {high_x, kWallNorth, kCorridorRoofBottom}, kPlaster);

  // Gabled roof: a pentagonal section (soffit, two fascias, two slopes) swept along x.
  builder.prism({{low_x, -kCorridorEaveHalfWidth, kCorridorRoofBottom},
                 {low_x, kCorridorEaveHalfWidth, kCorridorRoofBottom},
                 {low_x, kCorridorEaveHalfWidth, kCorridorEaveTop},
                 {low_x, 0.0, kCorridorRidge},
                 {low_x, -kCorridorEaveHalfWidth, kCorridorEaveTop}},
                {high_x - low_x, 0.0, 0.0}, kRoofTile);
}

}  // namespace

Mesh make_sample_gate() {
  SolidBuilder builder;
  builder.mesh().materials = {
      Material{"vermilion lacquer", {0.70f, 0.06f, 0.03f, 1.0f}},
      Material{"white plaster", {0.80f, 0.78f, 0.72f, 1.0f}},
      Material{"dark grey roof tiles", {0.05f, 0.05f, 0.055f, 1.0f}},
      Material{"grey stone", {0.32f, 0.32f, 0.30f, 1.0f}},
  };
  add_gate(builder);
  add_corridor(builder, +1.0);
  add_corridor(builder, -1.0);
  return builder.take();
}

Site make_sample_site(const std::filesystem::path& model) {
  Site site;
  site.model = model;
  site.up = UpAxis::Y;  // the sample model is written as glTF, which is y-up
  site.scale = 1.0;
  site.dome_frequency = 2;
  site.location = GeoLocation{34.69, 135.80};  // Nara, where the demo's simulated day is

  // Ground: the building's footprint (|x| ≤ 13.3, |y| ≤ 4.5) plus about 6 m each way, 6.25 cm
  // texels.
  geom::Plane ground;
  ground.name = "ground";
  ground.origin = Vec3(-20.0, -12.0, kPlaneOffset);
  ground.u = Vec3(40.0, 0.0, 0.0);
  ground.v = Vec3(0.0, 24.0, 0.0);
  ground.width = 640;
  ground.height = 384;

  // Wall: 1 cm south of the east corridor's wall, facing south: u east × v up = −y.
  geom::Plane wall;
  wall.name = "wall";
  wall.origin = Vec3(kCorridorStart, kWallSouth - kPlaneOffset, 0.0);
  wall.u = Vec3(kCorridorEnd - kCorridorStart, 0.0, 0.0);
  wall.v = Vec3(0.0, 0.0, kCorridorRoofBottom);
  wall.width = 512;
  wall.height = 224;

  // Roof: 1 cm above the gate roof's south slope, eave to ridge over the full eave width (the
  // parts beyond the hips float above them: the roof is convex). u east × v up-slope = up-south.
  const double half_x = kGatePillarX[3] + kGateEaveOverhang;
  const double half_y = kGatePillarY[2] + kGateEaveOverhang;
  geom::Plane roof;
  roof.name = "roof";
  roof.u = Vec3(2.0 * half_x, 0.0, 0.0);
  roof.v = Vec3(0.0, half_y, kGateRidge - kGateEaveTop);
  roof.origin = Vec3(-half_x, -half_y, kGateEaveTop) + kPlaneOffset * roof.u.cross(roof.v).normalized();
  roof.width = 256;
  roof.height = 110;  // 13 m × 5.58 m: square texels of 5.1 cm

  site.planes = {ground, wall, roof};
  // The ground is the real ground the HMD camera sees; the wall and the roof are the gate's.
  site.plane_surfaces = {PlaneSurface::Real, PlaneSurface::Virtual, PlaneSurface::Virtual};
  return site;
}

}  // namespace skylit::scene
