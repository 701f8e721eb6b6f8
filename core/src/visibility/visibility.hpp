// visibility.hpp — the interface of occlusion between surfels, folded into the FMM's
// interaction lists.
//
// One interface (VisibilityModel; the sampling both methods share is in visibility.cpp), two
// methods, built by make_visibility() (visibility_factory.hpp):
//   "exact" (raycast.hpp)        rays against the surfels as oriented discs (Embree 3);
//   "seed"  (seed_visibility.hpp) the talk's point_visible / Leaf_Leaf / Node_Node, scale-free.
// Both are built once per geometry (over the octree, in tree order) and then queried, from any
// number of threads, by the traversal while it builds its interaction lists. Nothing here is
// touched by apply(): the traversal stores the classes / fractions / per-pair blocks it needs.
//
// What a method answers (all indices in TREE order, node ids are Octree::nodes indices):
//   pair(i, j)        V(i,j) in [0,1] for surfels i, j. Symmetric: V(i,j) == V(j,i) exactly
//                     (both methods evaluate the canonical ordering min(i,j), max(i,j)).
//   classify(a, b)    VALID (every pair sees each other), INVALID (none does) or PARTIAL.
//                     Symmetric: classify(a,b) == classify(b,a). It RESTS ON SAMPLES (m facing
//                     point pairs drawn with a deterministic per-pair RNG, seeded from the
//                     pair's geometry, not its node ids: visibility.cpp) and can be wrong: a
//                     pair with a small blocked (or visible) part can be called VALID (INVALID).
//                     tests_native/test_visibility.cpp measures that error.
//   fraction(a, b)    sampled fraction of visible facing pairs (the "fractional leaf–leaf" option).
//   block(a, b, out)  per-pair V for all i in a, j in b (row-major, |a| x |b|): the near field.
//                     classify / classify_fraction can keep their draws (DrawMemo) for a block
//                     of the same pair that follows, which then casts none of them again.
//
// How the traversal folds it in (the talk's Octree_Visibility; traversal.cpp's Walker::step):
//   1. k = classify(surf, t, s, opt)   -- the kernel alone, no query.
//      DROP / SPLIT: done (a pair the kernel splits anyway needs no visibility query).
//   2. k == ACCEPT, M2P, P2L or NEAR: c = model.classify(t, s): INVALID -> DROP; PARTIAL ->
//      SPLIT (pushed down to the children) unless both are leaves.
//   3. A NEAR pair whose class is PARTIAL gets, per leaf_mode():
//        PerPair: block(t, s) if the MAC fails (true near field), fraction(t, s) if the MAC
//                 holds (a far leaf pair the kernel would have accepted);
//        PerPairAll: block(t, s) always (the far pair moves from M2L to P2P);
//                 (a far pair with a scan's point: point_fractions() of its wider leaf,
//                 V_ij = w_i both ways, through M2P / P2L or P2P rows; traversal.hpp)
//        Fractional: fraction(t, s);   Binary (the talk): never PARTIAL.
//      A NEAR pair of two leaves can get class and fraction in one pass: classify_fraction().
//      P2P then weights pair (i, j) by 1, fraction, or block[i][j].
//   Reciprocity: classify / fraction / block are symmetric, so V_ij = V_ji whenever the lists
//   of (t, s) and (s, t) contain mirrored pairs; the traversal's split rule must then be
//   mirror-symmetric (break radius ties by node_before), otherwise sampled classes of different
//   sub-pairs can make V_ij != V_ji (then use GMRES, or PerPair everywhere).

#pragma once

#include "geometry/octree.hpp"
#include "parallel.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <vector>

namespace illumap {

enum class VisClass : std::uint8_t { Valid = 0, Invalid = 1, Partial = 2 };

// What happens to a PARTIAL leaf–leaf pair.
enum class LeafMode : std::uint8_t {
    Binary = 0,      // the talk: a leaf pair is visible or not (never PARTIAL)
    Fractional = 1,  // PARTIAL leaf pairs are scaled by fraction(a, b)
    PerPair = 2,     // PARTIAL near-field leaf pairs get per-pair block(a, b), PARTIAL far
                     // leaf pairs (MAC satisfied, cannot split) fraction(a, b)  (default)
    PerPairAll = 3,  // every PARTIAL leaf pair gets per-pair block(a, b), far ones too (P2P):
                     // one fraction per far pair cannot follow a shadow edge across its
                     // receivers, the dominant FMM error in occluded scenes
};

enum class VisMethod : std::uint8_t { None = 0, Seed = 1, Exact = 2 };

class MeshScene;  // visibility/mesh_scene.hpp

struct VisibilityOptions {
    VisMethod method = VisMethod::None;
    LeafMode leaf_mode = LeafMode::PerPair;
    // Sampling (both methods): facing point pairs drawn per node pair for classify() and
    // fraction(). Draws stop after 4*samples attempts; a pair with no facing sample is VALID
    // (the kernel clamps it to ~0 anyway) and counted in VisStats::no_facing. 8 keeps 1M
    // surfels near 120M rays (tests_native/README.md); 16 halves the misclassified share.
    int samples = 8;
    std::uint64_t seed = 0x9e3779b97f4a7c15ULL;
    // "exact": disc radius = coverage * sqrt(A/pi). 1 leaves gaps between discs (light leaks);
    // larger closes them but lets discs stick out past edges and corners (over-occlusion).
    double coverage = 1.3;
    // "exact": occluders that cross the segment within endpoint_offset * (disc radius r of the
    // endpoint) of an endpoint's tangent plane are ignored: endpoint_offset * r / |cos| along
    // the segment, at most 2 r (the endpoints' own discs, coincident duplicates, overlapping
    // neighbours on curved surfaces). Pairs closer than the two trims together are visible.
    double endpoint_offset = 0.05;
    // "exact": the occluder shape. Disc: Embree's oriented-disc points (radius coverage *
    // sqrt(A/pi)). Quad: a square of the same area in the tangent plane (side
    // coverage * sqrt(A)), two overlapping triangles; measured ~3x more rays per CPU-second
    // than discs here; its corners reach 1.25x the disc radius. Octagon: a regular octagon of
    // the same area (corners at 1.054x the disc radius, edges at 0.974x), eight overlapping
    // triangles: nearly the disc, at nearly the quad's speed.
    enum class Shape : std::uint8_t { Disc = 0, Quad = 1, Octagon = 2 } shape = Shape::Disc;
    // "exact": when set (n_triangles x 9 doubles, world corners), the occluders are these
    // triangles, the scene's true surfaces, instead of shapes made from the surfels: nothing
    // overhangs an outline and nothing leaks between surfels. Read only while building.
    const double* triangles = nullptr;
    std::size_t n_triangles = 0;
    // The occluders are triangles[k] - triangles_shift[k % 3] (the caller's world corners in
    // the surfels' frame, without a shifted copy of a scan's millions of splat triangles).
    double triangles_shift[3] = {0.0, 0.0, 0.0};
    // A ray scene of these same triangles (the receivers'), cast against instead of building
    // one of its own: one BVH of a scan's splats per run. May be null.
    const MeshScene* triangles_scene = nullptr;
    // "exact": cast the samples of a node pair as packets of 8 rays (no early exit) instead of
    // one by one with early exit on the first disagreement.
    bool packets = false;
    // "seed" (the talk): see seed_visibility.hpp for the meaning of each.
    double delta = 2.0;  // Delta, in units of each occluder's spacing h_k = sqrt(A_k/pi)
    int k = 8;           // at most k closest occluders multiply their attenuation
    double t1 = 0.5;     // point_visible: product of attenuations > t1 -> visible
    double t2 = 0.5;     // point_leaf: fraction of the leaf's (sampled) points visible > t2
    double t3 = 0.5;     // leaf_leaf: fraction of the other leaf's (sampled) points > t3
    int leaf_points = 8;  // points sampled per leaf in the talk's Leaf_Leaf (s x s queries)
    bool seed_binary_pairs = true;  // pair(): 0/1 after t1; false: the attenuation product
};

// Counts per level (level = max(level(a), level(b))), and totals.
struct VisStats {
    std::vector<std::array<std::uint64_t, 3>> per_level;  // [valid, invalid, partial]
    std::uint64_t queries = 0;    // point-pair visibility evaluations (rays or point_visible)
    std::uint64_t no_facing = 0;  // classify() calls that found no facing sample
    std::uint64_t blocks = 0, block_pairs = 0;  // block() calls and pairs they filled
    double build_seconds = 0;     // once-per-geometry set-up (Embree BVH)
    std::size_t bytes = 0;        // memory held by the method (estimate)
};

// ---- small shared helpers -------------------------------------------------------------

inline std::uint64_t vis_mix(std::uint64_t x) {  // splitmix64 finaliser
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

// i and j face each other: both cosines above kCoplanarCos (kernel.hpp), so
// round-off between coplanar surfels (the two sides of a thin panel, random samples on one
// plane) neither costs rays nor makes a node pair PARTIAL; the kernel is ~0 there anyway.
// False for coincident points.
inline bool vis_facing(const SurfelSoA& s, std::uint32_t i, std::uint32_t j) {
    const double dx = s.px[j] - s.px[i], dy = s.py[j] - s.py[i], dz = s.pz[j] - s.pz[i];
    const double ci = s.nx[i] * dx + s.ny[i] * dy + s.nz[i] * dz;
    const double cj = -(s.nx[j] * dx + s.ny[j] * dy + s.nz[j] * dz);
    const double tol = kCoplanarCos * std::sqrt(dx * dx + dy * dy + dz * dz);
    return ci > tol && cj > tol;
}

// ---- the interface ---------------------------------------------------------------------

class VisibilityModel {
public:
    VisibilityModel(const Octree& tree, const VisibilityOptions& opt);
    virtual ~VisibilityModel() = default;
    VisibilityModel(const VisibilityModel&) = delete;
    VisibilityModel& operator=(const VisibilityModel&) = delete;

    virtual const char* name() const = 0;
    const VisibilityOptions& options() const { return opt_; }
    LeafMode leaf_mode() const { return opt_.leaf_mode; }
    const Octree& tree() const { return tree_; }

    // V(i,j) in [0,1], tree order, symmetric, thread-safe.
    virtual float pair(std::uint32_t i, std::uint32_t j) const = 0;
    // out[k] = pair(I[k], J[k]) for n pairs; a method with packet queries overrides it and
    // returns true from batched() (then classify gathers its samples first; samples are
    // capped at kMaxBatch).
    virtual void pairs_batch(const std::uint32_t* I, const std::uint32_t* J, int n,
                             float* out) const;
    virtual bool batched() const { return false; }
    static constexpr int kMaxBatch = 64;

    // The pairs a sampling pass has queried, with their answers. Draws are with replacement,
    // so on two small nodes a quarter of them can repeat: a pair drawn again reuses its first
    // answer (V is deterministic) and still counts as a sample. A caller that passes one to
    // classify() and then to block() of the same node pair pays no query twice (a PARTIAL
    // leaf pair's sampled rays are part of its block).
    class DrawMemo {
    public:
        explicit DrawMemo(const VisibilityModel& m) : m_(m) {}
        float operator()(std::uint32_t i, std::uint32_t j) {
            for (int k = 0; k < n_; ++k)
                if (i_[k] == i && j_[k] == j) return v_[k];
            const float v = m_.pair(i, j);
            if (n_ < kMax) { i_[n_] = i; j_[n_] = j; v_[n_++] = v; }
            return v;
        }
        bool empty() const { return n_ == 0; }
        // fn(i, j, V(i, j)) for each kept draw.
        template <class Fn>
        void for_each(Fn&& fn) const {
            for (int k = 0; k < n_; ++k) fn(i_[k], j_[k], v_[k]);
        }
    private:
        static constexpr int kMax = 64;
        const VisibilityModel& m_;
        std::uint32_t i_[kMax], j_[kMax];
        float v_[kMax];
        int n_ = 0;
    };

    // Sampled classification, symmetric, thread-safe; records stats. Without packets it
    // stops at the first disagreement (PARTIAL is then certain), except for two leaves in
    // LeafMode::Binary, which take a majority of all `samples`. With `draws`, the pairs it
    // queries (one by one; not in packets) are kept there for block().
    virtual VisClass classify(std::int32_t a, std::int32_t b, DrawMemo* draws = nullptr) const;

    // One pass for a pair of LEAVES that cannot be split: the class and the sampled fraction
    // together (`samples` queries, no early exit), so a PARTIAL far leaf pair costs no second
    // round of queries. In LeafMode::Binary it is classify() (fraction 1 or 0). `draws`: as
    // in classify().
    virtual VisClass classify_fraction(std::int32_t a, std::int32_t b, float* frac,
                                       DrawMemo* draws = nullptr) const;

    // Sampled mean of V over facing pairs (1 if none faces). Symmetric, thread-safe.
    virtual float fraction(std::int32_t a, std::int32_t b) const;

    // Per point of node x: the sampled mean of V(i, j) over `samples` facing j in node y
    // (all of y when |y| <= samples), out[i - x.begin]; `fallback` where i faces none drawn.
    // One far PARTIAL leaf pair's fraction cannot follow a shadow edge across the wider leaf
    // (a floor leaf of which one point sees through a hole): the traversal weights each of
    // its points by its own. Deterministic per (x, y, seed); thread-safe.
    virtual void point_fractions(std::int32_t x, std::int32_t y, float fallback,
                                 float* out) const;

    // out[(i - a.begin) * |b| + (j - b.begin)] = V(i, j); pairs that do not face get 1 (the
    // kernel is zero there) without a query; pairs in `drawn` (a classify() of a and b) get
    // their kept answer without one. Thread-safe.
    virtual void block(std::int32_t a, std::int32_t b, float* out,
                       const DrawMemo* drawn = nullptr) const;

    // classify() for a batch of pairs on ctx's workers, with progress and cancellation
    // (throws Cancelled). For a traversal that builds its lists level by level.
    void classify_batch(Context& ctx, const std::int32_t* a, const std::int32_t* b,
                        std::size_t n, VisClass* out) const;

    VisStats stats() const;
    void reset_stats();

    // A sampled pair counts as visible when V >= kVisibleAt.
    static constexpr float kVisibleAt = 0.5f;

protected:
    // block() helpers: with draws kept for the pair (a, b), every entry of out (|a| x |b|) is
    // set to kUnknown but the drawn ones, which get their answer; returns false (out
    // untouched) when there are none.
    static constexpr float kUnknown = -1.0f;
    bool fill_drawn(std::int32_t a, std::int32_t b, const DrawMemo* drawn, float* out) const;

    void record(int level, VisClass c) const {
        shard().counts[std::min(level, kLevels - 1)][int(c)].fetch_add(1, std::memory_order_relaxed);
    }
    void count_queries(std::uint64_t n) const {
        shard().queries.fetch_add(n, std::memory_order_relaxed);
    }
    void count_no_facing() const { shard().no_facing.fetch_add(1, std::memory_order_relaxed); }
    void count_block(std::uint64_t pairs) const {
        Shard& sh = shard();
        sh.blocks.fetch_add(1, std::memory_order_relaxed);
        sh.block_pairs.fetch_add(pairs, std::memory_order_relaxed);
    }

    static constexpr int kLevels = 64;
    const Octree& tree_;
    VisibilityOptions opt_;
    // The statistics, counted once per ray or class from every thread: one shard per thread
    // (by a thread's first use; more threads than shards share them), each on its own cache
    // lines. A single shared counter cost a contended atomic per ray (most of pair()'s own
    // time on two cores); stats() sums the shards.
    static constexpr int kShards = 16;
    struct alignas(64) Shard {
        std::array<std::array<std::atomic<std::uint64_t>, 3>, kLevels> counts;
        std::atomic<std::uint64_t> queries{0}, no_facing{0}, blocks{0}, block_pairs{0};
    };
    Shard& shard() const {
        static std::atomic<unsigned> next{0};
        thread_local const unsigned mine = next.fetch_add(1, std::memory_order_relaxed);
        return shards_[mine % kShards];
    }
    mutable std::array<Shard, kShards> shards_;
    double build_seconds_ = 0;
    std::size_t bytes_ = 0;

private:
    // The samples of the node pair (lo, hi) queried in one packet (at most kMaxBatch);
    // returns their number.
    int sample_batch(std::int32_t lo, std::int32_t hi, float* v) const;
    // The class from `vis` visible samples out of n (none: Valid, counted in no_facing).
    VisClass class_of(int vis, int n) const;
};

}  // namespace illumap
