// gather.cpp — final gather at receivers (see gather.hpp).
#include "gather/gather.hpp"

#include <algorithm>
#include <memory>
#include <cmath>
#include <stdexcept>

namespace illumap {

namespace {

constexpr double kLumR = 0.2126, kLumG = 0.7152, kLumB = 0.0722;

// Uniform [0, 1) from a 64-bit mix of (id, seed, stream) (SplitMix64's finaliser).
double hash_uniform(std::int64_t id, std::uint64_t seed, std::uint64_t stream) {
    std::uint64_t x = std::uint64_t(id) * 0x9E3779B97F4A7C15ull;
    x ^= seed * 0x632BE59BD9B4E019ull + stream * 0x85EBCA77C2B2AE63ull;
    x ^= x >> 30;
    x *= 0xBF58476D1CE4E5B9ull;
    x ^= x >> 27;
    x *= 0x94D049BB133111EBull;
    x ^= x >> 31;
    return double(x >> 11) * (1.0 / 9007199254740992.0);
}

}  // namespace

void cosine_directions(const double n[3], std::size_t count, std::int64_t id, std::uint64_t seed,
                       double* dirs) {
    const double s1 = hash_uniform(id, seed, 1), s2 = hash_uniform(id, seed, 2);
    const double helper[3] = {std::fabs(n[0]) < 0.9 ? 1.0 : 0.0, std::fabs(n[0]) < 0.9 ? 0.0 : 1.0, 0.0};
    double t[3] = {n[1] * helper[2] - n[2] * helper[1], n[2] * helper[0] - n[0] * helper[2],
                   n[0] * helper[1] - n[1] * helper[0]};
    const double tl = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    for (double& x : t) x /= tl;
    const double s[3] = {n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0]};
    constexpr double kGolden = 0.6180339887498949;
    constexpr double kQuarterPi = 0.7853981633974483;
    for (std::size_t k = 0; k < count; ++k) {
        double u = (double(k) + 0.5) / double(count) + s1, v = double(k) * kGolden + s2;
        u -= std::floor(u);
        v -= std::floor(v);
        // Shirley's concentric map to the disc, then up to the hemisphere (Malley).
        const double a = 2 * u - 1, b = 2 * v - 1;
        double r, phi;
        if (std::fabs(a) > std::fabs(b)) {
            r = a;
            phi = kQuarterPi * b / (a == 0 ? 1 : a);
        } else {
            r = b;
            phi = 2 * kQuarterPi - kQuarterPi * a / (b == 0 ? 1 : b);
        }
        const double x = r * std::cos(phi), y = r * std::sin(phi);
        const double z = std::sqrt(std::max(0.0, 1.0 - x * x - y * y));
        for (int d = 0; d < 3; ++d) dirs[3 * k + d] = x * t[d] + y * s[d] + z * n[d];
    }
}

namespace {

// The field tabulated on every triangle (one side): a barycentric lattice of n_t + 1 points
// per edge, n_t = ceil(longest edge / the field's reach), looked up once per point. A hit then
// interpolates the three lattice points of its sub-triangle: one lookup per lattice point
// instead of one per hit, and as fine as the surfels resolve.
// Sub-triangles whose lattice points see each other ("clean") interpolate; the others (a
// box's side stands on them) look the field up at the hit itself.
//
// The per-triangle arrays end at the last triangle that has a lattice (size()): a scan's splat
// triangles, a dozen per point, carry their own surfel and follow the meshes' triangles.
struct FieldTable {
    std::vector<std::size_t> start;     // first lattice point of each triangle (size() + 1)
    std::vector<std::size_t> sub_start;  // first sub-triangle of each triangle (size() + 1)
    std::vector<std::uint32_t> n;       // subdivisions per edge of each triangle
    std::vector<double> values;         // 3 per lattice point
    std::vector<std::uint8_t> clean;    // per sub-triangle

    std::size_t size() const { return n.size(); }  // triangles 0 .. size() - 1 may have one
    static std::size_t row(std::size_t i, std::size_t nn) { return i * (nn + 1) - i * (i - 1) / 2; }
    static std::size_t count(std::size_t nn) { return (nn + 1) * (nn + 2) / 2; }
    // Sub-triangles: "lower" (i, j), (i+1, j), (i, j+1) for i + j <= nn - 1, then "upper"
    // (i+1, j+1), (i, j+1), (i+1, j) for i + j <= nn - 2.
    static std::size_t lower(std::size_t i, std::size_t j, std::size_t nn) { return row(i, nn - 1) + j; }
    static std::size_t upper(std::size_t i, std::size_t j, std::size_t nn) {
        return count(nn - 1) + row(i, nn - 2) + j;
    }

    // Interpolated value at barycentric (u, v) (Embree's: weights of corners 1 and 2) of
    // triangle t; false (nothing written) where the sub-triangle is not clean.
    bool at(std::size_t t, double u, double v, double out[3]) const {
        if (t >= n.size()) return false;   // past the last lattice
        const std::size_t nn = n[t];
        if (nn == 0) return false;   // not tabulated
        const double x = std::min(std::max(u, 0.0), 1.0) * double(nn);
        const double y = std::min(std::max(v, 0.0), 1.0) * double(nn);
        std::size_t i = std::min<std::size_t>(std::size_t(x), nn - 1);
        std::size_t j = std::min<std::size_t>(std::size_t(y), nn - 1 - i);
        double fx = x - double(i), fy = y - double(j);
        const double* base = &values[3 * start[t]];
        auto pt = [&](std::size_t a, std::size_t b) { return base + 3 * (row(a, nn) + b); };
        const double *p0, *p1, *p2;
        double w0, w1, w2;
        if (fx + fy <= 1.0 || i + j + 1 >= nn) {
            if (!clean[sub_start[t] + lower(i, j, nn)]) return false;
            p0 = pt(i, j); p1 = pt(i + 1, j); p2 = pt(i, j + 1);
            w1 = fx; w2 = fy; w0 = 1.0 - fx - fy;
        } else {
            if (!clean[sub_start[t] + upper(i, j, nn)]) return false;
            p0 = pt(i + 1, j + 1); p1 = pt(i, j + 1); p2 = pt(i + 1, j);
            w0 = fx + fy - 1.0; w1 = 1.0 - fx; w2 = 1.0 - fy;
        }
        for (int c = 0; c < 3; ++c) out[c] = w0 * p0[c] + w1 * p1[c] + w2 * p2[c];
        return true;
    }
};

// Lattice point (i, j) of triangle c (9 doubles) with nn subdivisions, moved kLatticeInset
// of the way to the centroid: a point on an edge where a wall stands then lies on one side of
// the wall, the side of its own triangle.
constexpr double kLatticeInset = 1e-3;

void lattice_point(const double* c, std::size_t i, std::size_t j, std::size_t nn, double q[3]) {
    const double u = double(i) / double(nn), v = double(j) / double(nn);
    for (int d = 0; d < 3; ++d) {
        const double p = c[d] + u * (c[3 + d] - c[d]) + v * (c[6 + d] - c[d]);
        const double centroid = (c[d] + c[3 + d] + c[6 + d]) / 3.0;
        q[d] = p + kLatticeInset * (centroid - p);
    }
}

// Which triangles' lattices a gather looks up (empty: all): not splats, which carry their own
// surfel, nor back faces that are black.
struct LatticeMasks {
    std::vector<std::uint8_t> front, back;
};

LatticeMasks lattice_masks(std::size_t T, bool has_back, const std::uint8_t* two_sided,
                           const OwnerRow* owner_front, const OwnerRow* owner_back) {
    LatticeMasks mk;
    if (owner_front) {
        mk.front.resize(T);
        for (std::size_t t = 0; t < T; ++t) mk.front[t] = owner_front[t] < 0;
    }
    if (has_back && (two_sided || owner_back)) {
        mk.back.resize(T);
        for (std::size_t t = 0; t < T; ++t)
            mk.back[t] = (!two_sided || two_sided[t]) && (!owner_back || owner_back[t] < 0);
    }
    return mk;
}

// The lattice alone: n_t = ceil(longest edge / reach) per used triangle, none on the others.
FieldTable lattice_layout(const MeshScene& scene, double reach, const std::uint8_t* only) {
    std::size_t T = scene.size();
    if (only)
        while (T > 0 && !only[T - 1]) --T;
    FieldTable tab;
    tab.start.assign(T + 1, 0);
    tab.sub_start.assign(T + 1, 0);
    tab.n.assign(T, 0);
    reach = std::max(reach, 1e-300);
    for (std::size_t t = 0; t < T; ++t) {
        tab.start[t + 1] = tab.start[t];
        tab.sub_start[t + 1] = tab.sub_start[t];
        if (only && !only[t]) continue;   // never looked up
        const double* c = scene.triangle_corners(t);
        double longest = 0;
        for (int e = 0; e < 3; ++e) {
            const double* a = c + 3 * e;
            const double* b = c + 3 * ((e + 1) % 3);
            const double dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
            longest = std::max(longest, std::sqrt(dx * dx + dy * dy + dz * dz));
        }
        tab.n[t] = std::uint32_t(std::min(std::max(std::ceil(longest / reach), 1.0), 4096.0));
        tab.start[t + 1] += FieldTable::count(tab.n[t]);
        tab.sub_start[t + 1] += std::size_t(tab.n[t]) * tab.n[t];
    }
    return tab;
}

// The field (plus `exact`, 3 per lattice point, where given) at every lattice point of `tab`,
// and which sub-triangles are clean.
void fill_table(Context& ctx, const MeshScene& scene, const SurfelField& field, double sign,
                double lift, const double* exact, FieldTable& tab) {
    const std::size_t T = tab.size();
    tab.values.assign(3 * tab.start[T], 0.0);
    tab.clean.assign(tab.sub_start[T], 0);
    parallel_for(ctx, T, 64, [&](std::size_t lo, std::size_t hi) {
        KdTree::Best best{std::size_t(field.k())};
        for (std::size_t t = lo; t < hi; ++t) {
            const std::size_t nn = tab.n[t];
            if (nn == 0) continue;
            const double* c = scene.triangle_corners(t);
            const std::array<float, 3> tn = scene.triangle_normal(t);
            const double nt[3] = {sign * tn[0], sign * tn[1], sign * tn[2]};
            double* out = &tab.values[3 * tab.start[t]];
            for (std::size_t i = 0; i <= nn; ++i)
                for (std::size_t j = 0; i + j <= nn; ++j) {
                    double q[3];
                    lattice_point(c, i, j, nn, q);
                    double* o = out + 3 * (FieldTable::row(i, nn) + j);
                    field.at(q, nt, best, o, &scene, lift);
                    if (exact) {
                        const double* e = exact + 3 * (tab.start[t] + FieldTable::row(i, nn) + j);
                        for (int d = 0; d < 3; ++d) o[d] += e[d];
                    }
                }
            // Lattice points lifted off the surface: does a triangle stand between them?
            auto lifted = [&](std::size_t i, std::size_t j, double q[3]) {
                lattice_point(c, i, j, nn, q);
                for (int d = 0; d < 3; ++d) q[d] += lift * nt[d];
            };
            auto sees = [&](std::size_t i0, std::size_t j0, std::size_t i1, std::size_t j1) {
                double a[3], b[3];
                lifted(i0, j0, a);
                lifted(i1, j1, b);
                return !scene.occluded(a, b);
            };
            std::uint8_t* cl = &tab.clean[tab.sub_start[t]];
            for (std::size_t i = 0; i < nn; ++i)
                for (std::size_t j = 0; i + j < nn; ++j) {
                    cl[FieldTable::lower(i, j, nn)] =
                        sees(i, j, i + 1, j) && sees(i, j, i, j + 1) && sees(i + 1, j, i, j + 1);
                    if (i + j + 2 <= nn)
                        cl[FieldTable::upper(i, j, nn)] = sees(i + 1, j + 1, i, j + 1) &&
                                                          sees(i + 1, j + 1, i + 1, j) &&
                                                          sees(i, j + 1, i + 1, j);
                }
        }
    });
}

void lattice_points_of(const MeshScene& scene, const FieldTable& tab, double sign,
                       std::vector<double>& points, std::vector<double>& normals,
                       std::vector<std::int64_t>& triangle) {
    const std::size_t T = tab.size();
    points.assign(3 * tab.start[T], 0.0);
    normals.assign(3 * tab.start[T], 0.0);
    triangle.assign(tab.start[T], 0);
    for (std::size_t t = 0; t < T; ++t)
        std::fill(triangle.begin() + std::ptrdiff_t(tab.start[t]),
                  triangle.begin() + std::ptrdiff_t(tab.start[t + 1]), std::int64_t(t));
    for (std::size_t t = 0; t < T; ++t) {
        const std::size_t nn = tab.n[t];
        if (nn == 0) continue;
        const double* c = scene.triangle_corners(t);
        const std::array<float, 3> tn = scene.triangle_normal(t);
        for (std::size_t i = 0; i <= nn; ++i)
            for (std::size_t j = 0; i + j <= nn; ++j) {
                const std::size_t k = tab.start[t] + FieldTable::row(i, nn) + j;
                lattice_point(c, i, j, nn, &points[3 * k]);
                for (int d = 0; d < 3; ++d) normals[3 * k + d] = sign * tn[d];
            }
    }
}

}  // namespace

struct GatherPlan::Tables {
    FieldTable front, back;
};

GatherPlan::GatherPlan(Context& ctx, const MeshScene& scene, const SurfelField& front,
                       const SurfelField* back, const GatherOptions& opt,
                       const std::uint8_t* two_sided, const OwnerRow* owner_front,
                       const OwnerRow* owner_back, const ExactPart* front_exact,
                       const ExactPart* back_exact)
    : scene_(scene), front_(front), back_(back), opt_(opt), two_sided_(two_sided),
      owner_front_(owner_front), owner_back_(owner_back), tables_(std::make_unique<Tables>()) {
    ctx.set_phase("gather: field", 0.0, 0.1);
    const LatticeMasks mk = lattice_masks(scene.size(), back != nullptr, two_sided, owner_front, owner_back);
    // With an exact part, the lattice takes its values plus the rest's field; hits off the
    // lattice (sub-triangles that are not clean) still look up the whole field.
    auto table = [&](const SurfelField& field, const ExactPart* exact, double sign,
                     const std::vector<std::uint8_t>& only) {
        const bool split = exact && exact->rest && exact->lattice;
        // Without a table each hit looks the field up itself (cheaper for a few receivers in
        // a large scene): an empty table, which has no lattice for any triangle (per-triangle
        // arrays of zeros were 0.48 GB for a 990k scan's straddling surfels). An exact part
        // lives on the lattice, so it keeps one.
        if (!split && !opt.tabulate) return FieldTable{};
        FieldTable tab = lattice_layout(scene, field.reach(), only.empty() ? nullptr : only.data());
        fill_table(ctx, scene, split ? *exact->rest : field, sign, opt.offset,
                   split ? exact->lattice : nullptr, tab);
        return tab;
    };
    tables_->front = table(front, front_exact, 1.0, mk.front);
    if (back) tables_->back = table(*back, back_exact, -1.0, mk.back);
}

GatherPlan::~GatherPlan() = default;

void GatherPlan::hit_value(std::size_t t, bool front_face, double u, double v,
                           const double q[3], KdTree::Best& best, double out[3]) const {
    const SurfelField* field = front_face ? &front_ : back_;
    if (!front_face && two_sided_ && !two_sided_[t]) field = nullptr;
    const FieldTable& tab = front_face ? tables_->front : tables_->back;
    const OwnerRow* owner = front_face ? owner_front_ : owner_back_;
    if (!field) {
        out[0] = out[1] = out[2] = 0.0;
    } else if (owner && owner[t] >= 0) {
        const double* own = field->value(std::size_t(owner[t]));
        for (int c = 0; c < 3; ++c) out[c] = own[c];
    } else if (!tab.at(t, u, v, out)) {
        const std::array<float, 3> tn = scene_.triangle_normal(t);
        const double sg = front_face ? 1.0 : -1.0;
        const double nt[3] = {sg * tn[0], sg * tn[1], sg * tn[2]};
        field->at(q, nt, best, out, &scene_, opt_.offset);
    }
}

void GatherPlan::hit_values(Context& ctx, const std::int64_t* triangles,
                            const std::uint8_t* front, const double* points, std::size_t m,
                            double* out) const {
    parallel_for(ctx, m, 1024, [&](std::size_t lo, std::size_t hi) {
        KdTree::Best best{std::size_t(std::max(front_.k(), back_ ? back_->k() : 1))};
        for (std::size_t i = lo; i < hi; ++i) {
            const std::size_t t = std::size_t(triangles[i]);
            const double* c = scene_.triangle_corners(t);
            const double* q = points + 3 * i;
            // Barycentric weights of corners 1 and 2 (Embree's u, v), from the normal
            // equations of q - c0 = u (c1 - c0) + v (c2 - c0).
            double e1[3], e2[3], w[3];
            for (int d = 0; d < 3; ++d) {
                e1[d] = c[3 + d] - c[d];
                e2[d] = c[6 + d] - c[d];
                w[d] = q[d] - c[d];
            }
            auto dot = [](const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
            const double a11 = dot(e1, e1), a12 = dot(e1, e2), a22 = dot(e2, e2);
            const double b1 = dot(w, e1), b2 = dot(w, e2), det = a11 * a22 - a12 * a12;
            const double u = det > 0 ? (a22 * b1 - a12 * b2) / det : 0.0;
            const double v = det > 0 ? (a11 * b2 - a12 * b1) / det : 0.0;
            hit_value(t, front[i] != 0, u, v, q, best, out + 3 * i);
        }
    });
}

namespace {

// Rays cast together: origins, directions and what the scene found (MeshScene::intersect_serial).
struct RayBatch {
    std::vector<double> org, dir, dist;
    std::vector<std::int64_t> prim;
    std::vector<std::uint8_t> face;
    std::vector<float> uv;
    explicit RayBatch(std::size_t K)
        : org(3 * K), dir(3 * K), dist(K), prim(K), face(K), uv(2 * K) {}
    void cast(const MeshScene& scene, std::size_t n) {
        scene.intersect_serial(org.data(), dir.data(), n, HUGE_VAL, prim.data(), dist.data(),
                               face.data(), uv.data());
    }
};

// What each of a receiver's rays takes: its value (3 each) and what it met (0: dropped, it
// takes nothing; 1: nothing, the background; 2: a surface at `dist`).
struct RayValues {
    std::vector<double> value, dist;
    std::vector<std::uint8_t> state;
    explicit RayValues(std::size_t K) : value(3 * K), dist(K), state(K) {}
    void drop(std::size_t k) {
        state[k] = 0;
        value[3 * k] = value[3 * k + 1] = value[3 * k + 2] = 0.0;
    }
};

// The gather's outputs (GatherPlan::gather): row r takes the mean of K rays' values and its
// statistics.
struct GatherRows {
    double *out, *stderr_out, *reach_out, *open_out, *halves_out;
    double offset;
    void set(std::size_t r, std::size_t K, const RayValues& rv) const {
        double sum[3] = {0, 0, 0}, lum = 0, lum2 = 0, lum_odd = 0, nearness = 0;
        std::size_t misses = 0;
        for (std::size_t k = 0; k < K; ++k) {
            if (rv.state[k] == 0) continue;   // dropped: takes nothing
            const double* v = rv.value.data() + 3 * k;
            if (rv.state[k] == 1) ++misses;
            else nearness += 1.0 / std::max(rv.dist[k] + offset, 1e-300);
            for (int c = 0; c < 3; ++c) sum[c] += v[c];
            const double y = kLumR * v[0] + kLumG * v[1] + kLumB * v[2];
            lum += y;
            lum2 += y * y;
            if (k & 1) lum_odd += y;
        }
        for (int c = 0; c < 3; ++c) out[3 * r + c] = sum[c] / double(K);
        const double mean = lum / double(K);
        const double var = std::max(0.0, lum2 / double(K) - mean * mean);
        stderr_out[r] = std::sqrt(var / double(K));
        if (halves_out) {
            const std::size_t odd = K / 2, even = K - odd;
            halves_out[r] = odd ? 0.5 * ((lum - lum_odd) / double(even) - lum_odd / double(odd)) : 0.0;
        }
        if (reach_out) reach_out[r] = nearness > 0 ? double(K) / nearness : HUGE_VAL;
        if (open_out) open_out[r] = double(misses) / double(K);
    }
};

double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

}  // namespace

void GatherPlan::take(const RayBatchView& b, std::size_t k, KdTree::Best& best, double* v,
                      std::uint8_t& state, double& dist) const {
    for (int c = 0; c < 3; ++c) v[c] = opt_.background[c];
    if (b.prim[k] < 0) {
        state = 1;
        return;
    }
    state = 2;
    dist = b.dist[k];
    const double* o = b.org + 3 * k;
    const double* d = b.dir + 3 * k;
    const double q[3] = {o[0] + dist * d[0], o[1] + dist * d[1], o[2] + dist * d[2]};
    hit_value(std::size_t(b.prim[k]), b.face[k] != 0, b.uv[2 * k], b.uv[2 * k + 1], q, best, v);
}

void GatherPlan::gather(Context& ctx, const double* positions, const double* normals,
                        const std::int64_t* ids, std::size_t m, int rays, std::uint64_t seed,
                        const std::int32_t* rays_per, double* out, double* stderr_out,
                        double* reach_out, double* open_out, double* halves_out,
                        const double* faces, const FaceShares* shares) const {
    const MeshScene& scene = scene_;
    const double offset = opt_.offset;
    if (shares && shares->count && !shares->start)
        throw std::invalid_argument("face shares need their receivers' offsets");
    std::size_t K_max = std::size_t(std::max(1, rays));
    if (rays_per)
        for (std::size_t i = 0; i < m; ++i)
            K_max = std::max(K_max, std::size_t(std::max(1, rays_per[i])));
    const std::size_t K_grain = std::size_t(std::max(1, rays));
    const GatherRows rows{out, stderr_out, reach_out, open_out, halves_out, offset};
    ctx.set_phase("gather", 0.1, 0.9);
    parallel_for(ctx, m, std::max<std::size_t>(1, 4096 / K_grain), [&](std::size_t lo, std::size_t hi) {
        RayBatch cast(K_max), again(K_max);
        RayValues lead(K_max), own(K_max);
        std::vector<std::size_t> redo(K_max);
        KdTree::Best best{std::size_t(std::max(front_.k(), back_ ? back_->k() : 1))};
        std::size_t recast = 0;
        auto view = [](const RayBatch& b) {
            return RayBatchView{b.org.data(), b.dir.data(), b.dist.data(), b.prim.data(),
                                b.face.data(), b.uv.data()};
        };
        for (std::size_t i = lo; i < hi; ++i) {
            const double* p = positions + 3 * i;
            const double* n = normals + 3 * i;
            const double* g = faces ? faces + 3 * i : nullptr;
            const std::size_t K = rays_per ? std::size_t(std::max(1, rays_per[i]))
                                           : std::size_t(std::max(1, rays));
            cosine_directions(n, K, ids ? ids[i] : std::int64_t(i), seed, cast.dir.data());
            for (std::size_t k = 0; k < K; ++k)
                for (int d = 0; d < 3; ++d) cast.org[3 * k + d] = p[d] + offset * n[d];
            cast.cast(scene, K);
            const RayBatchView cv = view(cast);
            for (std::size_t k = 0; k < K; ++k) {
                if (g && dot3(cast.dir.data() + 3 * k, g) <= 0.0) lead.drop(k);   // below its face
                else take(cv, k, best, lead.value.data() + 3 * k, lead.state[k], lead.dist[k]);
            }
            rows.set(i, K, lead);
            // The corners that share the receiver's rays, each in its own face: a ray above
            // the receiver's face and the corner's counts as cast (both points lie at the
            // vertex: they see its other faces alike); one below the receiver's face only is
            // cast again from the corner's own point (from the receiver's it enters the
            // receiver's own surface); one below the corner's face takes nothing.
            const std::size_t s0 = shares ? std::size_t(shares->start[i]) : 0;
            const std::size_t s1 = shares ? std::size_t(shares->start[i + 1]) : 0;
            for (std::size_t s = s0; s < s1; ++s) {
                const double* gs = shares->faces + 3 * s;
                const double* ps = shares->positions + 3 * s;
                std::size_t nredo = 0;
                for (std::size_t k = 0; k < K; ++k) {
                    const double* dk = cast.dir.data() + 3 * k;
                    if (dot3(dk, gs) <= 0.0) {
                        own.drop(k);
                    } else if (lead.state[k] != 0) {
                        own.state[k] = lead.state[k];
                        own.dist[k] = lead.dist[k];
                        for (int c = 0; c < 3; ++c) own.value[3 * k + c] = lead.value[3 * k + c];
                    } else {
                        for (int d = 0; d < 3; ++d) {
                            again.org[3 * nredo + d] = ps[d] + offset * n[d];
                            again.dir[3 * nredo + d] = dk[d];
                        }
                        redo[nredo++] = k;
                    }
                }
                if (nredo) {
                    recast += nredo;
                    again.cast(scene, nredo);
                    const RayBatchView av = view(again);
                    for (std::size_t j = 0; j < nredo; ++j) {
                        const std::size_t k = redo[j];
                        take(av, j, best, own.value.data() + 3 * k, own.state[k], own.dist[k]);
                    }
                }
                rows.set(m + s, K, own);
            }
        }
        if (shares) shares->recast += recast;
    });
}


void gather_lattices(const MeshScene& scene, const SurfelField& front, const SurfelField* back,
                     const std::uint8_t* two_sided, const OwnerRow* owner_front,
                     const OwnerRow* owner_back, GatherLattice& front_out,
                     GatherLattice& back_out) {
    const LatticeMasks mk = lattice_masks(scene.size(), back != nullptr, two_sided, owner_front, owner_back);
    const FieldTable f = lattice_layout(scene, front.reach(), mk.front.empty() ? nullptr : mk.front.data());
    lattice_points_of(scene, f, 1.0, front_out.points, front_out.normals, front_out.triangle);
    back_out.points.clear();
    back_out.normals.clear();
    back_out.triangle.clear();
    if (back) {
        const FieldTable b = lattice_layout(scene, back->reach(), mk.back.empty() ? nullptr : mk.back.data());
        lattice_points_of(scene, b, -1.0, back_out.points, back_out.normals, back_out.triangle);
    }
}

}  // namespace illumap
