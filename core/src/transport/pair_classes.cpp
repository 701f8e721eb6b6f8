// pair_classes.cpp — the kernel's class of a node pair (traversal.hpp): facing certificates
// (cone and slab bounds, a leaf's own points), point-node classes and the acceptance criterion.
#include "transport/traversal.hpp"

#include <algorithm>
#include <cmath>

namespace illumap {

namespace {
// Relative round-off allowed in the facing bounds.
constexpr double kRoundOff = 1e-12;
}  // namespace

Facing facing_bound(const OctreeNode& o, const OctreeNode& q) {
    // D = c_q - c_o; r_j - r_i = D + u_j - v_i with |u_j| <= rho_q, |v_i| <= rho_o.
    const double D[3] = {q.center[0] - o.center[0], q.center[1] - o.center[1],
                         q.center[2] - o.center[2]};
    const double dist = std::sqrt(D[0] * D[0] + D[1] * D[1] + D[2] * D[2]);
    const double reach = dist + o.radius + q.radius;  // bound on |r_j - r_i|
    const double tol = kRoundOff * reach;             // round-off in the bounds below
    const double* a = o.axis;
    const double aD = a[0] * D[0] + a[1] * D[1] + a[2] * D[2];

    // Slab test: n_i = a + (n_i - a), |n_i - a| <= chord_o.
    //   a.(r_j - r_i) = a.D + a.u_j - a.v_i; a.v_i in o's own slab; a.u_j in q's slab along
    //   its own axis widened by |a - a_q| rho_q (and never beyond +-rho_q).
    const double dax = a[0] - q.axis[0], day = a[1] - q.axis[1], daz = a[2] - q.axis[2];
    const double widen = std::sqrt(dax * dax + day * day + daz * daz) * q.radius;
    // ... and within q's box: support function of the box along a.
    const double boxq = std::fabs(a[0]) * q.half[0] + std::fabs(a[1]) * q.half[1] +
                        std::fabs(a[2]) * q.half[2];
    const double qlo = std::max({-q.radius, -boxq, q.slab_lo - widen});
    const double qhi = std::min({q.radius, boxq, q.slab_hi + widen});
    const double err = o.cone_chord * reach;
    const double hi = aD + qhi - o.slab_lo + err;
    const double lo = aD + qlo - o.slab_hi - err;
    Facing f{lo >= -tol, hi <= tol};

    // Cone test: every direction r_j - r_i lies within beta of D, every n_i within alpha of a.
    const double sep = o.radius + q.radius;
    if (dist > sep && o.cone_angle < kPi) {
        const double beta = std::asin(sep / dist);
        const double gamma = std::acos(std::clamp(aD / dist, -1.0, 1.0));
        if (gamma + o.cone_angle + beta < 0.5 * kPi) f.all_pos = true;
        if (gamma - o.cone_angle - beta > 0.5 * kPi) f.none_pos = true;
    }
    return f;
}

Facing facing_points(const SurfelSoA& s, const OctreeNode& o, const OctreeNode& q) {
    Facing f{true, true};
    for (std::uint32_t i = o.begin; i < o.end && (f.all_pos || f.none_pos); ++i) {
        const double n[3] = {s.nx[i], s.ny[i], s.nz[i]};
        const double D[3] = {q.center[0] - s.px[i], q.center[1] - s.py[i], q.center[2] - s.pz[i]};
        const double g = n[0] * D[0] + n[1] * D[1] + n[2] * D[2];
        // n.(r_j - c_q) is within the support of q's box (and of its sphere)
        const double sup = std::min(q.radius, std::fabs(n[0]) * q.half[0] +
                                                  std::fabs(n[1]) * q.half[1] +
                                                  std::fabs(n[2]) * q.half[2]);
        const double tol = kRoundOff * (std::sqrt(D[0] * D[0] + D[1] * D[1] + D[2] * D[2]) + q.radius);
        if (g - sup < -tol) f.all_pos = false;
        if (g + sup > tol) f.none_pos = false;
    }
    return f;
}

namespace {
// Node bounds first; a leaf's own points when they do not settle it.
Facing facing(const SurfelSoA& s, const OctreeNode& o, const OctreeNode& q) {
    Facing f = facing_bound(o, q);
    if (!f.all_pos && !f.none_pos && o.leaf()) f = facing_points(s, o, q);
    return f;
}
}  // namespace

int point_node_class(const SurfelSoA& s, std::uint32_t i, const OctreeNode& q) {
    OctreeNode p;  // the surfel as a node of one point
    p.begin = i;
    p.end = i + 1;
    p.center[0] = s.px[i]; p.center[1] = s.py[i]; p.center[2] = s.pz[i];
    p.axis[0] = s.nx[i]; p.axis[1] = s.ny[i]; p.axis[2] = s.nz[i];
    p.amax = s.area[i];
    const Facing a = facing(s, p, q);  // its normal against q's points
    if (a.none_pos) return 0;
    const Facing b = facing(s, q, p);  // q's normals against it
    if (b.none_pos) return 0;
    return (a.all_pos && b.all_pos) ? 1 : -1;
}

namespace {
// Every point of o is decided (all or nothing) against q.
bool points_decided(const SurfelSoA& s, const OctreeNode& o, const OctreeNode& q) {
    for (std::uint32_t i = o.begin; i < o.end; ++i)
        if (point_node_class(s, i, q) < 0) return false;
    return true;
}
}  // namespace

bool mac_holds(const OctreeNode& t, const OctreeNode& s, double theta) {
    const double R[3] = {t.center[0] - s.center[0], t.center[1] - s.center[1],
                         t.center[2] - s.center[2]};
    const double dist = std::sqrt(R[0] * R[0] + R[1] * R[1] + R[2] * R[2]);
    const double sep = t.radius + s.radius;
    const double rmin = dist - sep;
    // Strongly coupled pairs (π r² ≤ 2 t0 Ā somewhere in them) are summed directly: their
    // large terms would otherwise carry the expansion's relative error.
    const bool well_separated =
        rmin > 0 && kPi * rmin * rmin > 2.0 * kT0 * 0.5 * (t.amax + s.amax);
    return sep < theta * dist && well_separated;
}

PairClass classify(const SurfelSoA& surf, const OctreeNode& t, const OctreeNode& s,
                   const TraversalOptions& opt) {
    const Facing rt = facing(surf, t, s);  // receivers in t facing sources in s
    if (rt.none_pos) return PairClass::Drop;
    const Facing rs = facing(surf, s, t);  // sources in s facing receivers in t
    if (rs.none_pos) return PairClass::Drop;
    if (mac_holds(t, s, opt.theta)) {
        if (rt.all_pos && rs.all_pos) return PairClass::Accept;
        // Mixed facing. If only the receivers' test is mixed, the source straddles the
        // target's tangent plane: refine the source down to leaves and hand each of their
        // points to the (large) target by P2L. Mirror case: refine the target, then M2P.
        // (Refining the other side would never resolve it and would end in P2P against
        // every leaf of that side.) For two leaves, P2P is cheaper than per-point expansions.
        if (!rt.all_pos && rs.all_pos) {
            if (!s.leaf()) return PairClass::SplitS;
            if (!t.leaf() && points_decided(surf, s, t)) return PairClass::P2L;
        } else if (rt.all_pos && !rs.all_pos) {
            if (!t.leaf()) return PairClass::SplitT;
            if (!s.leaf() && points_decided(surf, t, s)) return PairClass::M2P;
        } else {
            if (t.leaf() && !s.leaf() && points_decided(surf, t, s)) return PairClass::M2P;
            if (s.leaf() && !t.leaf() && points_decided(surf, s, t)) return PairClass::P2L;
        }
    }
    if (t.leaf() && s.leaf()) return PairClass::Near;
    return PairClass::Split;
}

}  // namespace illumap
