// direct.hpp — the exact O(N^2) transport operator, the reference for every FMM error figure.
#pragma once

#include "transport/kernel.hpp"
#include "parallel.hpp"

#include <cstdint>

namespace illumap {

// y[r] = sum_j F_{rows[r], j} x_j for each listed receiver (x, y: N x 3 / R x 3, row-major).
// Parallel over receivers; each writes only its own row.
void direct_rows(Context& ctx, const SurfelSoA& s, const double* x,
                 const std::int64_t* rows, std::size_t nrows, double* y);

// y = F_point x for all receivers (the near-field correction is added by the caller).
void direct_apply(Context& ctx, const SurfelSoA& s, const double* x, double* y);

// Sources as raw arrays (positions, normals, areas, values; all of length n).
struct SourceView {
    const double *px, *py, *pz, *nx, *ny, *nz, *area, *x0, *x1, *x2;
    std::size_t n;
};

// Receiver data.
struct Receiver {
    double px, py, pz, nx, ny, nz, area;
};

// acc[3] += sum_j F_ij x_j over all sources of v (the shared inner loop of direct and P2P).
void accumulate_sources(const Receiver& r, const SourceView& v, double acc[3]);

// acc[3] += sum_j (weights[j]/kVisLevels) F_ij x_j: a per-pair visibility block's row (fmm.cpp).
void accumulate_sources_weighted(const Receiver& r, const SourceView& v,
                                 const std::uint8_t* weights, double acc[3]);

}  // namespace illumap
