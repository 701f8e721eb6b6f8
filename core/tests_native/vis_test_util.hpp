// vis_test_util.hpp — scenes, a reference dual-tree traversal with the talk's Octree_Visibility
// (classify -> keep / drop / push down), and transfer sums, for the visibility tests.
// The traversal here is the glue the FMM traversal needs, written out plainly; sums over
// accepted pairs are exact kernel sums (no expansion error), so the figures isolate visibility.
#pragma once

#include "transport/kernel.hpp"
#include "geometry/octree.hpp"
#include "parallel.hpp"
#include "visibility/raycast.hpp"
#include "visibility/seed_visibility.hpp"
#include "visibility/visibility.hpp"
#include "visibility/visibility_factory.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <vector>

namespace vt {
using namespace illumap;

inline int g_fail = 0;
#define CHECK(cond, ...)                                                       \
    do {                                                                       \
        if (!(cond)) {                                                         \
            std::printf("FAIL %s:%d: %s  ", __FILE__, __LINE__, #cond);        \
            std::printf(__VA_ARGS__);                                          \
            std::printf("\n");                                                 \
            ::vt::g_fail++;                                                    \
        }                                                                      \
    } while (0)

inline double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

struct Scene {
    std::vector<double> p, n, a;  // p, n: 3 per surfel
    std::vector<int> tag;         // user label per surfel
    std::size_t size() const { return a.size(); }
    void add(double x, double y, double z, double nx, double ny, double nz, double A, int t) {
        p.insert(p.end(), {x, y, z});
        n.insert(n.end(), {nx, ny, nz});
        a.push_back(A);
        tag.push_back(t);
    }
    // Rectangle o + s u + t v, s,t in [0,1], nu x nv cells, one surfel per cell centre
    // (jitter: fraction of a cell), normal nrm.
    void rect(const double o[3], const double u[3], const double v[3], int nu, int nv,
              const double nrm[3], int t, double jitter = 0.0, unsigned seed = 1) {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> U(-0.5, 0.5);
        const double lu = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        const double lv = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        const double A = lu * lv / (double(nu) * nv);
        for (int i = 0; i < nu; ++i)
            for (int j = 0; j < nv; ++j) {
                const double s = (i + 0.5 + jitter * U(rng)) / nu, q = (j + 0.5 + jitter * U(rng)) / nv;
                add(o[0] + s * u[0] + q * v[0], o[1] + s * u[1] + q * v[1],
                    o[2] + s * u[2] + q * v[2], nrm[0], nrm[1], nrm[2], A, t);
            }
    }
    // Axis-aligned box faces, normals pointing out (sign = +1) or in (sign = -1); spacing h.
    // skip: bit mask of faces to omit (0:-x 1:+x 2:-y 3:+y 4:-z 5:+z).
    void box(const double lo[3], const double hi[3], double h, int sign, int t, int skip = 0,
             double jitter = 0.0) {
        for (int f = 0; f < 6; ++f) {
            if (skip >> f & 1) continue;
            const int ax = f / 2, side = f % 2;
            const int a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
            double o[3], u[3] = {0, 0, 0}, v[3] = {0, 0, 0}, nr[3] = {0, 0, 0};
            o[ax] = side ? hi[ax] : lo[ax];
            o[a1] = lo[a1];
            o[a2] = lo[a2];
            u[a1] = hi[a1] - lo[a1];
            v[a2] = hi[a2] - lo[a2];
            nr[ax] = (side ? 1.0 : -1.0) * sign;
            const int nu = std::max(1, int(std::lround(u[a1] / h)));
            const int nv = std::max(1, int(std::lround(v[a2] / h)));
            rect(o, u, v, nu, nv, nr, t, jitter, 17u * f + 3u);
        }
    }
    Scene transformed(double scale, double shift) const {
        Scene s = *this;
        for (auto& x : s.p) x = x * scale + shift;
        for (auto& x : s.a) x *= scale * scale;
        return s;
    }
};

struct Built {
    Context ctx;
    Octree tree;
    std::vector<int> tag;  // tree order
};

inline void build(Built& b, const Scene& sc, int leaf = 32, int threads = 0) {
    b.ctx.threads = threads;
    SurfelSoA s;
    s.resize(sc.size());
    for (std::size_t i = 0; i < sc.size(); ++i) {
        s.px[i] = sc.p[3 * i]; s.py[i] = sc.p[3 * i + 1]; s.pz[i] = sc.p[3 * i + 2];
        s.nx[i] = sc.n[3 * i]; s.ny[i] = sc.n[3 * i + 1]; s.nz[i] = sc.n[3 * i + 2];
        s.area[i] = sc.a[i];
    }
    b.tree = build_octree(b.ctx, s, leaf);
    b.tag.resize(sc.size());
    for (std::size_t i = 0; i < sc.size(); ++i) b.tag[i] = sc.tag[b.tree.perm[i]];
}

inline double F(const SurfelSoA& s, std::size_t i, std::size_t j) {
    if (i == j) return 0.0;
    // The bare point kernel: these tests compare transfers with and without occlusion.
    return pair_factor(s.px[i] - s.px[j], s.py[i] - s.py[j], s.pz[i] - s.pz[j], s.nx[i],
                       s.ny[i], s.nz[i], s.nx[j], s.ny[j], s.nz[j], s.area[j]);
}

// Sum over receivers with tag rt and sources with tag st of A_i F_ij V_ij, V from `vis`
// (nullptr: V = 1), exhaustively per pair. rt/st < 0: any.
inline double transfer_pairs(const Built& b, const std::function<float(std::uint32_t, std::uint32_t)>& vis,
                             int rt, int st) {
    const SurfelSoA& s = b.tree.s;
    double sum = 0;
    for (std::size_t i = 0; i < s.n; ++i) {
        if (rt >= 0 && b.tag[i] != rt) continue;
        for (std::size_t j = 0; j < s.n; ++j) {
            if (st >= 0 && b.tag[j] != st) continue;
            const double f = F(s, i, j);
            if (f == 0) continue;
            sum += s.area[i] * f * (vis ? vis(std::uint32_t(i), std::uint32_t(j)) : 1.0f);
        }
    }
    return sum;
}

// ---- the reference traversal: MAC candidates, then Octree_Visibility rounds -------------

struct PairOut {
    std::vector<std::int32_t> a, b;
};

inline bool cannot_face(const Octree& t, std::int32_t ia, std::int32_t ib) {
    const OctreeNode &A = t.nodes[ia], &B = t.nodes[ib];
    if (A.cone_angle > 0 || B.cone_angle > 0) return false;
    const double dot = A.axis[0] * B.axis[0] + A.axis[1] * B.axis[1] + A.axis[2] * B.axis[2];
    if (std::fabs(std::fabs(dot) - 1.0) > 1e-12) return false;
    // Both flat and parallel: B's points in front of A's plane?
    const double c = A.axis[0] * (B.center[0] - A.center[0]) + A.axis[1] * (B.center[1] - A.center[1]) +
                     A.axis[2] * (B.center[2] - A.center[2]);
    const double bmax = c + (dot > 0 ? B.slab_hi : -B.slab_lo);
    const double tol = 1e-9 * (A.radius + B.radius + std::fabs(c));
    return bmax <= A.slab_hi + tol;
}

struct Traversal {
    const Octree& t;
    double theta = 0.5;
    explicit Traversal(const Octree& tr, double th = 0.5) : t(tr), theta(th) {}
    bool far(std::int32_t a, std::int32_t b) const {
        const OctreeNode &A = t.nodes[a], &B = t.nodes[b];
        const double dx = A.center[0] - B.center[0], dy = A.center[1] - B.center[1],
                     dz = A.center[2] - B.center[2];
        const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
        return (A.radius + B.radius) < theta * d;
    }
    // MAC expansion: emits far pairs and leaf (near) pairs reachable from (a, b).
    void expand(std::int32_t a, std::int32_t b, PairOut& out) const {
        const OctreeNode &A = t.nodes[a], &B = t.nodes[b];
        if (a == b) {
            if (A.leaf()) { out.a.push_back(a); out.b.push_back(b); return; }
            for (int i = 0; i < A.nchild; ++i)
                for (int j = 0; j < A.nchild; ++j) expand(A.child + i, A.child + j, out);
            return;
        }
        if (cannot_face(t, a, b)) return;
        if (far(a, b) || (A.leaf() && B.leaf())) { out.a.push_back(a); out.b.push_back(b); return; }
        split(a, b, out);
    }
    void split(std::int32_t a, std::int32_t b, PairOut& out) const {
        const OctreeNode &A = t.nodes[a], &B = t.nodes[b];
        // Split the larger node; ties by id, so that the expansion of (b, a) mirrors (a, b).
        const bool split_b = A.leaf() || (!B.leaf() && (B.radius > A.radius || (B.radius == A.radius && b < a)));
        if (split_b) {
            for (int j = 0; j < B.nchild; ++j) expand(a, B.child + j, out);
        } else {
            for (int i = 0; i < A.nchild; ++i) expand(A.child + i, b, out);
        }
    }
};

struct VisLists {
    PairOut valid;         // kept with V = 1
    PairOut leaf_partial;  // two leaves, PARTIAL, near field: block() (PerPair) or fraction()
    PairOut far_partial;   // two leaves, PARTIAL, MAC satisfied: fraction()
    std::vector<float> far_fraction;
    std::size_t invalid = 0, rounds = 0, classified = 0;
    double seconds = 0;
};

// The talk's Octree_Visibility, round by round: classify all candidates in parallel; VALID
// stays, INVALID goes, PARTIAL is pushed down to the children (MAC applied again).
inline VisLists octree_visibility(Context& ctx, const VisibilityModel& vis, const Traversal& tr) {
    VisLists L;
    const double t0 = now();
    PairOut cur;
    tr.expand(0, 0, cur);
    while (!cur.a.empty()) {
        // The rounds are mirror-closed and classify() is symmetric: classify each unordered
        // pair once.
        std::vector<std::uint64_t> keys;
        PairOut uniq;
        for (std::size_t k = 0; k < cur.a.size(); ++k)
            if (cur.a[k] <= cur.b[k]) keys.push_back(std::uint64_t(std::uint32_t(cur.a[k])) << 32 | std::uint32_t(cur.b[k]));
        std::sort(keys.begin(), keys.end());
        keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
        for (auto key : keys) { uniq.a.push_back(std::int32_t(key >> 32)); uniq.b.push_back(std::int32_t(key & 0xffffffffu)); }
        std::vector<VisClass> ucls(keys.size());
        std::vector<float> ufrac(keys.size(), 1.0f);
        // Far pairs of two leaves: class and fraction in one pass; the rest: classify().
        parallel_for(ctx, keys.size(), 64, [&](std::size_t lo, std::size_t hi) {
            for (std::size_t k = lo; k < hi; ++k) {
                const std::int32_t a = uniq.a[k], b = uniq.b[k];
                if (tr.t.nodes[a].leaf() && tr.t.nodes[b].leaf() && tr.far(a, b))
                    ucls[k] = vis.classify_fraction(a, b, &ufrac[k]);
                else
                    ucls[k] = vis.classify(a, b);
            }
        });
        std::vector<float> frac(cur.a.size(), 1.0f);
        std::vector<VisClass> cls(cur.a.size());
        for (std::size_t k = 0; k < cur.a.size(); ++k) {
            const std::int32_t lo = std::min(cur.a[k], cur.b[k]), hi = std::max(cur.a[k], cur.b[k]);
            const std::uint64_t key = std::uint64_t(std::uint32_t(lo)) << 32 | std::uint32_t(hi);
            auto it = std::lower_bound(keys.begin(), keys.end(), key);
            if (it == keys.end() || *it != key) {  // mirror missing: classify directly
                cls[k] = vis.classify(cur.a[k], cur.b[k]);
            } else {
                cls[k] = ucls[std::size_t(it - keys.begin())];
                frac[k] = ufrac[std::size_t(it - keys.begin())];
            }
        }
        L.classified += keys.size();
        L.rounds++;
        PairOut next;
        for (std::size_t k = 0; k < cur.a.size(); ++k) {
            const std::int32_t a = cur.a[k], b = cur.b[k];
            if (cls[k] == VisClass::Valid) { L.valid.a.push_back(a); L.valid.b.push_back(b); }
            else if (cls[k] == VisClass::Invalid) L.invalid++;
            else if (tr.t.nodes[a].leaf() && tr.t.nodes[b].leaf()) {
                if (tr.far(a, b)) {
                    L.far_partial.a.push_back(a); L.far_partial.b.push_back(b); L.far_fraction.push_back(frac[k]);
                } else {
                    L.leaf_partial.a.push_back(a); L.leaf_partial.b.push_back(b);
                }
            } else tr.split(a, b, next);
        }
        cur = std::move(next);
    }
    L.seconds = now() - t0;
    return L;
}

// Transfer (receivers tag rt, sources tag st) through the lists: exact kernel sums.
inline double transfer_lists(const Built& b, const VisibilityModel& vis, const VisLists& L, int rt, int st) {
    const SurfelSoA& s = b.tree.s;
    auto sum_pair = [&](std::int32_t ia, std::int32_t ib, const float* blk, float scale) {
        const OctreeNode &A = b.tree.nodes[ia], &B = b.tree.nodes[ib];
        double acc = 0;
        for (std::uint32_t i = A.begin; i < A.end; ++i) {
            if (rt >= 0 && b.tag[i] != rt) continue;
            for (std::uint32_t j = B.begin; j < B.end; ++j) {
                if (st >= 0 && b.tag[j] != st) continue;
                double v = blk ? blk[std::size_t(i - A.begin) * B.count() + (j - B.begin)] : scale;
                acc += s.area[i] * F(s, i, j) * v;
            }
        }
        return acc;
    };
    double sum = 0;
    for (std::size_t k = 0; k < L.valid.a.size(); ++k) sum += sum_pair(L.valid.a[k], L.valid.b[k], nullptr, 1.0f);
    for (std::size_t k = 0; k < L.far_partial.a.size(); ++k)
        sum += sum_pair(L.far_partial.a[k], L.far_partial.b[k], nullptr, L.far_fraction[k]);
    std::vector<float> blk;
    for (std::size_t k = 0; k < L.leaf_partial.a.size(); ++k) {
        const std::int32_t a = L.leaf_partial.a[k], bb = L.leaf_partial.b[k];
        if (vis.leaf_mode() == LeafMode::PerPair) {
            blk.resize(std::size_t(b.tree.nodes[a].count()) * b.tree.nodes[bb].count());
            vis.block(a, bb, blk.data());
            sum += sum_pair(a, bb, blk.data(), 0);
        } else {
            sum += sum_pair(a, bb, nullptr, vis.fraction(a, bb));
        }
    }
    return sum;
}

// ILLUMAP_VIS_SHAPE=quad runs the exact-mode tests with equal-area squares instead of discs.
inline void apply_env(VisibilityOptions& o) {
    const char* sh = std::getenv("ILLUMAP_VIS_SHAPE");
    if (sh && std::string(sh) == "quad") o.shape = VisibilityOptions::Shape::Quad;
}

inline std::unique_ptr<VisibilityModel> make(Built& b, VisMethod m, LeafMode lm = LeafMode::PerPair,
                                        double coverage = 1.3) {
    VisibilityOptions o;
    o.method = m;
    o.leaf_mode = lm;
    o.coverage = coverage;
    apply_env(o);
    return make_visibility(b.ctx, b.tree, o);
}

}  // namespace vt
