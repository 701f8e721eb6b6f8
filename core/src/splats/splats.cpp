// splats.cpp — clipped splat outlines, one point per task (see splats.hpp).
#include "splats/splats.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace illumap {

namespace {

double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double sign(double x) { return double(x > 0) - double(x < 0); }

// cos and sin of the outline's angles 2 pi m / sides.
void outline_directions(std::size_t sides, std::vector<double>& cos_t, std::vector<double>& sin_t) {
    cos_t.resize(sides);
    sin_t.resize(sides);
    for (std::size_t m = 0; m < sides; ++m) {
        const double t = 2.0 * M_PI * double(m) / double(sides);
        cos_t[m] = std::cos(t);
        sin_t[m] = std::sin(t);
    }
}

// What a neighbour imposes on the splat, independent of the direction.
struct Neighbour {
    double w[3];        // neighbour minus point
    double nq[3];       // its normal
    double half;        // |w|^2 / 2
    double gap;         // sqrt(2 half) = |w|
    double length;      // |w| in the tangent plane
    bool turn;          // its surface turns away from the point's
    bool on_plane;      // the point lies on its tangent plane
    double side;        // which side of that plane the splat keeps (0: none)
    double bend;        // which side of the point's plane it lies on (0: on the edge line)
};

}  // namespace

void splat_radii(Context& ctx, const double* points, const double* normals, const double* u,
                 const double* v, const double* reach, const double* rim, std::size_t n,
                 const std::int64_t* neighbours, std::size_t k, std::size_t sides,
                 const SplatOptions& o, double* radii) {
    ctx.set_phase("splats", 0.0, 1.0);
    std::vector<double> cos_t, sin_t;
    outline_directions(sides, cos_t, sin_t);
    const double inf = std::numeric_limits<double>::infinity();
    parallel_for(ctx, n, 1024, [&](std::size_t b, std::size_t e) {
        std::vector<Neighbour> nb(k);
        for (std::size_t i = b; i < e; ++i) {
            const double* p = points + 3 * i;
            const double* np = normals + 3 * i;
            double* out = radii + i * sides;
            // The point's own surface: neighbours that do not turn away, their centroid with p.
            double centroid[3] = {0, 0, 0}, own = 1.0;
            for (std::size_t j = 0; j < k; ++j) {
                const std::int64_t q = neighbours[i * k + j];
                if (q < 0 || std::size_t(q) >= n) throw std::out_of_range("neighbour index out of range");
                Neighbour& g = nb[j];
                for (int c = 0; c < 3; ++c) {
                    g.w[c] = points[3 * q + c] - p[c];
                    g.nq[c] = normals[3 * q + c];
                }
                g.half = 0.5 * dot3(g.w, g.w);
                g.gap = std::sqrt(2.0 * g.half);
                g.turn = dot3(np, g.nq) < o.edge_cos;
                const double rise = dot3(g.w, np);
                double t[3];
                for (int c = 0; c < 3; ++c) t[c] = g.w[c] - rise * np[c];
                g.length = std::sqrt(dot3(t, t));
                g.bend = std::fabs(rise) > o.junction_tolerance * g.gap ? sign(rise) : 0.0;
                if (!g.turn) {
                    for (int c = 0; c < 3; ++c) centroid[c] += g.w[c];
                    own += 1.0;
                }
            }
            for (double& c : centroid) c /= own;
            bool up = false, down = false;
            for (std::size_t j = 0; j < k; ++j) {
                Neighbour& g = nb[j];
                const double height = -dot3(g.w, g.nq);                 // (p - q) . n_q
                g.on_plane = g.turn && std::fabs(height) <= o.junction_tolerance * g.gap;
                const double lean = dot3(centroid, g.nq) + height;      // (c - q) . n_q
                const bool leaning = std::fabs(lean) > o.junction_tolerance * g.gap;
                g.side = g.on_plane ? (leaning ? sign(lean) : 0.0) : sign(height);
                up |= g.on_plane && g.bend > 0;
                down |= g.on_plane && g.bend < 0;
            }
            // Another surface on both sides of p's plane, p on it: a junction, nothing clips.
            const bool junction = up && down;
            for (std::size_t m = 0; m < sides; ++m) {
                double d[3];
                for (int c = 0; c < 3; ++c) d[c] = cos_t[m] * u[3 * i + c] + sin_t[m] * v[3 * i + c];
                double radius = inf;
                bool supported = false;
                for (std::size_t j = 0; j < k; ++j) {
                    const Neighbour& g = nb[j];
                    const double dw = dot3(d, g.w);
                    if (dw > 1e-12 * std::sqrt(g.half) + 1e-300 && !g.turn)
                        radius = std::min(radius, o.corner_slack * g.half / dw);
                    supported |= dw / std::max(g.length, 1e-300) > o.rim_cos && g.length > 0;
                    if (g.turn && g.side != 0 && !(g.on_plane && junction)) {
                        const double slope = g.side * dot3(d, g.nq);
                        if (slope < 0) {
                            const double height = -dot3(g.w, g.nq);
                            const double lift = std::max(g.side * height, 0.0) + o.edge_overlap * g.gap;
                            radius = std::min(radius, lift / -slope);
                        }
                    }
                }
                if (!supported) radius = std::min(radius, rim[i]);
                out[m] = std::min(radius, reach[i]);
            }
        }
    });
}

void splat_fans(Context& ctx, const double* points, const double* u, const double* v,
                const double* radii, const double* facing, std::size_t n, std::size_t sides,
                double* triangles) {
    ctx.set_phase("splats", 0.0, 1.0);
    std::vector<double> cos_t, sin_t;
    outline_directions(sides, cos_t, sin_t);
    parallel_for(ctx, n, 4096, [&](std::size_t b, std::size_t e) {
        std::vector<double> rim(3 * sides);
        for (std::size_t i = b; i < e; ++i) {
            const double* p = points + 3 * i;
            const double* ui = u + 3 * i;
            const double* vi = v + 3 * i;
            for (std::size_t m = 0; m < sides; ++m) {
                const double r = radii[i * sides + m];
                for (int c = 0; c < 3; ++c)
                    rim[3 * m + c] = p[c] + r * (cos_t[m] * ui[c] + sin_t[m] * vi[c]);
            }
            // The rim runs counter-clockwise about u x v.
            const double w[3] = {ui[1] * vi[2] - ui[2] * vi[1], ui[2] * vi[0] - ui[0] * vi[2],
                                 ui[0] * vi[1] - ui[1] * vi[0]};
            const bool along = dot3(w, facing + 3 * i) >= 0;
            for (std::size_t m = 0; m < sides; ++m) {
                const double* here = rim.data() + 3 * m;
                const double* next = rim.data() + 3 * ((m + 1) % sides);
                double* t = triangles + 9 * (i * sides + m);
                for (int c = 0; c < 3; ++c) {
                    t[c] = p[c];
                    t[3 + c] = along ? here[c] : next[c];
                    t[6 + c] = along ? next[c] : here[c];
                }
            }
        }
    });
}

}  // namespace illumap
