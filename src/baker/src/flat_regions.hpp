#pragma once
// The model's flat regions: triangles joined across shared edges (welded to the millimetre),
// normals within 1°, in one plane within 1 cm. The faces a plane or a light map chart lies over.
#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "skylit/scene/mesh.hpp"

namespace skylit::baker {

struct FlatFaces {
  std::vector<Eigen::Vector3d> normal;  // per triangle, unit (zero for a degenerate one)
  std::vector<double> area;             // per triangle, m²
};
FlatFaces flat_faces(const scene::Mesh& mesh);

struct FlatRegion {
  std::vector<std::size_t> triangles;   // ascending
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // area-weighted mean, unit
  double area = 0.0;                    // m²
};
// Every region, in the order of its first triangle; degenerate triangles belong to none.
std::vector<FlatRegion> flat_regions(const scene::Mesh& mesh, const FlatFaces& faces);

}  // namespace skylit::baker
