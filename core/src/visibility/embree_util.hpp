// embree_util.hpp — what the two Embree scenes (raycast.cpp's surfel occluders and
// mesh_scene.cpp's triangles) share: error translation, the build's cancel hook, and clipping
// a ray to the scene's box in double precision before it becomes single precision.
#pragma once

#include "parallel.hpp"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace illumap {

// Throws Cancelled for a cancelled build, std::runtime_error for another Embree error.
inline void throw_embree(RTCDevice dev, const char* what) {
    const RTCError e = rtcGetDeviceError(dev);
    if (e == RTC_ERROR_NONE) return;
    if (e == RTC_ERROR_CANCELLED) throw Cancelled();
    throw std::runtime_error(std::string("embree: ") + what + " failed (error " +
                             std::to_string(int(e)) + ")");
}

// Embree's build progress callback: false (stop) once the context's cancel flag is set.
inline bool embree_build_progress(void* cancel_flag, double) {
    return !static_cast<std::atomic<bool>*>(cancel_flag)->load(std::memory_order_relaxed);
}

// Triangles (n_tri x 9 doubles, world corners) as geometry g's index and vertex buffers, in
// float relative to `center`, neighbours sharing their vertices: a corner whose floats equal
// (bit for bit) one of the kWindow vertices last added in its chunk of kChunk triangles reuses
// it. A splat's fan of 12 triangles needs 13 vertices instead of 36, a mesh's strip about one
// per triangle; Embree sees the same floats as with three vertices per triangle. The chunks
// are fixed, so the buffers do not depend on the threads. Returns the number of vertices.
// `shift` (may be null: none) is taken off each corner first, in double: the same floats as
// corners shifted by the caller beforehand.
inline std::size_t set_shared_triangles(Context& ctx, RTCDevice dev, RTCGeometry g,
                                        const double* corners, std::size_t n_tri,
                                        const double center[3], const double* shift = nullptr) {
    constexpr std::size_t kChunk = std::size_t(1) << 14;
    constexpr int kWindow = 16;
    auto corner = [&](std::size_t t, int c, float out[3]) {
        for (int d = 0; d < 3; ++d) {
            const double x = corners[9 * t + 3 * c + d];
            out[d] = float((shift ? x - shift[d] : x) - center[d]);
        }
    };
    unsigned* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), n_tri));
    throw_embree(dev, "index buffer");
    const std::size_t nchunks = (n_tri + kChunk - 1) / kChunk;
    std::vector<std::size_t> first(nchunks + 1, 0);  // each chunk's first vertex, once summed
    // Pass 1: chunk-local vertex numbers into the index buffer, and each chunk's count.
    parallel_for(ctx, n_tri, kChunk, [&](std::size_t b, std::size_t e) {
        float ring[kWindow][3];
        unsigned ring_id[kWindow];
        int filled = 0, head = 0;
        unsigned count = 0;
        for (std::size_t t = b; t < e; ++t) {
            for (int c = 0; c < 3; ++c) {
                float x[3];
                corner(t, c, x);
                unsigned id = count;
                for (int k = 0; k < filled; ++k)
                    if (std::memcmp(ring[k], x, sizeof x) == 0) { id = ring_id[k]; break; }
                if (id == count) {
                    std::memcpy(ring[head], x, sizeof x);
                    ring_id[head] = count++;
                    head = (head + 1) % kWindow;
                    filled = std::min(filled + 1, kWindow);
                }
                ib[3 * t + c] = id;
            }
        }
        first[b / kChunk + 1] = count;
    });
    for (std::size_t c = 0; c < nchunks; ++c) first[c + 1] += first[c];
    if (first[nchunks] > 0xffffffffu)
        throw std::runtime_error("embree: more than 2^32 distinct triangle corners");
    float* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), first[nchunks]));
    throw_embree(dev, "vertex buffer");
    // Pass 2: each chunk's new vertices in order (a local number seen for the first time is
    // the next one), its indices made global.
    parallel_for(ctx, n_tri, kChunk, [&](std::size_t b, std::size_t e) {
        const std::size_t base = first[b / kChunk];
        unsigned next = 0;
        for (std::size_t t = b; t < e; ++t) {
            for (int c = 0; c < 3; ++c) {
                if (ib[3 * t + c] == next) corner(t, c, v + 3 * (base + next++));
                ib[3 * t + c] = unsigned(base + ib[3 * t + c]);
            }
        }
    });
    return first[nchunks];
}

// [a, e]: the part of [0, len] of the line p + t u (unit u) inside the box [lo, hi] (slabs);
// false when the line misses it or nothing of [0, len] is inside.
inline bool clip_to_box(const double lo[3], const double hi[3], const double* p, const double* u,
                        double len, double& a, double& e) {
    a = 0;
    e = len;
    for (int d = 0; d < 3; ++d) {
        if (u[d] != 0.0) {
            double ta = (lo[d] - p[d]) / u[d], tb = (hi[d] - p[d]) / u[d];
            if (ta > tb) std::swap(ta, tb);
            a = std::max(a, ta);
            e = std::min(e, tb);
        } else if (p[d] < lo[d] || p[d] > hi[d]) {
            return false;
        }
    }
    return e > a;
}

}  // namespace illumap
