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
// queries (knn below, the preview's splats, and the final gather's lookups of surfel values).
class KdTree {
public:
    KdTree(const double* points, std::size_t n);  // points: n x 3, copied; built serially
    // The same tree (node for node: the same splits, so the same neighbours and the same
    // choice among equidistant ones), its subtrees built on ctx's workers. Call it from the
    // calling thread only (it polls ctx's monitor).
    KdTree(Context& ctx, const double* points, std::size_t n);

    // The k best (squared distance, index) pairs found so far, sorted. A pair enters when it
    // is below the worst kept one in (distance, index) order, and evicts it: the k smallest
    // pairs in that order whatever order the points are offered in, so the answer does not
    // depend on the tree (its shape, the library's nth_element, the threads), ties at equal
    // distance go to the lower index, and a search for fewer neighbours finds the first
    // columns of a search for more (one table can serve consumers of several widths).
    struct Best {
        std::vector<std::pair<double, std::int64_t>> h;
        std::size_t k;
        explicit Best(std::size_t k_) : k(k_) { h.reserve(k_); }
        double worst() const {
            return h.size() < k ? std::numeric_limits<double>::infinity() : h.back().first;
        }
        // Whether the pair (d2, i) would enter.
        bool takes(double d2, std::int64_t i) const {
            return h.size() < k || d2 < h.back().first ||
                   (d2 == h.back().first && i < h.back().second);
        }
        void offer(double d2, std::int64_t i) {
            const std::pair<double, std::int64_t> item{d2, i};
            if (h.size() < k) {
                h.push_back(item);
            } else if (item < h.back()) {
                h.back() = item;
            } else {
                return;
            }
            // Insertion into the sorted list (k is small: a few neighbours).
            std::size_t j = h.size() - 1;
            for (; j > 0 && item < h[j - 1]; --j) h[j] = h[j - 1];
            h[j] = item;
        }
    };
    // Fills best with the best.k nearest points of q, nearest first.
    void nearest(const double q[3], Best& best) const;

    struct Item {  // a point and its input index, as the build moves them
        double x[3];
        std::int64_t index;
    };

    // Tree order: the points in it (n x 3) and the input index of each; neighbouring
    // entries lie close in space (a cache-friendly order to visit the points in).
    const std::vector<double>& sorted_points() const { return pts; }
    const std::vector<std::int64_t>& order() const { return idx; }

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
    struct Subtree {
        std::int32_t node;
        std::uint32_t begin, end;
    };
    // Builds items [b, e) into out (preorder); `depth` levels down (when tasks is given) a
    // node is a placeholder for a subtree built later, listed in tasks.
    static std::int32_t build(std::vector<Item>& items, std::vector<Node>& out, std::uint32_t b,
                              std::uint32_t e, int depth, std::vector<Subtree>* tasks);
    void unpack(Context* ctx, const std::vector<Item>& items);  // idx and pts from items
    // rd: a lower bound on the squared distance from q to the node's cell (the sum of the
    // squared offsets `off` past the splits that bound it along each axis).
    void search(std::int32_t id, const double q[3], Best& best, double rd, double off[3]) const;
};

// The queries (m x 3) in Morton order: neighbouring queries touch the same tree nodes, so the
// tree stays in cache (random query order is several times slower at millions of points).
// Each query's answer depends on the query alone, so the order changes no result.
std::vector<std::size_t> morton_order(const double* queries, std::size_t m);

// points: n x 3, queries: m x 3 (row-major). Writes indices (m x k, int64) and Euclidean
// distances (m x k), nearest first. A query that coincides with a point finds it (distance 0).
// Requires 1 <= k <= n.
void knn(Context& ctx, const double* points, std::size_t n, const double* queries, std::size_t m,
         std::size_t k, std::int64_t* indices, double* distances);

}  // namespace illumap
