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

// The splats' outlines as the filter reads them: per point its plane's axes u, v (6 floats),
// its fan's radii (sides floats) and whether its winding faces along u x v; the outline's
// directions; Embree's disc buffer (centre relative to the frame, and radius).
struct SplatData {
    std::size_t n = 0, sides = 0, first = 0;
    std::vector<float> axes, radii;
    std::vector<std::uint8_t> along;
    std::vector<double> cos_t, sin_t;
    const float* disc = nullptr;  // 4 per point, owned by the Embree geometry

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
        const float* r = radii.data() + k * sides;
        const double ax = r[m] * cos_t[m], ay = r[m] * sin_t[m];
        const double bx = r[m1] * cos_t[m1], by = r[m1] * sin_t[m1];
        const double det = ax * by - ay * bx;
        if (!(det > 0.0)) return false;   // a rim at radius 0: no triangle there
        const double al = (x * by - y * bx) / det, be = (ax * y - ay * x) / det;
        if (!(al + be <= 1.0)) return false;
        row = first + k * sides + m;
        // Corners (centre, rim m, rim m + 1) when the fan is wound along u x v, else
        // (centre, rim m + 1, rim m).
        bu = float(along[k] ? al : be);
        bv = float(along[k] ? be : al);
        return true;
    }

    // The same for the hit of a ray (frame-relative float origin, direction, distance t) on
    // point k's disc.
    bool ray_hit(std::size_t k, const float o[3], const float d[3], float t, std::size_t& row,
                 float& bu, float& bv) const {
        const float* c = disc + 4 * k;
        const float* ax = axes.data() + 6 * k;
        double w[3];
        for (int i = 0; i < 3; ++i) w[i] = double(o[i]) + double(t) * double(d[i]) - double(c[i]);
        const double x = w[0] * ax[0] + w[1] * ax[1] + w[2] * ax[2];
        const double y = w[0] * ax[3] + w[1] * ax[4] + w[2] * ax[5];
        return hit(k, x, y, row, bu, bv);
    }
};

namespace {

constexpr std::size_t kBatch = 64;  // rays per rtcOccluded1M / rtcIntersect1M call
constexpr unsigned kTriangleGeom = 0, kSplatGeom = 1;  // Embree geometry ids

// Embree's intersection and occlusion filter on the splat discs: a hit outside the fan's
// outline is no hit (the ray goes on).
void splat_filter(const RTCFilterFunctionNArguments* args) {
    const auto* sd = static_cast<const SplatData*>(args->geometryUserPtr);
    const unsigned N = args->N;
    for (unsigned i = 0; i < N; ++i) {
        if (args->valid[i] != -1) continue;
        const float o[3] = {RTCRayN_org_x(args->ray, N, i), RTCRayN_org_y(args->ray, N, i),
                            RTCRayN_org_z(args->ray, N, i)};
        const float d[3] = {RTCRayN_dir_x(args->ray, N, i), RTCRayN_dir_y(args->ray, N, i),
                            RTCRayN_dir_z(args->ray, N, i)};
        std::size_t row;
        float bu, bv;
        if (!sd->ray_hit(RTCHitN_primID(args->hit, N, i), o, d, RTCRayN_tfar(args->ray, N, i),
                         row, bu, bv))
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

// The splats as one oriented disc each (radius: the fan's largest), in the fan's plane, with
// the outline filter; their data copied into floats (SplatData).
void MeshScene::add_splats(Context& ctx, const SplatOutlines& s) {
    auto sd = std::make_shared<SplatData>();
    sd->n = s.n;
    sd->sides = s.sides;
    sd->first = s.first;
    sd->axes.resize(6 * s.n);
    sd->radii.resize(s.n * s.sides);
    sd->along.resize(s.n);
    sd->cos_t.resize(s.sides);
    sd->sin_t.resize(s.sides);
    for (std::size_t m = 0; m < s.sides; ++m) {   // as splats.cpp's outline_directions
        const double t = 2.0 * M_PI * double(m) / double(s.sides);
        sd->cos_t[m] = std::cos(t);
        sd->sin_t[m] = std::sin(t);
    }
    RTCGeometry g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT);
    float* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), s.n));
    float* nb = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), s.n));
    throw_embree(impl_->device, "splat buffers");
    sd->disc = v;
    ctx.set_phase("receivers: splats", 0.0, 0.3);
    std::vector<double> reach(s.n, 0.0);
    std::atomic<bool> bad{false};
    parallel_for(ctx, s.n, 1 << 14, [&](std::size_t b, std::size_t e) {
        for (std::size_t k = b; k < e; ++k) {
            const double* p = s.points + 3 * k;
            const double* u = s.u + 3 * k;
            const double* w = s.v + 3 * k;
            const double* f = s.facing + 3 * k;
            const double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                                 u[0] * w[1] - u[1] * w[0]};
            const double nl = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            double r = 0.0;
            for (std::size_t m = 0; m < s.sides; ++m) {
                const double x = s.radii[k * s.sides + m];
                if (!(x >= 0.0) || !std::isfinite(x)) bad = true;
                r = std::max(r, x);
                sd->radii[k * s.sides + m] = float(x);
            }
            if (!(nl > 0.0) || !std::isfinite(nl + p[0] + p[1] + p[2])) bad = true;
            for (int d = 0; d < 3; ++d) {
                sd->axes[6 * k + d] = float(u[d]);
                sd->axes[6 * k + 3 + d] = float(w[d]);
                nb[3 * k + d] = float(n[d] / nl);
                v[4 * k + d] = float(p[d] - frame_.center[d]);
            }
            // A hair wider than the fan, so that the disc's own test never clips its corners.
            v[4 * k + 3] = float(r * (1.0 + 1e-5));
            sd->along[k] = n[0] * f[0] + n[1] * f[1] + n[2] * f[2] >= 0.0 ? 1 : 0;
            reach[k] = r;
        }
    });
    if (bad) {
        rtcReleaseGeometry(g);
        throw std::invalid_argument("splats: a point, axis or radius is not finite (or a radius < 0)");
    }
    double rmax = 0.0;
    for (double r : reach) rmax = std::max(rmax, r);
    back_ = 2.5 * rmax;
    rtcSetGeometryUserData(g, sd.get());
    rtcSetGeometryIntersectFilterFunction(g, splat_filter);
    rtcSetGeometryOccludedFilterFunction(g, splat_filter);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(impl_->scene, g, kSplatGeom);
    rtcReleaseGeometry(g);
    n_splats_ = s.n;
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
// With splats, the ray starts `back` (MeshScene::ray_back) behind that origin.
void fill(RTCRay& r, const double* p, const double* u, double s0, double s1, const LocalFrame& f,
          double back) {
    const double o[3] = {p[0] + s0 * u[0], p[1] + s0 * u[1], p[2] + s0 * u[2]};
    if (back > 0.0) {
        r.org_x = float(o[0] - back * u[0] - f.center[0]);
        r.org_y = float(o[1] - back * u[1] - f.center[1]);
        r.org_z = float(o[2] - back * u[2] - f.center[2]);
        r.tnear = float(back + std::min(f.noise(o), 0.5 * (s1 - s0)));
        r.tfar = float(back + (s1 - s0));
    } else {   // meshes alone: as ever, bit for bit
        r.org_x = float(o[0] - f.center[0]);
        r.org_y = float(o[1] - f.center[1]);
        r.org_z = float(o[2] - f.center[2]);
        r.tnear = float(std::min(f.noise(o), 0.5 * (s1 - s0)));
        r.tfar = float(s1 - s0);
    }
    r.dir_x = float(u[0]);
    r.dir_y = float(u[1]);
    r.dir_z = float(u[2]);
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
            fill(rays[m], p, u, s0, s1, frame_, back_);
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
    fill(r, a, u, s0, s1, frame_, back_);
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
                if (!splats_->ray_hit(pr, org, dir, rh.ray.tfar, pr, hu, hv)) continue;
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
        fill(rays[m].ray, p, u, s0, s1, frame_, back_);
        rays[m].hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rays[m].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        start[m] = s0 - back_;   // s0 itself without splats (back_ = 0)
        slot[m++] = k;
        if (m == kBatch) flush();
    }
    flush();
}

}  // namespace illumap
