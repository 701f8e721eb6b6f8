// irradiance_cache.cpp — see irradiance_cache.hpp.
#include "gather/irradiance_cache.hpp"

#include "geometry/knn.hpp"
#include "geometry/sym3.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace illumap {

namespace {

// Record j's weight at receiver me at distance d (0 where not valid; irradiance_cache.hpp).
inline double record_weight(const double* points, const double* normals, const double* reach,
                            const double* own, std::int64_t me, std::int64_t j, double d,
                            double accuracy, double behind_slack, bool& ok) {
    const double* q = points + 3 * me;
    const double* nq = normals + 3 * me;
    const double* pj = points + 3 * j;
    const double* nj = normals + 3 * j;
    const double cos = nq[0] * nj[0] + nq[1] * nj[1] + nq[2] * nj[2];
    const double eps = d / std::min(reach[j], own[me]) + std::sqrt(std::max(0.0, 1.0 - cos));
    double lift = 0.0;
    for (int c = 0; c < 3; ++c) lift += (q[c] - pj[c]) * (0.5 * (nq[c] + nj[c]));
    ok = eps < accuracy && lift >= -behind_slack * d;
    return ok ? 1.0 / std::max(eps, 1e-3 * accuracy) - 1.0 / accuracy : 0.0;
}

}  // namespace

void record_lookup(Context& ctx, const double* points, const double* normals,
                   const double* reach, const double* own, const double* raw, double min_reach,
                   double far_reach, const std::int64_t* records, std::size_t nr,
                   const std::int64_t* rows, std::size_t r, std::size_t K, double accuracy,
                   double behind_slack, std::int64_t* near, double* weights,
                   std::int32_t* counts) {
    if (r == 0 || K == 0) return;
    std::vector<double> at(3 * nr), q(3 * r);
    for (std::size_t i = 0; i < nr; ++i)
        for (int c = 0; c < 3; ++c) at[3 * i + c] = points[3 * records[i] + c];
    for (std::size_t i = 0; i < r; ++i)
        for (int c = 0; c < 3; ++c) q[3 * i + c] = points[3 * rows[i] + c];
    const KdTree tree(ctx, at.data(), nr);
    const std::vector<std::size_t> order = morton_order(q.data(), r);
    const bool floored = raw != nullptr && min_reach > 0;
    parallel_for(ctx, r, 1024, [&](std::size_t b, std::size_t e) {
        KdTree::Best best(K);
        for (std::size_t oi = b; oi < e; ++oi) {
            const std::size_t i = order[oi];
            const std::int64_t me = rows[i];
            tree.nearest(&q[3 * i], best);
            std::int32_t count = 0;
            for (std::size_t k = 0; k < K; ++k) {
                const std::int64_t j = records[best.h[k].second];
                bool ok;
                double w = record_weight(points, normals, reach, own, me, j,
                                         std::sqrt(best.h[k].first), accuracy, behind_slack, ok);
                // A receiver near its surroundings and a record far from them (or the other
                // way round) see different light, whatever the floor says.
                if (ok && floored &&
                    ((raw[me] < min_reach && raw[j] >= far_reach) ||
                     (raw[me] >= far_reach && raw[j] < min_reach))) {
                    ok = false;
                    w = 0.0;
                }
                const std::size_t cell = i * K + k;
                if (near) near[cell] = j;
                if (weights) weights[cell] = w;
                count += ok ? 1 : 0;
            }
            if (counts) counts[i] = count;
        }
    });
}

namespace {

// Solves the symmetric positive definite 3x3 system a x = b for the first unknown of each of
// three right-hand sides (b: 3 x 3, column c the channel), by Gaussian elimination with
// partial pivoting.
void solve3_first(const double a_in[3][3], const double b_in[3][3], double out[3]) {
    double a[3][4 + 2];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) a[i][j] = a_in[i][j];
        for (int c = 0; c < 3; ++c) a[i][3 + c] = b_in[i][c];
    }
    for (int col = 0; col < 3; ++col) {
        int piv = col;
        for (int i = col + 1; i < 3; ++i)
            if (std::fabs(a[i][col]) > std::fabs(a[piv][col])) piv = i;
        if (piv != col)
            for (int j = 0; j < 6; ++j) std::swap(a[col][j], a[piv][j]);
        for (int i = col + 1; i < 3; ++i) {
            const double f = a[i][col] / a[col][col];
            for (int j = col; j < 6; ++j) a[i][j] -= f * a[col][j];
        }
    }
    for (int c = 0; c < 3; ++c) {
        double x[3];
        for (int i = 2; i >= 0; --i) {
            double s = a[i][3 + c];
            for (int j = i + 1; j < 3; ++j) s -= a[i][j] * x[j];
            x[i] = s / a[i][i];
        }
        out[c] = x[0];
    }
}

}  // namespace

void fitted_values(Context& ctx, const double* points, const double* normals,
                   const double* values, const std::int64_t* rows, std::size_t r,
                   const std::int64_t* near, const double* weights, std::size_t K, double* out) {
    parallel_for(ctx, r, 2048, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
            const std::int64_t me = rows[i];
            const double* q = points + 3 * me;
            const double* nq = normals + 3 * me;
            const std::int64_t* nb = near + i * K;
            const double* w = weights + i * K;
            double* o = out + 3 * i;
            double wsum = 0.0, mean[3] = {0, 0, 0};
            double low[3], high[3];
            int counted = 0;
            for (int c = 0; c < 3; ++c) {
                low[c] = std::numeric_limits<double>::infinity();
                high[c] = -std::numeric_limits<double>::infinity();
            }
            for (std::size_t k = 0; k < K; ++k) {
                const double* v = values + 3 * nb[k];
                wsum += w[k];
                for (int c = 0; c < 3; ++c) mean[c] += w[k] * v[c];
                if (w[k] > 0) {
                    ++counted;
                    for (int c = 0; c < 3; ++c) {
                        low[c] = std::min(low[c], v[c]);
                        high[c] = std::max(high[c], v[c]);
                    }
                }
            }
            // The mean too stays in the records' range (its rounding could leave it).
            for (int c = 0; c < 3; ++c)
                o[c] = counted ? std::min(std::max(mean[c] / wsum, low[c]), high[c]) : mean[c] / wsum;
            if (counted < 3) continue;
            // The tangent plane's axes: u from the axis least along the normal.
            const double helper[3] = {std::fabs(nq[0]) < 0.9 ? 1.0 : 0.0,
                                      std::fabs(nq[0]) < 0.9 ? 0.0 : 1.0, 0.0};
            double u[3] = {nq[1] * helper[2] - nq[2] * helper[1], nq[2] * helper[0] - nq[0] * helper[2],
                           nq[0] * helper[1] - nq[1] * helper[0]};
            const double ul = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
            for (double& x : u) x /= ul;
            const double v_ax[3] = {nq[1] * u[2] - nq[2] * u[1], nq[2] * u[0] - nq[0] * u[2],
                                    nq[0] * u[1] - nq[1] * u[0]};
            double spread = 0.0;
            for (std::size_t k = 0; k < K; ++k) {
                const double* pk = points + 3 * nb[k];
                double d2 = 0.0;
                for (int c = 0; c < 3; ++c) d2 += (pk[c] - q[c]) * (pk[c] - q[c]);
                spread += w[k] * d2;
            }
            double scale = std::sqrt(spread / wsum);
            if (!(scale > 0)) scale = 1.0;
            double normal[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, rhs[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
            for (std::size_t k = 0; k < K; ++k) {
                const double* pk = points + 3 * nb[k];
                const double* vk = values + 3 * nb[k];
                double du = 0.0, dv = 0.0;
                for (int c = 0; c < 3; ++c) {
                    du += (pk[c] - q[c]) * u[c];
                    dv += (pk[c] - q[c]) * v_ax[c];
                }
                const double design[3] = {1.0, du / scale, dv / scale};
                for (int a = 0; a < 3; ++a) {
                    for (int bb = 0; bb < 3; ++bb) normal[a][bb] += w[k] * design[a] * design[bb];
                    for (int c = 0; c < 3; ++c) rhs[a][c] += w[k] * design[a] * vk[c];
                }
            }
            if (!(sym3_eigen(normal).values[0] > 1e-3 * wsum)) continue;
            double fit[3];
            solve3_first(normal, rhs, fit);
            for (int c = 0; c < 3; ++c) o[c] = std::min(std::max(fit[c], low[c]), high[c]);
        }
    });
}

}  // namespace illumap
