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
constexpr double kT0 = 16.0;  // near-field threshold t0 (docs/architecture.md)

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

// w(t): t/(1+t) up to t0 (point-to-disc form factor), a linear ramp to 1 on (t0, 2 t0], then 1.
inline double near_weight(double t) {
    constexpr double w0 = kT0 / (1.0 + kT0);
    const double wd = t / (1.0 + t);
    const double wr = w0 + (1.0 - w0) * (t - kT0) * (1.0 / kT0);
    return t <= kT0 ? wd : (t <= 2.0 * kT0 ? wr : 1.0);
}

// F_ij for receiver i and source j, d = r_i - r_j. Zero for r = 0 and for pairs that do not
// face each other (clamped cosines). cos_i cos_j / r^2 = (-n_i.d)(n_j.d) / r^4.
template <NearField NF>
inline double pair_factor(double dx, double dy, double dz, double nix, double niy, double niz,
                          double Ai, double njx, double njy, double njz, double Aj) {
    const double r2 = dx * dx + dy * dy + dz * dz;
    double ci = -(nix * dx + niy * dy + niz * dz);
    double cj = njx * dx + njy * dy + njz * dz;
    ci = ci > 0.0 ? ci : 0.0;
    cj = cj > 0.0 ? cj : 0.0;
    const bool nz = r2 > 0.0;
    if constexpr (NF == NearField::Point) {
        const double inv_r4 = nz ? 1.0 / (nz ? r2 * r2 : 1.0) : 0.0;
        return Aj * kInvPi * ci * cj * inv_r4;
    } else {
        // One division for all three branches of w: g = 1 / (r^4 Abar (Abar + pi r^2)).
        //   w(t) / r^4 = pi r^2 / (Abar + pi r^2) / r^4 = pi r^2 Abar g            (t <= t0)
        //   1 / r^4    = Abar (Abar + pi r^2) g,  t = pi r^2 / Abar = pi r^6 (Abar + pi r^2) g
        const double abar = 0.5 * (Ai + Aj);
        const double s = abar + kPi * r2;
        const double r4 = r2 * r2;
        const double g = nz ? 1.0 / (nz ? r4 * abar * s : 1.0) : 0.0;
        const double t = kPi * r2 * r4 * s * g;
        const double inv_r4 = abar * s * g;
        constexpr double w0 = kT0 / (1.0 + kT0);
        const double w_disc = kPi * r2 * abar * g;
        const double w_ramp = (w0 + (1.0 - w0) * (t - kT0) * (1.0 / kT0)) * inv_r4;
        const double wr4 = t <= kT0 ? w_disc : (t <= 2.0 * kT0 ? w_ramp : inv_r4);
        return Aj * kInvPi * ci * cj * wr4;
    }
}

}  // namespace illumap
