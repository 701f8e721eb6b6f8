// splat_frames.hpp — the Object Preview's splat of each scan point: an ellipse in its tangent
// plane, cut back at creases and rims (illumap/splats.py, ``splat_frames``, documents the
// rules and their constants; this is its per-point work, one point per task).
#pragma once

#include "geometry/normals.hpp"
#include "parallel.hpp"

#include <cstddef>
#include <cstdint>

namespace illumap {

struct SplatFrameOptions {
    double cover = 1.0;           // disc radius in units of the k-th neighbour's distance
    double edge_cos = 0.9;        // a neighbour's normal turned further: another surface
    double on_plane = 0.05;       // "on a plane": within this fraction of the distance
    double edge_slack = 0.15;     // splats reach past a clipping line by this fraction of r
    // ... past a convex crease's line (the clipping surface's normal points beyond it); only
    // for oriented normals (a scanner's, facing out of the surfaces); < 0: edge_slack (normals
    // estimated: unoriented, a convex crease and a concave one look alike). What reaches past
    // a convex edge stands out of the surface, and where the other face is seen at a grazing
    // angle it hides a strip of it.
    double convex_slack = -1.0;
    double rim_shift = 0.2;       // the neighbours' centroid this far off (x the 16th distance)
    double rim_gap = 2.6179938779914944;  // ... and a wider gap (radians) between them: a rim
    double rim_along = 0.7;       // a rim point needs a rim neighbour facing within acos(this)
    double rim_reach = 0.0;       // a rim's splats reach this fraction of r past its line
    double parallel_cos = 0.8660254037844387;  // a second line turns by more than acos(this)
    double crease_width = 0.3;    // a crease point's strip reaches this far into its side (x r)
    int propagate = 1;            // rounds in which the neighbours' planes clip a point
    int rim_neighbours = 16;      // neighbours that tell a rim (for the candidates)
    bool crease_strips = true;    // points on a crease keep a strip (normals were estimated)
};

// Each point's splat, from its k nearest points (2 <= k < n). given_normals (n x 3, unit) the
// scan's own, or null: fitted (plane_normals, options fit); given_radii (n) the scan's own, or
// null: cover x the mean, over the point and its k nearest, of the distance to their k-th
// nearest. Writes frames (n x 13): the normal (3), the ellipse's first axis (3, unit), its
// semi-axes (a, b, a), the offset from the point to its centre (3) and 1 where a crease or
// rim shaped it, else 0. order (n) and neighbours (n x k), or null: the kd-tree's order of
// the points (input indices; neighbouring entries lie close in space) and, in that order,
// each point's k nearest others, nearest first, as positions in that order (what
// splat_shading needs to fit each splat without a search, its reads near each other).
void splat_frames(Context& ctx, const double* points, std::size_t n, const double* given_normals,
                  const double* given_radii, std::size_t k, const PlaneFitOptions& fit,
                  const SplatFrameOptions& options, double* frames,
                  std::int64_t* order_out = nullptr, std::int64_t* neighbours = nullptr);

}  // namespace illumap
