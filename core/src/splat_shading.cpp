// splat_shading.cpp — least-squares gradients in each splat's plane, limited (see
// splat_shading.hpp and tests/core/splat_shading_reference.py, the numpy version).
#include "splat_shading.hpp"

#include "knn.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace illumap {

namespace {

double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// One point's shading from its neighbours `nb` (count of them): out (9).
void shade(const double* points, const double* normals, const double* axes, const double* scales,
           const double* offsets, const double* values, std::size_t i, const std::int64_t* nb,
           std::size_t count, const SplatShadingOptions& o, std::vector<double>& st_of,
           double* out) {
    const double* p = points + 3 * i;
    const double* nv = normals + 3 * i;
    const double* ax = axes + 3 * i;
    const double across[3] = {nv[1] * ax[2] - nv[2] * ax[1], nv[2] * ax[0] - nv[0] * ax[2],
                              nv[0] * ax[1] - nv[1] * ax[0]};
    const double* v = values + 3 * i;
    st_of.assign(2 * count, 0.0);
    double ss = 0, st = 0, tt = 0, bs[3] = {0, 0, 0}, bt[3] = {0, 0, 0};
    double hi[3] = {v[0], v[1], v[2]}, lo[3] = {v[0], v[1], v[2]};
    double same = 0;
    for (std::size_t j = 0; j < count; ++j) {
        const std::size_t q = std::size_t(nb[j]);
        if (std::fabs(dot3(nv, normals + 3 * q)) < o.edge_cos) continue;
        const double d[3] = {points[3 * q] - p[0], points[3 * q + 1] - p[1],
                             points[3 * q + 2] - p[2]};
        const double s = dot3(d, ax), t = dot3(d, across);
        st_of[2 * j] = s, st_of[2 * j + 1] = t;
        ss += s * s, st += s * t, tt += t * t;
        for (int c = 0; c < 3; ++c) {
            const double vq = values[3 * q + c];
            bs[c] += s * (vq - v[c]), bt[c] += t * (vq - v[c]);
            hi[c] = std::max(hi[c], vq), lo[c] = std::min(lo[c], vq);
        }
        same += 1;
    }
    const double ridge = o.ridge * (ss + tt) / std::max(same, 1.0) + 1e-300;
    ss += ridge, tt += ridge;
    const double det = ss * tt - st * st;
    const bool fitted = same >= 2 && det > 0;
    const double* off = offsets + 3 * i;
    const double off_s = dot3(off, ax), off_t = dot3(off, across);
    for (int c = 0; c < 3; ++c) {
        double gs = fitted ? (tt * bs[c] - st * bt[c]) / det : 0.0;
        double gt = fitted ? (ss * bt[c] - st * bs[c]) / det : 0.0;
        // The limit: half-way to each neighbour the function stays within [lo, hi].
        double phi = 1.0;
        for (std::size_t j = 0; j < count; ++j) {
            const double half = 0.5 * (gs * st_of[2 * j] + gt * st_of[2 * j + 1]);
            if (half > 0) phi = std::min(phi, (hi[c] - v[c]) / std::max(half, 1e-300));
            if (half < 0) phi = std::min(phi, (v[c] - lo[c]) / std::max(-half, 1e-300));
        }
        phi = std::min(1.0, std::max(0.0, phi));
        gs *= phi, gt *= phi;
        out[c] = v[c] + gs * off_s + gt * off_t;
        out[3 + c] = gs * scales[3 * i];
        out[6 + c] = gt * scales[3 * i + 1];
    }
}

}  // namespace

void splat_shading(Context& ctx, const double* points, const double* normals, const double* axes,
                   const double* scales, const double* offsets, const double* values,
                   std::size_t n, std::size_t k, const SplatShadingOptions& o, double* out) {
    if (k < 1 || k + 1 > n) throw std::invalid_argument("splat_shading needs 1 <= k < n");
    ctx.set_phase("shading", 0.0, 0.3);
    checkpoint(ctx, 0.0);
    const KdTree tree(ctx, points, n);
    const std::vector<std::int64_t>& order = tree.order();  // visit in the tree's order (cache)
    ctx.set_phase("shading", 0.3, 0.7);
    parallel_for(ctx, n, 2048, [&](std::size_t b, std::size_t e) {
        KdTree::Best best(k + 1);
        std::vector<std::int64_t> nb(k);
        std::vector<double> st_of;
        for (std::size_t t = b; t < e; ++t) {
            const std::size_t i = std::size_t(order[t]);
            tree.nearest(points + 3 * i, best);
            for (std::size_t j = 0; j < k; ++j) nb[j] = best.h[j + 1].second;  // the first: itself
            shade(points, normals, axes, scales, offsets, values, i, nb.data(), k, o, st_of,
                  out + 9 * i);
        }
    });
}

}  // namespace illumap
