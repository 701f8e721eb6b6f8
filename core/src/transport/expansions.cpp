// expansions.cpp — multi-index tables, kernel derivatives and the six far-field operators.
#include "transport/expansions.hpp"

#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace illumap {

namespace {
constexpr int kSymA[6] = {0, 0, 0, 1, 1, 2};
constexpr int kSymB[6] = {0, 1, 2, 1, 2, 2};
}  // namespace

ExpansionTables::ExpansionTables(int order) : p(order) {
    if (order < 0 || order > kMaxOrder) throw std::invalid_argument(order_range_message());
    const int P = p + 1;
    index_table.assign(P * P * P, -1);
    for (int d = 0; d <= p; ++d)
        for (int i = d; i >= 0; --i)
            for (int j = d - i; j >= 0; --j) {
                const int k = d - i - j;
                index_table[(i * P + j) * P + k] = int(mi.size());
                mi.push_back({i, j, k});
                degree.push_back(d);
            }
    ncoef = int(mi.size());
    factorial.resize(ncoef);
    mono_pred.assign(ncoef, -1);
    mono_axis.assign(ncoef, 0);
    mono_scale.assign(ncoef, 1.0);
    minus1.resize(ncoef);
    minus2.resize(ncoef);
    auto idx = [&](int i, int j, int k) {
        return (i < 0 || j < 0 || k < 0) ? -1 : index(i, j, k);
    };
    auto fact = [](int n) { double f = 1; for (int i = 2; i <= n; ++i) f *= i; return f; };
    for (int c = 0; c < ncoef; ++c) {
        const auto& n = mi[c];
        factorial[c] = fact(n[0]) * fact(n[1]) * fact(n[2]);
        for (int a = 0; a < 3; ++a) {
            std::array<int, 3> q = n;
            q[a] -= 1;
            minus1[c][a] = idx(q[0], q[1], q[2]);
        }
        for (int s = 0; s < 6; ++s) {
            std::array<int, 3> q = n;
            q[kSymA[s]] -= 1;
            q[kSymB[s]] -= 1;
            minus2[c][s] = idx(q[0], q[1], q[2]);
        }
        if (c > 0) {
            int a = n[0] > 0 ? 0 : (n[1] > 0 ? 1 : 2);
            mono_axis[c] = a;
            mono_pred[c] = minus1[c][a];
            mono_scale[c] = 1.0 / n[a];
        }
    }
    // M2L: every (k, m) with |k| + |m| <= p.
    for (int k = 0; k < ncoef; ++k)
        for (int m = 0; m < ncoef; ++m) {
            const auto &a = mi[k], &b = mi[m];
            if (degree[k] + degree[m] > p) continue;
            m2l_k.push_back(k);
            m2l_m.push_back(m);
            m2l_n.push_back(index(a[0] + b[0], a[1] + b[1], a[2] + b[2]));
        }
    m2l_koff.assign(ncoef + 1, 0);
    for (std::int32_t k : m2l_k) m2l_koff[k + 1]++;
    for (int k = 0; k < ncoef; ++k) m2l_koff[k + 1] += m2l_koff[k];
    // Shifts: every (big, small) with small <= big componentwise.
    for (int big = 0; big < ncoef; ++big)
        for (int sm = 0; sm < ncoef; ++sm) {
            const auto &a = mi[big], &b = mi[sm];
            if (b[0] > a[0] || b[1] > a[1] || b[2] > a[2]) continue;
            const int dlt = index(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
            shift_to.push_back(big); shift_from.push_back(sm); shift_delta.push_back(dlt);
            l2l_to.push_back(sm); l2l_from.push_back(big); l2l_delta.push_back(dlt);
        }
}

std::size_t expansion_work_size(const ExpansionTables& tb) { return 64 * std::size_t(tb.ncoef) + 16; }

void scaled_monomials(const ExpansionTables& tb, const double y[3], double* mono) {
    mono[0] = 1.0;
    for (int c = 1; c < tb.ncoef; ++c)
        mono[c] = mono[tb.mono_pred[c]] * y[tb.mono_axis[c]] * tb.mono_scale[c];
}

void g_taylor(const ExpansionTables& tb, const double d[3], double* a) {
    const double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    const double inv_r2 = 1.0 / r2;
    a[0] = inv_r2 * inv_r2;
    // |n| r^2 a_n = -(2|n|+2) sum_j d_j a_{n-e_j} - (|n|+2) sum_j a_{n-2e_j}
    for (int c = 1; c < tb.ncoef; ++c) {
        const int nn = tb.degree[c];
        double s1 = 0, s2 = 0;
        for (int j = 0; j < 3; ++j) {
            const int q1 = tb.minus1[c][j];
            if (q1 >= 0) s1 += d[j] * a[q1];
        }
        for (int s : {0, 3, 5}) {
            const int q2 = tb.minus2[c][s];
            if (q2 >= 0) s2 += a[q2];
        }
        a[c] = (-(2.0 * nn + 2.0) * s1 - (nn + 2.0) * s2) * inv_r2 / nn;
    }
}

void kernel_derivatives(const ExpansionTables& tb, const double d[3], double* D, double* work) {
    double* a = work;
    g_taylor(tb, d, a);
    // tau_n^{ab} = d_a d_b a_n + d_a a_{n-e_b} + d_b a_{n-e_a} + a_{n-e_a-e_b};  D = n! tau
    for (int c = 0; c < tb.ncoef; ++c) {
        const auto& m1 = tb.minus1[c];
        const auto& m2 = tb.minus2[c];
        const double f = tb.factorial[c];
        for (int s = 0; s < 6; ++s) {
            const int A = kSymA[s], B = kSymB[s];
            double t = d[A] * d[B] * a[c];
            if (m1[B] >= 0) t += d[A] * a[m1[B]];
            if (m1[A] >= 0) t += d[B] * a[m1[A]];
            if (m2[s] >= 0) t += a[m2[s]];
            D[6 * c + s] = f * t;
        }
    }
}

void p2m(const ExpansionTables& tb, const double c[3], const double* px, const double* py,
         const double* pz, const double* nx, const double* ny, const double* nz, const double* A,
         const double* x, std::size_t count, double* M, double* work) {
    double* mono = work;
    for (std::size_t i = 0; i < count; ++i) {
        const double w[3] = {c[0] - px[i], c[1] - py[i], c[2] - pz[i]};
        scaled_monomials(tb, w, mono);
        const double nA[3] = {nx[i] * A[i], ny[i] * A[i], nz[i] * A[i]};
        double s[9];
        for (int b = 0; b < 3; ++b)
            for (int ch = 0; ch < 3; ++ch) s[3 * b + ch] = nA[b] * x[3 * i + ch];
        for (int q = 0; q < tb.ncoef; ++q) {
            const double mq = mono[q];
            double* Mq = M + 9 * q;
            for (int e = 0; e < 9; ++e) Mq[e] += mq * s[e];
        }
    }
}

void m2m(const ExpansionTables& tb, const double delta[3], const double* Mc, double* Mp,
         double* work) {
    double* mono = work;
    scaled_monomials(tb, delta, mono);
    const std::size_t nt = tb.shift_to.size();
    for (std::size_t t = 0; t < nt; ++t) {
        const double f = mono[tb.shift_delta[t]];
        const double* src = Mc + 9 * tb.shift_from[t];
        double* dst = Mp + 9 * tb.shift_to[t];
        for (int e = 0; e < 9; ++e) dst[e] += f * src[e];
    }
}

__attribute__((target_clones("avx2", "default")))
void m2l(const ExpansionTables& tb, const double R[3], const double* __restrict M,
         double* __restrict L, double* work) {
    double* D = work + tb.ncoef;  // 6 per coefficient
    kernel_derivatives(tb, R, D, work);
    const std::int32_t* Mi = tb.m2l_m.data();
    const std::int32_t* Ni = tb.m2l_n.data();
    // For each local coefficient k, accumulate sum_m D_{k+m} M_m in registers (9 numbers),
    // then add once: 15 loads per 27 multiply-adds.
    for (int k = 0; k < tb.ncoef; ++k) {
        double l0 = 0, l1 = 0, l2 = 0, l3 = 0, l4 = 0, l5 = 0, l6 = 0, l7 = 0, l8 = 0;
        for (std::int32_t t = tb.m2l_koff[k]; t < tb.m2l_koff[k + 1]; ++t) {
            const double* d = D + 6 * Ni[t];
            const double* m = M + 9 * Mi[t];
            const double d00 = d[0], d01 = d[1], d02 = d[2], d11 = d[3], d12 = d[4], d22 = d[5];
            const double a0 = m[0], a1 = m[1], a2 = m[2];
            const double b0 = m[3], b1 = m[4], b2 = m[5];
            const double c0 = m[6], c1 = m[7], c2 = m[8];
            l0 += d00 * a0 + d01 * b0 + d02 * c0;
            l1 += d00 * a1 + d01 * b1 + d02 * c1;
            l2 += d00 * a2 + d01 * b2 + d02 * c2;
            l3 += d01 * a0 + d11 * b0 + d12 * c0;
            l4 += d01 * a1 + d11 * b1 + d12 * c1;
            l5 += d01 * a2 + d11 * b2 + d12 * c2;
            l6 += d02 * a0 + d12 * b0 + d22 * c0;
            l7 += d02 * a1 + d12 * b1 + d22 * c1;
            l8 += d02 * a2 + d12 * b2 + d22 * c2;
        }
        double* l = L + 9 * k;
        l[0] += l0; l[1] += l1; l[2] += l2; l[3] += l3; l[4] += l4;
        l[5] += l5; l[6] += l6; l[7] += l7; l[8] += l8;
    }
}

namespace {
// Four lanes of doubles (GCC vector extension): one lane per source in m2l4. Element access
// and arithmetic are lane-wise; each clone of m2l4 below compiles them for its own ISA.
typedef double V4 __attribute__((vector_size(32)));

inline __attribute__((always_inline)) void m2l4_body(const ExpansionTables& tb,
                                                     const double R[4][3],
                                                     const double* const M[4],
                                                     const double* w4,
                                                     double* __restrict L, double* work) {
    const int nc = tb.ncoef;
    // Lane-interleaved copies: Dv[6 n + s], Mv[9 m + e], a[n] (g's Taylor coefficients),
    // each a vector of the four sources. work is 8-byte aligned: align it to 32.
    const std::uintptr_t base = (reinterpret_cast<std::uintptr_t>(work) + 31) & ~std::uintptr_t(31);
    V4* __restrict Dv = reinterpret_cast<V4*>(base);  // 6 nc
    V4* __restrict Mv = Dv + 6 * nc;                   // 9 nc
    V4* __restrict a = Mv + 9 * nc;                    // nc
    const double *M0 = M[0], *M1 = M[1], *M2 = M[2], *M3 = M[3];
    if (w4) {
        const V4 w = {w4[0], w4[1], w4[2], w4[3]};
        for (int i = 0; i < 9 * nc; ++i) Mv[i] = V4{M0[i], M1[i], M2[i], M3[i]} * w;
    } else {
        for (int i = 0; i < 9 * nc; ++i) Mv[i] = V4{M0[i], M1[i], M2[i], M3[i]};
    }
    // Kernel derivatives for the four lanes together (same recurrence as kernel_derivatives).
    V4 dx[3];
    for (int d = 0; d < 3; ++d) dx[d] = V4{R[0][d], R[1][d], R[2][d], R[3][d]};
    const V4 inv_r2 = 1.0 / (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]);
    a[0] = inv_r2 * inv_r2;
    for (int c = 1; c < nc; ++c) {
        const double nn = tb.degree[c];
        const double c1 = -(2.0 * nn + 2.0) / nn, c2 = -(nn + 2.0) / nn;
        V4 s1 = {0, 0, 0, 0}, s2 = {0, 0, 0, 0};
        for (int j = 0; j < 3; ++j) {
            const int q1 = tb.minus1[c][j];
            if (q1 >= 0) s1 += dx[j] * a[q1];
        }
        for (int sidx : {0, 3, 5}) {
            const int q2 = tb.minus2[c][sidx];
            if (q2 >= 0) s2 += a[q2];
        }
        a[c] = (c1 * s1 + c2 * s2) * inv_r2;
    }
    for (int c = 0; c < nc; ++c) {
        const auto& m1 = tb.minus1[c];
        const auto& m2 = tb.minus2[c];
        const double f = tb.factorial[c];
        for (int sidx = 0; sidx < 6; ++sidx) {
            const int A = kSymA[sidx], B = kSymB[sidx];
            V4 t = dx[A] * dx[B] * a[c];
            if (m1[B] >= 0) t += dx[A] * a[m1[B]];
            if (m1[A] >= 0) t += dx[B] * a[m1[A]];
            if (m2[sidx] >= 0) t += a[m2[sidx]];
            Dv[6 * c + sidx] = f * t;
        }
    }
    const std::int32_t* Mi = tb.m2l_m.data();
    const std::int32_t* Ni = tb.m2l_n.data();
    for (int k = 0; k < nc; ++k) {
        V4 acc[9];
        for (V4& x : acc) x = V4{0, 0, 0, 0};
        for (std::int32_t t = tb.m2l_koff[k]; t < tb.m2l_koff[k + 1]; ++t) {
            const V4* d = Dv + 6 * Ni[t];
            const V4* m = Mv + 9 * Mi[t];
            const V4 d00 = d[0], d01 = d[1], d02 = d[2], d11 = d[3], d12 = d[4], d22 = d[5];
            for (int ch = 0; ch < 3; ++ch) {
                const V4 x = m[ch], y = m[3 + ch], z = m[6 + ch];
                acc[ch] += d00 * x + d01 * y + d02 * z;
                acc[3 + ch] += d01 * x + d11 * y + d12 * z;
                acc[6 + ch] += d02 * x + d12 * y + d22 * z;
            }
        }
        double* l = L + 9 * k;
        for (int e = 0; e < 9; ++e) l[e] += (acc[e][0] + acc[e][1]) + (acc[e][2] + acc[e][3]);
    }
}
}  // namespace

// SIMD across the four sources. The x86-64-v4 clone (AVX-512 encodings: 32 vector registers,
// so the nine accumulators, six derivatives and three moments stay in registers) and the v3
// clone (AVX2 + FMA) contract with fused multiply-adds.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "avx2", "default")))
void m2l4(const ExpansionTables& tb, const double R[4][3], const double* const M[4],
          double* __restrict L, double* work, const double* w4) {
    m2l4_body(tb, R, M, w4, L, work);
}

void p2l(const ExpansionTables& tb, const double R[3], const double s9[9], double* L,
         double* work) {
    double* D = work + tb.ncoef;
    kernel_derivatives(tb, R, D, work);
    for (int k = 0; k < tb.ncoef; ++k) {
        const double* d = D + 6 * k;
        double* l = L + 9 * k;
        for (int ch = 0; ch < 3; ++ch) {
            const double a = s9[ch], b = s9[3 + ch], c = s9[6 + ch];
            l[ch] += d[0] * a + d[1] * b + d[2] * c;
            l[3 + ch] += d[1] * a + d[3] * b + d[4] * c;
            l[6 + ch] += d[2] * a + d[4] * b + d[5] * c;
        }
    }
}

void m2p(const ExpansionTables& tb, const double R[3], const double* M, double out[9],
         double* work) {
    double* D = work + tb.ncoef;
    kernel_derivatives(tb, R, D, work);
    for (int e = 0; e < 9; ++e) out[e] = 0;
    for (int m = 0; m < tb.ncoef; ++m) {
        const double* d = D + 6 * m;
        const double* mm = M + 9 * m;
        for (int ch = 0; ch < 3; ++ch) {
            const double a = mm[ch], b = mm[3 + ch], c = mm[6 + ch];
            out[ch] += d[0] * a + d[1] * b + d[2] * c;
            out[3 + ch] += d[1] * a + d[3] * b + d[4] * c;
            out[6 + ch] += d[2] * a + d[4] * b + d[5] * c;
        }
    }
}

void l2l(const ExpansionTables& tb, const double delta[3], const double* Lp, double* Lc,
         double* work) {
    double* mono = work;
    scaled_monomials(tb, delta, mono);
    const std::size_t nt = tb.l2l_to.size();
    for (std::size_t t = 0; t < nt; ++t) {
        const double f = mono[tb.l2l_delta[t]];
        const double* src = Lp + 9 * tb.l2l_from[t];
        double* dst = Lc + 9 * tb.l2l_to[t];
        for (int e = 0; e < 9; ++e) dst[e] += f * src[e];
    }
}

void l2p(const ExpansionTables& tb, const double y[3], const double* L, double out[9],
         double* work) {
    double* mono = work;
    scaled_monomials(tb, y, mono);
    for (int e = 0; e < 9; ++e) out[e] = 0;
    for (int q = 0; q < tb.ncoef; ++q) {
        const double mq = mono[q];
        for (int e = 0; e < 9; ++e) out[e] += mq * L[9 * q + e];
    }
}

}  // namespace illumap
