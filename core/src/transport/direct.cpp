// direct.cpp — exact O(N^2) operator, multithreaded over receivers.
#include "transport/direct.hpp"

#include <vector>

namespace illumap {

namespace {
// acc += sum_j weight(j) F_ij x_j; inlined into each target clone below so that both loops
// vectorise (weight is a constant 1 or a visibility byte).
template <class Weight>
inline __attribute__((always_inline)) void accumulate_loop(const Receiver& rc,
                                                           const SourceView& v, Weight weight,
                                                           double acc[3]) {
    const double px = rc.px, py = rc.py, pz = rc.pz;
    const double nix = rc.nx, niy = rc.ny, niz = rc.nz;
    const double *__restrict qx = v.px, *__restrict qy = v.py, *__restrict qz = v.pz;
    const double *__restrict mx = v.nx, *__restrict my = v.ny, *__restrict mz = v.nz,
                 *__restrict A = v.area;
    const double *__restrict x0 = v.x0, *__restrict x1 = v.x1, *__restrict x2 = v.x2;
    double a0 = 0, a1 = 0, a2 = 0;
    const std::size_t n = v.n;
    for (std::size_t j = 0; j < n; ++j) {
        const double f = weight(j) * pair_factor(px - qx[j], py - qy[j], pz - qz[j], nix, niy,
                                                 niz, mx[j], my[j], mz[j], A[j]);
        a0 += f * x0[j];
        a1 += f * x1[j];
        a2 += f * x2[j];
    }
    acc[0] += a0;
    acc[1] += a1;
    acc[2] += a2;
}

__attribute__((target_clones("avx2", "default")))
void accumulate_impl(const Receiver& rc, const SourceView& v, double acc[3]) {
    accumulate_loop(rc, v, [](std::size_t) { return 1.0; }, acc);
}

// Per-pair visibility blocks (V = w/255), branch-free like the unweighted loop: in occluded
// scenes they are most of the near field.
__attribute__((target_clones("avx2", "default")))
void accumulate_weighted_impl(const Receiver& rc, const SourceView& v,
                              const std::uint8_t* __restrict w, double acc[3]) {
    double sum[3] = {0, 0, 0};
    accumulate_loop(rc, v, [w](std::size_t j) { return double(w[j]); }, sum);
    constexpr double kInvLevels = 1.0 / kVisLevels;
    acc[0] += sum[0] * kInvLevels;
    acc[1] += sum[1] * kInvLevels;
    acc[2] += sum[2] * kInvLevels;
}
}  // namespace

void accumulate_sources(const Receiver& r, const SourceView& v, double acc[3]) {
    accumulate_impl(r, v, acc);
}

void accumulate_sources_weighted(const Receiver& r, const SourceView& v,
                                 const std::uint8_t* weights, double acc[3]) {
    accumulate_weighted_impl(r, v, weights, acc);
}

void direct_rows(Context& ctx, const SurfelSoA& s, const double* x,
                 const std::int64_t* rows, std::size_t nrows, double* y) {
    const std::size_t n = s.n;
    // Source values in SoA so the inner loop streams three contiguous arrays.
    std::vector<double> x0(n), x1(n), x2(n);
    for (std::size_t j = 0; j < n; ++j) {
        x0[j] = x[3 * j];
        x1[j] = x[3 * j + 1];
        x2[j] = x[3 * j + 2];
    }
    const SourceView src{s.px.data(), s.py.data(), s.pz.data(), s.nx.data(), s.ny.data(),
                         s.nz.data(), s.area.data(), x0.data(), x1.data(), x2.data(), n};
    const std::size_t grain = std::max<std::size_t>(1, std::min<std::size_t>(64, (1u << 22) / (n + 1)));
    parallel_for(ctx, nrows, grain, [&](std::size_t b, std::size_t e) {
        for (std::size_t r = b; r < e; ++r) {
            if (ctx.cancel.load(std::memory_order_relaxed)) return;
            double acc[3] = {0, 0, 0};
            const std::size_t i = std::size_t(rows[r]);
            const Receiver rc{s.px[i], s.py[i], s.pz[i], s.nx[i], s.ny[i], s.nz[i], s.area[i]};
            accumulate_sources(rc, src, acc);
            y[3 * r] = acc[0];
            y[3 * r + 1] = acc[1];
            y[3 * r + 2] = acc[2];
        }
    });
}

void direct_apply(Context& ctx, const SurfelSoA& s, const double* x, double* y) {
    std::vector<std::int64_t> rows(s.n);
    for (std::size_t i = 0; i < s.n; ++i) rows[i] = std::int64_t(i);
    direct_rows(ctx, s, x, rows.data(), s.n, y);
}

}  // namespace illumap
