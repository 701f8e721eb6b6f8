// splat_shading.hpp — the preview splats' linear shading: each splat's value changing across
// it as the light does (illumap/splat_shading.py documents the rules and constants; this is
// its per-point work, one point per task).
#pragma once

#include "parallel.hpp"

#include <cstddef>
#include <cstdint>

namespace illumap {

struct SplatShadingOptions {
    double edge_cos = 0.9;  // a neighbour is on the point's surface when |n.m| >= this
    double ridge = 1e-3;    // ridge term of the fit (x the neighbours' mean squared distance)
};

// points (n x 3); the splats' normals, axes (unit), semi-axes (a, b, .) and offsets (n x 3
// each, splat_frames'); values (n x 3, the light at the points). Fits each point's gradient
// to its k nearest others on its own surface, limits it (Barth-Jespersen, half-way to each
// of them) and writes out (n x 9): the value at the ellipse's centre (3) and its change per
// unit of the instanced disc's X (3) and Y (3). The neighbours: splat_frames' order (n) and
// neighbours (n x k, positions in that order), or, both null, found here. Requires
// 1 <= k < n.
void splat_shading(Context& ctx, const double* points, const double* normals, const double* axes,
                   const double* scales, const double* offsets, const double* values,
                   std::size_t n, std::size_t k, const SplatShadingOptions& options, double* out,
                   const std::int64_t* order = nullptr, const std::int64_t* neighbours = nullptr);

// The same from float32 points and frames (as the preview keeps them: no float64 copies of
// them are made), with the search given (order and neighbours required).
void splat_shading(Context& ctx, const float* points, const float* normals, const float* axes,
                   const float* scales, const float* offsets, const double* values,
                   std::size_t n, std::size_t k, const SplatShadingOptions& options, double* out,
                   const std::int64_t* order, const std::int64_t* neighbours);

}  // namespace illumap
