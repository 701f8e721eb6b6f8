// mesh_scene.cpp — Embree 3 triangle scene for receivers (see mesh_scene.hpp).
#include "visibility/mesh_scene.hpp"

#include "visibility/embree_util.hpp"
#include "geometry/local_frame.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace illumap {

struct MeshScene::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
};

// The splats' outlines as the filter reads them, one record of floats per point (together:
// a candidate hit reads one or two cache lines): its centre relative to the frame (3), its
// plane's axes u, v (6), the square of a radius within which every direction is inside the
// fan (its smallest radius x cos(pi / sides), the chord of the narrowest triangle, a hair
// less), +1 / -1 as its fan is wound along u x v or against it, and its radii (sides).
struct SplatData {
    static constexpr std::size_t kC = 0, kU = 3, kV = 6, kInner2 = 9, kAlong = 10, kRadii = 11;
    std::size_t n = 0, sides = 0, first = 0, stride = 0;
    std::vector<float> rec;
    std::vector<double> cos_t, sin_t;

    const float* of(std::size_t k) const { return rec.data() + k * stride; }

    // Whether (x, y), along u, v from point k in its plane, lies in its fan: the triangle
    // (centre, rim m, rim m + 1) of the direction's sector. Then the triangle's row and the
    // barycentric coordinates of its corners 1 and 2 as Embree gives them for that triangle.
    bool hit(std::size_t k, double x, double y, std::size_t& row, float& bu, float& bv) const {
        constexpr double kTurn = 2.0 * M_PI;
        double a = std::atan2(y, x);
        if (a < 0.0) a += kTurn;
        std::size_t m = std::size_t(a * double(sides) / kTurn);
        if (m >= sides) m = sides - 1;
        const std::size_t m1 = m + 1 == sides ? 0 : m + 1;
        const float* r = of(k) + kRadii;
        const double ax = r[m] * cos_t[m], ay = r[m] * sin_t[m];
        const double bx = r[m1] * cos_t[m1], by = r[m1] * sin_t[m1];
        const double det = ax * by - ay * bx;
        if (!(det > 0.0)) return false;   // a rim at radius 0: no triangle there
        const double al = (x * by - y * bx) / det, be = (ax * y - ay * x) / det;
        if (!(al + be <= 1.0)) return false;
        row = first + k * sides + m;
        // Corners (centre, rim m, rim m + 1) when the fan is wound along u x v, else
        // (centre, rim m + 1, rim m).
        const bool along = of(k)[kAlong] > 0.0f;
        bu = float(along ? al : be);
        bv = float(along ? be : al);
        return true;
    }

    // Where the hit of a ray (frame-relative float origin, direction, distance t) on point
    // k's rectangle lies in its plane, along u and v from the point.
    void plane_xy(std::size_t k, const float o[3], const float d[3], float t, double& x,
                  double& y) const {
        const float* c = of(k) + kC;
        const float* ax = of(k) + kU;   // u, then v
        double w[3];
        for (int i = 0; i < 3; ++i) w[i] = double(o[i]) + double(t) * double(d[i]) - double(c[i]);
        x = w[0] * ax[0] + w[1] * ax[1] + w[2] * ax[2];
        y = w[0] * ax[3] + w[1] * ax[4] + w[2] * ax[5];
    }

    // The same test for such a hit, and its fan triangle (hit()).
    bool ray_hit(std::size_t k, const float o[3], const float d[3], float t, std::size_t& row,
                 float& bu, float& bv) const {
        double x, y;
        plane_xy(k, o, d, t, x, y);
        return hit(k, x, y, row, bu, bv);
    }

    // Whether such a hit lies in the fan (the filter's question): at once within the inner
    // radius, else by hit().
    bool ray_inside(std::size_t k, const float o[3], const float d[3], float t) const {
        double x, y;
        plane_xy(k, o, d, t, x, y);
        if (x * x + y * y < double(of(k)[kInner2])) return true;   // strictly: none at radius 0
        std::size_t row;
        float bu, bv;
        return hit(k, x, y, row, bu, bv);
    }
};

namespace {

constexpr std::size_t kBatch = 64;  // rays per rtcOccluded1M / rtcIntersect1M call
constexpr unsigned kTriangleGeom = 0, kSplatGeom = 1;  // Embree geometry ids

// Embree's intersection and occlusion filter on the splats' rectangles (two triangles each,
// primitives 2k and 2k + 1 of point k): a hit outside the fan's outline is no hit (the ray
// goes on).
void splat_filter(const RTCFilterFunctionNArguments* args) {
    const auto* sd = static_cast<const SplatData*>(args->geometryUserPtr);
    const unsigned N = args->N;
    for (unsigned i = 0; i < N; ++i) {
        if (args->valid[i] != -1) continue;
        const float o[3] = {RTCRayN_org_x(args->ray, N, i), RTCRayN_org_y(args->ray, N, i),
                            RTCRayN_org_z(args->ray, N, i)};
        const float d[3] = {RTCRayN_dir_x(args->ray, N, i), RTCRayN_dir_y(args->ray, N, i),
                            RTCRayN_dir_z(args->ray, N, i)};
        if (!sd->ray_inside(RTCHitN_primID(args->hit, N, i) / 2, o, d, RTCRayN_tfar(args->ray, N, i)))
            args->valid[i] = 0;
    }
}

}  // namespace

MeshScene::MeshScene(Context& ctx, const double* corners, std::size_t n_tri,
                     const SplatOutlines* splats)
    : n_tri_(n_tri) {
    if (splats && splats->n > 0) {
        const SplatOutlines& s = *splats;
        if (s.sides < 3 || s.first + s.n * s.sides != n_tri || !s.points || !s.u || !s.v ||
            !s.radii || !s.facing)
            throw std::invalid_argument("splats: their fans must be the last n * sides (sides >= 3) "
                                        "of the triangles, with points, axes, radii and facing");
    } else {
        splats = nullptr;
    }
    const std::size_t n_mesh = splats ? splats->first : n_tri;
    const auto t_start = std::chrono::steady_clock::now();
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (std::size_t k = 0; k < 9 * n_tri; ++k) {
        const double x = corners[k];
        if (!std::isfinite(x))
            throw std::invalid_argument("triangle " + std::to_string(k / 9) + " has a corner that is not finite");
        lo[k % 3] = std::min(lo[k % 3], x);
        hi[k % 3] = std::max(hi[k % 3], x);
    }
    frame_ = make_local_frame(3 * n_tri, [&](std::size_t i, double* p) {
        for (int d = 0; d < 3; ++d) p[d] = corners[3 * i + d];
    }, [&](std::size_t i) { return triangle_area(corners + 9 * (i / 3)) / 3.0; });
    for (int d = 0; d < 3; ++d) {
        lo_[d] = n_tri ? lo[d] : 0.0;
        hi_[d] = n_tri ? hi[d] : 0.0;
        extent_ = std::max(extent_, hi_[d] - lo_[d]);
    }
    // Pad the box so that rays leaving a surface on its boundary are not clipped away.
    const double pad = 1e-4 * extent_ + 1e-30;
    for (int d = 0; d < 3; ++d) { lo_[d] -= pad; hi_[d] += pad; }

    corners_ = corners;
    impl_ = new Impl;
    const std::string cfg = "threads=" + std::to_string(ctx.nthreads());
    impl_->device = rtcNewDevice(cfg.c_str());
    if (!impl_->device) {
        delete impl_;
        impl_ = nullptr;
        throw std::runtime_error("embree: rtcNewDevice failed");
    }
    try {
        impl_->scene = rtcNewScene(impl_->device);
        rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_MEDIUM);
        // Watertight: a ray through an edge two triangles share hits one of them on every
        // CPU (without it, AMD EPYC let rays through a split square's inner edges).
        // Not RTC_SCENE_FLAG_COMPACT: its leaves name their vertices instead of copying them,
        // a third of the BVH's memory, but rays took 1.65x the CPU time (300k splats).
        rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
        rtcSetSceneProgressMonitorFunction(impl_->scene, embree_build_progress, &ctx.cancel);
        if (n_mesh > 0) {
            RTCGeometry g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
            ctx.set_phase("receivers: triangles", 0.0, 0.3);
            vertices_ = set_shared_triangles(ctx, impl_->device, g, corners, n_mesh, frame_.center);
            rtcCommitGeometry(g);
            rtcAttachGeometryByID(impl_->scene, g, kTriangleGeom);
            rtcReleaseGeometry(g);
        }
        if (splats) add_splats(ctx, *splats);
        ctx.set_phase("receivers: BVH", 0.3, 0.7);
        if (n_tri < (std::size_t(1) << 16))
            rtcCommitScene(impl_->scene);
        else
            run_watched(ctx, [&] { rtcCommitScene(impl_->scene); });
        if (ctx.cancel.load()) throw Cancelled();
        throw_embree(impl_->device, "BVH build");
    } catch (...) {
        delete impl_;
        impl_ = nullptr;
        throw;
    }
    rtc_scene_ = impl_->scene;
    build_seconds_ =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
}

MeshScene::~MeshScene() { delete impl_; }

// The splats as one rectangle each (two triangles sharing a diagonal, in the fan's plane,
// the bounding box of its outline along u and v), with the outline filter; their data copied
// into floats (SplatData). Rectangles rather than Embree's oriented discs (tried first, as
// fast and half the memory): Embree skips a disc whose bounding sphere holds the ray's
// origin (EMBREE_DISC_POINT_SELF_INTERSECTION_AVOIDANCE), so every ray had to start behind
// its origin and a scene with splats would cast rays unlike one without; triangles keep the
// rays as they were, and need nothing of Embree beyond what the meshes use.
void MeshScene::add_splats(Context& ctx, const SplatOutlines& s) {
    // Without filter functions (an Embree built without them) the rectangles would stand for
    // the fans unclipped: refuse rather than over-occlude.
    if (!rtcGetDeviceProperty(impl_->device, RTC_DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED))
        throw std::runtime_error("embree: built without filter functions, which splat outlines need");
    auto sd = std::make_shared<SplatData>();
    sd->n = s.n;
    sd->sides = s.sides;
    sd->first = s.first;
    sd->stride = SplatData::kRadii + s.sides;
    sd->rec.resize(s.n * sd->stride);
    const double chord = std::cos(M_PI / double(s.sides)) * (1.0 - 1e-6);
    sd->cos_t.resize(s.sides);
    sd->sin_t.resize(s.sides);
    for (std::size_t m = 0; m < s.sides; ++m) {   // as splats.cpp's outline_directions
        const double t = 2.0 * M_PI * double(m) / double(s.sides);
        sd->cos_t[m] = std::cos(t);
        sd->sin_t[m] = std::sin(t);
    }
    RTCGeometry g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4 * s.n));
    unsigned* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 2 * s.n));
    throw_embree(impl_->device, "splat buffers");
    if (4 * s.n > 0xffffffffu) throw std::invalid_argument("splats: more than 2^30 points");
    ctx.set_phase("receivers: splats", 0.0, 0.3);
    std::atomic<bool> bad{false};
    parallel_for(ctx, s.n, 1 << 14, [&](std::size_t b, std::size_t e) {
        for (std::size_t k = b; k < e; ++k) {
            const double* p = s.points + 3 * k;
            const double* u = s.u + 3 * k;
            const double* w = s.v + 3 * k;
            const double* f = s.facing + 3 * k;
            const double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                                 u[0] * w[1] - u[1] * w[0]};
            float* rec = sd->rec.data() + k * sd->stride;
            // The outline's box along u, v (the point itself included), and its least radius.
            double x0 = 0, x1 = 0, y0 = 0, y1 = 0, least = HUGE_VAL;
            for (std::size_t m = 0; m < s.sides; ++m) {
                const double r = s.radii[k * s.sides + m];
                if (!(r >= 0.0) || !std::isfinite(r)) bad = true;
                const float rf = float(r);
                rec[SplatData::kRadii + m] = rf;
                least = std::min(least, double(rf));
                x0 = std::min(x0, double(rf) * sd->cos_t[m]);
                x1 = std::max(x1, double(rf) * sd->cos_t[m]);
                y0 = std::min(y0, double(rf) * sd->sin_t[m]);
                y1 = std::max(y1, double(rf) * sd->sin_t[m]);
            }
            rec[SplatData::kInner2] = float(least * chord * least * chord);
            if (!std::isfinite(p[0] + p[1] + p[2] + n[0] + n[1] + n[2])) bad = true;
            // A hair wider than the outline, so that the rectangle never clips its corners.
            const double pad = 1e-5 * std::max({x1 - x0, y1 - y0, 1e-30});
            x0 -= pad; x1 += pad; y0 -= pad; y1 += pad;
            const double xs[4] = {x0, x1, x1, x0}, ys[4] = {y0, y0, y1, y1};
            for (int c = 0; c < 4; ++c)
                for (int d = 0; d < 3; ++d)
                    vb[3 * (4 * k + c) + d] =
                        float(p[d] + xs[c] * u[d] + ys[c] * w[d] - frame_.center[d]);
            const unsigned v0 = unsigned(4 * k);
            ib[6 * k + 0] = v0; ib[6 * k + 1] = v0 + 1; ib[6 * k + 2] = v0 + 2;
            ib[6 * k + 3] = v0; ib[6 * k + 4] = v0 + 2; ib[6 * k + 5] = v0 + 3;
            for (int d = 0; d < 3; ++d) {
                rec[SplatData::kC + d] = float(p[d] - frame_.center[d]);
                rec[SplatData::kU + d] = float(u[d]);
                rec[SplatData::kV + d] = float(w[d]);
            }
            rec[SplatData::kAlong] = n[0] * f[0] + n[1] * f[1] + n[2] * f[2] >= 0.0 ? 1.0f : -1.0f;
        }
    });
    if (bad) {
        rtcReleaseGeometry(g);
        throw std::invalid_argument("splats: a point, axis or radius is not finite (or a radius < 0)");
    }
    rtcSetGeometryUserData(g, sd.get());
    rtcSetGeometryIntersectFilterFunction(g, splat_filter);
    rtcSetGeometryOccludedFilterFunction(g, splat_filter);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(impl_->scene, g, kSplatGeom);
    rtcReleaseGeometry(g);
    n_splats_ = s.n;
    splat_sides_ = s.sides;
    splats_ = std::move(sd);
}

std::array<float, 3> MeshScene::triangle_normal(std::size_t t) const {
    const double* c = corners_ + 9 * t;
    const double e1[3] = {c[3] - c[0], c[4] - c[1], c[5] - c[2]};
    const double e2[3] = {c[6] - c[0], c[7] - c[1], c[8] - c[2]};
    double nx = e1[1] * e2[2] - e1[2] * e2[1], ny = e1[2] * e2[0] - e1[0] * e2[2],
           nz = e1[0] * e2[1] - e1[1] * e2[0];
    const double l = std::sqrt(nx * nx + ny * ny + nz * nz);
    if (l > 0) { nx /= l; ny /= l; nz /= l; }
    return {float(nx), float(ny), float(nz)};
}

bool MeshScene::clip(const double* p, const double* u, double len, double& s0, double& s1) const {
    return clip_to_box(lo_, hi_, p, u, len, s0, s1);
}

namespace {

// The Embree ray for [s0, s1] of p + t u, its origin at p + s0 u relative to the frame's
// origin. The first few float ulps of the origin's distance from there are skipped: a receiver
// far from the bulk must not hit its own surface through rounding.
void fill(RTCRay& r, const double* p, const double* u, double s0, double s1, const LocalFrame& f) {
    const double o[3] = {p[0] + s0 * u[0], p[1] + s0 * u[1], p[2] + s0 * u[2]};
    r.org_x = float(o[0] - f.center[0]);
    r.org_y = float(o[1] - f.center[1]);
    r.org_z = float(o[2] - f.center[2]);
    r.dir_x = float(u[0]);
    r.dir_y = float(u[1]);
    r.dir_z = float(u[2]);
    r.tnear = float(std::min(f.noise(o), 0.5 * (s1 - s0)));
    r.tfar = float(s1 - s0);
    r.time = 0.0f;
    r.mask = 0xffffffffu;
    r.id = 0;
    r.flags = 0;
}

}  // namespace

void MeshScene::segments(Context& ctx, const double* a, const double* b, std::size_t n,
                         double end_trim, float* out) const {
    if (n_tri_ == 0) {
        std::fill(out, out + n, 1.0f);
        return;
    }
    const auto scene = impl_->scene;
    parallel_for(ctx, n, 1024, [&](std::size_t lo, std::size_t hi) {
        RTCIntersectContext ic;
        rtcInitIntersectContext(&ic);
        ic.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
        RTCRay rays[kBatch];
        std::size_t slot[kBatch], m = 0;
        auto flush = [&] {
            if (!m) return;
            rtcOccluded1M(scene, &ic, rays, unsigned(m), sizeof(RTCRay));
            for (std::size_t q = 0; q < m; ++q) out[slot[q]] = rays[q].tfar < 0.0f ? 0.0f : 1.0f;
            m = 0;
        };
        for (std::size_t k = lo; k < hi; ++k) {
            out[k] = 1.0f;
            const double* p = a + 3 * k;
            const double* q = b + 3 * k;
            double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
            const double len = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
            if (!(len > end_trim) || !std::isfinite(len)) continue;
            for (double& x : u) x /= len;
            double s0, s1;
            if (!clip(p, u, len - end_trim, s0, s1)) continue;
            fill(rays[m], p, u, s0, s1, frame_);
            slot[m++] = k;
            if (m == kBatch) flush();
        }
        flush();
    });
}

bool MeshScene::occluded(const double* a, const double* b) const {
    if (n_tri_ == 0) return false;
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double len = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (!(len > 0) || !std::isfinite(len)) return false;
    for (double& x : u) x /= len;
    double s0, s1;
    if (!clip(a, u, len, s0, s1)) return false;
    RTCRay r;
    fill(r, a, u, s0, s1, frame_);
    RTCIntersectContext ic;
    rtcInitIntersectContext(&ic);
    rtcOccluded1(impl_->scene, &ic, &r);
    return r.tfar < 0.0f;
}

void MeshScene::intersect(Context& ctx, const double* o, const double* d, std::size_t n,
                          double tmax, std::int64_t* prim, double* t, std::uint8_t* front) const {
    parallel_for(ctx, n, 1024, [&](std::size_t lo, std::size_t hi) {
        intersect_serial(o + 3 * lo, d + 3 * lo, hi - lo, tmax, prim + lo, t + lo, front + lo);
    });
}

void MeshScene::intersect_serial(const double* o, const double* d, std::size_t n, double tmax,
                                 std::int64_t* prim, double* t, std::uint8_t* front,
                                 float* uv) const {
    std::fill(prim, prim + n, std::int64_t(-1));
    std::fill(t, t + n, HUGE_VAL);
    std::fill(front, front + n, std::uint8_t(0));
    if (n_tri_ == 0) return;
    RTCIntersectContext ic;
    rtcInitIntersectContext(&ic);
    ic.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    RTCRayHit rays[kBatch];
    std::size_t slot[kBatch], m = 0;
    double start[kBatch];
    auto flush = [&] {
        if (!m) return;
        rtcIntersect1M(impl_->scene, &ic, rays, unsigned(m), sizeof(RTCRayHit));
        for (std::size_t q = 0; q < m; ++q) {
            const RTCRayHit& rh = rays[q];
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
            const std::size_t k = slot[q];
            std::size_t pr = rh.hit.primID;
            float hu = rh.hit.u, hv = rh.hit.v;
            if (rh.hit.geomID == kSplatGeom) {
                // The fan triangle the filter found the hit in (the same test, the same floats).
                const float org[3] = {rh.ray.org_x, rh.ray.org_y, rh.ray.org_z};
                const float dir[3] = {rh.ray.dir_x, rh.ray.dir_y, rh.ray.dir_z};
                if (!splats_->ray_hit(pr / 2, org, dir, rh.ray.tfar, pr, hu, hv)) continue;
            }
            prim[k] = std::int64_t(pr);
            t[k] = start[q] + double(rh.ray.tfar);
            const std::array<float, 3> nt = triangle_normal(pr);
            const double c = d[3 * k] * nt[0] + d[3 * k + 1] * nt[1] + d[3 * k + 2] * nt[2];
            front[k] = c < 0.0 ? 1 : 0;
            if (uv) { uv[2 * k] = hu; uv[2 * k + 1] = hv; }
        }
        m = 0;
    };
    for (std::size_t k = 0; k < n; ++k) {
        const double* p = o + 3 * k;
        const double* u = d + 3 * k;
        if (!std::isfinite(p[0] + p[1] + p[2] + u[0] + u[1] + u[2])) continue;
        double s0, s1;
        if (!clip(p, u, tmax, s0, s1)) continue;
        fill(rays[m].ray, p, u, s0, s1, frame_);
        rays[m].hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rays[m].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        start[m] = s0;
        slot[m++] = k;
        if (m == kBatch) flush();
    }
    flush();
}

}  // namespace illumap
