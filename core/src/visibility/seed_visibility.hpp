// seed_visibility.hpp — visibility="seed": the talk's point-based visibility, made scale-free.
//
// point_visible(p, q)  (the talk's procedure; evaluated for the canonical order p = min(i,j),
// q = max(i,j), so V is symmetric and reciprocity / CG survive):
//   1. Find the surfels k within Delta_k of the segment pq, with a walk down the octree that
//      visits only nodes whose bounding sphere comes within radius + Delta_max(node) of the
//      segment (never a linear scan). Delta_k = delta * h_k, h_k = sqrt(A_k / pi): every
//      distance is measured in units of the occluder's own spacing, so a scene in millimetres
//      and the same scene in kilometres give the same answer.
//   2. Prune by the tangent plane: keep k only if its tangent plane cuts the line pq strictly
//      inside the segment, at least 0.25 h from either end (surfels coplanar with p or q, p's and
//      q's own neighbours and coincident duplicates cut it at an endpoint and are dropped; a
//      surfel whose plane contains the line, e.g. one lying edge-on on the segment, is dropped).
//   3. Of the survivors keep the k closest to the segment and multiply their transmissions
//      tau(u), u = distance / Delta_k in [0, 1]: tau(u) = u^2 (3 - 2u) (a smooth step: 0 on the
//      segment, 1 at Delta_k; the talk's "visibility_look_up" table, analytic here).
//   4. visible iff the product > t1. pair() returns 0/1 (seed_binary_pairs) or the product.
//   The walk stops early once the product of the k closest found so far is <= t1 (the final
//   product can only be smaller), which keeps dense occluders cheap.
//
// point_leaf(p, L) (t2): p sees leaf L if more than t2 of the (sampled) facing points of L are
//   visible from p.  leaf_leaf(L, C) (t3): visible if more than t3 of C's (sampled) points see
//   L. Up to `leaf_points` points per leaf are used (evenly strided), so a leaf pair costs at
//   most leaf_points^2 point_visible calls. Thresholds are fractions (the talk's counts depend
//   on the leaf size; fractions do not).
// Node–node: the talk visits every leaf pair under A x B (quadratic at the top of the tree);
//   here classify() samples `samples` facing point pairs under A x B and calls point_visible:
//   all visible -> VALID, none -> INVALID, else PARTIAL (a sampled estimate of the talk's
//   all / none test). For two leaves in LeafMode::Binary it is the talk's Leaf_Leaf; in the
//   Fractional / PerPair modes a leaf pair is classified from samples like a node pair and a
//   PARTIAL one gets fraction() / block().
// Known failure modes (DESIGN.md §3): delta below ~1.3 leaks through walls sampled on a grid
// (the worst line through a square grid passes 1.25 h from the nearest centres); large delta or
// concave corners over-occlude; near edges surfels whose plane is cut inside the segment but
// whose disc is not crossed still attenuate.
#pragma once

#include "visibility/visibility.hpp"

namespace illumap {

class SeedVisibility final : public VisibilityModel {
public:
    SeedVisibility(Context& ctx, const Octree& tree, const VisibilityOptions& opt);

    const char* name() const override { return "seed"; }
    float pair(std::uint32_t i, std::uint32_t j) const override;
    VisClass classify(std::int32_t a, std::int32_t b, DrawMemo* draws = nullptr) const override;

    // The product of transmissions of the <= k closest occluders of segment (i, j), canonical
    // order; `early` stops at the first product <= t1 (then the value is an upper bound).
    double attenuation(std::uint32_t i, std::uint32_t j, bool early) const;
    bool point_visible(std::uint32_t i, std::uint32_t j) const {
        return attenuation(i, j, true) > opt_.t1;
    }
    bool point_leaf(std::uint32_t p, std::int32_t leaf) const;       // t2
    bool leaf_leaf(std::int32_t L, std::int32_t C) const;            // t3, canonical order

private:
    std::vector<float> hmax_;  // per node: delta * max h over its points
};

}  // namespace illumap
