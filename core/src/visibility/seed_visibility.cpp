// seed_visibility.cpp — the talk's point_visible / point_leaf / leaf_leaf over the octree.
#include "visibility/seed_visibility.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace illumap {

namespace {

inline double smoothstep01(double u) {
    u = u < 0 ? 0 : (u > 1 ? 1 : u);
    return u * u * (3.0 - 2.0 * u);
}

// Squared distance from point c to segment p + t d, t in [0, 1] (dd = |d|^2 > 0).
inline double seg_dist2(const double p[3], const double d[3], double dd, double cx, double cy,
                        double cz) {
    const double wx = cx - p[0], wy = cy - p[1], wz = cz - p[2];
    double t = (wx * d[0] + wy * d[1] + wz * d[2]) / dd;
    t = t < 0 ? 0 : (t > 1 ? 1 : t);
    const double ex = wx - t * d[0], ey = wy - t * d[1], ez = wz - t * d[2];
    return ex * ex + ey * ey + ez * ez;
}

}  // namespace

SeedVisibility::SeedVisibility(Context& ctx, const Octree& tree, const VisibilityOptions& opt)
    : VisibilityModel(tree, opt) {
    const auto t_start = std::chrono::steady_clock::now();
    if (!(opt.delta > 0) || opt.k < 1 || opt.leaf_points < 1)
        throw std::invalid_argument("seed visibility: need delta > 0, k >= 1, leaf_points >= 1");
    hmax_.resize(tree.nodes.size());
    ctx.set_phase("visibility: seed index", 0.0, 1.0);
    parallel_for(ctx, tree.nodes.size(), 256, [&](std::size_t b, std::size_t e) {
        for (std::size_t k = b; k < e; ++k)
            hmax_[k] = float(opt.delta * std::sqrt(std::max(tree.nodes[k].amax, 0.0) * kInvPi) *
                             (1.0 + 1e-6));
    });
    build_seconds_ =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    bytes_ = hmax_.size() * sizeof(float);
}

double SeedVisibility::attenuation(std::uint32_t i, std::uint32_t j, bool early) const {
    if (i == j) return 1.0;
    if (i > j) std::swap(i, j);
    const SurfelSoA& s = tree_.s;
    const double p[3] = {s.px[i], s.py[i], s.pz[i]};
    const double d[3] = {s.px[j] - p[0], s.py[j] - p[1], s.pz[j] - p[2]};
    const double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if (!(dd > 0)) return 1.0;
    const double len = std::sqrt(dd);
    const double hi_ = std::sqrt(std::max(s.area[i], 0.0) * kInvPi);
    const double hj_ = std::sqrt(std::max(s.area[j], 0.0) * kInvPi);
    // Tangent-plane cut must lie in (tlo, thi): 0.25 h away from each endpoint.
    const double tlo = 0.25 * hi_ / len, thi = 1.0 - 0.25 * hj_ / len;
    if (!(tlo < thi)) return 1.0;
    const double delta = opt_.delta, t1 = opt_.t1;
    const int K = opt_.k;

    // The k smallest transmissions found so far (unsorted; K is small).
    double best[64];
    const int kk = std::min(K, 64);
    int nb = 0;
    double prod = 1.0;
    auto product = [&] {
        double r = 1.0;
        for (int m = 0; m < nb; ++m) r *= best[m];
        return r;
    };

    // The nodes still to visit (grown as needed: a deep tree never drops a branch).
    thread_local std::vector<std::int32_t> stack;
    stack.clear();
    stack.push_back(0);
    const auto& nodes = tree_.nodes;
    while (!stack.empty()) {
        const std::int32_t id = stack.back();
        stack.pop_back();
        const OctreeNode& nd = nodes[id];
        const double reach = nd.radius + hmax_[id];
        if (seg_dist2(p, d, dd, nd.center[0], nd.center[1], nd.center[2]) > reach * reach)
            continue;
        if (!nd.leaf()) {
            for (int c = 0; c < nd.nchild; ++c) stack.push_back(nd.child + c);
            continue;
        }
        for (std::uint32_t k = nd.begin; k < nd.end; ++k) {
            if (k == i || k == j) continue;
            const double hk = std::sqrt(std::max(s.area[k], 0.0) * kInvPi);
            const double dk = delta * hk;
            const double dist2 = seg_dist2(p, d, dd, s.px[k], s.py[k], s.pz[k]);
            if (!(dist2 < dk * dk)) continue;
            // Tangent plane of k against the line p + t d.
            const double den = s.nx[k] * d[0] + s.ny[k] * d[1] + s.nz[k] * d[2];
            const double num =
                s.nx[k] * (s.px[k] - p[0]) + s.ny[k] * (s.py[k] - p[1]) + s.nz[k] * (s.pz[k] - p[2]);
            if (!(std::fabs(den) > 1e-12 * len)) continue;  // plane contains the line
            const double t = num / den;
            if (!(t > tlo && t < thi)) continue;
            const double tau = smoothstep01(std::sqrt(dist2) / dk);
            if (nb < kk) {
                best[nb++] = tau;
            } else {
                int w = 0;
                for (int m = 1; m < nb; ++m)
                    if (best[m] > best[w]) w = m;
                if (tau >= best[w]) continue;
                best[w] = tau;
            }
            if (early) {
                prod = product();
                if (prod <= t1) {
                    count_queries(1);
                    return prod;
                }
            }
        }
    }
    count_queries(1);
    return product();
}

float SeedVisibility::pair(std::uint32_t i, std::uint32_t j) const {
    if (opt_.seed_binary_pairs) return point_visible(i, j) ? 1.0f : 0.0f;
    return float(attenuation(i, j, false));
}

// Evenly strided sample of up to m points of a node (deterministic).
namespace {
template <class Fn>
void strided(const OctreeNode& n, int m, Fn&& fn) {
    const std::uint32_t c = n.count();
    if (c <= std::uint32_t(m)) {
        for (std::uint32_t i = n.begin; i < n.end; ++i) fn(i);
        return;
    }
    for (int k = 0; k < m; ++k)
        fn(n.begin + std::uint32_t((std::uint64_t(2 * k + 1) * c) / (2 * std::uint64_t(m))));
}
}  // namespace

bool SeedVisibility::point_leaf(std::uint32_t p, std::int32_t leaf) const {
    const OctreeNode& L = tree_.nodes[leaf];
    int facing = 0, vis = 0;
    strided(L, opt_.leaf_points, [&](std::uint32_t q) {
        if (q == p || !vis_facing(tree_.s, p, q)) return;
        facing++;
        if (point_visible(p, q)) vis++;
    });
    return facing > 0 && vis > opt_.t2 * facing;
}

bool SeedVisibility::leaf_leaf(std::int32_t L, std::int32_t C) const {
    if (node_before(tree_.nodes[C], tree_.nodes[L])) std::swap(L, C);
    const OctreeNode& Cn = tree_.nodes[C];
    const OctreeNode& Ln = tree_.nodes[L];
    int considered = 0, vis = 0;
    strided(Cn, opt_.leaf_points, [&](std::uint32_t p) {
        // p counts only if some sampled point of L faces it.
        bool any = false;
        strided(Ln, opt_.leaf_points, [&](std::uint32_t q) {
            if (q != p && vis_facing(tree_.s, p, q)) any = true;
        });
        if (!any) return;
        considered++;
        if (point_leaf(p, L)) vis++;
    });
    return considered == 0 || vis > opt_.t3 * considered;
}

VisClass SeedVisibility::classify(std::int32_t a, std::int32_t b, DrawMemo* draws) const {
    const OctreeNode &A = tree_.nodes[a], &B = tree_.nodes[b];
    if (A.leaf() && B.leaf() && opt_.leaf_mode == LeafMode::Binary) {
        const VisClass c = leaf_leaf(a, b) ? VisClass::Valid : VisClass::Invalid;
        record(std::max(A.level, B.level), c);
        return c;
    }
    return VisibilityModel::classify(a, b, draws);
}

}  // namespace illumap
