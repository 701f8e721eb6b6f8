// limits.hpp — the native core's limits on its inputs. The one table of every limit is
// core/python/illumap/limits.py; these constants are exposed as illumap._core.LIMITS, and
// illumap.operator refuses a native module whose LIMITS differ from that table.
#pragma once

#include <climits>
#include <string>

namespace illumap {

constexpr int kMaxOrder = 10;              // highest FMM expansion order
constexpr int kMaxVisibilitySamples = 4096;  // sampled point pairs per node pair
constexpr int kMaxCount = INT_MAX;         // counts (leaf size, threads, seed k...): a C int

// "order must be in 0..10"
inline std::string order_range_message() {
    return "order must be in 0.." + std::to_string(kMaxOrder);
}

}  // namespace illumap
