// bind_tools.cpp — illumap._core._kernel_derivatives, knn, the point clouds' normals
// (plane fits, orient_normals) and splat_radii (the irradiance cache's: bind_cache.cpp).
#include "bindings/bindings.hpp"

#include <nanobind/stl/vector.h>

#include "geometry/knn.hpp"
#include "gather/lamp_samples.hpp"
#include "geometry/normals.hpp"
#include "splats/splat_frames.hpp"
#include "splats/splat_shading.hpp"
#include "splats/splats.hpp"

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

namespace {

// A checked (n, k) int64 neighbour table of any k.
const std::int64_t* neighbour_table(nb::handle h, std::size_t n, std::size_t& k, nb::object& keep) {
    AnyArray shape_of;
    if (!nb::try_cast<AnyArray>(h, shape_of, false) || shape_of.ndim() != 2)
        throw nb::value_error("neighbours must be a 2-D (N, k) numpy array");
    k = shape_of.shape(1);
    std::size_t rows;
    const std::int64_t* I = view<std::int64_t>(h, "neighbours", 2, std::int64_t(k), rows, keep);
    if (rows != n)
        throw nb::value_error(("neighbours must have one row per point (" + std::to_string(n) +
                               "), got " + std::to_string(rows)).c_str());
    return I;
}

// Normals (N, 3) that fit(ctx, points, n, neighbours, k, out) computes without the GIL.
template <class Fit>
nb::ndarray<nb::numpy, double> fitted_normals(nb::handle points, nb::handle neighbours,
                                              int threads, nb::handle progress, Fit&& fit) {
    std::size_t n, k;
    nb::object k1, k2;
    const double* P = view<double>(points, "points", 2, 3, n, k1);
    const std::int64_t* I = neighbour_table(neighbours, n, k, k2);
    double* out;
    auto O = new_array(n, 3, &out);
    run_released(threads, progress, [&](Context& ctx) {
        checkpoint(ctx, 0.0);
        fit(ctx, P, n, I, k, out);
    });
    return O;
}

}  // namespace

void bind_lamp_samples(nb::module_& m) {
    m.def("lamp_samples",
          [](const std::string& kind, nb::handle points, nb::handle normals, nb::handle shifts,
             std::int64_t k, double far, std::vector<double> position,
             std::vector<double> direction, std::vector<double> axes, double radius,
             double angle, bool disk, nb::handle corner, nb::handle edge1, nb::handle edge2,
             nb::handle normal, nb::handle cumulative, nb::handle power, bool two_sided,
             int threads, nb::handle progress) {
              LampShape L;
              static const std::pair<const char*, LampKind> kinds[] = {
                  {"WORLD", LampKind::World}, {"SUN", LampKind::Sun}, {"MESH", LampKind::Mesh},
                  {"AREA", LampKind::Area}, {"POINT", LampKind::Point}, {"SPOT", LampKind::Point}};
              bool known = false;
              for (const auto& kv : kinds)
                  if (kind == kv.first) L.kind = kv.second, known = true;
              if (!known) throw nb::value_error(("unknown lamp kind '" + kind + "'").c_str());
              if (position.size() != 3 || direction.size() != 3 || axes.size() != 6)
                  throw nb::value_error("position and direction need 3 values, axes 6");
              for (int c = 0; c < 3; ++c) {
                  L.position[c] = position[c];
                  L.direction[c] = direction[c];
                  L.axes[0][c] = axes[c];
                  L.axes[1][c] = axes[3 + c];
              }
              L.radius = radius;
              L.angle = angle;
              L.disk = disk;
              L.two_sided = two_sided;
              if (k < 1) throw nb::value_error("k must be >= 1");
              std::size_t m, rows[2];
              nb::object keep[9];
              const double* P = view<double>(points, "points", 2, 3, m, keep[0]);
              const double* N = view<double>(normals, "normals", 2, 3, rows[0], keep[1]);
              const double* S = view<double>(shifts, "shifts", 2, 2, rows[1], keep[2]);
              if (rows[0] != m || rows[1] != m)
                  throw nb::value_error("points, normals and shifts must have the same length");
              if (L.kind == LampKind::Mesh) {
                  std::size_t t[6];
                  L.corner = view<double>(corner, "corner", 2, 3, t[0], keep[3]);
                  L.edge1 = view<double>(edge1, "edge1", 2, 3, t[1], keep[4]);
                  L.edge2 = view<double>(edge2, "edge2", 2, 3, t[2], keep[5]);
                  L.normal = view<double>(normal, "normal", 2, 3, t[3], keep[6]);
                  L.cumulative = view<double>(cumulative, "cumulative", 1, 0, t[4], keep[7]);
                  L.power = view<double>(power, "power", 1, 0, t[5], keep[8]);
                  for (std::size_t x : t)
                      if (x != t[0]) throw nb::value_error("a mesh lamp's arrays must have one row per triangle");
                  if (t[0] == 0) throw nb::value_error("a mesh lamp needs triangles");
                  L.triangles = t[0];
              }
              double* data = new double[std::max<std::size_t>(1, m * std::size_t(k) * 3)]();
              nb::capsule owner(data, [](void* q) noexcept { delete[] static_cast<double*>(q); });
              nb::ndarray<nb::numpy, double> T(data, {m, std::size_t(k), 3}, owner);
              double* w;
              auto W = new_array(m, std::size_t(k), &w);
              run_released(threads, progress, [&](Context& ctx) {
                  checkpoint(ctx, 0.0);
                  lamp_samples(ctx, L, P, N, S, m, std::size_t(k), far, data, w);
              });
              return nb::make_tuple(T, W);
          },
          nb::arg("kind"), nb::arg("points"), nb::arg("normals"), nb::arg("shifts"),
          nb::arg("k"), nb::arg("far"), nb::kw_only(), nb::arg("position"), nb::arg("direction"),
          nb::arg("axes"), nb::arg("radius") = 0.0, nb::arg("angle") = 0.0,
          nb::arg("disk") = false, nb::arg("corner") = nb::none(), nb::arg("edge1") = nb::none(),
          nb::arg("edge2") = nb::none(), nb::arg("normal") = nb::none(),
          nb::arg("cumulative") = nb::none(), nb::arg("power") = nb::none(),
          nb::arg("two_sided") = false, nb::arg("threads") = 0, nb::arg("progress") = nb::none(),
          "Shadow-ray targets (M, k, 3) in m on a lamp and their unshadowed weights (M, k) for "
          "receivers (M, 3) with normals (M, 3), the lattice shifted per receiver by shifts "
          "(M, 2). See lamp_samples.hpp.");
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

    m.def("covariance_normals",
          [](nb::handle points, nb::handle neighbours, int threads, nb::handle progress) {
              return fitted_normals(points, neighbours, threads, progress,
                                    [](Context& ctx, const double* P, std::size_t n,
                                       const std::int64_t* I, std::size_t k, double* out) {
                                        covariance_normals(ctx, P, n, I, k, out);
                                    });
          },
          nb::arg("points"), nb::arg("neighbours"), nb::kw_only(), nb::arg("threads") = 0,
          nb::arg("progress") = nb::none(),
          "Unit normals (N, 3), sign arbitrary: the smallest eigenvector of the covariance of "
          "each point's neighbours (N, k), about their mean. See normals.hpp.");

    m.def("plane_normals",
          [](nb::handle points, nb::handle neighbours, double inlier, double share, double spread,
             int threads, nb::handle progress) {
              const PlaneFitOptions options{inlier, share, spread};
              return fitted_normals(points, neighbours, threads, progress,
                                    [&](Context& ctx, const double* P, std::size_t n,
                                        const std::int64_t* I, std::size_t k, double* out) {
                                        plane_normals(ctx, P, n, I, k, options, out);
                                    });
          },
          nb::arg("points"), nb::arg("neighbours"), nb::kw_only(), nb::arg("inlier"),
          nb::arg("share"), nb::arg("spread"), nb::arg("threads") = 0,
          nb::arg("progress") = nb::none(),
          "Unit normals (N, 3), sign arbitrary, of the plane through each point that most of "
          "its neighbours (N, k; the first column the point itself) lie on. See normals.hpp.");

    m.def("settled_normals",
          [](nb::handle points, nb::handle normals, nb::handle neighbours, double same_cos,
             std::int64_t min_points, double on_a_line, int threads, nb::handle progress) {
              std::size_t n, nn, k;
              nb::object k1, k2, k3;
              const double* P = view<double>(points, "points", 2, 3, n, k1);
              const double* N = view<double>(normals, "normals", 2, 3, nn, k2);
              if (nn != n) throw nb::value_error("points and normals must have the same length");
              const std::int64_t* I = neighbour_table(neighbours, n, k, k3);
              double* out;
              auto O = new_array(n, 3, &out);
              const SettleOptions options{same_cos, std::size_t(std::max<std::int64_t>(min_points, 0)),
                                          on_a_line};
              run_released(threads, progress, [&](Context& ctx) {
                  checkpoint(ctx, 0.0);
                  settled_normals(ctx, P, N, n, I, k, options, out);
              });
              return O;
          },
          nb::arg("points"), nb::arg("normals"), nb::arg("neighbours"), nb::kw_only(),
          nb::arg("same_cos"), nb::arg("min_points"), nb::arg("on_a_line"),
          nb::arg("threads") = 0, nb::arg("progress") = nb::none(),
          "Normals (N, 3) refitted as the plane through each point and its neighbours on the "
          "same surface, oriented as given. See normals.hpp.");

    m.def("splat_radii",
          [](nb::handle points, nb::handle normals, nb::handle u, nb::handle v, nb::handle reach,
             nb::handle rim, nb::handle neighbours, std::int64_t sides, double corner_slack,
             double edge_cos, double rim_cos, double junction_tolerance, double edge_overlap,
             int threads, nb::handle progress) {
              std::size_t n, k, rows[5];
              nb::object keep[7];
              const double* P = view<double>(points, "points", 2, 3, n, keep[0]);
              const double* N = view<double>(normals, "normals", 2, 3, rows[0], keep[1]);
              const double* U = view<double>(u, "u", 2, 3, rows[1], keep[2]);
              const double* V = view<double>(v, "v", 2, 3, rows[2], keep[3]);
              const double* R = view<double>(reach, "reach", 1, 0, rows[3], keep[4]);
              const double* E = view<double>(rim, "rim", 1, 0, rows[4], keep[5]);
              for (std::size_t r : rows)
                  if (r != n)
                      throw nb::value_error("points, normals, u, v, reach and rim must have the same length");
              if (sides < 1) throw nb::value_error("sides must be >= 1");
              const std::int64_t* I = neighbour_table(neighbours, n, k, keep[6]);
              double* out;
              auto O = new_array(n, std::size_t(sides), &out);
              const SplatOptions options{corner_slack, edge_cos, rim_cos, junction_tolerance,
                                         edge_overlap};
              run_released(threads, progress, [&](Context& ctx) {
                  checkpoint(ctx, 0.0);
                  splat_radii(ctx, P, N, U, V, R, E, n, I, k, std::size_t(sides), options, out);
              });
              return O;
          },
          nb::arg("points"), nb::arg("normals"), nb::arg("u"), nb::arg("v"), nb::arg("reach"),
          nb::arg("rim"), nb::arg("neighbours"), nb::kw_only(), nb::arg("sides"),
          nb::arg("corner_slack"), nb::arg("edge_cos"), nb::arg("rim_cos"),
          nb::arg("junction_tolerance"), nb::arg("edge_overlap"), nb::arg("threads") = 0,
          nb::arg("progress") = nb::none(),
          "Radii (N, sides) in m of each point's clipped splat along cos(t) u + sin(t) v. "
          "See splats.hpp and illumap/splats.py.");

    m.def("splat_frames",
          [](nb::handle points, nb::handle normals, nb::handle radii, std::int64_t k,
             double inlier, double share, double spread, double cover, double edge_cos,
             double on_plane, double edge_slack, double rim_shift, double rim_gap,
             double rim_along, double rim_reach, double parallel_cos, double crease_width,
             int propagate, int rim_neighbours, bool crease_strips, double convex_slack,
             bool with_neighbours, int threads, nb::handle progress) {
              std::size_t n, rows;
              nb::object keep[3];
              const double* P = view<double>(points, "points", 2, 3, n, keep[0]);
              const double* N = nullptr;
              const double* R = nullptr;
              if (!normals.is_none()) {
                  N = view<double>(normals, "normals", 2, 3, rows, keep[1]);
                  if (rows != n) throw nb::value_error("normals must have one row per point");
              }
              if (!radii.is_none()) {
                  R = view<double>(radii, "radii", 1, 0, rows, keep[2]);
                  if (rows != n) throw nb::value_error("radii must have one value per point");
              }
              if (k < 2 || std::size_t(k) >= n)
                  throw nb::value_error(("splat_frames needs 2 <= k < the number of points (" +
                                         std::to_string(n) + "), got k = " +
                                         std::to_string(k)).c_str());
              if (propagate < 0 || rim_neighbours < 2)
                  throw nb::value_error("propagate must be >= 0 and rim_neighbours >= 2");
              double* out;
              auto O = new_array(n, 13, &out);
              std::int64_t *ord = nullptr, *nbr = nullptr;
              nb::object order = nb::none(), neighbours = nb::none();
              auto int_array = [](std::size_t rows, std::size_t cols, std::int64_t** data) {
                  *data = new std::int64_t[std::max<std::size_t>(1, rows * cols)]();
                  nb::capsule own(*data, [](void* q) noexcept {
                      delete[] static_cast<std::int64_t*>(q);
                  });
                  return nb::cast(nb::ndarray<nb::numpy, std::int64_t>(*data, {rows, cols}, own));
              };
              if (with_neighbours) {
                  order = int_array(n, 1, &ord);
                  neighbours = int_array(n, std::size_t(k), &nbr);
              }
              const PlaneFitOptions fit{inlier, share, spread};
              SplatFrameOptions options;
              options.cover = cover;
              options.edge_cos = edge_cos;
              options.on_plane = on_plane;
              options.edge_slack = edge_slack;
              options.rim_shift = rim_shift;
              options.rim_gap = rim_gap;
              options.rim_along = rim_along;
              options.rim_reach = rim_reach;
              options.parallel_cos = parallel_cos;
              options.crease_width = crease_width;
              options.propagate = propagate;
              options.rim_neighbours = rim_neighbours;
              options.crease_strips = crease_strips;
              options.convex_slack = convex_slack;
              run_released(threads, progress, [&](Context& ctx) {
                  splat_frames(ctx, P, n, N, R, std::size_t(k), fit, options, out, ord, nbr);
              });
              if (with_neighbours) return nb::object(nb::make_tuple(O, order, neighbours));
              return nb::cast(O);
          },
          nb::arg("points"), nb::arg("normals").none(), nb::arg("radii").none(), nb::kw_only(),
          nb::arg("k"), nb::arg("inlier"), nb::arg("share"), nb::arg("spread"), nb::arg("cover"),
          nb::arg("edge_cos"), nb::arg("on_plane"), nb::arg("edge_slack"), nb::arg("rim_shift"),
          nb::arg("rim_gap"), nb::arg("rim_along"), nb::arg("rim_reach"),
          nb::arg("parallel_cos"), nb::arg("crease_width"), nb::arg("propagate"),
          nb::arg("rim_neighbours"), nb::arg("crease_strips"), nb::arg("convex_slack") = -1.0,
          nb::arg("with_neighbours") = false, nb::arg("threads") = 0,
          nb::arg("progress") = nb::none(),
          "The preview's splat of each point (N, 13): normal (3), axis (3), semi-axes (a, b, "
          "a), offset (3), clipped (1 or 0), from its k nearest points; normals (N, 3, unit) and "
          "radii (N,) the scan's own, or None; with_neighbours: (frames, order (N, 1) int64, "
          "neighbours (N, k) int64, positions in that order). See splat_frames.hpp and "
          "illumap/splats.py.");

    m.def("splat_shading",
          [](nb::handle points, nb::handle normals, nb::handle axes, nb::handle scales,
             nb::handle offsets, nb::handle values, nb::handle order, nb::handle neighbours,
             std::int64_t k, double edge_cos, double ridge, int threads, nb::handle progress) {
              std::size_t n, rows;
              nb::object keep[6];
              // Points and frames all float32 (the preview's): read as they are.
              AnyArray probe;
              const bool f32 = nb::try_cast<AnyArray>(points, probe, false) &&
                               probe.dtype() == nb::dtype<float>();
              const double* P = f32 ? nullptr : view<double>(points, "points", 2, 3, n, keep[0]);
              const float* PF = f32 ? view<float>(points, "points", 2, 3, n, keep[0]) : nullptr;
              const double* arrays[5] = {};
              const float* floats[4] = {};
              const char* names[5] = {"normals", "axes", "scales", "offsets", "values"};
              nb::handle given[5] = {normals, axes, scales, offsets, values};
              for (int a = 0; a < 5; ++a) {
                  if (f32 && a < 4)
                      floats[a] = view<float>(given[a], names[a], 2, 3, rows, keep[a + 1]);
                  else
                      arrays[a] = view<double>(given[a], names[a], 2, 3, rows, keep[a + 1]);
                  if (rows != n)
                      throw nb::value_error((std::string(names[a]) +
                                             " must have one row per point").c_str());
              }
              if (f32 && neighbours.is_none())
                  throw nb::value_error("float32 points and frames need order and neighbours");
              if (k < 1 || std::size_t(k) >= n)
                  throw nb::value_error(("splat_shading needs 1 <= k < the number of points (" +
                                         std::to_string(n) + "), got k = " +
                                         std::to_string(k)).c_str());
              const std::int64_t *OR = nullptr, *NB = nullptr;
              nb::object keep_nb[2];
              if (order.is_none() != neighbours.is_none())
                  throw nb::value_error("give both order and neighbours, or neither");
              if (!neighbours.is_none()) {
                  OR = view<std::int64_t>(order, "order", 1, 0, rows, keep_nb[0]);
                  if (rows != n) throw nb::value_error("order must have one entry per point");
                  NB = view<std::int64_t>(neighbours, "neighbours", 2, k, rows, keep_nb[1]);
                  if (rows != n) throw nb::value_error("neighbours must have one row per point");
              }
              double* out;
              auto O = new_array(n, 9, &out);
              SplatShadingOptions options;
              options.edge_cos = edge_cos;
              options.ridge = ridge;
              run_released(threads, progress, [&](Context& ctx) {
                  if (f32)
                      splat_shading(ctx, PF, floats[0], floats[1], floats[2], floats[3],
                                    arrays[4], n, std::size_t(k), options, out, OR, NB);
                  else
                      splat_shading(ctx, P, arrays[0], arrays[1], arrays[2], arrays[3],
                                    arrays[4], n, std::size_t(k), options, out, OR, NB);
              });
              return O;
          },
          nb::arg("points"), nb::arg("normals"), nb::arg("axes"), nb::arg("scales"),
          nb::arg("offsets"), nb::arg("values"), nb::arg("order").none(),
          nb::arg("neighbours").none(), nb::kw_only(),
          nb::arg("k"),
          nb::arg("edge_cos"), nb::arg("ridge"), nb::arg("threads") = 0,
          nb::arg("progress") = nb::none(),
          "Each splat's linear shading (N, 9): the value at its centre (3) and its change per "
          "unit of the instanced disc's X (3) and Y (3). See splat_shading.hpp and "
          "illumap/splat_shading.py.");

    m.def("splat_fans",
          [](nb::handle points, nb::handle u, nb::handle v, nb::handle radii, nb::handle facing,
             int threads, nb::handle progress) {
              std::size_t n, rows[4];
              nb::object keep[5];
              AnyArray shape_of;
              if (!nb::try_cast<AnyArray>(radii, shape_of, false) || shape_of.ndim() != 2)
                  throw nb::value_error("radii must be a 2-D (N, sides) numpy array");
              const std::size_t sides = shape_of.shape(1);
              const double* P = view<double>(points, "points", 2, 3, n, keep[0]);
              const double* U = view<double>(u, "u", 2, 3, rows[0], keep[1]);
              const double* V = view<double>(v, "v", 2, 3, rows[1], keep[2]);
              const double* R = view<double>(radii, "radii", 2, std::int64_t(sides), rows[2], keep[3]);
              const double* F = view<double>(facing, "facing", 2, 3, rows[3], keep[4]);
              for (std::size_t r : rows)
                  if (r != n)
                      throw nb::value_error("points, u, v, radii and facing must have the same length");
              double* data = new double[std::max<std::size_t>(1, n * sides * 9)]();
              nb::capsule owner(data, [](void* q) noexcept { delete[] static_cast<double*>(q); });
              nb::ndarray<nb::numpy, double> T(data, {n * sides, 3, 3}, owner);
              run_released(threads, progress, [&](Context& ctx) {
                  checkpoint(ctx, 0.0);
                  splat_fans(ctx, P, U, V, R, F, n, sides, data);
              });
              return T;
          },
          nb::arg("points"), nb::arg("u"), nb::arg("v"), nb::arg("radii"), nb::arg("facing"),
          nb::kw_only(), nb::arg("threads") = 0, nb::arg("progress") = nb::none(),
          "Triangles (N * sides, 3, 3) in m: each point's splat as a fan about it, its rim at "
          "radii (N, sides) along cos(t) u + sin(t) v, wound to face along facing (N, 3). "
          "See splats.hpp.");
}

}  // namespace illumap::bindings
