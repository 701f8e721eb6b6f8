// knn.hpp — k nearest neighbours with a kd-tree, multithreaded over queries.
// Used by the add-on for point-cloud spacing, PCA normals and transferring results to meshes.
#pragma once

#include "parallel.hpp"

#include <cstdint>

namespace illumap {

// points: n x 3, queries: m x 3 (row-major). Writes indices (m x k, int64) and Euclidean
// distances (m x k), nearest first. A query that coincides with a point finds it (distance 0).
// Requires 1 <= k <= n.
void knn(Context& ctx, const double* points, std::size_t n, const double* queries, std::size_t m,
         std::size_t k, std::int64_t* indices, double* distances);

}  // namespace illumap
