// embree_util.hpp — what the two Embree scenes (raycast.cpp's surfel occluders and
// mesh_scene.cpp's triangles) share: error translation, the build's cancel hook, and clipping
// a ray to the scene's box in double precision before it becomes single precision.
#pragma once

#include "parallel.hpp"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <stdexcept>
#include <string>

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
