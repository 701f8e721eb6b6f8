// knn.cpp — kd-tree (median splits on the widest axis) and best-first-by-side k-NN queries.
#include "geometry/knn.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>
#include <vector>

namespace illumap {

namespace {

// The items the build sorts: each point with its input index. nth_element moves them as it
// would move bare indices compared through the points (the same comparisons, the same
// swaps), so the tree is the same, but each comparison reads the item at hand instead of a
// point somewhere in memory.
std::vector<KdTree::Item> items_of(Context* ctx, const double* p, std::size_t n) {
    std::vector<KdTree::Item> items(n);
    auto fill = [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i)
            items[i] = KdTree::Item{{p[3 * i], p[3 * i + 1], p[3 * i + 2]}, std::int64_t(i)};
    };
    if (ctx)
        parallel_for(*ctx, n, 65536, fill);
    else
        fill(0, n);
    return items;
}

}  // namespace

KdTree::KdTree(const double* p, std::size_t n) : idx(n), pts(3 * n) {
    std::vector<Item> items = items_of(nullptr, p, n);
    nodes.reserve(2 * (n / kLeaf + 1));
    build(items, nodes, 0, std::uint32_t(n), 0, nullptr);
    unpack(nullptr, items);
}

KdTree::KdTree(Context& ctx, const double* p, std::size_t n) : idx(n), pts(3 * n) {
    std::vector<Item> items = items_of(&ctx, p, n);
    nodes.reserve(2 * (n / kLeaf + 1));
    // The top levels serially, down to about four subtrees per worker (median splits: of
    // equal size, so the workers share them evenly); each subtree then on its own, into its
    // own nodes, spliced in afterwards. Each subtree's range of items is its own, and every
    // split is the same nth_element on the same range as in the serial build.
    const int threads = ctx.nthreads();
    int depth = 0;
    while (threads > 1 && (1 << depth) < 4 * threads && (n >> depth) > 16384) ++depth;
    std::vector<Subtree> tasks;
    build(items, nodes, 0, std::uint32_t(n), depth, depth > 0 ? &tasks : nullptr);
    std::vector<std::vector<Node>> sub(tasks.size());
    parallel_for(ctx, tasks.size(), 1, [&](std::size_t b, std::size_t e) {
        for (std::size_t t = b; t < e; ++t)
            build(items, sub[t], tasks[t].begin, tasks[t].end, 0, nullptr);
    });
    for (std::size_t t = 0; t < tasks.size(); ++t) {
        // The subtree's root takes its placeholder's place; its other nodes follow the tree's.
        const std::int32_t shift = std::int32_t(nodes.size()) - 1;
        auto moved = [&](Node nd) {
            if (nd.left >= 0) nd.left += shift, nd.right += shift;
            return nd;
        };
        nodes[tasks[t].node] = moved(sub[t][0]);
        for (std::size_t j = 1; j < sub[t].size(); ++j) nodes.push_back(moved(sub[t][j]));
    }
    unpack(&ctx, items);
}

void KdTree::unpack(Context* ctx, const std::vector<Item>& items) {
    auto copy = [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
            idx[i] = items[i].index;
            for (int d = 0; d < 3; ++d) pts[3 * i + d] = items[i].x[d];
        }
    };
    if (ctx)
        parallel_for(*ctx, items.size(), 65536, copy);
    else
        copy(0, items.size());
}

std::int32_t KdTree::build(std::vector<Item>& items, std::vector<Node>& out, std::uint32_t b,
                           std::uint32_t e, int depth, std::vector<Subtree>* tasks) {
    std::int32_t id = std::int32_t(out.size());
    out.push_back(Node{b, e});
    if (e - b <= kLeaf) return id;
    if (tasks && depth == 0) {
        tasks->push_back(Subtree{id, b, e});
        return id;
    }
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (std::uint32_t i = b; i < e; ++i)
        for (int d = 0; d < 3; ++d) {
            double v = items[i].x[d];
            lo[d] = std::min(lo[d], v);
            hi[d] = std::max(hi[d], v);
        }
    int dim = 0;
    for (int d = 1; d < 3; ++d)
        if (hi[d] - lo[d] > hi[dim] - lo[dim]) dim = d;
    if (!(hi[dim] > lo[dim])) return id;  // all coincident: keep as a (large) leaf
    std::uint32_t mid = b + (e - b) / 2;
    std::nth_element(items.begin() + b, items.begin() + mid, items.begin() + e,
                     [dim](const Item& u, const Item& v) { return u.x[dim] < v.x[dim]; });
    double split = items[mid].x[dim];
    std::int32_t l = build(items, out, b, mid, depth - 1, tasks);
    std::int32_t r = build(items, out, mid, e, depth - 1, tasks);
    out[id].left = l;
    out[id].right = r;
    out[id].dim = dim;
    out[id].split = split;
    return id;
}

void KdTree::search(std::int32_t id, const double q[3], Best& best, double rd,
                    double off[3]) const {
    const Node& nd = nodes[id];
    if (nd.left < 0) {
        double worst = best.worst();
        for (std::uint32_t i = nd.begin; i < nd.end; ++i) {
            const double* p = &pts[3 * i];
            double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
            const double d2 = dx * dx + dy * dy + dz * dz;
            if (d2 <= worst && best.takes(d2, idx[i])) {  // what offer would take
                best.offer(d2, idx[i]);
                worst = best.worst();
            }
        }
        return;
    }
    double diff = q[nd.dim] - nd.split;
    std::int32_t near = diff < 0 ? nd.left : nd.right, far = diff < 0 ? nd.right : nd.left;
    search(near, q, best, rd, off);
    // The far side only if its cell may hold a point nearer than the worst kept: every point
    // there is at least rd_far away, and offer refuses any point not nearer than the worst,
    // so skipping it changes nothing (the margin covers rd_far's rounding).
    const double old = off[nd.dim];
    const double rd_far = rd - old * old + diff * diff;
    if (rd_far <= best.worst() * (1.0 + 1e-9)) {
        off[nd.dim] = diff;
        search(far, q, best, rd_far, off);
        off[nd.dim] = old;
    }
}

void KdTree::nearest(const double q[3], Best& best) const {
    best.h.clear();
    double off[3] = {0.0, 0.0, 0.0};
    if (!nodes.empty()) search(0, q, best, 0.0, off);
}

std::vector<std::size_t> morton_order(const double* queries, std::size_t m) {
    // 10 bits an axis (a grid of 1024^3 over the queries' box) orders them as coherently as
    // more would for a tree's cache; a stable radix sort of the 30-bit keys, three passes of
    // 10 bits, takes a tenth of the time the comparison sort of 63-bit keys took.
    constexpr int kBits = 10;
    constexpr std::uint32_t kCells = 1u << kBits;
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (std::size_t i = 0; i < m; ++i)
        for (int d = 0; d < 3; ++d) {
            lo[d] = std::min(lo[d], queries[3 * i + d]);
            hi[d] = std::max(hi[d], queries[3 * i + d]);
        }
    const double ext = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-300});
    auto spread = [](std::uint32_t v) {  // bit b of v to bit 3b
        v &= 0x3ffu;
        v = (v | (v << 16)) & 0x030000ffu;
        v = (v | (v << 8)) & 0x0300f00fu;
        v = (v | (v << 4)) & 0x030c30c3u;
        v = (v | (v << 2)) & 0x09249249u;
        return v;
    };
    std::vector<std::uint32_t> key(m), key_next(m);
    std::vector<std::size_t> order(m), next(m);
    for (std::size_t i = 0; i < m; ++i) {
        std::uint32_t c[3];
        for (int d = 0; d < 3; ++d) {
            const double v = (queries[3 * i + d] - lo[d]) / ext * double(kCells - 1);
            c[d] = std::uint32_t(std::min(double(kCells - 1), std::max(0.0, v)));
        }
        key[i] = spread(c[0]) << 2 | spread(c[1]) << 1 | spread(c[2]);
        order[i] = i;
    }
    std::vector<std::size_t> count(kCells + 1);
    for (int pass = 0; pass < 3; ++pass) {
        const int shift = pass * kBits;
        std::fill(count.begin(), count.end(), 0);
        for (std::size_t i = 0; i < m; ++i) ++count[((key[i] >> shift) & (kCells - 1)) + 1];
        for (std::uint32_t c = 0; c < kCells; ++c) count[c + 1] += count[c];
        for (std::size_t i = 0; i < m; ++i) {
            const std::size_t at = count[(key[i] >> shift) & (kCells - 1)]++;
            next[at] = order[i];
            key_next[at] = key[i];
        }
        order.swap(next);
        key.swap(key_next);
    }
    return order;
}

void knn(Context& ctx, const double* points, std::size_t n, const double* queries, std::size_t m,
         std::size_t k, std::int64_t* indices, double* distances) {
    KdTree tree(ctx, points, n);
    // The points' own search (queries = points, the scans' spacing, normals and splats) visits
    // them in the tree's order, as coherent as Morton order and already at hand.
    const bool own = m == n && (queries == points ||
                                std::equal(queries, queries + 3 * m, points));
    std::vector<std::size_t> order;
    if (own) {
        order.resize(m);
        const std::vector<std::int64_t>& tree_order = tree.order();
        for (std::size_t i = 0; i < m; ++i) order[i] = std::size_t(tree_order[i]);
    } else {
        order = morton_order(queries, m);
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
