// near_field.cpp — exact point-to-polygon form factors for close pairs, as a sparse correction.
#include "transport/near_field.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace illumap {

namespace {

inline double dot(const double a[3], const double b[3]) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline void cross(const double a[3], const double b[3], double c[3]) {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

// An orthonormal tangent basis (u, v) for the unit normal m, chosen deterministically.
void tangent_basis(const double m[3], double u[3], double v[3]) {
    const double ax = std::fabs(m[0]), ay = std::fabs(m[1]), az = std::fabs(m[2]);
    const double e[3] = {ax <= ay && ax <= az ? 1.0 : 0.0,
                         ay < ax && ay <= az ? 1.0 : 0.0,
                         az < ax && az < ay ? 1.0 : 0.0};
    cross(m, e, u);
    const double lu = std::sqrt(dot(u, u));
    for (int k = 0; k < 3; ++k) u[k] /= lu;
    cross(m, u, v);
}

// Smooth blend weight of the polygon rule: 1 up to t0, 0 beyond 2 t0.
inline double polygon_weight(double t) {
    return t <= kT0 ? 1.0 : (t >= 2.0 * kT0 ? 0.0 : 2.0 - t / kT0);
}

// Surfels within kCoplanarCos of coplanar (kernel.hpp): their octagons overlap each other's
// centres, and the exact polygon rule would see almost a whole hemisphere.

struct CellKey {
    std::int64_t x, y, z;
    bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellHash {
    std::size_t operator()(const CellKey& k) const {
        std::uint64_t h = std::uint64_t(k.x) * 0x9E3779B97F4A7C15ull;
        h ^= std::uint64_t(k.y) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
        h ^= std::uint64_t(k.z) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
        return std::size_t(h);
    }
};

}  // namespace

double point_to_polygon(const double x[3], const double n[3], const double c[3],
                        const double m[3], double area) {
    // Receiver behind (or in) the source's plane sees nothing of its front side.
    const double xc[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]};
    if (dot(m, xc) <= 0.0) return 0.0;

    double u[3], v[3];
    tangent_basis(m, u, v);
    constexpr int K = kPolygonSides;
    const double circumradius = std::sqrt(2.0 * area / (K * std::sin(2.0 * kPi / K)));

    // Vertices relative to x, clipped to the receiver's front half-space (Sutherland–Hodgman).
    double poly[K][3];
    double height[K];
    for (int k = 0; k < K; ++k) {
        const double a = 2.0 * kPi * k / K;
        const double cu = circumradius * std::cos(a), sv = circumradius * std::sin(a);
        for (int q = 0; q < 3; ++q) poly[k][q] = c[q] + cu * u[q] + sv * v[q] - x[q];
        height[k] = dot(n, poly[k]);
    }
    double clipped[2 * K][3];
    int nc = 0;
    for (int k = 0; k < K; ++k) {
        const int k1 = (k + 1) % K;
        const double h0 = height[k], h1 = height[k1];
        if (h0 > 0.0) {
            for (int q = 0; q < 3; ++q) clipped[nc][q] = poly[k][q];
            ++nc;
        }
        if ((h0 > 0.0) != (h1 > 0.0)) {
            const double s = h0 / (h0 - h1);
            for (int q = 0; q < 3; ++q) clipped[nc][q] = poly[k][q] + s * (poly[k1][q] - poly[k][q]);
            ++nc;
        }
    }
    if (nc < 3) return 0.0;

    // Lambert: F = (1/2π) Σ_k angle(v_k, v_k+1) · n·(v_k × v_k+1)/|v_k × v_k+1|.
    double sum = 0.0;
    for (int k = 0; k < nc; ++k) {
        const double* a = clipped[k];
        const double* b = clipped[(k + 1) % nc];
        double w[3];
        cross(a, b, w);
        const double lw = std::sqrt(dot(w, w));
        if (lw <= 0.0) continue;
        sum += std::atan2(lw, dot(a, b)) * dot(n, w) / lw;
    }
    return std::min(1.0, std::fabs(sum) / (2.0 * kPi));
}

double disc_to_polygon(const double x[3], const double n[3], double receiver_area,
                       const double c[3], const double m[3], double area) {
    // A 7-point rule on the disc (exact for polynomials of degree 5): the centre, weight 1/4,
    // and six points at sqrt(2/3) of the radius, weight 1/8 each.
    double u[3], v[3];
    tangent_basis(n, u, v);
    const double r = std::sqrt(receiver_area / kPi) * std::sqrt(2.0 / 3.0);
    double sum = 0.25 * point_to_polygon(x, n, c, m, area);
    for (int k = 0; k < 6; ++k) {
        const double a = kPi * k / 3.0;
        const double cu = r * std::cos(a), sv = r * std::sin(a);
        const double p[3] = {x[0] + cu * u[0] + sv * v[0], x[1] + cu * u[1] + sv * v[1],
                             x[2] + cu * u[2] + sv * v[2]};
        sum += 0.125 * point_to_polygon(p, n, c, m, area);
    }
    return sum;
}

bool facing_plates(const double d[3], const double ni[3], const double nj[3], double area_i,
                   double area_j) {
    // d = x_i − x_j. Each centre lies within half the other's radius of its plane (a thin gap).
    if (dot(ni, nj) > kPlateCos) return false;
    const double hj = -dot(ni, d), hi = dot(nj, d);
    return hj > 0.0 && hi > 0.0 && 4.0 * hj * hj * kPi < area_i && 4.0 * hi * hi * kPi < area_j;
}

void NearCorrection::apply_add(Context& ctx, const double* x, double* y) const {
    const std::size_t n = offsets.empty() ? 0 : offsets.size() - 1;
    parallel_for(ctx, n, 4096, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
            double a0 = 0, a1 = 0, a2 = 0;
            for (std::int64_t p = offsets[i]; p < offsets[i + 1]; ++p) {
                const double c = values[p];
                const double* xj = x + 3 * columns[p];
                a0 += c * xj[0];
                a1 += c * xj[1];
                a2 += c * xj[2];
            }
            y[3 * i] += a0;
            y[3 * i + 1] += a1;
            y[3 * i + 2] += a2;
        }
    });
}

void NearCorrection::apply_rows_add(const double* x, const std::int64_t* rows, std::size_t nrows,
                                    double* y) const {
    for (std::size_t r = 0; r < nrows; ++r) {
        const std::size_t i = std::size_t(rows[r]);
        for (std::int64_t p = offsets[i]; p < offsets[i + 1]; ++p) {
            const double c = values[p];
            const double* xj = x + 3 * columns[p];
            for (int q = 0; q < 3; ++q) y[3 * r + q] += c * xj[q];
        }
    }
}

std::size_t NearCorrection::bytes() const {
    return offsets.capacity() * sizeof(std::int64_t) + columns.capacity() * sizeof(std::int64_t) +
           (values.capacity() + full.capacity()) * sizeof(double);
}

std::size_t NearCorrection::limit_close_sums() {
    const std::size_t n = offsets.empty() ? 0 : offsets.size() - 1;
    std::vector<double> gamma(n, 1.0);
    std::size_t limited = 0;
    for (std::size_t i = 0; i < n; ++i) {
        double close = 0.0;
        for (std::int64_t p = offsets[i]; p < offsets[i + 1]; ++p) close += full[p];
        if (close > 1.0) {
            gamma[i] = 1.0 / close;
            ++limited;
        }
    }
    if (limited == 0) return 0;
    // min(γ_i, γ_j) keeps A_i F_ij = A_j F_ji, and every row's close part sums to at most 1.
    for (std::size_t i = 0; i < n; ++i)
        for (std::int64_t p = offsets[i]; p < offsets[i + 1]; ++p) {
            const double g = std::min(gamma[i], gamma[std::size_t(columns[p])]);
            values[p] -= (1.0 - g) * full[p];
            full[p] *= g;
        }
    return limited;
}

NearCorrection assemble_correction(std::size_t n, std::vector<std::vector<SparseEntry>>& chunks) {
    NearCorrection out;
    out.offsets.assign(n + 1, 0);
    std::size_t total = 0;
    for (const auto& chunk : chunks) {
        total += chunk.size();
        for (const SparseEntry& t : chunk) ++out.offsets[t.row + 1];
    }
    for (std::size_t i = 0; i < n; ++i) out.offsets[i + 1] += out.offsets[i];
    out.columns.resize(total);
    out.values.resize(total);
    out.full.resize(total);
    std::vector<std::int64_t> fill(out.offsets.begin(), out.offsets.end() - 1);
    for (auto& chunk : chunks) {
        for (const SparseEntry& t : chunk) {
            const std::int64_t p = fill[t.row]++;
            out.columns[p] = t.col;
            out.values[p] = t.value;
            out.full[p] = t.full;
        }
        std::vector<SparseEntry>().swap(chunk);
    }
    return out;
}

// The correction entries of the close pair (i, j), t = π r² / Ā apart, appended to `out`.
static void close_pair(const SurfelSoA& s, std::size_t i, std::uint32_t j, double t,
                       const PairVisibilityFn* vis, const std::uint32_t* scan,
                       std::vector<SparseEntry>& out) {
    const double xi[3] = {s.px[i], s.py[i], s.pz[i]};
    const double ni[3] = {s.nx[i], s.ny[i], s.nz[i]};
    const double Ai = s.area[i], Aj = s.area[j];
    const double d[3] = {xi[0] - s.px[j], xi[1] - s.py[j], xi[2] - s.pz[j]};
    const double r2 = dot(d, d);
    const double xj[3] = {s.px[j], s.py[j], s.pz[j]};
    const double nj[3] = {s.nx[j], s.ny[j], s.nz[j]};
    const double p_ij = pair_factor(d[0], d[1], d[2], ni[0], ni[1], ni[2],
                                   nj[0], nj[1], nj[2], Aj);
    const double p_ji = pair_factor(-d[0], -d[1], -d[2], nj[0], nj[1], nj[2],
                                   ni[0], ni[1], ni[2], Ai);
    // Centres that do not face stay at zero, as in the far field:
    // otherwise octagons overhanging an edge, or tilted neighbours on
    // a convex surface, would let a surface light itself. Coplanar
    // pairs count as not facing even when rounding tilts them by
    // 1e-16 (a box standing on a floor would otherwise flip between
    // seeing a full hemisphere and nothing with the scene's scale).
    // Planes within kContactHeight of each other are in contact.
    const double rr = std::sqrt(r2);
    const double cos_i = -dot(ni, d) / rr, cos_j = dot(nj, d) / rr;
    const double contact = kContactHeight * std::sqrt(std::min(Ai, Aj));
    if (p_ij == 0.0 || cos_i <= kCoplanarCos || cos_j <= kCoplanarCos ||
        std::max(cos_i, cos_j) * rr <= contact)
        return;
    // A scan's surfel and one facing it closer than their size (the scan's
    // base 1.5 mm over a floor): the receiver's centre alone sees the one
    // source overhead and none of the neighbours its rim lies over, and the
    // segment between two centres through the gap meets the scan's own
    // bumpy splats; such a pair passed the light between itself alone and
    // read 0.13 (Cycles 0.85). Averaged over the receiver's disc, unblocked.
    // Not within one scan: a base point's neighbour's back, 0.2 mm lower,
    // would face it as a plate does.
    const bool plates = scan && scan[i] != scan[j] &&
                        facing_plates(d, ni, nj, Ai, Aj);
    const double f_ij = plates ? disc_to_polygon(xi, ni, Ai, xj, nj, Aj)
                               : point_to_polygon(xi, ni, xj, nj, Aj);
    const double f_ji = plates ? disc_to_polygon(xj, nj, Aj, xi, ni, Ai)
                               : point_to_polygon(xj, nj, xi, ni, Ai);
    const double g = 0.5 * (Ai * f_ij + Aj * f_ji);  // symmetric
    const double w = polygon_weight(t);
    double c_ij = w * (g / Ai - p_ij);
    double c_ji = w * (g / Aj - p_ji);
    double vis_ij = 1.0;
    if (vis && !plates && (c_ij != 0.0 || c_ji != 0.0)) {
        vis_ij = (*vis)(std::uint32_t(i), j);
        c_ij *= vis_ij;
        c_ji *= vis_ij;
    }
    const double v = vis_ij;
    if (c_ij != 0.0)
        out.push_back({std::int64_t(i), std::int64_t(j), c_ij, v * p_ij + c_ij});
    if (c_ji != 0.0)
        out.push_back({std::int64_t(j), std::int64_t(i), c_ji, v * p_ji + c_ji});
}

NearCorrection build_near_correction(Context& ctx, const SurfelSoA& s,
                                     const PairVisibilityFn* vis, const std::uint32_t* scan) {
    const std::size_t n = s.n;
    if (n < 2) {
        std::vector<std::vector<SparseEntry>> none;
        return assemble_correction(n, none);
    }

    // A pair is close when π r² ≤ 2 t0 Ā ≤ 2 t0 max(A_i, A_j): it is found from the side with
    // the larger area, within that surfel's own search radius.
    std::vector<double> reach(n);
    for (std::size_t i = 0; i < n; ++i) reach[i] = std::sqrt(2.0 * kT0 * s.area[i] / kPi);
    std::vector<double> sorted(reach);
    std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.end());
    const double cell = std::max(sorted[n / 2], 1e-300);
    double lo[3] = {s.px[0], s.py[0], s.pz[0]};
    for (std::size_t i = 1; i < n; ++i) {
        lo[0] = std::min(lo[0], s.px[i]);
        lo[1] = std::min(lo[1], s.py[i]);
        lo[2] = std::min(lo[2], s.pz[i]);
    }
    // Cell coordinates are clamped to ±2^40 cells (a cloud of any use spans far fewer median
    // reaches), so that no search box, however wide, overflows them; the pair test below
    // still measures every distance.
    constexpr double kMaxCell = 1099511627776.0;  // 2^40
    auto coord = [&](double v, double origin) {
        const double c = std::floor((v - origin) / cell);
        return std::int64_t(std::max(-kMaxCell, std::min(kMaxCell, c)));
    };
    auto key_of = [&](double x, double y, double z) {
        return CellKey{coord(x, lo[0]), coord(y, lo[1]), coord(z, lo[2])};
    };
    std::unordered_map<CellKey, std::vector<std::uint32_t>, CellHash> grid;
    grid.reserve(n);
    for (std::size_t i = 0; i < n; ++i) grid[key_of(s.px[i], s.py[i], s.pz[i])].push_back(std::uint32_t(i));
    // The occupied cells, for a search box with more cells than there are occupied ones (a
    // surfel far larger than the median, such as a scan's stray point whose disc was
    // estimated from neighbours kilometres away): its box is then searched by visiting these
    // instead of every cell of the box, so the work per surfel is bounded by the cloud's size.
    std::vector<const std::pair<const CellKey, std::vector<std::uint32_t>>*> occupied;
    occupied.reserve(grid.size());
    for (const auto& entry : grid) occupied.push_back(&entry);

    const std::size_t grain = 2048;
    const std::size_t nchunks = (n + grain - 1) / grain;
    std::vector<std::vector<SparseEntry>> found(nchunks);
    std::vector<std::size_t> examined(nchunks, 0);
    parallel_for(ctx, n, grain, [&](std::size_t b, std::size_t e) {
        auto& mine = found[b / grain];
        std::size_t count = 0;
        for (std::size_t i = b; i < e; ++i) {
            const double xi[3] = {s.px[i], s.py[i], s.pz[i]};
            const double Ai = s.area[i];
            const double R = reach[i];
            const CellKey k0 = key_of(xi[0] - R, xi[1] - R, xi[2] - R);
            const CellKey k1 = key_of(xi[0] + R, xi[1] + R, xi[2] + R);
            const double box_cells = double(k1.x - k0.x + 1) * double(k1.y - k0.y + 1) *
                                     double(k1.z - k0.z + 1);
            const bool scan_occupied = box_cells > double(occupied.size());
            auto inside = [&](const CellKey& c) {
                return c.x >= k0.x && c.x <= k1.x && c.y >= k0.y && c.y <= k1.y &&
                       c.z >= k0.z && c.z <= k1.z;
            };
            // One visit per cell: the box's cells in order, or the occupied cells in the box.
            const std::int64_t visits = scan_occupied
                ? std::int64_t(occupied.size())
                : (k1.x - k0.x + 1) * (k1.y - k0.y + 1) * (k1.z - k0.z + 1);
            for (std::int64_t visit = 0; visit < visits; ++visit) {
                const std::vector<std::uint32_t>* members = nullptr;
                if (scan_occupied) {
                    if (!inside(occupied[std::size_t(visit)]->first)) continue;
                    members = &occupied[std::size_t(visit)]->second;
                } else {
                    const std::int64_t ny = k1.y - k0.y + 1, nz = k1.z - k0.z + 1;
                    const CellKey c{k0.x + visit / (ny * nz), k0.y + (visit / nz) % ny,
                                    k0.z + visit % nz};
                    auto it = grid.find(c);
                    if (it == grid.end()) continue;
                    members = &it->second;
                }
                for (std::uint32_t j : *members) {
                    const double Aj = s.area[j];
                    if (Aj > Ai || (Aj == Ai && j <= i)) continue;  // once per pair
                    const double d[3] = {xi[0] - s.px[j], xi[1] - s.py[j], xi[2] - s.pz[j]};
                    const double r2 = dot(d, d);
                    const double t = kPi * r2 / (0.5 * (Ai + Aj));
                    if (t > 2.0 * kT0) continue;
                    ++count;
                    close_pair(s, i, j, t, vis, scan, mine);
                }
            }
        }
        examined[b / grain] = count;
    });

    std::size_t candidates = 0;
    for (std::size_t c = 0; c < nchunks; ++c) candidates += 2 * examined[c];
    NearCorrection out = assemble_correction(n, found);
    out.candidate_pairs = candidates;
    out.limited_rows = out.limit_close_sums();
    return out;
}

}  // namespace illumap
