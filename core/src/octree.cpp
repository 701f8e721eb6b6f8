// octree.cpp — Morton sort, top-down split into contiguous child ranges, then node bounds.
#include "octree.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <numeric>
#include <utility>
#include <vector>

namespace illumap {

namespace {

constexpr int kMaxLevel = 21;  // 21 bits per axis in a 63-bit Morton key
constexpr double kClusterChord = 0.3;  // |n - seed| below this: same normal cluster (~17 deg)

inline std::uint64_t spread3(std::uint64_t v) {  // 21 bits -> every third bit
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
}

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

// Morton keys of perm[b, e) against the points' own bounding cube, the range re-sorted by
// them (keys and perm together). False, and nothing changed, when the points coincide.
bool rekey(const SurfelSoA& s, std::vector<std::uint32_t>& perm, std::vector<std::uint64_t>& key,
           std::uint32_t b, std::uint32_t e) {
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (std::uint32_t i = b; i < e; ++i) {
        const std::uint32_t j = perm[i];
        const double p[3] = {s.px[j], s.py[j], s.pz[j]};
        for (int d = 0; d < 3; ++d) { lo[d] = std::min(lo[d], p[d]); hi[d] = std::max(hi[d], p[d]); }
    }
    const double ext = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    if (!(ext > 0)) return false;
    const double top = double((1u << kMaxLevel) - 1), scale = top / ext;
    auto q = [&](double v, int d) { return std::uint64_t(std::min(top, std::max(0.0, (v - lo[d]) * scale))); };
    std::vector<std::pair<std::uint64_t, std::uint32_t>> order;
    order.reserve(e - b);
    for (std::uint32_t i = b; i < e; ++i) {
        const std::uint32_t j = perm[i];
        order.push_back({spread3(q(s.px[j], 0)) << 2 | spread3(q(s.py[j], 1)) << 1 | spread3(q(s.pz[j], 2)), j});
    }
    std::sort(order.begin(), order.end());
    for (std::uint32_t i = b; i < e; ++i) {
        key[i] = order[i - b].first;
        perm[i] = order[i - b].second;
    }
    return true;
}

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

    // Bounding cube of all points, then Morton keys.
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (std::size_t i = 0; i < n; ++i) {
        lo[0] = std::min(lo[0], orig.px[i]); hi[0] = std::max(hi[0], orig.px[i]);
        lo[1] = std::min(lo[1], orig.py[i]); hi[1] = std::max(hi[1], orig.py[i]);
        lo[2] = std::min(lo[2], orig.pz[i]); hi[2] = std::max(hi[2], orig.pz[i]);
    }
    double ext = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-300});
    const double scale = double((1u << kMaxLevel) - 1) / ext;
    std::vector<std::uint64_t> key(n);
    parallel_for(ctx, n, 1 << 16, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
            auto q = [&](double v, int d) { return std::uint64_t(std::min(double((1u << kMaxLevel) - 1), std::max(0.0, (v - lo[d]) * scale))); };
            key[i] = spread3(q(orig.px[i], 0)) << 2 | spread3(q(orig.py[i], 1)) << 1 | spread3(q(orig.pz[i], 2));
        }
    });
    // Normal bin: the dominant axis and sign of the normal (6 bins, cube-map faces). The root
    // splits by bin first, then each bin is an ordinary spatial octree. Surfaces meeting at
    // an edge (a floor and a wall) then never share a node, so every node below the root has
    // a usable normal cone and the facing tests can accept or drop whole nodes.
    std::vector<std::uint8_t> bin(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double v[3] = {orig.nx[i], orig.ny[i], orig.nz[i]};
        int d = 0;
        for (int k = 1; k < 3; ++k)
            if (std::fabs(v[k]) > std::fabs(v[d])) d = k;
        bin[i] = std::uint8_t(2 * d + (v[d] < 0));
    }
    t.perm.resize(n);
    std::iota(t.perm.begin(), t.perm.end(), 0u);
    std::sort(t.perm.begin(), t.perm.end(), [&](std::uint32_t a, std::uint32_t b) {
        if (bin[a] != bin[b]) return bin[a] < bin[b];
        return key[a] < key[b] || (key[a] == key[b] && a < b);
    });
    std::vector<std::uint64_t> skey(n);
    for (std::size_t i = 0; i < n; ++i) skey[i] = key[t.perm[i]];
    key.clear();
    key.shrink_to_fit();

    // Top-down, breadth first: children of a node are appended together (contiguous ids).
    // A node whose points all fall into one octant descends without creating a node
    // (compressed octree), so chains of single children never appear.
    struct Item { std::int32_t id; int bit; };  // bit: Morton level being split; -1: by bin
    t.nodes.push_back(OctreeNode{});
    t.nodes[0].begin = 0;
    t.nodes[0].end = std::uint32_t(n);
    std::deque<Item> queue{{0, -1}};
    while (!queue.empty()) {
        Item it = queue.front();
        queue.pop_front();
        OctreeNode nd = t.nodes[it.id];
        if (nd.count() <= std::uint32_t(leaf_size)) continue;
        int bit = it.bit;
        std::vector<std::uint32_t> cuts;
        if (bit < 0) {  // split by normal bin
            cuts.push_back(nd.begin);
            for (std::uint32_t i = nd.begin + 1; i < nd.end; ++i)
                if (bin[t.perm[i]] != bin[t.perm[i - 1]]) cuts.push_back(i);
            cuts.push_back(nd.end);
            bit = 0;
        }
        while (cuts.size() <= 2 && bit < kMaxLevel) {
            const int shift = 3 * (kMaxLevel - 1 - bit);
            cuts.clear();
            cuts.push_back(nd.begin);
            for (std::uint32_t i = nd.begin + 1; i < nd.end; ++i)
                if ((skey[i] >> shift) != (skey[i - 1] >> shift)) cuts.push_back(i);
            cuts.push_back(nd.end);
            ++bit;
        }
        if (cuts.size() <= 2) {
            // Keys exhausted: a far outlier made the root cube so large that this node is one
            // finest cell. Key its points against their own box and go on splitting;
            // coincident points stay a leaf.
            if (rekey(orig, t.perm, skey, nd.begin, nd.end)) queue.push_front({it.id, 0});
            continue;
        }
        const std::int32_t first = std::int32_t(t.nodes.size());
        for (std::size_t c = 0; c + 1 < cuts.size(); ++c) {
            OctreeNode ch;
            ch.begin = cuts[c];
            ch.end = cuts[c + 1];
            ch.parent = it.id;
            ch.level = nd.level + 1;
            t.nodes.push_back(ch);
            queue.push_back({std::int32_t(t.nodes.size() - 1), bit});
        }
        t.nodes[it.id].child = first;
        t.nodes[it.id].nchild = std::int32_t(cuts.size() - 1);
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
