"""illumap._core.Operator: the FMM against the exact direct operator, facing, reciprocity."""
import numpy as np
import pytest

from illumap import _core


def sphere(n, seed=0, inward=True, radius=1.0):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    nrm = -p if inward else p.copy()
    return (np.ascontiguousarray(radius * p), np.ascontiguousarray(nrm),
            np.full(n, 4 * np.pi * radius ** 2 / n))


def cube_surface(n, seed=0):
    """Random surfels on the unit cube's surface, normals pointing inside."""
    rng = np.random.default_rng(seed)
    face = rng.integers(0, 6, n)
    axis, side = face // 2, face % 2
    p = rng.random((n, 3))
    p[np.arange(n), axis] = side
    nrm = np.zeros((n, 3))
    nrm[np.arange(n), axis] = np.where(side == 0, 1.0, -1.0)
    return p, nrm, np.full(n, 6.0 / n)


def rel(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


@pytest.fixture(scope="module")
def sphere_case():
    P, N, A = sphere(3000, seed=1)
    x = np.random.default_rng(2).random((3000, 3))
    y = _core.Operator(P, N, A, method="direct").apply(x)
    return P, N, A, x, y


def test_fmm_error_falls_as_order_rises(sphere_case):
    P, N, A, x, y = sphere_case
    errs = [rel(_core.Operator(P, N, A, order=p, theta=0.5, leaf_size=32).apply(x), y)
            for p in (0, 2, 4, 6, 8)]
    assert all(b < 0.6 * a for a, b in zip(errs[:-1], errs[1:])), errs
    assert errs[0] < 0.1 and errs[-1] < 1e-4, errs


def test_fmm_error_falls_as_theta_falls(sphere_case):
    P, N, A, x, y = sphere_case
    errs = [rel(_core.Operator(P, N, A, order=3, theta=t, leaf_size=16).apply(x), y)
            for t in (0.7, 0.5, 0.3)]
    assert errs[1] < errs[0] and errs[2] < 0.5 * errs[1], errs


def test_fmm_reaches_1e6_on_20k_surfels_of_a_closed_surface():
    P, N, A = cube_surface(20000, seed=3)
    x = np.random.default_rng(4).random((20000, 3))
    y = _core.Operator(P, N, A, method="direct").apply(x)
    op = _core.Operator(P, N, A, order=8, theta=0.35, leaf_size=64)
    err = rel(op.apply(x), y)
    assert err <= 1e-6, err
    assert op.stats["m2l_pairs"] > 0  # the far field really was used


def test_every_order_up_to_ten_runs_and_small_n_is_exact():
    P, N, A = sphere(200, seed=5)
    x = np.random.default_rng(6).random((200, 3))
    y = _core.Operator(P, N, A, method="direct").apply(x)
    theta = 0.6
    errs = [rel(_core.Operator(P, N, A, order=p, theta=theta, leaf_size=8).apply(x), y)
            for p in range(11)]
    assert max(errs) < 0.2, errs
    # each order is used: the expansion's error falls geometrically, by at least θ per order
    # (θ² per two: the even and the odd orders converge each at their own pace)
    assert all(errs[p + 2] <= theta ** 2 * errs[p] for p in range(9)), errs
    # a tiny opening angle accepts only pairs of single surfels (exact in the far field too)
    # and sums everything else directly, so it is exact
    op = _core.Operator(P, N, A, order=2, theta=1e-3)
    np.testing.assert_allclose(op.apply(x), y, rtol=1e-12, atol=1e-15)


def test_point_kernel_inside_a_sphere_is_exact():
    # Inside a sphere every pair faces and F_ij = A_j / (4 pi R^2) for the point kernel.
    R = 2.0
    P, N, A = sphere(500, seed=7, radius=R)
    A = A * np.random.default_rng(8).uniform(0.5, 1.5, 500)
    x = np.random.default_rng(9).random((500, 3))
    expected = (A[:, None] * x).sum(0)[None, :] - A[:, None] * x  # r = 0 (self) contributes 0
    expected /= 4 * np.pi * R ** 2
    for method in ("direct", "fmm"):
        op = _core.Operator(P, N, A, method=method, near_field="point", order=8, theta=0.3,
                            leaf_size=16)
        tol = 1e-12 if method == "direct" else 1e-5
        assert rel(op.apply(x), expected) < tol


def test_reciprocity_and_symmetry_of_diag_a_f():
    P, N, A = cube_surface(300, seed=10)
    A = A * np.random.default_rng(11).uniform(0.3, 2.0, 300)
    op = _core.Operator(P, N, A, method="direct")
    assert op.symmetric
    F = np.empty((300, 300))
    for j in range(300):
        e = np.zeros((300, 3))
        e[j, 0] = 1.0
        F[:, j] = op.apply(e)[:, 0]
    S = A[:, None] * F
    np.testing.assert_allclose(S, S.T, rtol=1e-12, atol=1e-15 * abs(S).max())
    assert (F >= -1e-14 * F.max()).all() and F.max() > 0     # rounding of the row limit
    # apply_rows gives the same rows
    x = np.random.default_rng(12).random((300, 3))
    rows = np.array([0, 17, 299, 17], dtype=np.int64)
    np.testing.assert_allclose(op.apply_rows(x, rows), (F @ x)[rows], rtol=1e-12)
    # the FMM keeps reciprocity up to its expansion error
    fop = _core.Operator(P, N, A, order=6, theta=0.4, leaf_size=8)
    i, j = 5, 250
    ej = np.zeros((300, 3)); ej[j] = 1
    ei = np.zeros((300, 3)); ei[i] = 1
    Fij, Fji = fop.apply(ej)[i, 0], fop.apply(ei)[j, 0]
    assert abs(A[i] * Fij - A[j] * Fji) <= 1e-4 * A[i] * Fij


def test_back_to_back_planes_exchange_nothing():
    rng = np.random.default_rng(13)
    n = 4000
    p = rng.random((n, 3))
    p[:, 2] = np.where(np.arange(n) < n // 2, 0.0, 0.05)
    nrm = np.zeros((n, 3))
    nrm[:, 2] = np.where(np.arange(n) < n // 2, -1.0, 1.0)  # lower faces down, upper faces up
    A = np.full(n, 1.0 / (n // 2))
    x = rng.random((n, 3))
    for method in ("direct", "fmm"):
        y = _core.Operator(p, nrm, A, method=method).apply(x)
        assert np.all(y == 0.0)
    st = _core.Operator(p, nrm, A).stats
    assert sum(st["dropped_per_level"]) > 0 and st["m2l_pairs"] == 0


def test_coplanar_floor_is_dropped_not_summed():
    rng = np.random.default_rng(14)
    n = 20000
    p = np.zeros((n, 3))
    p[:, :2] = 10 * rng.random((n, 2))
    p[:, 2] = 0.3
    nrm = np.tile([0.0, 0.0, 1.0], (n, 1))
    A = np.full(n, 100.0 / n)
    op = _core.Operator(p, nrm, A, leaf_size=32)
    y = op.apply(rng.random((n, 3)))
    assert np.all(y == 0.0)
    st = op.stats
    assert st["m2l_pairs"] == 0
    assert sum(st["dropped_per_level"]) > 100
    # only each leaf against itself is summed directly: far below N^2
    assert st["p2p_pairs"] <= 32 * n < 1e-2 * n * n


def test_facing_pairs_transfer_and_nonfacing_do_not():
    # Two parallel squares facing each other transfer; flip one and nothing moves.
    g = (np.arange(20) + 0.5) / 20
    X, Y = np.meshgrid(g, g)
    sq = np.column_stack([X.ravel(), Y.ravel(), np.zeros(400)])
    P = np.vstack([sq, sq + [0, 0, 1]])
    A = np.full(800, 1 / 400)
    up = np.tile([0.0, 0, 1], (400, 1))
    x = np.zeros((800, 3)); x[400:] = 1.0  # the upper square emits
    for flip, expect_zero in ((-1.0, False), (1.0, True)):
        N = np.vstack([up, flip * up])
        for method in ("direct", "fmm"):
            y = _core.Operator(P, N, A, method=method, order=6, leaf_size=16).apply(x)
            lower = (A[:400] * y[:400, 0]).sum()  # area-weighted view factor lower <- upper
            if expect_zero:
                assert lower == 0.0
            else:
                assert abs(lower - 0.19982489569838746) < 2e-3  # DESIGN.md §4, O(h^2) error


def test_disc_near_field_keeps_closed_row_sums_bounded():
    P, N, A = cube_surface(6000, seed=15)
    ones = np.ones((6000, 3))
    disc = _core.Operator(P, N, A, method="direct").apply(ones)[:, 0]
    point = _core.Operator(P, N, A, method="direct", near_field="point").apply(ones)[:, 0]
    # random sampling puts some surfels very close together, so single rows scatter; the bulk
    # stays near 1 with the disc rule, while the bare point kernel blows up on close pairs
    assert abs(np.median(disc) - 1) < 0.03 and np.percentile(disc, 95) < 1.1
    assert point.max() > 2 * disc.max()
    fmm = _core.Operator(P, N, A, order=4).apply(ones)[:, 0]
    assert abs(fmm - disc).max() < 1e-2


def test_stats_report_the_tree_and_lists():
    P, N, A = sphere(5000, seed=16)
    st = _core.Operator(P, N, A, order=3, theta=0.5, leaf_size=24).stats
    for key in ("nodes", "leaves", "depth", "m2l_pairs", "p2p_pairs", "bytes",
                "dropped_per_level", "split_per_level", "accepted_per_level", "near_per_level"):
        assert key in st
    assert st["leaves"] < st["nodes"] and st["depth"] >= 2 and st["bytes"] > 0
    assert st["p2p_pairs"] < 5000 ** 2 / 5
    assert st["order"] == 3 and st["leaf_size"] == 24
    d = _core.Operator(P, N, A, method="direct").stats
    assert d["method"] == "direct" and d["p2p_pairs"] == 5000 ** 2


@pytest.mark.parametrize("vis", [{}, dict(visibility="exact", visibility_leaf_mode="per_pair_all",
                                          visibility_samples=16)])
def test_sources_that_are_zero_are_skipped_without_changing_the_sum(vis):
    # The near field, M2L, M2P and P2L leave out sources whose values are all zero (the first
    # application, K(E), has values at the emitters only). Linearity catches a source left out
    # that should not be: K(x_few) + K(x_rest) = K(x_few + x_rest) to rounding.
    p, n, a = cube_surface(3000, seed=4)
    op = _core.Operator(p, n, a, method="fmm", order=3, theta=0.3, leaf_size=16, **vis)
    rng = np.random.default_rng(5)
    few = np.zeros((3000, 3))
    few[rng.choice(3000, 40, replace=False)] = rng.random((40, 3))
    rest = rng.random((3000, 3)) * (few == 0)
    y_few, y_rest, y_all = op.apply(few), op.apply(rest), op.apply(few + rest)
    assert rel(y_few + y_rest, y_all) < 1e-13
    assert np.count_nonzero(y_few) > 0.5 * y_few.size   # the few still reach most receivers
    # and the near field of the few is there: against the exact per-pair sums (which differ
    # from the FMM by its expansion and, with visibility, its sampled classes only)
    exact = op.apply_rows(few, np.arange(3000, dtype=np.int64))
    assert rel(y_few, exact) < 0.02
