// kernel.hpp — the pair rule F_ij, exactly as docs/architecture.md states it.
//
// One inline function, used by the direct operator and by the FMM near field (P2P), so that
// the two agree term by term. Written branch-free (selects, not jumps) so loops over sources
// vectorise.
#pragma once

#include <cstddef>
#include <vector>

namespace illumap {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInvPi = 1.0 / kPi;
constexpr double kT0 = 16.0;  // close pairs: pi r^2 / Abar <= 2 t0 (near_field.hpp)
// |cos| below this is coplanar up to rounding (scale-free: cosines are ratios). Normals read
// from a mesh are single precision (~6e-8), so two surfels of one plane facing opposite ways
// (an open surface's two sides) can tilt towards each other by ~1e-6 (near_field.cpp).
constexpr double kCoplanarCos = 1e-6;
// Two surfels whose planes lie closer than this fraction of the smaller one's size (sqrt of its
// area) are in contact: the two sides of one open surface, a box resting on a floor. Rounding
// of positions far from the origin, or given in single precision, separates them by up to
// ~1e-7 of the coordinates; a real gap this thin carries no light.
constexpr double kContactHeight = 1e-3;
// Per-pair visibility blocks hold V quantised to 8 bits: round(kVisLevels V) (traversal.hpp).
constexpr int kVisLevels = 255;

enum class NearField { Disc, Point };

// Surfels in structure-of-arrays layout (vectorisable inner loops).
struct SurfelSoA {
    std::size_t n = 0;
    std::vector<double> px, py, pz, nx, ny, nz, area;
    void resize(std::size_t m) {
        n = m;
        for (auto* v : {&px, &py, &pz, &nx, &ny, &nz, &area}) v->assign(m, 0.0);
    }
};

// F_ij for receiver i and source j, d = r_i - r_j: the bare point kernel with clamped cosines,
// zero for r = 0. cos_i cos_j / r^2 = (-n_i.d)(n_j.d) / r^4. The bounded "disc" rule for close
// pairs is a sparse correction on top of this (near_field.hpp), so the FMM approximates exactly
// this kernel.
inline double pair_factor(double dx, double dy, double dz, double nix, double niy, double niz,
                          double njx, double njy, double njz, double Aj) {
    const double r2 = dx * dx + dy * dy + dz * dz;
    double ci = -(nix * dx + niy * dy + niz * dz);
    double cj = njx * dx + njy * dy + njz * dz;
    ci = ci > 0.0 ? ci : 0.0;
    cj = cj > 0.0 ? cj : 0.0;
    const bool nz = r2 > 0.0;
    const double inv_r4 = nz ? 1.0 / (nz ? r2 * r2 : 1.0) : 0.0;
    return Aj * kInvPi * ci * cj * inv_r4;
}

}  // namespace illumap
