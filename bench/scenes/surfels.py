"""The surfel scenes of the benchmarks and calibration, and their references (numpy + illumap,
no bpy): shared by bench/reference/cycles_bake.py, bench/calibration, bench/micro,
bench/experiments and tests/core.

Four scenes, each built at a requested density so that error can be charted against cost:

* ``cornell(n)`` -- Cornell's box (0.556 m, open front, Cornell RGB reflectances, light
  radiance (17, 12, 4) on a 0.13 x 0.105 m quad just below the ceiling) with its two blocks
  (Cornell's published footprints and heights): occluders, so visibility matters. Every wall is
  an n x n grid of cells, each block face and the light a grid of cells of about the same size,
  with a surfel at each midpoint; Cycles bakes at exactly the same points
  (bench/reference/cycles_bake.py builds meshes from ``cornell_grid_meshes`` whose interior
  vertices are those midpoints).
  ``cornell_geometry`` gives the same box as planar quads (for other samplings): the regular
  form of the one Cornell box, ``cornell.regular_quads``.
* ``cornell_sampled(n)`` (scene ``cornell_mesh``) -- the same box as triangles
  (``cornell_triangles``) with stratified surfels, as the add-on samples meshes; measured
  against the Cornell box's reference.
* ``bunny(n)`` -- the Stanford bunny scan (Turk and Levoy, Stanford 3D Scanning Repository,
  1994) as a raw point cloud, decimated evenly to the requested density: vertices only,
  normals estimated by PCA over 12 nearest neighbours and oriented away from the centroid, areas from the local point spacing; on a
  grey floor under an emissive square. The data stay outside the extension
  (/work/shared/data/stanford-bunny or $ILLUMAP_BUNNY).
* ``interior(n)`` -- ``illumap.scenes.box_room`` (light power normalized): a room with a box,
  a sphere and a two-sided panel (many occluders once visibility exists).

``reference_at(ref_surfels, ref_B, query_surfels)`` evaluates a converged reference solution at
other points by one exact gather, ``B_q = E_q + rho_q sum_j F_qj B_j`` (direct O(N_q N_ref)).
"""

from __future__ import annotations

import math
import os

import numpy as np

import illumap
from illumap import accuracy, pointcloud, sampling
from illumap import scenes as core_scenes

from . import cornell as cornell_box, shapes
from .cornell import BOX, LIGHT_HALF
from .records import provenance, utc_now, write_json  # noqa: F401  (the scripts' S.write_json)
from .shapes import BUNNY_PLY  # noqa: F401  (the scripts' S.BUNNY_PLY)

SCENES = ("cornell", "cornell_mesh", "bunny", "interior")

#: Keywords of ``visibility="exact"`` used by the references and the benchmarks, per scene: those
#: of the automatic mode for the scene's kind (``illumap.accuracy.EXACT_KEYWORDS``: one-radius
#: endpoint trim; discs 1.3 spacings wide on the grid, 1.7 on random samples and the scan). With
#: the operator's default trim (0.05 radius) the neighbours' discs on a curved or scanned
#: surface shadow a surfel's own grazing rays (docs/benchmarks.md).
def exact_keywords(name):
    """The exact-visibility keywords of scene ``name``."""
    return accuracy.visibility_keywords("exact", KIND[name])


#: Surfels of bunny(n) with every scan point (35,947 of them, 70% of n)
BUNNY_MAX = 52000


# ------------------------------------------------------------------------------------------------
# Cornell box with its two blocks, on vertex grids

def cornell_geometry(blocks=True):
    """The Cornell box as planar quads (``cornell.regular_quads``): dicts ``name``, ``origin``,
    ``u``, ``v`` (edge vectors, m; normal = u x v), ``albedo``, ``emission`` (radiance)."""
    return cornell_box.regular_quads(blocks)


def cornell_grid_meshes(n, blocks=True):
    """The Cornell box (``cornell_geometry``) as grid meshes whose interior vertices are the
    surfels of ``cornell(n, blocks)``.

    Each quad (wall, block face, light) is split into cells of side about h = BOX / n (the
    walls into exactly n x n); a mesh has vertices at the cell midpoints plus a border ring on
    the quad's edges, so that Cycles bakes at exactly the midpoint surfels (border vertices, on
    edges where incident light is discontinuous, are not compared). The light is Cornell's
    130 x 105 mm quad 0.1 mm below the ceiling at every n (at least 2 x 2 emitter surfels);
    floor cells whose midpoint lies under a block and ceiling cells whose midpoint lies behind
    the light carry no surfel.

    Returns a list of dicts: name, verts (V x 3), faces (F x 4), normal, albedo, emission,
    area (per surfel, m^2), surfel (bool V: which vertices are surfels, in the order
    ``cornell(n)`` uses; the light's are its emitters)."""
    L = BOX
    h = L / n
    out = []
    for q in cornell_geometry(blocks):
        lu, lv = np.linalg.norm(q["u"]), np.linalg.norm(q["v"])
        least = 2 if q["name"] == "Light" else 1
        nu, nv = max(least, int(round(lu / h))), max(least, int(round(lv / h)))
        verts, faces, interior = shapes.midpoint_grid_mesh(q["origin"], q["u"], q["v"], nu, nv)
        surfel = interior.copy()
        if q["name"] == "Ceiling":
            surfel &= ~((np.abs(verts[:, 0] - L / 2) < LIGHT_HALF[0])
                        & (np.abs(verts[:, 1] - L / 2) < LIGHT_HALF[1]))
        if q["name"] == "Floor" and blocks:
            surfel &= ~cornell_box.inside_footprints(verts[:, :2])
        normal = np.cross(q["u"], q["v"])
        out.append(dict(name=q["name"], verts=verts, faces=faces,
                        normal=normal / np.linalg.norm(normal), albedo=q["albedo"],
                        emission=q["emission"], area=lu * lv / (nu * nv), surfel=surfel))
    return out


def cornell(n, blocks=True):
    """Surfels at the cell midpoints of ``cornell_grid_meshes(n, blocks)``: about 6 n^2 on
    the walls and the blocks' faces, then the light's emitter surfels last."""
    P, N, A, R, E = [], [], [], [], []
    for w in cornell_grid_meshes(n, blocks):
        pts = w["verts"][w["surfel"]]
        k = len(pts)
        P.append(pts)
        N.append(np.tile(w["normal"], (k, 1)))
        A.append(np.full(k, w["area"]))
        R.append(np.tile(w["albedo"], (k, 1)))
        E.append(np.tile(w["emission"], (k, 1)))
    return illumap.Surfels(*(np.concatenate(x) for x in (P, N, A, R, E)))


#: Cells per side of each Cornell quad in ``cornell_surface``'s default mesh: 16 quads of 18 x 18
#: cells, 10,368 triangles, about the reference bench's Cornell box (5,100 vertices).
CORNELL_MESH_CELLS = 18


def cornell_surface(cells=CORNELL_MESH_CELLS, blocks=True):
    """The Cornell box (``cornell_geometry``) as the triangle mesh a user would model:
    (T, 3, 3) corners, m, every quad split into ``cells`` x ``cells`` squares of two triangles.
    The scaling bench gives it as ``occluder_triangles``, as the add-on gives a mesh scene's
    triangles to exact visibility."""
    return np.concatenate([_quad_triangles(q, cells) for q in cornell_geometry(blocks)])


def _quad_triangles(q, cells):
    """Quad ``q`` (``cornell_geometry``) as cells x cells squares of two triangles each."""
    return shapes.quad_triangles(q["origin"], q["u"], q["v"], cells)


def cornell_triangles(blocks=True):
    """The Cornell box (``cornell_geometry``) as a triangle soup for mesh sampling:
    corners (T, 3, 3), albedo (T, 3), emission (T, 3), and ``keep(positions) -> bool``, false
    for points of the floor under a block or of the ceiling behind the light (no surfel of
    ``cornell(n)`` lies there either)."""
    quads = cornell_geometry(blocks)
    corners = np.concatenate([_quad_triangles(q, 1) for q in quads])
    albedo = np.repeat([q["albedo"] for q in quads], 2, axis=0)
    emission = np.repeat([q["emission"] for q in quads], 2, axis=0)

    def keep(p):
        under = ((np.abs(p[:, 2]) < 1e-9) & cornell_box.inside_footprints(p[:, :2])
                 if blocks else False)
        return ~(under | cornell_box.behind_light(p))
    return corners, albedo, emission, keep


def cornell_sampled(n, seed=0):
    """About ``n`` surfels on ``cornell_triangles()``: stratified, uniform density
    (``illumap.sampling.sample_triangles``, as the add-on samples meshes), without those
    ``keep`` drops."""
    corners, albedo, emission, keep = cornell_triangles()
    s = sampling.sample_triangles(corners, int(n), np.random.default_rng(seed))
    m = keep(s.positions)
    tri = s.triangle[m]
    return illumap.Surfels(s.positions[m], s.normals[m], s.areas[m], albedo[tri], emission[tri])


#: Surfels per wall-cell count n^2 of ``cornell(n)`` with blocks (walls 5 n^2, blocks ~1.2 n^2
#: on their faces, less ~0.2 n^2 floor cells under them)
CORNELL_PER_N2 = 6.0


def cornell_n_for(count):
    """Grid cells per wall side giving about ``count`` surfels (with the blocks)."""
    return max(2, int(round(math.sqrt(count / CORNELL_PER_N2))))


# ------------------------------------------------------------------------------------------------
# the bunny scan as a point cloud

_BUNNY_CACHE = {}


def bunny_points():
    """The 35,947 scan vertices (m, z up, standing at z = 0: ``shapes.bunny_scan``)."""
    return shapes.bunny_scan()[0]


def estimate_areas(points, k=12):
    """Areas pi * r^2 with r half the mean distance to the k nearest neighbours, rescaled so
    the areas sum to the area estimate sum(pi r_k^2 / k)."""
    from illumap import _core
    _, dist = _core.knn(np.ascontiguousarray(points), np.ascontiguousarray(points), k + 1)
    return math.pi * dist[:, -1] ** 2 / k


def bunny(n, seed=0):
    """About ``n`` surfels: the scan decimated evenly (``illumap.sampling.thin_points``, the
    grid shifted by ``seed``; up to all 35,947 points) plus a floor and an emitter in
    proportion (the scan keeps ~70% of the surfels)."""
    pts = bunny_points()
    pick = sampling.thin_points(pts, min(len(pts), max(200, int(0.7 * n))),
                                np.random.default_rng(seed))
    sub, m = pts[pick], len(pick)
    # normals from the whole scan (as a scanner's software gives them: PCA, consistently
    # oriented; a per-point heuristic turns 9% of them, on the ears, inwards), areas from the
    # subset's own spacing
    if "normals" not in _BUNNY_CACHE:
        _BUNNY_CACHE["normals"] = pointcloud.estimate_normals(pts)
    normals = _BUNNY_CACHE["normals"][pick]
    areas = estimate_areas(sub)
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


#: The accuracy mode's scene kind per benchmark scene (how its surfels are sampled)
KIND = {"cornell": "grid", "cornell_mesh": "mesh", "bunny": "point_cloud", "interior": "random"}
#: Scenes given as triangles too (the automatic mode samples them itself, adaptively)
TRIANGLE_SCENES = {"cornell_mesh": cornell_triangles}
#: The scene whose reference a scene is measured against (the same geometry sampled otherwise)
REFERENCE_SCENE = {"cornell_mesh": "cornell"}


def reference_scene(name):
    """The scene whose converged reference measures scene ``name``."""
    return REFERENCE_SCENE.get(name, name)


def max_surfels(name):
    """The most surfels a scene can be sampled with (a scan has its points; meshes: no cap)."""
    return BUNNY_MAX if name == "bunny" else accuracy.NO_SURFEL_LIMIT


def build(name, n, seed=0):
    """Scene ``name`` with about ``n`` surfels."""
    if name == "cornell":
        return cornell(cornell_n_for(n))
    if name == "cornell_mesh":
        return cornell_sampled(n, seed=seed)
    if name == "bunny":
        return bunny(n, seed=seed)
    if name == "interior":
        return interior(n, seed=seed)
    raise ValueError(f"unknown scene {name!r}; expected one of {SCENES}")


def build_at_least(name, count, seed=0):
    """Scene ``name`` with at least ``count`` surfels, and not many more (within about 3%, or
    as close as the scene's sampling steps allow; a scan stops at its points). ``build(name,
    n)`` gives only about n surfels (the bunny about 1.5 n), so the request is rescaled."""
    count = max(int(count), 2)
    n = count
    best = None
    for _ in range(8):
        q = build(name, n, seed=seed)
        if q.n >= count and (best is None or q.n < best.n):
            best = q
        if best is not None and best.n <= 1.03 * count:
            break
        if q.n < count and best is None and n >= 4 * count:   # a scan cannot grow past it
            return q
        step = count / q.n * (1.01 if q.n < count else 1.0)
        n_next = max(2, int(math.ceil(n * step)) + (1 if q.n < count else 0))
        if n_next == n:
            n_next = n + 1 if q.n < count else n - 1
        n = n_next
    return best if best is not None else q


# ------------------------------------------------------------------------------------------------
# reference and error

def reference_solution(surfels, name, tol=1e-9, visibility="exact"):
    """The converged reference of scene ``name``: direct O(N^2) operator (with
    ``visibility``, default exact ray casting), CG to ``tol``."""
    kw = exact_keywords(name) if visibility == "exact" else {}
    return illumap.solve(surfels, method="direct", tol=tol, visibility=visibility, **kw)


def reference_at(ref, ref_B, query, name, chunk=2048, visibility="exact"):
    """Exact gather of the reference radiosity at the points of ``query`` (Surfels):
    ``B_q = E_q + rho_q sum_j F_qj V_qj B_j``, one ray per facing pair with ``visibility``
    (default exact). Each query point takes the area of its nearest reference surfel, so that
    the near-field rule and the rays' endpoint offset are those of a reference surfel there;
    it sends nothing (x = 0). Only ``apply_rows`` of the union operator is used, which sums
    every pair exactly whatever the method (the FMM build just hosts the visibility model)."""
    from illumap import _core
    nq = query.n
    idx, _ = _core.knn(np.ascontiguousarray(ref.positions),
                       np.ascontiguousarray(query.positions), 1)
    P = np.concatenate([ref.positions, query.positions])
    N = np.concatenate([ref.normals, query.normals])
    A = np.concatenate([ref.areas, ref.areas[np.asarray(idx).reshape(-1)]])
    zeros = np.zeros((ref.n + nq, 3))
    union = illumap.Surfels(P, N, A, zeros, zeros)
    if visibility == "none":
        op = illumap.TransportOperator(union, method="direct")
    else:
        kw = exact_keywords(name) if visibility == "exact" else {}
        op = illumap.TransportOperator(union, method="fmm", order=0, visibility=visibility,
                                       **kw)
    x = np.concatenate([ref_B, np.zeros((nq, 3))])
    rows = np.arange(ref.n, ref.n + nq)
    gathered = np.concatenate([op.apply_rows(x, rows[i:i + chunk]) for i in range(0, nq, chunk)])
    return query.emission + query.albedo * gathered


def error_subset(surfels, count=1200, seed=7):
    """Indices of at most ``count`` non-emitting surfels, drawn at random: the relative RMS
    error is estimated on them (each point costs one ray per reference surfel)."""
    cand = np.flatnonzero(~(surfels.emission.max(axis=1) > 0))
    if len(cand) <= count:
        return cand
    return np.sort(np.random.default_rng(seed).choice(cand, count, replace=False))


def subset(surfels, idx):
    """The surfels ``idx`` as a Surfels object (for ``reference_at``)."""
    return illumap.Surfels(surfels.positions[idx], surfels.normals[idx], surfels.areas[idx],
                           surfels.albedo[idx], surfels.emission[idx])


def relative_rms(B, B_ref, emission=None):
    """Relative RMS per surfel, over all channels, excluding emitters (whose B ≈ E would hide
    the error): sqrt(mean |B − B_ref|²) / sqrt(mean |B_ref|²)."""
    mask = np.ones(len(B), bool) if emission is None else ~(emission.max(axis=1) > 0)
    d = B[mask] - B_ref[mask]
    return float(math.sqrt(np.mean(d * d)) / math.sqrt(np.mean(B_ref[mask] ** 2)))


def source_hash(name) -> str:
    """A hash of the code that builds scene ``name`` and its reference (cache key)."""
    import hashlib
    import inspect
    name = reference_scene(name)
    funcs = {"cornell": (cornell_box.regular_quads, cornell_box.block_footprints,
                         cornell_box.inside_footprints, shapes.midpoint_grid_mesh,
                         cornell_grid_meshes, cornell, cornell_n_for),
             "bunny": (shapes.read_ply, shapes.bunny_scan, estimate_areas,
                       pointcloud.estimate_normals,
                       pointcloud.orient_normals, sampling.thin_points, bunny),
             "interior": (interior, core_scenes.box_room)}[name]
    text = "".join(inspect.getsource(f) for f in funcs + (reference_solution,))
    if name == "bunny":   # the scan's normals come from the native orientation
        with open(os.path.join(os.path.dirname(__file__), "..", "..", "core", "src",
                               "normals.cpp")) as f:
            text += f.read()
    return hashlib.sha1(text.encode()).hexdigest()

