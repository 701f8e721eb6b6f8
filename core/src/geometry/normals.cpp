// normals.cpp — plane fits over each point's neighbours; minimum spanning forest (Kruskal)
// over the k-NN graph and sign propagation.
#include "geometry/normals.hpp"

#include "geometry/sym3.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <vector>

namespace illumap {

namespace {

struct Edge {
    float weight;   // 1 - |n_i . n_j|
    float length2;  // tie-break: |p_i - p_j|^2
    std::uint32_t i, j;
};

struct DisjointSets {
    std::vector<std::uint32_t> parent;
    explicit DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
    std::uint32_t find(std::uint32_t a) {
        while (parent[a] != a) a = parent[a] = parent[parent[a]];  // path halving
        return a;
    }
    bool unite(std::uint32_t a, std::uint32_t b) {
        a = find(a);
        b = find(b);
        if (a == b) return false;
        parent[std::max(a, b)] = std::min(a, b);
        return true;
    }
};

double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Points handled per task by the plane fits.
constexpr std::size_t kFitGrain = 2048;

// The neighbours of point i minus the point (k x 3).
void offsets_of(const double* points, std::size_t n, const std::int64_t* row, std::size_t k,
                std::size_t i, double* off) {
    const double* p = points + 3 * i;
    for (std::size_t j = 0; j < k; ++j) {
        const std::int64_t q = row[j];
        if (q < 0 || std::size_t(q) >= n) throw std::out_of_range("neighbour index out of range");
        for (int c = 0; c < 3; ++c) off[3 * j + c] = points[3 * q + c] - p[c];
    }
}

// The eigen-decomposition of the covariance of the rows `keep` selects, about their mean.
Sym3Eigen centred_covariance(const double* off, std::size_t k, const unsigned char* keep) {
    double mean[3] = {0, 0, 0}, count = 0;
    for (std::size_t j = 0; j < k; ++j)
        if (keep[j]) {
            for (int c = 0; c < 3; ++c) mean[c] += off[3 * j + c];
            count += 1;
        }
    for (int c = 0; c < 3; ++c) mean[c] /= std::max(count, 1.0);
    double cov[3][3] = {};
    for (std::size_t j = 0; j < k; ++j) {
        if (!keep[j]) continue;
        const double d[3] = {off[3 * j] - mean[0], off[3 * j + 1] - mean[1], off[3 * j + 2] - mean[2]};
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) cov[a][b] += d[a] * d[b];
    }
    return sym3_eigen(cov);
}

void store(double* out, std::size_t i, const double* v) {
    for (int c = 0; c < 3; ++c) out[3 * i + c] = v[c];
}

double median(std::vector<double>& v) {
    const std::size_t m = v.size();
    if (m == 0) return 0.0;
    std::sort(v.begin(), v.end());
    return m % 2 ? v[m / 2] : 0.5 * (v[m / 2 - 1] + v[m / 2]);
}

}  // namespace

void covariance_normals(Context& ctx, const double* points, std::size_t n,
                        const std::int64_t* neighbours, std::size_t k, double* out) {
    ctx.set_phase("normals", 0.0, 1.0);
    parallel_for(ctx, n, kFitGrain, [&](std::size_t b, std::size_t e) {
        std::vector<double> off(3 * k);
        const std::vector<unsigned char> all(k, 1);
        for (std::size_t i = b; i < e; ++i) {
            offsets_of(points, n, neighbours + i * k, k, i, off.data());
            store(out, i, centred_covariance(off.data(), k, all.data()).vectors[0]);
        }
    });
}

void plane_normals(Context& ctx, const double* points, std::size_t n,
                   const std::int64_t* neighbours, std::size_t k, const PlaneFitOptions& options,
                   double* out) {
    ctx.set_phase("normals", 0.0, 1.0);
    parallel_for(ctx, n, kFitGrain, [&](std::size_t b, std::size_t e) {
        const std::size_t m = k > 0 ? k - 1 : 0;   // neighbours other than the first column
        std::vector<double> off(3 * k), length(m);
        std::vector<unsigned char> keep(k), all(k, 1);
        for (std::size_t i = b; i < e; ++i) {
            offsets_of(points, n, neighbours + i * k, k, i, off.data());
            const double* nb = off.data() + 3;
            for (std::size_t j = 0; j < m; ++j) length[j] = std::sqrt(dot3(nb + 3 * j, nb + 3 * j));
            const double scale = median(length);   // reorders `length`: only its median is used
            const double tol = options.inlier * scale;
            const double floor = 1e-6 * std::max(scale, 1e-300) * std::max(scale, 1e-300);
            const double norm = std::max(tol * double(m), 1e-300);
            double best_score = -std::numeric_limits<double>::infinity(), best[3] = {0, 0, 0};
            bool usable_any = false;
            for (std::size_t a = 0; a < m; ++a)
                for (std::size_t c = a + 1; c < m; ++c) {
                    const double* u = nb + 3 * a;
                    const double* v = nb + 3 * c;
                    double cand[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                                      u[0] * v[1] - u[1] * v[0]};
                    const double len = std::sqrt(dot3(cand, cand));
                    if (!(len > floor)) continue;
                    usable_any = true;
                    for (double& x : cand) x /= len;
                    double inliers = 0, clamped = 0;
                    for (std::size_t j = 0; j < m; ++j) {
                        const double d = std::fabs(dot3(cand, nb + 3 * j));
                        inliers += d < tol;
                        clamped += std::min(d, tol);
                    }
                    const double score = inliers - clamped / norm;
                    if (score > best_score) {
                        best_score = score;
                        std::copy(cand, cand + 3, best);
                    }
                }
            std::size_t kept = 0;
            keep[0] = 1;
            for (std::size_t j = 0; j < m; ++j) {
                keep[j + 1] = usable_any && std::fabs(dot3(best, nb + 3 * j)) < tol;
                kept += keep[j + 1];
            }
            const bool weak = !usable_any || double(kept) < options.share * double(m);
            Sym3Eigen fit = centred_covariance(off.data(), k, weak ? all.data() : keep.data());
            if (!weak && fit.values[1] < options.spread * fit.values[2])
                fit = centred_covariance(off.data(), k, all.data());
            store(out, i, fit.vectors[0]);
        }
    });
}

void settled_normals(Context& ctx, const double* points, const double* normals, std::size_t n,
                     const std::int64_t* neighbours, std::size_t k, const SettleOptions& options,
                     double* out) {
    ctx.set_phase("normals", 0.0, 1.0);
    parallel_for(ctx, n, kFitGrain, [&](std::size_t b, std::size_t e) {
        std::vector<double> off(3 * k);
        for (std::size_t i = b; i < e; ++i) {
            offsets_of(points, n, neighbours + i * k, k, i, off.data());
            const double* ni = normals + 3 * i;
            double cov[3][3] = {};
            std::size_t same = 0;
            for (std::size_t j = 0; j < k; ++j) {
                if (!(std::fabs(dot3(ni, normals + 3 * neighbours[i * k + j])) > options.same_cos))
                    continue;
                ++same;
                const double* d = off.data() + 3 * j;
                for (int a = 0; a < 3; ++a)
                    for (int c = 0; c < 3; ++c) cov[a][c] += d[a] * d[c];
            }
            const Sym3Eigen fit = sym3_eigen(cov);
            const bool on_line =
                fit.values[1] < options.on_a_line * options.on_a_line * fit.values[2];
            if (on_line || same < options.min_points) {
                store(out, i, ni);
                continue;
            }
            const double flip = dot3(fit.vectors[0], ni) < 0 ? -1.0 : 1.0;
            const double v[3] = {flip * fit.vectors[0][0], flip * fit.vectors[0][1],
                                 flip * fit.vectors[0][2]};
            store(out, i, v);
        }
    });
}

std::size_t orient_normals(Context& ctx, const double* points, double* normals, std::size_t n,
                           const std::int64_t* neighbours, std::size_t k, std::int64_t* part) {
    if (n == 0) return 0;
    ctx.set_phase("orient normals", 0.0, 1.0);
    // Each undirected edge once (i < j); a pair listed by both ends appears twice, harmlessly.
    std::vector<std::size_t> count(n + 1, 0);
    parallel_for(ctx, n, 4096, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i)
            for (std::size_t r = 0; r < k; ++r) {
                const std::int64_t j = neighbours[i * k + r];
                count[i + 1] += (j >= 0 && std::size_t(j) < n && std::size_t(j) > i);
            }
    });
    std::partial_sum(count.begin(), count.end(), count.begin());
    std::vector<Edge> edges(count[n]);
    parallel_for(ctx, n, 4096, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
            std::size_t at = count[i];
            for (std::size_t r = 0; r < k; ++r) {
                const std::int64_t j = neighbours[i * k + r];
                if (!(j >= 0 && std::size_t(j) < n && std::size_t(j) > i)) continue;
                const double* pi = points + 3 * i;
                const double* pj = points + 3 * j;
                const double dx = pi[0] - pj[0], dy = pi[1] - pj[1], dz = pi[2] - pj[2];
                edges[at++] = Edge{float(1.0 - std::fabs(dot3(normals + 3 * i, normals + 3 * j))),
                                   float(dx * dx + dy * dy + dz * dz), std::uint32_t(i),
                                   std::uint32_t(j)};
            }
        }
    });
    checkpoint(ctx, 0.2);
    std::sort(edges.begin(), edges.end(), [](const Edge& a, const Edge& b) {
        return a.weight < b.weight || (a.weight == b.weight && a.length2 < b.length2);
    });
    checkpoint(ctx, 0.5);

    // The forest as adjacency lists (CSR), each edge with its relative sign.
    DisjointSets sets(n);
    std::vector<std::uint32_t> tree_i, tree_j;
    tree_i.reserve(n);
    tree_j.reserve(n);
    for (const Edge& e : edges)
        if (sets.unite(e.i, e.j)) {
            tree_i.push_back(e.i);
            tree_j.push_back(e.j);
        }
    std::vector<std::size_t> start(n + 1, 0);
    for (std::size_t t = 0; t < tree_i.size(); ++t) {
        ++start[tree_i[t] + 1];
        ++start[tree_j[t] + 1];
    }
    std::partial_sum(start.begin(), start.end(), start.begin());
    std::vector<std::uint32_t> adjacent(2 * tree_i.size());
    {
        std::vector<std::size_t> fill(start.begin(), start.end() - 1);
        for (std::size_t t = 0; t < tree_i.size(); ++t) {
            adjacent[fill[tree_i[t]]++] = tree_j[t];
            adjacent[fill[tree_j[t]]++] = tree_i[t];
        }
    }
    checkpoint(ctx, 0.7);

    // Breadth-first over each tree: a child takes the sign that agrees with its parent.
    std::vector<signed char> sign(n, 0);
    std::vector<std::uint32_t> queue;
    queue.reserve(n);
    std::size_t parts = 0;
    for (std::size_t root = 0; root < n; ++root) {
        if (sign[root] != 0) continue;
        ++parts;
        const std::size_t first = queue.size();
        sign[root] = 1;
        queue.push_back(std::uint32_t(root));
        for (std::size_t q = first; q < queue.size(); ++q) {
            const std::uint32_t u = queue[q];
            for (std::size_t a = start[u]; a < start[u + 1]; ++a) {
                const std::uint32_t v = adjacent[a];
                if (sign[v] != 0) continue;
                const double d = dot3(normals + 3 * u, normals + 3 * v);
                sign[v] = static_cast<signed char>(d < 0 ? -sign[u] : sign[u]);
                queue.push_back(v);
            }
        }
        for (std::size_t q = first; q < queue.size(); ++q) part[queue[q]] = std::int64_t(parts - 1);
    }
    for (std::size_t i = 0; i < n; ++i)
        if (sign[i] < 0)
            for (int c = 0; c < 3; ++c) normals[3 * i + c] = -normals[3 * i + c];
    checkpoint(ctx, 1.0);
    return parts;
}

}  // namespace illumap
