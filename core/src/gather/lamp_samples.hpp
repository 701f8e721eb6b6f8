// lamp_samples.hpp — shadow-ray targets on a lamp and their unshadowed weights, for many
// receivers at once (the add-on's lamps.py documents each lamp kind's rules).
#pragma once

#include "parallel.hpp"

#include <cstddef>
#include <cstdint>

namespace illumap {

enum class LampKind { World, Sun, Mesh, Area, Point };

struct LampShape {
    LampKind kind = LampKind::Point;
    double position[3] = {0, 0, 0};
    double direction[3] = {0, 0, -1};   // the lamp's facing (sun: towards the scene)
    double axes[2][3] = {{1, 0, 0}, {0, 1, 0}};  // an area lamp's half-extents
    double radius = 0;                  // point and spot lamps
    double angle = 0;                   // sun: the disc's full angle (rad)
    bool disk = false;                  // area: a disc or ellipse, else a rectangle
    // Mesh lamps: T triangles (corner 0, edges e1 and e2, unit normal), the cumulative area
    // share (T) and each triangle's power (luminance), two-sided or facing its normal.
    std::size_t triangles = 0;
    const double* corner = nullptr;
    const double* edge1 = nullptr;
    const double* edge2 = nullptr;
    const double* normal = nullptr;
    const double* cumulative = nullptr;
    const double* power = nullptr;
    bool two_sided = false;
};

// For receivers p, n (m x 3): k samples each (targets m x k x 3, m; weights m x k), placed
// by one rank-1 lattice shifted per receiver by shifts (m x 2, in [0, 1)); `far` (m) is where
// a direction's target is put for the sun and the world.
void lamp_samples(Context& ctx, const LampShape& lamp, const double* p, const double* n,
                  const double* shifts, std::size_t m, std::size_t k, double far,
                  double* targets, double* weights);

}  // namespace illumap
