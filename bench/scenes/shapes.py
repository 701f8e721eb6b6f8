"""Geometry shared by the scenes, as numpy arrays (no bpy): grids over quads, boxes, the
Stanford bunny scan.

A *part* is ``(verts (V, 3), faces (F, k), uvs (V, 2) or None)``; the Blender builder
(``blender.mesh_object``) makes a mesh of a list of parts, the surfel builders sample them.
"""

from __future__ import annotations

import math
import os

import numpy as np

#: The Stanford bunny (test data outside the extension; credited in ``BUNNY_CREDIT``).
BUNNY_PLY = os.environ.get("ILLUMAP_BUNNY", "/work/shared/data/stanford-bunny/bun_zipper.ply")
BUNNY_CREDIT = ("Stanford Bunny: Stanford 3D Scanning Repository, Stanford University Computer "
                "Graphics Laboratory (Greg Turk and Marc Levoy, 1994)")


def grid_patch(corners, cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A bilinear grid over the quad ``corners`` (4, 3) (c0, c1, c2, c3 around; m) with cells
    of about ``cell`` m: vertices (V, 3), quads (F, 4) wound c0 → c1 → c2 (normal
    (c1 − c0) × (c3 − c0)), and UVs (V, 2) running 0–1 along c0 → c1 and c0 → c3."""
    c = np.asarray(corners, dtype=np.float64)
    nu = max(1, math.ceil(max(np.linalg.norm(c[1] - c[0]), np.linalg.norm(c[2] - c[3])) / cell))
    nv = max(1, math.ceil(max(np.linalg.norm(c[3] - c[0]), np.linalg.norm(c[2] - c[1])) / cell))
    s, t = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1))
    s, t = s.ravel()[:, None], t.ravel()[:, None]
    verts = (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3]
    i, j = np.meshgrid(np.arange(nu), np.arange(nv))
    first = (j * (nu + 1) + i).ravel()
    quads = np.stack([first, first + 1, first + nu + 2, first + nu + 1], axis=1)
    return verts, quads, np.hstack([s, t])


def jittered_patch(corners, cell: float, jitter: float, rng) -> tuple:
    """``grid_patch`` with each vertex moved up to ``jitter`` cells in the quad's plane (a
    vertex on the patch's edge along that edge; corners kept): the points of a scan that
    still lie exactly on the surface."""
    verts, quads, uvs = grid_patch(corners, cell)
    if jitter > 0:
        c = np.asarray(corners, float)
        s, t = uvs[:, 0].copy(), uvs[:, 1].copy()
        nu = round(1 / max(np.diff(np.unique(s)).min(), 1e-9))
        nv = round(1 / max(np.diff(np.unique(t)).min(), 1e-9))
        ds = rng.uniform(-jitter, jitter, len(s)) / nu
        dt = rng.uniform(-jitter, jitter, len(t)) / nv
        s = np.where((s > 0) & (s < 1), s + ds, s)
        t = np.where((t > 0) & (t < 1), t + dt, t)
        s, t = s[:, None], t[:, None]
        verts = (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3]
    return verts, quads, uvs


def facing(corners, toward) -> np.ndarray:
    """``corners`` reordered, if needed, so the quad's normal points toward ``toward``
    (a direction vector)."""
    c = np.asarray(corners, dtype=np.float64)
    normal = np.cross(c[1] - c[0], c[3] - c[0])
    return c if normal @ np.asarray(toward, float) >= 0 else c[[0, 3, 2, 1]]


def box_faces(lo, hi, *, inward: bool = False, skip=()) -> list:
    """The corners (4, 3) of the six faces of the axis-aligned box ``lo``–``hi`` (m), wound for
    outward (or ``inward``) normals; ``skip`` names faces left out ('-x', '+x', '-y', '+y',
    '-z', '+z')."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    faces = []
    for axis in range(3):
        for side, value in (("-", lo[axis]), ("+", hi[axis])):
            if f"{side}{'xyz'[axis]}" in skip:
                continue
            a, b = [k for k in range(3) if k != axis]
            corners = np.zeros((4, 3))
            corners[:, axis] = value
            corners[:, a] = [lo[a], hi[a], hi[a], lo[a]]
            corners[:, b] = [lo[b], lo[b], hi[b], hi[b]]
            out = np.zeros(3)
            out[axis] = 1.0 if side == "+" else -1.0
            faces.append(facing(corners, -out if inward else out))
    return faces


def box_parts(lo, hi, cell: float, *, inward: bool = False, skip=()) -> list:
    """Grid parts of the faces of ``box_faces``."""
    return [grid_patch(corners, cell) for corners in box_faces(lo, hi, inward=inward, skip=skip)]


def quad_parts(corners, toward, cell: float) -> list:
    """The one grid part of a planar quad, facing ``toward``."""
    return [grid_patch(facing(corners, toward), cell)]


def midpoint_grid_mesh(origin, u, v, nu: int, nv: int):
    """A grid mesh on origin + s u + t v whose interior vertices are the nu × nv cell
    midpoints and whose border ring lies on the quad's edges: verts, faces (F, 4), interior
    (bool per vertex)."""
    su = np.concatenate([[0.0], (np.arange(nu) + 0.5) / nu, [1.0]])
    sv = np.concatenate([[0.0], (np.arange(nv) + 0.5) / nv, [1.0]])
    mu, mv = len(su), len(sv)
    a, b = np.meshgrid(su, sv, indexing="xy")        # vertex (row b, column a)
    verts = origin + a.reshape(-1, 1) * u + b.reshape(-1, 1) * v
    j, i = np.meshgrid(np.arange(mv - 1), np.arange(mu - 1), indexing="ij")
    j, i = j.ravel(), i.ravel()
    faces = np.stack([j * mu + i, j * mu + i + 1, (j + 1) * mu + i + 1, (j + 1) * mu + i],
                     axis=1).astype(np.int64)
    interior = np.zeros((mv, mu), bool)
    interior[1:-1, 1:-1] = True
    return verts, faces, interior.reshape(-1)


def quad_triangles(origin, u, v, cells: int) -> np.ndarray:
    """The quad origin + s u + t v as cells × cells squares of two triangles each,
    (2 cells², 3, 3): first every square's (o, o+u, o+u+v) half, then its (o, o+u+v, o+v)."""
    s = np.arange(cells + 1) / cells
    grid = origin + s[:, None, None] * u + s[None, :, None] * v
    a, b = grid[:-1, :-1], grid[1:, :-1]
    c, d = grid[1:, 1:], grid[:-1, 1:]
    return np.concatenate([np.stack([a, b, c], axis=2).reshape(-1, 3, 3),
                           np.stack([a, c, d], axis=2).reshape(-1, 3, 3)])


def read_ply(path: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (F, 3) of an ASCII PLY such as the Stanford bunny."""
    with open(path) as f:
        counts = {}
        for line in f:
            parts = line.split()
            if parts[:1] == ["element"]:
                counts[parts[1]] = int(parts[2])
            if parts[:1] == ["end_header"]:
                break
        rows = f.read().split("\n")
    nv, nf = counts["vertex"], counts["face"]
    verts = np.array([r.split()[:3] for r in rows[:nv]], dtype=np.float64)
    faces = np.array([r.split()[1:4] for r in rows[nv:nv + nf]], dtype=np.int64)
    return verts, faces


_BUNNY = {}


def bunny_scan() -> tuple[np.ndarray, np.ndarray]:
    """The bunny scan's 35,947 vertices (m, Z up: the scan's (x, −z, y), a rotation, so the
    triangles keep their winding), centred on the Z axis and standing at z = 0, and its
    triangles. Read once."""
    if "scan" not in _BUNNY:
        verts, faces = read_ply(BUNNY_PLY)
        verts = verts[:, [0, 2, 1]] * np.array([1.0, -1.0, 1.0])          # y up -> z up
        verts = verts - [verts[:, 0].mean(), verts[:, 1].mean(), verts[:, 2].min()]
        _BUNNY["scan"] = (verts, faces)
    return _BUNNY["scan"]
