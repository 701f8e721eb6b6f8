"""Stability where methods fail (docs/stability.md): one or more tests per case, each asserting
the behaviour the page documents. Public illumap API only; the whole file runs in well under a
minute on two shared cores.
"""

import math

import numpy as np
import pytest

import illumap
from illumap import scenes
from illumap.operator import VISIBILITIES


def row_sums(surfels, **kw):
    op = illumap.TransportOperator(surfels, **kw)
    return op.apply(np.ones((surfels.n, 3)))[:, 0]


def rel_rms(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b ** 2)))


# --- 1. near-singular pairs at touching surfaces and corners --------------------------------------

def test_bare_point_kernel_overshoots_at_edges_and_disc_rule_bounds_it():
    box = scenes.closed_box(8)
    point = row_sums(box, method="direct", near_field="point")
    disc = row_sums(box, method="direct", near_field="disc")
    assert point.max() > 1.2            # DESIGN §2: 1.24 at edges and corners
    assert disc.max() < 1.02            # bounded near field: O(h) excess only
    assert disc.min() > 0.95
    # the overshoot sits at edges and corners: the surfels nearest another face
    d_edge = np.min(np.minimum(box.positions, 1.0 - box.positions)
                    + np.where(np.abs(box.normals) > 0.5, 9.0, 0.0), axis=1)
    assert point[d_edge < 0.1].mean() > point[d_edge > 0.3].mean() + 0.1


def test_touching_perpendicular_squares_converge_at_first_order():
    errors = []
    for n in (8, 16, 32):
        s, a, b = scenes.perpendicular_squares(n)
        op = illumap.TransportOperator(s, method="direct")
        errors.append(abs(scenes.view_factor(op.apply, s, a, b) - scenes.PERPENDICULAR_SQUARES_F))
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.01
    assert errors[0] / errors[2] > 2.5      # about O(h): halving h twice gives ~4x


def test_bare_point_kernel_fails_loudly_or_wrongly_at_high_albedo():
    box = scenes.closed_box(8, albedo=0.99)
    cg = illumap.solve(box, method="direct", near_field="point", solver="cg", tol=1e-6)
    assert not cg.converged and "positive definite" in cg.stats["warning"]
    jacobi = illumap.solve(box, method="direct", near_field="point", solver="jacobi", tol=1e-6)
    assert not jacobi.converged and "diverged" in jacobi.stats["warning"]
    # GMRES "converges" to a meaningless, negative radiosity: why the disc rule is the default
    gmres = illumap.solve(box, method="direct", near_field="point", solver="gmres", tol=1e-6)
    assert gmres.radiosity.min() < 0
    disc = illumap.solve(box, method="direct", near_field="disc", solver="auto", tol=1e-6)
    assert disc.converged and disc.radiosity.min() > 1.0


# --- 2. thin walls and light leaks ------------------------------------------------------------------

def _thin_wall(gap=1e-3, n=10):
    """An emitter facing a wall made of two back-to-back panels (gap apart), and a receiver
    panel beyond the wall facing the emitter. Returns surfels and masks."""
    def grid(z, normal, k=n):
        g = (np.arange(k) + 0.5) / k - 0.5
        x, y = np.meshgrid(g, g)
        p = np.column_stack([x.ravel(), y.ravel(), np.full(k * k, z)])
        return p, np.tile(normal, (k * k, 1)), np.full(k * k, 1.0 / (k * k))
    parts = [grid(0.0, (0, 0, 1.0)),              # emitter, facing +z
             grid(0.5, (0, 0, -1.0)),             # wall, side facing the emitter
             grid(0.5 + gap, (0, 0, 1.0)),        # wall, far side
             grid(1.0, (0, 0, -1.0))]             # receiver beyond the wall, facing the emitter
    P, N, A = (np.concatenate([p[i] for p in parts]) for i in range(3))
    k = n * n
    emission = np.zeros((4 * k, 3))
    emission[:k] = 1.0
    albedo = np.full((4 * k, 3), 0.5)
    albedo[:k] = 0.0
    masks = [np.arange(4 * k) // k == i for i in range(4)]
    return illumap.Surfels(P, N, A, albedo, emission), masks


@pytest.mark.parametrize("method", ["direct", "fmm"])
@pytest.mark.parametrize("visibility", list(VISIBILITIES))
def test_thin_wall(visibility, method):
    """visibility="none" leaks through the wall by design (V = 1): the receiver gets exactly the
    unoccluded exchange. The occluding modes ("seed", "exact") stop it, with the direct operator
    (V per pair) and with the FMM (node pairs behind the wall classified hidden)."""
    implemented = VISIBILITIES[visibility][0]
    if not implemented:
        pytest.skip(f"visibility={visibility!r} is not available in this build; the thin-wall "
                    "leak is then asserted only for 'none'")
    s, (emit, near, far, recv) = _thin_wall()
    sol = illumap.solve(s, method=method, visibility=visibility, tol=1e-10)
    B = sol.radiosity[:, 0]
    # the two sides of the wall face away from each other: they never exchange
    only_far = np.zeros((s.n, 3))
    only_far[far] = 1.0
    op = illumap.TransportOperator(s, method=method, visibility=visibility)
    assert np.all(op.apply(only_far)[near] == 0)
    if visibility == "none":
        # leak: the receiver sees the emitter straight through the wall, as if it were absent
        unoccluded = 0.5 * op.apply(np.where(emit[:, None], 1.0, np.zeros((s.n, 3))))[recv, 0]
        assert B[recv].mean() > 0.9 * unoccluded.mean() > 0.01
    else:
        assert B[recv].mean() < 0.01 * B[near].mean()


@pytest.mark.parametrize("method", ["direct", "fmm"])
@pytest.mark.parametrize("visibility", ["seed", "exact"])
def test_visibility_does_not_occlude_a_convex_closed_box(visibility, method):
    """Over-occlusion check: inside a closed cube nothing is between any two surfels, so the
    occluding modes must give the same row sums as visibility="none" (rays grazing along the
    walls and into the corners must not hit the neighbouring discs)."""
    s = scenes.closed_box(8, albedo=0.9, emission=1.0)
    one = np.ones((s.n, 3))
    plain = illumap.TransportOperator(s, method=method).apply(one)
    occluded = illumap.TransportOperator(s, method=method, visibility=visibility).apply(one)
    assert np.max(np.abs(occluded - plain)) < 1e-3


# --- 3. albedo 0.99 ---------------------------------------------------------------------------------

def test_albedo_099_krylov_converges_fast_and_jacobi_slowly():
    box = scenes.closed_box(8, albedo=0.99)
    cg = illumap.solve(box, method="fmm", order=4, solver="cg", tol=1e-6)
    jac = illumap.solve(box, method="fmm", order=4, solver="jacobi", tol=1e-6)
    assert cg.converged and cg.iterations <= 30
    assert jac.converged and jac.iterations > 10 * cg.iterations
    assert rel_rms(jac.radiosity, cg.radiosity) < 1e-4


def test_albedo_099_amplifies_the_row_sum_error_which_shrinks_with_density():
    """Furnace: B = E/(1 − ρ) = 100 if row sums were 1. The disc rule's O(h) row-sum excess
    (mean 1.005 at 8×8 per face) is amplified ~1/(1 − ρ) times: B/100 = 2.57 at 6×6, 1.48 at
    12×12, 1.20 at 24×24. Refining the sampling shrinks it."""
    excess = []
    for n in (6, 12):
        box = scenes.closed_box(n, albedo=0.99)
        sol = illumap.solve(box, method="direct", tol=1e-8)
        assert sol.converged and np.all(sol.radiosity > 1.0)
        excess.append(sol.radiosity.mean() / 100.0 - 1.0)
    assert 0 < excess[1] < 0.5 * excess[0] and excess[0] < 2.0


def test_albedo_of_one_is_refused():
    box = scenes.closed_box(4, albedo=0.9)
    with pytest.raises(illumap.InputError, match="must be < 1"):
        box.replace(albedo=np.ones((box.n, 3)))


# --- 4. very sparse or very uneven sampling ---------------------------------------------------------

@pytest.mark.parametrize("n,sampling,areas", [(12, "fibonacci", "uniform"),
                                               (400, "clustered", "random"),
                                               (400, "random", "random")])
def test_sparse_and_uneven_sampling_match_the_closed_form(n, sampling, areas):
    s = scenes.sphere_interior(n, sampling=sampling, areas=areas, albedo=0.8, seed=3)
    exact = scenes.sphere_exact_radiosity(s, 1.0)
    for method in ("direct", "fmm"):
        sol = illumap.solve(s, method=method, order=6, near_field="point", tol=1e-10)
        assert rel_rms(sol.radiosity, exact) < (1e-8 if method == "direct" else 1e-3)


def test_uneven_sampling_with_the_disc_rule_stays_bounded():
    """Clustered sampling with random areas: the disc rule only damps close pairs, so the
    result stays within a few % of the closed form and never exceeds it."""
    s = scenes.sphere_interior(600, sampling="clustered", areas="random", albedo=0.8, seed=1)
    exact = scenes.sphere_exact_radiosity(s, 1.0)
    sol = illumap.solve(s, method="fmm", tol=1e-8)
    assert rel_rms(sol.radiosity, exact) < 0.05
    assert sol.radiosity.mean() <= exact.mean() * (1 + 1e-9)


# --- 5. scenes at 1e-3 and 1e3 scale ----------------------------------------------------------------

@pytest.mark.parametrize("scale", [1e-3, 1e3])
@pytest.mark.parametrize("method", ["direct", "fmm"])
def test_radiosity_is_scale_invariant(scale, method):
    s = scenes.box_room(1500, seed=2)
    big = illumap.Surfels(s.positions * scale, s.normals, s.areas * scale ** 2, s.albedo,
                          s.emission)
    a = illumap.solve(s, method=method, tol=1e-10)
    b = illumap.solve(big, method=method, tol=1e-10)
    assert a.converged and b.converged
    assert rel_rms(b.radiosity, a.radiosity) < 1e-8


# --- 6. duplicate and coincident points -------------------------------------------------------------

def test_duplicated_surfels_with_split_areas_change_nothing_much():
    s = scenes.closed_box(8, albedo=0.7, emission=0.0).replace(
        emission=np.where(np.arange(384)[:, None] < 64, 1.0, 0.0) * np.ones((384, 3)))
    dup = np.arange(0, s.n, 3)
    areas = s.areas.copy()
    areas[dup] /= 2
    d = illumap.Surfels(np.concatenate([s.positions, s.positions[dup]]),
                        np.concatenate([s.normals, s.normals[dup]]),
                        np.concatenate([areas, areas[dup]]),
                        np.concatenate([s.albedo, s.albedo[dup]]),
                        np.concatenate([s.emission, s.emission[dup]]))
    for method in ("direct", "fmm"):
        a = illumap.solve(s, method=method, tol=1e-10)
        b = illumap.solve(d, method=method, tol=1e-10)
        assert np.all(np.isfinite(b.radiosity))
        # a coincident pair does not interact (r = 0); both copies get the same value
        assert np.allclose(b.radiosity[s.n:], b.radiosity[dup], rtol=1e-6)
        # splitting a surfel's area changes the near-field weight w(t) of its close pairs
        # (t uses the pair's mean area): 2.5% RMS here, never a blow-up
        assert rel_rms(b.radiosity[:s.n], a.radiosity) < 0.05


def test_coincident_back_to_back_points_do_not_exchange():
    p = np.array([[0.0, 0, 0], [0.0, 0, 0], [0.0, 0, 1.0]])
    n = np.array([[0, 0, 1.0], [0, 0, -1.0], [0, 0, -1.0]])
    s = illumap.Surfels(p, n, np.full(3, 0.01), np.full((3, 3), 0.5),
                        np.array([[0.0] * 3, [1.0] * 3, [0.0] * 3]))
    sol = illumap.solve(s, method="direct", tol=1e-12)
    assert np.all(np.isfinite(sol.radiosity))
    assert sol.radiosity[0, 0] == 0.0 and sol.radiosity[2, 0] == 0.0


def test_duplicated_surfels_with_exact_visibility_do_not_shadow_each_other():
    """Coincident copies with exact visibility: each copy's disc sits on the other's ray
    origin; rays ignore occluders within a fraction of the endpoint's disc radius, so the copies
    neither shadow each other nor the scene (change < 3% RMS, copies equal)."""
    s = scenes.box_room(1500, seed=2)
    base = illumap.solve(s, method="direct", visibility="exact", tol=1e-8).radiosity
    k = s.n // 3
    areas = s.areas.copy()
    areas[:k] /= 2
    d = illumap.Surfels(np.concatenate([s.positions, s.positions[:k]]),
                        np.concatenate([s.normals, s.normals[:k]]),
                        np.concatenate([areas, areas[:k]]),
                        np.concatenate([s.albedo, s.albedo[:k]]),
                        np.concatenate([s.emission, s.emission[:k]]))
    sol = illumap.solve(d, method="direct", visibility="exact", tol=1e-8)
    assert sol.converged
    assert np.max(np.abs(sol.radiosity[:k] - sol.radiosity[s.n:])) < 1e-9
    lit = ~(s.emission.max(axis=1) > 0)
    assert rel_rms(sol.radiosity[:s.n][lit], base[lit]) < 0.03


# --- 7. flipped or noisy normals ---------------------------------------------------------------------

def test_flipped_normals_neither_receive_nor_send():
    s = scenes.closed_box(8, albedo=0.7, emission=0.0)
    emission = np.zeros((s.n, 3))
    emission[:64] = 1.0
    rng = np.random.default_rng(0)
    flip = np.zeros(s.n, bool)
    flip[rng.choice(np.arange(64, s.n), 40, replace=False)] = True
    normals = np.where(flip[:, None], -s.normals, s.normals)
    f = s.replace(normals=normals, emission=emission)
    sol = illumap.solve(f, method="fmm", tol=1e-8)
    assert sol.converged
    assert np.all(sol.radiosity[flip] == 0.0)          # faces the outside: gets nothing
    clean = illumap.solve(s.replace(emission=emission), method="fmm", tol=1e-8)
    assert np.all(sol.radiosity[~flip] <= clean.radiosity[~flip] + 1e-9)  # lost their light


def test_noisy_normals_degrade_smoothly():
    s = scenes.closed_box(10, albedo=0.7, emission=0.0)
    emission = np.zeros((s.n, 3))
    emission[:100] = 1.0
    s = s.replace(emission=emission)
    clean = illumap.solve(s, method="fmm", tol=1e-8).radiosity
    rng = np.random.default_rng(1)
    errs, noise = [], (2.0, 10.0)
    for degrees in noise:
        noisy = s.normals + rng.normal(scale=math.radians(degrees), size=s.normals.shape)
        noisy /= np.linalg.norm(noisy, axis=1)[:, None]
        sol = illumap.solve(s.replace(normals=noisy), method="fmm", tol=1e-8)
        assert sol.converged and np.all(np.isfinite(sol.radiosity))
        errs.append(rel_rms(sol.radiosity, clean))
    # to first order a tilt of δ radians moves each cosine of the kernel by at most about δ
    # of its value: the error stays below the noise's own size, and grows with it in step
    # (at most twice faster than in proportion)
    assert all(e < math.radians(d) for e, d in zip(errs, noise)), errs
    assert errs[0] < errs[1] < 2 * (noise[1] / noise[0]) * errs[0], errs


def test_noisy_normals_and_exact_visibility_on_a_convex_scan():
    """A convex object cannot shadow its own lit side. With noisy normals (a scan's PCA
    normals) each surfel's disc is tilted, and the neighbours' discs catch a surfel's grazing
    rays: with the default endpoint offset (0.05 disc radius) the direct light on the lit cap
    of a sphere drops by more than with the offset the automatic mode uses (1 radius), which
    stays within 1% of the unoccluded value."""
    rng = np.random.default_rng(0)
    n = 800
    i = np.arange(n) + 0.5
    phi, th = np.arccos(1 - 2 * i / n), math.pi * (1 + 5 ** 0.5) * i
    u = np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], axis=1)
    normals = u + 0.1 * rng.normal(size=u.shape)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    g = (np.arange(10) + 0.5) / 10 - 0.5
    gx, gy = np.meshgrid(g, g)
    light = np.stack([gx.ravel(), gy.ravel(), np.full(100, 1.5)], axis=1)
    s = illumap.Surfels(np.concatenate([0.5 * u, light]),
                        np.concatenate([normals, np.tile([0, 0, -1.0], (100, 1))]),
                        np.concatenate([np.full(n, math.pi / n), np.full(100, 0.01)]),
                        np.zeros((n + 100, 3)),
                        np.concatenate([np.zeros((n, 3)), np.ones((100, 3))]))
    cap = np.flatnonzero(u[:, 2] > 0.4)
    plain = illumap.TransportOperator(s, method="direct").apply(s.emission)[cap, 0].sum()
    ratio = {}
    for offset in (0.05, 1.0):
        op = illumap.TransportOperator(s, method="direct", visibility="exact",
                                       endpoint_offset=offset)
        ratio[offset] = op.apply(s.emission)[cap, 0].sum() / plain
    assert ratio[1.0] > 0.99, ratio
    assert ratio[0.05] < ratio[1.0] - 0.01, ratio


# --- 8. the talk's p = 2-3 expansions -----------------------------------------------------------------

def test_expansion_error_falls_steadily_with_order():
    s = scenes.box_room(3000, seed=4)
    x = np.random.default_rng(0).random((s.n, 3))
    exact = illumap.TransportOperator(s, method="direct").apply(x)
    errs = {p: rel_rms(illumap.TransportOperator(s, method="fmm", order=p, theta=0.5).apply(x),
                       exact) for p in (0, 2, 3, 4, 6, 8)}
    orders = sorted(errs)
    assert all(errs[a] > errs[b] for a, b in zip(orders, orders[1:])), errs
    # p = 2-3 (the talk's choice) is good to a few 1e-3 in the operator, not to 1e-4
    assert 1e-4 < errs[2] < 1e-2 and 1e-4 < errs[3] < 5e-3
    assert errs[8] < 1e-4


def test_low_order_fmm_keeps_the_operator_nonnegative():
    """The truncated Gegenbauer kernel of the talk can turn negative; the Cartesian expansion
    with the facing test keeps F·1 ≥ 0 at p = 2 and 3 (a negative sum would create light)."""
    s = scenes.box_room(3000, seed=5)
    for p in (2, 3):
        y = illumap.TransportOperator(s, method="fmm", order=p).apply(np.ones((s.n, 3)))
        assert y.min() >= 0.0
