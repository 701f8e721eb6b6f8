"""The operator's exact visibility against the caller's triangles without copies: the
surfels' origin taken off each corner by the core (``occluder_shift``), and the receivers'
ray scene of the same triangles cast against instead of one of its own (one BVH per run)."""

import numpy as np
import pytest

import illumap
from test_visibility import METHODS, ideal_half_blocked, square_triangles, squares, transfer


def test_triangles_shifted_by_the_core_are_the_callers_shifted_copy():
    """The native operator takes the surfels' origin off each triangle corner itself
    (``occluder_shift``), so a scan's millions of splat triangles need no shifted copy: the
    same doubles as the caller's copy, hence the same floats, rays and transport, bit for bit,
    a kilometre from the world origin where the shift is not exact."""
    from illumap import _core
    n = 8
    s, lab = squares(n)
    far = np.array([1234.5678, -987.654321, 321.0987])
    tri = square_triangles(-1.5, 0.01, -1.5, 1.5, 0.5, 4) + far
    p = np.ascontiguousarray(s.positions)        # the surfels as the core sees them
    kw = dict(method="direct", visibility="exact")
    copy = _core.Operator(p, s.normals, s.areas, occluder_triangles=np.ascontiguousarray(
        (tri - far).reshape(-1, 9)), **kw)
    shifted = _core.Operator(p, s.normals, s.areas, occluder_triangles=tri.reshape(-1, 9),
                             occluder_shift=far, **kw)
    x = np.random.default_rng(3).uniform(0.0, 1.0, (s.n, 3))
    y = np.asarray(copy.apply(x))
    assert np.array_equal(np.asarray(shifted.apply(x)), y)
    unshielded = np.asarray(_core.Operator(p, s.normals, s.areas, method="direct").apply(x))
    assert not np.allclose(y, unshielded)        # the triangles do block pairs
    with pytest.raises(ValueError, match="occluder_shift"):
        _core.Operator(p, s.normals, s.areas, occluder_triangles=tri.reshape(-1, 9),
                       occluder_shift=np.array([0.0, np.nan, 0.0]), **kw)


@pytest.mark.parametrize("method", METHODS)
def test_visibility_cast_against_the_receivers_ray_scene_blocks_the_same_pairs(method):
    """Exact visibility cast against the caller's ray scene of the same triangles (the
    receivers' ``MeshOccluders``, one BVH per run) instead of one of its own: the same pairs
    blocked as the ideal half-blocked transfer (its floats are relative to that scene's own
    centre, so the bits may differ, not the blocking), and the same transfer as its own scene
    to within float rounding. A ray scene of other triangles is refused."""
    from illumap.receivers import MeshOccluders
    n = 16
    h = 1.0 / n
    s, lab = squares(n)
    ref, _ = ideal_half_blocked(s, lab)
    tri = square_triangles(-1.5, 0.01, -1.5, 1.5, 0.5, 8)
    own = illumap.TransportOperator(s, method=method, visibility="exact", occluder_triangles=tri)
    shared = illumap.TransportOperator(s, method=method, visibility="exact",
                                       occluder_triangles=tri, occluders=MeshOccluders(tri))
    T_own, T_shared = (transfer(op, s, lab == 0, lab == 1) for op in (own, shared))
    assert abs(T_shared / ref - 1) <= (1e-9 if method == "direct" else 1.25 * h), (T_shared, ref)
    assert T_shared == pytest.approx(T_own, rel=1e-9)
    from illumap import _core
    with pytest.raises(ValueError, match="occluder_scene"):
        _core.Operator(np.ascontiguousarray(s.positions), s.normals, s.areas, method=method,
                       visibility="exact", occluder_triangles=tri.reshape(-1, 9),
                       occluder_scene=MeshOccluders(tri[:4])._scene)
