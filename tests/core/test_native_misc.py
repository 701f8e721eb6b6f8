"""illumap._core: k-NN, progress and cancellation, and argument checking."""
import numpy as np
import pytest

from illumap import _core


def cloud(n, seed=0):
    return np.random.default_rng(seed).random((n, 3))


def test_hardware_threads():
    assert _core.hardware_threads() >= 1


@pytest.mark.parametrize("k", [1, 5, 16])
def test_knn_matches_brute_force(k):
    P = cloud(3000, 1)
    Q = np.vstack([cloud(400, 2), P[:50]])  # some queries coincide with points
    idx, dist = _core.knn(P, Q, k)
    assert idx.shape == (450, k) and idx.dtype == np.int64 and dist.dtype == np.float64
    D = np.linalg.norm(Q[:, None, :] - P[None, :, :], axis=2)
    ref = np.sort(D, axis=1)[:, :k]
    np.testing.assert_allclose(dist, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.take_along_axis(D, idx, 1), ref, atol=1e-12)
    assert (np.diff(dist, axis=1) >= 0).all()
    np.testing.assert_array_equal(idx[400:, 0], np.arange(50))  # a point finds itself
    assert (dist[400:, 0] == 0).all()


def test_knn_handles_duplicates_and_planes():
    P = np.zeros((500, 3))
    P[:250, :2] = cloud(250, 3)[:, :2]  # flat
    P[250:] = P[0]  # many coincident points
    idx, dist = _core.knn(P, P[:10], 8)
    D = np.linalg.norm(P[:10, None] - P[None], axis=2)
    np.testing.assert_allclose(dist, np.sort(D, 1)[:, :8], atol=1e-12)


def test_knn_errors():
    P = cloud(10)
    with pytest.raises(ValueError):
        _core.knn(P, P, 11)
    with pytest.raises(ValueError):
        _core.knn(P, P, 0)
    with pytest.raises(ValueError):
        _core.knn(P[:, :2].copy(), P, 1)
    with pytest.raises(ValueError):
        _core.knn(P.astype(np.float32), P, 1)


def surfels(n, seed=0):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    return np.ascontiguousarray(p), np.ascontiguousarray(-p), np.full(n, 4 * np.pi / n)


@pytest.mark.parametrize("method", ["direct", "fmm"])
def test_progress_reports_fractions_and_phases(method):
    P, N, A = surfels(2000)
    calls = []
    op = _core.Operator(P, N, A, method=method)
    y = op.apply(np.ones((2000, 3)), progress=lambda f, ph: calls.append((f, ph)))
    assert y.shape == (2000, 3) and calls
    assert all(0.0 <= f <= 1.0 and isinstance(ph, str) for f, ph in calls)


@pytest.mark.parametrize("method", ["direct", "fmm"])
def test_returning_false_cancels(method):
    P, N, A = surfels(2000)
    op = _core.Operator(P, N, A, method=method)
    with pytest.raises(_core.Cancelled):
        op.apply(np.ones((2000, 3)), progress=lambda f, ph: False)
    with pytest.raises(_core.Cancelled):
        _core.Operator(P, N, A, method=method, progress=lambda f, ph: False)
    with pytest.raises(_core.Cancelled):
        op.apply_rows(np.ones((2000, 3)), np.arange(5, dtype=np.int64), progress=lambda f, ph: False)
    # the operator still works afterwards
    assert np.isfinite(op.apply(np.ones((2000, 3)))).all()


@pytest.mark.parametrize("threads", [0, 1])
def test_cancel_in_the_middle_of_a_long_run(threads):
    """threads=1 runs the chunks on the calling thread, which then polls between them: the
    run reports progress part way and stops when asked, as with worker threads."""
    P, N, A = surfels(40000, 1)
    op = _core.Operator(P, N, A, method="direct", threads=threads)
    calls = []

    def progress(f, ph):
        calls.append(f)
        return len(calls) < 3  # let it start, then stop it

    with pytest.raises(_core.Cancelled):
        op.apply(np.ones((40000, 3)), progress=progress)
    assert len(calls) == 3
    assert 0.0 < calls[1] < 1.0, calls


def test_a_raising_callback_is_re_raised():
    P, N, A = surfels(1000)
    op = _core.Operator(P, N, A)

    class Boom(RuntimeError):
        pass

    def progress(f, ph):
        raise Boom("stop here")

    with pytest.raises(Boom, match="stop here"):
        op.apply(np.ones((1000, 3)), progress=progress)
    with pytest.raises(Boom):
        _core.knn(P, P, 3, progress=progress)


def test_cancelled_is_an_exception_class():
    assert issubclass(_core.Cancelled, Exception)


def test_shape_dtype_and_layout_errors():
    P, N, A = surfels(100)
    good = dict(positions=P, normals=N, areas=A)
    bad = [
        dict(good, positions=P[:, :2].copy()),
        dict(good, positions=P.astype(np.float32)),
        dict(good, positions=np.asfortranarray(P)),
        dict(good, positions=P[::2]),  # wrong length
        dict(good, normals=N.ravel()),
        dict(good, areas=A[:, None].copy()),
        dict(good, areas=A.astype(np.int64)),
        dict(good, positions=P.tolist()),
        dict(good, positions=np.ascontiguousarray(P.T)[:, :100].T),  # non-contiguous view
    ]
    for kw in bad:
        with pytest.raises(ValueError):
            _core.Operator(kw["positions"], kw["normals"], kw["areas"])
    for kw in (dict(method="fast"), dict(near_field="sphere"), dict(order=11), dict(order=-1),
               dict(theta=0.0), dict(theta=1.5), dict(leaf_size=0), dict(threads=-1)):
        with pytest.raises(ValueError):
            _core.Operator(P, N, A, **kw)
    op = _core.Operator(P, N, A)
    with pytest.raises(ValueError):
        op.apply(np.ones((99, 3)))
    with pytest.raises(ValueError):
        op.apply(np.ones((100, 3), dtype=np.float32))
    with pytest.raises(ValueError):
        op.apply(np.ones((3, 100)).T)
    with pytest.raises(ValueError):
        op.apply_rows(np.ones((100, 3)), np.array([0, 100], dtype=np.int64))
    with pytest.raises(ValueError):
        op.apply_rows(np.ones((100, 3)), np.array([0, 1], dtype=np.int32))
    with pytest.raises(ValueError):
        op.apply_rows(np.ones((100, 3)), np.array([-1], dtype=np.int64))


def test_inputs_are_not_modified_and_threads_agree():
    P, N, A = surfels(3000, 2)
    x = np.random.default_rng(3).random((3000, 3))
    copies = [a.copy() for a in (P, N, A, x)]
    y1 = _core.Operator(P, N, A, threads=1).apply(x)
    y2 = _core.Operator(P, N, A, threads=2).apply(x)
    for a, c in zip((P, N, A, x), copies):
        np.testing.assert_array_equal(a, c)
    np.testing.assert_allclose(y1, y2, rtol=1e-13)
    op = _core.Operator(P, N, A)
    assert len(op) == op.n == 3000 and op.method == "fmm" and op.near_field == "disc"
