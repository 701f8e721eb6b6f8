// sym3.hpp — eigen-decomposition of a symmetric 3x3 matrix (cyclic Jacobi).
//
// Jacobi rotations converge quadratically and keep the eigenvectors orthonormal to rounding,
// also where two eigenvalues nearly coincide; a 3x3 takes a handful of sweeps. The point
// cloud's plane fits need the smallest eigenvector of a covariance per point.
#pragma once

#include <cmath>
#include <utility>

namespace illumap {

struct Sym3Eigen {
    double values[3];      // ascending
    double vectors[3][3];  // vectors[i]: the unit eigenvector of values[i]
};

inline Sym3Eigen sym3_eigen(const double m[3][3]) {
    double a[3][3], v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) a[i][j] = 0.5 * (m[i][j] + m[j][i]);
    static const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    for (int sweep = 0; sweep < 64; ++sweep) {
        const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        const double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if (!(off > 1e-34 * diag)) break;   // also ends on off == 0 and on NaN
        for (const auto& pq : pairs) {
            const int p = pq[0], q = pq[1];
            const double apq = a[p][q];
            if (apq == 0.0) continue;
            // The rotation (c, s) in the (p, q) plane that zeroes a[p][q] (the smaller angle).
            const double theta = (a[q][q] - a[p][p]) / (2.0 * apq);
            const double t = (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
            const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
            for (int k = 0; k < 3; ++k) {  // A <- A J
                const double akp = a[k][p], akq = a[k][q];
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for (int k = 0; k < 3; ++k) {  // A <- J^T A
                const double apk = a[p][k], aqk = a[q][k];
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            a[p][q] = a[q][p] = 0.0;
            for (int k = 0; k < 3; ++k) {  // V <- V J
                const double vkp = v[k][p], vkq = v[k][q];
                v[k][p] = c * vkp - s * vkq;
                v[k][q] = s * vkp + c * vkq;
            }
        }
    }
    int order[3] = {0, 1, 2};
    if (a[order[1]][order[1]] < a[order[0]][order[0]]) std::swap(order[0], order[1]);
    if (a[order[2]][order[2]] < a[order[1]][order[1]]) std::swap(order[1], order[2]);
    if (a[order[1]][order[1]] < a[order[0]][order[0]]) std::swap(order[0], order[1]);
    Sym3Eigen out;
    for (int i = 0; i < 3; ++i) {
        out.values[i] = a[order[i]][order[i]];
        for (int k = 0; k < 3; ++k) out.vectors[i][k] = v[k][order[i]];
    }
    return out;
}

}  // namespace illumap
