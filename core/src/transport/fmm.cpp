// fmm.cpp — the FMM evaluation, phase by phase (fmm.hpp).
#include "transport/fmm.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>

namespace illumap {

namespace {

using Clock = std::chrono::steady_clock;

// Items per chunk of each phase's parallel loop (FMM work per node is very uneven).
constexpr std::size_t kUpwardGrain = 16;    // nodes of one level
constexpr std::size_t kFarFieldGrain = 4;   // internal nodes
constexpr std::size_t kDownwardGrain = 32;  // nodes of one level
constexpr std::size_t kLeafGrain = 4;       // leaves
// Arrays a near source carries into P2P: position (3), normal (3), area, value (3).
constexpr std::size_t kNearArrays = 10;
constexpr std::size_t kFirstValueArray = 7;

// Runs phase() and adds its seconds to timings[name].
template <class Phase>
void timed(std::map<std::string, double>& timings, const char* name, Phase&& phase) {
    const auto t0 = Clock::now();
    phase();
    timings[name] = std::chrono::duration<double>(Clock::now() - t0).count();
}

// y_i's share of a light vector lv (9 numbers, [axis * 3 + channel]): -(1/pi) n_i . L.
inline double receive(const SurfelSoA& s, std::uint32_t i, const double lv[9], int ch) {
    return kInvPi * (s.nx[i] * lv[ch] + s.ny[i] * lv[3 + ch] + s.nz[i] * lv[6 + ch]);
}

}  // namespace

struct Fmm::Values {
    std::vector<double> xt;          // interleaved, n x 3 (P2M, P2L)
    std::vector<double> x0, x1, x2;  // one array per channel (P2P)
    std::vector<std::uint8_t> live;  // per node: some value in it is not zero
};

// A leaf's near sources gathered contiguously (SoA), in two sets: entries without per-pair V
// (a whole-entry weight scales their values) and entries with it, whose V rows (stored per
// entry, |t| x |s|) are gathered into vrows over the same concatenation, so that each receiver
// sums all its blocks in one vectorised loop.
struct Fmm::NearSources {
    std::vector<double> plain_buf, blocked_buf;
    std::vector<std::uint8_t> vrows;  // V of the blocked set, receiver-major (row r: receiver r)
    SourceView plain{}, blocked{};
    // The leaf's per-point weighted far pairs: a local expansion each (W doubles) and the
    // offset of its receivers' weights in InteractionLists::point_w.
    std::vector<double> pair_locals;
    std::vector<std::int64_t> pair_weights;
};

Fmm::Fmm(const Octree& tree, const InteractionLists& lists, int order)
    : T_(tree), IL_(lists), tables_(order), W_(9 * std::size_t(tables_.ncoef)),
      work_size_(expansion_work_size(tables_)) {
    const std::size_t nn = T_.nodes.size();
    std::vector<char> read(nn, 0);
    for (std::int32_t sidx : IL_.m2l_src) read[sidx] = 1;
    for (std::int32_t sidx : IL_.m2p_src) read[sidx] = 1;
    mslot_.assign(nn, -1);
    lslot_.assign(nn, -1);
    for (std::size_t k = 0; k < nn; ++k) {
        const bool leaf = T_.nodes[k].leaf();
        if (!leaf || read[k]) mslot_[k] = mslots_++;
        if (!leaf) {
            lslot_[k] = lslots_++;
            internal_.push_back(std::int32_t(k));
        }
    }
    has_local_.assign(nn, 0);
    for (std::size_t k = 0; k < nn; ++k) {  // BFS order: parents before children
        has_local_[k] = IL_.m2l_off[k + 1] > IL_.m2l_off[k] || IL_.p2l_off[k + 1] > IL_.p2l_off[k];
        if (T_.nodes[k].parent >= 0 && has_local_[T_.nodes[k].parent]) has_local_[k] = 1;
    }
}

std::size_t Fmm::expansion_bytes() const {
    return std::size_t(mslots_ + lslots_) * W_ * sizeof(double);
}

// ---- the driver -------------------------------------------------------------------------

void Fmm::apply(Context& ctx, const double* x, double* y,
                std::map<std::string, double>& timings) {
    const Values v = load_values(x);
    std::vector<double> yt(3 * T_.s.n, 0.0);
    multipoles_.assign(std::size_t(mslots_) * W_, 0.0);
    locals_.assign(std::size_t(lslots_) * W_, 0.0);
    timed(timings, "upward", [&] { upward_pass(ctx, v); });
    timed(timings, "m2l", [&] { far_field(ctx, v); });
    timed(timings, "downward", [&] { downward_pass(ctx); });
    timed(timings, "near", [&] { leaf_evaluation(ctx, v, yt.data()); });
    store_values(yt.data(), y);
}

// Values in tree order, interleaved (for P2M) and as three arrays (for P2P), and the nodes
// with a non-zero value (the others add nothing and are skipped), from a running count.
Fmm::Values Fmm::load_values(const double* x) const {
    const std::size_t n = T_.s.n, nn = T_.nodes.size();
    Values v;
    v.xt.resize(3 * n);
    v.x0.resize(n);
    v.x1.resize(n);
    v.x2.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint32_t j = T_.perm[i];
        v.x0[i] = v.xt[3 * i] = x[3 * j];
        v.x1[i] = v.xt[3 * i + 1] = x[3 * j + 1];
        v.x2[i] = v.xt[3 * i + 2] = x[3 * j + 2];
    }
    std::vector<std::uint32_t> nonzero(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i)
        nonzero[i + 1] = nonzero[i] + (v.x0[i] != 0.0 || v.x1[i] != 0.0 || v.x2[i] != 0.0);
    v.live.resize(nn);
    for (std::size_t k = 0; k < nn; ++k)
        v.live[k] = nonzero[T_.nodes[k].end] > nonzero[T_.nodes[k].begin];
    return v;
}

void Fmm::store_values(const double* yt, double* y) const {
    for (std::size_t i = 0; i < T_.s.n; ++i) {
        const std::uint32_t j = T_.perm[i];
        y[3 * j] = yt[3 * i];
        y[3 * j + 1] = yt[3 * i + 1];
        y[3 * j + 2] = yt[3 * i + 2];
    }
}

// ---- upward pass: P2M, M2M ----------------------------------------------------------------

void Fmm::upward_pass(Context& ctx, const Values& v) {
    ctx.set_phase("upward", 0.0, 0.15);
    checkpoint(ctx, 0.0);
    for (int lev = T_.depth; lev >= 0; --lev) {
        const auto& ids = T_.levels[lev];
        parallel_for(ctx, ids.size(), kUpwardGrain, [&](std::size_t b, std::size_t e) {
            std::vector<double> work(work_size_), tmp(W_);
            for (std::size_t q = b; q < e; ++q) form_multipole(ids[q], v, tmp.data(), work.data());
        });
    }
}

void Fmm::leaf_p2m(const OctreeNode& nd, const Values& v, double* M, double* work) const {
    const std::size_t o = nd.begin;
    const SurfelSoA& s = T_.s;
    p2m(tables_, nd.center, &s.px[o], &s.py[o], &s.pz[o], &s.nx[o], &s.ny[o], &s.nz[o],
        &s.area[o], &v.xt[3 * o], nd.count(), M, work);
}

// A node's stored multipole: P2M at a leaf, else M2M from its children (a child leaf nobody
// reads is formed here on the fly, in tmp).
void Fmm::form_multipole(std::int32_t id, const Values& v, double* tmp, double* work) {
    if (mslot_[id] < 0) return;  // a leaf nobody reads: its parent forms it
    const OctreeNode& nd = T_.nodes[id];
    double* Mn = multipole(id);
    if (nd.leaf()) {
        leaf_p2m(nd, v, Mn, work);
        return;
    }
    for (int c = 0; c < nd.nchild; ++c) {
        const std::int32_t cid = nd.child + c;
        const OctreeNode& ch = T_.nodes[cid];
        const double* Mc;
        if (mslot_[cid] >= 0) {
            Mc = multipole(cid);
        } else {
            std::fill(tmp, tmp + W_, 0.0);
            leaf_p2m(ch, v, tmp, work);
            Mc = tmp;
        }
        const double delta[3] = {nd.center[0] - ch.center[0], nd.center[1] - ch.center[1],
                                 nd.center[2] - ch.center[2]};
        m2m(tables_, delta, Mc, Mn, work);
    }
}

// ---- far field: M2L, P2L ------------------------------------------------------------------

// M2L and P2L for internal nodes (leaves gather theirs in the leaf evaluation).
void Fmm::far_field(Context& ctx, const Values& v) {
    ctx.set_phase("m2l", 0.15, 0.35);
    parallel_for(ctx, internal_.size(), kFarFieldGrain, [&](std::size_t b, std::size_t e) {
        std::vector<double> work(work_size_), buf(far_buffer_size(), 0.0);
        for (std::size_t q = b; q < e; ++q) {
            const std::int32_t tn = internal_[q];
            m2l_into(tn, v, local(tn), work.data(), buf.data());
            p2l_into(tn, v, local(tn), work.data());
        }
    });
}

// M2L into the local expansion L of node tn. Sources whose values are all zero add nothing
// and are left out (K(E) has values at the emitters only). Four sources at a time (m2l4, SIMD
// across sources; a weighted PARTIAL far leaf pair scales its multipole by its weight in
// m2l4's lane copy: M2L is linear in it); a last group of two or three is padded with zero
// multipoles, a single source goes alone (scaled into buf). The next group's multipoles are
// prefetched while one group is contracted: leaf targets read their sources' multipoles
// from all over the store. `buf`: far_buffer_size() doubles, the last W_ of them zero.
void Fmm::m2l_into(std::int32_t tn, const Values& v, double* L, double* work,
                   double* buf) const {
    const OctreeNode& nt = T_.nodes[tn];
    const double* zero = buf + 4 * W_;
    const bool weighted = !IL_.m2l_w.empty();
    const std::int64_t k0 = IL_.m2l_off[tn], k1 = IL_.m2l_off[tn + 1];
    auto prefetch = [&](std::int64_t k) {  // the multipoles of the next four live sources
        for (int c = 0; c < 4 && k < k1; ++k) {
            const std::int32_t sn = IL_.m2l_src[k];
            if (!v.live[sn]) continue;
            const char* p = reinterpret_cast<const char*>(multipole(sn));
            for (std::size_t b = 0; b < W_ * sizeof(double); b += 64) __builtin_prefetch(p + b);
            ++c;
        }
    };
    double R4[4][3], w4[4];
    const double* M4[4];
    bool any_weight = false;
    int q = 0;
    std::int64_t k = k0;
    prefetch(k);
    while (k < k1) {
        const std::int32_t sn = IL_.m2l_src[k];
        const double w = weighted ? double(IL_.m2l_w[k]) : 1.0;
        ++k;
        if (!v.live[sn]) continue;
        const OctreeNode& ns = T_.nodes[sn];
        for (int d = 0; d < 3; ++d) R4[q][d] = nt.center[d] - ns.center[d];
        M4[q] = multipole(sn);
        w4[q] = w;
        any_weight = any_weight || w != 1.0;
        if (++q == 4) {
            prefetch(k);
            m2l4(tables_, R4, M4, L, work, any_weight ? w4 : nullptr);
            q = 0;
            any_weight = false;
        }
    }
    if (q == 1) {
        const double* M = M4[0];
        if (w4[0] != 1.0) {
            for (std::size_t c = 0; c < W_; ++c) buf[c] = w4[0] * M[c];
            M = buf;
        }
        m2l(tables_, R4[0], M, L, work);
    } else if (q > 1) {
        for (int r = q; r < 4; ++r) {
            for (int d = 0; d < 3; ++d) R4[r][d] = R4[0][d];
            M4[r] = zero;
            w4[r] = 1.0;
        }
        m2l4(tables_, R4, M4, L, work, any_weight ? w4 : nullptr);
    }
}

// P2L: the facing points of source leaves straight into node tn's local expansion L. An
// entry with per-point weights (a far PARTIAL leaf pair, accepted: every pair faces) scales
// each source point by its own visibility weight (a weighted multipole and M2L).
void Fmm::p2l_into(std::int32_t tn, const Values& v, double* L, double* work) const {
    const OctreeNode& nt = T_.nodes[tn];
    const SurfelSoA& s = T_.s;
    const bool weighted = !IL_.p2l_pw.empty();
    for (std::int64_t k = IL_.p2l_off[tn]; k < IL_.p2l_off[tn + 1]; ++k) {
        if (!v.live[IL_.p2l_src[k]]) continue;
        const OctreeNode& ns = T_.nodes[IL_.p2l_src[k]];
        if (weighted && IL_.p2l_pw[k] >= 0) {
            // Every pair faces (accepted): the source leaf's multipole with each point's area
            // scaled by its weight, then one M2L.
            const float* pw = &IL_.point_w[IL_.p2l_pw[k]];
            const std::size_t o = ns.begin, cnt = ns.count();
            std::vector<double> wa(cnt), M(W_, 0.0);
            for (std::size_t q = 0; q < cnt; ++q) wa[q] = double(pw[q]) * s.area[o + q];
            p2m(tables_, ns.center, &s.px[o], &s.py[o], &s.pz[o], &s.nx[o], &s.ny[o], &s.nz[o],
                wa.data(), &v.xt[3 * o], cnt, M.data(), work);
            const double R[3] = {nt.center[0] - ns.center[0], nt.center[1] - ns.center[1],
                                 nt.center[2] - ns.center[2]};
            m2l(tables_, R, M.data(), L, work);
            continue;
        }
        for (std::uint32_t j = ns.begin; j < ns.end; ++j) {
            if (point_node_class(s, j, nt) != 1) continue;
            const double R[3] = {nt.center[0] - s.px[j], nt.center[1] - s.py[j],
                                 nt.center[2] - s.pz[j]};
            const double nA[3] = {s.nx[j] * s.area[j], s.ny[j] * s.area[j], s.nz[j] * s.area[j]};
            double s9[9];
            for (int bb = 0; bb < 3; ++bb)
                for (int ch = 0; ch < 3; ++ch) s9[3 * bb + ch] = nA[bb] * v.xt[3 * j + ch];
            p2l(tables_, R, s9, L, work);
        }
    }
}

// ---- downward pass: L2L -------------------------------------------------------------------

// Between internal nodes, top-down (leaves take theirs in the leaf evaluation).
void Fmm::downward_pass(Context& ctx) {
    ctx.set_phase("downward", 0.5, 0.05);
    for (int lev = 1; lev <= T_.depth; ++lev) {
        const auto& ids = T_.levels[lev];
        parallel_for(ctx, ids.size(), kDownwardGrain, [&](std::size_t b, std::size_t e) {
            std::vector<double> work(work_size_);
            for (std::size_t q = b; q < e; ++q) {
                const OctreeNode& nd = T_.nodes[ids[q]];
                if (nd.leaf() || !has_local_[nd.parent]) continue;
                l2l_from_parent(ids[q], local(ids[q]), work.data());
            }
        });
    }
}

void Fmm::l2l_from_parent(std::int32_t id, double* L, double* work) const {
    const OctreeNode& nd = T_.nodes[id];
    const OctreeNode& pa = T_.nodes[nd.parent];
    const double delta[3] = {nd.center[0] - pa.center[0], nd.center[1] - pa.center[1],
                             nd.center[2] - pa.center[2]};
    l2l(tables_, delta, local(nd.parent), L, work);
}

// ---- leaf evaluation: the leaf's local, L2P, M2P, P2P ---------------------------------------

void Fmm::leaf_evaluation(Context& ctx, const Values& v, double* yt) {
    ctx.set_phase("near", 0.55, 0.45);
    parallel_for(ctx, T_.leaves.size(), kLeafGrain, [&](std::size_t b, std::size_t e) {
        std::vector<double> work(work_size_), local(W_), buf(far_buffer_size(), 0.0);
        NearSources near;
        for (std::size_t q = b; q < e; ++q)
            evaluate_leaf(T_.leaves[q], v, yt, near, local.data(), work.data(), buf.data());
    });
}

// y at the receivers of leaf ln: its local expansion (L2L from the parent + its own M2L /
// P2L, assembled in `local`) evaluated by L2P, M2P from its M2P sources, and P2P.
void Fmm::evaluate_leaf(std::int32_t ln, const Values& v, double* yt, NearSources& near,
                        double* local, double* work, double* buf) const {
    const OctreeNode& nd = T_.nodes[ln];
    const bool loc = has_local_[ln];
    if (loc) {
        std::fill(local, local + W_, 0.0);
        if (nd.parent >= 0 && has_local_[nd.parent]) l2l_from_parent(ln, local, work);
        m2l_into(ln, v, local, work, buf);
        p2l_into(ln, v, local, work);
    }
    gather_near(ln, v, near);
    weighted_locals(ln, v, near, work);
    const std::size_t nb = near.blocked.n;
    for (std::uint32_t i = nd.begin; i < nd.end; ++i) {
        double acc[3] = {0, 0, 0};
        if (loc) l2p_at(i, nd, local, acc, work);
        m2p_at(i, ln, v, acc, work);
        if (!near.pair_weights.empty()) weighted_at(i, nd, near, acc, work);
        const Receiver rc{T_.s.px[i], T_.s.py[i], T_.s.pz[i], T_.s.nx[i],
                          T_.s.ny[i], T_.s.nz[i], T_.s.area[i]};
        if (near.plain.n) accumulate_sources(rc, near.plain, acc);
        if (nb) accumulate_sources_weighted(rc, near.blocked, &near.vrows[(i - nd.begin) * nb], acc);
        yt[3 * i] = acc[0];
        yt[3 * i + 1] = acc[1];
        yt[3 * i + 2] = acc[2];
    }
}

// acc = y_i from the leaf's local expansion: -(1/pi) n_i . L(r_i), per channel.
void Fmm::l2p_at(std::uint32_t i, const OctreeNode& leaf, const double* local, double acc[3],
                 double* work) const {
    const SurfelSoA& s = T_.s;
    const double yv[3] = {s.px[i] - leaf.center[0], s.py[i] - leaf.center[1],
                          s.pz[i] - leaf.center[2]};
    double lv[9];
    l2p(tables_, yv, local, lv, work);
    for (int ch = 0; ch < 3; ++ch) acc[ch] = -receive(s, i, lv, ch);
}

// acc -= M2P: the source multipoles of leaf ln's M2P list evaluated at receiver i, for the
// sources it faces. An entry with per-point weights (a far PARTIAL leaf pair, accepted: every
// pair faces) scales it by receiver i's own visibility weight.
void Fmm::m2p_at(std::uint32_t i, std::int32_t ln, const Values& v, double acc[3],
                 double* work) const {
    const SurfelSoA& s = T_.s;
    const bool weighted = !IL_.m2p_pw.empty();
    for (std::int64_t k = IL_.m2p_off[ln]; k < IL_.m2p_off[ln + 1]; ++k) {
        const std::int32_t sn = IL_.m2p_src[k];
        const OctreeNode& nsn = T_.nodes[sn];
        if ((weighted && IL_.m2p_pw[k] >= 0) || !v.live[sn] || point_node_class(s, i, nsn) != 1)
            continue;
        const double R[3] = {s.px[i] - nsn.center[0], s.py[i] - nsn.center[1],
                             s.pz[i] - nsn.center[2]};
        double lv[9];
        m2p(tables_, R, multipole(sn), lv, work);
        for (int ch = 0; ch < 3; ++ch) acc[ch] -= receive(s, i, lv, ch);
    }
}

void Fmm::weighted_locals(std::int32_t ln, const Values& v, NearSources& near,
                          double* work) const {
    near.pair_locals.clear();
    near.pair_weights.clear();
    if (IL_.m2p_pw.empty()) return;
    const OctreeNode& nd = T_.nodes[ln];
    for (std::int64_t k = IL_.m2p_off[ln]; k < IL_.m2p_off[ln + 1]; ++k) {
        const std::int32_t sn = IL_.m2p_src[k];
        if (IL_.m2p_pw[k] < 0 || !v.live[sn]) continue;
        const OctreeNode& ns = T_.nodes[sn];
        const std::size_t at = near.pair_locals.size();
        near.pair_locals.resize(at + W_, 0.0);
        const double R[3] = {nd.center[0] - ns.center[0], nd.center[1] - ns.center[1],
                             nd.center[2] - ns.center[2]};
        m2l(tables_, R, multipole(sn), &near.pair_locals[at], work);
        near.pair_weights.push_back(IL_.m2p_pw[k]);
    }
}

// acc -= the weighted far pairs' locals at receiver i, each scaled by i's weight.
void Fmm::weighted_at(std::uint32_t i, const OctreeNode& leaf, const NearSources& near,
                      double acc[3], double* work) const {
    const SurfelSoA& s = T_.s;
    const double yv[3] = {s.px[i] - leaf.center[0], s.py[i] - leaf.center[1],
                          s.pz[i] - leaf.center[2]};
    for (std::size_t e = 0; e < near.pair_weights.size(); ++e) {
        const double w = IL_.point_w[near.pair_weights[e] + (i - leaf.begin)];
        if (w == 0.0) continue;
        double lv[9];
        l2p(tables_, yv, &near.pair_locals[e * W_], lv, work);
        for (int ch = 0; ch < 3; ++ch) acc[ch] -= w * receive(s, i, lv, ch);
    }
}

// The near sources of leaf ln (its P2P list), in near.plain and near.blocked. Source leaves
// whose values are all zero add nothing and are left out (the first application, K(E), has
// values at the emitters only).
void Fmm::gather_near(std::int32_t ln, const Values& v, NearSources& near) const {
    const bool weighted = !IL_.p2p_w.empty();
    auto has_block = [&](std::int64_t k) { return weighted && IL_.p2p_blk[k] >= 0; };
    const std::int64_t k0 = IL_.p2p_off[ln], k1 = IL_.p2p_off[ln + 1];
    std::size_t nplain = 0, nblocked = 0;
    for (std::int64_t k = k0; k < k1; ++k)
        if (v.live[IL_.p2p_src[k]])
            (has_block(k) ? nblocked : nplain) += T_.nodes[IL_.p2p_src[k]].count();
    const std::size_t ct = T_.nodes[ln].count();
    auto gather = [&](std::vector<double>& into, std::size_t total, bool blocked) {
        into.resize(std::max<std::size_t>(1, kNearArrays * total));
        if (blocked) near.vrows.resize(ct * total);
        double* d = into.data();
        std::size_t o = 0;
        for (std::int64_t k = k0; k < k1; ++k) {
            if (has_block(k) != blocked || !v.live[IL_.p2p_src[k]]) continue;
            const OctreeNode& sn = T_.nodes[IL_.p2p_src[k]];
            const std::size_t c = sn.count(), j0 = sn.begin;
            const SurfelSoA& s = T_.s;
            const double* from[kNearArrays] = {&s.px[j0], &s.py[j0], &s.pz[j0], &s.nx[j0],
                                               &s.ny[j0], &s.nz[j0], &s.area[j0], &v.x0[j0],
                                               &v.x1[j0], &v.x2[j0]};
            for (std::size_t a = 0; a < kNearArrays; ++a)
                std::memcpy(d + a * total + o, from[a], c * sizeof(double));
            if (blocked) {
                const std::uint8_t* V = &IL_.blocks[std::size_t(IL_.p2p_blk[k])];
                for (std::size_t r = 0; r < ct; ++r)
                    std::memcpy(&near.vrows[r * total + o], V + r * c, c);
            } else if (weighted && IL_.p2p_w[k] != 1.0f) {
                const double w = IL_.p2p_w[k];
                for (std::size_t a = kFirstValueArray; a < kNearArrays; ++a)
                    for (std::size_t q = 0; q < c; ++q) d[a * total + o + q] *= w;
            }
            o += c;
        }
        return SourceView{d, d + total, d + 2 * total, d + 3 * total, d + 4 * total,
                          d + 5 * total, d + 6 * total, d + 7 * total, d + 8 * total,
                          d + 9 * total, total};
    };
    near.plain = gather(near.plain_buf, nplain, false);
    near.blocked = nblocked ? gather(near.blocked_buf, nblocked, true) : SourceView{};
}

}  // namespace illumap
