// octree.hpp — adaptive octree over surfels with the per-node bounds the traversal needs.
//
// Surfels are reordered into tree order so every node owns a contiguous range.
// Per node: bounding sphere (centre = centre of the points' box, radius tight over points),
// normal cone (axis, half-angle, and the chord bound max |n - axis|), the slab
// [min, max] of axis.(r - centre) over its points (zero width for a flat patch: this is what
// lets coplanar node pairs be dropped), and the largest surfel area.
#pragma once

#include "transport/kernel.hpp"
#include "parallel.hpp"

#include <cstdint>
#include <vector>

namespace illumap {

struct OctreeNode {
    std::uint32_t begin = 0, end = 0;  // surfel range in tree order
    std::int32_t child = -1;           // first child (children are contiguous); -1: leaf
    std::int32_t nchild = 0;
    std::int32_t parent = -1;
    std::int32_t level = 0;
    double center[3] = {0, 0, 0};
    double radius = 0;
    double half[3] = {0, 0, 0};  // half-extents of the points' box (centre = center)
    double axis[3] = {0, 0, 1};
    double cone_chord = 0;  // max over points of |n - axis|
    double cone_angle = 0;  // half-angle, 2 asin(chord / 2)
    double slab_lo = 0, slab_hi = 0;
    double amax = 0;
    bool leaf() const { return child < 0; }
    std::uint32_t count() const { return end - begin; }
};

struct Octree {
    std::vector<OctreeNode> nodes;               // node 0 is the root; BFS order
    std::vector<std::vector<std::int32_t>> levels;  // node ids per level
    std::vector<std::int32_t> leaves;
    std::vector<std::uint32_t> perm;  // tree position -> caller's index
    SurfelSoA s;                      // surfels in tree order
    int depth = 0;
    std::size_t bytes() const;
};

// Builds the tree; leaves hold at most leaf_size surfels unless they are coincident (or 60
// levels deep). Below the root's split by normal bin, every node is split by the octants of
// its own points' box, so a node's subtree depends on its points (and their relative order)
// alone: surfels far away, or added elsewhere in the input, leave a cluster's cells as they
// are.
Octree build_octree(Context& ctx, const SurfelSoA& orig, int leaf_size);

// A total order of nodes that surfels elsewhere in the tree do not change: by first tree
// position, an ancestor before its descendants. (Node ids are breadth first: a far object
// adds a level above a cluster and reorders its ids against the others'; tree positions only
// shift.) Rules that need a canonical order of two nodes use it (the mutual walk, radius ties,
// visibility samples), so that a cluster's interactions do not depend on the rest.
inline bool node_before(const OctreeNode& a, const OctreeNode& b) {
    return a.begin != b.begin ? a.begin < b.begin : a.end > b.end;
}

}  // namespace illumap
