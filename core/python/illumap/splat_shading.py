"""The preview splats' shading: each splat of a scan (``splats.splat_frames``) shows its
point's value changing across it the way the light changes there, not one flat value.

A flat value per point steps from one splat to the next where light fades (into a corner,
across a penumbra): each step is the change over a point spacing, and the eye and the metric
see it as a staircase. Here each point gets the gradient of its value in its tangent plane,
fitted to its neighbours' values after the solve, and its splat is coloured by the linear
function that takes the point's own value at the point:

* Fit. Least squares over the point's ``SHADING_NEIGHBOURS`` nearest points on its own
  surface (normals within acos ``EDGE_COS`` of its own: across a crease the light belongs to
  another surface), in the splat's own axes; with fewer than two such neighbours, or when
  they lie on a line, the splat stays flat along that line's normal (a ridge term
  ``RIDGE`` × their spread keeps the fit defined).
* Limit. Half-way to each of those neighbours (about where the point's splat meets the
  neighbour's: the nearer point's splat shows) the linear function stays within the range of
  the values of the point and its neighbours (the gradient is scaled down, per channel, until
  it does; the limiter of Barth and Jespersen): a linear light is shown as it is, a splat
  beside a shadow's sharp edge does not overshoot into negative or too-bright light, and at a
  peak of the light the splat is flat.

The result is what the preview's material reads per splat (``base`` + X ``dx`` + Y ``dy``,
with X, Y the unit disc's coordinates that the splat instances: X along ``axis`` scaled by the
first semi-axis, Y across it by the second). Units: the values' (RGB, W/m²/sr), per unit X, Y.
"""

from __future__ import annotations

import numpy as np

from . import _core
from .splats import PREVIEW_NEIGHBOURS
from .surfels import InputError

#: Neighbours the gradient is fitted to: the splats' own (their search serves both).
SHADING_NEIGHBOURS = PREVIEW_NEIGHBOURS
#: A neighbour lies on the point's surface when |n·m| is at least this (about 25°).
EDGE_COS = 0.9
#: Ridge term of the fit, as a fraction of the neighbours' mean squared distance: keeps the
#: normal equations defined when the neighbours lie on a line (a scan's rim, one row).
RIDGE = 1e-3
def splat_shading(positions, frames: dict, values, *, order=None, neighbours=None,
                  threads: int = 0, progress=None) -> dict:
    """Each splat's linear shading (the rules above) as float32 (N, 3) arrays: ``base`` (the
    value at the ellipse's centre), ``dx`` and ``dy`` (its change per unit of the instanced
    disc's X and Y). ``positions`` (N, 3) the scan's points, ``frames`` their
    ``splats.splat_frames``, ``values`` (N, 3) or (N, 4) their light (RGB; a fourth column is
    ignored). ``order`` (N,) and ``neighbours`` (N, SHADING_NEIGHBOURS) int: the search
    ``splats.splat_frames(..., with_neighbours=True)`` made, or None: searched here.
    Native (``_core.splat_shading``, splat_shading.cpp);
    ``threads``: worker threads (0: all); ``progress(fraction, phase)`` may cancel
    (``illumap.Cancelled``)."""
    p = np.asarray(positions)
    if p.dtype != np.float32:
        p = np.ascontiguousarray(p, dtype=np.float64)
    count = len(p)
    v = np.asarray(values)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"splat_shading: positions must be an (N, 3) array, got {p.shape}")
    if v.ndim != 2 or v.shape[0] != count or v.shape[1] not in (3, 4):
        raise InputError(f"splat_shading: values must be ({count}, 3) or ({count}, 4), got "
                         f"{v.shape}")
    v = np.ascontiguousarray(v[:, :3], dtype=np.float64)
    if count < 3:
        zero = np.zeros((count, 3), np.float32)
        return {"base": v.astype(np.float32), "dx": zero, "dy": zero.copy()}
    if not (np.isfinite(p).all() and np.isfinite(v).all()):
        raise InputError("splat_shading: positions and values must be finite")
    keys = ("normal", "axis", "scale", "offset")
    k = min(SHADING_NEIGHBOURS, count - 1)
    if (order is None) != (neighbours is None):
        raise InputError("splat_shading: give both order and neighbours, or neither")
    if neighbours is not None:
        order = np.ascontiguousarray(order, dtype=np.int64)
        neighbours = np.ascontiguousarray(neighbours, dtype=np.int64)
        if order.shape != (count,) or neighbours.shape != (count, k):
            raise InputError(f"splat_shading: order must be ({count},) and neighbours "
                             f"({count}, {k}), got {order.shape} and {neighbours.shape}")
    # float32 points and frames (the preview's) go to the core as they are, with the search
    # given: no float64 copies of them (a quarter of the shading's time at 1M points).
    single = (neighbours is not None and p.dtype == np.float32
              and all(np.asarray(frames[key]).dtype == np.float32 for key in keys))
    p = np.ascontiguousarray(p, dtype=np.float32 if single else np.float64)
    f = {key: np.ascontiguousarray(frames[key], dtype=np.float32 if single else np.float64)
         for key in keys}
    out = np.asarray(_core.splat_shading(
        p, f["normal"], f["axis"], f["scale"], f["offset"], v, order, neighbours, k=k,
        edge_cos=EDGE_COS, ridge=RIDGE, threads=threads,
        progress=progress))
    return {"base": np.ascontiguousarray(out[:, 0:3], dtype=np.float32),
            "dx": np.ascontiguousarray(out[:, 3:6], dtype=np.float32),
            "dy": np.ascontiguousarray(out[:, 6:9], dtype=np.float32)}
