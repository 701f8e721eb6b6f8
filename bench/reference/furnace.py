#!/usr/bin/env python3
"""White furnace against Cycles: seven geometry classes where every surface is white.

Every material is a white Diffuse BSDF (albedo 1; Illumap clamps it to 0.999, which is
expected), there are no lamps and no emitters, and the world's Background is white (1, 1, 1)
at strength 1. The ideal answer is 1 at every point light can reach (a path to the sky, however
long, carries radiance 1) and 0 at points sealed inside a closed part; a renderer that reads
above 1 creates light.

The reference is a Cycles bake of the same meshes (``bake.bake_incident``: DIFFUSE, direct +
indirect, CPU, no clamping) with two changes from ``bake.py``'s defaults, both measured
(16-sample bakes, relative RMS over a case's vertices):

* ``BOUNCES = 1024`` (Cycles' maximum) for 64: the gap under the bunny's flat base (3,906
  points within 2 cm of the floor) takes hundreds of bounces. At albedo 1, 64 bounces read
  the bunny case 14.5% (relative RMS) under 1024, which read 1.0000; on ``resting`` 2.2% (the
  sphere's contact). At albedo 0.999, 256 bounces read the bunny case's mean 0.46% under 1024.
* The materials' albedo is set to Illumap's clamp (``illumap_albedo()``, 0.999) for the bakes,
  outgoing = 0.999 × incident: what a correct solver of the clamped scene must give. The clamp
  alone moves the bunny case by 2.7% relative RMS (mean 0.9914 against 1.0000), ``resting`` and
  ``monkey`` by 0.5%. ``--albedo 1`` bakes the ideal furnace instead (cached apart).

Where a vertex lies on a contact (a box's foot, the floor round it) Cycles' POINT bake is
the mean of its corners, each evaluated on its own face: 0.5 at a box's bottom edge, 2/3 at
its bottom corners, 0.5 and 0.75 on the floor round it. The reference is the mean of two bakes
with different seeds (``SEEDS``); its own noise, the relative RMS of that mean, is half the
relative RMS difference of the two bakes.

Cases (``CASES``; ``CLASSES`` are the seven, the rest diagnostics run when named):

* ``monkey``: Suzanne (bmesh, subdivided once, smooth, shade_smooth) resting on a floor: an
  open mesh whose eyes are separate parts pushed into the head (``scenes.meshes.monkey``'s
  geometry). Cycles drops the directions a smooth normal's hemisphere has below a face:
  Suzanne's reference mean is 0.83 smooth, 0.93 flat (``monkey_flat``, the diagnostic).
* ``intersecting``: two closed boxes that interpenetrate, standing on a floor (no vertex of
  one lies on a face of the other): each box's vertices inside the other are sealed (0).
* ``resting``: a closed box and a UV sphere resting on a floor: the floor under the box and
  the box's bottom are sealed, the sphere touches the floor at its pole.
* ``plate``: a single open quad grid (1 m, horizontal at 0.5 m) above a floor: both faces of
  the plate, and the floor under it, read 1.
* ``scan``: the Stanford bunny's 35,947 vertices (``scenes.BUNNY_PLY`` placed as
  ``scenes.meshes.scan_object`` does) as a point cloud without normals on a mesh floor; Cycles bakes
  the scan's triangles, with the five holes in its base filled (faces only, no new vertices)
  so that its inside is sealed and each point's brighter side is its outside.
* ``scan_normals``: the same, with a ``normal`` point attribute (the name
  ``addon/read/pointcloud.py`` reads) holding the scan's vertex normals, from its own triangles
  before the fill (a loose vertex, which no triangle uses, takes its nearest used vertex's).
  ``scan_fill_normals`` (diagnostic) takes them after the fill instead.
* ``room_scan``: a 3 × 3 × 2.5 m room open at the top (four walls one mesh, the floor another,
  both facing in) and a box table without a bottom on the floor's grid lines, all given to
  Illumap as ONE point cloud of the meshes' vertices without normals: the walls' and the
  table's feet are twins of floor points. Without normals a point shows its brighter side
  (Illumap's warning says so), so the walls' and the floor's reference is the larger of a bake
  of their front and one of their back (normals flipped): the floor under the table, sealed
  from above, reads 1 from below.

Scoring is over every vertex Cycles bakes (``bake.baked_vertices``), on the RGB mean of each:
relative RMS of Illumap (``pipeline.Settings(transfer=True, transfer_domain="POINT")``) against
the reference, mean ratio, Illumap's largest value, the share of points above 1.005, and the
solve's convergence and warnings ("not positive definite").

    .venv/bin/python bench/reference/furnace.py                    # the seven, 512 samples
    .venv/bin/python bench/reference/furnace.py --cases monkey plate --samples 128
    .venv/bin/python bench/reference/furnace.py --cases monkey_flat scan_fill_normals

The bunny's references are capped at 128 samples (``max_samples``: ~0.7 s a sample). References
are cached in ``bench/results/reference/furnace_<case>.npz`` (both bakes; used when the sample
count, albedo, bounces and vertices match); results go to ``bench/results/furnace.json`` for the
seven classes at the default settings, to ``out/furnace_partial.json`` for any other run
(``--out`` chooses).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import sys
import time
from dataclasses import dataclass, field

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_ROOT = os.path.dirname(os.path.dirname(HERE))
if REPO_ROOT not in sys.path:          # ``import addon``, as tests/blender/conftest.py does
    sys.path.insert(0, REPO_ROOT)

import bpy  # noqa: E402
import bmesh  # noqa: E402

if __package__ in (None, ""):          # run as a script: bench/ on the path
    sys.path.insert(0, os.path.dirname(HERE))
    from reference import bake  # noqa: E402
    from scenes import blender as scenes  # noqa: E402
    from reference import run as reference_run  # noqa: E402
else:
    from . import bake  # noqa: E402
    if __package__.startswith("bench."):
        from bench.scenes import blender as scenes  # noqa: E402
    else:                              # ``reference.…`` with bench/ on the path
        from scenes import blender as scenes  # noqa: E402
    from . import run as reference_run  # noqa: E402

#: Seeds of the two reference bakes (their mean is the reference, their difference its noise).
SEEDS = (7919, 104729)
#: Bounces of every kind in the reference bakes: Cycles' maximum (see the module docstring).
BOUNCES = 1024
#: Points read "above 1" over this (the sky's radiance is 1).
ABOVE = 1.005
DEFAULT_SAMPLES = 512
CACHE_DIR = os.path.join(REPO_ROOT, "bench", "results", "reference")
DEFAULT_OUT = os.path.join(REPO_ROOT, "bench", "results", "furnace.json")
#: Where a run of other cases than the seven classes, or of other settings, goes unless
#: ``--out`` says: the published table's file holds the seven classes of one run only.
PARTIAL_OUT = os.path.join(REPO_ROOT, "out", "furnace_partial.json")


@dataclass
class FurnaceCase:
    """A built furnace case: the scene (scored meshes, scan names) and how to give it to
    Illumap."""

    name: str
    scene: "scenes.ReferenceScene"
    normals: dict[str, np.ndarray] = field(default_factory=dict)  # scan mesh -> (V, 3)
    notes: str = ""
    back_sides: tuple = ()              # scored meshes whose value is the brighter side
    reference: str = ""                 # the cached reference's name ("": the case's own)
    max_samples: int = 0                # a cap on the reference's samples (0: none)


# --- scene -----------------------------------------------------------------------------------

def white_world() -> None:
    """The furnace's sky: Background (1, 1, 1) at strength 1."""
    scenes.sky_world(color=(1.0, 1.0, 1.0), strength=1.0)


def white() -> "bpy.types.Material":
    return scenes.diffuse_material("White", (1.0, 1.0, 1.0))


def floor(half: float, cell: float, material, name: str = "Floor"):
    return scenes.mesh_object(name, scenes.quad_parts(
        [(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)], (0, 0, 1), cell),
        material)


def _start() -> "bpy.types.Material":
    scenes.reset()
    white_world()
    return white()


def _finish(name: str, scored: list, notes: str, scan=(), normals=None,
            back_sides=()) -> FurnaceCase:
    scene = scenes.finish(name, scored, [], [], notes)
    scene.scan = list(scan)
    return FurnaceCase(name, scene, dict(normals or {}), notes, tuple(back_sides))


def monkey() -> FurnaceCase:
    from mathutils import Matrix
    mat = _start()
    ground = floor(2.0, 0.1, mat)
    mesh = bpy.data.meshes.new("Monkey")
    bm = bmesh.new()
    bmesh.ops.create_monkey(bm)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True, smooth=1.0)
    bmesh.ops.rotate(bm, verts=bm.verts, cent=(0, 0, 0),
                     matrix=Matrix.Rotation(math.pi / 2, 3, "X"))
    bmesh.ops.translate(bm, verts=bm.verts, vec=(0, 0, -min(v.co.z for v in bm.verts)))
    bm.to_mesh(mesh)
    bm.free()
    mesh.shade_smooth()
    mesh.materials.append(mat)
    head = bpy.data.objects.new("Monkey", mesh)
    bpy.context.scene.collection.objects.link(head)
    return _finish("monkey", [head, ground],
                   "smooth Suzanne (open, eyes inside the head) on a floor")


def intersecting() -> FurnaceCase:
    mat = _start()
    ground = floor(2.0, 0.1, mat)
    # No vertex of one box lies on a face of the other (their grids are offset).
    a = scenes.mesh_object("BoxA", scenes.box_parts((-0.6, -0.4, 0.0), (0.2, 0.4, 0.8), 0.1), mat)
    b = scenes.mesh_object("BoxB", scenes.box_parts((-0.15, -0.25, 0.0), (0.65, 0.55, 0.65), 0.1),
                           mat)
    return _finish("intersecting", [a, b, ground], "two closed boxes interpenetrating on a floor")


def resting() -> FurnaceCase:
    mat = _start()
    ground = floor(2.0, 0.1, mat)
    box = scenes.mesh_object("Box", scenes.box_parts((-1.0, -0.4, 0.0), (-0.2, 0.4, 0.6), 0.1), mat)
    sphere = scenes.uv_sphere("Sphere", (0.7, 0.0, 0.4), 0.4, mat)
    return _finish("resting", [box, sphere, ground],
                   "a closed box and a UV sphere resting on a floor")


def plate() -> FurnaceCase:
    mat = _start()
    ground = floor(1.5, 0.1, mat)
    sheet = scenes.mesh_object("Plate", scenes.quad_parts(
        [(-0.5, -0.5, 0.5), (0.5, -0.5, 0.5), (0.5, 0.5, 0.5), (-0.5, 0.5, 0.5)], (0, 0, 1), 0.05),
        mat)
    return _finish("plate", [sheet, ground], "a single open 1 m quad grid 0.5 m above a floor")


def _bunny(mat, fill_normals: bool = False):
    """The Stanford bunny as ``scenes.scan_object`` places it, its holes filled (below), and
    the scan's vertex normals (V, 3): those of its own triangles, before the holes are filled
    (``fill_normals``: after, which tilts 211 rim normals by up to 48°)."""
    verts, faces = scenes.bunny_scan()
    verts = verts * scenes.BUNNY_SCALE
    mesh = bpy.data.meshes.new("Bunny")
    mesh.from_pydata(verts, [], faces)
    mesh.validate()
    obj = bpy.data.objects.new("Bunny", mesh)
    bpy.context.scene.collection.objects.link(obj)
    normals = None if fill_normals else vertex_normals(obj)
    # bun_zipper has five holes in its base (223 boundary edges): filled with faces (no new
    # vertices), so that its inside is sealed and every point's lit side is its outside.
    bm = bmesh.new()
    bm.from_mesh(mesh)
    filled = bmesh.ops.holes_fill(bm, edges=bm.edges[:], sides=0)["faces"]
    bmesh.ops.triangulate(bm, faces=filled)
    bm.to_mesh(mesh)
    bm.free()
    mesh.validate()
    mesh.materials.append(mat)
    return obj, (vertex_normals(obj) if fill_normals else normals)


def vertex_normals(obj) -> np.ndarray:
    """The mesh's vertex normals (V, 3), world space (the object has no transform); a loose
    vertex (no face: 1,113 of the bunny's) takes the normal of its nearest vertex that a face
    uses."""
    n = len(obj.data.vertices)
    normals = np.empty(n * 3)
    obj.data.vertices.foreach_get("normal", normals)
    normals = normals.reshape(n, 3)
    used = bake.baked_vertices(obj)
    if not used.all():
        pos = bake.vertex_positions(obj)
        used_ids = np.flatnonzero(used)
        for i in np.flatnonzero(~used):
            d2 = ((pos[used_ids] - pos[i]) ** 2).sum(axis=1)
            normals[i] = normals[used_ids[np.argmin(d2)]]
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)


def scan(with_normals: bool = False, fill_normals: bool = False) -> FurnaceCase:
    mat = _start()
    bunny, bunny_normals = _bunny(mat, fill_normals)
    ground = floor(1.5, 0.1, mat)
    name = "scan_normals" if with_normals else "scan"
    normals = {"Bunny": bunny_normals} if with_normals else {}
    case = _finish(name, [bunny, ground],
                   f"Stanford bunny ({len(bunny.data.vertices)} vertices) x {scenes.BUNNY_SCALE:g} "
                   f"as a point cloud {'with' if with_normals else 'without'} normals on a mesh "
                   "floor", scan=["Bunny"], normals=normals)
    # One reference for both (the same meshes); 1024 bounces cost ~0.7 s a sample here.
    case.reference, case.max_samples = "scan", 128
    return case


def scan_fill_normals() -> FurnaceCase:
    """``scan_normals`` with the normals of the hole-filled mesh (a diagnostic): 211 points
    round the filled holes have normals tilted by 1-48° from the scan's own."""
    case = scan(True, fill_normals=True)
    case.name, case.notes = "scan_fill_normals", case.notes + ", normals after the holes' fill"
    return case


def room_scan() -> FurnaceCase:
    mat = _start()
    size = (3.0, 3.0, 2.5)
    walls = scenes.mesh_object("Walls", scenes.box_parts((0, 0, 0), size, 0.1, inward=True,
                                                         skip=("-z", "+z")), mat)
    ground = scenes.mesh_object("RoomFloor", scenes.quad_parts(
        [(0, 0, 0), (size[0], 0, 0), (size[0], size[1], 0), (0, size[1], 0)], (0, 0, 1), 0.1), mat)
    # A box table without a bottom (a scanner sees none) standing on the floor's grid lines:
    # the foot of each side is a row of twins of floor points, as the walls' feet are.
    table = scenes.mesh_object("Table", scenes.box_parts((1.0, 1.0, 0.0), (2.0, 1.5, 0.7), 0.1,
                                                         skip=("-z",)), mat)
    # Without normals each point shows its brighter side (Illumap's warning says so): the
    # walls' outside and the floor's underside see the sky, so the floor under the table (its
    # top sealed by the table) reads 1 from below; the table's inside is sealed (0).
    return _finish("room_scan", [walls, ground, table],
                   "a 3 x 3 x 2.5 m room open at the top and a box table, one point cloud of "
                   "their vertices without normals (twin points at the edges and under the table)",
                   scan=["Walls", "RoomFloor", "Table"], back_sides=["Walls", "RoomFloor"])


def monkey_flat() -> FurnaceCase:
    """``monkey`` flat-shaded (a diagnostic, not one of the seven classes): Cycles drops the
    directions a smooth (shading) normal's hemisphere has below a face, which costs the
    smooth Suzanne ~10% of its light in the furnace (mean 0.83 smooth, 0.93 flat)."""
    case = monkey()
    case.scene.scored[0].data.shade_flat()
    case.name, case.notes = "monkey_flat", "flat-shaded Suzanne on a floor (diagnostic)"
    return case


CASES = {"monkey": monkey, "intersecting": intersecting, "resting": resting, "plate": plate,
         "scan": lambda: scan(False), "scan_normals": lambda: scan(True), "room_scan": room_scan,
         "monkey_flat": monkey_flat, "scan_fill_normals": scan_fill_normals}
#: The seven classes (the other cases are diagnostics, run when named).
CLASSES = ("monkey", "intersecting", "resting", "plate", "scan", "scan_normals", "room_scan")


def build(name: str) -> FurnaceCase:
    """Build case ``name`` (one of CASES) in a fresh, empty file."""
    return CASES[name]()


# --- Illumap ---------------------------------------------------------------------------------

def illumap_objects(case: FurnaceCase) -> tuple[list, dict]:
    """What Illumap is given (``run.scan_objects``, plus the ``normal`` attribute of a case
    with normals) and the scan's spans."""
    objects, spans = reference_run.scan_objects(case.scene)
    if case.normals:
        meshes = [o for o in case.scene.scored if o.name in case.scene.scan]
        normals = np.concatenate([case.normals[o.name] for o in meshes])
        data = bpy.data.objects["Scan"].data
        data.attributes.new("normal", "FLOAT_VECTOR", "POINT").data.foreach_set(
            "vector", normals.astype(np.float32).ravel())
    return objects, spans


def run_illumap(case: FurnaceCase, settings=None) -> tuple[dict[str, np.ndarray], object, float]:
    """Illumap's per-vertex outgoing radiance {scored mesh: (V, 3)}, the Result and the
    seconds of ``pipeline.compute``. The add-on must be registered."""
    from addon import pipeline
    objects, spans = illumap_objects(case)
    if settings is None:
        settings = pipeline.Settings(transfer=True, transfer_domain="POINT")
    start = time.perf_counter()
    result = pipeline.compute(bpy.context, objects, settings)
    seconds = time.perf_counter() - start
    values = {o.name: reference_run.read_illumination(o)
              for o in case.scene.scored if o.name not in spans}
    values.update(reference_run.read_scan(spans) if spans else {})
    return values, result, seconds


# --- reference -------------------------------------------------------------------------------

def illumap_albedo() -> float:
    """The albedo Illumap gives a white (1) material: its clamp, ``materials.MAX_ALBEDO``."""
    from addon.read.materials import MAX_ALBEDO
    return float(MAX_ALBEDO)


def _set_albedo(value: float) -> None:
    for mat in bpy.data.materials:
        if mat.node_tree is None:
            continue
        for node in mat.node_tree.nodes:
            if node.type == "BSDF_DIFFUSE":
                node.inputs["Color"].default_value = (value, value, value, 1.0)


def _bake(case: FurnaceCase, objects: list, samples: int, seed: int, albedo: float):
    """Outgoing radiance (albedo × incident) of ``objects`` from one bake at ``albedo``."""
    saved = bake.BOUNCES
    bake.BOUNCES = BOUNCES
    _set_albedo(albedo)
    try:
        incident, seconds = bake.bake_incident(objects, samples, seed)
    finally:
        bake.BOUNCES = saved
        _set_albedo(1.0)
    return {name: albedo * value for name, value in incident.items()}, seconds


def bake_reference(case: FurnaceCase, samples: int, seeds=SEEDS,
                   albedo: float | None = None) -> dict:
    """Cycles' outgoing radiance at every vertex of the case's scored meshes, one bake per seed:
    {"bakes": [{name: (V, 3)}, …], "seconds": [s, …]}. The materials' albedo is set to
    ``albedo`` for the bakes (default: Illumap's clamp, ``illumap_albedo()``) and back to 1
    after. For the meshes of ``case.back_sides`` (scans without normals: each point shows its
    brighter side) the value is the larger of the front's and the back's (the normals flipped
    for a second bake). Illumap's objects must not exist yet (or be hidden from render)."""
    albedo = illumap_albedo() if albedo is None else float(albedo)
    backs = [o for o in case.scene.scored if o.name in case.back_sides]
    bakes, seconds = [], []
    for seed in seeds:
        out, s = _bake(case, case.scene.scored, samples, seed, albedo)
        if backs:
            for obj in backs:
                obj.data.flip_normals()
            try:
                back, s_back = _bake(case, backs, samples, seed, albedo)
            finally:
                for obj in backs:
                    obj.data.flip_normals()
            s += s_back
            for name, value in back.items():
                out[name] = np.maximum(out[name], value)
        bakes.append(out)
        seconds.append(s)
    return dict(bakes=bakes, seconds=seconds, samples=samples, albedo=albedo)


def _cache_path(case: FurnaceCase, albedo: float) -> str:
    tail = "" if abs(albedo - illumap_albedo()) < 1e-12 else f"_albedo{albedo:g}"
    return os.path.join(CACHE_DIR, f"furnace_{case.reference or case.name}{tail}.npz")


def load_reference(case: FurnaceCase, samples: int, albedo: float) -> dict | None:
    """The cached reference of ``case`` if it was baked at ``samples`` samples, ``albedo`` and
    ``BOUNCES`` on these vertices, else None."""
    path = _cache_path(case, albedo)
    if not os.path.exists(path):
        return None
    data = np.load(path, allow_pickle=False)
    names = [o.name for o in case.scene.scored]
    counts = [len(o.data.vertices) for o in case.scene.scored]
    if list(data["names"]) != names or list(data["counts"]) != counts:
        print(f"  cached reference {path} is for other meshes: re-baking")
        return None
    positions = np.concatenate([bake.vertex_positions(o) for o in case.scene.scored])
    if np.abs(data["positions"] - positions).max() > 1e-4:
        print(f"  cached reference {path} has other vertex positions: re-baking")
        return None
    if (int(data["samples"]) != samples or abs(float(data["albedo"]) - albedo) > 1e-9
            or int(data["bounces"]) != BOUNCES
            or list(data["back_sides"]) != list(case.back_sides)):
        print(f"  cached reference {path} has {int(data['samples'])} samples, albedo "
              f"{float(data['albedo']):g}, {int(data['bounces'])} bounces: re-baking")
        return None
    split = np.cumsum(counts)[:-1]
    bakes = [dict(zip(names, np.split(b.astype(np.float64), split))) for b in data["bakes"]]
    return dict(bakes=bakes, seconds=[float(s) for s in data["seconds"]], samples=samples,
                albedo=albedo, cached=True)


def save_reference(case: FurnaceCase, ref: dict) -> None:
    names = [o.name for o in case.scene.scored]
    os.makedirs(CACHE_DIR, exist_ok=True)
    np.savez_compressed(
        _cache_path(case, ref["albedo"]), names=np.array(names),
        counts=np.array([len(o.data.vertices) for o in case.scene.scored]),
        positions=np.concatenate([bake.vertex_positions(o)
                                  for o in case.scene.scored]).astype(np.float32),
        bakes=np.stack([np.concatenate([b[n] for n in names])
                        for b in ref["bakes"]]).astype(np.float32),
        seconds=np.array(ref["seconds"]), samples=ref["samples"], seeds=np.array(SEEDS),
        albedo=ref["albedo"], bounces=BOUNCES,
        back_sides=np.array(list(case.back_sides), dtype=str),
        blender=bpy.app.version_string,
        date=datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"))


# --- scores ----------------------------------------------------------------------------------

def _stack(case: FurnaceCase, per_name: dict) -> tuple[np.ndarray, np.ndarray]:
    """RGB means of the scored (baked) vertices, stacked in the scored order, and the object
    index of each."""
    rows, owner = [], []
    for k, obj in enumerate(case.scene.scored):
        keep = bake.baked_vertices(obj)
        rows.append(np.asarray(per_name[obj.name], dtype=np.float64)[keep].mean(axis=1))
        owner.append(np.full(int(keep.sum()), k))
    return np.concatenate(rows), np.concatenate(owner)


def relative_rms(x: np.ndarray, r: np.ndarray) -> float:
    return float(np.sqrt(np.sum((x - r) ** 2) / np.sum(r ** 2)))


def reference_values(case: FurnaceCase, ref: dict) -> tuple[np.ndarray, float]:
    """The reference (the mean of the bakes) at the scored vertices, and its own noise: the
    relative RMS of the mean, half the relative RMS difference of two bakes."""
    bakes = [_stack(case, b)[0] for b in ref["bakes"]]
    mean = np.mean(bakes, axis=0)
    noise = relative_rms(bakes[0], bakes[1]) / 2.0 if len(bakes) == 2 else float("nan")
    return mean, noise


def score(case: FurnaceCase, values: dict, ref_values: np.ndarray, result=None) -> dict:
    """The scores of Illumap's ``values`` against the reference (module docstring)."""
    got, owner = _stack(case, values)
    row = dict(relative_rms=relative_rms(got, ref_values),
               mean_ratio=float(got.mean() / ref_values.mean()),
               max=float(got.max()), above=float(np.mean(got > ABOVE)),
               points=int(len(got)), reference_max=float(ref_values.max()),
               reference_dark=float(np.mean(ref_values < 0.5)))
    row["objects"] = {}
    for k, obj in enumerate(case.scene.scored):
        m = owner == k
        worst = int(np.argmax(np.abs(got[m] - ref_values[m])))
        pos = bake.vertex_positions(obj)[bake.baked_vertices(obj)]
        row["objects"][obj.name] = dict(
            relative_rms=relative_rms(got[m], ref_values[m]),
            mean=float(got[m].mean()), mean_reference=float(ref_values[m].mean()),
            max=float(got[m].max()), above=float(np.mean(got[m] > ABOVE)),
            worst=float(got[m][worst]), worst_reference=float(ref_values[m][worst]),
            worst_at=[round(float(c), 4) for c in pos[worst]])
    if result is not None:
        row.update(converged=bool(result.converged), iterations=int(result.iterations),
                   surfels=int(result.count), warnings=list(result.warnings),
                   not_positive_definite=any("positive definite" in w for w in result.warnings))
    return row


# --- runs ------------------------------------------------------------------------------------

def run_case(name: str, samples: int, use_cache: bool = True, albedo: float | None = None) -> dict:
    case = build(name)
    albedo = illumap_albedo() if albedo is None else albedo
    if case.max_samples:
        samples = min(samples, case.max_samples)
    print(f"{name}: {case.scene.vertex_count()} vertices in {len(case.scene.scored)} meshes "
          f"({case.notes})", flush=True)
    ref = load_reference(case, samples, albedo) if use_cache else None
    if ref is None:
        print(f"  baking the reference: 2 x {samples} samples, albedo {albedo:g}, {BOUNCES} "
              "bounces …", flush=True)
        ref = bake_reference(case, samples, albedo=albedo)
        ref["cached"] = False
        if use_cache:
            save_reference(case, ref)
    ref_values, noise = reference_values(case, ref)
    print(f"  reference: {samples} samples x 2 seeds, bakes {sum(ref['seconds']):.1f} s "
          f"({'cached' if ref['cached'] else 'new'}), noise (rel. RMS of the mean) {noise:.5f}",
          flush=True)
    case = build(name)                  # a fresh file for Illumap
    values, result, seconds = run_illumap(case)
    row = score(case, values, ref_values, result)
    row.update(case=name, seconds=round(seconds, 3),
               cycles_seconds=[round(s, 3) for s in ref["seconds"]],
               samples=samples, reference_albedo=albedo, bounces=BOUNCES, noise=noise,
               notes=case.notes)
    print(f"  Illumap {seconds:.2f} s, {row['surfels']} surfels: "
          f"rel. RMS {row['relative_rms']:.4f}, "
          f"mean ratio {row['mean_ratio']:.4f}, max {row['max']:.4f}, above {ABOVE}: "
          f"{row['above']:.2%}, converged {row['converged']}", flush=True)
    for w in row["warnings"]:
        print(f"    warning: {w}")
    return row


def print_table(rows: list[dict], detail: bool = True) -> None:
    print(f"\n{'case':13s} {'points':>7s} {'rel.RMS':>8s} {'noise':>8s} {'ratio':>7s} {'max':>7s} "
          f"{'>1.005':>7s} {'conv':>5s} {'NPD':>4s} {'illumap s':>9s} {'cycles s':>9s}")
    for r in rows:
        print(f"{r['case']:13s} {r['points']:7d} {r['relative_rms']:8.4f} {r['noise']:8.5f} "
              f"{r['mean_ratio']:7.4f} {r['max']:7.4f} {r['above']:7.2%} {str(r['converged']):>5s} "
              f"{'yes' if r['not_positive_definite'] else 'no':>4s} {r['seconds']:9.2f} "
              f"{sum(r['cycles_seconds']):9.2f}")
        if detail:
            for obj, o in r["objects"].items():
                print(f"{'':4s}{obj:12s} rel.RMS {o['relative_rms']:.4f} mean {o['mean']:.4f} "
                      f"(ref {o['mean_reference']:.4f}) max {o['max']:.4f} >1.005 {o['above']:.2%} "
                      f"worst {o['worst']:.3f} vs {o['worst_reference']:.3f} at {o['worst_at']}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CLASSES))
    ap.add_argument("--samples", type=int, default=DEFAULT_SAMPLES,
                    help="Cycles samples of each of the two reference bakes "
                         f"(default {DEFAULT_SAMPLES})")
    ap.add_argument("--albedo", type=float, default=None,
                    help="the albedo of the reference bakes (default: Illumap's clamp, 0.999; "
                         "1 gives the ideal furnace, cached apart)")
    ap.add_argument("--no-cache", action="store_true", help="bake afresh and write no cache")
    ap.add_argument("--out", default=None,
                    help="the results file (default: bench/results/furnace.json for the seven "
                         "classes at the default settings, else out/furnace_partial.json)")
    ap.add_argument("--conserve", choices=("on", "off"), default=None,
                    help="set illumap.stages.light.CONSERVE_LIGHT for this run (default: as shipped)")
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)
    if args.out is None:
        whole = (sorted(args.cases) == sorted(CLASSES) and args.samples == DEFAULT_SAMPLES
                 and args.albedo is None and args.conserve is None and not args.no_cache)
        args.out = DEFAULT_OUT if whole else PARTIAL_OUT
    reference_run.register_addon()
    from illumap.stages import light as light_stage
    if args.conserve is not None:
        light_stage.CONSERVE_LIGHT = args.conserve == "on"
    start = time.perf_counter()
    rows = [run_case(name, args.samples, not args.no_cache, args.albedo) for name in args.cases]
    import illumap
    results = dict(commit=reference_run._commit(), blender=bpy.app.version_string,
                   illumap_core=getattr(illumap, "__file__", ""), samples=args.samples,
                   seeds=list(SEEDS), bounces=BOUNCES,
                   conserve_light=light_stage.CONSERVE_LIGHT,
                   machine=dict(platform=platform.platform(), cpus=os.cpu_count()),
                   date=datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                   rows=rows, wall_seconds=time.perf_counter() - start)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(results, f, indent=1)
    print_table(rows)
    print(f"illumap.stages.light.CONSERVE_LIGHT = {results['conserve_light']}")
    print(f"wrote {args.out} ({results['wall_seconds']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
