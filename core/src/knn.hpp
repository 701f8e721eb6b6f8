// knn.hpp — k nearest neighbours with a kd-tree, multithreaded over queries.
// Used by the add-on for point-cloud spacing, PCA normals and transferring results to meshes.
#pragma once

#include "parallel.hpp"

#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace illumap {

// A kd-tree over points (median splits on the widest axis), for repeated nearest-neighbour
// queries (knn below, and the final gather's lookups of surfel values).
class KdTree {
public:
    KdTree(const double* points, std::size_t n);  // points: n x 3, copied

    // The k best (squared distance, index) pairs found so far: a bounded max-heap.
    struct Best {
        std::vector<std::pair<double, std::int64_t>> h;
        std::size_t k;
        explicit Best(std::size_t k_) : k(k_) { h.reserve(k_); }
        double worst() const {
            return h.size() < k ? std::numeric_limits<double>::infinity() : h.front().first;
        }
        void offer(double d2, std::int64_t i);
    };
    // Fills best with the best.k nearest points of q, nearest first.
    void nearest(const double q[3], Best& best) const;

private:
    static constexpr std::size_t kLeaf = 12;
    struct Node {
        std::uint32_t begin, end;  // range in idx / pts
        std::int32_t left = -1, right = -1;
        int dim = 0;
        double split = 0;
    };
    std::vector<Node> nodes;
    std::vector<std::int64_t> idx;  // tree order -> original index
    std::vector<double> pts;        // points in tree order (x, y, z)
    std::int32_t build(const double* p, std::uint32_t b, std::uint32_t e);
    void search(std::int32_t id, const double q[3], Best& best) const;
};

// points: n x 3, queries: m x 3 (row-major). Writes indices (m x k, int64) and Euclidean
// distances (m x k), nearest first. A query that coincides with a point finds it (distance 0).
// Requires 1 <= k <= n.
void knn(Context& ctx, const double* points, std::size_t n, const double* queries, std::size_t m,
         std::size_t k, std::int64_t* indices, double* distances);

}  // namespace illumap
