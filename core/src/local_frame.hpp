// local_frame.hpp — where single-precision coordinates are measured from, and the length that
// ray offsets scale with, so that results do not depend on where a scene sits or on a far
// outlier beside it.
//
// Embree stores floats: a coordinate carries a rounding error of ~6e-8 of its distance from
// the origin it is stored against. The frame's origin is the per-axis median of the geometry,
// so one far object moves neither the origin nor the bulk's precision, and its feature length
// is the largest per-axis spread between the 1st and 99th percentiles, so offsets follow the
// size of the bulk rather than the distance to an outlier. Both come from at most kSample
// evenly strided points: deterministic, and O(n) however large the scene.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace illumap {

struct LocalFrame {
    double center[3] = {0, 0, 0};
    double length = 0;  // m, > 0 whenever the points are not all equal

    // Distance below which float positions near p are not told apart: a few dozen ulps of
    // p's distance from the origin (2^-18 ~ 3.8e-6 relative).
    double noise(const double* p) const {
        const double d = std::max({std::fabs(p[0] - center[0]), std::fabs(p[1] - center[1]),
                                   std::fabs(p[2] - center[2])});
        return d * 0x1p-18;
    }
};

// Points are given by `point(i, xyz)` for i < n (xyz: 3 doubles out).
template <class PointFn>
LocalFrame make_local_frame(std::size_t n, PointFn point) {
    constexpr std::size_t kSample = std::size_t(1) << 16;
    LocalFrame f;
    if (n == 0) return f;
    const std::size_t stride = (n + kSample - 1) / kSample;
    std::vector<double> axis[3];
    for (auto& a : axis) a.reserve(n / stride + 1);
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (std::size_t i = 0; i < n; i += stride) {
        double p[3];
        point(i, p);
        for (int d = 0; d < 3; ++d) {
            axis[d].push_back(p[d]);
            lo[d] = std::min(lo[d], p[d]);
            hi[d] = std::max(hi[d], p[d]);
        }
    }
    const std::size_t m = axis[0].size();
    auto at = [&](std::vector<double>& a, std::size_t k) {
        std::nth_element(a.begin(), a.begin() + std::ptrdiff_t(k), a.end());
        return a[k];
    };
    double box = 0;
    for (int d = 0; d < 3; ++d) {
        f.center[d] = at(axis[d], m / 2);
        const double q1 = at(axis[d], m / 100), q99 = at(axis[d], m - 1 - m / 100);
        f.length = std::max(f.length, q99 - q1);
        box = std::max(box, hi[d] - lo[d]);
    }
    if (!(f.length > 0)) f.length = box;  // a few points, or all but one equal
    return f;
}

}  // namespace illumap
