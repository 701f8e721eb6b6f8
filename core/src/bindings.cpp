// bindings.cpp — the nanobind module illumap._core (contract: docs/architecture.md).
//
// Shapes, dtypes and contiguity are checked here (ValueError with the array's name); the
// Python layer checks values. Inputs that are already C-contiguous float64 are read in place.
// The GIL is released during compute; progress callbacks re-acquire it on the calling thread.
#include "transport_operator.hpp"
#include "knn.hpp"
#include "gather.hpp"
#include "mesh_scene.hpp"
#include "normals.hpp"
#include "raycast.hpp"

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

namespace nb = nanobind;
using namespace illumap;

namespace {

using AnyArray = nb::ndarray<nb::ro, nb::device::cpu>;

// A read-only, C-contiguous float64 (or int64) view of a numpy array, checked.
template <class T>
const T* view(nb::handle h, const char* name, std::size_t ndim, std::int64_t cols,
              std::size_t& rows, nb::object& keep) {
    AnyArray a;
    if (!nb::try_cast<AnyArray>(h, a, false))
        throw nb::value_error((std::string(name) + " must be a numpy array").c_str());
    const char* tname = std::is_same_v<T, double> ? "float64" : "int64";
    if (a.dtype() != nb::dtype<T>())
        throw nb::value_error((std::string(name) + " must have dtype " + tname).c_str());
    if (a.ndim() != ndim) {
        std::string want = ndim == 1 ? "1-D (N,)" : "2-D (N, " + std::to_string(cols) + ")";
        throw nb::value_error((std::string(name) + " must be " + want + ", got " +
                               std::to_string(a.ndim()) + " dimensions").c_str());
    }
    if (ndim == 2 && std::int64_t(a.shape(1)) != cols)
        throw nb::value_error((std::string(name) + " must have shape (N, " + std::to_string(cols) +
                               "), got (" + std::to_string(a.shape(0)) + ", " +
                               std::to_string(a.shape(1)) + ")").c_str());
    // C-contiguous: unit stride in the last axis, rows packed (size-1 axes are free).
    bool contig = true;
    std::int64_t expect = 1;
    for (int d = int(ndim) - 1; d >= 0; --d) {
        if (a.shape(d) > 1 && a.stride(d) != expect) contig = false;
        expect *= std::int64_t(a.shape(d));
    }
    if (!contig)
        throw nb::value_error((std::string(name) +
                               " must be C-contiguous (use numpy.ascontiguousarray)").c_str());
    rows = a.shape(0);
    keep = nb::borrow(h);
    return static_cast<const T*>(a.data());
}

// Checked views of the surfel arrays every constructor takes, of one common length n.
struct SurfelViews {
    const double *P, *N, *A;
    std::size_t n;
    nb::object keep[3];
    SurfelViews(nb::handle positions, nb::handle normals, nb::handle areas) {
        std::size_t nn, na;
        P = view<double>(positions, "positions", 2, 3, n, keep[0]);
        N = view<double>(normals, "normals", 2, 3, nn, keep[1]);
        A = view<double>(areas, "areas", 1, 0, na, keep[2]);
        if (nn != n || na != n)
            throw nb::value_error(("positions, normals and areas must have the same length, got " +
                                   std::to_string(n) + ", " + std::to_string(nn) + ", " +
                                   std::to_string(na)).c_str());
    }
};

nb::ndarray<nb::numpy, double> new_array(std::size_t rows, std::size_t cols, double** data) {
    double* p = new double[std::max<std::size_t>(1, rows * std::max<std::size_t>(cols, 1))]();
    nb::capsule owner(p, [](void* q) noexcept { delete[] static_cast<double*>(q); });
    *data = p;
    if (cols == 0) return nb::ndarray<nb::numpy, double>(p, {rows}, owner);
    return nb::ndarray<nb::numpy, double>(p, {rows, cols}, owner);
}

// Calls the Python progress callable with the GIL; remembers an exception it raised.
struct PyMonitor : Monitor {
    nb::object cb;
    std::optional<nb::python_error> error;
    bool poll(double fraction, const char* phase) override {
        nb::gil_scoped_acquire gil;
        try {
            nb::object r = cb(std::min(1.0, std::max(0.0, fraction)), phase);
            if (r.is_none()) return true;
            return PyObject_IsTrue(r.ptr()) == 1;
        } catch (nb::python_error& e) {
            if (!error) error.emplace(std::move(e));
            return false;
        }
    }
};

// Runs fn(ctx) without the GIL; translates cancellation into the right Python exception.
template <class Fn>
void run_released(int threads, nb::handle progress, Fn&& fn) {
    PyMonitor mon;
    Context ctx;
    ctx.threads = threads;
    if (progress.is_valid() && !progress.is_none()) {
        mon.cb = nb::borrow(progress);
        ctx.monitor = &mon;
    }
    bool cancelled = false;
    {
        nb::gil_scoped_release nogil;
        try {
            fn(ctx);
        } catch (Cancelled&) {
            cancelled = true;
        }
    }
    if (cancelled) {
        if (mon.error) throw std::move(*mon.error);
        throw Cancelled();
    }
}

struct PyOperator {
    std::unique_ptr<TransportOperator> op;
    std::string method, near_field, visibility = "none";
    int threads = 0;
};

struct PyOccluders {
    std::unique_ptr<OccluderScene> scene;
    int threads = 0;
};

struct PyMeshScene {
    std::unique_ptr<MeshScene> scene;
    int threads = 0;
};

struct PySurfelField {
    std::unique_ptr<SurfelField> field;
};

// The names of the visibility options, as the Python API spells them (ValueError otherwise).
VisMethod parse_vis_method(const std::string& s) {
    if (s == "none") return VisMethod::None;
    if (s == "seed") return VisMethod::Seed;
    if (s == "exact") return VisMethod::Exact;
    throw nb::value_error(("visibility must be 'none', 'seed' or 'exact', not '" + s + "'").c_str());
}
VisibilityOptions::Shape parse_vis_shape(const std::string& s) {
    if (s == "disc") return VisibilityOptions::Shape::Disc;
    if (s == "quad") return VisibilityOptions::Shape::Quad;
    if (s == "octagon") return VisibilityOptions::Shape::Octagon;
    throw nb::value_error(
        ("visibility shape must be 'disc', 'quad' or 'octagon', not '" + s + "'").c_str());
}
LeafMode parse_leaf_mode(const std::string& s) {
    if (s == "binary") return LeafMode::Binary;
    if (s == "fractional") return LeafMode::Fractional;
    if (s == "per_pair") return LeafMode::PerPair;
    if (s == "per_pair_all") return LeafMode::PerPairAll;
    throw nb::value_error(
        ("leaf mode must be 'binary', 'fractional', 'per_pair' or 'per_pair_all', not '" + s +
         "'").c_str());
}

// Two (M, 3) float64 arrays of one length, every value finite.
std::size_t paired_rays(nb::handle a, const char* an, nb::handle b, const char* bn,
                        const double*& A, const double*& B, nb::object& ka, nb::object& kb) {
    std::size_t na, nbn;
    A = view<double>(a, an, 2, 3, na, ka);
    B = view<double>(b, bn, 2, 3, nbn, kb);
    if (na != nbn)
        throw nb::value_error((std::string(an) + " and " + bn + " must have the same length, got " +
                               std::to_string(na) + " and " + std::to_string(nbn)).c_str());
    for (std::size_t k = 0; k < 3 * na; ++k)
        if (!std::isfinite(A[k]) || !std::isfinite(B[k]))
            throw nb::value_error((std::string(!std::isfinite(A[k]) ? an : bn) + "[" +
                                   std::to_string(k / 3) + ", " + std::to_string(k % 3) +
                                   "] is not finite").c_str());
    return na;
}

}  // namespace

NB_MODULE(_core, m) {
    m.doc() = "Illumap native core: FMM and direct radiosity transport operators, k-NN.";
    nb::exception<Cancelled>(m, "Cancelled");
    m.def("hardware_threads", &hardware_threads, "Number of hardware threads.");

    nb::class_<PyOperator>(m, "Operator",
        "Transport operator y_i = sum_j F_ij V_ij x_j (V: visibility 'none', 'seed', 'exact').")
        .def("__init__",
             [](PyOperator* self, nb::handle positions, nb::handle normals, nb::handle areas,
                const std::string& method, int order, double theta, int leaf_size,
                const std::string& near_field, int threads, nb::handle progress,
                const std::string& visibility, const std::string& visibility_leaf_mode,
                int visibility_samples, double coverage, const std::string& visibility_shape,
                double endpoint_offset, double seed_delta, int seed_k, double seed_t1,
                double seed_t2, double seed_t3, int seed_leaf_points, bool seed_binary_pairs,
                nb::handle occluder_triangles) {
                 if (method != "fmm" && method != "direct")
                     throw nb::value_error("method must be 'fmm' or 'direct'");
                 if (near_field != "disc" && near_field != "point")
                     throw nb::value_error("near_field must be 'disc' or 'point'");
                 if (order < 0 || order > kMaxOrder)
                     throw nb::value_error("order must be in 0..10");
                 if (!(theta > 0.0 && theta < 1.0)) throw nb::value_error("theta must be in (0, 1)");
                 if (leaf_size < 1) throw nb::value_error("leaf_size must be >= 1");
                 if (threads < 0) throw nb::value_error("threads must be >= 0");
                 const SurfelViews sv(positions, normals, areas);
                 const double *P = sv.P, *N = sv.N, *A = sv.A;
                 const std::size_t np = sv.n;
                 OperatorOptions opt;
                 opt.fmm = method == "fmm";
                 opt.order = order;
                 opt.theta = theta;
                 opt.leaf_size = leaf_size;
                 opt.near_field = near_field == "disc" ? NearField::Disc : NearField::Point;
                 opt.vis.method = parse_vis_method(visibility);
                 opt.vis.leaf_mode = parse_leaf_mode(visibility_leaf_mode);
                 opt.vis.shape = parse_vis_shape(visibility_shape);
                 if (visibility_samples < 1 || visibility_samples > 4096)
                     throw nb::value_error("visibility_samples must be in 1..4096");
                 if (!(coverage > 0.0) || !(endpoint_offset >= 0.0) || !(seed_delta > 0.0))
                     throw nb::value_error("coverage and seed_delta must be > 0, endpoint_offset >= 0");
                 if (seed_k < 1 || seed_leaf_points < 1)
                     throw nb::value_error("seed_k and seed_leaf_points must be >= 1");
                 for (double t : {seed_t1, seed_t2, seed_t3})
                     if (!(t >= 0.0 && t <= 1.0)) throw nb::value_error("seed_t1..t3 must be in [0, 1]");
                 opt.vis.samples = visibility_samples;
                 opt.vis.coverage = coverage;
                 opt.vis.endpoint_offset = endpoint_offset;
                 opt.vis.delta = seed_delta;
                 opt.vis.k = seed_k;
                 opt.vis.t1 = seed_t1;
                 opt.vis.t2 = seed_t2;
                 opt.vis.t3 = seed_t3;
                 opt.vis.leaf_points = seed_leaf_points;
                 opt.vis.seed_binary_pairs = seed_binary_pairs;
                 nb::object keep_tri;
                 if (occluder_triangles.is_valid() && !occluder_triangles.is_none()) {
                     std::size_t nt;
                     opt.vis.triangles = view<double>(occluder_triangles, "occluder_triangles", 2, 9, nt, keep_tri);
                     opt.vis.n_triangles = nt;
                 }
                 std::unique_ptr<TransportOperator> op;
                 run_released(threads, progress, [&](Context& ctx) {
                     op = std::make_unique<TransportOperator>(ctx, P, N, A, np, opt);
                 });
                 new (self) PyOperator{std::move(op), method, near_field, visibility, threads};
             },
             nb::arg("positions"), nb::arg("normals"), nb::arg("areas"), nb::kw_only(),
             nb::arg("method") = "fmm", nb::arg("order") = 4, nb::arg("theta") = 0.5,
             nb::arg("leaf_size") = 32, nb::arg("near_field") = "disc", nb::arg("threads") = 0,
             nb::arg("progress") = nb::none(), nb::arg("visibility") = "none",
             nb::arg("visibility_leaf_mode") = "per_pair", nb::arg("visibility_samples") = 8,
             nb::arg("coverage") = 1.3, nb::arg("visibility_shape") = "disc",
             nb::arg("endpoint_offset") = 0.05, nb::arg("seed_delta") = 2.0,
             nb::arg("seed_k") = 8, nb::arg("seed_t1") = 0.5, nb::arg("seed_t2") = 0.5,
             nb::arg("seed_t3") = 0.5, nb::arg("seed_leaf_points") = 8,
             nb::arg("seed_binary_pairs") = true, nb::arg("occluder_triangles").none() = nb::none())
        .def("apply",
             [](PyOperator& self, nb::handle values, nb::handle progress) {
                 std::size_t nv;
                 nb::object keep;
                 const double* x = view<double>(values, "values", 2, 3, nv, keep);
                 if (nv != self.op->size())
                     throw nb::value_error(("values must have shape (" +
                                            std::to_string(self.op->size()) + ", 3), got (" +
                                            std::to_string(nv) + ", 3)").c_str());
                 double* y;
                 auto out = new_array(nv, 3, &y);
                 run_released(self.threads, progress,
                              [&](Context& ctx) { self.op->apply(ctx, x, y); });
                 return out;
             },
             nb::arg("values"), nb::arg("progress") = nb::none(),
             "y = F x for an (N, 3) array x; returns a new (N, 3) array.")
        .def("apply_rows",
             [](PyOperator& self, nb::handle values, nb::handle rows, nb::handle progress) {
                 std::size_t nv, nr;
                 nb::object k1, k2;
                 const double* x = view<double>(values, "values", 2, 3, nv, k1);
                 const std::int64_t* r = view<std::int64_t>(rows, "rows", 1, 0, nr, k2);
                 const std::size_t n = self.op->size();
                 if (nv != n)
                     throw nb::value_error(("values must have shape (" + std::to_string(n) +
                                            ", 3), got (" + std::to_string(nv) + ", 3)").c_str());
                 for (std::size_t i = 0; i < nr; ++i)
                     if (r[i] < 0 || std::size_t(r[i]) >= n)
                         throw nb::value_error(("rows[" + std::to_string(i) + "] = " +
                                                std::to_string(r[i]) + " is out of range [0, " +
                                                std::to_string(n) + ")").c_str());
                 double* y;
                 auto out = new_array(nr, 3, &y);
                 run_released(self.threads, progress,
                              [&](Context& ctx) { self.op->apply_rows(ctx, x, r, nr, y); });
                 return out;
             },
             nb::arg("values"), nb::arg("rows"), nb::arg("progress") = nb::none(),
             "Exact direct sum for the selected receivers: (len(rows), 3).")
        .def_prop_ro("stats",
             [](const PyOperator& self) {
                 nb::dict d;
                 d["method"] = self.method;
                 d["near_field"] = self.near_field;
                 d["visibility"] = self.visibility;
                 for (const auto& kv : self.op->scalar_stats()) {
                     const bool integral = kv.first.rfind("time_", 0) != 0 && kv.first != "theta";
                     if (integral)
                         d[kv.first.c_str()] = nb::int_(std::int64_t(kv.second));
                     else
                         d[kv.first.c_str()] = kv.second;
                 }
                 for (const auto& kv : self.op->level_stats()) {
                     nb::list l;
                     for (double v : kv.second) l.append(nb::int_(std::int64_t(v)));
                     d[kv.first.c_str()] = l;
                 }
                 return d;
             })
        .def_prop_ro("symmetric",
             [](const PyOperator&) {
                 // The pair rule is reciprocal (A_i F_ij = A_j F_ji); the FMM is symmetric up
                 // to its expansion error. Both visibility methods evaluate V(i,j) in the
                 // canonical order (V_ij = V_ji), classify / fraction / block are symmetric and
                 // the traversal's lists mirror each other (radius ties broken by node id), so
                 // diag(A) F V stays symmetric for every method and leaf mode.
                 return true;
             })
        .def_prop_ro("visibility", [](const PyOperator& self) { return self.visibility; })
        .def_prop_ro("n", [](const PyOperator& self) { return self.op->size(); })
        .def_prop_ro("method", [](const PyOperator& self) { return self.method; })
        .def_prop_ro("order", [](const PyOperator& self) { return self.op->options().order; })
        .def_prop_ro("theta", [](const PyOperator& self) { return self.op->options().theta; })
        .def_prop_ro("leaf_size", [](const PyOperator& self) { return self.op->options().leaf_size; })
        .def_prop_ro("near_field", [](const PyOperator& self) { return self.near_field; })
        .def("__len__", [](const PyOperator& self) { return self.op->size(); });

    nb::class_<PyOccluders>(m, "Occluders",
        "The surfels as occluders (Embree scene of discs, quads or octagons), for segment queries.")
        .def("__init__",
             [](PyOccluders* self, nb::handle positions, nb::handle normals, nb::handle areas,
                double coverage, const std::string& shape, int threads, nb::handle progress) {
                 if (!(coverage > 0.0) || !std::isfinite(coverage))
                     throw nb::value_error("coverage must be a finite number > 0");
                 if (threads < 0) throw nb::value_error("threads must be >= 0");
                 const VisibilityOptions::Shape sh = parse_vis_shape(shape);
                 const SurfelViews sv(positions, normals, areas);
                 const double *P = sv.P, *N = sv.N, *A = sv.A;
                 const std::size_t np = sv.n;
                 std::unique_ptr<OccluderScene> scene;
                 run_released(threads, progress, [&](Context& ctx) {
                     ctx.set_phase("occluders: build", 0.0, 1.0);
                     checkpoint(ctx, 0.0);
                     SurfelSoA s;
                     s.resize(np);
                     for (std::size_t i = 0; i < np; ++i) {
                         s.px[i] = P[3 * i]; s.py[i] = P[3 * i + 1]; s.pz[i] = P[3 * i + 2];
                         s.nx[i] = N[3 * i]; s.ny[i] = N[3 * i + 1]; s.nz[i] = N[3 * i + 2];
                         s.area[i] = A[i];
                     }
                     scene = std::make_unique<OccluderScene>(ctx, s, coverage, sh);
                 });
                 new (self) PyOccluders{std::move(scene), threads};
             },
             nb::arg("positions"), nb::arg("normals"), nb::arg("areas"), nb::kw_only(),
             nb::arg("coverage") = 1.3, nb::arg("shape") = "disc", nb::arg("threads") = 0,
             nb::arg("progress") = nb::none())
        .def("visible",
             [](PyOccluders& self, nb::handle origins, nb::handle targets, nb::handle skip,
                double endpoint_offset, nb::handle progress) {
                 std::size_t no, nt, ns = 0;
                 nb::object k1, k2, k3;
                 const double* O = view<double>(origins, "origins", 2, 3, no, k1);
                 const double* T = view<double>(targets, "targets", 2, 3, nt, k2);
                 if (nt != no)
                     throw nb::value_error(("origins and targets must have the same length, got " +
                                            std::to_string(no) + " and " + std::to_string(nt)).c_str());
                 const std::int64_t* S = nullptr;
                 if (skip.is_valid() && !skip.is_none()) {
                     S = view<std::int64_t>(skip, "skip", 1, 0, ns, k3);
                     if (ns != no)
                         throw nb::value_error(("skip must have the same length as origins, got " +
                                                std::to_string(ns) + " and " + std::to_string(no)).c_str());
                     const std::int64_t n = std::int64_t(self.scene->size());
                     for (std::size_t k = 0; k < ns; ++k)
                         if (S[k] < -1 || S[k] >= n)
                             throw nb::value_error(("skip[" + std::to_string(k) + "] = " +
                                                    std::to_string(S[k]) + " is not -1 or in [0, " +
                                                    std::to_string(n) + ")").c_str());
                 }
                 for (std::size_t k = 0; k < 3 * no; ++k)
                     if (!std::isfinite(O[k]) || !std::isfinite(T[k]))
                         throw nb::value_error((std::string(!std::isfinite(O[k]) ? "origins" : "targets") +
                                                "[" + std::to_string(k / 3) + ", " + std::to_string(k % 3) +
                                                "] is not finite").c_str());
                 if (!(endpoint_offset >= 0.0) || !std::isfinite(endpoint_offset))
                     throw nb::value_error("endpoint_offset must be a finite number >= 0");
                 float* v = new float[std::max<std::size_t>(1, no)]();
                 nb::capsule own(v, [](void* q) noexcept { delete[] static_cast<float*>(q); });
                 nb::ndarray<nb::numpy, float> out(v, {no}, own);
                 run_released(self.threads, progress, [&](Context& ctx) {
                     ctx.set_phase("occluders: rays", 0.0, 1.0);
                     checkpoint(ctx, 0.0);
                     self.scene->segments(ctx, O, T, S, endpoint_offset, no, v);
                 });
                 return out;
             },
             nb::arg("origins"), nb::arg("targets"), nb::kw_only(), nb::arg("skip") = nb::none(),
             nb::arg("endpoint_offset") = 0.05, nb::arg("progress") = nb::none(),
             "1 where no occluder meets the segment origins[k] -> targets[k], else 0: float32 (M,).")
        .def_prop_ro("n", [](const PyOccluders& self) { return self.scene->size(); })
        .def_prop_ro("build_seconds", [](const PyOccluders& self) { return self.scene->build_seconds(); })
        .def_prop_ro("bytes", [](const PyOccluders& self) { return self.scene->bytes(); });

    nb::class_<PyMeshScene>(m, "MeshScene",
        "Triangles as an Embree scene, for direct light and final gather at receivers.")
        .def("__init__",
             [](PyMeshScene* self, nb::handle corners, int threads, nb::handle progress) {
                 if (threads < 0) throw nb::value_error("threads must be >= 0");
                 std::size_t nt;
                 nb::object keep;
                 const double* C = view<double>(corners, "corners", 2, 9, nt, keep);
                 std::unique_ptr<MeshScene> scene;
                 run_released(threads, progress, [&](Context& ctx) {
                     checkpoint(ctx, 0.0);
                     try {
                         scene = std::make_unique<MeshScene>(ctx, C, nt);
                     } catch (std::invalid_argument& e) {
                         throw std::runtime_error(std::string("corners: ") + e.what());
                     }
                 });
                 new (self) PyMeshScene{std::move(scene), threads};
             },
             nb::arg("corners"), nb::kw_only(), nb::arg("threads") = 0,
             nb::arg("progress") = nb::none())
        .def("visible",
             [](PyMeshScene& self, nb::handle origins, nb::handle targets, double end_trim,
                nb::handle progress) {
                 const double *O, *T;
                 nb::object k1, k2;
                 const std::size_t no = paired_rays(origins, "origins", targets, "targets", O, T, k1, k2);
                 if (!(end_trim >= 0.0) || !std::isfinite(end_trim))
                     throw nb::value_error("end_trim must be a finite number >= 0");
                 float* v = new float[std::max<std::size_t>(1, no)]();
                 nb::capsule own(v, [](void* q) noexcept { delete[] static_cast<float*>(q); });
                 nb::ndarray<nb::numpy, float> out(v, {no}, own);
                 run_released(self.threads, progress, [&](Context& ctx) {
                     ctx.set_phase("receivers: shadow rays", 0.0, 1.0);
                     checkpoint(ctx, 0.0);
                     self.scene->segments(ctx, O, T, no, end_trim, v);
                 });
                 return out;
             },
             nb::arg("origins"), nb::arg("targets"), nb::kw_only(), nb::arg("end_trim") = 0.0,
             nb::arg("progress") = nb::none(),
             "1 where no triangle meets origins[k] -> targets[k] (its last end_trim left out), else 0: float32 (M,).")
        .def("intersect",
             [](PyMeshScene& self, nb::handle origins, nb::handle directions, double tmax,
                nb::handle progress) {
                 const double *O, *D;
                 nb::object k1, k2;
                 const std::size_t no = paired_rays(origins, "origins", directions, "directions", O, D, k1, k2);
                 if (!(tmax > 0.0)) throw nb::value_error("tmax must be > 0");
                 auto* prim = new std::int64_t[std::max<std::size_t>(1, no)]();
                 auto* dist = new double[std::max<std::size_t>(1, no)]();
                 auto* front = new std::uint8_t[std::max<std::size_t>(1, no)]();
                 nb::capsule o1(prim, [](void* q) noexcept { delete[] static_cast<std::int64_t*>(q); });
                 nb::capsule o2(dist, [](void* q) noexcept { delete[] static_cast<double*>(q); });
                 nb::capsule o3(front, [](void* q) noexcept { delete[] static_cast<std::uint8_t*>(q); });
                 nb::ndarray<nb::numpy, std::int64_t> a1(prim, {no}, o1);
                 nb::ndarray<nb::numpy, double> a2(dist, {no}, o2);
                 nb::ndarray<nb::numpy, std::uint8_t> a3(front, {no}, o3);
                 run_released(self.threads, progress, [&](Context& ctx) {
                     ctx.set_phase("receivers: gather rays", 0.0, 1.0);
                     checkpoint(ctx, 0.0);
                     self.scene->intersect(ctx, O, D, no, tmax, prim, dist, front);
                 });
                 return nb::make_tuple(a1, a2, a3);
             },
             nb::arg("origins"), nb::arg("directions"), nb::kw_only(),
             nb::arg("tmax") = HUGE_VAL, nb::arg("progress") = nb::none(),
             "Closest triangle hit of unit-direction rays: (triangle int64 (-1: none), distance, front uint8).")
        .def_prop_ro("n", [](const PyMeshScene& self) { return self.scene->size(); })
        .def_prop_ro("extent", [](const PyMeshScene& self) { return self.scene->extent(); })
        .def_prop_ro("build_seconds", [](const PyMeshScene& self) { return self.scene->build_seconds(); });

    nb::class_<PySurfelField>(m, "SurfelField",
        "Surfel values looked up at points on surfaces (k nearest with agreeing normals, IDW).")
        .def("__init__",
             [](PySurfelField* self, nb::handle positions, nb::handle normals, nb::handle values,
                int k, double min_cos) {
                 std::size_t n, nn, nv;
                 nb::object k1, k2, k3;
                 const double* P = view<double>(positions, "positions", 2, 3, n, k1);
                 const double* N = view<double>(normals, "normals", 2, 3, nn, k2);
                 const double* V = view<double>(values, "values", 2, 3, nv, k3);
                 if (nn != n || nv != n)
                     throw nb::value_error("positions, normals and values must have the same length");
                 if (n == 0) throw nb::value_error("a surfel field needs at least one surfel");
                 if (k < 1) throw nb::value_error("k must be >= 1");
                 std::unique_ptr<SurfelField> f;
                 {
                     nb::gil_scoped_release nogil;
                     f = std::make_unique<SurfelField>(P, N, V, n, k, min_cos);
                 }
                 new (self) PySurfelField{std::move(f)};
             },
             nb::arg("positions"), nb::arg("normals"), nb::arg("values"), nb::kw_only(),
             nb::arg("k") = 8, nb::arg("min_cos") = 0.5)
        .def("at",
             [](PySurfelField& self, nb::handle points, nb::handle surface_normals,
                nb::handle scene, double lift) {
                 const double *Q, *N;
                 nb::object k1, k2;
                 const std::size_t m = paired_rays(points, "points", surface_normals, "surface_normals", Q, N, k1, k2);
                 const MeshScene* sc = nullptr;
                 if (scene.is_valid() && !scene.is_none()) sc = nb::cast<PyMeshScene&>(scene).scene.get();
                 double* out;
                 auto arr = new_array(m, 3, &out);
                 {
                     nb::gil_scoped_release nogil;
                     KdTree::Best best(std::size_t(self.field->k()));
                     for (std::size_t i = 0; i < m; ++i)
                         self.field->at(Q + 3 * i, N + 3 * i, best, out + 3 * i, sc, lift);
                 }
                 return arr;
             },
             nb::arg("points"), nb::arg("surface_normals"), nb::arg("scene").none() = nb::none(),
             nb::arg("lift") = 0.0)
        .def_prop_ro("n", [](const PySurfelField& self) { return self.field->size(); });

    m.def("cosine_directions",
          [](nb::handle normals, std::size_t count, nb::handle ids, std::uint64_t seed) {
              std::size_t m, ni;
              nb::object k1, k2;
              const double* N = view<double>(normals, "normals", 2, 3, m, k1);
              const std::int64_t* I = view<std::int64_t>(ids, "ids", 1, 0, ni, k2);
              if (ni != m) throw nb::value_error("ids must have one entry per normal");
              if (count < 1) throw nb::value_error("count must be >= 1");
              double* out = new double[std::max<std::size_t>(1, m * count * 3)]();
              nb::capsule own(out, [](void* q) noexcept { delete[] static_cast<double*>(q); });
              for (std::size_t i = 0; i < m; ++i) cosine_directions(N + 3 * i, count, I[i], seed, out + 3 * count * i);
              return nb::ndarray<nb::numpy, double>(out, {m, count, std::size_t(3)}, own);
          },
          nb::arg("normals"), nb::arg("count"), nb::arg("ids"), nb::arg("seed") = 0,
          "Cosine-distributed unit directions (M, count, 3) about unit normals, per receiver id.");

    m.def("gather",
          [](PyMeshScene& scene, PySurfelField& front, nb::handle back, nb::handle positions,
             nb::handle normals, nb::handle ids, int rays, std::uint64_t seed, double offset,
             nb::handle background, nb::handle two_sided, nb::handle rays_per, int threads,
             nb::handle progress) {
              const double *P, *N;
              nb::object k1, k2, k3, k4;
              const std::size_t m = paired_rays(positions, "positions", normals, "normals", P, N, k1, k2);
              std::size_t ni, nbg;
              const std::int64_t* I = view<std::int64_t>(ids, "ids", 1, 0, ni, k3);
              if (ni != m) throw nb::value_error("ids must have one entry per receiver");
              const double* BG = view<double>(background, "background", 1, 0, nbg, k4);
              if (nbg != 3) throw nb::value_error("background must have 3 values");
              if (rays < 1) throw nb::value_error("rays must be >= 1");
              if (!(offset >= 0) || !std::isfinite(offset)) throw nb::value_error("offset must be finite and >= 0");
              std::vector<std::uint8_t> sided;
              if (two_sided.is_valid() && !two_sided.is_none()) {
                  std::size_t ns;
                  nb::object k5;
                  const std::int64_t* S = view<std::int64_t>(two_sided, "two_sided", 1, 0, ns, k5);
                  if (ns != scene.scene->size())
                      throw nb::value_error("two_sided must have one entry per triangle");
                  sided.assign(S, S + ns);
              }
              std::vector<std::int32_t> per;
              if (rays_per.is_valid() && !rays_per.is_none()) {
                  std::size_t nr;
                  nb::object k6;
                  const std::int64_t* R = view<std::int64_t>(rays_per, "rays_per", 1, 0, nr, k6);
                  if (nr != m) throw nb::value_error("rays_per must have one entry per receiver");
                  per.resize(m);
                  for (std::size_t i = 0; i < m; ++i) {
                      if (R[i] < 1 || R[i] > (1 << 20))
                          throw nb::value_error(("rays_per[" + std::to_string(i) + "] must be in 1..2^20").c_str());
                      per[i] = std::int32_t(R[i]);
                  }
              }
              const SurfelField* back_field = nullptr;
              if (back.is_valid() && !back.is_none()) back_field = nb::cast<PySurfelField&>(back).field.get();
              GatherOptions opt;
              opt.rays = rays;
              opt.seed = seed;
              opt.offset = offset;
              for (int c = 0; c < 3; ++c) opt.background[c] = BG[c];
              double *out, *err;
              auto a1 = new_array(m, 3, &out);
              auto a2 = new_array(m, 0, &err);
              run_released(threads, progress, [&](Context& ctx) {
                  ctx.set_phase("gather", 0.0, 1.0);
                  checkpoint(ctx, 0.0);
                  gather(ctx, *scene.scene, *front.field, back_field, P, N, I, m, opt, out, err,
                         sided.empty() ? nullptr : sided.data(), per.empty() ? nullptr : per.data());
              });
              return nb::make_tuple(a1, a2);
          },
          nb::arg("scene"), nb::arg("front"), nb::arg("back").none(), nb::arg("positions"),
          nb::arg("normals"), nb::arg("ids"), nb::kw_only(), nb::arg("rays"), nb::arg("seed") = 0,
          nb::arg("offset"), nb::arg("background"), nb::arg("two_sided").none() = nb::none(),
          nb::arg("rays_per").none() = nb::none(),
          nb::arg("threads") = 0,
          nb::arg("progress") = nb::none(),
          "Final gather: (mean radiance (M, 3), standard error of its luminance (M,)).");

    m.def("_kernel_derivatives",
          [](nb::handle d, int order) {
              std::size_t n3;
              nb::object keep;
              const double* dv = view<double>(d, "d", 1, 0, n3, keep);
              if (n3 != 3) throw nb::value_error("d must have shape (3,)");
              if (order < 0 || order > kMaxOrder) throw nb::value_error("order must be in 0..10");
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
