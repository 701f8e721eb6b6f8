// raycast.hpp — visibility="exact": occlusion rays against the surfels as oriented discs.
//
// Every surfel k is an Embree RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT of radius
// coverage * sqrt(A_k / pi) and normal n_k (discs occlude from both sides). V(i, j) is one
// occlusion ray between the centres of i and j, cast from min(i,j) to max(i,j) so that V is
// symmetric. Degenerate cases:
//   * the endpoints' own discs, coincident duplicates and overlapping neighbours: each end of
//     the segment is trimmed by the part of the ray within endpoint_offset * r (r: that
//     endpoint's disc radius) of the endpoint's tangent plane, i.e. endpoint_offset * r /
//     |cos| along the ray, at most 2 r (OccluderScene::trim; default 0.05, well above float
//     noise). A perpendicular ray loses 0.05 r; a grazing one up to 2 r, the farthest a disc
//     that contains the endpoint can reach. Without the angle, neighbours' discs on a curved
//     surface (they pass ~d^2/2R above the endpoint) blocked rays leaving at up to ~10 degrees
//     and made most near leaf pairs on a sphere PARTIAL;
//   * pairs closer than the two trims together, and coincident pairs, are visible (V = 1);
//   * with triangles as occluders, a segment that leaves or reaches a surfel behind the face
//     the surfel lies on is blocked without a ray (OccluderScene::leaves_front): a smooth
//     normal tilts off its face near a crease, and the trims would let such a segment, which
//     crosses the surfel's own face at its end, couple a part's inside to its outside;
//   * a disc seen exactly edge-on (the segment lies in its plane) does not occlude (Embree's
//     disc test divides by n.d = 0 and reports no hit; no NaN reaches our side).
// Positions are shifted to the scene's box centre before conversion to float, so precision is
// relative to the scene size (millimetres and kilometres behave alike).
//
// Trade-off of `coverage`: sqrt(A/pi) discs (coverage 1) tile a surface with gaps (a square
// grid of spacing h leaves ~21% of the area uncovered) so rays leak through walls; coverage
// >= sqrt(2)*sqrt(pi)/2 = 1.2533 covers a square grid fully; larger values close gaps of
// irregular sampling but make discs overhang edges and corners (over-occlusion of grazing
// pairs near edges, light blocked by a wall's overhanging rim). Default 1.3.
//
// shape = Quad (VisibilityOptions::Shape) replaces each disc by a square of the same area,
// side coverage * sqrt(A), in the tangent plane (frame a fixed function of the normal), made
// of two triangles that overlap along its diagonal (a single Embree quad leaks along it).
// Measured here: ~3x more occlusion rays per CPU-second than oriented discs (Embree's quad
// kernels are its most optimised), no leak through the test occluders at coverage 1.3 where
// discs leak 0.46% (jittered sampling), slightly more over-occlusion at edges (corners reach
// 1.25x the disc radius). shape = Octagon: a regular octagon of the same area (a fan of eight
// triangles, each overlapping its neighbours along their shared spoke): corners at 1.054x and
// edges at 0.974x the disc radius, so it closes nearly what discs close, at ~1.3x discs' speed
// in whole solves (bench/results/NOTE.md). Discs stay the default (the definition of
// the disc model).
//
// Node classes rest on `samples` sampled rays per pair and can be wrong (see visibility.hpp).
#pragma once

#include "visibility/visibility.hpp"

#include <memory>

namespace illumap {

// The Embree scene of a set of surfels as occluders (discs, quads or octagons, per VisibilityOptions'
// coverage and shape), in float coordinates relative to the surfels' box centre. Shared by
// RaycastVisibility (pairs of surfels) and the arbitrary-segment query behind
// illumap.Occluders (lamp shadows), so both see exactly the same occluders.
class OccluderScene {
public:
    // Builds the BVH over s (indices are s's own order). Embree's threads build it while the
    // calling thread polls ctx.monitor. Throws Cancelled, std::invalid_argument on bad
    // options, or std::runtime_error on an Embree error.
    // With `triangles` (n_tri x 9 doubles, world corners) the occluders are those triangles;
    // the endpoint trims then only clear the surfel's own triangle (radius() is 1e-4 of the
    // scene's size), so no ray slips past a wall near its end.
    // `shift` (3 doubles, may be null) is taken off every triangle corner (in double, as a
    // caller's shifted copy would be), so a scan's splats need no shifted copy. `shared` (may
    // be null): a ray scene of the same triangles (world corners, shift not taken off), which
    // is cast against (retained) instead of building one: its floats are relative to its own
    // centre, which this scene's rays then use; a scan's splats there are its outlines
    // (MeshScene's SplatOutlines, their filter's data held as long as the Embree scene).
    OccluderScene(Context& ctx, const SurfelSoA& s, double coverage, VisibilityOptions::Shape shape,
                  const double* triangles = nullptr, std::size_t n_tri = 0,
                  const double* shift = nullptr, const MeshScene* shared = nullptr);
    ~OccluderScene();
    OccluderScene(const OccluderScene&) = delete;
    OccluderScene& operator=(const OccluderScene&) = delete;

    std::size_t size() const { return radius_.size(); }
    float radius(std::uint32_t i) const { return radius_[i]; }  // disc radius, for trims
    // How much of a segment leaving surfel k along unit direction u is ignored: the part of
    // the ray within off * r_k of k's tangent plane, off * r_k / |n_k . u|, at most
    // kTrimReach * r_k (see raycast.cpp).
    double trim(std::uint32_t k, const double* u, double off) const;
    static constexpr double kTrimReach = 2.0;
    // Whether a segment leaving surfel k along unit u leaves on the front of the face k lies
    // on (given triangles only; true without them). A smooth-shaded surfel's normal tilts
    // away from its face near a crease, so a neighbour can face it by normals while the
    // segment between them runs behind the face, inside the part: such a pair sees nothing
    // of each other, as a renderer drops the directions below a face. The trims, which clear
    // the surfel's own face, would otherwise let that segment through.
    bool leaves_front(std::uint32_t k, const double* u) const;
    const float* radii() const { return radius_.data(); }
    VisibilityOptions::Shape shape() const { return shape_; }
    bool triangles() const { return n_tri_ > 0; }
    double build_seconds() const { return build_seconds_; }
    std::size_t bytes() const;

    // Visibility of n segments a[k] -> b[k] (world coordinates, 3 doubles each). skip[k] >= 0
    // (skip may be null) names a surfel at a[k]: the first trim(skip[k], u, endpoint_offset)
    // of the segment is ignored, as pair() does (its own disc, coincident duplicates, and
    // neighbours' discs that pass just above it).
    // out[k] = 1 when no occluder meets the remaining segment, else 0. Segments are clipped
    // to the occluders' box in double precision first, so a target may lie arbitrarily far.
    // Runs on ctx's workers with progress and cancellation (throws Cancelled).
    void segments(Context& ctx, const double* a, const double* b, const std::int64_t* skip,
                  double endpoint_offset, std::size_t n, float* out) const;

    // Internal: the ray for segment p -> q trimmed by t0 / t1 (false: nothing to test).
    bool make_ray(const double* p, const double* q, double t0, double t1, void* rtc_ray) const;
    // Internal: the ray for [s0, s1] of p + t u (unit u), t in [a, e] inside the box.
    void fill_ray(const double* p, const double* u, double a, double e, double s0, double s1,
                  void* rtc_ray) const;
    void* rtc_scene() const;  // RTCScene

private:
    struct Impl;
    Impl* impl_ = nullptr;
    std::vector<float> radius_;  // disc radius per surfel
    std::vector<float> normal_;  // unit normal per surfel (3 floats), for the trims
    // Given triangles: the unit normal of the face each surfel lies on, turned to the
    // surfel's side (3 floats; zero where no face was found), for leaves_front().
    std::vector<float> face_normal_;
    void find_faces(Context& ctx, const SurfelSoA& s);
    VisibilityOptions::Shape shape_;
    std::size_t n_tri_ = 0;  // > 0: the occluders are given triangles
    std::size_t vertices_ = 0;  // their distinct float corners (neighbours share them)
    std::size_t shared_bytes_ = 0;  // a shared scene's own estimate (MeshScene::bytes)
    double center_[3] = {0, 0, 0};
    double lo_[3] = {0, 0, 0}, hi_[3] = {0, 0, 0};  // occluders' box (padded), world units
    double back_ = 0;  // rays start this far behind their first endpoint (see raycast.cpp)
    double build_seconds_ = 0;
};

class RaycastVisibility final : public VisibilityModel {
public:
    // Builds the BVH (on a worker, the calling thread polls ctx.monitor; Embree's own threads
    // do the work). Throws Cancelled, or std::runtime_error on an Embree error.
    RaycastVisibility(Context& ctx, const Octree& tree, const VisibilityOptions& opt);
    ~RaycastVisibility() override;

    const char* name() const override { return "exact"; }
    float pair(std::uint32_t i, std::uint32_t j) const override;
    void block(std::int32_t a, std::int32_t b, float* out,
               const DrawMemo* drawn = nullptr) const override;
    // Packets of 8 coherent rays (rtcOccluded8): the samples of one node pair.
    void pairs_batch(const std::uint32_t* I, const std::uint32_t* J, int n,
                     float* out) const override;
    bool batched() const override { return opt_.packets; }

    // Occlusion of n surfel pairs (for benchmarks and callers with their own samples):
    // visible[k] = 1 if nothing lies between i[k] and j[k], with the same trimming as pair().
    void pairs(const std::uint32_t* i, const std::uint32_t* j, std::size_t n,
               float* visible) const;

    float disc_radius(std::uint32_t i) const { return scene_->radius(i); }
    const OccluderScene& scene() const { return *scene_; }

private:
    // What a pair needs: no ray (visible: coincident, or closer than the trims), a ray
    // (filled in rtc_ray), or none because it is blocked (behind an endpoint's face).
    enum class PairRay { Visible, Cast, Blocked };
    PairRay make_pair_ray(std::uint32_t i, std::uint32_t j, void* rtc_ray) const;
    std::unique_ptr<OccluderScene> scene_;
};

}  // namespace illumap
