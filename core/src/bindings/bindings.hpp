// bindings.hpp — what the binding files of illumap._core share: checked views of numpy
// arrays, new result arrays, running native code without the GIL, the objects the Python
// classes hold, and one registration function per class or function group.
//
// Shapes, dtypes and contiguity are checked here (ValueError with the array's name); the
// Python layer checks values. Inputs that are already C-contiguous float64 are read in place.
// The GIL is released during compute; progress callbacks re-acquire it on the calling thread.
#pragma once

#include "gather/gather.hpp"
#include "visibility/mesh_scene.hpp"
#include "visibility/raycast.hpp"
#include "transport/transport_operator.hpp"

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <string>

namespace illumap::bindings {

namespace nb = nanobind;

using AnyArray = nb::ndarray<nb::ro, nb::device::cpu>;

// A read-only, C-contiguous float64 (or float32, int64, int32, uint8) view of a numpy array,
// checked.
template <class T>
const T* view(nb::handle h, const char* name, std::size_t ndim, std::int64_t cols,
              std::size_t& rows, nb::object& keep) {
    AnyArray a;
    if (!nb::try_cast<AnyArray>(h, a, false))
        throw nb::value_error((std::string(name) + " must be a numpy array").c_str());
    const char* tname = std::is_same_v<T, double>         ? "float64"
                        : std::is_same_v<T, float>        ? "float32"
                        : std::is_same_v<T, std::int32_t> ? "int32"
                        : std::is_same_v<T, std::uint8_t> ? "uint8"
                                                          : "int64";
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

inline nb::ndarray<nb::numpy, double> new_array(std::size_t rows, std::size_t cols, double** data) {
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

// Two (M, 3) float64 arrays of one length, every value finite.
inline std::size_t paired_rays(nb::handle a, const char* an, nb::handle b, const char* bn,
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

// The names of the visibility options, as the Python API spells them (ValueError otherwise).
inline VisMethod parse_vis_method(const std::string& s) {
    if (s == "none") return VisMethod::None;
    if (s == "seed") return VisMethod::Seed;
    if (s == "exact") return VisMethod::Exact;
    throw nb::value_error(("visibility must be 'none', 'seed' or 'exact', not '" + s + "'").c_str());
}
inline VisibilityOptions::Shape parse_vis_shape(const std::string& s) {
    if (s == "disc") return VisibilityOptions::Shape::Disc;
    if (s == "quad") return VisibilityOptions::Shape::Quad;
    if (s == "octagon") return VisibilityOptions::Shape::Octagon;
    throw nb::value_error(
        ("visibility shape must be 'disc', 'quad' or 'octagon', not '" + s + "'").c_str());
}
inline LeafMode parse_leaf_mode(const std::string& s) {
    if (s == "binary") return LeafMode::Binary;
    if (s == "fractional") return LeafMode::Fractional;
    if (s == "per_pair") return LeafMode::PerPair;
    if (s == "per_pair_all") return LeafMode::PerPairAll;
    throw nb::value_error(
        ("leaf mode must be 'binary', 'fractional', 'per_pair' or 'per_pair_all', not '" + s +
         "'").c_str());
}

// What the Python classes hold.
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
    nb::object corners;  // the array the scene reads its triangles' corners from
};

struct PySurfelField {
    std::unique_ptr<SurfelField> field;
};

// One registration function per class or function group (bindings.cpp calls them in order).
void bind_operator(nb::module_& m);        // Operator            (bind_operator.cpp)
void bind_occluders(nb::module_& m);       // Occluders           (bind_occluders.cpp)
void bind_mesh_scene(nb::module_& m);      // MeshScene           (bindings.cpp)
void bind_surfel_field(nb::module_& m);    // SurfelField         (bindings.cpp)
void bind_gather(nb::module_& m);          // cosine_directions, gather (bindings.cpp)
void bind_kernel(nb::module_& m);          // _kernel_derivatives (bind_tools.cpp)
void bind_lamp_samples(nb::module_& m);    // lamp_samples (bind_tools.cpp)
void bind_point_tools(nb::module_& m);     // knn, normals, splat_radii (bind_tools.cpp)
void bind_irradiance_cache(nb::module_& m);  // record_lookup, fitted_values (bind_cache.cpp)

}  // namespace illumap::bindings
