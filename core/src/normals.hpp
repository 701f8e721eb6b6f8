// normals.hpp — consistent orientation of unoriented (PCA) normals on a point cloud.
#pragma once

#include "parallel.hpp"

#include <cstdint>

namespace illumap {

// Flips normals (n x 3, unit, in place) so that neighbours agree (Hoppe et al. 1992): the
// minimum spanning forest of the neighbour graph, weighted by 1 - |n_i . n_j| (ties: shorter
// edges first), carries each sign to the next point along the smoothest path, so a thin
// sheet's two sides and a concave fold keep their own sides. Each tree keeps its first
// point's sign; `part` (n) receives the tree's index, so the caller can choose each part's
// global sign. neighbours: n x k indices (i itself and entries outside [0, n) are skipped).
// Returns the number of connected parts.
std::size_t orient_normals(Context& ctx, const double* points, double* normals, std::size_t n,
                           const std::int64_t* neighbours, std::size_t k, std::int64_t* part);

}  // namespace illumap
