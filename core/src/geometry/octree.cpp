// octree.cpp — top-down split by normal bin, then by each node's own octants, into contiguous
// child ranges; then node bounds.
#include "geometry/octree.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <numeric>
#include <utility>
#include <vector>

namespace illumap {

namespace {

constexpr double kClusterChord = 0.3;  // |n - seed| below this: same normal cluster (~17 deg)
// A node is split at its own box's midplanes, along the axes whose extent is at least this
// share of its longest one (a flat patch is not cut across its thickness; a long strip is cut
// along its length only), so a node's children are about half its size in every direction
// that matters.
constexpr double kAxisShare = 0.5;
// Spatial levels below the root at most (a node this deep is a leaf whatever its count).
constexpr int kMaxDepth = 60;

// Bounds of one node, computed from its own points (tighter than merging children).
void compute_bounds(const SurfelSoA& s, OctreeNode& nd) {
    const std::uint32_t b = nd.begin, e = nd.end;
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    double ax = 0, ay = 0, az = 0, amax = 0;
    for (std::uint32_t i = b; i < e; ++i) {
        lo[0] = std::min(lo[0], s.px[i]); hi[0] = std::max(hi[0], s.px[i]);
        lo[1] = std::min(lo[1], s.py[i]); hi[1] = std::max(hi[1], s.py[i]);
        lo[2] = std::min(lo[2], s.pz[i]); hi[2] = std::max(hi[2], s.pz[i]);
        ax += s.nx[i]; ay += s.ny[i]; az += s.nz[i];
        amax = std::max(amax, s.area[i]);
    }
    for (int d = 0; d < 3; ++d) {
        nd.center[d] = 0.5 * (lo[d] + hi[d]);
        nd.half[d] = 0.5 * (hi[d] - lo[d]);
    }
    double len = std::sqrt(ax * ax + ay * ay + az * az);
    if (len > 1e-12 * (e - b)) {
        nd.axis[0] = ax / len; nd.axis[1] = ay / len; nd.axis[2] = az / len;
    } else {
        nd.axis[0] = 0; nd.axis[1] = 0; nd.axis[2] = 1;
    }
    double r2 = 0, chord2 = 0, slo = HUGE_VAL, shi = -HUGE_VAL;
    for (std::uint32_t i = b; i < e; ++i) {
        double ux = s.px[i] - nd.center[0], uy = s.py[i] - nd.center[1], uz = s.pz[i] - nd.center[2];
        r2 = std::max(r2, ux * ux + uy * uy + uz * uz);
        double cx = s.nx[i] - nd.axis[0], cy = s.ny[i] - nd.axis[1], cz = s.nz[i] - nd.axis[2];
        chord2 = std::max(chord2, cx * cx + cy * cy + cz * cz);
        double h = nd.axis[0] * ux + nd.axis[1] * uy + nd.axis[2] * uz;
        slo = std::min(slo, h);
        shi = std::max(shi, h);
    }
    nd.radius = std::sqrt(r2);
    nd.cone_chord = std::sqrt(chord2);
    nd.cone_angle = nd.cone_chord >= 2.0 ? kPi : 2.0 * std::asin(0.5 * nd.cone_chord);
    nd.slab_lo = slo;
    nd.slab_hi = shi;
    nd.amax = amax;
}

// The surfels of a node range [b, e) in tree order, with their positions alongside (copied in
// the same order, so each level reads them sequentially).
struct SplitWork {
    std::vector<std::uint32_t>& perm;
    std::vector<double> x, y, z;
    std::vector<std::uint32_t> tp;
    std::vector<double> tx, ty, tz;
    std::vector<std::uint8_t> code;

    SplitWork(std::vector<std::uint32_t>& p, const SurfelSoA& s) : perm(p) {
        const std::size_t n = perm.size();
        x.resize(n); y.resize(n); z.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            x[i] = s.px[perm[i]]; y[i] = s.py[perm[i]]; z[i] = s.pz[perm[i]];
        }
        tp.resize(n); tx.resize(n); ty.resize(n); tz.resize(n); code.resize(n);
    }

    // Splits [b, e) by the octants of its own box (stable: each child keeps its surfels in
    // their order); cuts gets the child boundaries. False (nothing moved) when the points
    // coincide or cannot be separated.
    bool split(std::uint32_t b, std::uint32_t e, std::vector<std::uint32_t>& cuts) {
        double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
        for (std::uint32_t i = b; i < e; ++i) {
            lo[0] = std::min(lo[0], x[i]); hi[0] = std::max(hi[0], x[i]);
            lo[1] = std::min(lo[1], y[i]); hi[1] = std::max(hi[1], y[i]);
            lo[2] = std::min(lo[2], z[i]); hi[2] = std::max(hi[2], z[i]);
        }
        const double ext[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
        const double emax = std::max({ext[0], ext[1], ext[2]});
        if (!(emax > 0)) return false;
        double mid[3];
        bool cut[3];
        for (int d = 0; d < 3; ++d) {
            mid[d] = lo[d] + 0.5 * ext[d];
            cut[d] = ext[d] > 0 && ext[d] >= kAxisShare * emax;
        }
        std::uint32_t count[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        for (std::uint32_t i = b; i < e; ++i) {
            const std::uint8_t c = std::uint8_t((cut[0] && x[i] >= mid[0]) << 2 |
                                                (cut[1] && y[i] >= mid[1]) << 1 |
                                                (cut[2] && z[i] >= mid[2]));
            code[i] = c;
            count[c]++;
        }
        int nonempty = 0;
        for (int c = 0; c < 8; ++c) nonempty += count[c] > 0;
        if (nonempty < 2) return false;
        std::uint32_t at[8];
        cuts.clear();
        cuts.push_back(b);
        std::uint32_t o = b;
        for (int c = 0; c < 8; ++c) {
            at[c] = o;
            o += count[c];
            if (count[c] > 0) cuts.push_back(o);
        }
        for (std::uint32_t i = b; i < e; ++i) {
            const std::uint32_t k = at[code[i]]++;
            tp[k] = perm[i]; tx[k] = x[i]; ty[k] = y[i]; tz[k] = z[i];
        }
        std::copy(tp.begin() + b, tp.begin() + e, perm.begin() + b);
        std::copy(tx.begin() + b, tx.begin() + e, x.begin() + b);
        std::copy(ty.begin() + b, ty.begin() + e, y.begin() + b);
        std::copy(tz.begin() + b, tz.begin() + e, z.begin() + b);
        return true;
    }
};

}  // namespace

std::size_t Octree::bytes() const {
    return nodes.capacity() * sizeof(OctreeNode) + perm.capacity() * sizeof(std::uint32_t) +
           7 * s.n * sizeof(double) + leaves.capacity() * sizeof(std::int32_t) +
           nodes.size() * sizeof(std::int32_t);
}

Octree build_octree(Context& ctx, const SurfelSoA& orig, int leaf_size) {
    const std::size_t n = orig.n;
    Octree t;
    leaf_size = std::max(1, leaf_size);

    // Normal bin: the dominant axis and sign of the normal (6 bins, cube-map faces). The root
    // splits by bin first, then each bin is a spatial octree. Surfaces meeting at an edge (a
    // floor and a wall) then never share a node, so every node below the root has a usable
    // normal cone and the facing tests can accept or drop whole nodes.
    std::vector<std::uint8_t> bin(n);
    std::uint32_t per_bin[6] = {0, 0, 0, 0, 0, 0};
    for (std::size_t i = 0; i < n; ++i) {
        const double v[3] = {orig.nx[i], orig.ny[i], orig.nz[i]};
        int d = 0;
        for (int k = 1; k < 3; ++k)
            if (std::fabs(v[k]) > std::fabs(v[d])) d = k;
        bin[i] = std::uint8_t(2 * d + (v[d] < 0));
        per_bin[bin[i]]++;
    }
    // Surfels by bin, each bin in the caller's order (counting sort).
    t.perm.resize(n);
    {
        std::uint32_t at[6], o = 0;
        for (int c = 0; c < 6; ++c) { at[c] = o; o += per_bin[c]; }
        for (std::size_t i = 0; i < n; ++i) t.perm[at[bin[i]]++] = std::uint32_t(i);
    }

    // Top-down, breadth first: children of a node are appended together (contiguous ids).
    // Every node is split by the octants of its own points' box, so a node's subtree depends
    // on its points alone (and their order): a cluster of surfels gets the same cells whatever
    // else is in the scene, and an object far away only adds its own branch.
    SplitWork work(t.perm, orig);
    t.nodes.push_back(OctreeNode{});
    t.nodes[0].begin = 0;
    t.nodes[0].end = std::uint32_t(n);
    std::deque<std::int32_t> queue{0};
    std::vector<std::uint32_t> cuts;
    while (!queue.empty()) {
        const std::int32_t id = queue.front();
        queue.pop_front();
        const OctreeNode nd = t.nodes[id];
        if (nd.count() <= std::uint32_t(leaf_size) || nd.level >= kMaxDepth) continue;
        cuts.clear();
        if (id == 0) {  // by normal bin
            cuts.push_back(0);
            for (int c = 0; c < 6; ++c)
                if (per_bin[c]) cuts.push_back(cuts.back() + per_bin[c]);
        }
        if (cuts.size() <= 2 && !work.split(nd.begin, nd.end, cuts)) continue;  // coincident
        const std::int32_t first = std::int32_t(t.nodes.size());
        for (std::size_t c = 0; c + 1 < cuts.size(); ++c) {
            OctreeNode ch;
            ch.begin = cuts[c];
            ch.end = cuts[c + 1];
            ch.parent = id;
            ch.level = nd.level + 1;
            t.nodes.push_back(ch);
            queue.push_back(std::int32_t(t.nodes.size() - 1));
        }
        t.nodes[id].child = first;
        t.nodes[id].nchild = std::int32_t(cuts.size() - 1);
    }

    // A leaf whose surfels have clearly different normals (it straddles an edge or a corner)
    // is split by normal into co-located children. Each child then has a narrow cone, so
    // the facing tests can accept or drop it whole instead of sending it to P2P.
    const std::size_t nspatial = t.nodes.size();
    for (std::size_t k = 0; k < nspatial; ++k) {
        if (!t.nodes[k].leaf() || t.nodes[k].count() < 2) continue;
        const std::uint32_t b = t.nodes[k].begin, e = t.nodes[k].end;
        std::vector<int> cl(e - b, -1);
        std::vector<std::array<double, 3>> seeds;
        for (std::uint32_t i = b; i < e; ++i) {
            const std::uint32_t j = t.perm[i];
            const double n[3] = {orig.nx[j], orig.ny[j], orig.nz[j]};
            int found = -1;
            for (std::size_t c = 0; c < seeds.size() && found < 0; ++c) {
                const double dx = n[0] - seeds[c][0], dy = n[1] - seeds[c][1], dz = n[2] - seeds[c][2];
                if (dx * dx + dy * dy + dz * dz < kClusterChord * kClusterChord) found = int(c);
            }
            if (found < 0) {
                found = int(seeds.size());
                seeds.push_back({n[0], n[1], n[2]});
            }
            cl[i - b] = found;
        }
        if (seeds.size() < 2) continue;
        std::vector<std::uint32_t> order(e - b);
        std::iota(order.begin(), order.end(), 0u);
        std::stable_sort(order.begin(), order.end(), [&](std::uint32_t u, std::uint32_t v) { return cl[u] < cl[v]; });
        std::vector<std::uint32_t> old(t.perm.begin() + b, t.perm.begin() + e);
        for (std::uint32_t i = 0; i < e - b; ++i) t.perm[b + i] = old[order[i]];
        const std::int32_t first = std::int32_t(t.nodes.size());
        std::uint32_t start = b;
        for (std::size_t c = 0; c < seeds.size(); ++c) {
            std::uint32_t cnt = 0;
            for (int v : cl) cnt += (v == int(c));
            OctreeNode ch;
            ch.begin = start;
            ch.end = start + cnt;
            ch.parent = std::int32_t(k);
            ch.level = t.nodes[k].level + 1;
            t.nodes.push_back(ch);
            start += cnt;
        }
        t.nodes[k].child = first;
        t.nodes[k].nchild = std::int32_t(seeds.size());
    }

    // Surfels in tree order.
    t.s.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint32_t j = t.perm[i];
        t.s.px[i] = orig.px[j]; t.s.py[i] = orig.py[j]; t.s.pz[i] = orig.pz[j];
        t.s.nx[i] = orig.nx[j]; t.s.ny[i] = orig.ny[j]; t.s.nz[i] = orig.nz[j];
        t.s.area[i] = orig.area[j];
    }
    parallel_for(ctx, t.nodes.size(), 64, [&](std::size_t b, std::size_t e) {
        for (std::size_t k = b; k < e; ++k) compute_bounds(t.s, t.nodes[k]);
    });

    for (std::size_t k = 0; k < t.nodes.size(); ++k) {
        const OctreeNode& nd = t.nodes[k];
        if (int(t.levels.size()) <= nd.level) t.levels.resize(nd.level + 1);
        t.levels[nd.level].push_back(std::int32_t(k));
        if (nd.leaf()) t.leaves.push_back(std::int32_t(k));
    }
    t.depth = int(t.levels.size()) - 1;
    return t;
}

}  // namespace illumap
