// bind_tools.cpp — illumap._core._kernel_derivatives, knn and orient_normals.
#include "bindings.hpp"

#include "knn.hpp"
#include "normals.hpp"

namespace illumap::bindings {

void bind_kernel(nb::module_& m) {
    m.def("_kernel_derivatives",
          [](nb::handle d, int order) {
              std::size_t n3;
              nb::object keep;
              const double* dv = view<double>(d, "d", 1, 0, n3, keep);
              if (n3 != 3) throw nb::value_error("d must have shape (3,)");
              if (order < 0 || order > kMaxOrder) throw nb::value_error(order_range_message().c_str());
              ExpansionTables tb(order);
              const std::size_t nc = tb.ncoef;
              std::int64_t* mi = new std::int64_t[3 * nc];
              nb::capsule own(mi, [](void* q) noexcept { delete[] static_cast<std::int64_t*>(q); });
              for (std::size_t c = 0; c < nc; ++c)
                  for (int a = 0; a < 3; ++a) mi[3 * c + a] = tb.mi[c][a];
              nb::ndarray<nb::numpy, std::int64_t> MI(mi, {nc, 3}, own);
              double* D;
              auto out = new_array(nc, 6, &D);
              std::vector<double> work(expansion_work_size(tb));
              kernel_derivatives(tb, dv, D, work.data());
              return nb::make_tuple(MI, out);
          },
          nb::arg("d"), nb::arg("order"),
          "Testing aid: multi-indices n (|n| <= order) and D^n T(d), components "
          "(xx, xy, xz, yy, yz, zz), for T(d) = d d^T / |d|^4.");
    m.def("_m2l4_check",
          [](nb::handle R, nb::handle M, nb::handle w, int order) {
              if (order < 0 || order > kMaxOrder) throw nb::value_error(order_range_message().c_str());
              ExpansionTables tb(order);
              const std::size_t W = 9 * std::size_t(tb.ncoef);
              std::size_t nr, nm, nw;
              nb::object k1, k2, k3;
              const double* Rv = view<double>(R, "R", 2, 3, nr, k1);
              const double* Mv = view<double>(M, "M", 2, W, nm, k2);
              const double* wv = view<double>(w, "w", 1, 0, nw, k3);
              if (nr != 4 || nm != 4 || nw != 4)
                  throw nb::value_error("R, M and w must hold four sources");
              double R4[4][3];
              const double* M4[4];
              for (int q = 0; q < 4; ++q) {
                  for (int d = 0; d < 3; ++d) R4[q][d] = Rv[3 * q + d];
                  M4[q] = Mv + q * W;
              }
              double *L4, *Ls;
              auto a = new_array(W / 9, 9, &L4);
              auto b = new_array(W / 9, 9, &Ls);
              std::fill(L4, L4 + W, 0.0);
              std::fill(Ls, Ls + W, 0.0);
              std::vector<double> work(expansion_work_size(tb)), scaled(W);
              m2l4(tb, R4, M4, L4, work.data(), wv);
              for (int q = 0; q < 4; ++q) {
                  for (std::size_t c = 0; c < W; ++c) scaled[c] = wv[q] * M4[q][c];
                  m2l(tb, R4[q], scaled.data(), Ls, work.data());
              }
              return nb::make_tuple(a, b);
          },
          nb::arg("R"), nb::arg("M"), nb::arg("w"), nb::arg("order"),
          "Testing aid: the local expansion (ncoef x 9) of four weighted sources (R: 4 x 3 "
          "target-minus-source offsets, M: 4 x 9 ncoef multipoles, w: 4 weights) by m2l4 and by "
          "the sum of four m2l.");
}

void bind_point_tools(nb::module_& m) {
    m.def("knn",
          [](nb::handle points, nb::handle queries, std::int64_t k, int threads, nb::handle progress) {
              std::size_t n, mq;
              nb::object k1, k2;
              const double* P = view<double>(points, "points", 2, 3, n, k1);
              const double* Q = view<double>(queries, "queries", 2, 3, mq, k2);
              if (k < 1) throw nb::value_error("k must be >= 1");
              if (std::size_t(k) > n)
                  throw nb::value_error(("k = " + std::to_string(k) + " exceeds the number of points (" +
                                         std::to_string(n) + ")").c_str());
              std::int64_t* idx = new std::int64_t[std::max<std::size_t>(1, mq * k)]();
              nb::capsule own_i(idx, [](void* q) noexcept { delete[] static_cast<std::int64_t*>(q); });
              nb::ndarray<nb::numpy, std::int64_t> I(idx, {mq, std::size_t(k)}, own_i);
              double* dist;
              auto D = new_array(mq, std::size_t(k), &dist);
              run_released(threads, progress, [&](Context& ctx) {
                  ctx.set_phase("knn", 0.0, 1.0);
                  checkpoint(ctx, 0.0);
                  knn(ctx, P, n, Q, mq, std::size_t(k), idx, dist);
              });
              return nb::make_tuple(I, D);
          },
          nb::arg("points"), nb::arg("queries"), nb::arg("k"), nb::kw_only(),
          nb::arg("threads") = 0, nb::arg("progress") = nb::none(),
          "k nearest points for each query: (indices int64 (M, k), distances float64 (M, k)), "
          "nearest first.");

    m.def("orient_normals",
          [](nb::handle points, nb::handle normals, nb::handle neighbours, int threads,
             nb::handle progress) {
              std::size_t n, nn, nk;
              nb::object k1, k2, k3;
              AnyArray shape_of;
              if (!nb::try_cast<AnyArray>(neighbours, shape_of, false) || shape_of.ndim() != 2)
                  throw nb::value_error("neighbours must be a 2-D (N, k) numpy array");
              const std::int64_t k = std::int64_t(shape_of.shape(1));
              const double* P = view<double>(points, "points", 2, 3, n, k1);
              const double* N = view<double>(normals, "normals", 2, 3, nn, k2);
              const std::int64_t* I = view<std::int64_t>(neighbours, "neighbours", 2, k, nk, k3);
              if (nn != n || nk != n)
                  throw nb::value_error("points, normals and neighbours must have the same length");
              double* out;
              auto O = new_array(n, 3, &out);
              std::copy(N, N + 3 * n, out);
              std::int64_t* part = new std::int64_t[std::max<std::size_t>(1, n)]();
              nb::capsule own_p(part, [](void* q) noexcept { delete[] static_cast<std::int64_t*>(q); });
              nb::ndarray<nb::numpy, std::int64_t> L(part, {n}, own_p);
              run_released(threads, progress, [&](Context& ctx) {
                  orient_normals(ctx, P, out, n, I, std::size_t(k), part);
              });
              return nb::make_tuple(O, L);
          },
          nb::arg("points"), nb::arg("normals"), nb::arg("neighbours"), nb::kw_only(),
          nb::arg("threads") = 0, nb::arg("progress") = nb::none(),
          "Unit normals (N, 3) flipped to agree along the neighbour graph (N, k): (normals, "
          "connected part of each point int64 (N,)); each part keeps its first point's sign. "
          "See normals.hpp.");
}

}  // namespace illumap::bindings
