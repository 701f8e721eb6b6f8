// mesh_scene.cpp — Embree 3 triangle scene for receivers (see mesh_scene.hpp).
#include "visibility/mesh_scene.hpp"

#include "visibility/embree_util.hpp"
#include "geometry/local_frame.hpp"

#include <algorithm>
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

namespace {

constexpr std::size_t kBatch = 64;  // rays per rtcOccluded1M / rtcIntersect1M call

}  // namespace

MeshScene::MeshScene(Context& ctx, const double* corners, std::size_t n_tri) : n_tri_(n_tri) {
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
        if (n_tri > 0) {
            RTCGeometry g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
            ctx.set_phase("receivers: triangles", 0.0, 0.3);
            vertices_ = set_shared_triangles(ctx, impl_->device, g, corners, n_tri, frame_.center);
            rtcCommitGeometry(g);
            rtcAttachGeometry(impl_->scene, g);
            rtcReleaseGeometry(g);
        }
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
            const std::uint32_t pr = rh.hit.primID;
            prim[k] = pr;
            t[k] = start[q] + double(rh.ray.tfar);
            const std::array<float, 3> nt = triangle_normal(pr);
            const double c = d[3 * k] * nt[0] + d[3 * k + 1] * nt[1] + d[3 * k + 2] * nt[2];
            front[k] = c < 0.0 ? 1 : 0;
            if (uv) { uv[2 * k] = rh.hit.u; uv[2 * k + 1] = rh.hit.v; }
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
