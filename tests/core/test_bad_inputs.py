"""The bad-input corpus of the core (issue 35): every case is refused up front in the Python
layer with an ``InputError`` whose message names the array or keyword and the cause — never a
raw nanobind type dump, a ``FloatingPointError`` deep in the solve or a plain ``ValueError``
from the native module."""

import numpy as np
import pytest

import illumap
from illumap import sampling
from illumap.operator import MAX_ORDER, TransportOperator


def scene(n=60, scale=1.0, **replace):
    """Two facing plates (the lower one lit by a few emitting surfels on the upper one)."""
    rng = np.random.default_rng(1)
    p = rng.random((n, 3))
    p[: n // 2, 2], p[n // 2:, 2] = 0.0, 0.5
    nrm = np.tile([0.0, 0.0, 1.0], (n, 1))
    nrm[n // 2:] = [0.0, 0.0, -1.0]
    arrays = dict(positions=p * scale, normals=nrm, areas=np.full(n, 2.0 / n) * scale ** 2,
                  albedo=np.full((n, 3), 0.5), emission=np.zeros((n, 3)))
    arrays["emission"][n // 2:n // 2 + 4] = 1.0
    for key, value in replace.items():
        arrays[key] = value(arrays[key].copy()) if callable(value) else value
    return arrays


def surfels(**replace):
    a = scene(**replace)
    return illumap.Surfels(a["positions"], a["normals"], a["areas"], a["albedo"], a["emission"])


def _set(index, value):
    def edit(array):
        array[index] = value
        return array
    return edit


TRI = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1.0, 0, 0], [1, 1, 0], [0, 1, 0]]])

CASES = [
    # (id, call, message regex)
    ("positions-nan", lambda: surfels(positions=_set((3, 1), np.nan)),
     r"positions\[3, 1\] = .*nan.* is not finite"),
    ("positions-shape", lambda: surfels(positions=np.zeros((60, 2))),
     r"positions: expected shape \(N, 3\), got \(60, 2\)"),
    ("positions-empty", lambda: illumap.Surfels(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0),
                                                np.zeros((0, 3)), np.zeros((0, 3))),
     r"positions: no surfels \(N = 0\)"),
    ("positions-strings", lambda: surfels(positions=np.full((60, 3), "x")),
     r"positions: expected real numbers, got dtype <U1"),
    ("scale-1e100", lambda: surfels(scale=1e100),
     r"positions\[0, 0\] = .*e\+(99|100).* lies beyond ±1e\+12: at such scales the kernels "
     r"overflow"),
    ("scale-1e-40", lambda: surfels(scale=1e-40),
     r"areas\[0\] = .*e-8\d.* lies outside \[1e-24, 1e\+24\]"),
    ("translated-1e13", lambda: surfels(positions=lambda p: p + 1e13),
     r"positions\[0, 0\] = .* lies beyond ±1e\+12"),
    ("normals-zero", lambda: surfels(normals=_set(5, 0.0)),
     r"normals\[5\] = \[0\.0, 0\.0, 0\.0\] has zero length"),
    ("normals-not-unit", lambda: surfels(normals=_set(2, [0.0, 0.0, 2.0])),
     r"normals\[2\] = .* has length 2; normals must have unit length"),
    ("normals-missing", lambda: surfels(normals=None),
     r"normals: missing \(got None\)"),
    ("areas-zero", lambda: surfels(areas=_set(7, 0.0)),
     r"areas\[7\] = .*0\.0.* must be > 0"),
    ("areas-inf", lambda: surfels(areas=_set(4, np.inf)),
     r"areas\[4\] = .*inf.* is not finite"),
    ("albedo-one", lambda: surfels(albedo=_set((9, 2), 1.0)),
     r"albedo\[9, 2\] = .*1\.0.* must be < 1 \(an albedo of 1 or more makes the energy"),
    ("albedo-negative", lambda: surfels(albedo=_set((1, 0), -0.1)),
     r"albedo\[1, 0\] = .*-0\.1.* must be >= 0"),
    ("emission-negative", lambda: surfels(emission=_set((0, 1), -1.0)),
     r"emission\[0, 1\] = .*-1\.0.* must be >= 0"),
    ("emission-nan", lambda: surfels(emission=_set((3, 0), np.nan)),
     r"emission\[3, 0\] = .*nan.* is not finite"),
    ("order-11", lambda: illumap.solve(surfels(), order=11),
     r"order: expected an integer >= 0 and <= 10, got 11"),
    ("order-negative", lambda: illumap.solve(surfels(), order=-1),
     r"order: expected an integer >= 0 and <= 10, got -1"),
    ("order-float", lambda: illumap.solve(surfels(), order=4.5),
     r"order: expected an integer >= 0 and <= 10, got 4\.5"),
    ("theta-one", lambda: illumap.solve(surfels(), theta=1.0),
     r"theta: expected a number in \(0, 1\), got 1\.0"),
    ("leaf-size-2^31", lambda: illumap.solve(surfels(), leaf_size=2 ** 31),
     r"leaf_size: expected an integer >= 1 and <= 2147483647, got 2147483648"),
    ("threads-2^31", lambda: illumap.solve(surfels(), threads=2 ** 31),
     r"threads: expected an integer >= 0 and <= 2147483647, got 2147483648"),
    ("seed-k-2^31", lambda: illumap.solve(surfels(), visibility="seed", seed_k=2 ** 31),
     r"seed_k: expected an integer >= 1 and <= 2147483647"),
    ("tol-string", lambda: illumap.solve(surfels(), tol="abc"),
     r"tol: expected a number in \(0, 1\), got 'abc'"),
    ("tol-nan", lambda: illumap.solve(surfels(), tol=float("nan")),
     r"tol: expected a number in \(0, 1\), got nan"),
    ("tol-2^31", lambda: illumap.solve(surfels(), tol=2 ** 31),
     r"tol: expected a number in \(0, 1\), got 2147483648"),
    ("method-unknown", lambda: illumap.solve(surfels(), method="fast"),
     r"method: expected one of \['fmm', 'direct'\], got 'fast'"),
    ("visibility-unknown", lambda: illumap.solve(surfels(), visibility="rays"),
     r"visibility: expected one of .*got 'rays'"),
    ("coverage-nan", lambda: illumap.Occluders(surfels(), coverage=float("nan")),
     r"coverage: expected a number in \(0, inf\), got nan"),
    ("occluder-triangles-nan", lambda: illumap.solve(
        surfels(), visibility="exact", occluder_triangles=np.full((2, 3, 3), np.nan)),
     r"occluder_triangles\[0\] is not finite"),
    ("corners-nan", lambda: sampling.sample_triangles(np.where(np.arange(2)[:, None, None] == 1,
                                                               np.nan, TRI), 10,
                                                      np.random.default_rng(0)),
     r"corners\[1\] = .*nan.* is not finite"),
    ("corners-far", lambda: sampling.sample_triangles(TRI * 1e100, 10, np.random.default_rng(0)),
     r"corners\[0\] = .* lies beyond ±1e\+12"),
    ("corners-shape", lambda: sampling.triangle_areas(np.zeros((4, 3))),
     r"corners: expected shape \(T, 3, 3\), got \(4, 3\)"),
    ("triangles-all-degenerate", lambda: sampling.sample_triangles(
        np.zeros((3, 3, 3)), 10, np.random.default_rng(0)),
     r"areas: every area is zero; nothing to sample"),
    ("sample-count-zero", lambda: sampling.sample_triangles(TRI, 0, np.random.default_rng(0)),
     r"count: need at least one surfel, got 0"),
    ("allocate-nan-area", lambda: sampling.allocate(np.array([1.0, np.nan]), budget=10),
     r"areas\[1\] = .*nan.* must be a finite area >= 0"),
    ("allocate-budget-small", lambda: sampling.allocate(np.ones(3), budget=2),
     r"Surfel budget 2 is smaller than the number of objects \(3\)"),
    ("allocate-budget-absurd", lambda: sampling.allocate(np.ones(3), budget=2 ** 70),
     r"Surfel budget 1,180,591,620,717,411,303,424 is far beyond any memory"),
    ("allocate-density-absurd", lambda: sampling.allocate(np.ones(2), density=1e300),
     r"Density 1e\+300/m² over 2 m² asks for .* far beyond any memory"),
    ("regions-far", lambda: sampling.Regions.build(TRI * 1e155, max_area=1.0),
     r"corners\[0\] = .* lies beyond ±1e\+12"),
    ("regions-max-area-inf", lambda: sampling.Regions.build(TRI, max_area=np.inf),
     r"max_area: expected a positive area, got inf"),
    ("thin-points-nan", lambda: sampling.thin_points(np.array([[0.0, 0, 0], [np.nan, 0, 0]]), 1),
     r"points: contains NaN or infinite coordinates"),
]


@pytest.mark.parametrize("call, pattern", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_is_refused_clearly(call, pattern):
    with pytest.raises(illumap.InputError, match=pattern):
        call()


def test_order_limit_is_the_native_limit():
    """MAX_ORDER is the native core's own limit: the highest order runs, the next one is
    refused by the native module too (so the Python check hides nothing it would accept)."""
    s = surfels()
    op = TransportOperator(s, method="fmm", order=MAX_ORDER)
    assert np.isfinite(op.apply(np.ones((s.n, 3)))).all()
    from illumap import _core
    with pytest.raises(ValueError, match="order must be in 0..10"):
        _core.Operator(s.positions, s.normals, s.areas, method="fmm", order=MAX_ORDER + 1)


def test_scales_inside_the_limits_still_solve():
    """The scale limits leave every sensible scene alone: millimetres to kilometres, and
    coordinates up to the limit, solve to the same answer."""
    reference = illumap.solve(surfels(), tol=1e-8).radiosity
    for scale in (1e-3, 1e3):
        got = illumap.solve(surfels(scale=scale), tol=1e-8).radiosity
        np.testing.assert_allclose(got, reference, rtol=1e-5, atol=1e-12)


def test_the_first_non_finite_triangle_is_named_past_the_checks_chunks(monkeypatch):
    """Triangles are checked for finite corners a chunk at a time (a scan's 12M splat
    triangles at once took a 107 MB mask): the first bad one is still the one named."""
    from illumap import array_checks
    from illumap.receivers import MeshOccluders
    monkeypatch.setattr(array_checks, "FINITE_CHECK_ROWS", 4)
    tri = np.tile(TRI, (11, 1, 1)).astype(np.float64)
    assert array_checks.first_nonfinite_row(tri) == -1
    tri[9, 2, 1] = np.inf
    tri[10, 0, 0] = np.nan
    assert array_checks.first_nonfinite_row(tri) == 9
    with pytest.raises(illumap.InputError, match=r"corners of triangle 9 are not finite"):
        MeshOccluders(tri)
