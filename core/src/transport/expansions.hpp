// expansions.hpp — Cartesian Taylor expansions for the tensor kernel T(d) = d d^T / |d|^4.
//
// Translation-invariant light-vector form (docs/architecture.md):
//   multipole  M_m = sum_j s_j (c - r_j)^m / m!      (signed moments; s_j = n_j A_j x_j)
//   local      l_k = sum_{|m| <= p-|k|} D^{k+m} T(R) M_m,   R = c_t - c_s
//   L2P        L(c + y) = sum_k l_k y^k / k!
// (the signed moments absorb the (-1)^|m| of the Taylor expansion of T(R + y - u)).
// Each coefficient holds 9 numbers: 3 vector components x 3 colour channels, [b*3 + channel].
// D^n T = n! tau_n, tau the Taylor coefficients of T, from those of g = r^-4 by recurrence.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "limits.hpp"

namespace illumap {

// kMaxOrder: limits.hpp.

struct ExpansionTables {
    int p = 0;
    int ncoef = 0;                          // number of multi-indices with |n| <= p
    std::vector<std::array<int, 3>> mi;     // multi-index per coefficient (by degree)
    std::vector<int> degree;
    std::vector<double> factorial;          // n!
    std::vector<int> index_table;           // (p+1)^3 -> coefficient index or -1
    // monomial recursion: mono[c] = mono[pred[c]] * y[axis[c]] / mi[c][axis]
    std::vector<int> mono_pred, mono_axis;
    std::vector<double> mono_scale;
    // predecessors n - e_a and n - e_a - e_b (-1 when absent)
    std::vector<std::array<int, 3>> minus1;
    std::vector<std::array<int, 6>> minus2;  // pairs (00,01,02,11,12,22)
    // M2L triples (k, m, k+m), grouped by k
    std::vector<std::int32_t> m2l_k, m2l_m, m2l_n;
    std::vector<std::int32_t> m2l_koff;  // triples of k are [m2l_koff[k], m2l_koff[k+1])
    // shift triples for M2M (target m, source m', delta index m-m') and L2L
    std::vector<std::int32_t> shift_to, shift_from, shift_delta;  // M2M
    std::vector<std::int32_t> l2l_to, l2l_from, l2l_delta;        // L2L

    explicit ExpansionTables(int order);
    int index(int i, int j, int k) const { return index_table[(i * (p + 1) + j) * (p + 1) + k]; }
    int coefs() const { return ncoef; }
};

// Scaled monomials y^m / m! for all |m| <= p.
void scaled_monomials(const ExpansionTables& tb, const double y[3], double* mono);

// Taylor coefficients a_n of g(d) = |d|^-4 at d, |n| <= p.
void g_taylor(const ExpansionTables& tb, const double d[3], double* a);

// Derivatives D^n T_ab(d) for |n| <= p, 6 symmetric components (00,01,02,11,12,22) per n.
void kernel_derivatives(const ExpansionTables& tb, const double d[3], double* D, double* work);

// Far-field operators (M, L: ncoef x 9 doubles).
void p2m(const ExpansionTables& tb, const double c[3], const double* px, const double* py,
         const double* pz, const double* nx, const double* ny, const double* nz, const double* A,
         const double* x, std::size_t count, double* M, double* work);
void m2m(const ExpansionTables& tb, const double delta[3], const double* Mchild, double* Mparent,
         double* work);
void m2l(const ExpansionTables& tb, const double R[3], const double* M, double* L, double* work);
void l2l(const ExpansionTables& tb, const double delta[3], const double* Lparent, double* Lchild,
         double* work);
// M2L from four sources at once (SIMD across sources): L += sum_q M2L(R[q], w4[q] M[q])
// (w4 == nullptr: every weight 1).
void m2l4(const ExpansionTables& tb, const double R[4][3], const double* const M[4], double* L,
          double* work, const double* w4 = nullptr);
// P2L: one source point (s9 = n A x, [b*3 + channel]) at offset R = c_t - r_j from the
// target centre, added to the target's local expansion.
void p2l(const ExpansionTables& tb, const double R[3], const double s9[9], double* L,
         double* work);
// M2P: the light vector at a point r from a multipole at c (R = r - c), 9 numbers.
void m2p(const ExpansionTables& tb, const double R[3], const double* M, double out[9],
         double* work);
// Evaluates the light vector L(c + y) (9 numbers: a*3 + channel).
void l2p(const ExpansionTables& tb, const double y[3], const double* L, double out[9],
         double* work);

// Work buffer size (doubles) the functions above need.
std::size_t expansion_work_size(const ExpansionTables& tb);  // enough for m2l4 too

}  // namespace illumap
