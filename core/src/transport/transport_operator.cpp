// transport_operator.cpp — the operator's set-up once per geometry (tree, visibility, near
// correction, lists, FMM), its applications, and its statistics.
#include "transport/transport_operator.hpp"

#include "visibility/visibility_factory.hpp"

#include <chrono>
#include <cmath>

namespace illumap {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}
// The share of the set-up's progress the tree takes: with visibility the tree is followed by
// the visibility model and the near correction, without it by the lists.
constexpr double kTreeProgressWithVisibility = 0.05;
constexpr double kTreeProgressAlone = 0.3;
// Receivers per chunk when the direct method's visibility correction is built.
constexpr std::size_t kDirectVisibilityGrain = 16;
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
    if (opt_.vis.method != VisMethod::None && n > 0) {
        // The visibility model lives on the octree (also for the direct method), and is built
        // before the near correction, whose pairs it weights.
        build_tree(ctx, kTreeProgressWithVisibility);
        build_visibility(ctx);
    }
    if (opt_.near_field == NearField::Disc && n > 1) build_near(ctx);
    if (!opt_.fmm && vis_ && n > 1) build_direct_visibility(ctx);
    if (opt_.fmm && n > 0) build_fmm(ctx);
}

void TransportOperator::build_tree(Context& ctx, double progress_span) {
    const auto t0 = Clock::now();
    ctx.set_phase("tree", 0.0, progress_span);
    checkpoint(ctx, 0.0);
    tree_ = std::make_unique<Octree>(build_octree(ctx, orig_, opt_.leaf_size));
    timings_["build_tree"] = seconds_since(t0);
}

void TransportOperator::build_visibility(Context& ctx) {
    iperm_.assign(n_, 0);
    for (std::size_t k = 0; k < n_; ++k) iperm_[tree_->perm[k]] = std::uint32_t(k);
    const auto t0 = Clock::now();
    ctx.set_phase("visibility", 0.05, 0.05);
    checkpoint(ctx, 0.05);
    vis_ = make_visibility(ctx, *tree_, opt_.vis);
    timings_["build_visibility"] = seconds_since(t0);
}

void TransportOperator::build_near(Context& ctx) {
    const auto t0 = Clock::now();
    ctx.set_phase("near field", 0.1, opt_.fmm ? 0.1 : 0.4);
    PairVisibilityFn vf = [this](std::uint32_t i, std::uint32_t j) {
        return vis_->pair(iperm_[i], iperm_[j]);
    };
    near_ = std::make_unique<NearCorrection>(
        build_near_correction(ctx, orig_, vis_ ? &vf : nullptr,
                              opt_.scan.size() == n_ ? opt_.scan.data() : nullptr));
    timings_["build_near"] = seconds_since(t0);
}

void TransportOperator::build_fmm(Context& ctx) {
    if (!tree_) build_tree(ctx, kTreeProgressAlone);
    const auto t0 = Clock::now();
    ctx.set_phase("lists", 0.3, 0.7);
    checkpoint(ctx, 0.3);
    TraversalOptions to;
    to.theta = opt_.theta;
    to.model = vis_.get();
    to.scan = opt_.scan.size() == n_ ? opt_.scan.data() : nullptr;
    lists_ = std::make_unique<InteractionLists>(build_interaction_lists(ctx, *tree_, to));
    timings_["build_lists"] = seconds_since(t0);
    fmm_ = std::make_unique<Fmm>(*tree_, *lists_, opt_.order);
}

// Direct method with visibility: C_ij = -(1 - V_ij) F_point_ij over the facing pairs that are
// not fully visible (each unordered pair queried once), so that F_point x + C x = (F_point∘V) x.
void TransportOperator::build_direct_visibility(Context& ctx) {
    const auto t0 = Clock::now();
    ctx.set_phase("direct visibility", 0.5, 0.5);
    checkpoint(ctx, 0.5);
    const SurfelSoA& s = orig_;
    const std::size_t n = n_;
    const std::size_t grain = kDirectVisibilityGrain;
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
    timings_["build_direct_visibility"] = seconds_since(t0);
}

void TransportOperator::apply(Context& ctx, const double* x, double* y) {
    auto t0 = Clock::now();
    if (!opt_.fmm || n_ == 0) {
        ctx.set_phase("direct", 0.0, 1.0);
        checkpoint(ctx, 0.0);
        direct_apply(ctx, orig_, x, y);
        if (vis_direct_) vis_direct_->apply_add(ctx, x, y);
    } else {
        fmm_->apply(ctx, x, y, timings_);
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
        s["coefficients"] = fmm_->coefficients();
        const std::size_t exp_bytes = fmm_->expansion_bytes();
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
            s["visibility_point_weighted"] = double(lists_->vis_point_weighted);
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
