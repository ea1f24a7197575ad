#pragma once
// Least-squares vertex values: each vertex's transfer chosen so that what the compositor
// interpolates across its triangles matches the light traced at points inside them, not the
// light at the vertex alone (Kavan, Bargteil, Sloan, "Least Squares Vertex Baking", EGSR 2011).
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/scene/mesh.hpp"

namespace skylit::baker {

// Points inside every triangle, triangle by triangle: the centroids of the n² triangles of its
// regular n-subdivision, each standing for 1/n² of its area.
struct FitPoints {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;             // interpolated, unit (as a fragment takes it)
  std::vector<std::array<std::uint32_t, 3>> corners;
  std::vector<std::array<double, 3>> weights;       // barycentric, sum 1
  std::vector<double> areas;                        // m²
};
FitPoints fit_points(const scene::Mesh& mesh, int n);

// The mesh with points appended as vertices no triangle uses: an engine traces them as it traces
// vertices (the first mesh.vertex_count() values are the model's own).
scene::Mesh with_points(const scene::Mesh& mesh, std::span<const Eigen::Vector3f> positions,
                        std::span<const Eigen::Vector3f> normals);

// Fits `layers` values per vertex (vertex-major) to `traced` (vertex-major, the model's vertices
// then the points'), every layer alike:
//     min Σ_p a_p (Σ_c b_{p,c} x_c − f_p)² + μ Σ_v m_v (x_v − f_v)²
// over the points p that have a value other than 0 in some layer (the others lie inside another
// solid, or see nothing of what is fitted: left out), a_p the point's area, b its barycentric
// weights, m_v a third of the area of the vertex's triangles: μ keeps a vertex no point informs
// at its own value. Fitted values are clamped to [0, upper] (upper per vertex and layer, as x;
// empty: no upper bound). std::invalid_argument when the sizes do not fit.
struct VertexFitOptions {
  double mu = 0.01;
};
std::vector<float> fit_vertex_values(const scene::Mesh& mesh, const FitPoints& points, std::span<const float> traced,
                                     std::size_t layers, std::span<const float> upper = {}, const VertexFitOptions& options = {});

}  // namespace skylit::baker
