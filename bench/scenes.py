"""Benchmark scenes shared by bench/*.py and tests/core/test_accuracy.py (numpy + illumap only).

Three scenes, each built at a requested density so that error can be charted against cost:

* ``cornell(n)`` -- Cornell's box (0.556 m, open front, Cornell RGB reflectances, light
  radiance (17, 12, 4) in a 0.13 x 0.105 m hole of the ceiling), empty: the two blocks are left
  out because only ``visibility="none"`` exists so far, and an empty box is convex, where V = 1
  is exact. Every wall is an n x n grid of cells with a surfel at each midpoint; Cycles bakes at
  exactly the same points (bench/cycles_bake.py builds meshes from ``cornell_mesh`` whose
  interior vertices are those midpoints).
* ``bunny(n)`` -- the Stanford bunny scan (Turk and Levoy, Stanford 3D Scanning Repository,
  1994) as a raw point cloud: vertices only, normals estimated by PCA over 12 nearest
  neighbours and oriented away from the centroid, areas from the local point spacing; on a
  grey floor under an emissive square. The data stay outside the extension
  (/work/shared/data/stanford-bunny or $ILLUMAP_BUNNY).
* ``interior(n)`` -- ``illumap.scenes.box_room`` (light power normalized): a room with a box, a sphere and a two-sided
  panel (many occluders once visibility exists).

``reference_at(ref_surfels, ref_B, query_surfels)`` evaluates a converged reference solution at
other points by one exact gather, ``B_q = E_q + rho_q sum_j F_qj B_j`` (direct O(N_q N_ref)).
"""

from __future__ import annotations

import math
import os

import numpy as np

import illumap
from illumap import scenes as core_scenes

BOX = 0.556
WHITE, RED, GREEN = (0.725, 0.71, 0.68), (0.63, 0.065, 0.05), (0.14, 0.45, 0.091)
LIGHT_RADIANCE = (17.0, 12.0, 4.0)
LIGHT_HALF = (0.065, 0.0525)   # Cornell's light: 130 x 105 mm

BUNNY_PLY = os.environ.get("ILLUMAP_BUNNY",
                           "/work/shared/data/stanford-bunny/bun_zipper.ply")
BUNNY_CREDIT = ("Stanford Bunny: Stanford 3D Scanning Repository, Stanford University Computer "
                "Graphics Laboratory (Greg Turk and Marc Levoy, 1994)")

SCENES = ("cornell", "bunny", "interior")
#: Surfels of bunny(n) with every scan point (35,947 of them are 70%)
BUNNY_MAX = 51000


# ------------------------------------------------------------------------------------------------
# Cornell box on a vertex grid

def cornell_mesh(n):
    """Walls as grid meshes whose interior vertices are the surfels.

    Each wall is split into n x n cells of side h = BOX / n; its mesh has vertices at the cell
    midpoints plus a border ring on the wall's edges (coordinates 0, h/2, 3h/2, ..., BOX), so
    that Cycles bakes at exactly the midpoint surfels (border vertices, on the box's edges where
    incident light is discontinuous, are not compared). The light is a separate quad, the union
    of the ceiling cells whose centres fall inside Cornell's 130 x 105 mm rectangle, 0.1 mm below
    the ceiling, its radiance scaled so that its power is that of Cornell's light at every n; the ceiling cells it covers carry no surfels.

    Returns a list of dicts: name, verts (V x 3), faces (F x 4), normal, albedo, emission,
    surfel (bool V: which vertices are surfels, in the order ``cornell(n)`` uses)."""
    L = BOX
    mid = (np.arange(n) + 0.5) / n
    s = np.concatenate([[0.0], mid, [1.0]])
    m = len(s)
    walls = [
        ("Floor", (0, 0, 0), (L, 0, 0), (0, L, 0), WHITE),
        ("Back", (0, L, 0), (L, 0, 0), (0, 0, L), WHITE),
        ("Left", (0, 0, 0), (0, L, 0), (0, 0, L), RED),       # x = 0, normal +x
        ("Right", (L, 0, 0), (0, 0, L), (0, L, 0), GREEN),    # x = L, normal -x
        ("Ceiling", (0, 0, L), (0, L, 0), (L, 0, 0), WHITE),  # normal -z
    ]
    inside_x = np.abs(mid * L - L / 2) < LIGHT_HALF[0]
    inside_y = np.abs(mid * L - L / 2) < LIGHT_HALF[1]
    if not inside_x.any():
        inside_x[n // 2] = True
    if not inside_y.any():
        inside_y[n // 2] = True
    out = []
    for name, origin, u, v, albedo in walls:
        origin, u, v = (np.array(x, float) for x in (origin, u, v))
        normal = np.cross(u, v)
        normal /= np.linalg.norm(normal)
        a, b = np.meshgrid(s, s, indexing="xy")        # vertex (row b, column a)
        verts = origin + a.reshape(-1, 1) * u + b.reshape(-1, 1) * v
        faces = np.array([(j * m + i, j * m + i + 1, (j + 1) * m + i + 1, (j + 1) * m + i)
                          for j in range(m - 1) for i in range(m - 1)], dtype=np.int64)
        interior = np.zeros((m, m), bool)
        interior[1:-1, 1:-1] = True
        if name == "Ceiling":    # u = +y (column index i), v = +x (row index j)
            interior[1:-1, 1:-1] &= ~(inside_x[:, None] & inside_y[None, :])
        out.append(dict(name=name, verts=verts, faces=faces, normal=normal,
                        albedo=np.array(albedo, float), emission=np.zeros(3),
                        surfel=interior.reshape(-1)))
    # the light: cells (x index, y index) inside the rectangle, as one grid
    xs = np.flatnonzero(inside_x)
    ys = np.flatnonzero(inside_y)
    h = L / n
    gx = np.concatenate([xs * h, [(xs[-1] + 1) * h]])
    gy = np.concatenate([ys * h, [(ys[-1] + 1) * h]])
    z = L - 1e-4
    verts = np.array([(x, y, z) for y in gy for x in gx])
    mx = len(gx)
    faces = np.array([(j * mx + i, (j + 1) * mx + i, (j + 1) * mx + i + 1, j * mx + i + 1)
                      for j in range(len(gy) - 1) for i in range(mx - 1)], dtype=np.int64)
    # scale the radiance so that the emitted power equals Cornell's light at every n
    scale = (4 * LIGHT_HALF[0] * LIGHT_HALF[1]) / (len(xs) * len(ys) * h * h)
    out.append(dict(name="Light", verts=verts, faces=faces, normal=np.array([0, 0, -1.0]),
                    albedo=np.zeros(3), emission=scale * np.array(LIGHT_RADIANCE, float),
                    surfel=np.zeros(len(verts), bool),
                    light_cells=np.array([(x + 0.5, y + 0.5) for y in ys for x in xs]) * h))
    return out


def cornell(n):
    """Surfels at the cell midpoints of ``cornell_mesh(n)``: 5 n^2 (the light cells are
    emitter surfels in the ceiling plane, the ceiling keeps the rest)."""
    h = BOX / n
    P, N, A, R, E = [], [], [], [], []
    for w in cornell_mesh(n):
        if w["name"] == "Light":
            c = w["light_cells"]
            pts = np.column_stack([c, np.full(len(c), BOX)])
        else:
            pts = w["verts"][w["surfel"]]
        k = len(pts)
        P.append(pts)
        N.append(np.tile(w["normal"], (k, 1)))
        A.append(np.full(k, h * h))
        R.append(np.tile(w["albedo"], (k, 1)))
        E.append(np.tile(w["emission"], (k, 1)))
    return illumap.Surfels(*(np.concatenate(x) for x in (P, N, A, R, E)))


def cornell_n_for(count):
    """Grid cells per side giving about ``count`` surfels."""
    return max(2, int(round(math.sqrt(count / 5.0))))


# ------------------------------------------------------------------------------------------------
# the bunny scan as a point cloud

_BUNNY_CACHE = {}


def bunny_points():
    """The 35,947 scan vertices (x, y, z in metres, y up), converted to z up."""
    if "points" not in _BUNNY_CACHE:
        with open(BUNNY_PLY, "r") as f:
            count = None
            while True:
                line = f.readline()
                if line.startswith("element vertex"):
                    count = int(line.split()[2])
                if line.strip() == "end_header":
                    break
            data = np.loadtxt(f, max_rows=count, usecols=(0, 1, 2))
        pts = np.stack([data[:, 0], -data[:, 2], data[:, 1]], axis=1)   # y up -> z up
        pts -= [pts[:, 0].mean(), pts[:, 1].mean(), pts[:, 2].min()]
        _BUNNY_CACHE["points"] = pts
    return _BUNNY_CACHE["points"]


def estimate_normals_areas(points, k=12, orient_from=None):
    """PCA normals over k nearest neighbours, oriented away from ``orient_from`` (default: the
    centroid), and areas pi * r^2 with r half the mean distance to the k nearest neighbours,
    rescaled so the areas sum to the area estimate sum(pi r_k^2 / k)."""
    from illumap import _core
    idx, dist = _core.knn(np.ascontiguousarray(points), np.ascontiguousarray(points), k + 1)
    nb = points[idx[:, 1:]]
    centred = nb - nb.mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", centred, centred)
    _, vecs = np.linalg.eigh(cov)
    normals = vecs[:, :, 0]
    centre = points.mean(axis=0) if orient_from is None else np.asarray(orient_from, float)
    flip = np.einsum("ij,ij->i", normals, points - centre) < 0
    normals[flip] *= -1
    areas = math.pi * dist[:, -1] ** 2 / k
    return normals, areas


def bunny(n, seed=0):
    """About ``n`` surfels: a random subset of the scan (up to all 35,947 points) plus a floor
    and an emitter in proportion (the scan keeps ~70% of the surfels)."""
    rng = np.random.default_rng(seed)
    pts = bunny_points()
    m = min(len(pts), max(200, int(0.7 * n)))
    sub = pts[np.sort(rng.choice(len(pts), m, replace=False))] if m < len(pts) else pts
    normals, areas = estimate_normals_areas(sub, orient_from=sub.mean(axis=0) * [1, 1, 0.8])
    bunny_area = areas.sum()
    # floor 0.5 x 0.5 m and an emitter 0.15 x 0.15 m at 0.35 m: regular grids (midpoints), the
    # floor at the bunny's density, the emitter with at least 10 x 10 surfels
    density = m / bunny_area
    kf = max(8, int(round(math.sqrt(0.25 * density * 0.25))))
    kl = max(10, int(round(math.sqrt(0.0225 * density * 0.25))))
    g = (np.arange(kf) + 0.5) / kf - 0.5
    fx, fy = np.meshgrid(0.5 * g, 0.5 * g)
    fp = np.column_stack([fx.ravel(), fy.ravel(), np.full(kf * kf, -1e-3)])
    g = (np.arange(kl) + 0.5) / kl - 0.5
    lx, ly = np.meshgrid(0.15 * g, 0.15 * g)
    lp = np.column_stack([lx.ravel(), ly.ravel(), np.full(kl * kl, 0.35)])
    floor_count, light_count = kf * kf, kl * kl
    P = np.concatenate([sub, fp, lp])
    N = np.concatenate([normals, np.tile([0, 0, 1.0], (floor_count, 1)),
                        np.tile([0, 0, -1.0], (light_count, 1))])
    A = np.concatenate([areas, np.full(floor_count, 0.25 / floor_count),
                        np.full(light_count, 0.0225 / light_count)])
    R = np.concatenate([np.tile([0.8, 0.75, 0.7], (m, 1)), np.tile([0.5, 0.5, 0.5], (floor_count, 1)),
                        np.zeros((light_count, 3))])
    E = np.concatenate([np.zeros((m + floor_count, 3)), np.tile([10.0, 10.0, 10.0], (light_count, 1))])
    return illumap.Surfels(P, N, A, R, E)


# ------------------------------------------------------------------------------------------------

def interior(n, seed=0):
    """``illumap.scenes.box_room`` with the ceiling light's radiance rescaled so that its power
    is that of the exact 1 m x 1 m patch whatever the random sample (otherwise the count of
    random surfels that land in the patch dominates the error)."""
    s = core_scenes.box_room(n, seed=seed)
    light = s.emission.max(axis=1) > 0
    power = float((s.areas[light]).sum())
    return s.replace(emission=s.emission * (1.0 / power))


def build(name, n, seed=0):
    """Scene ``name`` with about ``n`` surfels."""
    if name == "cornell":
        return cornell(cornell_n_for(n))
    if name == "bunny":
        return bunny(n, seed=seed)
    if name == "interior":
        return interior(n, seed=seed)
    raise ValueError(f"unknown scene {name!r}; expected one of {SCENES}")


# ------------------------------------------------------------------------------------------------
# reference and error

def reference_solution(surfels, tol=1e-9, visibility="none"):
    """The converged reference: direct O(N^2) operator, CG/GMRES to ``tol``."""
    kw = {} if visibility == "none" else {"visibility": visibility}
    return illumap.solve(surfels, method="direct", tol=tol, **kw)


def reference_at(ref, ref_B, query, chunk=4096):
    """Exact gather of the reference radiosity at the points of ``query`` (Surfels):
    ``B_q = E_q + rho_q sum_j F_qj B_ref_j``. The query points get a tiny area so that they
    neither emit into the sum nor change the near-field rule much (Ā ≈ A_j / 2)."""
    nq = query.n
    P = np.concatenate([ref.positions, query.positions])
    N = np.concatenate([ref.normals, query.normals])
    A = np.concatenate([ref.areas, np.full(nq, 1e-3 * ref.areas.min())])
    zeros = np.zeros((ref.n + nq, 3))
    union = illumap.Surfels(P, N, A, zeros, zeros)
    op = illumap.TransportOperator(union, method="direct")
    x = np.concatenate([ref_B, np.zeros((nq, 3))])
    rows = np.arange(ref.n, ref.n + nq)
    gathered = np.concatenate([op.apply_rows(x, rows[i:i + chunk]) for i in range(0, nq, chunk)])
    return query.emission + query.albedo * gathered


def relative_rms(B, B_ref, emission=None):
    """Relative RMS per surfel, over all channels, excluding emitters (whose B ≈ E would hide
    the error): sqrt(mean |B − B_ref|²) / sqrt(mean |B_ref|²)."""
    mask = np.ones(len(B), bool) if emission is None else ~(emission.max(axis=1) > 0)
    d = B[mask] - B_ref[mask]
    return float(math.sqrt(np.mean(d * d)) / math.sqrt(np.mean(B_ref[mask] ** 2)))
