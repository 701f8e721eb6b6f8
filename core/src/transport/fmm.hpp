// fmm.hpp — the FMM evaluation of y = F_point x over an octree and its interaction lists
// (traversal.hpp), with the expansion operators of expansions.hpp. One apply runs four phases:
//
//   upward pass      P2M at the leaves, M2M into their parents, deepest level first;
//   far field        M2L (and P2L) into the local expansion of every internal node;
//   downward pass    L2L from each internal node to its internal children, top-down;
//   leaf evaluation  per leaf: its local expansion (L2L from the parent plus its own M2L / P2L),
//                    L2P at its receivers, M2P, and the near field P2P.
//
// Every parallel loop writes only its own nodes / receivers. The near-field correction and
// the choice between FMM and direct sum belong to the operator (transport_operator.hpp).
#pragma once

#include "transport/direct.hpp"
#include "transport/expansions.hpp"
#include "geometry/octree.hpp"
#include "transport/traversal.hpp"

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace illumap {

class Fmm {
public:
    // `tree` and `lists` must outlive the Fmm.
    Fmm(const Octree& tree, const InteractionLists& lists, int order);

    // y = F_point x (x, y: n x 3 row-major, in the caller's order). Adds the seconds of each
    // phase to `timings` ("upward", "m2l", "downward", "near").
    void apply(Context& ctx, const double* x, double* y, std::map<std::string, double>& timings);

    int coefficients() const { return tables_.ncoef; }
    // The stored multipole and local expansions.
    std::size_t expansion_bytes() const;

private:
    struct Values;       // one apply's values in tree order
    struct NearSources;  // a leaf's near sources, gathered contiguously

    // The phases, in the order apply() runs them.
    Values load_values(const double* x) const;
    void upward_pass(Context& ctx, const Values& v);
    void far_field(Context& ctx, const Values& v);
    void downward_pass(Context& ctx);
    void leaf_evaluation(Context& ctx, const Values& v, double* yt);
    void store_values(const double* yt, double* y) const;

    // Upward pass.
    void leaf_p2m(const OctreeNode& nd, const Values& v, double* M, double* work) const;
    void form_multipole(std::int32_t id, const Values& v, double* tmp, double* work);
    // Far field of one node into its local expansion L.
    void m2l_into(std::int32_t tn, const Values& v, double* L, double* work, double* buf) const;
    void p2l_into(std::int32_t tn, const Values& v, double* L, double* work) const;
    // Downward pass: the parent's local expansion shifted into L.
    void l2l_from_parent(std::int32_t id, double* L, double* work) const;
    // Leaf evaluation.
    void evaluate_leaf(std::int32_t ln, const Values& v, double* yt, NearSources& near,
                       double* local, double* work, double* buf) const;
    void gather_near(std::int32_t ln, const Values& v, NearSources& near) const;
    void l2p_at(std::uint32_t i, const OctreeNode& leaf, const double* local, double acc[3],
                double* work) const;
    void m2p_at(std::uint32_t i, std::int32_t ln, const Values& v, double acc[3],
                double* work) const;
    // Per-point weighted far pairs of leaf ln as receivers (InteractionLists::m2p_pw): one
    // local expansion per entry at the leaf's centre (M2L), then L2P scaled by each
    // receiver's weight (cheaper than M2P at every receiver).
    void weighted_locals(std::int32_t ln, const Values& v, NearSources& near, double* work) const;
    void weighted_at(std::uint32_t i, const OctreeNode& leaf, const NearSources& near,
                     double acc[3], double* work) const;

    double* multipole(std::int32_t node) { return &multipoles_[std::size_t(mslot_[node]) * W_]; }
    const double* multipole(std::int32_t node) const {
        return &multipoles_[std::size_t(mslot_[node]) * W_];
    }
    double* local(std::int32_t node) { return &locals_[std::size_t(lslot_[node]) * W_]; }
    const double* local(std::int32_t node) const {
        return &locals_[std::size_t(lslot_[node]) * W_];
    }
    // m2l_into's buffer: four scaled multipoles and one zero multipole.
    std::size_t far_buffer_size() const { return 5 * W_; }

    const Octree& T_;
    const InteractionLists& IL_;
    ExpansionTables tables_;
    std::size_t W_;         // doubles per expansion: 9 per coefficient
    std::size_t work_size_; // doubles of work buffer the expansion operators need
    // Storage slots: multipoles for internal nodes and for leaves that some list reads
    // (others are formed on the fly by their parent); locals for internal nodes only (a
    // leaf's local is assembled on the fly where it is evaluated). -1: none stored.
    std::vector<std::int32_t> mslot_, lslot_;
    std::int32_t mslots_ = 0, lslots_ = 0;
    std::vector<std::int32_t> internal_;  // internal node ids
    std::vector<char> has_local_;         // the node's local expansion is not zero
    std::vector<double> multipoles_, locals_;  // kept between applies (no re-allocation)
};

}  // namespace illumap
