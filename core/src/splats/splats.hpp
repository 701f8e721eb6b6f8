// splats.hpp — the outline of each point's splat: a disc in its tangent plane clipped by its
// neighbours' bisector planes and, where the surface turns, by their tangent planes
// (illumap/splats.py documents the rules and their constants).
#pragma once

#include "parallel.hpp"

#include <cstddef>
#include <cstdint>

namespace illumap {

struct SplatOptions {
    double corner_slack = 1.3;       // bisector limits reach this far past the half-way point
    double edge_cos = 0.9;           // a neighbour's normal turned further: its tangent plane clips
    double rim_cos = 0.5;            // a direction with no neighbour within acos(this) leads off the rim
    double junction_tolerance = 0.05;  // "on a plane": within this fraction of the distance
    double edge_overlap = 0.02;      // splats reach past a clipping tangent plane by this fraction
};

// radii (n x sides, m): how far each point's splat reaches along the directions
// cos(t_m) u + sin(t_m) v, t_m = 2 pi m / sides, at most `reach` (n); `rim` (n) where no
// neighbour supports a direction. normals, u, v: unit (n x 3); neighbours: n x k indices
// (the point itself left out).
void splat_radii(Context& ctx, const double* points, const double* normals, const double* u,
                 const double* v, const double* reach, const double* rim, std::size_t n,
                 const std::int64_t* neighbours, std::size_t k, std::size_t sides,
                 const SplatOptions& options, double* radii);

// The splats as fans of `sides` triangles about their points (n x sides x 3 x 3, m): point i's
// are rows i*sides ... (i+1)*sides - 1, (centre, rim m, rim m+1), the rim at `radii` along
// the directions above, wound so that each fan faces along `facing` (n x 3).
void splat_fans(Context& ctx, const double* points, const double* u, const double* v,
                const double* radii, const double* facing, std::size_t n, std::size_t sides,
                double* triangles);

}  // namespace illumap
