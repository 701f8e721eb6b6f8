// traversal.cpp — the parallel dual-tree walk that fills the per-target interaction lists
// (the kernel's class of a pair: pair_classes.cpp).
#include "transport/traversal.hpp"

#include <algorithm>
#include <cmath>

namespace illumap {

namespace {
// The walk is shared out once the breadth-first frontier holds this many pairs per thread
// (or, after one more level, over kFrontierOvershoot times that), in kChunksPerThread chunks
// per thread (one Walker each). With visibility one top pair can hold a large share of the
// rays: at 300k Cornell surfels (exact) 64 pairs and 8 chunks per thread left one chunk with
// 24% of the walk's time, so one core idled for a quarter of it; 256 and 32 keep the largest
// chunk near 5%.
constexpr std::size_t kFrontierPerThread = 256;
constexpr std::size_t kFrontierOvershoot = 4;
constexpr std::size_t kChunksPerThread = 32;
// Target nodes per chunk when each target's lists are sorted by source.
constexpr std::size_t kSortGrain = 1024;
}  // namespace

std::size_t InteractionLists::bytes() const {
    return (m2l_off.capacity() + p2p_off.capacity() + m2p_off.capacity() + p2l_off.capacity()) *
               sizeof(std::int64_t) +
           (m2l_src.capacity() + p2p_src.capacity() + m2p_src.capacity() + p2l_src.capacity()) *
               sizeof(std::int32_t) +
           (m2l_w.capacity() + p2p_w.capacity() + point_w.capacity()) * sizeof(float) +
           blocks.capacity() +
           (p2p_blk.capacity() + m2p_pw.capacity() + p2l_pw.capacity()) * sizeof(std::int64_t);
}

namespace {

struct Pair { std::int32_t t, s; };

// V in [0, 1] as a block entry (kVisLevels steps, kernel.hpp).
std::uint8_t quantised(float v) {
    return std::uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * float(kVisLevels)));
}

struct Walker {
    const Octree& tree;
    const TraversalOptions& opt;
    std::vector<Pair> m2l, p2p, m2p, p2l;
    std::vector<std::int64_t> acc, drop, split, nearc;
    std::int64_t surfel_pairs = 0;
    // Visibility (opt.model): weights parallel to m2l / p2p, per-pair blocks (local offsets).
    std::vector<float> m2l_w, p2p_w;
    std::vector<std::uint8_t> blk;
    std::vector<std::int64_t> p2p_blk;
    // Per-point weights of far PARTIAL leaf pairs (local offsets into pw), parallel to m2p / p2l.
    std::vector<std::int64_t> m2p_pw, p2l_pw;
    std::vector<float> pw;
    std::vector<std::int64_t> vv, vi, vp;
    std::int64_t nm2lw = 0, np2pw = 0, nblk = 0, npw = 0;
    std::vector<float> tmp;
    const bool mutual;  // with a visibility model: visit each unordered pair once (step)

    Walker(const Octree& tr, const TraversalOptions& o)
        : tree(tr), opt(o), mutual(o.model != nullptr) {
        const std::size_t L = tree.levels.size() + 1;
        acc.assign(L, 0); drop.assign(L, 0); split.assign(L, 0); nearc.assign(L, 0);
        vv.assign(L, 0); vi.assign(L, 0); vp.assign(L, 0);
    }

    void add_m2l(Pair pr, float w) {
        m2l.push_back(pr);
        if (opt.model) {
            m2l_w.push_back(w);
            if (w != 1.0f) nm2lw++;
        }
    }
    void add_m2p(Pair pr, std::int64_t o) {
        m2p.push_back(pr);
        if (opt.model) m2p_pw.push_back(o);
    }
    void add_p2l(Pair pr, std::int64_t o) {
        p2l.push_back(pr);
        if (opt.model) p2l_pw.push_back(o);
    }
    void add_p2p(Pair pr, float w, std::int64_t b) {
        p2p.push_back(pr);
        if (opt.model) {
            p2p_w.push_back(w);
            p2p_blk.push_back(b);
            if (w != 1.0f) np2pw++;
            if (b >= 0) nblk++;
        }
    }
    // Per-pair V of two leaves, stored for (a, b) (row-major |a| x |b|) and, when `mirror`,
    // transposed for (b, a) right after it; -1 when every pair is visible (nothing stored).
    // `drawn`: the pairs the classification of (a, b) queried, not queried again.
    std::int64_t store_block(std::int32_t a, std::int32_t b, bool mirror = false,
                             const VisibilityModel::DrawMemo* drawn = nullptr) {
        const std::size_t na = tree.nodes[a].count(), nb = tree.nodes[b].count();
        const std::size_t m = na * nb;
        tmp.resize(m);
        opt.model->block(a, b, tmp.data(), drawn);
        bool all = true;
        for (float v : tmp) all = all && v == 1.0f;
        if (all) return -1;
        const std::int64_t off = std::int64_t(blk.size());
        for (float v : tmp) blk.push_back(quantised(v));
        if (mirror)
            for (std::size_t j = 0; j < nb; ++j)
                for (std::size_t i = 0; i < na; ++i) blk.push_back(quantised(tmp[i * nb + j]));
        return off;
    }

    // The block of (a, b) (and, when `mirror`, of (b, a) after it) whose V_ij is w of the
    // point of the weighted leaf (a's point i when `on_a`, else b's point j).
    std::int64_t store_point_block(std::int32_t a, std::int32_t b, bool on_a, const float* w,
                                   bool mirror) {
        const std::size_t na = tree.nodes[a].count(), nb = tree.nodes[b].count();
        const std::int64_t off = std::int64_t(blk.size());
        for (std::size_t i = 0; i < na; ++i)
            for (std::size_t j = 0; j < nb; ++j) blk.push_back(quantised(w[on_a ? i : j]));
        if (mirror)
            for (std::size_t j = 0; j < nb; ++j)
                for (std::size_t i = 0; i < na; ++i) blk.push_back(quantised(w[on_a ? i : j]));
        return off;
    }

    // Split children, in canonical order (node_before) when the walk is mutual.
    void push(std::vector<Pair>& out, std::int32_t a, std::int32_t b) const {
        if (mutual && node_before(tree.nodes[b], tree.nodes[a])) std::swap(a, b);
        out.push_back({a, b});
    }

    // How a pair's interaction is weighted by visibility: the whole entry by w, or per pair by
    // the block at offset b (>= 0) of `blk`.
    struct Weight {
        float w = 1.0f;
        std::int64_t b = -1;
        std::int64_t pw = -1;  // offset into pw of the weighted leaf's per-point weights
        bool on_t = true;      // ... which is the target t (else the source s)
    };

    // Classifies one pair; appends its children pairs to `out` when it must be split.
    // Mutual walk (with a visibility model): only pairs t <= s are visited and each records
    // the mirrored interaction of (s, t) too (t <= s: node_before). The kernel classes of
    // (t, s) and (s, t) mirror each other (Accept, Drop, Near alike; M2P <-> P2L; the split
    // rule picks the same node, radius ties broken by node_before), so the lists are those of
    // the ordered walk while each node pair is classified, sampled and blocked once.
    void step(Pair pr, std::vector<Pair>& out) {
        if (pr.t == pr.s) {
            step_self(pr, out);
            return;
        }
        // The kernel alone first; visibility only where an interaction would be produced.
        PairClass k = classify(tree.s, tree.nodes[pr.t], tree.nodes[pr.s], opt);
        Weight wt;
        if (opt.model && (k == PairClass::Accept || k == PairClass::M2P ||
                          k == PairClass::P2L || k == PairClass::Near))
            k = with_visibility(pr, k, wt);
        record(pr, k, wt, out);
    }

    // A self pair: all ordered child pairs, or direct at a leaf.
    void step_self(Pair pr, std::vector<Pair>& out) {
        const OctreeNode& t = tree.nodes[pr.t];
        if (t.leaf()) {
            // Surfels of one leaf can hide each other (a corner, a block on a floor).
            add_p2p(pr, 1.0f, opt.model ? store_block(pr.t, pr.t) : -1);
            nearc[t.level]++;
            surfel_pairs += std::int64_t(t.count()) * t.count();
        } else {
            split[t.level]++;
            for (int a = 0; a < t.nchild; ++a)
                for (int b = mutual ? a : 0; b < t.nchild; ++b)
                    out.push_back({t.child + a, t.child + b});
        }
    }

    // A point of a scan lies in node n (opt.scan).
    bool holds_scan(const OctreeNode& n) const {
        if (!opt.scan) return false;
        for (std::uint32_t i = n.begin; i < n.end; ++i)
            if (opt.scan[tree.perm[i]] != 0) return true;
        return false;
    }

    // The kernel's class k of a pair that produces an interaction, corrected by the model's
    // class of the pair: INVALID drops it, PARTIAL splits it or, for two leaves, weights it.
    PairClass with_visibility(Pair pr, PairClass k, Weight& wt) {
        const OctreeNode& t = tree.nodes[pr.t];
        const OctreeNode& s = tree.nodes[pr.s];
        const VisibilityModel& m = *opt.model;
        const bool leaves = t.leaf() && s.leaf();
        float frac = 1.0f;
        // A fraction is needed only where a PARTIAL leaf pair may keep one.
        const bool wants_fraction = leaves && m.leaf_mode() != LeafMode::Binary &&
                                    m.leaf_mode() != LeafMode::PerPairAll;
        VisibilityModel::DrawMemo draws(m);  // for a block of this pair
        const VisClass c = wants_fraction ? m.classify_fraction(pr.t, pr.s, &frac, &draws)
                                          : m.classify(pr.t, pr.s, &draws);
        const int lev = std::max(t.level, s.level);
        (c == VisClass::Valid ? vv : c == VisClass::Invalid ? vi : vp)[lev] += mutual ? 2 : 1;
        if (c == VisClass::Valid) return k;
        if (c == VisClass::Invalid) return PairClass::Drop;
        if (!leaves) return PairClass::Split;  // PARTIAL: pushed down to the children
        // A PARTIAL leaf pair cannot be pushed down: Accept (far) or Near. PerPair: per-pair
        // V only in the true near field; a leaf pair that is Near only because its facing is
        // mixed (a sphere's leaf against a distant wall) is far apart and gets the fraction,
        // as far leaf pairs in M2L. PerPairAll: per-pair V (P2P) wherever a leaf pair is
        // PARTIAL.
        if (m.leaf_mode() == LeafMode::PerPairAll ||
            (k == PairClass::Near && m.leaf_mode() == LeafMode::PerPair &&
             !mac_holds(t, s, opt.theta))) {
            wt.b = store_block(pr.t, pr.s, mutual, &draws);
            return PairClass::Near;
        }
        if (m.leaf_mode() == LeafMode::PerPair && (holds_scan(t) || holds_scan(s))) {
            // A far leaf pair with a scan's point (TraversalOptions::scan): the wider leaf's
            // points each get their own fraction (a floor leaf of which one point sees a
            // scan's lit inside through a hole must not lend that view to the rest);
            // V_ij = w_i for i in it, both ways (reciprocal).
            const bool on_t = t.radius >= s.radius;
            const std::int32_t x = on_t ? pr.t : pr.s, y = on_t ? pr.s : pr.t;
            const std::size_t nx = tree.nodes[x].count();
            tmp.resize(nx);
            m.point_fractions(x, y, frac, tmp.data());
            const auto [lo, hi] = std::minmax_element(tmp.begin(), tmp.begin() + std::ptrdiff_t(nx));
            if (*lo == *hi) {  // one weight for all (often 0 or 1): the pair's own, cheaper
                if (*lo == 0.0f) return PairClass::Drop;
                wt.w = *lo;
                return k;
            }
            npw++;
            if (k == PairClass::Near) {
                wt.b = store_point_block(pr.t, pr.s, on_t, tmp.data(), mutual);
                return PairClass::Near;
            }
            wt.pw = std::int64_t(pw.size());
            wt.on_t = on_t;
            pw.insert(pw.end(), tmp.begin(), tmp.begin() + std::ptrdiff_t(nx));
            return k;
        }
        wt.w = frac;
        return k;
    }

    // Records the pair (t, s) of class k (and its mirror (s, t) in a mutual walk) in the
    // lists and counts, or appends the children pairs to `out`.
    void record(Pair pr, PairClass k, Weight wt, std::vector<Pair>& out) {
        const OctreeNode& t = tree.nodes[pr.t];
        const OctreeNode& s = tree.nodes[pr.s];
        const int lev = std::max(t.level, s.level);
        const std::int64_t both = mutual ? 2 : 1;  // ordered pairs this visit stands for
        const Pair mr{pr.s, pr.t};
        switch (k) {
            case PairClass::Drop: drop[lev] += both; return;
            case PairClass::Accept:
                acc[lev] += both;
                if (wt.pw >= 0) {  // per-point weights: M2P for their leaf, P2L for the other
                    if (wt.on_t) {
                        add_m2p(pr, wt.pw);
                        if (mutual) add_p2l(mr, wt.pw);
                    } else {
                        add_p2l(pr, wt.pw);
                        if (mutual) add_m2p(mr, wt.pw);
                    }
                    return;
                }
                add_m2l(pr, wt.w);
                if (mutual) add_m2l(mr, wt.w);
                return;
            case PairClass::M2P:
                acc[lev] += both;
                add_m2p(pr, -1);
                if (mutual) add_p2l(mr, -1);
                return;
            case PairClass::P2L:
                acc[lev] += both;
                add_p2l(pr, -1);
                if (mutual) add_m2p(mr, -1);
                return;
            case PairClass::Near:
                nearc[lev] += both;
                add_p2p(pr, wt.w, wt.b);
                if (mutual)
                    add_p2p(mr, wt.w, wt.b < 0 ? -1 : wt.b + std::int64_t(t.count()) * s.count());
                surfel_pairs += both * std::int64_t(t.count()) * s.count();
                return;
            case PairClass::SplitS:
                split[lev] += both;
                for (int c = 0; c < s.nchild; ++c) push(out, pr.t, s.child + c);
                return;
            case PairClass::SplitT:
                split[lev] += both;
                for (int c = 0; c < t.nchild; ++c) push(out, t.child + c, pr.s);
                return;
            case PairClass::Split:
                split[lev] += both;
                split_larger(pr, out);
                return;
        }
    }

    // Splits the source when the target is a leaf or the source is the larger one. With a
    // visibility model radius ties go by node_before (octree.hpp), so (t, s) and (s, t) split
    // the same node and their lists mirror each other (exact reciprocity of the sampled
    // classes).
    void split_larger(Pair pr, std::vector<Pair>& out) {
        const OctreeNode& t = tree.nodes[pr.t];
        const OctreeNode& s = tree.nodes[pr.s];
        if (!s.leaf() && (t.leaf() || s.radius > t.radius ||
                          (opt.model && s.radius == t.radius && node_before(t, s)))) {
            for (int c = 0; c < s.nchild; ++c) push(out, pr.t, s.child + c);
        } else {
            for (int c = 0; c < t.nchild; ++c) push(out, t.child + c, pr.s);
        }
    }

    void walk(Pair pr) {
        std::vector<Pair> stack{pr}, kids;
        while (!stack.empty()) {
            Pair p = stack.back();
            stack.pop_back();
            kids.clear();
            step(p, kids);
            stack.insert(stack.end(), kids.begin(), kids.end());
        }
    }
};

std::vector<std::int64_t> to_csr(std::size_t nnodes, std::vector<std::vector<Pair>*>& parts,
                                 std::vector<std::int32_t>& src) {
    std::vector<std::int64_t> off(nnodes + 1, 0);
    for (auto* v : parts)
        for (const Pair& p : *v) off[p.t + 1]++;
    for (std::size_t i = 0; i < nnodes; ++i) off[i + 1] += off[i];
    src.assign(off[nnodes], 0);
    std::vector<std::int64_t> pos(off.begin(), off.end() - 1);
    for (auto* v : parts)
        for (const Pair& p : *v) src[pos[p.t]++] = p.s;
    return off;
}

// The same CSR, carrying per-entry weights (and block offsets shifted into one store).
template <class T>
void csr_payload(std::size_t nnodes, const std::vector<std::int64_t>& off,
                 std::vector<std::vector<Pair>*>& parts, std::vector<const std::vector<T>*>& pay,
                 std::vector<T>& out) {
    out.assign(off[nnodes], T());
    std::vector<std::int64_t> pos(off.begin(), off.end() - 1);
    for (std::size_t q = 0; q < parts.size(); ++q)
        for (std::size_t k = 0; k < parts[q]->size(); ++k) out[pos[(*parts[q])[k].t]++] = (*pay[q])[k];
}

// Sorts each row [off[t], off[t + 1]) of a CSR list by source in tree order (node_before;
// the same node twice: by position, so the result is deterministic), permuting the payloads
// `w` and `blk` (either may be null) alike. Tree order, not node id: a cluster's lists then
// come out in the same order whatever else is in the tree, and so do its sums, to the bit.
void sort_by_source(Context& ctx, const Octree& tree, const std::vector<std::int64_t>& off,
                    std::vector<std::int32_t>& src, std::vector<float>* w,
                    std::vector<std::int64_t>* blk) {
    const std::size_t nn = off.empty() ? 0 : off.size() - 1;
    auto before = [&](std::int32_t a, std::int32_t b) {
        return node_before(tree.nodes[a], tree.nodes[b]);
    };
    parallel_for(ctx, nn, kSortGrain, [&](std::size_t b, std::size_t e) {
        std::vector<std::int64_t> idx;
        std::vector<std::int32_t> s2;
        std::vector<float> w2;
        std::vector<std::int64_t> b2;
        for (std::size_t t = b; t < e; ++t) {
            const std::int64_t k0 = off[t], k1 = off[t + 1];
            if (std::is_sorted(src.begin() + k0, src.begin() + k1, before)) continue;
            idx.resize(std::size_t(k1 - k0));
            for (std::int64_t k = k0; k < k1; ++k) idx[std::size_t(k - k0)] = k;
            std::sort(idx.begin(), idx.end(), [&](std::int64_t x, std::int64_t y) {
                return src[x] != src[y] ? before(src[x], src[y]) : x < y;
            });
            auto permute = [&](auto& v, auto& tmp) {
                tmp.resize(idx.size());
                for (std::size_t q = 0; q < idx.size(); ++q) tmp[q] = v[std::size_t(idx[q])];
                std::copy(tmp.begin(), tmp.end(), v.begin() + k0);
            };
            permute(src, s2);
            if (w) permute(*w, w2);
            if (blk) permute(*blk, b2);
        }
    });
}

}  // namespace

InteractionLists build_interaction_lists(Context& ctx, const Octree& tree,
                                         const TraversalOptions& opt) {
    InteractionLists L;
    const std::size_t nn = tree.nodes.size();
    // Breadth-first expansion on the calling thread until there is enough work to share.
    Walker top(tree, opt);
    std::vector<Pair> frontier{{0, 0}}, next;
    const std::size_t want = kFrontierPerThread * std::size_t(ctx.nthreads());
    while (!frontier.empty() && frontier.size() < want) {
        next.clear();
        for (const Pair& p : frontier) top.step(p, next);
        frontier.swap(next);
        if (frontier.size() > kFrontierOvershoot * want) break;
    }
    const int nt = ctx.nthreads();
    std::vector<Walker> walkers;
    walkers.reserve(frontier.size());
    // One walker per chunk keeps outputs private to a thread without thread ids.
    const std::size_t grain = std::max<std::size_t>(1, frontier.size() / (kChunksPerThread * std::size_t(nt)));
    const std::size_t nchunks = (frontier.size() + grain - 1) / grain;
    for (std::size_t c = 0; c < nchunks; ++c) walkers.emplace_back(tree, opt);
    parallel_for(ctx, nchunks, 1, [&](std::size_t b, std::size_t e) {
        for (std::size_t c = b; c < e; ++c) {
            const std::size_t lo = c * grain, hi = std::min(frontier.size(), lo + grain);
            for (std::size_t i = lo; i < hi; ++i) walkers[c].walk(frontier[i]);
        }
    });
    walkers.push_back(std::move(top));

    std::vector<std::vector<Pair>*> mparts, pparts, m2pparts, p2lparts;
    const std::size_t Lv = tree.levels.size() + 1;
    L.accepted_per_level.assign(Lv, 0); L.dropped_per_level.assign(Lv, 0);
    L.split_per_level.assign(Lv, 0); L.near_per_level.assign(Lv, 0);
    for (auto& w : walkers) {
        mparts.push_back(&w.m2l);
        pparts.push_back(&w.p2p);
        m2pparts.push_back(&w.m2p);
        p2lparts.push_back(&w.p2l);
        L.p2p_surfel_pairs += w.surfel_pairs;
        for (std::size_t l = 0; l < Lv; ++l) {
            L.accepted_per_level[l] += w.acc[l];
            L.dropped_per_level[l] += w.drop[l];
            L.split_per_level[l] += w.split[l];
            L.near_per_level[l] += w.nearc[l];
        }
    }
    L.m2l_off = to_csr(nn, mparts, L.m2l_src);
    L.p2p_off = to_csr(nn, pparts, L.p2p_src);
    if (opt.model) {
        L.vis_valid_per_level.assign(Lv, 0); L.vis_invalid_per_level.assign(Lv, 0);
        L.vis_partial_per_level.assign(Lv, 0);
        std::vector<const std::vector<float>*> mw, pw;
        std::vector<const std::vector<std::int64_t>*> pb;
        std::size_t total = 0;
        for (auto& w : walkers) {
            for (auto& o : w.p2p_blk)
                if (o >= 0) o += std::int64_t(total);
            total += w.blk.size();
            mw.push_back(&w.m2l_w);
            pw.push_back(&w.p2p_w);
            pb.push_back(&w.p2p_blk);
            L.vis_m2l_weighted += w.nm2lw;
            L.vis_p2p_weighted += w.np2pw;
            L.vis_p2p_blocks += w.nblk;
            for (std::size_t l = 0; l < Lv; ++l) {
                L.vis_valid_per_level[l] += w.vv[l];
                L.vis_invalid_per_level[l] += w.vi[l];
                L.vis_partial_per_level[l] += w.vp[l];
            }
        }
        L.blocks.reserve(total);
        for (auto& w : walkers) {
            L.blocks.insert(L.blocks.end(), w.blk.begin(), w.blk.end());
            std::vector<std::uint8_t>().swap(w.blk);
        }
        csr_payload(nn, L.m2l_off, mparts, mw, L.m2l_w);
        csr_payload(nn, L.p2p_off, pparts, pw, L.p2p_w);
        csr_payload(nn, L.p2p_off, pparts, pb, L.p2p_blk);
    }
    L.m2p_off = to_csr(nn, m2pparts, L.m2p_src);
    L.p2l_off = to_csr(nn, p2lparts, L.p2l_src);
    if (opt.model) {  // per-point weights of far PARTIAL leaf pairs, in one store
        std::vector<const std::vector<std::int64_t>*> mpw, ppw;
        std::size_t total = 0;
        for (auto& w : walkers) {
            for (auto* v : {&w.m2p_pw, &w.p2l_pw})
                for (auto& o : *v)
                    if (o >= 0) o += std::int64_t(total);
            total += w.pw.size();
            mpw.push_back(&w.m2p_pw);
            ppw.push_back(&w.p2l_pw);
            L.vis_point_weighted += w.npw;
        }
        L.point_w.reserve(total);
        for (auto& w : walkers) L.point_w.insert(L.point_w.end(), w.pw.begin(), w.pw.end());
        csr_payload(nn, L.m2p_off, m2pparts, mpw, L.m2p_pw);
        csr_payload(nn, L.p2l_off, p2lparts, ppw, L.p2l_pw);
    }
    // Each target's sources in tree order (weights and block offsets carried along): the
    // applications then read source surfels in ascending addresses, the lists no longer depend
    // on how the walk was shared out, and a cluster's lists not on the rest of the tree.
    sort_by_source(ctx, tree, L.m2l_off, L.m2l_src, opt.model ? &L.m2l_w : nullptr, nullptr);
    sort_by_source(ctx, tree, L.p2p_off, L.p2p_src, opt.model ? &L.p2p_w : nullptr,
                   opt.model ? &L.p2p_blk : nullptr);
    sort_by_source(ctx, tree, L.m2p_off, L.m2p_src, nullptr, opt.model ? &L.m2p_pw : nullptr);
    sort_by_source(ctx, tree, L.p2l_off, L.p2l_src, nullptr, opt.model ? &L.p2l_pw : nullptr);
    L.m2p_pairs = std::int64_t(L.m2p_src.size());
    L.p2l_pairs = std::int64_t(L.p2l_src.size());
    L.m2l_pairs = std::int64_t(L.m2l_src.size());
    L.p2p_node_pairs = std::int64_t(L.p2p_src.size());
    return L;
}

}  // namespace illumap
