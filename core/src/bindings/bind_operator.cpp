// bind_operator.cpp — illumap._core.Operator: the transport operator (transport_operator.hpp).
#include "bindings/bindings.hpp"

namespace illumap::bindings {

void bind_operator(nb::module_& m) {
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
                nb::handle occluder_triangles, nb::handle occluder_shift,
                nb::handle occluder_scene, nb::handle scan_surfels) {
                 if (method != "fmm" && method != "direct")
                     throw nb::value_error("method must be 'fmm' or 'direct'");
                 if (near_field != "disc" && near_field != "point")
                     throw nb::value_error("near_field must be 'disc' or 'point'");
                 if (order < 0 || order > kMaxOrder)
                     throw nb::value_error(order_range_message().c_str());
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
                 if (visibility_samples < 1 || visibility_samples > kMaxVisibilitySamples)
                     throw nb::value_error(("visibility_samples must be in 1.." +
                                            std::to_string(kMaxVisibilitySamples)).c_str());
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
                 if (occluder_shift.is_valid() && !occluder_shift.is_none()) {
                     std::size_t ns;
                     nb::object keep_shift;
                     const double* sh = view<double>(occluder_shift, "occluder_shift", 1, 3, ns, keep_shift);
                     if (ns != 3) throw nb::value_error("occluder_shift must have 3 entries");
                     for (int d = 0; d < 3; ++d) {
                         if (!std::isfinite(sh[d])) throw nb::value_error("occluder_shift is not finite");
                         opt.vis.triangles_shift[d] = sh[d];
                     }
                 }
                 if (occluder_scene.is_valid() && !occluder_scene.is_none()) {
                     // The receivers' ray scene of the same triangles: cast against, not
                     // built again (the operator retains its Embree scene).
                     const MeshScene* sc = nb::cast<PyMeshScene&>(occluder_scene).scene.get();
                     if (!opt.vis.triangles || sc->size() != opt.vis.n_triangles)
                         throw nb::value_error("occluder_scene must be a MeshScene of occluder_triangles");
                     opt.vis.triangles_scene = sc;
                 }
                 if (scan_surfels.is_valid() && !scan_surfels.is_none()) {
                     std::size_t ns;
                     nb::object keep_scan;
                     const double* flags = view<double>(scan_surfels, "scan_surfels", 1, 1, ns, keep_scan);
                     if (ns != np)
                         throw nb::value_error("scan_surfels must have one entry per surfel");
                     opt.scan.resize(np);
                     for (std::size_t k = 0; k < np; ++k) {
                         if (!(flags[k] >= 0.0 && flags[k] < 4294967296.0))
                             throw nb::value_error("scan_surfels must lie in [0, 2^32)");
                         opt.scan[k] = std::uint32_t(flags[k]);
                     }
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
             nb::arg("seed_binary_pairs") = true, nb::arg("occluder_triangles").none() = nb::none(),
             nb::arg("occluder_shift").none() = nb::none(),
             nb::arg("occluder_scene").none() = nb::none(),
             nb::arg("scan_surfels").none() = nb::none())
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
}

}  // namespace illumap::bindings
