"""Procedural scenes for tests and benchmarks (numpy only, no bpy).

Every builder returns validated :class:`Surfels`; the view-factor scenes also return boolean
masks of the two patches. ``albedo`` and ``emission`` accept a scalar, an RGB triple or an N×3
array. Exact values for these scenes are in DESIGN.md §4; :func:`sphere_exact_radiosity` gives
the closed-form discrete solution inside a sphere.
"""

from __future__ import annotations

import math

import numpy as np

from .surfels import Surfels

__all__ = [
    "sphere_interior", "sphere_exact_radiosity", "closed_box", "parallel_squares",
    "perpendicular_squares", "coaxial_discs", "point_over_square", "box_room",
    "view_factor", "PARALLEL_SQUARES_F", "PERPENDICULAR_SQUARES_F", "COAXIAL_DISCS_F",
    "POINT_OVER_SQUARE_F",
]

#: Exact view factors (DESIGN.md §4).
PARALLEL_SQUARES_F = 0.19982489569838746      # unit squares, distance 1
PERPENDICULAR_SQUARES_F = 0.20004377607540316  # unit squares sharing an edge
COAXIAL_DISCS_F = (3.0 - math.sqrt(5.0)) / 2.0  # r1 = r2 = h
POINT_OVER_SQUARE_F = 0.23945                   # differential area under a centred unit square


def _per_surfel(value, n, name):
    array = np.asarray(value, dtype=np.float64)
    if array.ndim == 0:
        return np.full((n, 3), float(array))
    if array.shape == (3,):
        return np.tile(array, (n, 1))
    if array.shape == (n, 3):
        return array.copy()
    raise ValueError(f"{name}: expected a scalar, an RGB triple or an ({n}, 3) array, "
                     f"got shape {array.shape}")


def _make(positions, normals, areas, albedo, emission):
    n = len(positions)
    return Surfels(positions, normals, areas, _per_surfel(albedo, n, "albedo"),
                   _per_surfel(emission, n, "emission"))


# --- sphere -------------------------------------------------------------------------------------

def _fibonacci_sphere(n):
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    rho = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    return np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=1)


def sphere_interior(n, *, radius=1.0, center=(0.0, 0.0, 0.0), sampling="fibonacci",
                    areas="uniform", albedo=0.5, emission=None, seed=0):
    """N surfels on a sphere with inward normals.

    sampling: "fibonacci" (quasi-uniform), "random" (uniform random), or "clustered" (denser
    near one pole: a non-uniform sampling). areas: "uniform" (4πR²/N each) or "random" (random
    positive weights scaled to total 4πR²). ``emission`` defaults to a smooth, position-dependent
    RGB pattern so that every channel differs. Points never coincide exactly.
    """
    rng = np.random.default_rng(seed)
    if sampling == "fibonacci":
        unit = _fibonacci_sphere(n)
    elif sampling == "random":
        unit = rng.normal(size=(n, 3))
        unit /= np.linalg.norm(unit, axis=1)[:, None]
    elif sampling == "clustered":
        unit = _fibonacci_sphere(n)
        z = unit[:, 2]
        z_new = 1.0 - 2.0 * ((1.0 - z) / 2.0) ** 2   # squeeze towards the +z pole
        scale = np.sqrt(np.maximum(0.0, 1.0 - z_new ** 2) / np.maximum(1e-300, 1.0 - z ** 2))
        unit = np.stack([unit[:, 0] * scale, unit[:, 1] * scale, z_new], axis=1)
        unit /= np.linalg.norm(unit, axis=1)[:, None]
    else:
        raise ValueError(f"sampling: unknown {sampling!r}")
    total = 4.0 * math.pi * radius ** 2
    if areas == "uniform":
        a = np.full(n, total / n)
    elif areas == "random":
        w = rng.uniform(0.2, 1.8, size=n)
        a = w * (total / w.sum())
    else:
        raise ValueError(f"areas: unknown {areas!r}")
    positions = np.asarray(center, dtype=np.float64) + radius * unit
    if emission is None:
        emission = np.stack([1.0 + unit[:, 0], 0.5 * (1.0 + unit[:, 2]) ** 2,
                             np.where(unit[:, 1] > 0.3, 2.0, 0.0)], axis=1)
    return _make(positions, -unit, a, albedo, emission)


def sphere_exact_radiosity(surfels: Surfels, radius: float) -> np.ndarray:
    """Closed-form solution of the discrete system inside a sphere with the bare point kernel.

    There ``F_ij = A_j/Q`` (Q = 4πR²) for j ≠ i, so with ``a_i = A_i/Q`` and per-surfel ρ_i::

        B_i = (E_i + ρ_i S/Q) / (1 + ρ_i a_i),
        S = Σ A_i E_i/(1 + ρ_i a_i) / (1 − Σ a_i ρ_i/(1 + ρ_i a_i))

    (DESIGN.md §4, with A_tot = Q; it reduces to the formula there for uniform ρ).
    """
    q = 4.0 * math.pi * radius ** 2
    A = surfels.areas[:, None]
    a = A / q
    rho = surfels.albedo
    E = surfels.emission
    denom = 1.0 + rho * a
    S = (A * E / denom).sum(axis=0) / (1.0 - (a * rho / denom).sum(axis=0))
    return (E + rho * S / q) / denom


# --- planar patches -----------------------------------------------------------------------------

def _grid(origin, u, v, nu, nv):
    """Midpoints and areas of an nu×nv grid on the parallelogram origin + s·u + t·v."""
    origin, u, v = (np.asarray(x, dtype=np.float64) for x in (origin, u, v))
    s = (np.arange(nu) + 0.5) / nu
    t = (np.arange(nv) + 0.5) / nv
    S, T = np.meshgrid(s, t, indexing="ij")
    points = origin + S.reshape(-1, 1) * u + T.reshape(-1, 1) * v
    area = np.linalg.norm(np.cross(u, v)) / (nu * nv)
    return points, np.full(nu * nv, area)


def _random_rect(origin, u, v, count, rng):
    origin, u, v = (np.asarray(x, dtype=np.float64) for x in (origin, u, v))
    st = rng.random((count, 2))
    points = origin + st[:, :1] * u + st[:, 1:] * v
    area = np.linalg.norm(np.cross(u, v)) / count
    return points, np.full(count, area)


def _patch(points, areas, normal):
    normals = np.tile(np.asarray(normal, dtype=np.float64), (len(points), 1))
    return points, normals, areas


def _concat(patches):
    return tuple(np.concatenate([p[i] for p in patches]) for i in range(3))


def _box_faces(lo, hi, inward=True):
    """(origin, u, v, normal) of the six faces of an axis-aligned box."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    size = hi - lo
    ex, ey, ez = np.eye(3) * size[:, None]
    sign = 1.0 if inward else -1.0
    return [
        (lo, ey, ez, sign * np.array([1.0, 0, 0])),           # x = lo
        (lo + ex, ey, ez, sign * np.array([-1.0, 0, 0])),     # x = hi
        (lo, ex, ez, sign * np.array([0, 1.0, 0])),           # y = lo
        (lo + ey, ex, ez, sign * np.array([0, -1.0, 0])),     # y = hi
        (lo, ex, ey, sign * np.array([0, 0, 1.0])),           # z = lo
        (lo + ez, ex, ey, sign * np.array([0, 0, -1.0])),     # z = hi
    ]


def closed_box(n, *, size=1.0, sampling="grid", albedo=0.9, emission=1.0, seed=0):
    """Inside of a cube of edge ``size``: n×n midpoint surfels per face (N = 6n²), inward
    normals; ``sampling="random"`` puts n² uniform random surfels on each face instead."""
    rng = np.random.default_rng(seed)
    patches = []
    for origin, u, v, normal in _box_faces(np.zeros(3), np.full(3, float(size)), inward=True):
        if sampling == "grid":
            pts, ar = _grid(origin, u, v, n, n)
        elif sampling == "random":
            pts, ar = _random_rect(origin, u, v, n * n, rng)
        else:
            raise ValueError(f"sampling: unknown {sampling!r}")
        patches.append(_patch(pts, ar, normal))
    return _make(*_concat(patches), albedo, emission)


def parallel_squares(n, *, distance=1.0):
    """Two unit squares facing each other at ``distance``, n×n midpoint surfels each.
    Returns (surfels, mask_a, mask_b); F_ab → 0.199825 at distance 1."""
    a = _patch(*_grid((0, 0, 0), (1, 0, 0), (0, 1, 0), n, n), (0, 0, 1))
    b = _patch(*_grid((0, 0, distance), (1, 0, 0), (0, 1, 0), n, n), (0, 0, -1))
    surfels = _make(*_concat([a, b]), 0.0, 0.0)
    mask = np.arange(2 * n * n) < n * n
    return surfels, mask, ~mask


def perpendicular_squares(n):
    """Unit squares sharing the edge x = z = 0: A in z = 0 (normal +z), B in x = 0 (normal +x).
    Returns (surfels, mask_a, mask_b); F_ab → 0.200044."""
    a = _patch(*_grid((0, 0, 0), (1, 0, 0), (0, 1, 0), n, n), (0, 0, 1))
    b = _patch(*_grid((0, 0, 0), (0, 1, 0), (0, 0, 1), n, n), (1, 0, 0))
    surfels = _make(*_concat([a, b]), 0.0, 0.0)
    mask = np.arange(2 * n * n) < n * n
    return surfels, mask, ~mask


def _disc(rings, radius, z, normal):
    """Polar midpoint sampling of a disc: ``rings`` rings of equal width, cells about square;
    each cell's surfel sits at the centroid of its annular sector."""
    dr = radius / rings
    pts, areas = [], []
    for k in range(rings):
        r1, r2 = k * dr, (k + 1) * dr
        cells = max(3, int(round(2.0 * math.pi * 0.5 * (r1 + r2) / dr)))
        half = math.pi / cells
        rc = (2.0 / 3.0) * (r2 ** 3 - r1 ** 3) / (r2 ** 2 - r1 ** 2) * math.sin(half) / half
        phi = (np.arange(cells) + 0.5) * 2.0 * half
        pts.append(np.stack([rc * np.cos(phi), rc * np.sin(phi), np.full(cells, z)], axis=1))
        areas.append(np.full(cells, half * (r2 ** 2 - r1 ** 2)))
    pts = np.concatenate(pts)
    return _patch(pts, np.concatenate(areas), normal)


def coaxial_discs(rings, *, radius=1.0, distance=1.0):
    """Two coaxial discs of radius ``radius`` facing each other at ``distance``.
    Returns (surfels, mask_a, mask_b); F_ab = (3 − √5)/2 for radius = distance."""
    a = _disc(rings, radius, 0.0, (0, 0, 1))
    b = _disc(rings, radius, distance, (0, 0, -1))
    surfels = _make(*_concat([a, b]), 0.0, 0.0)
    mask = np.arange(len(a[0]) + len(b[0])) < len(a[0])
    return surfels, mask, ~mask


def point_over_square(n, *, height=1.0, receiver_area=1e-6):
    """A small receiver at height ``height`` facing down onto the centred unit square (n×n
    midpoint surfels, facing up). Returns (surfels, mask_receiver, mask_square);
    F → 0.23945 at height 1."""
    r = _patch(np.array([[0.0, 0.0, height]]), np.array([receiver_area]), (0, 0, -1))
    s = _patch(*_grid((-0.5, -0.5, 0), (1, 0, 0), (0, 1, 0), n, n), (0, 0, 1))
    surfels = _make(*_concat([r, s]), 0.0, 0.0)
    mask = np.arange(1 + n * n) < 1
    return surfels, mask, ~mask


def view_factor(apply, surfels: Surfels, mask_a, mask_b) -> float:
    """Area-weighted view factor F_ab = (1/A_a) Σ_{i∈a} A_i Σ_{j∈b} F_ij through an operator's
    ``apply`` (N×3 → N×3)."""
    x = np.zeros((surfels.n, 3))
    x[mask_b] = 1.0
    y = np.asarray(apply(x))[:, 0]
    A = surfels.areas
    return float((A[mask_a] * y[mask_a]).sum() / A[mask_a].sum())


# --- a room with objects (benchmarks) ----------------------------------------------------------

def box_room(n, *, seed=0, albedo=None, emission=None):
    """About ``n`` random surfels in a closed room (4 × 3 × 2.5) holding a box, a sphere and a
    floating panel, all sampled uniformly by area. Without visibility (V = 1) the objects do not
    shadow, so row sums exceed 1 here: use it for timing and FMM accuracy, not furnace tests.
    Default albedo: white walls 0.7, red/green side walls, grey objects; default emission:
    a ceiling light patch."""
    rng = np.random.default_rng(seed)
    shapes = []   # (kind, params, area)
    for origin, u, v, normal in _box_faces((0, 0, 0), (4.0, 3.0, 2.5), inward=True):
        shapes.append(("rect", (origin, u, v, normal), np.linalg.norm(np.cross(u, v))))
    for origin, u, v, normal in _box_faces((0.6, 0.5, 0.0), (1.6, 1.4, 1.2), inward=False):
        shapes.append(("rect", (origin, u, v, normal), np.linalg.norm(np.cross(u, v))))
    shapes.append(("sphere", (np.array([2.8, 1.8, 0.7]), 0.6), 4 * math.pi * 0.36))
    panel = (np.array([2.2, 0.3, 1.6]), np.array([1.0, 0, 0]), np.array([0, 0.8, 0.3]))
    pn = np.cross(panel[1], panel[2])
    pn /= np.linalg.norm(pn)
    shapes.append(("rect", (*panel, pn), np.linalg.norm(np.cross(panel[1], panel[2]))))
    shapes.append(("rect", (panel[0] + panel[1], -panel[1], panel[2], -pn),
                   np.linalg.norm(np.cross(panel[1], panel[2]))))
    total = sum(s[2] for s in shapes)
    patches = []
    for kind, params, area in shapes:
        count = max(8, int(round(n * area / total)))
        if kind == "rect":
            origin, u, v, normal = params
            pts, ar = _random_rect(origin, u, v, count, rng)
            patches.append(_patch(pts, ar, normal))
        else:
            c, r = params
            unit = rng.normal(size=(count, 3))
            unit /= np.linalg.norm(unit, axis=1)[:, None]
            patches.append((c + r * unit, unit, np.full(count, area / count)))
    positions, normals, areas = _concat(patches)
    count = len(positions)
    if albedo is None:
        albedo = np.full((count, 3), 0.7)
        albedo[positions[:, 0] < 1e-9] = (0.63, 0.065, 0.05)
        albedo[positions[:, 0] > 4.0 - 1e-9] = (0.14, 0.45, 0.091)
    if emission is None:
        emission = np.zeros((count, 3))
        light = ((positions[:, 2] > 2.5 - 1e-9) & (np.abs(positions[:, 0] - 2.0) < 0.5)
                 & (np.abs(positions[:, 1] - 1.5) < 0.5))
        emission[light] = (17.0, 12.0, 4.0)
    return _make(positions, normals, areas, albedo, emission)
