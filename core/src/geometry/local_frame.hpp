// local_frame.hpp — where single-precision coordinates are measured from, and the length that
// ray offsets scale with, so that results do not depend on where a scene sits or on a far
// outlier beside it.
//
// Embree stores floats: a coordinate carries a rounding error of ~6e-8 of its distance from
// the origin it is stored against. The frame's origin is the per-axis median of the geometry,
// weighted by area, so one far object moves neither the origin nor the bulk's precision, and
// its feature length is the largest per-axis spread between the 1st and 99th percentiles of
// the area, so offsets follow the size of the bulk rather than the distance to an outlier.
// Both come from at most kSample evenly strided points: deterministic, O(n log n) in at most
// kSample, however large the scene.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

namespace illumap {

// Area (m²) of the triangle with corners c[0..8].
inline double triangle_area(const double* c) {
    const double u[3] = {c[3] - c[0], c[4] - c[1], c[5] - c[2]};
    const double v[3] = {c[6] - c[0], c[7] - c[1], c[8] - c[2]};
    const double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2],
                 z = u[0] * v[1] - u[1] * v[0];
    return 0.5 * std::sqrt(x * x + y * y + z * z);
}

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

// Points are given by `point(i, xyz)` for i < n (xyz: 3 doubles out), each with a weight
// `weight(i)` >= 0: the area it stands for, so that a speck far away (a 1 cm plane 1000 km
// off, a handful of points among a room's hundreds) moves neither the origin nor the length.
// The origin is one of the points, so it moves with the scene: a scene moved by a micron
// keeps its float coordinates (snapping it to a grid had made them round differently).
template <class PointFn, class WeightFn>
LocalFrame make_local_frame(std::size_t n, PointFn point, WeightFn weight) {
    constexpr std::size_t kSample = std::size_t(1) << 16;
    LocalFrame f;
    if (n == 0) return f;
    const std::size_t stride = (n + kSample - 1) / kSample;
    std::vector<std::pair<double, double>> axis[3];  // (coordinate, weight)
    for (auto& a : axis) a.reserve(n / stride + 1);
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    double total = 0;
    for (std::size_t i = 0; i < n; i += stride) {
        double p[3];
        point(i, p);
        const double w = std::max(0.0, double(weight(i)));
        total += w;
        for (int d = 0; d < 3; ++d) {
            axis[d].push_back({p[d], w});
            lo[d] = std::min(lo[d], p[d]);
            hi[d] = std::max(hi[d], p[d]);
        }
    }
    const bool weighted = total > 0 && std::isfinite(total);
    // The coordinate below which a share q of the weight lies (of the points, unweighted).
    auto at = [&](std::vector<std::pair<double, double>>& a, double q) {
        const double goal = q * (weighted ? total : double(a.size()));
        double sum = 0;
        for (const auto& [x, w] : a) {
            sum += weighted ? w : 1.0;
            if (sum > goal) return x;
        }
        return a.back().first;
    };
    double box = 0;
    for (int d = 0; d < 3; ++d) {
        std::sort(axis[d].begin(), axis[d].end());
        f.center[d] = at(axis[d], 0.5);
        f.length = std::max(f.length, at(axis[d], 0.99) - at(axis[d], 0.01));
        box = std::max(box, hi[d] - lo[d]);
    }
    if (!(f.length > 0)) f.length = box;  // a few points, or all but one equal
    return f;
}

template <class PointFn>
LocalFrame make_local_frame(std::size_t n, PointFn point) {
    return make_local_frame(n, point, [](std::size_t) { return 1.0; });
}

}  // namespace illumap
