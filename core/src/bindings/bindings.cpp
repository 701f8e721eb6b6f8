// bindings.cpp — the nanobind module illumap._core (contract: docs/architecture.md). Each
// class or function group registers itself through its own function (bindings.hpp); those
// of the final gather (MeshScene, SurfelField, cosine_directions, gather) are here.
#include "bindings/bindings.hpp"

#include "parallel.hpp"

#include <limits>

namespace illumap::bindings {

void bind_mesh_scene(nb::module_& m) {
    nb::class_<PyMeshScene>(m, "MeshScene",
        "Triangles as an Embree scene, for direct light and final gather at receivers.")
        .def("__init__",
             [](PyMeshScene* self, nb::handle corners, nb::handle splat_points,
                nb::handle splat_u, nb::handle splat_v, nb::handle splat_radii,
                nb::handle splat_facing, int threads, nb::handle progress) {
                 if (threads < 0) throw nb::value_error("threads must be >= 0");
                 std::size_t nt;
                 nb::object keep;
                 const double* C = view<double>(corners, "corners", 2, 9, nt, keep);
                 // A scan's splats (the last n * sides triangles), cast against as outlines.
                 SplatOutlines so;
                 nb::object k1, k2, k3, k4, k5;
                 const bool with_splats = splat_points.is_valid() && !splat_points.is_none();
                 if (with_splats) {
                     AnyArray r;
                     if (!nb::try_cast<AnyArray>(splat_radii, r, false) || r.ndim() != 2)
                         throw nb::value_error("splat_radii must be a 2-D numpy array (N, sides)");
                     so.sides = r.shape(1);
                     std::size_t n1, n2, n3, n4, n5;
                     so.points = view<double>(splat_points, "splat_points", 2, 3, n1, k1);
                     so.u = view<double>(splat_u, "splat_u", 2, 3, n2, k2);
                     so.v = view<double>(splat_v, "splat_v", 2, 3, n3, k3);
                     so.radii = view<double>(splat_radii, "splat_radii", 2, std::int64_t(so.sides), n4, k4);
                     so.facing = view<double>(splat_facing, "splat_facing", 2, 3, n5, k5);
                     if (n2 != n1 || n3 != n1 || n4 != n1 || n5 != n1)
                         throw nb::value_error("splat arrays must have one row per splat point");
                     so.n = n1;
                     if (so.sides < 3 || so.n * so.sides > nt)
                         throw nb::value_error("splats: sides >= 3, and their n * sides fan triangles "
                                               "must be the last of the corners");
                     so.first = nt - so.n * so.sides;
                 }
                 std::unique_ptr<MeshScene> scene;
                 run_released(threads, progress, [&](Context& ctx) {
                     checkpoint(ctx, 0.0);
                     try {
                         scene = std::make_unique<MeshScene>(ctx, C, nt, with_splats ? &so : nullptr);
                     } catch (std::invalid_argument& e) {
                         throw std::runtime_error(std::string("corners: ") + e.what());
                     }
                 });
                 new (self) PyMeshScene{std::move(scene), threads, std::move(keep)};
             },
             nb::arg("corners"), nb::kw_only(), nb::arg("splat_points").none() = nb::none(),
             nb::arg("splat_u").none() = nb::none(), nb::arg("splat_v").none() = nb::none(),
             nb::arg("splat_radii").none() = nb::none(),
             nb::arg("splat_facing").none() = nb::none(), nb::arg("threads") = 0,
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
        .def_prop_ro("extent", [](const PyMeshScene& self) { return self.scene->extent(); },
                     "Largest side of the triangles' box (m).")
        .def_prop_ro("feature_length", [](const PyMeshScene& self) { return self.scene->frame().length; },
                     "Size of the bulk of the triangles (m): the largest per-axis spread between the 1st "
                     "and 99th percentiles of their corners; a far outlier does not change it.")
        .def_prop_ro("center", [](const PyMeshScene& self) {
                         const double* c = self.scene->frame().center;
                         return nb::make_tuple(c[0], c[1], c[2]);
                     },
                     "Origin that float coordinates are stored against (m): the corners' per-axis median.")
        .def_prop_ro("build_seconds", [](const PyMeshScene& self) { return self.scene->build_seconds(); })
        .def_prop_ro("splat_points", [](const PyMeshScene& self) { return self.scene->splat_points(); },
                     "Splat fans cast against as one outline each.")
        .def_prop_ro("vertices", [](const PyMeshScene& self) { return self.scene->vertices(); },
                     "Distinct float corners the ray-casting scene holds (neighbours share theirs).");
}

void bind_surfel_field(nb::module_& m) {
    nb::class_<PySurfelField>(m, "SurfelField",
        "Surfel values looked up at points on surfaces (k nearest with agreeing normals, IDW).")
        .def("__init__",
             [](PySurfelField* self, nb::handle positions, nb::handle normals, nb::handle values,
                int k, double min_cos, bool light_field) {
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
                     f = std::make_unique<SurfelField>(P, N, V, n, k, min_cos, light_field);
                 }
                 new (self) PySurfelField{std::move(f)};
             },
             nb::arg("positions"), nb::arg("normals"), nb::arg("values"), nb::kw_only(),
             nb::arg("k") = 8, nb::arg("min_cos") = 0.5, nb::arg("light_field") = false)
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
        .def_prop_ro("n", [](const PySurfelField& self) { return self.field->size(); })
        .def_prop_ro("reach", [](const PySurfelField& self) { return self.field->reach(); },
                     "Median distance to the k-th nearest surfel (m): the gather's lattice "
                     "spacing is at most this.");
}

void bind_gather(nb::module_& m) {
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

    // A gather prepared once (GatherPlan): the scene, fields and exact parts stay referenced,
    // the per-triangle arrays are copied and checked once.
    struct PyGatherer {
        nb::object scene_ref, front_ref, back_ref, keep_front_rest, keep_back_rest,
            keep_front_lattice, keep_back_lattice;
        // The caller's per-triangle arrays, held (not copied: a scan has millions of splat
        // triangles): uint8 two_sided, int32 owners.
        nb::object keep_sided, keep_front_owner, keep_back_owner;
        const std::uint8_t* sided = nullptr;
        const OwnerRow* own_front = nullptr;
        const OwnerRow* own_back = nullptr;
        ExactPart ex_front, ex_back;
        GatherOptions opt;
        std::unique_ptr<GatherPlan> plan;
    };
    nb::class_<PyGatherer>(m, "Gatherer")
        .def("__init__",
             [](PyGatherer* self, nb::handle scene_h, nb::handle front_h, nb::handle back,
                double offset, nb::handle background, nb::handle two_sided,
                nb::handle owner_front, nb::handle owner_back, nb::handle front_rest,
                nb::handle front_lattice, nb::handle back_rest, nb::handle back_lattice,
                bool tabulate, int threads, nb::handle progress) {
                 // Built aside and moved in only once complete: nanobind destroys no half-built
                 // instance, so a refused argument must not leave references behind.
                 PyGatherer g;
                 PyMeshScene& scene = nb::cast<PyMeshScene&>(scene_h);
                 PySurfelField& front = nb::cast<PySurfelField&>(front_h);
                 g.scene_ref = nb::borrow(scene_h);
                 g.front_ref = nb::borrow(front_h);
                 std::size_t nbg;
                 nb::object k4;
                 const double* BG = view<double>(background, "background", 1, 0, nbg, k4);
                 if (nbg != 3) throw nb::value_error("background must have 3 values");
                 if (!(offset >= 0) || !std::isfinite(offset)) throw nb::value_error("offset must be finite and >= 0");
                 const std::size_t T = scene.scene->size();
                 if (two_sided.is_valid() && !two_sided.is_none()) {
                     std::size_t ns;
                     g.sided = view<std::uint8_t>(two_sided, "two_sided", 1, 0, ns, g.keep_sided);
                     if (ns != T) throw nb::value_error("two_sided must have one entry per triangle");
                 }
                 const SurfelField* back_field = nullptr;
                 if (back.is_valid() && !back.is_none()) {
                     back_field = nb::cast<PySurfelField&>(back).field.get();
                     g.back_ref = nb::borrow(back);
                 }
                 // Splat owners: -1, or a row of the field they index.
                 auto owners = [&](nb::handle h, const char* name, const SurfelField* field,
                                   nb::object& keep) -> const OwnerRow* {
                     if (!h.is_valid() || h.is_none()) return nullptr;
                     std::size_t no;
                     const OwnerRow* O = view<OwnerRow>(h, name, 1, 0, no, keep);
                     if (no != T)
                         throw nb::value_error((std::string(name) + " must have one entry per triangle").c_str());
                     const std::int64_t limit = field ? std::int64_t(field->size()) : 0;
                     for (std::size_t t = 0; t < no; ++t)
                         if (O[t] < -1 || O[t] >= limit)
                             throw nb::value_error((std::string(name) + "[" + std::to_string(t) +
                                                    "] is not -1 or a surfel of its field").c_str());
                     return O;
                 };
                 g.own_front = owners(owner_front, "owner_front", front.field.get(), g.keep_front_owner);
                 g.own_back = owners(owner_back, "owner_back", back_field, g.keep_back_owner);
                 const std::uint8_t* sided = g.sided;
                 const OwnerRow* of = g.own_front;
                 const OwnerRow* ob = g.own_back;
                 // Exact parts: a rest field and one value per lattice point, both or neither.
                 GatherLattice lat_front, lat_back;
                 if (!front_lattice.is_none() || !back_lattice.is_none())
                     gather_lattices(*scene.scene, *front.field, back_field, sided, of, ob,
                                     lat_front, lat_back);
                 auto exact = [&](nb::handle rest, nb::handle lattice, const char* name,
                                  std::size_t expected, nb::object& keep_lattice, nb::object& keep_rest) {
                     ExactPart e;
                     if (rest.is_none() != lattice.is_none())
                         throw nb::value_error((std::string(name) + ": give the rest field and the lattice values together").c_str());
                     if (lattice.is_none()) return e;
                     std::size_t nl;
                     e.lattice = view<double>(lattice, name, 2, 3, nl, keep_lattice);
                     if (nl != expected)
                         throw nb::value_error((std::string(name) + " must have " + std::to_string(expected) +
                                                " rows (gather_lattices), got " + std::to_string(nl)).c_str());
                     e.rest = nb::cast<PySurfelField&>(rest).field.get();
                     keep_rest = nb::borrow(rest);
                     return e;
                 };
                 g.ex_front = exact(front_rest, front_lattice, "front_lattice", lat_front.size(),
                                        g.keep_front_lattice, g.keep_front_rest);
                 if (!back_lattice.is_none() && !back_field)
                     throw nb::value_error("back_lattice needs a back field");
                 g.ex_back = exact(back_rest, back_lattice, "back_lattice", lat_back.size(),
                                       g.keep_back_lattice, g.keep_back_rest);
                 g.opt.offset = offset;
                 g.opt.tabulate = tabulate;
                 for (int c = 0; c < 3; ++c) g.opt.background[c] = BG[c];
                 run_released(threads, progress, [&](Context& ctx) {
                     checkpoint(ctx, 0.0);
                     g.plan = std::make_unique<GatherPlan>(
                         ctx, *scene.scene, *front.field, back_field, g.opt, sided, of, ob,
                         g.ex_front.lattice ? &g.ex_front : nullptr,
                         g.ex_back.lattice ? &g.ex_back : nullptr);
                 });
                 new (self) PyGatherer(std::move(g));   // the plan keeps no pointer into g itself
             },
             nb::arg("scene"), nb::arg("front"), nb::arg("back").none(), nb::kw_only(),
             nb::arg("offset"), nb::arg("background"), nb::arg("two_sided").none() = nb::none(),
             nb::arg("owner_front").none() = nb::none(), nb::arg("owner_back").none() = nb::none(),
             nb::arg("front_rest").none() = nb::none(), nb::arg("front_lattice").none() = nb::none(),
             nb::arg("back_rest").none() = nb::none(), nb::arg("back_lattice").none() = nb::none(),
             nb::arg("tabulate") = true, nb::arg("threads") = 0, nb::arg("progress") = nb::none(),
             "A final gather prepared once for any number of receivers (its field tables).")
        .def("gather",
             [](PyGatherer& self, nb::handle positions, nb::handle normals, nb::handle ids, int rays,
                std::uint64_t seed, nb::handle rays_per, nb::handle faces, nb::handle share_start,
                nb::handle share_positions, nb::handle share_faces, int threads,
                nb::handle progress) {
                 const double *P, *N;
                 nb::object k1, k2, k3;
                 const std::size_t m = paired_rays(positions, "positions", normals, "normals", P, N, k1, k2);
                 std::size_t ni;
                 const std::int64_t* I = view<std::int64_t>(ids, "ids", 1, 0, ni, k3);
                 if (ni != m) throw nb::value_error("ids must have one entry per receiver");
                 if (rays < 1) throw nb::value_error("rays must be >= 1");
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
                 const double* F = nullptr;
                 nb::object k7;
                 if (faces.is_valid() && !faces.is_none()) {
                     std::size_t nf;
                     F = view<double>(faces, "faces", 2, 3, nf, k7);
                     if (nf != m) throw nb::value_error("faces must have one row per receiver");
                 }
                 // Corners sharing the receivers' rays in faces of their own (FaceShares).
                 FaceShares sh;
                 nb::object k8, k9, k10;
                 const bool with_shares = share_start.is_valid() && !share_start.is_none();
                 if (with_shares) {
                     if (!F) throw nb::value_error("face shares need the receivers' faces");
                     std::size_t ns, np_, nfs;
                     sh.start = view<std::int64_t>(share_start, "share_start", 1, 0, ns, k8);
                     if (ns != m + 1) throw nb::value_error("share_start must have one entry per receiver and one more");
                     sh.positions = view<double>(share_positions, "share_positions", 2, 3, np_, k9);
                     sh.faces = view<double>(share_faces, "share_faces", 2, 3, nfs, k10);
                     if (np_ != nfs) throw nb::value_error("share_positions and share_faces must have as many rows");
                     if (sh.start[0] != 0 || std::size_t(sh.start[m]) != np_)
                         throw nb::value_error("share_start must run from 0 to the number of shares");
                     for (std::size_t i = 0; i < m; ++i)
                         if (sh.start[i + 1] < sh.start[i]) throw nb::value_error("share_start must not decrease");
                     sh.count = np_;
                 }
                 const std::size_t rows = m + sh.count;
                 double *out, *err, *reach, *open, *halves;
                 auto a1 = new_array(rows, 3, &out);
                 auto a2 = new_array(rows, 0, &err);
                 auto a3 = new_array(rows, 0, &reach);
                 auto a4 = new_array(rows, 0, &open);
                 auto a5 = new_array(rows, 0, &halves);
                 run_released(threads, progress, [&](Context& ctx) {
                     ctx.set_phase("gather", 0.0, 1.0);
                     checkpoint(ctx, 0.0);
                     self.plan->gather(ctx, P, N, I, m, rays, seed, per.empty() ? nullptr : per.data(),
                                       out, err, reach, open, halves, F, with_shares ? &sh : nullptr);
                 });
                 return nb::make_tuple(a1, a2, a3, a4, a5, std::size_t(sh.recast));
             },
             nb::arg("positions"), nb::arg("normals"), nb::arg("ids"), nb::kw_only(),
             nb::arg("rays"), nb::arg("seed") = 0, nb::arg("rays_per").none() = nb::none(),
             nb::arg("faces").none() = nb::none(), nb::arg("share_start").none() = nb::none(),
             nb::arg("share_positions").none() = nb::none(), nb::arg("share_faces").none() = nb::none(),
             nb::arg("threads") = 0, nb::arg("progress") = nb::none(),
             "Final gather: (mean radiance (M, 3), standard error of its luminance (M,), reach (M,) m, "
             "share of the rays that hit nothing (M,), half the difference of the even and odd "
             "rays' mean luminance (M,), rays cast again for the shares); with shares (corners taking "
             "the receivers' rays in faces of their own: offsets (M + 1,), points and faces (E, 3)) "
             "each array has M + E rows.")
        .def("hit_values",
             [](PyGatherer& self, nb::handle triangles, nb::handle front, nb::handle points,
                int threads) {
                 std::size_t nt, nf, np_;
                 nb::object k1, k2, k3;
                 const std::int64_t* T = view<std::int64_t>(triangles, "triangles", 1, 0, nt, k1);
                 const std::uint8_t* F = view<std::uint8_t>(front, "front", 1, 0, nf, k2);
                 const double* P = view<double>(points, "points", 2, 3, np_, k3);
                 if (nf != nt || np_ != nt)
                     throw nb::value_error("triangles, front and points must have the same length");
                 const std::size_t n_tri = self.plan->triangles();
                 for (std::size_t i = 0; i < nt; ++i)
                     if (T[i] < 0 || std::size_t(T[i]) >= n_tri)
                         throw nb::value_error(("triangles[" + std::to_string(i) + "] is not a triangle of the scene").c_str());
                 double* out;
                 auto a = new_array(nt, 3, &out);
                 run_released(threads, nb::none(), [&](Context& ctx) {
                     self.plan->hit_values(ctx, T, F, P, nt, out);
                 });
                 return a;
             },
             nb::arg("triangles"), nb::arg("front"), nb::arg("points"), nb::kw_only(),
             nb::arg("threads") = 0,
             "What a gather ray takes at hits (triangle, front face, point (M, 3)): radiance (M, 3).");

    m.def("gather_lattices",
          [](PyMeshScene& scene, PySurfelField& front, nb::handle back, nb::handle two_sided,
             nb::handle owner_front, nb::handle owner_back) {
              const std::size_t T = scene.scene->size();
              // uint8 two_sided, int32 owners (only their signs matter here: which triangles
              // have a lattice), one entry per triangle each, read in place.
              auto rows = [&](nb::handle h, const char* name, nb::object& keep, auto* tag) {
                  using V = std::remove_pointer_t<decltype(tag)>;
                  if (h.is_none()) return static_cast<const V*>(nullptr);
                  std::size_t n;
                  const V* v = view<V>(h, name, 1, 0, n, keep);
                  if (n != T) throw nb::value_error((std::string(name) + " must have one entry per triangle").c_str());
                  return v;
              };
              nb::object k1, k2, k3;
              const std::uint8_t* S = rows(two_sided, "two_sided", k1, static_cast<std::uint8_t*>(nullptr));
              const OwnerRow* OF = rows(owner_front, "owner_front", k2, static_cast<OwnerRow*>(nullptr));
              const OwnerRow* OB = rows(owner_back, "owner_back", k3, static_cast<OwnerRow*>(nullptr));
              const SurfelField* back_field = back.is_none() ? nullptr : nb::cast<PySurfelField&>(back).field.get();
              GatherLattice f, b;
              {
                  nb::gil_scoped_release nogil;
                  gather_lattices(*scene.scene, *front.field, back_field, S, OF, OB, f, b);
              }
              auto out = [](const std::vector<double>& v) {
                  double* p;
                  auto a = new_array(v.size() / 3, 3, &p);
                  std::copy(v.begin(), v.end(), p);
                  return a;
              };
              auto tri = [](const std::vector<std::int64_t>& v) {
                  std::int64_t* p = new std::int64_t[std::max<std::size_t>(1, v.size())]();
                  nb::capsule own(p, [](void* q) noexcept { delete[] static_cast<std::int64_t*>(q); });
                  std::copy(v.begin(), v.end(), p);
                  return nb::ndarray<nb::numpy, std::int64_t>(p, {v.size()}, own);
              };
              return nb::make_tuple(out(f.points), out(f.normals), out(b.points), out(b.normals),
                                    tri(f.triangle), tri(b.triangle));
          },
          nb::arg("scene"), nb::arg("front"), nb::arg("back").none() = nb::none(), nb::kw_only(),
          nb::arg("two_sided").none() = nb::none(), nb::arg("owner_front").none() = nb::none(),
          nb::arg("owner_back").none() = nb::none(),
          "The gather's lattice points and normals: (front points, front normals, back points, "
          "back normals), each (L, 3), and the triangle each point lies in (front, back), (L,).");
}

}  // namespace illumap::bindings

using namespace illumap;
using namespace illumap::bindings;

NB_MODULE(_core, m) {
    m.doc() = "Illumap native core: FMM and direct radiosity transport operators, k-NN.";
    nb::exception<Cancelled>(m, "Cancelled");
    m.def("hardware_threads", &hardware_threads, "Number of hardware threads.");
    // The limits this module checks itself: name -> (low, high), as illumap.limits has them.
    nb::dict limits;
    limits["order"] = nb::make_tuple(0, kMaxOrder);
    limits["theta"] = nb::make_tuple(0.0, 1.0);
    limits["leaf_size"] = nb::make_tuple(1, kMaxCount);
    limits["threads"] = nb::make_tuple(0, kMaxCount);
    limits["visibility_samples"] = nb::make_tuple(1, kMaxVisibilitySamples);
    limits["seed_k"] = nb::make_tuple(1, kMaxCount);
    limits["seed_leaf_points"] = nb::make_tuple(1, kMaxCount);
    m.attr("LIMITS") = limits;
    bind_operator(m);
    bind_occluders(m);
    bind_mesh_scene(m);
    bind_surfel_field(m);
    bind_gather(m);
    bind_kernel(m);
    bind_point_tools(m);
    bind_irradiance_cache(m);
    bind_lamp_samples(m);
}
