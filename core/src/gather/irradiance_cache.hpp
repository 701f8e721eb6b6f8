// irradiance_cache.hpp — the irradiance cache's per-receiver arithmetic (Ward et al. 1988):
// how much each nearby record counts at a receiver, and the value a receiver takes from the
// records valid there (illumap/irradiance_cache.py documents the rules and their constants).
#pragma once

#include "parallel.hpp"

#include <cstddef>
#include <cstdint>

namespace illumap {

// The records near receivers, in one pass: for receivers `rows` (r), their K nearest of the
// records `records` (nr rows of points, K <= nr; a kd-tree over the records' positions, as
// knn finds them) at distances d, and each one's error measure
//   eps = d / min(reach[record], own[receiver]) + sqrt(max(0, 1 - n_receiver . n_record)),
// valid where eps < accuracy and the receiver is not behind the record's surface by more
// than behind_slack x d (along the mean of their normals); weight 1/max(eps, 1e-3 accuracy)
// - 1/accuracy where valid, 0 elsewhere. Where min_reach > 0, a record is also not valid
// when its reach before the floor (raw) and the receiver's lie on different sides of it: one
// below min_reach, the other at or beyond far_reach. Writes any of near (r x K, rows of
// points), weights (r x K) and counts (r: valid records per receiver) that is not null.
void record_lookup(Context& ctx, const double* points, const double* normals,
                   const double* reach, const double* own, const double* raw, double min_reach,
                   double far_reach, const std::int64_t* records, std::size_t nr,
                   const std::int64_t* rows, std::size_t r, std::size_t K, double accuracy,
                   double behind_slack, std::int64_t* near, double* weights,
                   std::int32_t* counts);

// For receivers `rows` (r): the value (r x 3) of the plane fitted by weighted least squares
// (weights r x K) to the records' values (values[near], near r x K) over the records' offsets
// in the receiver's tangent plane, clamped to the range of the records with weight > 0; their
// weighted mean where fewer than three count or they do not span the plane (the scaled normal
// matrix's smallest eigenvalue at most 1e-3 of the weights' sum).
void fitted_values(Context& ctx, const double* points, const double* normals,
                   const double* values, const std::int64_t* rows, std::size_t r,
                   const std::int64_t* near, const double* weights, std::size_t K, double* out);

}  // namespace illumap
