// normals.hpp — normals of a point cloud: plane fits over each point's neighbours, and a
// consistent orientation of the unoriented result.
#pragma once

#include "parallel.hpp"

#include <cstdint>

namespace illumap {

// Flips normals (n x 3, unit, in place) so that neighbours agree (Hoppe et al. 1992): the
// minimum spanning forest of the neighbour graph, weighted by 1 - |n_i . n_j| (ties: shorter
// edges first), carries each sign to the next point along the smoothest path, so a thin
// sheet's two sides and a concave fold keep their own sides. Each tree keeps its first
// point's sign; `part` (n) receives the tree's index, so the caller can choose each part's
// global sign. neighbours: n x k indices (i itself and entries outside [0, n) are skipped).
// Returns the number of connected parts.
std::size_t orient_normals(Context& ctx, const double* points, double* normals, std::size_t n,
                           const std::int64_t* neighbours, std::size_t k, std::int64_t* part);

// The plane fits below take each point's neighbours as rows of `neighbours` (n x k, point
// indices; the first column is the point itself or a point at its place, as a k-NN query of
// the cloud against itself returns). Each writes unit normals (n x 3), sign arbitrary unless
// said otherwise. Both threads work; progress and cancellation go through ctx.

// PCA: the smallest eigenvector of the covariance of all k neighbours (about their mean).
void covariance_normals(Context& ctx, const double* points, std::size_t n,
                        const std::int64_t* neighbours, std::size_t k, double* out);

struct PlaneFitOptions {
    double inlier = 0.2;   // on a plane within this fraction of the median neighbour distance
    double share = 0.5;    // fewer of the neighbours than this share on the best plane: PCA
    double spread = 0.05;  // the chosen neighbours' 2nd variance below this share of the 1st: PCA
};

// The plane that most neighbours lie on: each pair of neighbours (columns 1..k-1) proposes
// the plane through it and the point; the one with the most neighbours within
// `inlier` x their median distance wins (the smaller clamped distance sum breaks ties, the
// first pair after that), and a PCA over the point and those neighbours gives the normal.
// Where no plane holds `share` of the neighbours, or its neighbours lie nearly on a line, all
// of them count (plain PCA about their mean).
void plane_normals(Context& ctx, const double* points, std::size_t n,
                   const std::int64_t* neighbours, std::size_t k, const PlaneFitOptions& options,
                   double* out);

struct SettleOptions {
    double same_cos = 0.9;    // neighbours on the point's surface: |n_i . n_j| above this
    std::size_t min_points = 4;  // ... at least this many (the point included), else keep n_i
    double on_a_line = 0.05;  // their 2nd spread below this share of the 1st: keep n_i
};

// Each normal refitted as the plane through the point and its neighbours on the same surface
// (normals within acos(same_cos)), not centred: the plane passes through the point. Oriented
// as the given normal.
void settled_normals(Context& ctx, const double* points, const double* normals, std::size_t n,
                     const std::int64_t* neighbours, std::size_t k, const SettleOptions& options,
                     double* out);

}  // namespace illumap
