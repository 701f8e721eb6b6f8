"""Surfels from triangle meshes: stratified, area-weighted sampling and adaptive density.

Numpy only (no native code, no Blender). Units: positions in metres, areas in m², densities in
surfels per m². Shared by the Blender add-on and the benchmarks.

API::

    areas = triangle_areas(corners)                          # (T, 3, 3) -> (T,) m²
    counts = allocate(object_areas, density=400.0)           # or budget=N: surfels per object
    s = sample_triangles(corners, count, rng,                # -> Samples: positions, normals,
                         corner_normals=None, weights=None)  #    areas, triangle, bary

    keep = thin_points(points, count, rng)                    # a scan decimated evenly

    # adaptive density: a first solution on surfels sampled from the same triangles
    reg = Regions.build(corners, max_area=6 / first_density)  # triangles split into regions
    r = reg.locate(s.triangle, s.bary)                        # region of each first-pass surfel
    var = local_variation(values, neighbours)                 # values (N,), neighbours (N, k)
    w = density_multipliers(r, var, reg.count, max_ratio=4)   # (R,) in [1, 4]
    s2 = sample_triangles(reg.corners, count, rng, weights=w,
                          corner_normals=reg.interpolate(corner_normals))
    parent, bary = reg.to_parent(s2.triangle, s2.bary)        # back to the original triangles

Sampling (``sample_triangles``) works in two stages, so that no surfel clumps:

1. *Allocation.* The triangles are laid end to end along their cumulative weighted area
   (area × weight; weight 1 without ``weights``) and ``count`` positions are placed
   systematically on that line (one random offset, then equal steps). A triangle receives the
   floor or ceiling of its expected count, never a cluster.
2. *Placement.* Inside a triangle the k-th of its m samples is the k-th point of the R2
   (Kronecker) low-discrepancy sequence with a random per-triangle shift, mapped onto the
   triangle by Heitz's area-preserving, low-distortion square-to-triangle map.

Each surfel's area is the real area of its stratum of the line (the equal steps mapped back
through the weights), so the areas sum to the total triangle area (up to rounding) whatever
the triangle sizes and weights. Without weights every surfel has the same area ``A / count``.

Adaptive density: ``Regions.build`` splits every triangle into 4^L congruent sub-triangles
(midpoint subdivision, L chosen per triangle so that no region is larger than ``max_area``);
``density_multipliers`` turns a per-surfel illumination variation into a bounded density
multiplier per region; sampling again with those weights and the same count puts more surfels
where the illumination varies (shadow boundaries, near lights, corners) and fewer where it is
flat, with the total count unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .limits import limit
from .surfels import MAX_COORDINATE, InputError

__all__ = ["Samples", "Regions", "triangle_areas", "allocate", "sample_triangles",
           "local_variation", "density_multipliers", "thin_points"]

# R2 sequence constants (1/g, 1/g² with g the plastic number): a well-spread 2-D lattice.
_R2 = np.array([0.7548776662466927, 0.5698402909980532])


@dataclass
class Samples:
    """Surfels placed on triangles."""

    positions: np.ndarray   # (N, 3) m
    normals: np.ndarray     # (N, 3) unit
    areas: np.ndarray       # (N,) m², sums to the triangles' total area
    triangle: np.ndarray    # (N,) int64 index of the triangle each surfel lies in
    bary: np.ndarray        # (N, 3) barycentric coordinates in that triangle


def _corners(corners) -> np.ndarray:
    """Triangle corners (T, 3, 3) as float64, finite and within ±MAX_COORDINATE, or an
    InputError naming the first bad triangle."""
    try:
        c = np.asarray(corners, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"corners: cannot be read as a float array ({exc})") from None
    if c.ndim != 3 or c.shape[1:] != (3, 3):
        raise InputError(f"corners: expected shape (T, 3, 3), got {c.shape}")
    if len(c) == 0:
        raise InputError("corners: no triangles")
    finite = np.isfinite(c).all(axis=(1, 2))
    if not finite.all():
        t = int(np.flatnonzero(~finite)[0])
        raise InputError(f"corners[{t}] = {c[t].tolist()} is not finite")
    far = (np.abs(c) > MAX_COORDINATE).any(axis=(1, 2))
    if far.any():
        t = int(np.flatnonzero(far)[0])
        raise InputError(f"corners[{t}] = {c[t].tolist()} lies beyond ±{MAX_COORDINATE:g}: "
                         "express the scene in metres (or rescale it)")
    return c


def _object_areas(areas, name: str = "areas") -> np.ndarray:
    """Areas (T,) finite and >= 0 with a positive sum, or an InputError naming the first bad
    entry."""
    a = np.asarray(areas, dtype=np.float64)
    if a.ndim != 1 or len(a) == 0:
        raise InputError(f"{name}: expected a non-empty 1-D array, got shape {a.shape}")
    bad = ~np.isfinite(a) | (a < 0)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(f"{name}[{k}] = {a[k]!r} must be a finite area >= 0")
    if not a.sum() > 0:
        raise InputError(f"{name}: every area is zero; nothing to sample")
    return a


def triangle_areas(corners) -> np.ndarray:
    """Areas (T,) in m² of triangles given as corner positions (T, 3, 3)."""
    c = _corners(corners)
    return 0.5 * np.linalg.norm(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]), axis=1)


def allocate(areas, *, density: float | None = None, budget: int | None = None) -> np.ndarray:
    """Surfel counts (int64) per object from a density (surfels/m²) or a total budget.

    Every object gets at least one surfel (so small emitters are never lost); a budget is
    shared in proportion to ``areas`` (m², or weighted areas) by largest remainder.
    Raises InputError for a budget below the number of objects or a non-positive density.
    """
    areas = _object_areas(areas)
    if budget is not None:
        budget = int(budget)
        if budget > 2 ** 53:
            raise InputError(f"Surfel budget {budget:,} is far beyond any memory")
        if budget < len(areas):
            raise InputError(f"Surfel budget {budget} is smaller than the number of objects "
                             f"({len(areas)})")
        exact = budget * areas / areas.sum()
        counts = np.floor(exact).astype(np.int64)
        rest = budget - counts.sum()
        counts[np.argsort(-(exact - counts), kind="stable")[:rest]] += 1
        return np.maximum(counts, 1)
    if density is None or not limit("density").contains(density):
        raise InputError(f"Surfel density must be a positive number, got {density}")
    if density * areas.sum() > 2.0 ** 53:
        raise InputError(f"Density {density:g}/m² over {areas.sum():g} m² asks for "
                         f"{density * areas.sum():.3g} surfels, far beyond any memory")
    return np.maximum(np.rint(density * areas).astype(np.int64), 1)


def sample_triangles(corners, count: int, rng: np.random.Generator, *,
                     corner_normals=None, weights=None, areas=None) -> Samples:
    """Place ``count`` stratified surfels on the triangles ``corners`` (T, 3, 3), in metres.

    corner_normals : (T, 3, 3) normals at the corners, interpolated linearly and normalised
        (shading normals); default the geometric normal of each triangle. Where interpolated
        normals cancel, the geometric normal is used.
    weights : (T,) positive density multipliers (relative surfels per m²); default 1.
    areas : (T,) triangle areas if already known (m²).
    The random stream (one offset, then one shift per triangle) is the same with and without
    weights, so a fixed ``rng`` seed reproduces the surfels.
    """
    c = _corners(corners)
    count = int(count)
    if count < 1:
        raise InputError(f"count: need at least one surfel, got {count}")
    area = _object_areas(triangle_areas(c) if areas is None else areas)
    if len(area) != len(c):
        raise InputError(f"areas: expected {len(c)} triangle areas, got {len(area)}")
    cum = np.cumsum(area)
    total = cum[-1]
    if weights is None:
        wcum, wtotal = cum, total
    else:
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != area.shape or not np.all(np.isfinite(w)) or np.any(w <= 0):
            raise InputError(f"weights: expected {area.shape[0]} positive finite values")
        wcum = np.cumsum(area * w)
        wtotal = wcum[-1]
    step = wtotal / count
    u = (np.arange(count) + rng.random()) * step
    tri = np.minimum(np.searchsorted(wcum, u, side="right"), len(cum) - 1)
    # u is increasing, so tri is sorted: rank of each sample inside its triangle.
    first = np.searchsorted(tri, tri, side="left")
    rank = np.arange(count) - first
    shift = rng.random((len(cum), 2))
    st = np.mod((rank[:, None] + 0.5) * _R2 + shift[tri], 1.0)
    # Heitz's low-distortion square→triangle map (2019): area-preserving and far less
    # distorting than folding, so the lattice's spacing survives.
    u1, u2 = st[:, 0], st[:, 1]
    upper = u2 > u1
    t1 = np.where(upper, u1 / 2, u1 - u2 / 2)
    t2 = np.where(upper, u2 - u1 / 2, u2 / 2)
    bary = np.column_stack([1.0 - t1 - t2, t1, t2])
    pos = np.einsum("nk,nkc->nc", bary, c[tri])
    face = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    face /= np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-300)
    if corner_normals is None:
        nrm = face[tri]
    else:
        nrm = np.einsum("nk,nkc->nc", bary, np.asarray(corner_normals, dtype=np.float64)[tri])
        length = np.linalg.norm(nrm, axis=1)
        bad = length < 1e-8  # opposite split normals cancel: use the face normal
        nrm[bad] = face[tri[bad]]
        length[bad] = 1.0
        nrm = nrm / length[:, None]
    if weights is None:
        out_areas = np.full(count, total / count)
    else:
        # Stratum k is [k·step, (k+1)·step) on the weighted line; its real area follows by
        # dividing the weighted length inside each triangle by that triangle's weight.
        edges = np.arange(count + 1) * step
        t = np.minimum(np.searchsorted(wcum, edges, side="right"), len(cum) - 1)
        before_w = wcum[t] - area[t] * w[t]
        before_a = cum[t] - area[t]
        real = before_a + np.clip(edges - before_w, 0.0, area[t] * w[t]) / w[t]
        real[0], real[-1] = 0.0, total
        out_areas = np.diff(real)
    return Samples(positions=pos, normals=nrm, areas=out_areas, triangle=tri, bary=bary)


# --- adaptive density ------------------------------------------------------------------------

def _children(bc: np.ndarray) -> np.ndarray:
    """The 4 midpoint children (R, 4, 3, 3) of regions given as barycentric corners (R, 3, 3),
    in the order ``locate`` uses: corner 0, corner 1, corner 2, middle."""
    c0, c1, c2 = bc[:, 0], bc[:, 1], bc[:, 2]
    m01, m12, m20 = (c0 + c1) / 2, (c1 + c2) / 2, (c2 + c0) / 2
    return np.stack([np.stack([c0, m01, m20], 1), np.stack([m01, c1, m12], 1),
                     np.stack([m20, m12, c2], 1), np.stack([m12, m20, m01], 1)], 1)


@dataclass
class Regions:
    """Triangles split into congruent sub-triangles ("regions") by repeated midpoint
    subdivision; triangle t is split ``level[t]`` times into 4^level[t] regions."""

    parent: np.ndarray         # (R,) int64 triangle each region lies in
    bary_corners: np.ndarray   # (R, 3, 3) region corners as barycentric coordinates in the parent
    corners: np.ndarray        # (R, 3, 3) region corners, m
    area: np.ndarray           # (R,) m²
    level: np.ndarray          # (T,) subdivision level per triangle
    offset: np.ndarray         # (T,) index of each triangle's first region

    @property
    def count(self) -> int:
        """Number of regions."""
        return len(self.parent)

    @classmethod
    def build(cls, corners, max_area: float, max_level: int = 6) -> "Regions":
        """Split each triangle of ``corners`` (T, 3, 3) until its regions are no larger than
        ``max_area`` (m²), at most ``max_level`` times (4^max_level regions per triangle)."""
        c = _corners(corners)
        if not (max_area > 0 and np.isfinite(max_area)):
            raise InputError(f"max_area: expected a positive area, got {max_area}")
        area = triangle_areas(c)
        level = np.ceil(np.log(np.maximum(area / max_area, 1.0)) / np.log(4.0) - 1e-9)
        level = np.clip(level, 0, int(max_level)).astype(np.int64)
        templates = [np.eye(3)[None]]
        for _ in range(int(level.max())):
            templates.append(_children(templates[-1]).reshape(-1, 3, 3))
        sizes = 4 ** level
        offset = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        parent = np.repeat(np.arange(len(c)), sizes)
        code = np.arange(len(parent)) - offset[parent]
        bary_corners = np.empty((len(parent), 3, 3))
        for lv in np.unique(level):
            rows = level[parent] == lv
            bary_corners[rows] = templates[lv][code[rows]]
        reg_corners = np.einsum("rkj,rjc->rkc", bary_corners, c[parent])
        return cls(parent=parent, bary_corners=bary_corners, corners=reg_corners,
                   area=area[parent] / sizes[parent], level=level, offset=offset)

    def locate(self, triangle, bary) -> np.ndarray:
        """Region index (N,) of points given by their triangle (N,) and barycentric
        coordinates (N, 3) in it (e.g. ``Samples.triangle``/``Samples.bary``)."""
        tri = np.asarray(triangle, dtype=np.int64)
        b = np.array(bary, dtype=np.float64)
        lv = self.level[tri]
        code = np.zeros(len(tri), dtype=np.int64)
        for step in range(int(lv.max()) if len(lv) else 0):
            act = lv > step
            a = b[act]
            # Child by the coordinate above ½ (corner children), else the middle one; the
            # point's coordinates in the child follow from the midpoint construction.
            child = np.where(a[:, 0] >= 0.5, 0, np.where(a[:, 1] >= 0.5, 1,
                                                         np.where(a[:, 2] >= 0.5, 2, 3)))
            nb = np.where((child == 3)[:, None], 1.0 - 2.0 * a, 2.0 * a)
            corner = child < 3
            nb[corner, child[corner]] -= 1.0
            b[act] = nb
            code[act] = 4 * code[act] + child
        return self.offset[tri] + code

    def to_parent(self, region, bary) -> tuple[np.ndarray, np.ndarray]:
        """Triangle (N,) and barycentric coordinates (N, 3) in it of points given in regions."""
        region = np.asarray(region, dtype=np.int64)
        return self.parent[region], np.einsum("nk,nkj->nj", bary, self.bary_corners[region])

    def interpolate(self, corner_values) -> np.ndarray:
        """Per-corner data of the triangles (T, 3, C) interpolated to the regions' corners
        (R, 3, C), linearly (normals are not renormalised, so interpolation stays exact)."""
        v = np.asarray(corner_values, dtype=np.float64)
        return np.einsum("rkj,rjc->rkc", self.bary_corners, v[self.parent])


def local_variation(values, neighbours) -> np.ndarray:
    """Per-surfel variation (N,): the largest absolute difference between a surfel's value
    (N,) and those of its neighbours (N, k) indices, e.g. its k nearest surfels."""
    v = np.asarray(values, dtype=np.float64)
    nb = np.asarray(neighbours, dtype=np.int64)
    return np.abs(v[nb] - v[:, None]).max(axis=1) if nb.size else np.zeros(len(v))


def density_multipliers(region, variation, n_regions: int, *, max_ratio: float = 4.0,
                        quantile: float = 0.9, fill=None) -> np.ndarray:
    """Density multipliers (R,) in [1, ``max_ratio``] per region from a first pass.

    region : (N,) region index of each first-pass surfel (``Regions.locate``).
    variation : (N,) per-surfel illumination variation (``local_variation``), any unit.
    A region's variation is the largest of its surfels'; it maps linearly onto [1, max_ratio],
    saturating at the ``quantile`` of the non-zero region variations, so that a few extreme
    values (an emitter's edge) do not flatten everything else. Regions without surfels (small
    triangles) take ``fill`` (R,) when given, e.g. the variation of the surfel nearest to
    each region's centre, else multiplier 1.
    The result is relative: sampling with a fixed count spends the same budget, denser where
    the multiplier is high.
    """
    if not max_ratio >= 1:
        raise InputError(f"max_ratio: expected a value ≥ 1, got {max_ratio}")
    region = np.asarray(region, dtype=np.int64)
    var = np.nan_to_num(np.asarray(variation, dtype=np.float64), nan=0.0, posinf=0.0)
    per = np.zeros(int(n_regions))
    np.maximum.at(per, region, np.maximum(var, 0.0))
    if fill is not None:
        empty = np.bincount(region, minlength=int(n_regions)) == 0
        per[empty] = np.maximum(np.nan_to_num(np.asarray(fill, dtype=np.float64)[empty]), 0.0)
    positive = per[per > 0]
    if positive.size == 0:
        return np.ones(int(n_regions))
    ref = float(np.quantile(positive, quantile))
    return 1.0 + (max_ratio - 1.0) * np.clip(per / ref, 0.0, 1.0)


def thin_points(points, count: int, rng: np.random.Generator | None = None, *,
                tolerance: float = 0.01) -> np.ndarray:
    """Indices (sorted) of about ``count`` of ``points`` (P, 3), spread evenly: one point per
    cell of a cubic grid (the one nearest the cell's centre), the cell size bisected until the
    count is within ``tolerance`` of ``count`` (or as close as the grid allows).

    Decimating a scan this way keeps its spacing even, as scanner software does. A random
    subset does not: its gaps (and so the light leaking between surfel discs) are those of a
    Poisson process at every density, so a solution on it does not converge as the density
    grows. ``rng`` shifts the grid (another even subset of the same size); without it the grid
    starts at the points' lower corner. All points when ``count`` ≥ P.
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points: expected shape (P, 3), got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise InputError("points: contains NaN or infinite coordinates")
    count = int(count)
    if count < 1:
        raise InputError(f"count: expected at least 1, got {count}")
    if count >= len(pts):
        return np.arange(len(pts))
    low = pts.min(axis=0)
    extent = float((pts.max(axis=0) - low).max())
    if extent <= 0.0:
        return np.arange(count)
    shift = rng.random(3) if rng is not None else np.zeros(3)

    def pick(size):
        cell = np.floor((pts - low) / size + shift)
        centre = low + (cell + 0.5 - shift) * size
        cell = (cell - cell.min(axis=0)).astype(np.int64)
        dims = cell.max(axis=0) + 1
        key = (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2]
        off_centre = ((pts - centre) ** 2).sum(axis=1)
        order = np.lexsort((off_centre, key))
        first = np.ones(len(order), bool)
        first[1:] = key[order[1:]] != key[order[:-1]]
        return np.sort(order[first])

    # cells of `small` give more than count points, of `large` fewer
    small, large = extent * 1e-6, extent * 2.0
    best = np.arange(len(pts))
    for _ in range(60):
        size = math.sqrt(small * large)
        keep = pick(size)
        if abs(len(keep) - count) < abs(len(best) - count):
            best = keep
        if abs(len(keep) - count) <= tolerance * count or large / small < 1.0 + 1e-9:
            break
        if len(keep) > count:
            small = size
        else:
            large = size
    return best
