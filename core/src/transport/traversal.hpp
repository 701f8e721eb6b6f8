// traversal.hpp — dual-tree traversal: classifies node pairs and builds the interaction lists.
//
// For target node t and source node s (R = c_t - c_s):
//   DROP    provably zero: no receiver in t faces any point of s, or no source in s faces any
//           point of t (cone test or slab test, whichever proves it), or visibility says invalid;
//   ACCEPT  far field (M2L): (rho_s + rho_t) < theta |R|, every pair faces both ways, and every
//           pair has t = pi r^2 / A_bar > 2 t0 (so w = 1 exactly; "point" rule: no condition);
//   NEAR    leaf-leaf pair summed directly with the exact rule (P2P);
//   SPLIT   otherwise (recurse into the larger node).
// Lists are per TARGET node (non-mutual), so the downward pass runs over targets without races.
#pragma once

#include "geometry/octree.hpp"
#include "visibility/visibility.hpp"

namespace illumap {

//   M2P     target leaf against a large source node whose facing is mixed only because the
//           target's points straddle it: each receiver is classified on its own (all facing:
//           the source multipole is evaluated at it; none: zero). Never per-point mixed.
//   P2L     the mirror case: a source leaf against a large target node; each facing source
//           point is added straight into the target's local expansion.
// (A leaf that straddles another surface's plane would otherwise need P2P with every leaf
// of that surface, which grows like N^1.5.)
// SplitS / SplitT: split that side first (it is the one straddling the other's plane).
enum class PairClass : std::uint8_t { Drop, Accept, Near, Split, M2P, P2L, SplitS, SplitT };

struct InteractionLists {
    // CSR by target node id: sources for M2L, and (leaves only) source nodes for P2P.
    std::vector<std::int64_t> m2l_off, p2p_off;
    std::vector<std::int32_t> m2l_src, p2p_src;
    // CSR by target node: M2P (target leaves only) and P2L sources.
    std::vector<std::int64_t> m2p_off, p2l_off;
    std::vector<std::int32_t> m2p_src, p2l_src;
    std::int64_t m2p_pairs = 0, p2l_pairs = 0;
    // statistics
    std::int64_t m2l_pairs = 0, p2p_node_pairs = 0, p2p_surfel_pairs = 0;
    // Visibility weights (empty when there is no visibility model), parallel to m2l_src and
    // p2p_src: m2l_w = sampled fraction of a PARTIAL far leaf pair (1 otherwise); p2p_w = the
    // same for a P2P node pair, and p2p_blk = offset into `blocks` of its per-pair V (row-major
    // |t| x |s|, tree order) or -1 (then p2p_w applies to every pair of the entry). Blocks hold
    // V quantised to 8 bits (round(kVisLevels V), kernel.hpp; exact and binary seed V, 0 or 1,
    // are kept exactly).
    std::vector<float> m2l_w, p2p_w;
    std::vector<std::int64_t> p2p_blk;
    std::vector<std::uint8_t> blocks;
    // A PARTIAL far leaf pair with a scan's point (LeafMode::PerPair, MAC holds,
    // TraversalOptions::scan) gets a visibility fraction per point of its wider leaf X
    // against the other leaf Y (VisibilityModel::point_fractions; equal ones collapse to one):
    // V_ij = w_i for i in X, both ways (reciprocal). An accepted pair goes to M2P for X's
    // points and to P2L for Y (X's points as sources); m2p_pw / p2l_pw, parallel to m2p_src /
    // p2l_src, hold the offset into `point_w` of X's weights, or -1 (unweighted). A near one
    // keeps P2P with a block of those rows.
    std::vector<std::int64_t> m2p_pw, p2l_pw;
    std::vector<float> point_w;
    std::int64_t vis_m2l_weighted = 0, vis_p2p_weighted = 0, vis_p2p_blocks = 0,
                 vis_point_weighted = 0;
    // Visibility classes of the node pairs the traversal queried, per level [valid, invalid,
    // partial] (ordered pairs: (t, s) and (s, t) both count).
    std::vector<std::int64_t> vis_valid_per_level, vis_invalid_per_level, vis_partial_per_level;
    std::vector<std::int64_t> accepted_per_level, dropped_per_level, split_per_level,
        near_per_level;
    std::size_t bytes() const;
};

struct TraversalOptions {
    double theta = 0.5;
    // A visibility model (nullptr: V = 1): classes, PARTIAL leaf pairs'
    // fractions and per-pair blocks (visibility.hpp), self leaf pairs get per-pair V too, and
    // radius ties in the split rule are broken by node_before so the lists of (t, s) and (s, t)
    // mirror each other (V symmetric: diag(A) F V stays symmetric).
    const VisibilityModel* model = nullptr;
    // Per surfel in the caller's order (tree.perm maps), the scan it is a point of (0: a
    // mesh's), or nullptr. A far PARTIAL leaf pair with a scan's point in either leaf gets
    // per-point fractions (InteractionLists::point_w) in LeafMode::PerPair: a scan's points
    // are two-sided, its inside is lit through its holes and gaps, and one fraction per pair
    // lent a floor leaf's view of it through a hole in the base to the whole leaf. Elsewhere
    // one fraction per pair, as before (per point cost 7x the rays on Cornell 300k).
    const std::uint32_t* scan = nullptr;
};

// Facing certificate for "owner" node o (whose normals are tested) against node q:
// the sign of n_i.(r_j - r_i) for i in o, j in q. all_pos: >= 0 for every pair; none_pos: <= 0.
struct Facing { bool all_pos, none_pos; };
Facing facing_bound(const OctreeNode& o, const OctreeNode& q);
// Per-point version for a leaf o (its own surfels against q's box): exact for each point of o,
// so a leaf that straddles an edge (two normals, a wide cone) is still proved facing or not.
Facing facing_points(const SurfelSoA& s, const OctreeNode& o, const OctreeNode& q);

// Surfel i against node q in both directions: 1 every pair faces both ways, 0 provably zero,
// -1 mixed. Used by the traversal and again by M2P/P2L at apply time (same answer).
int point_node_class(const SurfelSoA& s, std::uint32_t i, const OctreeNode& q);

// The multipole acceptance criterion alone (separation and strong coupling), facing aside.
bool mac_holds(const OctreeNode& t, const OctreeNode& s, double theta);

// The kernel's class of the pair (facing and the MAC), visibility aside.
PairClass classify(const SurfelSoA& s, const OctreeNode& t, const OctreeNode& src,
                   const TraversalOptions& opt);

InteractionLists build_interaction_lists(Context& ctx, const Octree& tree,
                                         const TraversalOptions& opt);

}  // namespace illumap
