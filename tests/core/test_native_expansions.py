"""Kernel derivatives of T(d) = d d^T / |d|^4 (the FMM's M2L kernel) against direct evaluation."""
import math

import numpy as np
import pytest

from illumap import _core

SYM = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]


def T(d):
    d = np.asarray(d, float)
    r2 = d @ d
    return np.outer(d, d) / r2 ** 2


def as_sym(Dn):
    M = np.empty((3, 3))
    for q, (a, b) in enumerate(SYM):
        M[a, b] = M[b, a] = Dn[q]
    return M


def test_order_zero_is_the_kernel():
    d = np.array([0.7, -0.4, 1.3])
    mi, D = _core._kernel_derivatives(d, 0)
    assert mi.tolist() == [[0, 0, 0]]
    np.testing.assert_allclose(as_sym(D[0]), T(d), rtol=1e-14)


@pytest.mark.parametrize("d", [[1.0, 0.0, 0.0], [0.3, -1.2, 0.5], [-2.0, 0.7, 3.1]])
def test_first_and_second_derivatives_match_finite_differences(d):
    d = np.asarray(d)
    mi, D = _core._kernel_derivatives(d, 2)
    index = {tuple(m): k for k, m in enumerate(mi.tolist())}
    h = 1e-4 * np.linalg.norm(d)
    E = np.eye(3)
    for a in range(3):
        fd = (T(d + h * E[a]) - T(d - h * E[a])) / (2 * h)
        n = [0, 0, 0]
        n[a] = 1
        np.testing.assert_allclose(as_sym(D[index[tuple(n)]]), fd, rtol=1e-6, atol=1e-8 * abs(fd).max())
        for b in range(3):
            fd2 = (T(d + h * E[a] + h * E[b]) - T(d + h * E[a] - h * E[b])
                   - T(d - h * E[a] + h * E[b]) + T(d - h * E[a] - h * E[b])) / (4 * h * h)
            n = [0, 0, 0]
            n[a] += 1
            n[b] += 1
            np.testing.assert_allclose(as_sym(D[index[tuple(n)]]), fd2, rtol=1e-5,
                                       atol=1e-6 * abs(fd2).max())


def taylor(d, h, p):
    mi, D = _core._kernel_derivatives(np.asarray(d, float), p)
    out = np.zeros((3, 3))
    for m, Dn in zip(mi, D):
        coef = np.prod([h[a] ** m[a] / math.factorial(m[a]) for a in range(3)])
        out += coef * as_sym(Dn)
    return out


def test_taylor_series_converges_to_the_kernel_at_every_order():
    d = np.array([0.6, -0.5, 0.9])
    h = 0.12 * np.array([0.3, 0.8, -0.52])
    exact = T(d + h)
    errors = [np.abs(taylor(d, h, p) - exact).max() / np.abs(exact).max() for p in range(0, 11)]
    # each order gains roughly a factor |h|/|d|; the series must keep converging up to p = 10
    for lo, hi in zip(errors[:-1], errors[1:]):
        assert hi < lo
    assert errors[10] < 1e-10


def test_bad_arguments():
    with pytest.raises(ValueError):
        _core._kernel_derivatives(np.zeros(4), 2)
    with pytest.raises(ValueError):
        _core._kernel_derivatives(np.ones(3), 11)


@pytest.mark.parametrize("order", range(0, 11))
def test_m2l4_equals_four_weighted_m2l(order):
    """The FMM's four-source M2L (SIMD lanes, in-register transposition, the weights of
    partial far leaf pairs applied in its lane copy) against four single M2L on scaled
    copies, at every order (the multipole length 9 * ncoef is not always a multiple of 4)."""
    ncoef = (order + 1) * (order + 2) * (order + 3) // 6
    rng = np.random.default_rng(order)
    R = rng.uniform(-1, 1, (4, 3)) + np.array([3.0, -1.0, 2.0])
    M = rng.uniform(-1, 1, (4, 9 * ncoef))
    for w in ([1.0, 1.0, 1.0, 1.0], [0.25, 1.0, 0.6, 0.0]):
        L4, Ls = _core._m2l4_check(R, M, np.array(w), order)
        assert L4.shape == (ncoef, 9)
        np.testing.assert_allclose(L4, Ls, rtol=1e-12, atol=1e-13 * np.abs(Ls).max())
