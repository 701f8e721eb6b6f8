// raycast.cpp — Embree 3 occluder scene (discs, quads or octagons) and occlusion rays (see
// raycast.hpp).
#include "visibility/raycast.hpp"

#include "visibility/embree_util.hpp"
#include "visibility/mesh_scene.hpp"
#include "geometry/local_frame.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace illumap {

struct OccluderScene::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::atomic<bool>* cancel = nullptr;  // the build's context flag
    std::shared_ptr<const void> splats;   // a shared scene's splat outlines (its filter's data)
    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
};

namespace {

// Occluders from which the BVH build is watched from a second thread (run_watched).
constexpr std::size_t kWatchedBuild = std::size_t(1) << 14;

// Incoherent occlusion rays cast 64 at a time (rtcOccluded1M); each ray writes 0 (blocked) or
// 1 (visible) into its own output slot. Slots without a ray are the caller's to fill.
class RayBatch {
public:
    RayBatch(RTCScene scene, float* out) : scene_(scene), out_(out) {
        rtcInitIntersectContext(&ctx_);
        ctx_.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    }
    // The ray to fill for output slot `slot`; call commit() once it is filled.
    RTCRay& next(std::size_t slot) {
        slot_[k_] = slot;
        return rays_[k_];
    }
    void commit() {
        if (++k_ == kSize) flush();
    }
    void flush() {
        if (!k_) return;
        rtcOccluded1M(scene_, &ctx_, rays_, unsigned(k_), sizeof(RTCRay));
        for (std::size_t m = 0; m < k_; ++m) out_[slot_[m]] = rays_[m].tfar < 0.0f ? 0.0f : 1.0f;
        cast_ += k_;
        k_ = 0;
    }
    std::uint64_t cast() const { return cast_; }

private:
    static constexpr std::size_t kSize = 64;
    RTCScene scene_;
    float* out_;
    RTCIntersectContext ctx_;
    RTCRay rays_[kSize];
    std::size_t slot_[kSize];
    std::size_t k_ = 0;
    std::uint64_t cast_ = 0;
};

// The surfel's unit normal (+z where it has none) and a tangent frame t, u that is a fixed,
// continuous function of it (Duff et al. 2017), so that polygon occluders are deterministic.
void tangent_frame(const SurfelSoA& s, std::size_t i, double t[3], double u[3]) {
    double nx = s.nx[i], ny = s.ny[i], nz = s.nz[i];
    const double nl = std::sqrt(nx * nx + ny * ny + nz * nz);
    if (nl > 0) { nx /= nl; ny /= nl; nz /= nl; } else { nx = 0; ny = 0; nz = 1; }
    const double sg = std::copysign(1.0, nz), a = -1.0 / (sg + nz), b = nx * ny * a;
    t[0] = 1.0 + sg * nx * nx * a; t[1] = sg * b; t[2] = -sg * nx;
    u[0] = b; u[1] = sg + ny * ny * a; u[2] = -ny;
}

// The disc radius coverage * sqrt(A/pi) of surfel i (what every shape's area is matched to).
double disc_radius(const SurfelSoA& s, std::size_t i, double coverage) {
    return coverage * std::sqrt(std::max(s.area[i], 0.0) * kInvPi);
}

}  // namespace

OccluderScene::OccluderScene(Context& ctx, const SurfelSoA& s, double coverage,
                             VisibilityOptions::Shape shape, const double* triangles,
                             std::size_t n_tri, const double* shift, const MeshScene* shared)
    : shape_(shape), n_tri_(triangles ? n_tri : 0) {
    if (n_tri_ == 0 || (shared && shared->size() != n_tri_)) shared = nullptr;
    const double no_shift[3] = {0.0, 0.0, 0.0};
    const double* sh = shift ? shift : no_shift;
    // Corner value k of the triangles, shifted (x - 0.0 is x: no shift changes no bit).
    auto tri_at = [&](std::size_t k) { return triangles[k] - sh[k % 3]; };
    const auto t_start = std::chrono::steady_clock::now();
    const std::size_t n = s.n;
    if (!(coverage > 0) || !std::isfinite(coverage))
        throw std::invalid_argument("coverage must be a finite number > 0");
    // The occluders' box, for clipping segments; float coordinates are relative to the local
    // frame (local_frame.hpp), not to the world origin.
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (std::size_t i = 0; i < n; ++i) {
        lo[0] = std::min(lo[0], s.px[i]); hi[0] = std::max(hi[0], s.px[i]);
        lo[1] = std::min(lo[1], s.py[i]); hi[1] = std::max(hi[1], s.py[i]);
        lo[2] = std::min(lo[2], s.pz[i]); hi[2] = std::max(hi[2], s.pz[i]);
    }
    for (std::size_t k = 0; k < 9 * n_tri_; ++k) {
        const double x = tri_at(k);
        if (!std::isfinite(x))
            throw std::invalid_argument("occluder triangle " + std::to_string(k / 9) +
                                        " has a corner that is not finite");
        lo[k % 3] = std::min(lo[k % 3], x);
        hi[k % 3] = std::max(hi[k % 3], x);
    }
    const bool any = n > 0 || n_tri_ > 0;
    const LocalFrame frame = make_local_frame(n + 3 * n_tri_, [&](std::size_t i, double* p) {
        if (i < n) {
            p[0] = s.px[i]; p[1] = s.py[i]; p[2] = s.pz[i];
        } else {
            for (int d = 0; d < 3; ++d) p[d] = tri_at(3 * (i - n) + d);
        }
    }, [&](std::size_t i) {
        if (i < n) return s.area[i];
        double c[9];
        for (int k = 0; k < 9; ++k) c[k] = tri_at(9 * ((i - n) / 3) + k);
        return triangle_area(c) / 3.0;
    });
    for (int d = 0; d < 3; ++d) {
        // The shared scene's floats are its corners less its own centre: in this frame (the
        // shift taken off), that centre less the shift.
        center_[d] = shared ? shared->frame().center[d] - sh[d] : frame.center[d];
        lo_[d] = any ? lo[d] : 0.0;
        hi_[d] = any ? hi[d] : 0.0;
    }

    radius_.resize(n);
    normal_.resize(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
        double nx = s.nx[i], ny = s.ny[i], nz = s.nz[i];
        const double nl = std::sqrt(nx * nx + ny * ny + nz * nz);
        if (nl > 0) { nx /= nl; ny /= nl; nz /= nl; }
        normal_[3 * i] = float(nx); normal_[3 * i + 1] = float(ny); normal_[3 * i + 2] = float(nz);
    }
    impl_ = new Impl;
    const std::string cfg = "threads=" + std::to_string(ctx.nthreads());
    impl_->device = rtcNewDevice(cfg.c_str());
    if (!impl_->device) {
        delete impl_;
        impl_ = nullptr;
        throw std::runtime_error("embree: rtcNewDevice failed");
    }
    try {
        impl_->cancel = &ctx.cancel;
        if (shared) {   // built (the same quality and flags) and committed; not committed here
            impl_->scene = static_cast<RTCScene>(shared->rtc_scene());
            rtcRetainScene(impl_->scene);
            // Its splats' outline filter reads data the scene owns: held as long as the scene.
            impl_->splats = shared->splat_keepalive();
        } else {
            impl_->scene = rtcNewScene(impl_->device);
            rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_MEDIUM);
            // Watertight: a ray through an edge two triangles share hits one of them on every
            // CPU (without it, AMD EPYC let rays through a split square's inner edges).
            rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
            rtcSetSceneProgressMonitorFunction(impl_->scene, embree_build_progress, &ctx.cancel);
        }
        RTCGeometry g = nullptr;  // the occluders: quads as triangle pairs, or oriented discs
        if (n_tri_ > 0) {
            // The scene's own triangles; the surfels' radii (coverage 1) only size the trims.
            if (shared) {
                vertices_ = shared->vertices();
                shared_bytes_ = shared->bytes();
            } else {
                g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
                ctx.set_phase("visibility: triangles", 0.0, 0.2);
                vertices_ = set_shared_triangles(ctx, impl_->device, g, triangles, n_tri_,
                                                 center_, sh);
            }
            // Triangles neither overlap nor overhang: the trims only have to clear the
            // surfel's own triangle, a hair of the bulk's size, or the float noise where the
            // surfel lies far from the bulk (local_frame.hpp).
            const double hair = 1e-4 * frame.length;
            for (std::size_t i = 0; i < n; ++i) {
                const double p[3] = {s.px[i], s.py[i], s.pz[i]};
                radius_[i] = float(std::max(hair, frame.noise(p)));
            }
        } else if (n > 0 && shape == VisibilityOptions::Shape::Quad) {
            // Equal-area squares (side coverage * sqrt(A)) in each tangent plane; the frame is a
            // fixed function of the normal (Duff et al. 2017), so the build is deterministic.
            // Each square is two triangles that OVERLAP along the diagonal (the first reaches
            // kOverlap of the side past it): Embree's triangle and quad tests are not
            // watertight, and a single quad let rays through its own diagonal (measured: lamp
            // rays through a regular grid of quads leaked at every cell's diagonal).
            constexpr double kOverlap = 0.02;
            g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
            float* v = static_cast<float*>(rtcSetNewGeometryBuffer(
                g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 6 * n));
            unsigned* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
                g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 2 * n));
            throw_embree(impl_->device, "buffers");
            const double cov = coverage;
            ctx.set_phase("visibility: quads", 0.0, 0.2);
            parallel_for(ctx, n, 1 << 15, [&](std::size_t b, std::size_t e) {
                for (std::size_t i = b; i < e; ++i) {
                    const double A = std::max(s.area[i], 0.0);
                    radius_[i] = float(disc_radius(s, i, cov));  // for the endpoint trims
                    const double half = 0.5 * cov * std::sqrt(A);
                    double t[3], u[3];
                    tangent_frame(s, i, t, u);
                    const double c[3] = {s.px[i] - center_[0], s.py[i] - center_[1], s.pz[i] - center_[2]};
                    // corners 0..3 counter-clockwise, then 1 and 3 moved towards 2
                    const double w = 2.0 * kOverlap - 1.0;
                    const double sgn[6][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}, {1, w}, {w, 1}};
                    for (int k = 0; k < 6; ++k)
                        for (int d = 0; d < 3; ++d)
                            v[3 * (6 * i + k) + d] = float(c[d] + half * (sgn[k][0] * t[d] + sgn[k][1] * u[d]));
                    const unsigned o = unsigned(6 * i);
                    const unsigned tri[6] = {o, o + 4, o + 5, o + 2, o + 3, o + 1};
                    for (int k = 0; k < 6; ++k) ib[6 * i + k] = tri[k];
                }
            });
        } else if (n > 0 && shape == VisibilityOptions::Shape::Octagon) {
            // The regular octagon of the disc's area (corner radius kCorner * r), a fan of 8
            // triangles about the centre. Each triangle's rim edge is lengthened by kWiden of
            // itself at both ends, so that it covers its two spokes inside (as the quad's two
            // triangles overlap along the diagonal: Embree's triangle test is not watertight).
            // Each triangle's apex also sits kBehind of the corner radius past the centre,
            // away from its rim, so that neighbours overlap along their spokes too: with one
            // shared apex a ray through the centre could pass between all eight.
            constexpr double kWiden = 0.02, kBehind = 0.04;
            constexpr int kSides = 8, kVerts = 3 * kSides;
            const double kCorner = std::sqrt(kPi / (kSides * 0.5 * std::sin(2 * kPi / kSides)));
            g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
            float* v = static_cast<float*>(rtcSetNewGeometryBuffer(
                g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), kVerts * n));
            unsigned* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
                g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), kSides * n));
            throw_embree(impl_->device, "buffers");
            double rim[kSides + 1][2];   // unit-area corners, the first repeated at the end
            for (int k = 0; k <= kSides; ++k) {
                rim[k][0] = kCorner * std::cos(2 * kPi * k / kSides);
                rim[k][1] = kCorner * std::sin(2 * kPi * k / kSides);
            }
            const double cov = coverage;
            ctx.set_phase("visibility: octagons", 0.0, 0.2);
            parallel_for(ctx, n, 1 << 15, [&](std::size_t b, std::size_t e) {
                for (std::size_t i = b; i < e; ++i) {
                    const double r = disc_radius(s, i, cov);
                    radius_[i] = float(r);
                    double t[3], u[3];
                    tangent_frame(s, i, t, u);
                    const double c[3] = {s.px[i] - center_[0], s.py[i] - center_[1], s.pz[i] - center_[2]};
                    float* out = v + 3 * kVerts * i;
                    auto put = [&](int slot, double x, double y) {
                        for (int d = 0; d < 3; ++d)
                            out[3 * slot + d] = float(c[d] + r * (x * t[d] + y * u[d]));
                    };
                    const unsigned o = unsigned(kVerts * i);
                    for (int k = 0; k < kSides; ++k) {
                        const double wx = kWiden * (rim[k + 1][0] - rim[k][0]);
                        const double wy = kWiden * (rim[k + 1][1] - rim[k][1]);
                        const double back = -0.5 * kBehind / kCorner;
                        put(3 * k, back * (rim[k][0] + rim[k + 1][0]), back * (rim[k][1] + rim[k + 1][1]));
                        put(3 * k + 1, rim[k][0] - wx, rim[k][1] - wy);
                        put(3 * k + 2, rim[k + 1][0] + wx, rim[k + 1][1] + wy);
                        for (int j = 0; j < 3; ++j) ib[3 * (kSides * i + k) + j] = o + 3 * k + j;
                    }
                }
            });
        } else if (n > 0) {
            g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT);
            float* v = static_cast<float*>(rtcSetNewGeometryBuffer(
                g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), n));
            float* nb = static_cast<float*>(rtcSetNewGeometryBuffer(
                g, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), n));
            throw_embree(impl_->device, "buffers");
            const double cov = coverage;
            ctx.set_phase("visibility: discs", 0.0, 0.2);
            parallel_for(ctx, n, 1 << 15, [&](std::size_t b, std::size_t e) {
                for (std::size_t i = b; i < e; ++i) {
                    const double r = disc_radius(s, i, cov);
                    radius_[i] = float(r);
                    v[4 * i + 0] = float(s.px[i] - center_[0]);
                    v[4 * i + 1] = float(s.py[i] - center_[1]);
                    v[4 * i + 2] = float(s.pz[i] - center_[2]);
                    v[4 * i + 3] = float(r);
                    nb[3 * i + 0] = float(s.nx[i]);
                    nb[3 * i + 1] = float(s.ny[i]);
                    nb[3 * i + 2] = float(s.nz[i]);
                }
            });
        }
        if (g) {
            float rmax = 0;
            for (std::size_t i = 0; i < n; ++i) rmax = std::max(rmax, radius_[i]);
            // Only disc points need the origin moved back (self-intersection avoidance).
            back_ = n_tri_ > 0 ? 0.0 : 2.5 * double(rmax);
            rtcCommitGeometry(g);
            rtcAttachGeometry(impl_->scene, g);
            rtcReleaseGeometry(g);
        }
        // The occluders' box, padded by the farthest reach of a disc or quad corner (1.26 r)
        // plus float noise, for clipping segments (a sun's target may be very far away).
        double ext = 0;
        for (int d = 0; d < 3; ++d) ext = std::max(ext, hi_[d] - lo_[d]);
        const double pad = 0.8 * back_ + 1e-6 * ext + 1e-30;
        for (int d = 0; d < 3; ++d) { lo_[d] -= pad; hi_[d] += pad; }
        // The BVH build runs on Embree's threads, started from one of our workers, while the
        // calling thread polls the monitor; a cancel makes build_progress stop Embree. Small
        // builds (well under the 50 ms between polls) start from the calling thread.
        ctx.set_phase("visibility: BVH", 0.2, 0.8);
        if (!shared) {
            if (n + n_tri_ < kWatchedBuild)  // triangles count too: a scan's splats are millions
                rtcCommitScene(impl_->scene);
            else
                run_watched(ctx, [&] { rtcCommitScene(impl_->scene); });
        }
        if (ctx.cancel.load()) throw Cancelled();
        throw_embree(impl_->device, "BVH build");
        if (n_tri_ > 0 && n > 0) find_faces(ctx, s);
    } catch (...) {
        delete impl_;
        impl_ = nullptr;
        throw;
    }
    build_seconds_ =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
}

// The face each surfel lies on: a ray along its normal back down through it, from radius()
// above it, that looks for a face only within half of that of the surfel itself (a scan's
// neighbouring splats, which pass near but not through its point, are not its face); that
// face's normal, turned to the surfel's side (a smooth normal stays within 90 degrees of its
// face's). A surfel without one keeps no test.
void OccluderScene::find_faces(Context& ctx, const SurfelSoA& s) {
    const std::size_t n = s.n;
    face_normal_.assign(3 * n, 0.0f);
    parallel_for(ctx, n, 1 << 12, [&](std::size_t b, std::size_t e) {
        RTCIntersectContext c;
        rtcInitIntersectContext(&c);
        for (std::size_t i = b; i < e; ++i) {
            const float* m = &normal_[3 * i];
            if (m[0] == 0.0f && m[1] == 0.0f && m[2] == 0.0f) continue;
            const double lift = double(radius_[i]);
            RTCRayHit rh;
            rh.ray.org_x = float(s.px[i] + lift * m[0] - center_[0]);
            rh.ray.org_y = float(s.py[i] + lift * m[1] - center_[1]);
            rh.ray.org_z = float(s.pz[i] + lift * m[2] - center_[2]);
            rh.ray.dir_x = -m[0];
            rh.ray.dir_y = -m[1];
            rh.ray.dir_z = -m[2];
            rh.ray.tnear = float(0.5 * lift);
            rh.ray.tfar = float(1.5 * lift);
            rh.ray.time = 0.0f;
            rh.ray.mask = 0xffffffffu;
            rh.ray.id = 0;
            rh.ray.flags = 0;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(impl_->scene, &c, &rh);
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
            double g[3] = {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z};
            const double gl = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
            if (!(gl > 0) || !std::isfinite(gl)) continue;
            const double side = (g[0] * m[0] + g[1] * m[1] + g[2] * m[2]) < 0.0 ? -1.0 : 1.0;
            for (int d = 0; d < 3; ++d) face_normal_[3 * i + d] = float(side * g[d] / gl);
        }
    });
}

bool OccluderScene::leaves_front(std::uint32_t k, const double* u) const {
    if (face_normal_.empty()) return true;
    const float* g = &face_normal_[3 * std::size_t(k)];
    if (g[0] == 0.0f && g[1] == 0.0f && g[2] == 0.0f) return true;
    return double(g[0]) * u[0] + double(g[1]) * u[1] + double(g[2]) * u[2] > 0.0;
}

OccluderScene::~OccluderScene() { delete impl_; }

void* OccluderScene::rtc_scene() const { return impl_->scene; }

std::size_t OccluderScene::bytes() const {
    // Buffers (discs 16 + 12 bytes, quads as two triangles 72 + 24, octagons as eight 204 +
    // 96, given triangles 12 per shared vertex + 12), our radii (and the faces' normals), and
    // Embree's BVH (estimated as 64 bytes per primitive).
    if (n_tri_ > 0)
        return (shared_bytes_ ? shared_bytes_ : vertices_ * 12 + n_tri_ * (12 + 64)) +
               size() * (16 + 12);
    switch (shape_) {
        case VisibilityOptions::Shape::Quad: return size() * (72 + 24 + 4 + 2 * 64);
        case VisibilityOptions::Shape::Octagon: return size() * (204 + 96 + 4 + 8 * 64);
        default: return size() * (16 + 12 + 4 + 64);
    }
}

// Segment p -> q with its first t0 and last t1 ignored, clipped to the occluders' box in
// double precision. The ray starts `back` (> 2 * largest disc radius) BEHIND its first point:
// Debian's Embree is built with EMBREE_DISC_POINT_SELF_INTERSECTION_AVOIDANCE, which skips
// every disc whose bounding sphere contains the ray origin; from the endpoint itself that
// would hide real occluders next to it (a wall beside a floor surfel). A disc whose sphere
// contains the shifted origin lies entirely within 2 r_k < back of it and so cannot reach the
// segment: nothing relevant is skipped. Returns false when nothing remains of the segment.
bool OccluderScene::make_ray(const double* p, const double* q, double t0, double t1,
                             void* rtc_ray) const {
    const double dx = q[0] - p[0], dy = q[1] - p[1], dz = q[2] - p[2];
    const double len = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (!(len > t0 + t1) || !(len > 0) || !std::isfinite(len)) return false;
    const double u[3] = {dx / len, dy / len, dz / len};
    // [a, e]: the part of [0, len] inside the box; a = 0, e = len when both ends are inside,
    // which is always the case for surfel pairs.
    double a, e;
    if (!clip_to_box(lo_, hi_, p, u, len, a, e)) return false;
    const double s0 = std::max(t0, a), s1 = std::min(len - t1, e);
    if (!(s1 > s0)) return false;
    fill_ray(p, u, a, e, s0, s1, rtc_ray);
    return true;
}

// The ray for the part [s0, s1] of the line p + t u, t in [a, e] (the part inside the box),
// started back_ behind a.
void OccluderScene::fill_ray(const double* p, const double* u, double a, double e, double s0,
                             double s1, void* rtc_ray) const {
    RTCRay& r = *static_cast<RTCRay*>(rtc_ray);
    const double total = (e - a) + back_;
    r.org_x = float(p[0] + (a - back_) * u[0] - center_[0]);
    r.org_y = float(p[1] + (a - back_) * u[1] - center_[1]);
    r.org_z = float(p[2] + (a - back_) * u[2] - center_[2]);
    r.dir_x = float(u[0] * total);
    r.dir_y = float(u[1] * total);
    r.dir_z = float(u[2] * total);
    r.tnear = float((back_ + s0 - a) / total);
    r.tfar = float((back_ + s1 - a) / total);
    r.time = 0.0f;
    r.mask = 0xffffffffu;
    r.id = 0;
    r.flags = 0;
}

// A neighbour's disc that contains the endpoint (overlapping discs of a random sampling, or the
// tangent discs of a curved surface) passes within a small height h of it and crosses a ray
// leaving at elevation sin = |n . u| about h / sin from it: on a convex surface h ~ d^2 / 2R
// for a neighbour at distance d, so grazing rays from a sphere were blocked by its own
// neighbours (most near leaf pairs on curved surfaces came out PARTIAL). Ignoring the part of
// the ray within off * r of the tangent plane removes that; such a disc reaches at most 2 r
// from the endpoint (its centre within r, plus its radius), hence the cap.
double OccluderScene::trim(std::uint32_t k, const double* u, double off) const {
    const float* nk = &normal_[3 * std::size_t(k)];
    const double c = std::fabs(double(nk[0]) * u[0] + double(nk[1]) * u[1] + double(nk[2]) * u[2]);
    const double r = radius_[k];
    return off * r < kTrimReach * r * c ? off * r / c : kTrimReach * r;
}

void OccluderScene::segments(Context& ctx, const double* a, const double* b,
                             const std::int64_t* skip, double endpoint_offset, std::size_t n,
                             float* out) const {
    parallel_for(ctx, n, 1024, [&](std::size_t lo, std::size_t hi) {
        RayBatch batch(impl_->scene, out);
        for (std::size_t k = lo; k < hi; ++k) {
            out[k] = 1.0f;
            const std::int64_t sk = skip ? skip[k] : -1;
            const double* p = a + 3 * k;
            const double* q = b + 3 * k;
            double t0 = 0.0;
            if (sk >= 0) {
                double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
                const double len = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
                if (!(len > 0)) continue;
                for (double& x : u) x /= len;
                t0 = trim(std::uint32_t(sk), u, endpoint_offset);
            }
            if (make_ray(p, q, t0, 0.0, &batch.next(k))) batch.commit();
        }
        batch.flush();
    });
}

RaycastVisibility::RaycastVisibility(Context& ctx, const Octree& tree,
                                     const VisibilityOptions& opt)
    : VisibilityModel(tree, opt) {
    if (!(opt.endpoint_offset >= 0))
        throw std::invalid_argument("endpoint_offset must be >= 0");
    scene_ = std::make_unique<OccluderScene>(ctx, tree.s, opt.coverage, opt.shape,
                                             opt.triangles, opt.n_triangles,
                                             opt.triangles_shift, opt.triangles_scene);
    build_seconds_ = scene_->build_seconds();
    bytes_ = scene_->bytes();
}

RaycastVisibility::~RaycastVisibility() = default;

// Surfel pair i < j, trimmed at both ends (OccluderScene::trim). A segment that leaves or
// reaches either end behind the face it lies on is blocked without a ray.
RaycastVisibility::PairRay RaycastVisibility::make_pair_ray(std::uint32_t i, std::uint32_t j,
                                                            void* r) const {
    const SurfelSoA& s = tree_.s;
    const double p[3] = {s.px[i], s.py[i], s.pz[i]}, q[3] = {s.px[j], s.py[j], s.pz[j]};
    double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
    const double len = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (!(len > 0) || !std::isfinite(len)) return PairRay::Visible;
    for (double& x : u) x /= len;
    const double back[3] = {-u[0], -u[1], -u[2]};
    if (!scene_->leaves_front(i, u) || !scene_->leaves_front(j, back)) return PairRay::Blocked;
    const double off = opt_.endpoint_offset;
    // Surfel centres lie inside the occluders' box: no clipping (OccluderScene::make_ray).
    const double s0 = scene_->trim(i, u, off), s1 = len - scene_->trim(j, u, off);
    if (!(s1 > s0)) return PairRay::Visible;
    scene_->fill_ray(p, u, 0.0, len, s0, s1, r);
    return PairRay::Cast;
}

float RaycastVisibility::pair(std::uint32_t i, std::uint32_t j) const {
    if (i == j) return 1.0f;
    if (i > j) std::swap(i, j);
    RTCRay r;
    const PairRay k = make_pair_ray(i, j, &r);
    if (k != PairRay::Cast) return k == PairRay::Blocked ? 0.0f : 1.0f;
    RTCIntersectContext c;
    rtcInitIntersectContext(&c);
    rtcOccluded1(static_cast<RTCScene>(scene_->rtc_scene()), &c, &r);
    count_queries(1);
    return r.tfar < 0.0f ? 0.0f : 1.0f;  // Embree sets tfar = -inf on a hit
}

void RaycastVisibility::pairs(const std::uint32_t* I, const std::uint32_t* J, std::size_t n,
                              float* visible) const {
    RayBatch batch(static_cast<RTCScene>(scene_->rtc_scene()), visible);
    for (std::size_t m = 0; m < n; ++m) {
        std::uint32_t i = I[m], j = J[m];
        if (i > j) std::swap(i, j);
        visible[m] = 1.0f;
        if (i == j) continue;
        const PairRay k = make_pair_ray(i, j, &batch.next(m));
        if (k == PairRay::Cast) batch.commit();
        else if (k == PairRay::Blocked) visible[m] = 0.0f;
    }
    batch.flush();
    count_queries(batch.cast());
}

void RaycastVisibility::pairs_batch(const std::uint32_t* I, const std::uint32_t* J, int n,
                                     float* out) const {
    RTCIntersectContext c;
    rtcInitIntersectContext(&c);
    c.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    std::uint64_t cast = 0;
    for (int base = 0; base < n; base += 8) {
        RTCRay8 p;
        alignas(32) int valid[8];
        for (int l = 0; l < 8; ++l) {
            valid[l] = 0;
            p.tfar[l] = 0.0f;
            const int k = base + l;
            if (k >= n) continue;
            out[k] = 1.0f;
            std::uint32_t i = I[k], j = J[k];
            if (i > j) std::swap(i, j);
            RTCRay r;
            if (i == j) continue;
            const PairRay kind = make_pair_ray(i, j, &r);
            if (kind == PairRay::Blocked) out[k] = 0.0f;
            if (kind != PairRay::Cast) continue;
            valid[l] = -1;
            p.org_x[l] = r.org_x; p.org_y[l] = r.org_y; p.org_z[l] = r.org_z;
            p.dir_x[l] = r.dir_x; p.dir_y[l] = r.dir_y; p.dir_z[l] = r.dir_z;
            p.tnear[l] = r.tnear; p.tfar[l] = r.tfar; p.time[l] = 0.0f;
            p.mask[l] = 0xffffffffu; p.id[l] = 0; p.flags[l] = 0;
            cast++;
        }
        rtcOccluded8(valid, static_cast<RTCScene>(scene_->rtc_scene()), &c, &p);
        for (int l = 0; l < 8 && base + l < n; ++l)
            if (valid[l]) out[base + l] = p.tfar[l] < 0.0f ? 0.0f : 1.0f;
    }
    count_queries(cast);
}

void RaycastVisibility::block(std::int32_t a, std::int32_t b, float* out,
                              const DrawMemo* drawn) const {
    const OctreeNode &A = tree_.nodes[a], &B = tree_.nodes[b];
    const std::uint32_t nb = B.count();
    const bool any_known = fill_drawn(a, b, drawn, out);
    RayBatch batch(static_cast<RTCScene>(scene_->rtc_scene()), out);
    for (std::uint32_t i = A.begin; i < A.end; ++i)
        for (std::uint32_t j = B.begin; j < B.end; ++j) {
            const std::size_t o = std::size_t(i - A.begin) * nb + (j - B.begin);
            if (any_known && out[o] != kUnknown) continue;
            out[o] = 1.0f;
            if (i == j || !vis_facing(tree_.s, i, j)) continue;
            const std::uint32_t lo = i < j ? i : j, hi = i < j ? j : i;
            const PairRay kind = make_pair_ray(lo, hi, &batch.next(o));
            if (kind == PairRay::Cast) batch.commit();
            else if (kind == PairRay::Blocked) out[o] = 0.0f;
        }
    batch.flush();
    count_queries(batch.cast());
    count_block(std::uint64_t(A.count()) * nb);
}

}  // namespace illumap
