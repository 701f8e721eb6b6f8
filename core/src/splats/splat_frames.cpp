// splat_frames.cpp — the preview's splats, in passes over the points (see splat_frames.hpp):
// each pass reads what the one before wrote for the neighbours, so passes are separated by
// the parallel_for's join and each point writes only its own rows.
#include "splats/splat_frames.hpp"

#include "geometry/knn.hpp"
#include "geometry/normals.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

namespace illumap {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct V3 {
    double x = 0, y = 0, z = 0;
};
V3 at(const double* a, std::size_t i) { return {a[3 * i], a[3 * i + 1], a[3 * i + 2]}; }
void put(double* a, std::size_t i, V3 v) { a[3 * i] = v.x; a[3 * i + 1] = v.y; a[3 * i + 2] = v.z; }
V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 operator*(double s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double norm(V3 a) { return std::sqrt(dot(a, a)); }
double sign(double x) { return double(x > 0) - double(x < 0); }

// A unit vector perpendicular to the unit n (the same rule as the reference's _tangent).
V3 tangent(V3 n) {
    const V3 helper = std::fabs(n.x) < 0.9 ? V3{1, 0, 0} : V3{0, 1, 0};
    const V3 u = cross(n, helper);
    return (1.0 / norm(u)) * u;
}

std::size_t checked(std::int64_t q, std::size_t n) {
    if (q < 0 || std::size_t(q) >= n) throw std::out_of_range("neighbour index out of range");
    return std::size_t(q);
}

// The widest angle between the directions to the points `idx` (count of them) seen from p in
// its tangent plane (unit normal nv), and the unit direction that halves it.
double widest_gap(const double* points, V3 p, V3 nv, const std::int64_t* idx, std::size_t count,
                  std::size_t n, std::vector<double>& angle, V3* out) {
    const V3 u = tangent(nv), v = cross(nv, u);
    angle.resize(count);
    for (std::size_t j = 0; j < count; ++j) {
        const V3 d = at(points, checked(idx[j], n)) - p;
        angle[j] = std::atan2(dot(d, v), dot(d, u));
    }
    std::sort(angle.begin(), angle.end());
    double best = -kInf, half = 0.0;
    for (std::size_t j = 0; j < count; ++j) {
        const double gap = (j + 1 < count ? angle[j + 1] : angle[0] + 2.0 * M_PI) - angle[j];
        if (gap > best) {
            best = gap;
            half = angle[j] + 0.5 * gap;
        }
    }
    if (out) *out = std::cos(half) * u + std::sin(half) * v;
    return best;
}

// Whether widest_gap(...) > wide (radians, in (0, pi); cos_wide its cosine), without the
// atan2s and the sort: a gap that wide starts at a direction a when no other direction b lies
// within [0, wide] counter-clockwise of a (cross(a, b) >= 0 and a cosine of at least
// cos(wide); of directions that coincide, the last one listed starts the gap). Branch-free
// over the pairs, a few neighbours.
bool gap_wider(const double* points, V3 p, V3 nv, const std::int64_t* idx, std::size_t count,
               std::size_t n, double wide, double cos_wide) {
    constexpr std::size_t kFew = 32;
    if (count > kFew) {
        std::vector<double> angle;
        return widest_gap(points, p, nv, idx, count, n, angle, nullptr) > wide;
    }
    double x[kFew], y[kFew], len[kFew];
    const V3 u = tangent(nv), v = cross(nv, u);
    for (std::size_t j = 0; j < count; ++j) {
        const V3 d = at(points, checked(idx[j], n)) - p;
        x[j] = dot(d, u), y[j] = dot(d, v);
        len[j] = std::sqrt(x[j] * x[j] + y[j] * y[j]);
        // A neighbour on the point itself has no direction: the angles decide as before.
        if (!(len[j] > 0)) {
            std::vector<double> angle;
            return widest_gap(points, p, nv, idx, count, n, angle, nullptr) > wide;
        }
    }
    for (std::size_t a = 0; a < count; ++a) {
        bool closed = false;
        for (std::size_t b = 0; b < count; ++b) {
            const double c = x[a] * y[b] - y[a] * x[b], d = x[a] * x[b] + y[a] * y[b];
            const bool ahead = (c > 0) | ((c == 0) & (b > a));
            closed |= ahead & (d >= cos_wide * len[a] * len[b]);
        }
        if (!closed) return true;
    }
    return false;
}

// What clips a point: the distance in its plane to the line (inf: none; negative at a rim),
// the unit direction toward it, the clipping plane (normal, offset), and whether that plane
// is a rim's (its normal points out of the scan, not out of a surface).
struct Clip {
    std::vector<double> c, w, pn, pd;
    std::vector<unsigned char> rim;
    explicit Clip(std::size_t n)
        : c(n, kInf), w(3 * n, 0.0), pn(3 * n, 0.0), pd(n, 0.0), rim(n, 0) {}
};

// How far (x r) a splat may reach past the line where the plane of normal pm cuts it, w the
// direction toward that line: less past a convex crease, where the normals are oriented (see
// SplatFrameOptions::convex_slack).
double slack(const SplatFrameOptions& o, bool rim_plane, V3 pm, V3 w) {
    const bool convex = o.convex_slack >= 0 && !rim_plane && dot(pm, w) > 0;
    return convex ? o.convex_slack : o.edge_slack;
}

struct Inputs {
    const double *p, *nrm, *r;
    std::size_t n;
    const std::int64_t* nb;  // point i's neighbours: nb[i * stride + j], j < k
    std::size_t k, stride;
};

// The nearest line where a neighbour on another surface cuts the point's plane (the
// reference's _crease_lines), when some neighbour is on another surface.
void crease_line(const Inputs& in, const SplatFrameOptions& o, std::size_t i, Clip& clip) {
    const V3 p = at(in.p, i), nv = at(in.nrm, i);
    const std::int64_t* row = in.nb + i * in.stride;
    bool any = false;
    V3 centroid, all;
    double same = 0.0;
    for (std::size_t j = 0; j < in.k; ++j) {
        const std::size_t q = checked(row[j], in.n);
        all = all + (at(in.p, q) - p);
        if (std::fabs(dot(nv, at(in.nrm, q))) < o.edge_cos) {
            any = true;
        } else {
            centroid = centroid + (at(in.p, q) - p);
            same += 1.0;
        }
    }
    if (!any) return;
    // No neighbour on the point's own surface (a corner whose normal is its faces' mean):
    // it keeps the side where its neighbours are.
    centroid = same > 0 ? (1.0 / same) * centroid : (1.0 / double(in.k)) * all;
    double best = kInf, best_side = 0.0, best_cos = 0.0, best_t = 1.0;
    std::size_t jbest = 0;
    for (std::size_t j = 0; j < in.k; ++j) {
        const std::size_t q = std::size_t(row[j]);
        const V3 m = at(in.nrm, q), off = at(in.p, q) - p;
        const double cs = dot(nv, m), h = -dot(m, off), near = norm(off);
        const bool other = std::fabs(cs) < o.edge_cos;
        const bool on_plane = std::fabs(h) <= o.on_plane * near;
        const double side = on_plane ? o.on_plane * near * sign(dot(m, centroid)) : h;
        const double t_len = std::sqrt(std::max(1.0 - cs * cs, 1e-12));
        const double c = (other && side != 0) ? (on_plane ? 0.0 : std::fabs(h)) / t_len : kInf;
        if (j == 0 || c < best) {
            best = c, best_side = side, best_cos = cs, best_t = t_len, jbest = j;
        }
    }
    const std::size_t q = std::size_t(row[jbest]);
    const V3 m = at(in.nrm, q);
    clip.c[i] = best;
    put(clip.w.data(), i, (-sign(best_side) / best_t) * (m - best_cos * nv));
    put(clip.pn.data(), i, m);
    clip.pd[i] = dot(m, at(in.p, q));
}

// The nearest line where a clipped neighbour's plane (from `from`) cuts the point's plane
// (the reference's _neighbours_planes); replaces the point's own line in `to` when nearer.
void neighbours_planes(const Inputs& in, const SplatFrameOptions& o, std::size_t i,
                       const Clip& from, Clip& to) {
    const V3 p = at(in.p, i), nv = at(in.nrm, i);
    const std::int64_t* row = in.nb + i * in.stride;
    double best = kInf, best_h = 0.0, best_cos = 0.0, best_t = 1.0;
    std::size_t jbest = 0;
    bool any = false;
    for (std::size_t j = 0; j < in.k; ++j) {
        const std::size_t q = std::size_t(row[j]);
        const bool has = std::isfinite(from.c[q]);
        any |= has;
        const V3 pm = at(from.pn.data(), q);
        const double cs = dot(nv, pm), h = dot(pm, p) - from.pd[q];
        const double t_len = std::sqrt(std::max(1.0 - cs * cs, 1e-12));
        const double near = norm(at(in.p, q) - p);
        const bool usable = has && std::fabs(cs) < o.edge_cos && std::fabs(h) > o.on_plane * near;
        const double c = usable ? std::fabs(h) / t_len : kInf;
        if (j == 0 || c < best) best = c, best_h = h, best_cos = cs, best_t = t_len, jbest = j;
    }
    if (!any || !(best < from.c[i])) return;
    const std::size_t q = std::size_t(row[jbest]);
    const V3 pm = at(from.pn.data(), q);
    to.c[i] = best;
    put(to.w.data(), i, (-sign(best_h) / best_t) * (pm - best_cos * nv));
    put(to.pn.data(), i, pm);
    to.pd[i] = from.pd[q];
    to.rim[i] = from.rim[q];
}

// The ellipse of one point: its axis, semi-axes and offset, shrunk where a second line cuts
// (the reference's splat_frames tail and _second_lines).
void ellipse(const Inputs& in, const SplatFrameOptions& o, std::size_t i, const Clip& clip,
             bool on_crease, double* frame) {
    const V3 p = at(in.p, i), nv = at(in.nrm, i);
    const double r = in.r[i];
    const double reach =
        clip.c[i] + slack(o, clip.rim[i], at(clip.pn.data(), i), at(clip.w.data(), i)) * r;
    bool clipped = reach < r;
    double a = r, b = clipped ? 0.5 * (r + reach) : r;
    const V3 w = clipped ? at(clip.w.data(), i) : V3{};
    V3 offset = (clipped ? -0.5 * (r - reach) : 0.0) * w;
    V3 axis = clipped ? cross(w, nv) : tangent(nv);
    axis = (1.0 / std::max(norm(axis), 1e-300)) * axis;
    if (clipped) {
        const std::int64_t* row = in.nb + i * in.stride;
        V3 inward, all;
        double own = 0.0;
        for (std::size_t j = 0; j < in.k; ++j) {
            const std::size_t q = std::size_t(row[j]);
            all = all + (at(in.p, q) - p);
            if (std::fabs(dot(nv, at(in.nrm, q))) >= o.edge_cos) {
                inward = inward + (at(in.p, q) - p);
                own += 1.0;
            }
        }
        inward = own > 0 ? (1.0 / own) * inward : (1.0 / double(in.k)) * all;
        const V3 bx = cross(nv, axis);
        const bool cut = w.x != 0 || w.y != 0 || w.z != 0;
        double shrink = kInf;
        // The clipping planes of the point and its neighbours (j <= k), then the neighbours'
        // own tangent planes (j > k): near a corner of three faces the third face's plane
        // may clip none of the neighbours, yet the ellipse reaches over it.
        for (std::size_t j = 0; j <= 2 * in.k; ++j) {
            const bool own_plane = j > in.k;
            const std::size_t q = j == 0 ? i : std::size_t(row[(own_plane ? j - in.k : j) - 1]);
            const V3 pm = own_plane ? at(in.nrm, q) : at(clip.pn.data(), q);
            const double pd = own_plane ? dot(pm, at(in.p, q)) : clip.pd[q];
            const bool has = own_plane || std::isfinite(clip.c[q]);
            const bool rim_plane = !own_plane && clip.rim[q];
            const double cs = dot(nv, pm), h = dot(pm, p) - pd;
            const double t_len = std::sqrt(std::max(1.0 - cs * cs, 1e-12));
            const double near = j == 0 ? 0.0 : norm(at(in.p, q) - p);
            const bool off = std::fabs(h) > o.on_plane * near;
            const double side = off ? sign(h) : -sign(dot(pm, inward));
            bool usable = has && std::fabs(cs) < o.edge_cos && side != 0;
            const double dist = (off ? std::fabs(h) : 0.0) / t_len;
            const V3 wl = (-side / t_len) * (pm - cs * nv);
            const double along = a * dot(axis, wl), across = b * dot(bx, wl);
            const double support = dot(offset, wl) + std::sqrt(along * along + across * across);
            usable = usable && (cut ? std::fabs(dot(w, wl)) < o.parallel_cos : off);
            const double limit = dist + slack(o, rim_plane, pm, wl) * r;
            shrink = std::min(shrink, usable && support > limit ? limit / std::max(support, 1e-300) : 1.0);
        }
        a *= shrink, b *= shrink;
        offset = shrink * offset;
        clipped = clipped || shrink < 1;
    }
    if (on_crease) {
        // Its own surface's side of the crease only (w points away from it), edge_slack x r
        // past the line: the other face's points cover theirs, and a strip across the line
        // would stand out of the other face with this face's light.
        b = 0.5 * (o.crease_width + o.edge_slack) * r;
        offset = (-0.5 * (o.crease_width - o.edge_slack) * r) * at(clip.w.data(), i);
    }
    const double row[10] = {axis.x, axis.y, axis.z, a, b, a, offset.x, offset.y, offset.z,
                            double(clipped || on_crease)};
    std::copy(row, row + 10, frame);
}

// values (rows of `width`) in `order`: row t is values' row order[t] (none without values).
std::vector<double> reordered(Context& ctx, const double* values, std::size_t width,
                              const std::vector<std::int64_t>& order) {
    if (!values) return {};
    std::vector<double> out(width * order.size());
    parallel_for(ctx, order.size(), 65536, [&](std::size_t b, std::size_t e) {
        for (std::size_t t = b; t < e; ++t)
            std::copy(values + width * order[t], values + width * (order[t] + 1),
                      out.data() + width * t);
    });
    return out;
}

// The rim test of the candidates (points whose k nearest leave a gap wider than rim_gap):
// among their rim_neighbours nearest (from `tree`, renumbered by `rank`), the gap is still that
// wide and their centroid lies rim_shift x the farthest one's distance off the point. Marks
// rim0 and the unit direction out of the scan (facing, n x 3).
void rim_test(Context& ctx, const KdTree& tree, const std::int64_t* rank, const double* points,
              const double* normals, std::size_t n, const std::vector<unsigned char>& candidate,
              const SplatFrameOptions& o, std::vector<unsigned char>& rim0,
              std::vector<double>& facing) {
    const std::size_t kw = std::min<std::size_t>(o.rim_neighbours, n - 1);
    std::vector<std::size_t> cand;
    for (std::size_t i = 0; i < n; ++i)
        if (candidate[i]) cand.push_back(i);
    ctx.set_phase("splats", 0.55, 0.15);
    parallel_for(ctx, cand.size(), 512, [&](std::size_t b, std::size_t e) {
        KdTree::Best best(kw + 1);
        std::vector<std::int64_t> row(kw);
        std::vector<double> angle;
        for (std::size_t c = b; c < e; ++c) {
            const std::size_t i = cand[c];
            tree.nearest(points + 3 * i, best);
            for (std::size_t j = 0; j < kw; ++j) row[j] = rank[best.h[j + 1].second];
            const double far = std::sqrt(best.h[kw].first);
            const V3 p = at(points, i), nv = at(normals, i);
            V3 centroid;
            for (std::size_t j = 0; j < kw; ++j) centroid = centroid + (at(points, std::size_t(row[j])) - p);
            centroid = (1.0 / double(kw)) * centroid;
            centroid = centroid - dot(centroid, nv) * nv;
            V3 out;
            const double gap = widest_gap(points, p, nv, row.data(), kw, n, angle, &out);
            if (norm(centroid) > o.rim_shift * far && gap > o.rim_gap) {
                rim0[i] = 1;
                put(facing.data(), i, out);
            }
        }
    });
}

}  // namespace

void splat_frames(Context& ctx, const double* points_in, std::size_t n, const double* normals_in,
                  const double* radii_in, std::size_t k, const PlaneFitOptions& fit,
                  const SplatFrameOptions& o, double* frames, std::int64_t* order_out,
                  std::int64_t* neighbours) {
    if (k < 2 || k + 1 > n) throw std::invalid_argument("splat_frames needs 2 <= k < n");
    const std::size_t k1 = k + 1;
    ctx.set_phase("splats", 0.0, 0.1);
    checkpoint(ctx, 0.0);
    // One tree for both searches (the k nearest of every point, the rim candidates' wider
    // one). The passes work on copies in the tree's order (point t is the input's order[t],
    // neighbours renumbered): neighbouring points are close in memory there, where a scan's
    // own order would make every neighbour a cache miss. The neighbours themselves, and so
    // every result, are those of the input's order.
    const KdTree tree(ctx, points_in, n);
    const std::vector<std::int64_t>& order = tree.order();
    std::vector<std::int64_t> rank(n);
    parallel_for(ctx, n, 65536, [&](std::size_t b, std::size_t e) {
        for (std::size_t t = b; t < e; ++t) rank[std::size_t(order[t])] = std::int64_t(t);
    });
    const std::vector<double> sorted_normals = reordered(ctx, normals_in, 3, order),
                              sorted_radii = reordered(ctx, radii_in, 1, order);
    const double* points = tree.sorted_points().data();
    const double* given_radii = radii_in ? sorted_radii.data() : nullptr;
    auto each = [&](double base, double span, auto&& fn) {
        ctx.set_phase("splats", base, span);
        parallel_for(ctx, n, 2048, [&](std::size_t b, std::size_t e) {
            for (std::size_t i = b; i < e; ++i) fn(i);
        });
    };
    std::vector<std::int64_t> nearest_(n * k1);
    std::vector<double> far(n);
    ctx.set_phase("splats", 0.1, 0.2);
    parallel_for(ctx, n, 2048, [&](std::size_t b, std::size_t e) {
        KdTree::Best best(k1);
        for (std::size_t i = b; i < e; ++i) {
            tree.nearest(points + 3 * i, best);
            for (std::size_t j = 0; j < k1; ++j) nearest_[i * k1 + j] = rank[best.h[j].second];
            far[i] = std::sqrt(best.h[k].first);
        }
    });
    const std::int64_t* nearest = nearest_.data();
    std::vector<double> fitted;
    const double* normals = normals_in ? sorted_normals.data() : nullptr;
    if (!normals) {
        fitted.resize(3 * n);
        ctx.set_phase("splats", 0.3, 0.15);
        plane_normals(ctx, points, n, nearest, k1, fit, fitted.data());
        normals = fitted.data();
    }
    // Pass 1: the radii; the rim candidates (a gap wider than rim_gap among the k nearest).
    std::vector<double> radii(n);
    std::vector<unsigned char> candidate(n, 0);
    const double cos_rim_gap = std::cos(o.rim_gap);
    each(0.45, 0.1, [&](std::size_t i) {
        const std::int64_t* row = nearest + i * k1;
        double r;
        if (given_radii) {
            r = given_radii[i];
        } else {
            double sum = 0.0;
            for (std::size_t j = 0; j < k1; ++j) sum += far[row[j]];
            r = o.cover * (sum / double(k1));
        }
        radii[i] = r > 0 ? r : std::max(far[i], 1e-6);
        candidate[i] = gap_wider(points, at(points, i), at(normals, i), row + 1, k, n, o.rim_gap,
                                 cos_rim_gap);
    });
    const Inputs in{points, normals, radii.data(), n, nearest + 1, k, k1};
    // Pass 2: the candidates' wide test (rim, and the direction out of the scan); creases.
    Clip clip(n);
    std::vector<unsigned char> rim0(n, 0);
    std::vector<double> facing(3 * n, 0.0);
    rim_test(ctx, tree, rank.data(), points, normals, n, candidate, o, rim0, facing);
    each(0.7, 0.07, [&](std::size_t i) { crease_line(in, o, i, clip); });
    std::vector<unsigned char> on_crease(n, 0);
    // Pass 3: a rim point needs a rim neighbour facing the same way; then its line clips it
    // (its own rows of clip only: no other point reads them in this pass).
    each(0.77, 0.03, [&](std::size_t i) {
        on_crease[i] = o.crease_strips && clip.c[i] == 0.0;
        if (!rim0[i]) return;
        const V3 f = at(facing.data(), i);
        bool along = false;
        for (std::size_t j = 0; j < k && !along; ++j) {
            const std::size_t q = std::size_t(in.nb[i * k1 + j]);
            along = rim0[q] && dot(f, at(facing.data(), q)) > o.rim_along;
        }
        if (!(along && o.rim_reach * radii[i] < clip.c[i])) return;
        const double c = (o.rim_reach - o.edge_slack) * radii[i];
        clip.c[i] = c;
        put(clip.w.data(), i, f);
        put(clip.pn.data(), i, f);
        clip.pd[i] = dot(f, at(points, i) + c * f);
        clip.rim[i] = 1;
    });
    // Pass 4: the planes that clipped the neighbours clip the point too.
    for (int round = 0; round < o.propagate; ++round) {
        Clip next(n);
        each(0.8, 0.08, [&](std::size_t i) {
            next.c[i] = clip.c[i], next.pd[i] = clip.pd[i], next.rim[i] = clip.rim[i];
            put(next.w.data(), i, at(clip.w.data(), i));
            put(next.pn.data(), i, at(clip.pn.data(), i));
            neighbours_planes(in, o, i, clip, next);
        });
        clip = std::move(next);
    }
    // Pass 5: the ellipses.
    each(0.88, 0.12, [&](std::size_t i) {
        double* frame = frames + 13 * std::size_t(order[i]);
        std::copy(normals + 3 * i, normals + 3 * i + 3, frame);
        ellipse(in, o, i, clip, on_crease[i], frame + 3);
        if (order_out) order_out[i] = order[i];
        if (neighbours) std::copy(in.nb + i * k1, in.nb + i * k1 + k, neighbours + k * i);
    });
}

}  // namespace illumap
