// near_field.hpp — the bounded rule for close pairs ("disc" near field).
//
// The bare point kernel A_j cos cos / (π r²) is a one-point quadrature of the form factor from
// a point to surfel j; it blows up for close pairs (row sums reach 1.24 at the edges of a closed
// cube). For pairs with t = π r² / Ā ≤ 2 t0 we instead integrate exactly: surfel j is a regular
// polygon of area A_j in its tangent plane, clipped to the receiver's hemisphere, and the
// point-to-polygon form factor has a closed form (Lambert). Averaging the two directions,
// G_ij = ½ (A_i F(i→j) + A_j F(j→i)), keeps diag(A)·F symmetric. A linear ramp over
// t0 < t ≤ 2 t0 blends into the point kernel, so the rule is continuous.
//
// The result is stored once per geometry as a sparse correction C = F_near − F_point over the
// close pairs only (coplanar and back-facing pairs are zero in both and are not stored); every
// operator then computes F·x = F_point·x + C·x, the FMM for the first term included.
#pragma once

#include "transport/kernel.hpp"
#include "parallel.hpp"

#include <cstdint>
#include <functional>
#include <vector>

namespace illumap {

constexpr int kPolygonSides = 8;  // regular octagon of the surfel's area

// Form factor from the point x with normal n to the regular polygon of area `area` centred at
// c with normal m (front side only), clipped to the half-space in front of x. Dimensionless.
double point_to_polygon(const double x[3], const double n[3], const double c[3],
                        const double m[3], double area);

// point_to_polygon averaged over the disc of area `receiver_area` centred at x in its plane:
// the form factor from that disc (as its octagon's neighbours see it) to the polygon.
double disc_to_polygon(const double x[3], const double n[3], double receiver_area,
                       const double c[3], const double m[3], double area);

// Two surfels whose normals' cosine is below this face each other as plates do.
constexpr double kPlateCos = -0.5;

// Whether surfels i and j (d = x_i − x_j) face each other as close plates: normals opposed
// (cos < kPlateCos), each centre in front of the other's plane by less than half its radius.
bool facing_plates(const double d[3], const double ni[3], const double nj[3], double area_i,
                   double area_j);

struct NearCorrection {
    std::vector<std::int64_t> offsets;  // CSR by receiver (caller's order), size n + 1
    std::vector<std::int64_t> columns;
    std::vector<double> values;  // F_near_ij − F_point_ij (times V_ij with visibility)
    std::vector<double> full;    // F_near_ij (times V_ij): the whole entry of the operator
    std::size_t candidate_pairs = 0;  // close pairs examined (both directions)
    std::size_t limited_rows = 0;     // rows scaled down by limit_close_sums

    // The close pairs of one receiver all lie within a few surfel spacings, so together they
    // can cover at most its hemisphere. Where they sum above 1 — overlapping discs of nearly
    // coincident surfels, faces touching face to face — that row's close pairs are scaled so
    // they sum to 1, symmetrically (pair factor min(γ_i, γ_j), so reciprocity holds). Local and
    // exact: the same for every method. Returns the number of rows scaled.
    std::size_t limit_close_sums();

    // y += C x (x, y: n x 3 row-major).
    void apply_add(Context& ctx, const double* x, double* y) const;
    // y[r] += (C x)[rows[r]].
    void apply_rows_add(const double* x, const std::int64_t* rows, std::size_t nrows,
                        double* y) const;
    std::size_t pairs() const { return columns.size(); }
    std::size_t bytes() const;
};

// One stored entry: row, column, correction value and the whole operator entry (`full`).
struct SparseEntry {
    std::int64_t row, col;
    double value, full;
};

// Builds the CSR from per-chunk entry lists (emptied on the way), for n receivers.
NearCorrection assemble_correction(std::size_t n, std::vector<std::vector<SparseEntry>>& chunks);

// V(i, j) in [0, 1] for surfels i, j in the caller's order (symmetric), or nullptr for V = 1.
using PairVisibilityFn = std::function<float(std::uint32_t, std::uint32_t)>;

// Finds every pair with π r² ≤ 2 t0 Ā_ij and stores its correction. Multithreaded. With `vis`,
// each stored pair's correction is multiplied by V(i, j) (so that F·V = F_point·V + C·V).
// `scan` (n entries, or nullptr): the point cloud each surfel stands for a point of (1, 2, …;
// 0: a mesh's). A pair of facing plates (facing_plates) of a scan and another object takes
// the plates rule: its form factors averaged over the receiver's disc (disc_to_polygon), and
// no visibility test between the two centres. Within one scan (its points' two sides, a thin
// part) the pair keeps the point rule.
NearCorrection build_near_correction(Context& ctx, const SurfelSoA& s,
                                     const PairVisibilityFn* vis = nullptr,
                                     const std::uint32_t* scan = nullptr);

}  // namespace illumap
