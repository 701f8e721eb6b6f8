// bind_occluders.cpp — illumap._core.Occluders: the surfels as occluders of segments (raycast.hpp).
#include "bindings/bindings.hpp"

namespace illumap::bindings {

void bind_occluders(nb::module_& m) {
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
}

}  // namespace illumap::bindings
