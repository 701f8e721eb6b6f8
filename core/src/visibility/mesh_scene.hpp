// mesh_scene.hpp — the user's triangles as an Embree scene, for evaluation at receivers.
//
// Receivers (mesh vertices and corners, display points) take their direct light and final
// gather from the true geometry rather than from surfel discs: triangles neither overhang
// outlines nor pass above a curved surface, so a lamp-lit sphere gets all of its light and a
// surface 1 mm behind an emitter is hidden by it. Coordinates are stored in float relative to
// the triangles' local frame (local_frame.hpp), so precision follows the size of the bulk of
// the scene, not its placement nor a far outlier.
//
// Rays are given in world coordinates (double); callers move their origins off the surface
// (the receiver's normal times an offset) before asking.
#pragma once

#include "geometry/local_frame.hpp"
#include "parallel.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace illumap {

// A scan's splats (splats.hpp) among a MeshScene's triangles: point k's fan of `sides`
// triangles are rows first + sides * k + m of the corners, (point, rim m, rim m + 1) wound
// to face along `facing`, rim m at radii[k * sides + m] along cos t_m u + sin t_m v,
// t_m = 2 pi m / sides. The scene casts against each fan as ONE primitive: the rectangle
// that bounds its outline in its plane (two triangles), whose hits an intersection filter
// keeps only inside the outline. A hit still names the fan triangle it lies in (row
// first + sides * k + m, with that triangle's barycentrics), so callers see the triangles
// they gave; Embree holds 4 vertices, 2 triangles and their BVH leaves per point instead of
// 12 triangles (~1 KB per point). The arrays are read during construction only.
struct SplatOutlines {
    std::size_t first = 0;           // the row of point 0's first fan triangle
    std::size_t n = 0;               // points
    std::size_t sides = 0;           // fan triangles per point
    const double* points = nullptr;  // n x 3, world
    const double* u = nullptr;       // n x 3, unit, in the point's plane
    const double* v = nullptr;       // n x 3, unit, u x v along the plane's normal
    const double* radii = nullptr;   // n x sides
    const double* facing = nullptr;  // n x 3: the fans' winding faces this way
};

struct SplatData;  // the outlines as the filter reads them (mesh_scene.cpp)

class MeshScene {
public:
    // corners: n_tri x 3 x 3 doubles (world coordinates), kept by reference, not copied (a
    // scan's splats are a dozen triangles per point): the caller keeps them alive and unchanged
    // for the scene's lifetime. splats (may be null): which of those triangles are splat fans,
    // cast against as one outline each (SplatOutlines; rows from splats->first on are all
    // splats). Throws Cancelled, std::invalid_argument (non-finite corners, bad outlines) or
    // std::runtime_error (Embree).
    MeshScene(Context& ctx, const double* corners, std::size_t n_tri,
              const SplatOutlines* splats = nullptr);
    ~MeshScene();
    MeshScene(const MeshScene&) = delete;
    MeshScene& operator=(const MeshScene&) = delete;

    std::size_t size() const { return n_tri_; }
    double extent() const { return extent_; }  // largest side of the triangles' box
    const LocalFrame& frame() const { return frame_; }
    double build_seconds() const { return build_seconds_; }
    std::size_t vertices() const { return vertices_; }  // distinct float corners Embree holds
    std::size_t splat_points() const { return n_splats_; }  // fans cast against as outlines
    // Estimated bytes of the Embree scene and the outlines (a BVH leaf: 64 bytes per
    // triangle): shared vertices 12 bytes, indices 12 per mesh triangle; per splat point its
    // rectangle (4 vertices, 2 triangles), centre and axes (36), radii (4 per side), inner
    // radius and winding (5). Inline: see rtc_scene().
    std::size_t bytes() const {
        const std::size_t mesh = n_tri_ - n_splats_ * splat_sides_;
        return vertices_ * 12 + mesh * (12 + 64) +
               n_splats_ * (48 + 2 * (12 + 64) + 36 + 4 * splat_sides_ + 5);
    }
    // What the outline test needs (mesh_scene.cpp), held by every scene that casts against
    // rtc_scene() (Embree's filter reads it), so it lives as long as the Embree scene.
    std::shared_ptr<const void> splat_keepalive() const { return splats_; }

    // out[k] = 1 when no triangle meets segment a[k] -> b[k] with its last `end_trim` (world
    // units) left out, else 0. Segments are clipped to the scene's box in double precision, so
    // b may lie arbitrarily far (a sun).
    void segments(Context& ctx, const double* a, const double* b, std::size_t n, double end_trim,
                  float* out) const;

    // Closest hits of rays o[k] + t d[k] (d unit), t in (0, tmax]: prim[k] is the triangle
    // (-1: none), t[k] its distance, front[k] 1 when the ray meets the triangle's front
    // (d . normal < 0, normal by the corners' winding).
    void intersect(Context& ctx, const double* o, const double* d, std::size_t n, double tmax,
                   std::int64_t* prim, double* t, std::uint8_t* front) const;
    // The same on the calling thread alone (for callers that parallelise over receivers);
    // uv (2 per ray, may be null) receives the hit's barycentric coordinates of corners 1, 2.
    void intersect_serial(const double* o, const double* d, std::size_t n, double tmax,
                          std::int64_t* prim, double* t, std::uint8_t* front,
                          float* uv = nullptr) const;
    // The unit normal of triangle t by its corners' winding (computed from the corners when
    // asked: a scan's 12 splat triangles per point would hold 144 bytes of normals).
    std::array<float, 3> triangle_normal(std::size_t t) const;
    // Whether a triangle meets the open segment a -> b (one ray, calling thread).
    bool occluded(const double* a, const double* b) const;
    const double* triangle_corners(std::size_t t) const { return corners_ + 9 * t; }
    // The Embree scene (RTCScene), for an OccluderScene that casts against these triangles
    // instead of building its own (it retains it: the scene outlives this object if need be).
    // Inline, so that code using it need not link this file (the native tests).
    void* rtc_scene() const { return rtc_scene_; }

private:
    struct Impl;
    Impl* impl_ = nullptr;
    std::size_t n_tri_ = 0;
    const double* corners_ = nullptr;  // world corners per triangle (9 doubles), the caller's
    LocalFrame frame_;
    double lo_[3] = {0, 0, 0}, hi_[3] = {0, 0, 0};
    double extent_ = 0;
    double build_seconds_ = 0;
    std::size_t vertices_ = 0;
    void* rtc_scene_ = nullptr;  // impl_'s scene, once built
    std::size_t n_splats_ = 0, splat_sides_ = 0;
    std::shared_ptr<SplatData> splats_;  // the outlines, when splats were given
    void add_splats(Context& ctx, const SplatOutlines& s);

    // [s0, s1] of p + t u inside the (padded) box, intersected with [0, len]; false if empty.
    bool clip(const double* p, const double* u, double len, double& s0, double& s1) const;
};

}  // namespace illumap
