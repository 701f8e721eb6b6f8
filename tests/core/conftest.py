"""Shared fixtures: an independent pure-numpy reference of the transport kernel.

The reference follows docs/architecture.md ("The kernel, exactly") line by line and builds the
dense matrix F (small N only). It checks the native direct operator and lets the solver tests
run on an operator whose every entry is known. Import them as ``illumap_core_testing``.
"""

import math
import sys

import numpy as np
import pytest

import illumap

# Test modules import these helpers as ``illumap_core_testing`` (a unique name: tests/blender has
# its own conftest.py, and both are "conftest" to Python).
sys.modules.setdefault("illumap_core_testing", sys.modules[__name__])

T0 = 16.0


def near_weight(t):
    """w(t) of the "disc" near-field rule."""
    t = np.asarray(t, dtype=np.float64)
    w_low = T0 / (1.0 + T0)
    return np.where(t <= T0, t / (1.0 + t),
                    np.where(t <= 2 * T0, w_low + (1.0 - w_low) * (t - T0) / T0, 1.0))


def reference_matrix(positions, normals, areas, near_field="disc", rows=None, chunk=256):
    """Dense F[i, j] for the receivers ``rows`` (all by default)."""
    positions = np.asarray(positions, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    areas = np.asarray(areas, dtype=np.float64)
    rows = np.arange(len(positions)) if rows is None else np.asarray(rows)
    out = np.empty((len(rows), len(positions)))
    for start in range(0, len(rows), chunk):
        idx = rows[start:start + chunk]
        d = positions[idx, None, :] - positions[None, :, :]          # r_i − r_j
        r2 = np.einsum("ijk,ijk->ij", d, d)
        r = np.sqrt(r2)
        safe = np.where(r > 0, r, 1.0)
        cos_i = -np.einsum("ik,ijk->ij", normals[idx], d) / safe
        cos_j = np.einsum("jk,ijk->ij", normals, d) / safe
        f = areas[None, :] * np.maximum(cos_i, 0) * np.maximum(cos_j, 0) / (
            math.pi * np.where(r > 0, r2, 1.0))
        if near_field == "disc":
            abar = 0.5 * (areas[idx, None] + areas[None, :])
            f = f * near_weight(math.pi * r2 / abar)
        elif near_field != "point":
            raise ValueError(near_field)
        out[start:start + chunk] = np.where(r > 0, f, 0.0)
    return out


class ReferenceOperator:
    """Dense numpy operator with TransportOperator's interface (apply, symmetric, stats)."""

    def __init__(self, surfels, near_field="disc"):
        self.surfels = surfels
        self.n = surfels.n
        self.near_field = near_field
        self.F = reference_matrix(surfels.positions, surfels.normals, surfels.areas, near_field)
        self.symmetric = True
        self.stats = {"method": "numpy-reference", "near_field": near_field, "n": self.n}
        self.calls = 0

    def apply(self, values, progress=None):
        self.calls += 1
        return self.F @ np.asarray(values, dtype=np.float64)


requires_native = pytest.mark.skipif(not illumap.native_available(),
                                     reason="illumap._core (native module) not built")


def make_operator(kind, surfels, near_field="disc", **keywords):
    """kind: "reference" (numpy), "direct" or "fmm" (native)."""
    if kind == "reference":
        return ReferenceOperator(surfels, near_field)
    if not illumap.native_available():
        pytest.skip("illumap._core (native module) not built")
    return illumap.TransportOperator(surfels, method=kind, near_field=near_field, **keywords)
