// splat_shading.cpp — least-squares gradients in each splat's plane, limited (see
// splat_shading.hpp and tests/core/splat_shading_reference.py, the numpy version).
#include "splats/splat_shading.hpp"

#include "geometry/knn.hpp"

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

// The shading of all points in `order` (input indices), each with its k neighbours given as
// positions in that order (local, n x k): on float64 copies in that order, so that a point's
// neighbours are near it in memory (in a scan's own order each of their reads would be a
// cache miss), written back to the input's order. geometry: points, normals, axes, scales,
// offsets (float32 as the preview keeps them, or float64).
template <class F>
void shade_in_order(Context& ctx, const F* const geometry[5], const double* values,
                    std::size_t n, std::size_t k, const std::int64_t* order,
                    const std::int64_t* local, const SplatShadingOptions& o, double* out) {
    std::vector<double> sorted[6];
    for (auto& a : sorted) a.resize(3 * n);
    std::vector<double> result(9 * n);
    parallel_for(ctx, n, 8192, [&](std::size_t b, std::size_t e) {
        for (int a = 0; a < 6; ++a)
            for (std::size_t t = b; t < e; ++t)
                for (int c = 0; c < 3; ++c)
                    sorted[a][3 * t + c] = a < 5 ? double(geometry[a][3 * order[t] + c])
                                                 : values[3 * order[t] + c];
    });
    parallel_for(ctx, n, 4096, [&](std::size_t b, std::size_t e) {
        std::vector<double> st_of;
        for (std::size_t t = b; t < e; ++t)
            shade(sorted[0].data(), sorted[1].data(), sorted[2].data(), sorted[3].data(),
                  sorted[4].data(), sorted[5].data(), t, local + k * t, k, o, st_of,
                  result.data() + 9 * t);
    });
    parallel_for(ctx, n, 8192, [&](std::size_t b, std::size_t e) {
        for (std::size_t t = b; t < e; ++t)
            std::copy(result.data() + 9 * t, result.data() + 9 * t + 9, out + 9 * order[t]);
    });
}

}  // namespace

namespace {

void check_search(std::size_t n, std::size_t k, const std::int64_t* order,
                  const std::int64_t* neighbours) {
    if (k < 1 || k + 1 > n) throw std::invalid_argument("splat_shading needs 1 <= k < n");
    for (std::size_t t = 0; t < n; ++t)
        if (order[t] < 0 || std::size_t(order[t]) >= n)
            throw std::out_of_range("order index out of range");
    for (std::size_t j = 0; j < n * k; ++j)
        if (neighbours[j] < 0 || std::size_t(neighbours[j]) >= n)
            throw std::out_of_range("neighbour index out of range");
}

}  // namespace

void splat_shading(Context& ctx, const float* points, const float* normals, const float* axes,
                   const float* scales, const float* offsets, const double* values,
                   std::size_t n, std::size_t k, const SplatShadingOptions& o, double* out,
                   const std::int64_t* order, const std::int64_t* neighbours) {
    if (!order || !neighbours) throw std::invalid_argument("splat_shading (float32) needs the search");
    check_search(n, k, order, neighbours);
    const float* const geometry[5] = {points, normals, axes, scales, offsets};
    ctx.set_phase("shading", 0.0, 1.0);
    shade_in_order(ctx, geometry, values, n, k, order, neighbours, o, out);
}

void splat_shading(Context& ctx, const double* points, const double* normals, const double* axes,
                   const double* scales, const double* offsets, const double* values,
                   std::size_t n, std::size_t k, const SplatShadingOptions& o, double* out,
                   const std::int64_t* order, const std::int64_t* neighbours) {
    if (k < 1 || k + 1 > n) throw std::invalid_argument("splat_shading needs 1 <= k < n");
    const double* const geometry[5] = {points, normals, axes, scales, offsets};
    if (order && neighbours) {
        check_search(n, k, order, neighbours);
        ctx.set_phase("shading", 0.0, 1.0);
        shade_in_order(ctx, geometry, values, n, k, order, neighbours, o, out);
        return;
    }
    // No neighbours given: the kd-tree's order and each point's k nearest others in it.
    ctx.set_phase("shading", 0.0, 0.3);
    checkpoint(ctx, 0.0);
    const KdTree tree(ctx, points, n);
    const std::vector<std::int64_t>& tree_order = tree.order();
    std::vector<std::int64_t> rank(n), local(n * k);
    for (std::size_t t = 0; t < n; ++t) rank[std::size_t(tree_order[t])] = std::int64_t(t);
    ctx.set_phase("shading", 0.3, 0.4);
    const double* sorted_points = tree.sorted_points().data();
    parallel_for(ctx, n, 2048, [&](std::size_t b, std::size_t e) {
        KdTree::Best best(k + 1);
        for (std::size_t t = b; t < e; ++t) {
            tree.nearest(sorted_points + 3 * t, best);
            for (std::size_t j = 0; j < k; ++j)  // the first: the point itself
                local[k * t + j] = rank[std::size_t(best.h[j + 1].second)];
        }
    });
    ctx.set_phase("shading", 0.7, 0.3);
    shade_in_order(ctx, geometry, values, n, k, tree_order.data(), local.data(), o, out);
}

}  // namespace illumap
