// gather.hpp — the final gather at receivers: indirect light from the surfels' solution.
//
// Each receiver casts `rays` cosine-distributed rays against the scene's triangles
// (MeshScene); a ray that meets a triangle's front takes the surfels' reflected radiance
// there (SurfelField: the nearest surfels whose normal agrees with the triangle's, by inverse
// squared distance), one that meets a back face the back field's (or black: surfaces are
// one-sided), one that leaves the scene the background radiance. The field is tabulated once
// on a barycentric lattice of each triangle, about as fine as the surfels, and a hit
// interpolates it: one lookup per lattice point, none per hit. The mean is the receiver's
// indirect incident radiance (irradiance / pi). Directions come from one rank-1 lattice,
// shifted per receiver by a hash of (seed, receiver id): results do not depend on threads,
// chunking or the order of receivers. Python: illumap.receivers.
#pragma once

#include "gather/surfel_field.hpp"
#include "geometry/knn.hpp"
#include "visibility/mesh_scene.hpp"

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace illumap {

// `count` unit directions (count x 3, row-major) about unit normal n for receiver `id`.
void cosine_directions(const double n[3], std::size_t count, std::int64_t id, std::uint64_t seed,
                       double* dirs);

struct GatherOptions {
    double offset = 0;                    // ray origins move this far along the normal (m)
    double background[3] = {0, 0, 0};     // radiance of rays that leave the scene
    // Tabulate the field on the triangles that are not splats (a lattice, looked up once per
    // point); false: each hit looks the field up itself (a few receivers in a large scene).
    bool tabulate = true;
};

// A part of a field known exactly at the gather's lattice points (direct light, evaluated with
// shadow rays there): the table then holds `rest` looked up plus `lattice` (3 per lattice
// point, in gather_lattices' order), so that sharp light is not blurred by the surfels' spacing.
struct ExactPart {
    const SurfelField* rest = nullptr;
    const double* lattice = nullptr;
};

// A splat triangle's surfel: a row of the field it indexes, or -1 (one per triangle: 32 bits,
// half of what a scan's 12 triangles per point cost in 64).
using OwnerRow = std::int32_t;

// The points (and their surface normals, the side's) of the lattices a gather with the same
// arguments tabulates the front and back fields on, each moved a hair towards its
// triangle's centroid. n x 3 row-major each.
struct GatherLattice {
    std::vector<double> points, normals;
    std::vector<std::int64_t> triangle;  // the triangle each point lies in
    std::size_t size() const { return points.size() / 3; }
};
void gather_lattices(const MeshScene& scene, const SurfelField& front, const SurfelField* back,
                     const std::uint8_t* two_sided, const OwnerRow* owner_front,
                     const OwnerRow* owner_back, GatherLattice& front_out,
                     GatherLattice& back_out);

// Corners that share a receiver's rays, each in a face of its own (a smooth vertex's corners,
// whose triangles' planes differ): receiver i's are rows [start[i], start[i + 1]) (start: m + 1
// offsets), each with its point and its face's unit geometric normal (count x 3 each). Its
// normal and ray directions are the receiver's.
struct FaceShares {
    std::size_t count = 0;
    const std::int64_t* start = nullptr;
    const double* positions = nullptr;
    const double* faces = nullptr;
    mutable std::atomic<std::size_t> recast{0};   // out: the rays cast again for them
};

// A gather prepared once for any number of receivers: the fields tabulated on the lattice
// of every triangle that needs one. Preparing it reads every triangle, so many batches of
// receivers in a large scene cost far less through one plan than through a plan each.
// The arguments must outlive the plan:
// two_sided (one flag per triangle, may be null: all): which triangles' back faces take the
// back field (`back`; null: every back face is black); the others' back faces are black.
// owner_front / owner_back (one entry per triangle, may be null) name the surfel of the front /
// back field that a triangle stands for (a point's splat), or -1: a hit on such a triangle
// takes that surfel's value, not a lookup.
// front_exact / back_exact (may be null): used while the plan is prepared only.
class GatherPlan {
public:
    GatherPlan(Context& ctx, const MeshScene& scene, const SurfelField& front,
               const SurfelField* back, const GatherOptions& opt,
               const std::uint8_t* two_sided = nullptr, const OwnerRow* owner_front = nullptr,
               const OwnerRow* owner_back = nullptr, const ExactPart* front_exact = nullptr,
               const ExactPart* back_exact = nullptr);
    ~GatherPlan();
    GatherPlan(const GatherPlan&) = delete;
    GatherPlan& operator=(const GatherPlan&) = delete;
    // Receivers (m: positions, unit normals, ids that key their directions) cast `rays`
    // each (rays_per, m entries, may be null: each receiver's own count) with `seed`.
    // out: m x 3 mean radiance; stderr_out: m, standard error of the mean's luminance;
    // reach_out (m, may be null): the harmonic mean of the rays' hit distances, misses
    // counted as infinitely far (infinite when nothing is hit): how near the surroundings
    // that shape the receiver's indirect light are (an irradiance cache's validity radius).
    // open_out (m, may be null): the share of the rays that hit nothing (the background).
    // halves_out (m, may be null): half the difference between the mean luminance of the
    // even and the odd rays. The rays are a lattice, not independent: stderr_out overstates
    // the mean's error where the light is smooth; the halves' squares, pooled over many
    // receivers, follow it. faces (m x 3 unit, may be null): the geometric normal of the
    // face each receiver lies in; a ray of the shading normal's hemisphere that leaves below
    // that face takes nothing (a renderer's diffuse surface drops such directions: a smooth
    // normal tilted off its face does not see through its own surface).
    // shares (may be null): corners that take the receivers' rays in faces of their own, one
    // evaluation per receiver: their results follow the receivers' in every output (rows m ..
    // m + shares->count - 1, the outputs sized for them). A ray above the receiver's face and
    // a corner's counts for the corner as it was cast (both points lie at the vertex); one
    // above the corner's face only is cast again from the corner's own point; one below the
    // corner's face takes nothing: each corner's mean is that of a gather of its own.
    void gather(Context& ctx, const double* positions, const double* normals,
                const std::int64_t* ids, std::size_t m, int rays, std::uint64_t seed,
                const std::int32_t* rays_per, double* out, double* stderr_out,
                double* reach_out = nullptr, double* open_out = nullptr,
                double* halves_out = nullptr, const double* faces = nullptr,
                const FaceShares* shares = nullptr) const;
    // What a gather ray takes at each of m hits (triangle, front face or not, the point on
    // it, m x 3): out (m x 3) radiance, the tables' interpolation where they cover the
    // point, as in `gather`.
    void hit_values(Context& ctx, const std::int64_t* triangles, const std::uint8_t* front,
                    const double* points, std::size_t m, double* out) const;
    std::size_t triangles() const { return scene_.size(); }

private:
    // Rays cast together and what the scene found for them (n entries each; org, dir n x 3).
    struct RayBatchView {
        const double *org, *dir, *dist;
        const std::int64_t* prim;
        const std::uint8_t* face;
        const float* uv;
    };
    // What ray k of `b` takes: the background where it met nothing (state 1), else the value
    // at its hit (state 2, dist its distance).
    void take(const RayBatchView& b, std::size_t k, KdTree::Best& best, double* v,
              std::uint8_t& state, double& dist) const;
    // The radiance a ray takes at a hit on triangle t (front face or back) at barycentric
    // (u, v) (Embree's: weights of corners 1 and 2), the point q.
    void hit_value(std::size_t t, bool front_face, double u, double v, const double q[3],
                   KdTree::Best& best, double out[3]) const;
    struct Tables;
    const MeshScene& scene_;
    const SurfelField& front_;
    const SurfelField* back_;
    GatherOptions opt_;
    const std::uint8_t* two_sided_;
    const OwnerRow* owner_front_;
    const OwnerRow* owner_back_;
    std::unique_ptr<Tables> tables_;
};

}  // namespace illumap
