// irradiance_cache.cpp — see irradiance_cache.hpp.
#include "gather/irradiance_cache.hpp"

#include "geometry/sym3.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace illumap {

void record_weights(Context& ctx, const double* points, const double* normals,
                    const double* reach, const double* own, const std::int64_t* rows,
                    std::size_t r, const std::int64_t* near, const double* dist, std::size_t K,
                    double accuracy, double behind_slack, double* weights, std::uint8_t* valid) {
    const double floor_eps = 1e-3 * accuracy;
    parallel_for(ctx, r, 4096, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
            const std::int64_t me = rows[i];
            const double* q = points + 3 * me;
            const double* nq = normals + 3 * me;
            for (std::size_t k = 0; k < K; ++k) {
                const std::size_t at = i * K + k;
                const std::int64_t j = near[at];
                const double* pj = points + 3 * j;
                const double* nj = normals + 3 * j;
                const double d = dist[at];
                const double cos = nq[0] * nj[0] + nq[1] * nj[1] + nq[2] * nj[2];
                const double eps = d / std::min(reach[j], own[me]) + std::sqrt(std::max(0.0, 1.0 - cos));
                double lift = 0.0;
                for (int c = 0; c < 3; ++c) lift += (q[c] - pj[c]) * (0.5 * (nq[c] + nj[c]));
                const bool ok = eps < accuracy && lift >= -behind_slack * d;
                valid[at] = ok ? 1 : 0;
                weights[at] = ok ? 1.0 / std::max(eps, floor_eps) - 1.0 / accuracy : 0.0;
            }
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
