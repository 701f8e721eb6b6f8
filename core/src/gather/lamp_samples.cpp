// lamp_samples.cpp — per receiver: the shifted lattice, mapped onto the lamp.
#include "gather/lamp_samples.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace illumap {

namespace {

constexpr double kGolden = 0.6180339887498949;

double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Shirley's concentric map of a point of [0,1)^2 onto the unit disc (area-preserving).
void concentric(double u, double v, double& x, double& y) {
    const double a = 2 * u - 1, b = 2 * v - 1;
    double r, phi;
    if (std::fabs(a) > std::fabs(b)) {
        r = a;
        phi = (M_PI / 4) * b / (a == 0 ? 1.0 : a);
    } else {
        r = b;
        phi = M_PI / 2 - (M_PI / 4) * a / (b == 0 ? 1.0 : b);
    }
    x = r * std::cos(phi);
    y = r * std::sin(phi);
}

// Two unit vectors perpendicular to unit d and to each other (lamps.py's _basis).
void basis(const double* d, double* u, double* v) {
    const double h[3] = {std::fabs(d[0]) < 0.9 ? 1.0 : 0.0, std::fabs(d[0]) < 0.9 ? 0.0 : 1.0, 0.0};
    u[0] = d[1] * h[2] - d[2] * h[1];
    u[1] = d[2] * h[0] - d[0] * h[2];
    u[2] = d[0] * h[1] - d[1] * h[0];
    const double len = std::sqrt(dot3(u, u));
    for (int c = 0; c < 3; ++c) u[c] /= len;
    v[0] = d[1] * u[2] - d[2] * u[1];
    v[1] = d[2] * u[0] - d[0] * u[2];
    v[2] = d[0] * u[1] - d[1] * u[0];
}

}  // namespace

void lamp_samples(Context& ctx, const LampShape& L, const double* p, const double* n,
                  const double* shifts, std::size_t m, std::size_t k, double far,
                  double* targets, double* weights) {
    ctx.set_phase("lamp samples", 0.0, 1.0);
    parallel_for(ctx, m, std::max<std::size_t>(1, 65536 / std::max<std::size_t>(k, 1)),
                 [&](std::size_t lo, std::size_t hi) {
        for (std::size_t i = lo; i < hi; ++i) {
            const double* pi = p + 3 * i;
            const double* ni = n + 3 * i;
            double bu[3], bv[3], sun[3];
            if (L.kind == LampKind::World) basis(ni, bu, bv);
            if (L.kind == LampKind::Sun) {
                for (int c = 0; c < 3; ++c) sun[c] = -L.direction[c];
                basis(sun, bu, bv);
            }
            if (L.kind == LampKind::Point) {
                double d[3];
                for (int c = 0; c < 3; ++c) d[c] = L.position[c] - pi[c];
                const double dist = std::max(std::sqrt(dot3(d, d)), 1e-300);
                for (double& x : d) x /= dist;
                basis(d, bu, bv);
            }
            for (std::size_t s = 0; s < k; ++s) {
                const double u = std::fmod((double(s) + 0.5) / double(k) + shifts[2 * i], 1.0);
                const double v = std::fmod(std::fmod(double(s) * kGolden, 1.0) + shifts[2 * i + 1], 1.0);
                double* t = targets + 3 * (i * k + s);
                double& w = weights[i * k + s];
                double x, y, d[3];
                switch (L.kind) {
                case LampKind::World: {
                    concentric(u, v, x, y);
                    const double up = std::sqrt(std::max(1.0 - (x * x + y * y), 0.0));
                    for (int c = 0; c < 3; ++c) t[c] = pi[c] + far * (x * bu[c] + y * bv[c] + up * ni[c]);
                    w = 1.0;
                    break;
                }
                case LampKind::Sun: {
                    concentric(u, v, x, y);
                    const double r = std::tan(L.angle / 2);
                    for (int c = 0; c < 3; ++c) d[c] = sun[c] + r * x * bu[c] + r * y * bv[c];
                    const double len = std::sqrt(dot3(d, d));
                    for (double& c : d) c /= len;
                    for (int c = 0; c < 3; ++c) t[c] = pi[c] + far * d[c];
                    w = std::max(dot3(d, ni), 0.0);
                    break;
                }
                case LampKind::Mesh: {
                    const double* cum = L.cumulative;
                    const std::size_t T = L.triangles;
                    std::size_t tri = std::size_t(std::upper_bound(cum, cum + T, u) - cum);
                    tri = std::min(tri, T - 1);
                    const double low = tri > 0 ? cum[tri - 1] : 0.0;
                    const double a = std::clamp((u - low) / std::max(cum[tri] - low, 1e-300), 0.0, 1.0);
                    const double sq = std::sqrt(a);
                    const double* c0 = L.corner + 3 * tri;
                    const double* e1 = L.edge1 + 3 * tri;
                    const double* e2 = L.edge2 + 3 * tri;
                    for (int c = 0; c < 3; ++c) t[c] = c0[c] + sq * (1 - v) * e1[c] + sq * v * e2[c];
                    for (int c = 0; c < 3; ++c) d[c] = t[c] - pi[c];
                    const double r2 = std::max(dot3(d, d), 1e-300);
                    const double cos_r = std::max(dot3(d, ni), 0.0);
                    double cos_l = -dot3(d, L.normal + 3 * tri);
                    cos_l = L.two_sided ? std::fabs(cos_l) : std::max(cos_l, 0.0);
                    w = L.power[tri] * cos_r * cos_l / (r2 * r2);
                    break;
                }
                case LampKind::Area: {
                    if (L.disk) {
                        concentric(u, v, x, y);
                    } else {
                        x = 2 * u - 1;
                        y = 2 * v - 1;
                    }
                    for (int c = 0; c < 3; ++c) t[c] = L.position[c] + x * L.axes[0][c] + y * L.axes[1][c];
                    for (int c = 0; c < 3; ++c) d[c] = t[c] - pi[c];
                    const double r2 = std::max(dot3(d, d), 1e-300);
                    const double cos_r = std::max(dot3(d, ni), 0.0);
                    const double cos_l = std::max(-dot3(d, L.direction), 0.0);
                    w = cos_r * cos_l / (r2 * r2);
                    break;
                }
                case LampKind::Point: {
                    concentric(u, v, x, y);
                    for (int c = 0; c < 3; ++c)
                        t[c] = L.position[c] + L.radius * x * bu[c] + L.radius * y * bv[c];
                    for (int c = 0; c < 3; ++c) d[c] = t[c] - pi[c];
                    const double r2 = std::max(dot3(d, d), 1e-300);
                    w = std::max(dot3(d, ni), 0.0) / (r2 * std::sqrt(r2));
                    break;
                }
                }
            }
        }
    });
}

}  // namespace illumap
