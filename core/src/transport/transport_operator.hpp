// transport_operator.hpp — the transport operator y = F x: the FMM (fmm.hpp) or the exact
// direct sum (direct.hpp), plus the near-field correction (near_field.hpp) and visibility
// (visibility.hpp), behind one interface. Built once per geometry, applied many times.
#pragma once

#include "transport/direct.hpp"
#include "transport/fmm.hpp"
#include "transport/near_field.hpp"
#include "geometry/octree.hpp"
#include "transport/traversal.hpp"
#include "visibility/visibility.hpp"

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace illumap {

struct OperatorOptions {
    bool fmm = true;
    int order = 4;
    double theta = 0.5;
    int leaf_size = 32;
    NearField near_field = NearField::Disc;
    // Occlusion (visibility.hpp). With a method other than None the octree is built for the
    // direct method too (the visibility model lives on it); the direct operator then applies
    // V per pair (F_point·V as F_point minus a sparse correction over the blocked pairs, O(N²)
    // rays once per geometry), and apply_rows applies V per pair on the fly.
    VisibilityOptions vis;
    // The point cloud (scan) each surfel stands for a point of, 1, 2, …, or 0 (a mesh's); empty:
    // none. Close facing pairs of a scan and another object take the plates rule
    // (near_field.hpp).
    std::vector<std::uint32_t> scan;
};

class TransportOperator {
public:
    // positions, normals: n x 3; areas: n. Copies what it needs (in tree order for the FMM).
    TransportOperator(Context& ctx, const double* positions, const double* normals,
                      const double* areas, std::size_t n, const OperatorOptions& opt);

    std::size_t size() const { return n_; }
    const OperatorOptions& options() const { return opt_; }
    // The visibility model (nullptr for "none").
    const VisibilityModel* visibility() const { return vis_.get(); }

    // y = F x (x, y: n x 3 row-major, in the caller's order).
    void apply(Context& ctx, const double* x, double* y);
    // Exact direct sum for the listed receivers (whatever the method).
    void apply_rows(Context& ctx, const double* x, const std::int64_t* rows, std::size_t nrows,
                    double* y) const;

    // Numbers for stats(): scalars and per-level arrays.
    std::map<std::string, double> scalar_stats() const;
    std::map<std::string, std::vector<double>> level_stats() const;

private:
    // The set-up steps, in the order the constructor runs them.
    void build_tree(Context& ctx, double progress_span);
    void build_visibility(Context& ctx);
    void build_near(Context& ctx);
    void build_direct_visibility(Context& ctx);
    void build_fmm(Context& ctx);

    std::size_t n_;
    OperatorOptions opt_;
    SurfelSoA orig_;  // caller's order: direct operator and apply_rows
    std::unique_ptr<NearCorrection> near_;  // "disc" rule for close pairs (both methods)
    std::unique_ptr<Octree> tree_;          // the FMM's, or visibility's (any method)
    std::unique_ptr<VisibilityModel> vis_;  // holds a reference to *tree_ (declared after it)
    std::vector<std::uint32_t> iperm_;      // caller's index -> tree position
    std::unique_ptr<NearCorrection> vis_direct_;  // direct method: -(1 - V_ij) F_point_ij
    std::unique_ptr<InteractionLists> lists_;
    std::unique_ptr<Fmm> fmm_;              // holds references to *tree_ and *lists_
    std::map<std::string, double> timings_;
};

}  // namespace illumap
