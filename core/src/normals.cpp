// normals.cpp — minimum spanning forest (Kruskal) over the k-NN graph and sign propagation.
#include "normals.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
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

}  // namespace

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
