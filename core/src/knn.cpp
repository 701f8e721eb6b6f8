// knn.cpp — kd-tree (median splits on the widest axis) and best-first-by-side k-NN queries.
#include "knn.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>
#include <vector>

namespace illumap {

KdTree::KdTree(const double* p, std::size_t n) : idx(n), pts(3 * n) {
    std::iota(idx.begin(), idx.end(), 0);
    nodes.reserve(2 * (n / kLeaf + 1));
    build(p, 0, std::uint32_t(n));
    for (std::size_t i = 0; i < n; ++i)
        for (int d = 0; d < 3; ++d) pts[3 * i + d] = p[3 * idx[i] + d];
}

std::int32_t KdTree::build(const double* p, std::uint32_t b, std::uint32_t e) {
    std::int32_t id = std::int32_t(nodes.size());
    nodes.push_back(Node{b, e});
    if (e - b <= kLeaf) return id;
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (std::uint32_t i = b; i < e; ++i)
        for (int d = 0; d < 3; ++d) {
            double v = p[3 * idx[i] + d];
            lo[d] = std::min(lo[d], v);
            hi[d] = std::max(hi[d], v);
        }
    int dim = 0;
    for (int d = 1; d < 3; ++d)
        if (hi[d] - lo[d] > hi[dim] - lo[dim]) dim = d;
    if (!(hi[dim] > lo[dim])) return id;  // all coincident: keep as a (large) leaf
    std::uint32_t mid = b + (e - b) / 2;
    std::nth_element(idx.begin() + b, idx.begin() + mid, idx.begin() + e,
                     [&](std::int64_t u, std::int64_t v) { return p[3 * u + dim] < p[3 * v + dim]; });
    double split = p[3 * idx[mid] + dim];
    std::int32_t l = build(p, b, mid);
    std::int32_t r = build(p, mid, e);
    nodes[id].left = l;
    nodes[id].right = r;
    nodes[id].dim = dim;
    nodes[id].split = split;
    return id;
}

void KdTree::Best::offer(double d2, std::int64_t i) {
    if (h.size() < k) {
        h.emplace_back(d2, i);
        std::push_heap(h.begin(), h.end());
    } else if (d2 < h.front().first) {
        std::pop_heap(h.begin(), h.end());
        h.back() = {d2, i};
        std::push_heap(h.begin(), h.end());
    }
}

void KdTree::search(std::int32_t id, const double q[3], Best& best) const {
    const Node& nd = nodes[id];
    if (nd.left < 0) {
        for (std::uint32_t i = nd.begin; i < nd.end; ++i) {
            const double* p = &pts[3 * i];
            double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
            best.offer(dx * dx + dy * dy + dz * dz, idx[i]);
        }
        return;
    }
    double diff = q[nd.dim] - nd.split;
    std::int32_t near = diff < 0 ? nd.left : nd.right, far = diff < 0 ? nd.right : nd.left;
    search(near, q, best);
    if (diff * diff <= best.worst()) search(far, q, best);
}

void KdTree::nearest(const double q[3], Best& best) const {
    best.h.clear();
    if (!nodes.empty()) search(0, q, best);
    std::sort_heap(best.h.begin(), best.h.end());
}

void knn(Context& ctx, const double* points, std::size_t n, const double* queries, std::size_t m,
         std::size_t k, std::int64_t* indices, double* distances) {
    KdTree tree(points, n);
    // Visit queries in Morton order: neighbouring queries touch the same tree nodes, so the
    // tree stays in cache (random query order is several times slower at millions of points).
    std::vector<std::uint64_t> key(m);
    std::vector<std::size_t> order(m);
    {
        double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
        for (std::size_t i = 0; i < m; ++i)
            for (int d = 0; d < 3; ++d) {
                lo[d] = std::min(lo[d], queries[3 * i + d]);
                hi[d] = std::max(hi[d], queries[3 * i + d]);
            }
        const double ext = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-300});
        auto spread = [](std::uint64_t v) {
            std::uint64_t r = 0;
            for (int b = 0; b < 21; ++b) r |= ((v >> b) & 1u) << (3 * b);
            return r;
        };
        for (std::size_t i = 0; i < m; ++i) {
            std::uint64_t c[3];
            for (int d = 0; d < 3; ++d) {
                const double v = (queries[3 * i + d] - lo[d]) / ext * 2097151.0;
                c[d] = std::uint64_t(std::min(2097151.0, std::max(0.0, v)));
            }
            key[i] = spread(c[0]) << 2 | spread(c[1]) << 1 | spread(c[2]);
        }
        std::iota(order.begin(), order.end(), std::size_t(0));
        std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return key[a] < key[b]; });
    }
    parallel_for(ctx, m, 256, [&](std::size_t b, std::size_t e) {
        KdTree::Best best(k);
        for (std::size_t oi = b; oi < e; ++oi) {
            const std::size_t qi = order[oi];
            tree.nearest(&queries[3 * qi], best);
            for (std::size_t r = 0; r < k; ++r) {
                indices[qi * k + r] = best.h[r].second;
                distances[qi * k + r] = std::sqrt(best.h[r].first);
            }
        }
    });
}

}  // namespace illumap
