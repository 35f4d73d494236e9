#pragma once
// Point-to-line solver for 2D ICP: the point-to-plane solver of point_to_plane_solver.hpp in two
// dimensions (a line is the plane of dimension 1). The name stays for the 2D laser setup's callers.

#include <concepts>

#include "rangenav/registration/point_to_plane_solver.hpp"

namespace rangenav {

/// The 2D point-to-plane solver: n . (T d - m) against the model's line normals.
template <std::floating_point Scalar = double>
using PointToLineSolver = PointToPlaneSolver<2, Scalar>;

}  // namespace rangenav
