// irradiance_cache.hpp — the irradiance cache's per-receiver arithmetic (Ward et al. 1988):
// how much each nearby record counts at a receiver, and the value a receiver takes from the
// records valid there (illumap/irradiance_cache.py documents the rules and their constants).
#pragma once

#include "parallel.hpp"

#include <cstddef>
#include <cstdint>

namespace illumap {

// For receivers `rows` (r) and their K nearest records `near` (r x K, rows of points) at
// distances `dist` (r x K, m): each record's error measure
//   eps = dist / min(reach[record], own[receiver]) + sqrt(max(0, 1 - n_receiver . n_record)),
// valid where eps < accuracy and the receiver is not behind the record's surface by more
// than behind_slack x dist (along the mean of their normals); weight 1/max(eps, 1e-3 accuracy)
// - 1/accuracy where valid, 0 elsewhere. Writes weights and valid (r x K).
void record_weights(Context& ctx, const double* points, const double* normals,
                    const double* reach, const double* own, const std::int64_t* rows,
                    std::size_t r, const std::int64_t* near, const double* dist, std::size_t K,
                    double accuracy, double behind_slack, double* weights, std::uint8_t* valid);

// For receivers `rows` (r): the value (r x 3) of the plane fitted by weighted least squares
// (weights r x K) to the records' values (values[near], near r x K) over the records' offsets
// in the receiver's tangent plane, clamped to the range of the records with weight > 0; their
// weighted mean where fewer than three count or they do not span the plane (the scaled normal
// matrix's smallest eigenvalue at most 1e-3 of the weights' sum).
void fitted_values(Context& ctx, const double* points, const double* normals,
                   const double* values, const std::int64_t* rows, std::size_t r,
                   const std::int64_t* near, const double* weights, std::size_t K, double* out);

}  // namespace illumap
