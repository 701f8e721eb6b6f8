// visibility.cpp — what both visibility methods share: sampled node-pair classes, fractions
// and blocks built on pair() / pairs_batch(), and the statistics (visibility.hpp).
#include "visibility/visibility.hpp"

namespace illumap {

namespace {

// Sampling gives up on a node pair after this many draws per wanted facing sample.
constexpr int kDrawsPerSample = 4;
// Node pairs per chunk in classify_batch().
constexpr std::size_t kClassifyGrain = 64;

// The random stream of the node pair (A, B): from what the two nodes are (their counts, their
// radii and where B lies from A, in units of the two radii), not from their ids or tree
// positions, which surfels elsewhere in the scene change. A cluster's pairs then draw the
// same samples whatever else the scene holds (and wherever it sits). Pairs alike in all of
// this (translated copies on a regular grid) share a stream.
std::uint64_t pair_stream(std::uint64_t seed, const OctreeNode& A, const OctreeNode& B) {
    std::uint64_t h = vis_mix(seed ^ (std::uint64_t(A.count()) << 32 | B.count()));
    const double s = A.radius + B.radius;
    if (!(s > 0)) return h;
    auto q = [&](double v) {  // in 1/1024 of the radii, bounded
        return std::uint64_t(std::llround(std::clamp(v / s * 1024.0, -1e15, 1e15)));
    };
    for (int d = 0; d < 3; ++d) h = vis_mix(h ^ q(B.center[d] - A.center[d]));
    return vis_mix(h ^ q(A.radius));
}

// The pair's nodes in canonical order (node_before): (lo, hi).
inline void canonical(const Octree& t, std::int32_t a, std::int32_t b, std::int32_t& lo,
                      std::int32_t& hi) {
    const bool ab = node_before(t.nodes[a], t.nodes[b]);
    lo = ab ? a : b;
    hi = ab ? b : a;
}

// Calls fn(i, j) (i in node lo, j in node hi, i != j, facing) for up to m sampled facing
// pairs, until fn returns false. Exhaustive (no sampling error) when |lo|*|hi| <= m.
// Deterministic per (lo, hi, seed), and the same for two node pairs of the same surfels.
template <class Fn>
void sample_pairs(const Octree& tree, std::uint64_t seed, std::int32_t lo, std::int32_t hi,
                  int m, Fn&& fn) {
    const OctreeNode &A = tree.nodes[lo], &B = tree.nodes[hi];
    const std::uint64_t na = A.count(), nb = B.count();
    if (na * nb <= std::uint64_t(m)) {
        for (std::uint32_t i = A.begin; i < A.end; ++i)
            for (std::uint32_t j = B.begin; j < B.end; ++j)
                if (i != j && vis_facing(tree.s, i, j) && !fn(i, j)) return;
        return;
    }
    std::uint64_t st = pair_stream(seed, A, B);
    int got = 0;
    for (int t = 0; t < kDrawsPerSample * m && got < m; ++t) {
        st = vis_mix(st);
        // The low and high 32 bits, scaled to [0, na) and [0, nb).
        const std::uint32_t i = A.begin + std::uint32_t((st & 0xffffffffULL) * na >> 32);
        const std::uint32_t j = B.begin + std::uint32_t((st >> 32) * nb >> 32);
        if (i == j || !vis_facing(tree.s, i, j)) continue;
        got++;
        if (!fn(i, j)) return;
    }
}

}  // namespace

VisibilityModel::VisibilityModel(const Octree& tree, const VisibilityOptions& opt)
    : tree_(tree), opt_(opt) {
    reset_stats();
}

void VisibilityModel::pairs_batch(const std::uint32_t* I, const std::uint32_t* J, int n,
                                  float* out) const {
    for (int k = 0; k < n; ++k) out[k] = pair(I[k], J[k]);
}

int VisibilityModel::sample_batch(std::int32_t lo, std::int32_t hi, float* v) const {
    // Gather the samples, then one packet query (coherent rays between two nodes).
    std::uint32_t I[kMaxBatch], J[kMaxBatch];
    int n = 0;
    sample_pairs(tree_, opt_.seed, lo, hi, std::min(opt_.samples, kMaxBatch),
                 [&](std::uint32_t i, std::uint32_t j) {
                     I[n] = i; J[n] = j; n++;
                     return true;
                 });
    pairs_batch(I, J, n, v);
    return n;
}

VisClass VisibilityModel::class_of(int vis, int n) const {
    if (n == 0) {
        count_no_facing();
        return VisClass::Valid;
    }
    return vis == n ? VisClass::Valid : (vis == 0 ? VisClass::Invalid : VisClass::Partial);
}

VisClass VisibilityModel::classify(std::int32_t a, std::int32_t b, DrawMemo* draws) const {
    std::int32_t lo, hi;
    canonical(tree_, a, b, lo, hi);
    const OctreeNode &A = tree_.nodes[lo], &B = tree_.nodes[hi];
    const bool binary_leaves = A.leaf() && B.leaf() && opt_.leaf_mode == LeafMode::Binary;
    int vis = 0, n = 0;
    if (batched()) {
        float v[kMaxBatch];
        n = sample_batch(lo, hi, v);
        for (int k = 0; k < n; ++k) vis += v[k] >= kVisibleAt;
    } else {
        // Stops at the first disagreement (then PARTIAL is certain): a PARTIAL pair costs a
        // few queries, VALID / INVALID cost `samples`. Binary leaf pairs need the full count.
        DrawMemo local(*this);
        DrawMemo& draw = draws ? *draws : local;
        sample_pairs(tree_, opt_.seed, lo, hi, opt_.samples, [&](std::uint32_t i, std::uint32_t j) {
            n++;
            if (draw(i, j) >= kVisibleAt) vis++;
            return binary_leaves || vis == n || vis == 0;
        });
    }
    VisClass c;
    if (n > 0 && binary_leaves)
        c = 2 * vis >= n ? VisClass::Valid : VisClass::Invalid;  // majority
    else
        c = class_of(vis, n);
    record(std::max(A.level, B.level), c);
    return c;
}

VisClass VisibilityModel::classify_fraction(std::int32_t a, std::int32_t b, float* frac,
                                            DrawMemo* draws) const {
    if (opt_.leaf_mode == LeafMode::Binary) {
        const VisClass c = classify(a, b, draws);
        *frac = c == VisClass::Invalid ? 0.0f : 1.0f;
        return c;
    }
    std::int32_t lo, hi;
    canonical(tree_, a, b, lo, hi);
    const OctreeNode &A = tree_.nodes[lo], &B = tree_.nodes[hi];
    double sum = 0;
    int n = 0, vis = 0;
    if (batched()) {
        float v[kMaxBatch];
        n = sample_batch(lo, hi, v);
        for (int k = 0; k < n; ++k) { sum += v[k]; vis += v[k] >= kVisibleAt; }
    } else {
        DrawMemo local(*this);
        DrawMemo& draw = draws ? *draws : local;
        sample_pairs(tree_, opt_.seed, lo, hi, opt_.samples, [&](std::uint32_t i, std::uint32_t j) {
            const float v = draw(i, j);
            n++;
            sum += v;
            vis += v >= kVisibleAt;
            return true;
        });
    }
    const VisClass c = class_of(vis, n);
    *frac = n ? float(sum / n) : 1.0f;
    record(std::max(A.level, B.level), c);
    return c;
}

float VisibilityModel::fraction(std::int32_t a, std::int32_t b) const {
    std::int32_t lo, hi;
    canonical(tree_, a, b, lo, hi);
    double sum = 0;
    int n = 0;
    DrawMemo draw(*this);
    sample_pairs(tree_, opt_.seed, lo, hi, opt_.samples, [&](std::uint32_t i, std::uint32_t j) {
        n++;
        sum += draw(i, j);
        return true;
    });
    return n ? float(sum / n) : 1.0f;
}

void VisibilityModel::point_fractions(std::int32_t x, std::int32_t y, float fallback,
                                      float* out) const {
    const OctreeNode &X = tree_.nodes[x], &Y = tree_.nodes[y];
    const int m = std::max(1, opt_.samples);
    const std::uint64_t ny = Y.count();
    const std::uint64_t base = pair_stream(opt_.seed ^ 0x5bd1e9955bd1e995ULL, X, Y);
    for (std::uint32_t i = X.begin; i < X.end; ++i) {
        double sum = 0;
        int n = 0;
        if (ny <= std::uint64_t(m)) {
            for (std::uint32_t j = Y.begin; j < Y.end; ++j)
                if (j != i && vis_facing(tree_.s, i, j)) { sum += pair(i, j); n++; }
        } else {
            std::uint64_t st = vis_mix(base ^ (std::uint64_t(i - X.begin) + 1));
            for (int t = 0; t < kDrawsPerSample * m && n < m; ++t) {
                st = vis_mix(st);
                const std::uint32_t j = Y.begin + std::uint32_t((st >> 32) * ny >> 32);
                if (j == i || !vis_facing(tree_.s, i, j)) continue;
                sum += pair(i, j);
                n++;
            }
        }
        out[i - X.begin] = n ? float(sum / n) : fallback;
    }
}

void VisibilityModel::block(std::int32_t a, std::int32_t b, float* out,
                            const DrawMemo* drawn) const {
    const OctreeNode &A = tree_.nodes[a], &B = tree_.nodes[b];
    const std::uint32_t nb = B.count();
    const bool any_known = fill_drawn(a, b, drawn, out);
    for (std::uint32_t i = A.begin; i < A.end; ++i)
        for (std::uint32_t j = B.begin; j < B.end; ++j) {
            float& v = out[std::size_t(i - A.begin) * nb + (j - B.begin)];
            if (any_known && v != kUnknown) continue;
            v = i != j && vis_facing(tree_.s, i, j) ? pair(i, j) : 1.0f;
        }
    count_block(std::uint64_t(A.count()) * nb);
}

void VisibilityModel::classify_batch(Context& ctx, const std::int32_t* a, const std::int32_t* b,
                                     std::size_t n, VisClass* out) const {
    parallel_for(ctx, n, kClassifyGrain, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t k = lo; k < hi; ++k) out[k] = classify(a[k], b[k]);
    });
}

VisStats VisibilityModel::stats() const {
    VisStats st;
    std::array<std::array<std::uint64_t, 3>, kLevels> counts{};
    for (const Shard& sh : shards_) {
        for (int l = 0; l < kLevels; ++l)
            for (int c = 0; c < 3; ++c) counts[l][c] += sh.counts[l][c].load();
        st.queries += sh.queries.load();
        st.no_facing += sh.no_facing.load();
        st.blocks += sh.blocks.load();
        st.block_pairs += sh.block_pairs.load();
    }
    int top = 0;
    for (int l = 0; l < kLevels; ++l)
        if (counts[l][0] + counts[l][1] + counts[l][2]) top = l + 1;
    st.per_level.assign(counts.begin(), counts.begin() + top);
    st.build_seconds = build_seconds_;
    st.bytes = bytes_;
    return st;
}

void VisibilityModel::reset_stats() {
    for (Shard& sh : shards_) {
        for (auto& l : sh.counts)
            for (auto& c : l) c.store(0);
        sh.queries = 0;
        sh.no_facing = 0;
        sh.blocks = 0;
        sh.block_pairs = 0;
    }
}

bool VisibilityModel::fill_drawn(std::int32_t a, std::int32_t b, const DrawMemo* drawn,
                                 float* out) const {
    if (!drawn || drawn->empty()) return false;
    const OctreeNode &A = tree_.nodes[a], &B = tree_.nodes[b];
    const std::uint32_t nb = B.count();
    std::fill(out, out + std::size_t(A.count()) * nb, kUnknown);
    auto inside = [](const OctreeNode& N, std::uint32_t i) { return i >= N.begin && i < N.end; };
    drawn->for_each([&](std::uint32_t i, std::uint32_t j, float v) {
        if (inside(A, i) && inside(B, j)) out[std::size_t(i - A.begin) * nb + (j - B.begin)] = v;
        if (inside(A, j) && inside(B, i)) out[std::size_t(j - A.begin) * nb + (i - B.begin)] = v;
    });
    return true;
}

}  // namespace illumap
