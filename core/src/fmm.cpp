// fmm.cpp — the transport operator: tree + lists built once per geometry, then per apply:
// P2M -> M2M (upward, per level) -> M2L (per target) -> L2L (downward, per level)
// -> L2P + P2P (per target leaf). Every parallel loop writes only its own nodes/receivers.
#include "fmm.hpp"

#include "visibility_factory.hpp"

#include <chrono>
#include <cmath>
#include <cstring>

namespace illumap {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}
}  // namespace

TransportOperator::TransportOperator(Context& ctx, const double* positions, const double* normals,
                                     const double* areas, std::size_t n,
                                     const OperatorOptions& opt)
    : n_(n), opt_(opt) {
    orig_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        orig_.px[i] = positions[3 * i]; orig_.py[i] = positions[3 * i + 1]; orig_.pz[i] = positions[3 * i + 2];
        orig_.nx[i] = normals[3 * i]; orig_.ny[i] = normals[3 * i + 1]; orig_.nz[i] = normals[3 * i + 2];
        orig_.area[i] = areas[i];
    }
    ctx.set_phase("setup", 0.0, 0.0);
    checkpoint(ctx, 0.0);
    const bool with_vis = opt_.vis.method != VisMethod::None && n > 0;
    if (with_vis) {
        // The visibility model lives on the octree (also for the direct method), and is built
        // before the near correction, whose pairs it weights.
        auto t0 = Clock::now();
        ctx.set_phase("tree", 0.0, 0.05);
        checkpoint(ctx, 0.0);
        tree_ = std::make_unique<Octree>(build_octree(ctx, orig_, opt_.leaf_size));
        timings_["build_tree"] = seconds_since(t0);
        iperm_.assign(n, 0);
        for (std::size_t k = 0; k < n; ++k) iperm_[tree_->perm[k]] = std::uint32_t(k);
        t0 = Clock::now();
        ctx.set_phase("visibility", 0.05, 0.05);
        checkpoint(ctx, 0.05);
        vis_ = make_visibility(ctx, *tree_, opt_.vis);
        timings_["build_visibility"] = seconds_since(t0);
    }
    if (opt_.near_field == NearField::Disc && n > 1) {
        const auto tn = Clock::now();
        ctx.set_phase("near field", 0.1, opt_.fmm ? 0.1 : 0.4);
        PairVisibilityFn vf = [this](std::uint32_t i, std::uint32_t j) {
            return vis_->pair(iperm_[i], iperm_[j]);
        };
        near_ = std::make_unique<NearCorrection>(
            build_near_correction(ctx, orig_, vis_ ? &vf : nullptr));
        timings_["build_near"] = seconds_since(tn);
    }
    if (!opt_.fmm && vis_ && n > 1) {
        const auto tn = Clock::now();
        ctx.set_phase("direct visibility", 0.5, 0.5);
        checkpoint(ctx, 0.5);
        build_direct_visibility(ctx);
        timings_["build_direct_visibility"] = seconds_since(tn);
    }
    if (!opt_.fmm || n == 0) return;
    auto t0 = Clock::now();
    if (!tree_) {
        ctx.set_phase("tree", 0.0, 0.3);
        checkpoint(ctx, 0.0);
        tree_ = std::make_unique<Octree>(build_octree(ctx, orig_, opt_.leaf_size));
        timings_["build_tree"] = seconds_since(t0);
    }
    auto t1 = Clock::now();
    ctx.set_phase("lists", 0.3, 0.7);
    checkpoint(ctx, 0.3);
    TraversalOptions to;
    to.theta = opt_.theta;
    to.model = vis_.get();
    lists_ = std::make_unique<InteractionLists>(build_interaction_lists(ctx, *tree_, to));
    timings_["build_lists"] = seconds_since(t1);
    tables_ = std::make_unique<ExpansionTables>(opt_.order);

    // Expansion slots (see apply_fmm).
    const std::size_t nn = tree_->nodes.size();
    std::vector<char> read(nn, 0);
    for (std::int32_t sidx : lists_->m2l_src) read[sidx] = 1;
    for (std::int32_t sidx : lists_->m2p_src) read[sidx] = 1;
    mslot_.assign(nn, -1);
    lslot_.assign(nn, -1);
    for (std::size_t k = 0; k < nn; ++k) {
        const bool leaf = tree_->nodes[k].leaf();
        if (!leaf || read[k]) mslot_[k] = mslots_++;
        if (!leaf) {
            lslot_[k] = lslots_++;
            internal_.push_back(std::int32_t(k));
        }
    }
}


// Direct method with visibility: C_ij = -(1 - V_ij) F_point_ij over the facing pairs that are
// not fully visible (each unordered pair queried once), so that F_point x + C x = (F_point∘V) x.
void TransportOperator::build_direct_visibility(Context& ctx) {
    const SurfelSoA& s = orig_;
    const std::size_t n = n_;
    const std::size_t grain = 16;
    const std::size_t nchunks = (n + grain - 1) / grain;
    std::vector<std::vector<SparseEntry>> found(nchunks);
    parallel_for(ctx, n, grain, [&](std::size_t b, std::size_t e) {
        auto& mine = found[b / grain];
        for (std::size_t i = b; i < e; ++i) {
            if (ctx.cancel.load(std::memory_order_relaxed)) return;
            for (std::size_t j = i + 1; j < n; ++j) {
                const double dx = s.px[i] - s.px[j], dy = s.py[i] - s.py[j], dz = s.pz[i] - s.pz[j];
                const double fij = pair_factor(dx, dy, dz, s.nx[i], s.ny[i], s.nz[i], s.nx[j],
                                               s.ny[j], s.nz[j], s.area[j]);
                if (!(fij > 0.0)) continue;
                const float v = vis_->pair(iperm_[i], iperm_[j]);
                if (v >= 1.0f) continue;
                const double fji = pair_factor(-dx, -dy, -dz, s.nx[j], s.ny[j], s.nz[j], s.nx[i],
                                               s.ny[i], s.nz[i], s.area[i]);
                mine.push_back({std::int64_t(i), std::int64_t(j), -(1.0 - v) * fij, v * fij});
                mine.push_back({std::int64_t(j), std::int64_t(i), -(1.0 - v) * fji, v * fji});
            }
        }
    });
    checkpoint(ctx, 1.0);
    vis_direct_ = std::make_unique<NearCorrection>(assemble_correction(n, found));
}

void TransportOperator::apply(Context& ctx, const double* x, double* y) {
    auto t0 = Clock::now();
    if (!opt_.fmm || n_ == 0) {
        ctx.set_phase("direct", 0.0, 1.0);
        checkpoint(ctx, 0.0);
        direct_apply(ctx, orig_, x, y);
        if (vis_direct_) vis_direct_->apply_add(ctx, x, y);
    } else {
        apply_fmm(ctx, x, y);
    }
    if (near_) near_->apply_add(ctx, x, y);
    timings_["apply"] = seconds_since(t0);
}

void TransportOperator::apply_rows(Context& ctx, const double* x, const std::int64_t* rows,
                                   std::size_t nrows, double* y) const {
    ctx.set_phase("direct", 0.0, 1.0);
    checkpoint(ctx, 0.0);
    if (!vis_) {
        direct_rows(ctx, orig_, x, rows, nrows, y);
    } else {
        // Per-pair visibility on the fly (one ray per facing pair): the reference "direct with
        // exact visibility" on a receiver subset.
        const SurfelSoA& s = orig_;
        parallel_for(ctx, nrows, 1, [&](std::size_t b, std::size_t e) {
            for (std::size_t r = b; r < e; ++r) {
                if (ctx.cancel.load(std::memory_order_relaxed)) return;
                const std::size_t i = std::size_t(rows[r]);
                double acc[3] = {0, 0, 0};
                for (std::size_t j = 0; j < n_; ++j) {
                    double f = pair_factor(s.px[i] - s.px[j], s.py[i] - s.py[j],
                                           s.pz[i] - s.pz[j], s.nx[i], s.ny[i], s.nz[i],
                                           s.nx[j], s.ny[j], s.nz[j], s.area[j]);
                    if (!(f > 0.0)) continue;
                    f *= vis_->pair(iperm_[i], iperm_[j]);
                    acc[0] += f * x[3 * j];
                    acc[1] += f * x[3 * j + 1];
                    acc[2] += f * x[3 * j + 2];
                }
                y[3 * r] = acc[0];
                y[3 * r + 1] = acc[1];
                y[3 * r + 2] = acc[2];
            }
        });
        checkpoint(ctx, 1.0);
    }
    if (near_) near_->apply_rows_add(x, rows, nrows, y);
}

void TransportOperator::apply_fmm(Context& ctx, const double* x, double* y) {
    const Octree& T = *tree_;
    const InteractionLists& IL = *lists_;
    const ExpansionTables& tb = *tables_;
    const std::size_t nn = T.nodes.size(), nc = std::size_t(tb.ncoef), W = 9 * nc;
    const std::size_t wsz = expansion_work_size(tb);

    // Values in tree order, interleaved (for P2M) and as three arrays (for P2P).
    std::vector<double> xt(3 * n_), x0(n_), x1(n_), x2(n_), yt(3 * n_, 0.0);
    for (std::size_t i = 0; i < n_; ++i) {
        const std::uint32_t j = T.perm[i];
        x0[i] = xt[3 * i] = x[3 * j];
        x1[i] = xt[3 * i + 1] = x[3 * j + 1];
        x2[i] = xt[3 * i + 2] = x[3 * j + 2];
    }
    // Nodes with a non-zero value (the near field skips the others), from a running count.
    std::vector<std::uint32_t> nonzero(n_ + 1, 0);
    for (std::size_t i = 0; i < n_; ++i)
        nonzero[i + 1] = nonzero[i] + (x0[i] != 0.0 || x1[i] != 0.0 || x2[i] != 0.0);
    std::vector<std::uint8_t> live(nn);
    for (std::size_t k = 0; k < nn; ++k)
        live[k] = nonzero[T.nodes[k].end] > nonzero[T.nodes[k].begin];
    // Storage slots: multipoles for internal nodes and for leaves that some list reads
    // (others are formed on the fly by their parent); locals for internal nodes only (a
    // leaf's local is assembled on the fly where it is evaluated). Saves most expansion memory.
    const std::size_t nms = std::size_t(mslots_), nls = std::size_t(lslots_);
    multipoles_.assign(nms * W, 0.0);
    locals_.assign(nls * W, 0.0);
    double* M = multipoles_.data();
    double* L = locals_.data();
    auto Mof = [&](std::int32_t node) { return M + std::size_t(mslot_[node]) * W; };
    auto Lof = [&](std::int32_t node) { return L + std::size_t(lslot_[node]) * W; };
    auto leaf_p2m = [&](const OctreeNode& nd, double* out, double* work) {
        const std::size_t o = nd.begin;
        p2m(tb, nd.center, &T.s.px[o], &T.s.py[o], &T.s.pz[o], &T.s.nx[o], &T.s.ny[o],
            &T.s.nz[o], &T.s.area[o], &xt[3 * o], nd.count(), out, work);
    };

    // Upward pass, deepest level first.
    auto t = Clock::now();
    ctx.set_phase("upward", 0.0, 0.15);
    checkpoint(ctx, 0.0);
    for (int lev = T.depth; lev >= 0; --lev) {
        const auto& ids = T.levels[lev];
        parallel_for(ctx, ids.size(), 16, [&](std::size_t b, std::size_t e) {
            std::vector<double> work(wsz), tmp(W);
            for (std::size_t q = b; q < e; ++q) {
                const std::int32_t id = ids[q];
                const OctreeNode& nd = T.nodes[id];
                if (mslot_[id] < 0) continue;  // a leaf nobody reads: its parent forms it
                double* Mn = Mof(id);
                if (nd.leaf()) {
                    leaf_p2m(nd, Mn, work.data());
                    continue;
                }
                for (int c = 0; c < nd.nchild; ++c) {
                    const std::int32_t cid = nd.child + c;
                    const OctreeNode& ch = T.nodes[cid];
                    const double* Mc;
                    if (mslot_[cid] >= 0) {
                        Mc = Mof(cid);
                    } else {
                        std::fill(tmp.begin(), tmp.end(), 0.0);
                        leaf_p2m(ch, tmp.data(), work.data());
                        Mc = tmp.data();
                    }
                    const double delta[3] = {nd.center[0] - ch.center[0],
                                             nd.center[1] - ch.center[1],
                                             nd.center[2] - ch.center[2]};
                    m2m(tb, delta, Mc, Mn, work.data());
                }
            }
        });
    }
    timings_["upward"] = seconds_since(t);

    // M2L and P2L into one node's local expansion Lt. Sources whose values are all zero add
    // nothing and are left out (K(E) has values at the emitters only). M2L goes four sources
    // at a time (m2l4, SIMD across sources; a weighted PARTIAL far leaf pair as a scaled copy
    // of its multipole: M2L is linear in it); a last group of two or three is padded with
    // zero multipoles, a single source goes alone. `buf`: far_buffer_size doubles of the
    // calling worker's own.
    auto gather_far = [&](std::int32_t tn, double* Lt, double* work, double* buf) {
        const OctreeNode& nt = T.nodes[tn];
        double* wbuf = buf;   // four scaled copies, one per lane
        const double* zero = buf + 4 * W;
        const bool weighted = !IL.m2l_w.empty();
        double R4[4][3];
        const double* M4[4];
        int q = 0;
        for (std::int64_t k = IL.m2l_off[tn]; k < IL.m2l_off[tn + 1]; ++k) {
            const std::int32_t sn = IL.m2l_src[k];
            if (!live[sn]) continue;
            const OctreeNode& ns = T.nodes[sn];
            for (int d = 0; d < 3; ++d) R4[q][d] = nt.center[d] - ns.center[d];
            M4[q] = Mof(sn);
            if (weighted && IL.m2l_w[k] != 1.0f) {
                const double w = IL.m2l_w[k];
                double* Mw = wbuf + std::size_t(q) * W;
                for (std::size_t c = 0; c < W; ++c) Mw[c] = w * M4[q][c];
                M4[q] = Mw;
            }
            if (++q == 4) {
                m2l4(tb, R4, M4, Lt, work);
                q = 0;
            }
        }
        if (q == 1) {
            m2l(tb, R4[0], M4[0], Lt, work);
        } else if (q > 1) {
            for (int r = q; r < 4; ++r) {
                for (int d = 0; d < 3; ++d) R4[r][d] = R4[0][d];
                M4[r] = zero;
            }
            m2l4(tb, R4, M4, Lt, work);
        }
        // P2L: facing points of source leaves straight into this node's local expansion.
        for (std::int64_t k = IL.p2l_off[tn]; k < IL.p2l_off[tn + 1]; ++k) {
            if (!live[IL.p2l_src[k]]) continue;
            const OctreeNode& ns = T.nodes[IL.p2l_src[k]];
            for (std::uint32_t j = ns.begin; j < ns.end; ++j) {
                if (point_node_class(T.s, j, nt) != 1) continue;
                const double R[3] = {nt.center[0] - T.s.px[j], nt.center[1] - T.s.py[j],
                                     nt.center[2] - T.s.pz[j]};
                const double nA[3] = {T.s.nx[j] * T.s.area[j], T.s.ny[j] * T.s.area[j],
                                      T.s.nz[j] * T.s.area[j]};
                double s9[9];
                for (int bb = 0; bb < 3; ++bb)
                    for (int ch = 0; ch < 3; ++ch) s9[3 * bb + ch] = nA[bb] * xt[3 * j + ch];
                p2l(tb, R, s9, Lt, work);
            }
        }
    };
    // gather_far's buffer: four scaled multipoles and one zero multipole.
    const std::size_t far_buffer_size = 5 * W;

    // M2L for internal nodes (leaves gather theirs in the last phase).
    t = Clock::now();
    ctx.set_phase("m2l", 0.15, 0.35);
    parallel_for(ctx, internal_.size(), 4, [&](std::size_t b, std::size_t e) {
        std::vector<double> work(wsz), fbuf(far_buffer_size, 0.0);
        for (std::size_t q = b; q < e; ++q)
            gather_far(internal_[q], Lof(internal_[q]), work.data(), fbuf.data());
    });
    timings_["m2l"] = seconds_since(t);

    // Downward pass between internal nodes, top-down.
    t = Clock::now();
    ctx.set_phase("downward", 0.5, 0.05);
    std::vector<char> has_local(nn, 0);
    for (std::size_t k = 0; k < nn; ++k) {  // BFS order: parents before children
        has_local[k] = IL.m2l_off[k + 1] > IL.m2l_off[k] || IL.p2l_off[k + 1] > IL.p2l_off[k];
        if (T.nodes[k].parent >= 0 && has_local[T.nodes[k].parent]) has_local[k] = 1;
    }
    for (int lev = 1; lev <= T.depth; ++lev) {
        const auto& ids = T.levels[lev];
        parallel_for(ctx, ids.size(), 32, [&](std::size_t b, std::size_t e) {
            std::vector<double> work(wsz);
            for (std::size_t q = b; q < e; ++q) {
                const OctreeNode& nd = T.nodes[ids[q]];
                if (nd.leaf() || !has_local[nd.parent]) continue;
                const OctreeNode& pa = T.nodes[nd.parent];
                const double delta[3] = {nd.center[0] - pa.center[0], nd.center[1] - pa.center[1],
                                         nd.center[2] - pa.center[2]};
                l2l(tb, delta, Lof(nd.parent), Lof(ids[q]), work.data());
            }
        });
    }
    timings_["downward"] = seconds_since(t);

    // Leaves: assemble the local expansion (L2L from the parent + own M2L/P2L), evaluate it,
    // add M2P and the near field.
    t = Clock::now();
    ctx.set_phase("near", 0.55, 0.45);
    parallel_for(ctx, T.leaves.size(), 4, [&](std::size_t b, std::size_t e) {
        std::vector<double> work(wsz), Lleaf(W), fbuf(far_buffer_size, 0.0);
        std::vector<double> buf, bbuf;  // this leaf's near sources (bbuf: with per-pair V)
        std::vector<std::uint8_t> vrows;   // their V, receiver-major (row r: receiver r)
        for (std::size_t q = b; q < e; ++q) {
            const std::int32_t ln = T.leaves[q];
            const OctreeNode& nd = T.nodes[ln];
            const bool loc = has_local[ln];
            if (loc) {
                std::fill(Lleaf.begin(), Lleaf.end(), 0.0);
                if (nd.parent >= 0 && has_local[nd.parent]) {
                    const OctreeNode& pa = T.nodes[nd.parent];
                    const double delta[3] = {nd.center[0] - pa.center[0],
                                             nd.center[1] - pa.center[1],
                                             nd.center[2] - pa.center[2]};
                    l2l(tb, delta, Lof(nd.parent), Lleaf.data(), work.data());
                }
                gather_far(ln, Lleaf.data(), work.data(), fbuf.data());
            }
            const double* Ll = Lleaf.data();
            // Near sources gathered contiguously (SoA), in two sets: entries without per-pair
            // V (a whole-entry weight scales their values) and entries with it, whose V rows
            // (stored per entry, |t| x |s|) are gathered into vrows over the same
            // concatenation, so that each receiver sums all its blocks in one vectorised loop.
            // Source leaves whose values are all zero add nothing and are left out (the first
            // application, K(E), has values at the emitters only).
            const bool vw = !IL.p2p_w.empty();
            auto has_block = [&](std::int64_t k) { return vw && IL.p2p_blk[k] >= 0; };
            std::size_t ns = 0, nb = 0;
            for (std::int64_t k = IL.p2p_off[ln]; k < IL.p2p_off[ln + 1]; ++k)
                if (live[IL.p2p_src[k]])
                    (has_block(k) ? nb : ns) += T.nodes[IL.p2p_src[k]].count();
            const std::size_t ct = nd.count();
            auto gather = [&](std::vector<double>& into, std::size_t total, bool blocked) {
                into.resize(std::max<std::size_t>(1, 10 * total));
                if (blocked) vrows.resize(ct * total);
                double* d = into.data();
                std::size_t o = 0;
                for (std::int64_t k = IL.p2p_off[ln]; k < IL.p2p_off[ln + 1]; ++k) {
                    if (has_block(k) != blocked || !live[IL.p2p_src[k]]) continue;
                    const OctreeNode& sn = T.nodes[IL.p2p_src[k]];
                    const std::size_t c = sn.count(), j0 = sn.begin;
                    const double* from[10] = {&T.s.px[j0], &T.s.py[j0], &T.s.pz[j0],
                                              &T.s.nx[j0], &T.s.ny[j0], &T.s.nz[j0],
                                              &T.s.area[j0], &x0[j0], &x1[j0], &x2[j0]};
                    for (std::size_t a = 0; a < 10; ++a)
                        std::memcpy(d + a * total + o, from[a], c * sizeof(double));
                    if (blocked) {
                        const std::uint8_t* V = &IL.blocks[std::size_t(IL.p2p_blk[k])];
                        for (std::size_t r = 0; r < ct; ++r)
                            std::memcpy(&vrows[r * total + o], V + r * c, c);
                    } else if (vw && IL.p2p_w[k] != 1.0f) {
                        const double w = IL.p2p_w[k];
                        for (std::size_t a = 7; a < 10; ++a)
                            for (std::size_t q2 = 0; q2 < c; ++q2) d[a * total + o + q2] *= w;
                    }
                    o += c;
                }
                return SourceView{d, d + total, d + 2 * total, d + 3 * total, d + 4 * total,
                                  d + 5 * total, d + 6 * total, d + 7 * total, d + 8 * total,
                                  d + 9 * total, total};
            };
            const SourceView v = gather(buf, ns, false);
            const SourceView vb = nb ? gather(bbuf, nb, true) : SourceView{};
            for (std::uint32_t i = nd.begin; i < nd.end; ++i) {
                double acc[3] = {0, 0, 0};
                if (loc) {
                    const double yv[3] = {T.s.px[i] - nd.center[0], T.s.py[i] - nd.center[1],
                                          T.s.pz[i] - nd.center[2]};
                    double lv[9];
                    l2p(tb, yv, Ll, lv, work.data());
                    // y_i = -(1/pi) n_i . L(r_i), per channel
                    for (int ch = 0; ch < 3; ++ch)
                        acc[ch] = -kInvPi * (T.s.nx[i] * lv[ch] + T.s.ny[i] * lv[3 + ch] +
                                             T.s.nz[i] * lv[6 + ch]);
                }
                // M2P: source multipoles evaluated at each receiver that faces them.
                for (std::int64_t k = IL.m2p_off[ln]; k < IL.m2p_off[ln + 1]; ++k) {
                    const std::int32_t sn = IL.m2p_src[k];
                    const OctreeNode& nsn = T.nodes[sn];
                    if (!live[sn] || point_node_class(T.s, i, nsn) != 1) continue;
                    const double R[3] = {T.s.px[i] - nsn.center[0], T.s.py[i] - nsn.center[1],
                                         T.s.pz[i] - nsn.center[2]};
                    double lv[9];
                    m2p(tb, R, Mof(sn), lv, work.data());
                    for (int ch = 0; ch < 3; ++ch)
                        acc[ch] -= kInvPi * (T.s.nx[i] * lv[ch] + T.s.ny[i] * lv[3 + ch] +
                                             T.s.nz[i] * lv[6 + ch]);
                }
                const Receiver rc{T.s.px[i], T.s.py[i], T.s.pz[i], T.s.nx[i],
                                  T.s.ny[i], T.s.nz[i], T.s.area[i]};
                if (ns) accumulate_sources(rc, v, acc);
                if (nb) accumulate_sources_weighted(rc, vb, &vrows[(i - nd.begin) * nb], acc);
                yt[3 * i] = acc[0];
                yt[3 * i + 1] = acc[1];
                yt[3 * i + 2] = acc[2];
            }
        }
    });
    timings_["near"] = seconds_since(t);

    for (std::size_t i = 0; i < n_; ++i) {
        const std::uint32_t j = T.perm[i];
        y[3 * j] = yt[3 * i];
        y[3 * j + 1] = yt[3 * i + 1];
        y[3 * j + 2] = yt[3 * i + 2];
    }
}

std::map<std::string, double> TransportOperator::scalar_stats() const {
    std::map<std::string, double> s;
    s["n"] = double(n_);
    s["order"] = opt_.order;
    s["theta"] = opt_.theta;
    s["leaf_size"] = opt_.leaf_size;
    std::size_t bytes = 7 * n_ * sizeof(double);
    if (lists_) {
        s["nodes"] = double(tree_->nodes.size());
        s["leaves"] = double(tree_->leaves.size());
        s["depth"] = tree_->depth;
        s["m2l_pairs"] = double(lists_->m2l_pairs);
        s["p2p_node_pairs"] = double(lists_->p2p_node_pairs);
        s["m2p_pairs"] = double(lists_->m2p_pairs);
        s["p2l_pairs"] = double(lists_->p2l_pairs);
        s["p2p_pairs"] = double(lists_->p2p_surfel_pairs);
        s["coefficients"] = tables_->ncoef;
        const std::size_t exp_bytes =
            std::size_t(mslots_ + lslots_) * 9 * std::size_t(tables_->ncoef) * sizeof(double);
        s["tree_bytes"] = double(tree_->bytes());
        s["lists_bytes"] = double(lists_->bytes());
        s["expansion_bytes"] = double(exp_bytes);
        // + per-apply temporaries: values in tree order (3n, and 3 arrays of n) and the result (3n)
        bytes += tree_->bytes() + lists_->bytes() + exp_bytes + 9 * n_ * sizeof(double);
    } else {
        s["nodes"] = 0; s["leaves"] = 0; s["depth"] = 0; s["m2l_pairs"] = 0;
        s["p2p_node_pairs"] = 0;
        s["p2p_pairs"] = double(n_) * double(n_);
    }
    if (vis_) {
        const VisStats vs = vis_->stats();
        s["visibility_queries"] = double(vs.queries);
        s["visibility_no_facing"] = double(vs.no_facing);
        s["visibility_blocks"] = double(vs.blocks);
        s["visibility_block_pairs"] = double(vs.block_pairs);
        s["visibility_bytes"] = double(vs.bytes);
        s["time_visibility_setup"] = vs.build_seconds;
        s["visibility_samples"] = vis_->options().samples;
        bytes += vs.bytes + iperm_.capacity() * sizeof(std::uint32_t);
        if (lists_) {
            s["visibility_m2l_weighted"] = double(lists_->vis_m2l_weighted);
            s["visibility_p2p_weighted"] = double(lists_->vis_p2p_weighted);
            s["visibility_p2p_blocks"] = double(lists_->vis_p2p_blocks);
            s["visibility_block_bytes"] = double(lists_->blocks.capacity());
        }
        if (vis_direct_) {
            s["visibility_blocked_pairs"] = double(vis_direct_->pairs());
            bytes += vis_direct_->bytes();
        }
        if (!lists_) bytes += tree_->bytes();
    }
    s["near_pairs"] = near_ ? double(near_->pairs()) : 0.0;
    s["near_candidate_pairs"] = near_ ? double(near_->candidate_pairs) : 0.0;
    s["near_bytes"] = near_ ? double(near_->bytes()) : 0.0;
    s["near_limited_rows"] = near_ ? double(near_->limited_rows) : 0.0;
    if (near_) bytes += near_->bytes();
    s["bytes"] = double(bytes);
    for (const auto& kv : timings_) s["time_" + kv.first] = kv.second;
    return s;
}

std::map<std::string, std::vector<double>> TransportOperator::level_stats() const {
    std::map<std::string, std::vector<double>> s;
    auto conv = [](const std::vector<std::int64_t>& v) {
        return std::vector<double>(v.begin(), v.end());
    };
    if (vis_) {
        // The model's own counts: every classify() call, per level max(level(a), level(b)).
        const VisStats vs = vis_->stats();
        std::vector<double> a, b, c;
        for (const auto& l : vs.per_level) {
            a.push_back(double(l[0]));
            b.push_back(double(l[1]));
            c.push_back(double(l[2]));
        }
        s["visibility_valid_per_level"] = a;
        s["visibility_invalid_per_level"] = b;
        s["visibility_partial_per_level"] = c;
        if (lists_ && !lists_->vis_valid_per_level.empty()) {
            // The traversal's view: ordered pairs it queried, by class.
            s["lists_valid_per_level"] = conv(lists_->vis_valid_per_level);
            s["lists_invalid_per_level"] = conv(lists_->vis_invalid_per_level);
            s["lists_partial_per_level"] = conv(lists_->vis_partial_per_level);
        }
    }
    if (!lists_) return s;
    s["accepted_per_level"] = conv(lists_->accepted_per_level);
    s["dropped_per_level"] = conv(lists_->dropped_per_level);
    s["split_per_level"] = conv(lists_->split_per_level);
    s["near_per_level"] = conv(lists_->near_per_level);
    std::vector<double> nodes_per_level;
    for (const auto& l : tree_->levels) nodes_per_level.push_back(double(l.size()));
    s["nodes_per_level"] = nodes_per_level;
    return s;
}

}  // namespace illumap
