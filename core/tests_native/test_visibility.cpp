// test_visibility.cpp — component tests of visibility="exact" and visibility="seed".
// Exits non-zero on failure. Figures are printed so the report can quote them.
#include "vis_test_util.hpp"

#include <algorithm>
#include <cstring>
#include <map>
#include <string>

using namespace vt;

// In the quad pass (ILLUMAP_VIS_SHAPE=quad) only the exact mode changes: skip seed.
static std::vector<VisMethod> methods() {
    const char* sh = std::getenv("ILLUMAP_VIS_SHAPE");
    if (sh && std::string(sh) == "quad") return {VisMethod::Exact};
    return {VisMethod::Exact, VisMethod::Seed};
}

static const char* mname(VisMethod m) { return m == VisMethod::Exact ? "exact" : "seed"; }
static const char* lname(LeafMode l) {
    return l == LeafMode::Binary ? "binary"
           : l == LeafMode::Fractional ? "fractional"
           : l == LeafMode::PerPairAll ? "per_pair_all" : "per_pair";
}

// Two parallel unit squares (z = 0 up, z = 1 down), occluder at z = 0.5 over [x0,x1] x [-0.5,1.5].
static Scene squares(int n, double x0, double x1, bool occluder) {
    Scene s;
    const double o0[3] = {0, 0, 0}, o1[3] = {0, 0, 1}, u[3] = {1, 0, 0}, v[3] = {0, 1, 0};
    const double up[3] = {0, 0, 1}, dn[3] = {0, 0, -1};
    s.rect(o0, u, v, n, n, up, 0, 0.3, 11);
    s.rect(o1, u, v, n, n, dn, 1, 0.3, 12);
    if (occluder) {
        const double oo[3] = {x0, -0.5, 0.5}, ou[3] = {x1 - x0, 0, 0}, ov[3] = {0, 2, 0};
        const int nu = int(std::lround((x1 - x0) * n)), nv = 2 * n;
        s.rect(oo, ou, ov, nu, nv, up, 2, 0.3, 13);
    }
    return s;
}

static void test_full_occluder() {
    std::printf("\n== parallel squares, larger opaque square between (transfer / unoccluded) ==\n");
    for (int n : {12, 24}) {
        Scene sc = squares(n, -0.5, 1.5, true);
        Built b;
        build(b, sc, 32);
        const double t_open = transfer_pairs(b, nullptr, 1, 0);
        for (VisMethod m : methods()) {
            for (LeafMode lm : {LeafMode::PerPair, LeafMode::Binary}) {
                auto vis = make(b, m, lm);
                Traversal tr(b.tree);
                VisLists L = octree_visibility(b.ctx, *vis, tr);
                const double t_list = transfer_lists(b, *vis, L, 1, 0);
                double t_pair = -1;
                if (lm == LeafMode::PerPair)
                    t_pair = transfer_pairs(b, [&](std::uint32_t i, std::uint32_t j) { return vis->pair(i, j); }, 1, 0);
                char pbuf[32] = "   n/a ";
                if (t_pair >= 0) std::snprintf(pbuf, sizeof pbuf, "%.5f", t_pair / t_open);
                std::printf("  n=%2d (N=%5zu) %-5s %-8s  per pair: %s  lists: %.5f  (unoccluded transfer %.5f)\n", n,
                            sc.size(), mname(m), lname(lm), pbuf, t_list / t_open, t_open);
                CHECK(t_list <= 0.01 * t_open, "%s n=%d lists %.4g", mname(m), n, t_list / t_open);
                if (t_pair >= 0) CHECK(t_pair <= 0.01 * t_open, "%s n=%d pairs %.4g", mname(m), n, t_pair / t_open);
            }
        }
    }
}

// Ideal visibility for the half-blocked case: blocked iff the segment crosses z = 0.5 at x < 0.5.
static void test_half_blocked() {
    std::printf("\n== half the gap blocked: transfer vs the unblocked part (ideal occluder) ==\n");
    for (int n : {12, 24}) {
        Scene sc = squares(n, -0.5, 0.5, true);
        Built b;
        build(b, sc, 32);
        const SurfelSoA& s = b.tree.s;
        auto ideal = [&](std::uint32_t i, std::uint32_t j) -> float {
            const double mx = 0.5 * (s.px[i] + s.px[j]);
            return mx < 0.5 ? 0.0f : 1.0f;
        };
        const double t_ideal = transfer_pairs(b, ideal, 1, 0);
        const double t_open = transfer_pairs(b, nullptr, 1, 0);
        for (VisMethod m : methods()) {
            for (LeafMode lm : {LeafMode::PerPair, LeafMode::Fractional, LeafMode::Binary}) {
                auto vis = make(b, m, lm);
                Traversal tr(b.tree);
                VisLists L = octree_visibility(b.ctx, *vis, tr);
                const double t_list = transfer_lists(b, *vis, L, 1, 0);
                double t_pair = -1, agree = -1;
                if (lm == LeafMode::PerPair) {
                    t_pair = transfer_pairs(b, [&](std::uint32_t i, std::uint32_t j) { return vis->pair(i, j); }, 1, 0);
                    // fraction of receiver/source pairs where V agrees with the ideal occluder
                    std::size_t same = 0, tot = 0;
                    for (std::size_t i = 0; i < s.n; ++i) {
                        if (b.tag[i] != 1) continue;
                        for (std::size_t j = 0; j < s.n; ++j)
                            if (b.tag[j] == 0) { tot++; same += (vis->pair(i, j) >= 0.5f) == (ideal(i, j) > 0.5f); }
                    }
                    agree = double(same) / tot;
                }
                const double e_list = t_list / t_ideal - 1, e_pair = t_pair / t_ideal - 1;
                char pbuf[64] = "";
                if (t_pair >= 0) std::snprintf(pbuf, sizeof pbuf, "per-pair err %+.4f  pair agreement %.4f", e_pair, agree);
                std::printf("  n=%2d %-5s %-10s  ideal/open %.4f  lists err %+.4f (tol %.3f)  %s\n", n, mname(m), lname(lm),
                            t_ideal / t_open, e_list, lm == LeafMode::Binary ? 3.0 / n : 1.25 / n, pbuf);
                // Documented tolerance, relative, O(h) with h = 1/n the spacing: the sampled
                // occluder's edge is only known to ~h/2 (jittered samples, discs of radius
                // 0.73 h overhang it), and both methods over-occlude there; sampled classes add
                // to it. per_pair and fractional: 1.25 h; binary leaves (the talk: a leaf pair is
                // all or nothing): 3 h.
                const double hh = 1.0 / n;
                const double tol = lm == LeafMode::Binary ? 3.0 * hh : 1.25 * hh;
                CHECK(std::fabs(e_list) <= tol, "%s %s n=%d err %.4f", mname(m), lname(lm), n, e_list);
                if (t_pair >= 0) CHECK(std::fabs(e_pair) <= tol, "%s n=%d pair err %.4f", mname(m), n, e_pair);
            }
        }
    }
}

// Two unit rooms side by side; the shared wall x = 1 is ONE layer of surfels facing room A.
static void test_rooms() {
    std::printf("\n== thin single-sided wall between two rooms: leak = T(B<-A) / T(A<-A) ==\n");
    // The lists' leak is the per-pair one (discs leave gaps: 5e-4 at n = 8) plus the sampled
    // classes' error, which depends on the sampling stream: over ten streams at n = 8, exact,
    // per_pair, 3.1e-4 to 1.03e-3 with cells against the scene's bounding cube and 6.6e-4 to
    // 1.11e-3 with each node split by its own box (the default stream: 5.0e-4 and 1.02e-3).
    std::map<std::string, double> bound = {{"exact", 1.5e-3}, {"seed", 1e-3}};
    for (int n : {8, 16}) {
        const double h = 1.0 / n;
        Scene sc;
        const double a0[3] = {0, 0, 0}, a1[3] = {1, 1, 1}, b0[3] = {1, 0, 0}, b1[3] = {2, 1, 1};
        sc.box(a0, a1, h, -1, 0, 1 << 1, 0.3);  // room A without its +x face
        sc.box(b0, b1, h, -1, 1, 1 << 0, 0.3);  // room B without its -x face
        const double wo[3] = {1, 0, 0}, wu[3] = {0, 1, 0}, wv[3] = {0, 0, 1}, wn[3] = {-1, 0, 0};
        sc.rect(wo, wu, wv, n, n, wn, 0, 0.3, 99);  // the wall, facing room A only
        Built b;
        build(b, sc, 32);
        const double open_leak = transfer_pairs(b, nullptr, 1, 0) / transfer_pairs(b, nullptr, 0, 0);
        std::printf("  n=%2d N=%5zu  without visibility: leak %.4f\n", n, sc.size(), open_leak);
        for (VisMethod m : methods()) {
            for (LeafMode lm : {LeafMode::PerPair, LeafMode::Binary}) {
                auto vis = make(b, m, lm);
                Traversal tr(b.tree);
                VisLists L = octree_visibility(b.ctx, *vis, tr);
                const double leak_l = transfer_lists(b, *vis, L, 1, 0) / transfer_lists(b, *vis, L, 0, 0);
                double leak_p = -1;
                if (lm == LeafMode::PerPair) {
                    auto V = [&](std::uint32_t i, std::uint32_t j) { return vis->pair(i, j); };
                    leak_p = transfer_pairs(b, V, 1, 0) / transfer_pairs(b, V, 0, 0);
                }
                char pbuf[32] = "   n/a  ";
                if (leak_p >= 0) std::snprintf(pbuf, sizeof pbuf, "%.2e", leak_p);
                std::printf("  n=%2d %-5s %-8s  leak lists %.2e  per pair %s  (bound %.1e)\n", n, mname(m),
                            lname(lm), leak_l, pbuf, bound[mname(m)]);
                CHECK(leak_l <= bound[mname(m)], "%s n=%d leak %.3g", mname(m), n, leak_l);
                if (leak_p >= 0) CHECK(leak_p <= bound[mname(m)], "%s n=%d leak %.3g", mname(m), n, leak_p);
            }
        }
    }
}

static void test_degenerate() {
    std::printf("\n== degenerate cases ==\n");
    // p, q facing; duplicates of p; an occluder touching p; surfels on the segment.
    for (int variant = 0; variant < 2; ++variant) {
        Scene sc;
        const double A = 0.01;
        sc.add(0, 0, 0, 0, 0, 1, A, 0);       // 0: p
        sc.add(0, 0, 1, 0, 0, -1, A, 0);      // 1: q
        sc.add(0, 0, 0, 0, 0, 1, A, 0);       // 2: coincident duplicate of p
        sc.add(0, 0, 0, 1, 0, 0, A, 0);       // 3: coincident, other normal
        sc.add(0, 0, 1, 0, 0, -1, A, 0);      // 4: duplicate of q
        const double r = std::sqrt(A / kPi);
        sc.add(r, 0, 0.001, 0, 0, 1, A, 0);   // 5: disc touching p (edge through p's centre)
        sc.add(0, 0, 0.5, 1, 0, 0, A, 0);     // 6: on the segment, edge-on
        sc.add(0, 0, 0.25, 0, 0, 0, 0.0, 0);  // 7: on the segment, zero area, zero normal
        if (variant == 1) sc.add(0, 0, 0.5, 0, 0, 1, A, 0);  // 8: on the segment, face-on
        Built b;
        build(b, sc, 2);
        std::vector<std::uint32_t> inv(sc.size());
        for (std::size_t i = 0; i < sc.size(); ++i) inv[b.tree.perm[i]] = std::uint32_t(i);
        for (VisMethod m : methods()) {
            auto vis = make(b, m);
            bool ok = true;
            for (std::uint32_t i = 0; i < sc.size(); ++i)
                for (std::uint32_t j = 0; j < sc.size(); ++j) {
                    const float v = vis->pair(i, j), w = vis->pair(j, i);
                    if (!(v >= 0 && v <= 1) || v != w) ok = false;
                }
            for (std::size_t x = 0; x < b.tree.nodes.size(); ++x)
                for (std::size_t y = 0; y < b.tree.nodes.size(); ++y) {
                    const VisClass c = vis->classify(std::int32_t(x), std::int32_t(y));
                    if (c != vis->classify(std::int32_t(y), std::int32_t(x))) ok = false;
                    const float f = vis->fraction(std::int32_t(x), std::int32_t(y));
                    if (!(f >= 0 && f <= 1)) ok = false;
                    std::vector<float> blk(std::size_t(b.tree.nodes[x].count()) * b.tree.nodes[y].count());
                    vis->block(std::int32_t(x), std::int32_t(y), blk.data());
                    for (float v : blk)
                        if (!(v >= 0 && v <= 1)) ok = false;
                }
            const float vpq = vis->pair(inv[0], inv[1]);
            std::printf("  variant %d %-5s  finite/symmetric %s  V(p,q) = %.0f (expect %d)\n", variant, mname(m),
                        ok ? "yes" : "NO", vpq, variant == 0 ? 1 : 0);
            CHECK(ok, "%s variant %d: NaN, out of range or asymmetric", mname(m), variant);
            CHECK(vpq == (variant == 0 ? 1.0f : 0.0f), "%s variant %d: V(p,q)=%g", mname(m), variant, vpq);
        }
    }
}

static void test_scale() {
    std::printf("\n== millimetre vs kilometre (same scene, scale 1e-3 / shift 0 and 1e3 / shift 5e3) ==\n");
    Scene base = squares(16, -0.5, 0.5, true);
    for (VisMethod m : methods()) {
        double ratio[2];
        std::vector<float> pv[2];
        std::vector<VisClass> cl[2];
        int k = 0;
        for (auto [sc_, sh] : {std::pair<double, double>{1e-3, 0.0}, {1e3, 5e3}}) {
            Scene sc = base.transformed(sc_, sh);
            Built b;
            build(b, sc, 32);
            auto vis = make(b, m);
            Traversal tr(b.tree);
            VisLists L = octree_visibility(b.ctx, *vis, tr);
            ratio[k] = transfer_lists(b, *vis, L, 1, 0) / transfer_pairs(b, nullptr, 1, 0);
            for (std::size_t i = 0; i < b.tree.s.n; i += 7)
                for (std::size_t j = 0; j < b.tree.s.n; j += 5) pv[k].push_back(vis->pair(i, j));
            for (std::size_t x = 0; x < L.valid.a.size(); ++x) cl[k].push_back(VisClass::Valid);
            k++;
        }
        std::size_t diff = 0;
        for (std::size_t x = 0; x < pv[0].size(); ++x) diff += pv[0][x] != pv[1][x];
        std::printf("  %-5s  transfer/open  mm %.6f  km %.6f   pair values differing: %zu of %zu   valid lists %zu / %zu\n",
                    mname(m), ratio[0], ratio[1], diff, pv[0].size(), cl[0].size(), cl[1].size());
        CHECK(std::fabs(ratio[0] - ratio[1]) <= 1e-3 * ratio[0], "%s mm %.6f km %.6f", mname(m), ratio[0], ratio[1]);
        CHECK(diff <= pv[0].size() / 1000, "%s %zu pair values differ", mname(m), diff);
    }
}

// Error of the sampled classification: for every VALID / INVALID pair of the lists, the
// F-weighted share of its facing pairs that per-pair visibility contradicts.
static void test_sampling_error() {
    std::printf("\n== classification rests on samples: its error (half-blocked squares and rooms) ==\n");
    for (int samples : {8, 16})
    for (int scene = 0; scene < 2; ++scene) {
        Scene sc;
        if (scene == 0) sc = squares(24, -0.5, 0.5, true);
        else {
            const double h = 1.0 / 16, a0[3] = {0, 0, 0}, a1[3] = {1, 1, 1}, b0[3] = {1, 0, 0}, b1[3] = {2, 1, 1};
            sc.box(a0, a1, h, -1, 0, 1 << 1, 0.3);
            sc.box(b0, b1, h, -1, 1, 1 << 0, 0.3);
            const double lo[3] = {0.3, 0.3, 0}, hi[3] = {0.6, 0.6, 0.5};
            sc.box(lo, hi, h, 1, 0, 1 << 4, 0.3);  // a block in room A
        }
        Built b;
        build(b, sc, 32);
        for (VisMethod m : methods()) {
            VisibilityOptions o;
            o.method = m;
            o.samples = samples;
            apply_env(o);
            auto vis = make_visibility(b.ctx, b.tree, o);
            Traversal tr(b.tree);
            VisLists L = octree_visibility(b.ctx, *vis, tr);
            const SurfelSoA& s = b.tree.s;
            std::printf("  samples %d:\n", samples);
            double wrong = 0, total = 0;
            std::size_t npairs_wrong = 0;
            double wrong_inv = 0, total_inv = 0;
            {
                // INVALID pairs are not kept in the lists: re-run the rounds' classes on the
                // candidate list is costly, so sample the leaf pairs of the whole scene instead.
                for (std::size_t x = 0; x < b.tree.leaves.size(); x += 3)
                    for (std::size_t y = 0; y < b.tree.leaves.size(); y += 5) {
                        const std::int32_t la = b.tree.leaves[x], lb = b.tree.leaves[y];
                        if (la == lb || vis->classify(la, lb) != VisClass::Invalid) continue;
                        const OctreeNode &A = b.tree.nodes[la], &B = b.tree.nodes[lb];
                        for (std::uint32_t i = A.begin; i < A.end; ++i)
                            for (std::uint32_t j = B.begin; j < B.end; ++j) {
                                const double f = s.area[i] * F(s, i, j);
                                if (f == 0) continue;
                                total_inv += f;
                                if (vis->pair(i, j) >= 0.5f) wrong_inv += f;
                            }
                    }
            }
            for (std::size_t k = 0; k < L.valid.a.size(); ++k) {
                const OctreeNode &A = b.tree.nodes[L.valid.a[k]], &B = b.tree.nodes[L.valid.b[k]];
                bool any = false;
                for (std::uint32_t i = A.begin; i < A.end; ++i)
                    for (std::uint32_t j = B.begin; j < B.end; ++j) {
                        const double f = s.area[i] * F(s, i, j);
                        if (f == 0) continue;
                        total += f;
                        if (vis->pair(i, j) < 0.5f) { wrong += f; any = true; }
                    }
                npairs_wrong += any;
            }
            double t_pair = transfer_pairs(b, [&](std::uint32_t i, std::uint32_t j) { return vis->pair(i, j); }, -1, -1);
            double t_list = transfer_lists(b, *vis, L, -1, -1);
            VisStats st = vis->stats();
            std::printf("  %s %-5s  lists: valid %zu (wrongly VALID %zu, %.2e of their F) invalid %zu leaf-partial %zu rounds %zu"
                        "  | total transfer lists vs per-pair %+.2e  queries %llu\n",
                        scene ? "rooms+block" : "half-blocked", mname(m), L.valid.a.size(), npairs_wrong,
                        total > 0 ? wrong / total : 0.0, L.invalid, L.leaf_partial.a.size(), L.rounds,
                        t_list / t_pair - 1, (unsigned long long)st.queries);
            std::printf("        leaf pairs called INVALID (every 3rd x 5th): %.2e of their F is visible per pair\n",
                        total_inv > 0 ? wrong_inv / total_inv : 0.0);
            std::printf("        per level [valid invalid partial]:");
            for (std::size_t l = 0; l < st.per_level.size(); ++l)
                std::printf(" L%zu[%llu %llu %llu]", l, (unsigned long long)st.per_level[l][0],
                            (unsigned long long)st.per_level[l][1], (unsigned long long)st.per_level[l][2]);
            std::printf("\n");
            // Documented bound: the sampled lists stay within 3% of per-pair visibility.
            CHECK(std::fabs(t_list / t_pair - 1) <= 0.03, "%s sampled lists vs per-pair %.4f", mname(m), t_list / t_pair - 1);
        }
    }
}

// Closed box with a block inside: row sums of F.V. The floor under the block is excluded (it
// faces the block's inside and is rightly dark). Reference: the same box without the block and
// without visibility, whose deviation is the kernel's own discretisation error (edges, corners).
static void test_furnace() {
    std::printf("\n== closed box with a block inside: row sums of F.V ==\n");
    for (int n : {8, 16}) {
        const double h = 1.0 / n;
        const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1}, blo[3] = {0.3, 0.3, 0.0}, bhi[3] = {0.65, 0.6, 0.5};
        double sgn = 0;
        auto stats = [&](const Built& b, const VisibilityModel* vis, double& mean, double& p95, double& mx) {
            const SurfelSoA& s = b.tree.s;
            std::vector<double> dev;
            sgn = 0;
            for (std::size_t i = 0; i < s.n; ++i) {
                if (s.pz[i] == 0.0 && s.px[i] > blo[0] && s.px[i] < bhi[0] && s.py[i] > blo[1] && s.py[i] < bhi[1]) continue;
                double rs = 0;
                for (std::size_t j = 0; j < s.n; ++j) {
                    const double f = F(s, i, j);
                    if (f != 0) rs += f * (vis ? vis->pair(std::uint32_t(i), std::uint32_t(j)) : 1.0f);
                }
                dev.push_back(std::fabs(rs - 1));
                sgn += rs - 1;
            }
            sgn /= dev.size();
            mean = 0;
            for (double d : dev) mean += d;
            mean /= dev.size();
            std::sort(dev.begin(), dev.end());
            p95 = dev[std::size_t(0.95 * (dev.size() - 1))];
            mx = dev.back();
        };
        Scene empty;
        empty.box(lo, hi, h, -1, 0, 0, 0.3);
        Built be;
        build(be, empty, 32);
        double m0, p0, x0;
        stats(be, nullptr, m0, p0, x0);
        std::printf("  n=%2d empty box, no visibility |rowsum-1|: mean %.4f  p95 %.4f  max %.4f\n", n, m0, p0, x0);
        Scene sc = empty;
        sc.box(blo, bhi, h, +1, 0, 1 << 4, 0.3);  // block standing on the floor
        Built b;
        build(b, sc, 32);
        for (int which = 0; which < 1 + int(methods().size()); ++which) {
            std::unique_ptr<VisibilityModel> vis;
            if (which) vis = make(b, which == 1 ? VisMethod::Exact : VisMethod::Seed);
            double mean, p95, mx;
            stats(b, vis.get(), mean, p95, mx);
            const char* nm = which == 0 ? "none" : (which == 1 ? "exact" : "seed");
            std::printf("  n=%2d N=%5zu %-5s  |rowsum-1|: mean %.4f  p95 %.4f  max %.4f   mean(rowsum-1) %+.4f\n", n,
                        b.tree.s.n, nm, mean, p95, mx, sgn);
            // Documented bound: mean deviation within 0.5 h of the empty box's (the kernel's own
            // discretisation error); the excess is O(h), from the block's edges and the floor
            // around its foot. Catches leaks (row sums above 1) and over-occlusion (below).
            if (which) CHECK(mean <= m0 + 0.5 * h, "%s n=%d mean row-sum deviation %.4f (empty box %.4f)", nm, n, mean, m0);
        }
    }
}

// coverage: leaks (full occluder, per pair) against over-occlusion (half-blocked error).
static void test_coverage_sweep() {
    std::printf("\n== exact: coverage trade-off (n = 24, jittered 0.3) ==\n");
    Scene full = squares(24, -0.5, 1.5, true), half = squares(24, -0.5, 0.5, true);
    Built bf, bh;
    build(bf, full, 32);
    build(bh, half, 32);
    const SurfelSoA& s = bh.tree.s;
    auto ideal = [&](std::uint32_t i, std::uint32_t j) -> float { return 0.5 * (s.px[i] + s.px[j]) < 0.5 ? 0.0f : 1.0f; };
    const double t_open = transfer_pairs(bf, nullptr, 1, 0), t_ideal = transfer_pairs(bh, ideal, 1, 0);
    for (double cov : {1.0, 1.15, 1.3, 1.5, 1.75}) {
        auto vf = make(bf, VisMethod::Exact, LeafMode::PerPair, cov);
        auto vh = make(bh, VisMethod::Exact, LeafMode::PerPair, cov);
        const double leak = transfer_pairs(bf, [&](std::uint32_t i, std::uint32_t j) { return vf->pair(i, j); }, 1, 0) / t_open;
        const double err = transfer_pairs(bh, [&](std::uint32_t i, std::uint32_t j) { return vh->pair(i, j); }, 1, 0) / t_ideal - 1;
        std::printf("  coverage %.2f  leak through full occluder %.4f   half-blocked error %+.4f\n", cov, leak, err);
    }
}

// The effective V_ij of the lists (valid 1, far partial: fraction, near partial: block) must
// be symmetric for a mirror-symmetric traversal, so diag(A) F V stays symmetric (CG).
static void test_reciprocity() {
    std::printf("\n== reciprocity of the effective V from the lists ==\n");
    Scene sc = squares(12, -0.5, 0.5, true);
    Built b;
    build(b, sc, 16);
    const std::size_t n = b.tree.s.n;
    for (VisMethod m : methods())
        for (LeafMode lm : {LeafMode::PerPair, LeafMode::Fractional, LeafMode::Binary}) {
            auto vis = make(b, m, lm);
            Traversal tr(b.tree);
            VisLists L = octree_visibility(b.ctx, *vis, tr);
            std::vector<float> V(n * n, -1.0f);  // -1: not in any list (dropped / invalid: 0)
            auto fill = [&](std::int32_t a, std::int32_t c, const float* blk, float val) {
                const OctreeNode &A = b.tree.nodes[a], &B = b.tree.nodes[c];
                for (std::uint32_t i = A.begin; i < A.end; ++i)
                    for (std::uint32_t j = B.begin; j < B.end; ++j)
                        V[i * n + j] = blk ? blk[std::size_t(i - A.begin) * B.count() + (j - B.begin)] : val;
            };
            for (std::size_t k = 0; k < L.valid.a.size(); ++k) fill(L.valid.a[k], L.valid.b[k], nullptr, 1.0f);
            for (std::size_t k = 0; k < L.far_partial.a.size(); ++k) fill(L.far_partial.a[k], L.far_partial.b[k], nullptr, L.far_fraction[k]);
            std::vector<float> blk;
            for (std::size_t k = 0; k < L.leaf_partial.a.size(); ++k) {
                const std::int32_t a = L.leaf_partial.a[k], c = L.leaf_partial.b[k];
                blk.resize(std::size_t(b.tree.nodes[a].count()) * b.tree.nodes[c].count());
                if (lm == LeafMode::PerPair) { vis->block(a, c, blk.data()); fill(a, c, blk.data(), 0); }
                else fill(a, c, nullptr, vis->fraction(a, c));
            }
            std::size_t asym = 0;
            for (std::size_t i = 0; i < n; ++i)
                for (std::size_t j = 0; j < n; ++j) {
                    const float x = V[i * n + j] < 0 ? 0.0f : V[i * n + j], y = V[j * n + i] < 0 ? 0.0f : V[j * n + i];
                    if (x != y && F(b.tree.s, i, j) > 0) asym++;
                }
            std::printf("  %-5s %-10s  asymmetric facing pairs: %zu\n", mname(m), lname(lm), asym);
            CHECK(asym == 0, "%s %s: %zu asymmetric pairs", mname(m), lname(lm), asym);
        }
}

// A PARTIAL leaf pair's block after its classification: the classification's draws (kept in a
// DrawMemo) are not queried again, and the block is the one computed without them.
static void test_block_after_classify() {
    std::printf("\n== block after classify: no query twice, same block ==\n");
    Scene sc = squares(12, -0.5, 0.5, true);
    Built b;
    build(b, sc, 16);
    for (VisMethod m : methods())
        for (LeafMode lm : {LeafMode::PerPair, LeafMode::PerPairAll}) {
            auto vis = make(b, m, lm);
            Traversal tr(b.tree);
            VisLists L = octree_visibility(b.ctx, *vis, tr);
            std::size_t pairs = 0, saved = 0, differ = 0, extra = 0;
            std::vector<float> plain, kept;
            PairOut partial = L.leaf_partial;   // near and far PARTIAL leaf pairs
            partial.a.insert(partial.a.end(), L.far_partial.a.begin(), L.far_partial.a.end());
            partial.b.insert(partial.b.end(), L.far_partial.b.begin(), L.far_partial.b.end());
            for (std::size_t k = 0; k < partial.a.size(); ++k) {
                const std::int32_t a = partial.a[k], c = partial.b[k];
                const std::size_t m2 = std::size_t(b.tree.nodes[a].count()) * b.tree.nodes[c].count();
                plain.assign(m2, 0.0f);
                kept.assign(m2, 0.0f);
                vis->reset_stats();
                vis->block(a, c, plain.data());
                const std::uint64_t q_plain = vis->stats().queries;
                vis->reset_stats();
                VisibilityModel::DrawMemo draws(*vis);
                float frac;
                if (lm == LeafMode::PerPairAll) vis->classify(a, c, &draws);
                else vis->classify_fraction(a, c, &frac, &draws);
                const std::uint64_t q_class = vis->stats().queries;
                vis->block(a, c, kept.data(), &draws);
                const std::uint64_t q_both = vis->stats().queries;
                pairs++;
                saved += q_class;
                if (plain != kept) differ++;
                // the two passes together query each facing pair of the block once
                if (q_both != q_plain) extra++;
            }
            std::printf("  %-5s %-12s  partial leaf pairs %zu, classification queries reused %zu, "
                        "blocks differing %zu, pairs queried twice %zu\n",
                        mname(m), lname(lm), pairs, saved, differ, extra);
            CHECK(pairs > 0 && saved > 0, "%s %s: nothing to test", mname(m), lname(lm));
            CHECK(differ == 0, "%s %s: %zu blocks differ", mname(m), lname(lm), differ);
            CHECK(extra == 0, "%s %s: %zu blocks re-queried", mname(m), lname(lm), extra);
        }
}

struct CancelNow : Monitor {
    int calls = 0;
    bool poll(double, const char*) override { calls++; return false; }
};

static void test_cancel() {
    std::printf("\n== cancellation and progress ==\n");
    Scene sc = squares(48, -0.5, 1.5, true);
    Built b;
    build(b, sc, 16);
    CancelNow mon;
    b.ctx.monitor = &mon;
    bool thrown = false;
    try {
        auto vis = make(b, VisMethod::Exact);
        // Embree build may finish before the first poll (50 ms); then the batch must cancel.
        Traversal tr(b.tree);
        std::vector<std::int32_t> A, B;
        for (int rep = 0; rep < 400; ++rep)
            for (std::int32_t l : b.tree.leaves) { A.push_back(l); B.push_back(b.tree.leaves[(l * 7 + rep) % b.tree.leaves.size()]); }
        std::vector<VisClass> out(A.size());
        vis->classify_batch(b.ctx, A.data(), B.data(), A.size(), out.data());
    } catch (const Cancelled&) {
        thrown = true;
    }
    std::printf("  cancelled: %s (monitor polled %d times)\n", thrown ? "yes" : "no", mon.calls);
    CHECK(thrown, "no Cancelled");
}

int main(int argc, char** argv) {
    const char* only = argc > 1 ? argv[1] : "";
    const char* shape = std::getenv("ILLUMAP_VIS_SHAPE");
    std::printf("exact-mode occluder shape: %s\n", shape && std::string(shape) == "quad" ? "quad" : "disc");
    auto want = [&](const char* n) { return !*only || std::strstr(only, n); };
    if (want("degenerate")) test_degenerate();
    if (want("occluder")) test_full_occluder();
    if (want("half")) test_half_blocked();
    if (want("rooms")) test_rooms();
    if (want("scale")) test_scale();
    if (want("sampling")) test_sampling_error();
    if (want("reciprocity")) test_reciprocity();
    if (want("block_after")) test_block_after_classify();
    if (want("furnace")) test_furnace();
    if (want("coverage")) test_coverage_sweep();
    if (want("cancel")) test_cancel();
    std::printf("\n%s (%d failures)\n", g_fail ? "FAILED" : "OK", g_fail);
    return g_fail ? 1 : 0;
}
