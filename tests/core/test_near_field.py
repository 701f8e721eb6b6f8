"""The "disc" near-field rule against brute-force quadrature of the form-factor integral.

For a close pair (π r² ≤ t0 Ā, where the polygon rule has full weight) the operator's entry is
F_01 = ½ (F(0→octagon 1) + (A_1/A_0)·F(1→octagon 0)). Each point-to-polygon form factor is
integrated here independently of Lambert's formula: the octagon is cut into many small cells
and the clamped point kernel is summed over them.
"""

import math

import numpy as np
import pytest

import illumap
from illumap_core_testing import _tangent_basis, requires_native

SIDES = 8


def quadrature_point_to_octagon(x, n, c, m, area, rings=400, sectors=512):
    """∫ max(0,cos_x) max(0,cos_y) / (π r²) dA over the regular octagon (midpoint rule in polar
    cells; the octagon's boundary is r(φ) = apothem / cos(φ − nearest edge normal angle))."""
    radius = math.sqrt(2.0 * area / (SIDES * math.sin(2.0 * math.pi / SIDES)))
    apothem = radius * math.cos(math.pi / SIDES)
    u, v = (b[0] for b in _tangent_basis(m[None, :]))
    phi = (np.arange(sectors) + 0.5) * 2.0 * math.pi / sectors
    # Vertices sit at angles 2πk/8, so edge normals at π/8 + 2πk/8.
    rel = phi % (2.0 * math.pi / SIDES) - math.pi / SIDES
    rmax = apothem / np.cos(rel)
    s = (np.arange(rings) + 0.5) / rings
    rr = s[:, None] * rmax[None, :]
    dA = (rmax[None, :] / rings) * rr * (2.0 * math.pi / sectors)
    pts = (c + rr[..., None] * (np.cos(phi)[None, :, None] * u + np.sin(phi)[None, :, None] * v))
    d = pts - x
    r2 = np.einsum("abk,abk->ab", d, d)
    cos_x = np.maximum(np.einsum("k,abk->ab", n, d), 0.0) / np.sqrt(r2)
    cos_y = np.maximum(-np.einsum("k,abk->ab", m, d), 0.0) / np.sqrt(r2)
    return float(np.sum(cos_x * cos_y / (math.pi * r2) * dA))


def random_close_pair(rng):
    while True:
        n0, n1 = rng.normal(size=(2, 3))
        n0 /= np.linalg.norm(n0)
        n1 /= np.linalg.norm(n1)
        a0, a1 = rng.uniform(0.5, 1.5, 2) * 1e-2
        offset = rng.normal(size=3)
        offset *= rng.uniform(0.3, 1.0) * math.sqrt(a0) / np.linalg.norm(offset)
        p0, p1 = np.zeros(3), offset
        t = math.pi * offset @ offset / (0.5 * (a0 + a1))
        faces = (n0 @ (p1 - p0) > 0) and (n1 @ (p0 - p1) > 0)
        if t <= 16.0 and faces:
            return p0, p1, n0, n1, a0, a1


@requires_native
@pytest.mark.parametrize("seed", range(6))
def test_close_pair_matches_quadrature(seed):
    rng = np.random.default_rng(seed)
    p0, p1, n0, n1, a0, a1 = random_close_pair(rng)
    s = illumap.Surfels(np.array([p0, p1]), np.array([n0, n1]), np.array([a0, a1]),
                        np.zeros((2, 3)), np.zeros((2, 3)))
    op = illumap.TransportOperator(s, method="direct", near_field="disc")
    f01 = op.apply(np.array([[0.0] * 3, [1.0] * 3]))[0, 0]
    f10 = op.apply(np.array([[1.0] * 3, [0.0] * 3]))[1, 0]
    q01 = quadrature_point_to_octagon(p0, n0, p1, n1, a1)
    q10 = quadrature_point_to_octagon(p1, n1, p0, n0, a0)
    expected01 = 0.5 * (q01 + a1 / a0 * q10)
    assert f01 == pytest.approx(expected01, rel=2e-3, abs=1e-7)
    assert a0 * f01 == pytest.approx(a1 * f10, rel=1e-12)      # reciprocity
    # The bare point kernel differs markedly for such close pairs: the test has teeth.
    d = p0 - p1
    point = a1 * max(0, -n0 @ d) * max(0, n1 @ d) / (math.pi * (d @ d) ** 2)
    assert abs(point - f01) > 0.02 * f01


@requires_native
def test_coincident_and_back_facing_pairs_are_zero():
    n = np.array([[0, 0, 1.0], [0, 0, 1.0], [0, 0, -1.0]])
    p = np.array([[0, 0, 0.0], [0, 0, 0.0], [0, 0, 0.05]])
    s = illumap.Surfels(p, n, np.full(3, 1e-2), np.zeros((3, 3)), np.zeros((3, 3)))
    y = illumap.TransportOperator(s, method="direct").apply(np.ones((3, 3)))
    assert np.all(np.isfinite(y))
    # 0 and 1 coincide (no transfer between them); 2 faces both from above at 5 cm.
    f = illumap.TransportOperator(s, method="direct").apply(np.array([[0.0] * 3, [1.0] * 3, [0.0] * 3]))
    assert f[0, 0] == 0.0 and f[2, 0] > 0.0
