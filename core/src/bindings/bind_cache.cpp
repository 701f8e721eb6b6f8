// bind_cache.cpp — illumap._core's irradiance cache: record_lookup (each receiver's nearest
// records and their weights) and fitted_values (the value a receiver takes from them).
#include "bindings/bindings.hpp"

#include "gather/irradiance_cache.hpp"

namespace illumap::bindings {

void bind_irradiance_cache(nb::module_& m) {
    // The receivers' rows and their records (rows of `points`), checked against its length.
    auto record_table = [](nb::handle rows, nb::handle near, std::size_t m, std::size_t& r,
                           std::size_t& K, nb::object keep[2]) {
        AnyArray shape_of;
        if (!nb::try_cast<AnyArray>(near, shape_of, false) || shape_of.ndim() != 2)
            throw nb::value_error("near must be a 2-D (R, K) numpy array");
        K = shape_of.shape(1);
        std::size_t rn;
        const std::int64_t* I = view<std::int64_t>(rows, "rows", 1, 0, r, keep[0]);
        const std::int64_t* J = view<std::int64_t>(near, "near", 2, std::int64_t(K), rn, keep[1]);
        if (rn != r) throw nb::value_error("near must have one row per receiver row");
        for (std::size_t i = 0; i < r; ++i)
            if (I[i] < 0 || std::size_t(I[i]) >= m) throw nb::value_error("rows out of range");
        for (std::size_t i = 0; i < r * K; ++i)
            if (J[i] < 0 || std::size_t(J[i]) >= m) throw nb::value_error("near out of range");
        return std::make_pair(I, J);
    };

    m.def("record_lookup",
          [](nb::handle points, nb::handle normals, nb::handle reach, nb::handle own,
             nb::handle raw, nb::handle records, nb::handle rows, std::int64_t k, double accuracy,
             double behind_slack, double min_reach, double far_reach, bool counts_only,
             int threads, nb::handle progress) {
              std::size_t m, sizes[3], nr, r;
              nb::object keep[7];
              const double* P = view<double>(points, "points", 2, 3, m, keep[0]);
              const double* N = view<double>(normals, "normals", 2, 3, sizes[0], keep[1]);
              const double* R = view<double>(reach, "reach", 1, 0, sizes[1], keep[2]);
              const double* O = view<double>(own, "own", 1, 0, sizes[2], keep[3]);
              const double* W = view<double>(raw, "raw", 1, 0, sizes[2], keep[4]);
              for (std::size_t z : sizes)
                  if (z != m) throw nb::value_error("points, normals, reach, own and raw must have the same length");
              const std::int64_t* J = view<std::int64_t>(records, "records", 1, 0, nr, keep[5]);
              const std::int64_t* I = view<std::int64_t>(rows, "rows", 1, 0, r, keep[6]);
              for (std::size_t i = 0; i < nr; ++i)
                  if (J[i] < 0 || std::size_t(J[i]) >= m) throw nb::value_error("records out of range");
              for (std::size_t i = 0; i < r; ++i)
                  if (I[i] < 0 || std::size_t(I[i]) >= m) throw nb::value_error("rows out of range");
              if (k < 1 || std::size_t(k) > nr) throw nb::value_error("k must be in [1, len(records)]");
              if (!(accuracy > 0)) throw nb::value_error("accuracy must be > 0");
              const std::size_t K = std::size_t(k);
              std::int32_t* count = new std::int32_t[std::max<std::size_t>(1, r)]();
              nb::capsule own_c(count, [](void* q) noexcept { delete[] static_cast<std::int32_t*>(q); });
              nb::ndarray<nb::numpy, std::int32_t> C(count, {r}, own_c);
              if (counts_only) {
                  run_released(threads, progress, [&](Context& ctx) {
                      checkpoint(ctx, 0.0);
                      record_lookup(ctx, P, N, R, O, W, min_reach, far_reach, J, nr, I, r, K,
                                    accuracy, behind_slack, nullptr, nullptr, count);
                  });
                  return nb::make_tuple(C);
              }
              std::int64_t* near = new std::int64_t[std::max<std::size_t>(1, r * K)]();
              nb::capsule own_n(near, [](void* q) noexcept { delete[] static_cast<std::int64_t*>(q); });
              nb::ndarray<nb::numpy, std::int64_t> NR(near, {r, K}, own_n);
              double* w;
              auto WT = new_array(r, K, &w);
              run_released(threads, progress, [&](Context& ctx) {
                  checkpoint(ctx, 0.0);
                  record_lookup(ctx, P, N, R, O, W, min_reach, far_reach, J, nr, I, r, K,
                                accuracy, behind_slack, near, w, count);
              });
              return nb::make_tuple(NR, WT, C);
          },
          nb::arg("points"), nb::arg("normals"), nb::arg("reach"), nb::arg("own"), nb::arg("raw"),
          nb::arg("records"), nb::arg("rows"), nb::arg("k"), nb::kw_only(), nb::arg("accuracy"),
          nb::arg("behind_slack"), nb::arg("min_reach") = 0.0, nb::arg("far_reach") = 0.0,
          nb::arg("counts_only") = false, nb::arg("threads") = 0, nb::arg("progress") = nb::none(),
          "Irradiance cache: each receiver's k nearest records (R, k) int64 rows, their weights "
          "(R, k) (0: not valid) and its count of valid ones (R,) int32; counts_only: (counts,). "
          "See irradiance_cache.hpp.");

    m.def("fitted_values",
          [record_table](nb::handle points, nb::handle normals, nb::handle values, nb::handle rows,
                         nb::handle near, nb::handle weights, int threads, nb::handle progress) {
              std::size_t m, sizes[2], r, K, rw;
              nb::object keep[5];
              const double* P = view<double>(points, "points", 2, 3, m, keep[0]);
              const double* N = view<double>(normals, "normals", 2, 3, sizes[0], keep[1]);
              const double* V = view<double>(values, "values", 2, 3, sizes[1], keep[2]);
              for (std::size_t z : sizes)
                  if (z != m) throw nb::value_error("points, normals and values must have the same length");
              nb::object kt[2];
              auto [I, J] = record_table(rows, near, m, r, K, kt);
              const double* W = view<double>(weights, "weights", 2, std::int64_t(K), rw, keep[3]);
              if (rw != r) throw nb::value_error("weights must have the shape of near");
              for (std::size_t i = 0; i < r; ++i) {
                  double sum = 0.0;
                  for (std::size_t k = 0; k < K; ++k) sum += W[i * K + k];
                  if (!(sum > 0)) throw nb::value_error("every receiver needs a positive weight sum");
              }
              double* out;
              auto O = new_array(r, 3, &out);
              run_released(threads, progress, [&](Context& ctx) {
                  checkpoint(ctx, 0.0);
                  fitted_values(ctx, P, N, V, I, r, J, W, K, out);
              });
              return O;
          },
          nb::arg("points"), nb::arg("normals"), nb::arg("values"), nb::arg("rows"), nb::arg("near"),
          nb::arg("weights"), nb::kw_only(), nb::arg("threads") = 0, nb::arg("progress") = nb::none(),
          "Irradiance cache: each receiver's value (R, 3) from its records' weighted plane fit. "
          "See irradiance_cache.hpp.");
}

}  // namespace illumap::bindings
