#!/usr/bin/env python3
"""Where a scan scene's error lies (a diagnostic): Illumap at default on a bench scene
(``scan_room``, ``scan_object``, or a mesh twin such as ``cornell``), scored against the cached
Cycles reference per object and per region; for a scan also its solved surfel values at the
points (before the gather; the side that faces along the scanned mesh's own vertex normals),
the inner sides' solved and direct light, and the estimated surfel areas against the meshes'.

Regions of the scored vertices: ``twin``: another scored object has a vertex at the same
position (where two scanned surfaces meet); ``contact``: one within half a grid ``--cell``;
``edge``: within one cell of the mesh's boundary; ``buried``: Cycles reads under 1e-3 there
(floor under a block); ``interior``: the rest. Each region's part is
sqrt(Σ_region |x − r|² / Σ_all |r|²) (the parts' squares add up to the relative RMS squared),
with its bias Σ_region (x − r) / sqrt(Σ_all r² · n_region) and its count.

    .venv/bin/python bench/experiments/scan_error_split.py scan_room cornell
    .venv/bin/python bench/experiments/scan_error_split.py --worst Floor,ShortBlock --region twin scan_room
    .venv/bin/python bench/experiments/scan_error_split.py --dump /tmp/split scan_object

With a scan and its mesh twin in one run (``scan_room cornell``), each object's solve is also
compared at the scan's points: the scan's solved surfels (the side along the mesh's vertex
normals) against the mesh's solve there (its front surfels of that object, the 8 nearest whose
normals agree with the nearest one's, inverse-distance weighted), as mean luminance and as
relative RMS of each against Cycles, beside both finals: where the scan's solve is off but
its final is not, the final gather is not the cause, and the other way round.

``--dark-inside A,B`` (an experiment): before the gather, the solved radiance of the inner
side (against the mesh's vertex normals) of scanned objects A, B is set to 0, the solve left
as it is: what a solve that kept the inside of closed scanned parts dark would buy through
the gather (``--dark-inside ShortBlock,TallBlock scan_room``).

``--leak A,B`` (scans): how much of the transport rows of the inner sides of scanned objects
A, B (against the mesh's vertex normals; face points apart from edge points, whose fitted
normal is off the vertex normal by more than ~18°) reaches surfels outside them (every surfel
but those inner sides and both sides of the points Cycles reads 0 at): a closed part's is 0;
rays against the same splats find a few tenths of a percent. ``--leaf-mode MODE`` builds the
solve's operator with that ``visibility_leaf_mode`` (``per_pair_all``: far leaf pairs per
pair too).

``--dump PREFIX`` saves PREFIX_<scene>.npz (values, reference, regions, positions, kept rows,
objects' names and counts) for offline study; ``--creases FILE`` saves the points and outward
normals the run gives ``illumap.scan_values.crease_surfaces``.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))

from reference import bake, run, score  # noqa: E402

REGIONS = ("interior", "edge", "contact", "twin", "buried")


def _boundary_vertices(mesh) -> np.ndarray:
    """Vertices (indices) on the mesh's boundary: on an edge that one face uses."""
    loops = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", loops)
    starts = np.empty(len(mesh.polygons), dtype=np.int64)
    mesh.polygons.foreach_get("loop_start", starts)
    totals = np.empty(len(mesh.polygons), dtype=np.int64)
    mesh.polygons.foreach_get("loop_total", totals)
    nxt = np.arange(len(loops)) + 1
    ends = starts + totals
    nxt[ends - 1] = starts                                   # each face's ring closes
    pairs = np.sort(np.stack([loops, loops[nxt]], axis=1), axis=1)
    unique, counts = np.unique(pairs, axis=0, return_counts=True)
    return np.unique(unique[counts == 1])


def regions_of(scene, reference: dict, cell: float) -> dict[str, np.ndarray]:
    """{object: (V,) region label} (the module docstring)."""
    from scipy.spatial import cKDTree
    objs = scene.scored
    pos = {o.name: bake.vertex_positions(o) for o in objs}
    out = {}
    for o in objs:
        others = np.concatenate([pos[q.name] for q in objs if q is not o])
        d, _ = cKDTree(others).query(pos[o.name])
        boundary = _boundary_vertices(o.data)
        bd = np.full(len(pos[o.name]), np.inf)
        if len(boundary):
            bd, _ = cKDTree(pos[o.name][boundary]).query(pos[o.name])
        label = np.full(len(d), "interior", dtype=object)
        label[bd <= 1.01 * cell] = "edge"
        label[d <= 0.5 * cell] = "contact"
        label[d <= 1e-4] = "twin"
        label[reference[o.name].mean(axis=1) < 1e-3] = "buried"
        out[o.name] = label
    return out


def _split(values: dict, reference: dict, keep: dict, regions: dict, total: float) -> str:
    rows = []
    for region in REGIONS:
        v = np.concatenate([values[n][keep[n]][regions[n][keep[n]] == region] for n in values])
        r = np.concatenate([reference[n][keep[n]][regions[n][keep[n]] == region] for n in values])
        if len(r):
            part = float(np.sqrt(np.sum((v - r) ** 2) / total))
            bias = float(np.sum(v - r) / np.sqrt(total * r.size))
            rows.append(f"{region} {part:.4f} ({bias:+.4f}, {len(r)})")
    return ", ".join(rows)


def report(label: str, scene, values: dict, reference: dict, regions: dict) -> None:
    """Print the relative RMS of ``values`` against ``reference``, whole and per object,
    split by region."""
    keep = {o.name: bake.baked_vertices(o) for o in scene.scored}
    names = [o.name for o in scene.scored]
    v = np.concatenate([values[n][keep[n]] for n in names])
    r = np.concatenate([reference[n][keep[n]] for n in names])
    print(f"  {label}: all {score.relative_rms(v, r):.4f} (bias {np.sum(v - r) / np.sum(r):+.4f});"
          f" {_split(values, reference, keep, regions, float(np.sum(r ** 2)))}")
    for n in names:
        own = float(np.sum(reference[n][keep[n]] ** 2))
        print(f"    {n:10s} {score.relative_rms(values[n][keep[n]], reference[n][keep[n]]):.4f}"
              f"  {_split({n: values[n]}, {n: reference[n]}, keep, regions, own)}")


#: Bands of distance (m) to the nearest vertex of another scored object, for ``bands``.
BANDS = (0.0, 1e-4, 0.05, 0.1, 0.2, 0.4, np.inf)


def bands(scene, values: dict, reference: dict, lit: dict | None = None) -> None:
    """Print the squared error's share (× 10⁻⁴ of Σ r², the relative RMS squared) by distance
    to another object (``BANDS``: twins, contact, ..., far from any junction), and with
    ``lit`` ({object: (V,) bool}) by lamp-lit points (direct light on either side) against
    the rest: where the error lies."""
    from scipy.spatial import cKDTree
    objs = scene.scored
    pos = {o.name: bake.vertex_positions(o) for o in objs}
    keep = {o.name: bake.baked_vertices(o) for o in objs}
    total = sum(float(np.sum(reference[o.name][keep[o.name]] ** 2)) for o in objs)
    err, dist, lamp = [], [], []
    for o in objs:
        n, k = o.name, keep[o.name]
        others = np.concatenate([pos[q.name] for q in objs if q is not o])
        dist.append(cKDTree(others).query(pos[n])[0][k])
        err.append(np.sum((values[n][k] - reference[n][k]) ** 2, axis=1) / total * 1e4)
        lamp.append(lit[n][k] if lit is not None else np.zeros(int(k.sum()), dtype=bool))
    err, dist, lamp = np.concatenate(err), np.concatenate(dist), np.concatenate(lamp)
    rows = []
    for lo, hi in zip(BANDS[:-1], BANDS[1:]):
        m = (dist >= lo) & (dist < hi)
        rows.append(f"[{lo:g}, {hi:g}) m {err[m].sum():.2f} ({int(m.sum())})")
    print(f"  squared error × 1e4 ({err.sum():.2f}) by distance to another object: " + ", ".join(rows))
    if lit is not None:
        print(f"    lamp-lit points {err[lamp].sum():.2f} ({int(lamp.sum())}), the rest "
              f"{err[~lamp].sum():.2f} ({int((~lamp).sum())})")


def worst(values, reference, positions, count: int = 12) -> list:
    """(position, value, reference) of the ``count`` largest errors (mean of the channels)."""
    v, r = values.mean(axis=1), reference.mean(axis=1)
    order = np.argsort(-np.abs(v - r))[:count]
    return [(tuple(round(float(x), 3) for x in positions[i]), round(float(v[i]), 4),
             round(float(r[i]), 4)) for i in order]


def _vertex_normals(obj) -> np.ndarray:
    n = len(obj.data.vertices)
    out = np.empty(n * 3)
    obj.data.vertices.foreach_get("normal", out)
    m = np.array(obj.matrix_world, dtype=np.float64)[:3, :3]
    out = out.reshape(n, 3) @ np.linalg.inv(m)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def _solved(bpy, scene, result, spans, values, reference, regions, args) -> dict | None:
    """The scan's solved surfels against the reference (the module docstring); returns
    {object: its points' solved outer side (V, 3)}, None where the scan was thinned."""
    job = result.job
    src = next(s for s in job.sources if s.kind == "POINTS")
    back = next((s for s in job.sources if s.kind == "BACK" and s.name == src.name), None)
    if src.stop - src.start != sum(c for _, c in spans.values()):
        print(f"  (scan thinned: {src.stop - src.start} surfels for the points)")
        return None
    solved = result.radiosity[src.start:src.stop]
    if back is not None:
        true_n = np.concatenate([_vertex_normals(bpy.data.objects[n]) for n in spans])
        along = (np.einsum("pc,pc->p", job.normals[src.start:src.stop], true_n) > 0)[:, None]
        other = result.radiosity[back.start:back.stop]
        solved, inner = np.where(along, solved, other), np.where(along, other, solved)
        direct = None
        if job.direct is not None:
            ahead, behind = job.direct[src.start:src.stop], job.direct[back.start:back.stop]
            direct = (np.where(along, behind, ahead), np.where(along, ahead, behind))
        for n, (s, c) in spans.items():
            lit = "" if direct is None else (
                f" (direct {direct[0][s:s + c].mean():.5f}, "
                f"{int((direct[0][s:s + c].max(axis=1) > 0).sum())} lit)")
            out = "" if direct is None else f" (direct {direct[1][s:s + c].mean():.5f})"
            print(f"    {n:10s} solved inner side {inner[s:s + c].mean():.4f}{lit}, outer "
                  f"{solved[s:s + c].mean():.4f}{out}, Cycles {reference[n].mean():.4f}")
    surf = {n: solved[s:s + c] for n, (s, c) in spans.items()}
    surf.update({o.name: values[o.name] for o in scene.scored if o.name not in spans})
    report("solved surfels at the points", scene, surf, reference, regions)
    for n in filter(None, args.worst.split(",")):
        rows = regions[n] == args.region
        where = bake.vertex_positions(bpy.data.objects[n])[rows]
        print(f"    worst solved {n} ({args.region}):", worst(surf[n][rows], reference[n][rows], where))
        print(f"    worst final {n} ({args.region}):", worst(values[n][rows], reference[n][rows], where))
    areas = job.areas[src.start:src.stop]
    for n, (s, c) in spans.items():
        obj = bpy.data.objects[n]
        scale = abs(np.linalg.det(np.array(obj.matrix_world)[:3, :3])) ** (2 / 3)
        true = sum(p.area for p in obj.data.polygons) * scale
        print(f"    area {n:10s} estimated / true {areas[s:s + c].sum() / true:.4f}")
    return {n: solved[s:s + c] for n, (s, c) in spans.items()}


LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def mesh_solve_at(result, name: str, points: np.ndarray, k: int = 8) -> np.ndarray:
    """The mesh run's solved radiance (V, 3) of object ``name`` at ``points`` (V, 3) m: its
    front surfels, the ``k`` nearest whose normals agree (cos > 0.9) with the nearest one's,
    inverse-distance weighted."""
    from scipy.spatial import cKDTree
    job = result.job
    rows = np.concatenate([np.arange(s.start, s.stop) for s in job.sources
                           if s.name == name and s.kind == "MESH"])
    d, j = cKDTree(job.positions[rows]).query(points, k=k)
    normals = job.normals[rows[j]]
    w = (np.einsum("pkc,pc->pk", normals, normals[:, 0]) > 0.9) / np.maximum(d, 1e-4)
    return np.einsum("pk,pkc->pc", w, result.radiosity[rows[j]]) / w.sum(axis=1)[:, None]


def against_mesh(bpy, scan_run: dict, mesh_run: dict) -> None:
    """Each scanned object's solve and final at its points, scan against mesh twin (the
    module docstring)."""
    print(f"  solve at the points, {scan_run['name']} against {mesh_run['name']} "
          "(mean luminance; relative RMS against Cycles):")
    for n, solved in scan_run["solved"].items():
        keep = scan_run["keep"][n]
        r = scan_run["reference"][n][keep]
        mesh = mesh_solve_at(mesh_run["result"], n,
                             bake.vertex_positions(bpy.data.objects[n]))[keep]
        rows = [("Cycles", r), ("scan solve", solved[keep]), ("mesh solve", mesh),
                ("scan final", scan_run["values"][n][keep]),
                ("mesh final", mesh_run["values"][n][keep])]
        print(f"    {n:10s} " + ", ".join(
            f"{label} {float(np.mean(v @ LUMINANCE)):.4f}"
            + ("" if label == "Cycles" else f" ({score.relative_rms(v, r):.4f})")
            for label, v in rows))


def one(pipeline, name: str, args) -> dict:
    """Run scene ``name`` at default and print its split; returns what ``against_mesh``
    compares."""
    import bpy
    scene = run.scenes.build(name)
    reference = run.load_reference(scene, 1)["outgoing"]
    regions = regions_of(scene, reference, args.cell)
    objects, spans = run.scan_objects(scene)
    if args.dark_inside and spans:
        _dark_inside(bpy, args.dark_inside.split(","), spans)
    built = _capture_operators() if args.leak and spans else None
    result = pipeline.compute(bpy.context, objects, run.make_settings(pipeline, {}))
    values = {o.name: run.read_illumination(o) for o in scene.scored if o.name not in spans}
    values.update(run.read_scan(spans) if spans else {})
    print(f"{name}: {len(result.radiosity)} surfels")
    if args.dump:
        names = [o.name for o in scene.scored]
        np.savez(f"{args.dump}_{name}.npz", names=names, counts=[len(values[n]) for n in names],
                 values=np.concatenate([values[n] for n in names]),
                 reference=np.concatenate([reference[n] for n in names]),
                 regions=np.concatenate([regions[n] for n in names]).astype(str),
                 positions=np.concatenate([bake.vertex_positions(o) for o in scene.scored]),
                 keep=np.concatenate([bake.baked_vertices(o) for o in scene.scored]))
    report("final", scene, values, reference, regions)
    lit = None
    if spans and result.job.direct is not None:
        job = result.job
        src = next(s for s in job.sources if s.kind == "POINTS")
        back = next((s for s in job.sources if s.kind == "BACK" and s.name == src.name), None)
        either = job.direct[src.start:src.stop].max(axis=1) > 0
        if back is not None and back.stop - back.start == len(either):
            either |= job.direct[back.start:back.stop].max(axis=1) > 0
        if len(either) == sum(c for _, c in spans.values()):
            lit = {n: either[s:s + c] for n, (s, c) in spans.items()}
    bands(scene, values, reference, lit)
    solved = None
    if spans:
        solved = _solved(bpy, scene, result, spans, values, reference, regions, args)
    if built:
        leak(bpy, result, built[-1], spans, reference, args.leak.split(","))
    return dict(name=name, twin=scene.reference, result=result, values=values,
                reference=reference, solved=solved,
                keep={o.name: bake.baked_vertices(o) for o in scene.scored})


def _dark_inside(bpy, names: list[str], spans: dict) -> None:
    """Patch the gather so that the inner sides of the scanned objects ``names`` send
    nothing (``--dark-inside``)."""
    import importlib
    receive = importlib.import_module("illumap.gather.receive")
    inner = receive._receive_once

    def wrapped(scene, direct, direct_lamps, radiosity, *args, **kwargs):
        src = next(s for s in scene.sources if s.kind == "POINTS")
        back = next(s for s in scene.sources if s.kind == "BACK" and s.name == src.name)
        radiosity = radiosity.copy()
        for n in names:
            start, count = spans[n]
            along = np.einsum("pc,pc->p", scene.normals[src.start + start:src.start + start + count],
                              _vertex_normals(bpy.data.objects[n])) > 0
            rows = np.arange(start, start + count)
            radiosity[np.where(along, back.start + rows, src.start + rows)] = 0.0
        return inner(scene, direct, direct_lamps, radiosity, *args, **kwargs)
    receive._receive_once = wrapped


def _capture_operators() -> list:
    """Keep every TransportOperator built from now on (for ``--leak``)."""
    import importlib
    operator = importlib.import_module("illumap.operator")
    built = []
    init = operator.TransportOperator.__init__

    def wrapped(self, *args, **kwargs):
        init(self, *args, **kwargs)
        built.append(self)
    operator.TransportOperator.__init__ = wrapped
    return built


def leak(bpy, result, op, spans, reference, names: list[str]) -> None:
    """Print the share of the inner sides' rows that reaches outside (``--leak``)."""
    job = result.job
    src = next(s for s in job.sources if s.kind == "POINTS")
    back = next(s for s in job.sources if s.kind == "BACK" and s.name == src.name)
    inside, parts = [], []
    for n in names:
        start, count = spans[n]
        normals = job.normals[src.start + start:src.start + start + count]
        true = _vertex_normals(bpy.data.objects[n])
        rows = np.arange(start, start + count)
        along = np.einsum("pc,pc->p", normals, true) > 0
        inner = np.where(along, back.start + rows, src.start + rows)
        edge = np.abs(np.einsum("pc,pc->p", normals, true)) < 0.95
        inside.append(inner)
        parts.append((n, inner, edge))
    for n, (start, count) in spans.items():
        dark = start + np.flatnonzero(reference[n].mean(axis=1) < 1e-3)
        inside += [src.start + dark, back.start + dark]
    x = np.ones((op.n, 3))
    x[np.concatenate(inside)] = 0.0
    out = op.apply(x)[:, 0]
    rows = op.apply(np.ones((op.n, 3)))[:, 0]
    for n, inner, edge in parts:
        for label, pick in (("faces", ~edge), ("edges", edge)):
            r = inner[pick]
            if len(r):
                print(f"    leak {n:10s} inner {label} ({len(r)}): {out[r].mean():.4f} of rows "
                      f"{rows[r].mean():.3f} reach outside (max {out[r].max():.3f})")


def _save_creases(path: str) -> None:
    """Save the points and outward normals the run gives ``crease_surfaces``."""
    import illumap.scan_values as sv
    inner = sv.crease_surfaces

    def wrapped(points, normals, **kwargs):
        np.savez(path, points=points, normals=normals)
        return inner(points, normals, **kwargs)
    sv.crease_surfaces = wrapped


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="+")
    parser.add_argument("--cell", type=float, default=0.1, help="the scene's grid cell, m")
    parser.add_argument("--worst", default="", help="objects whose worst points to list")
    parser.add_argument("--region", default="interior", choices=REGIONS)
    parser.add_argument("--dump", default="", help="save PREFIX_<scene>.npz")
    parser.add_argument("--creases", default="", help="save crease_surfaces' input here")
    parser.add_argument("--leak", default="",
                        help="scanned objects whose inner sides' rows to measure")
    parser.add_argument("--leaf-mode", default="",
                        help="the solve's visibility_leaf_mode (per_pair_all, ...)")
    parser.add_argument("--dark-inside", default="",
                        help="scanned objects whose inner sides send nothing to the gather")
    args = parser.parse_args()
    pipeline = run.register_addon()
    if args.leaf_mode:
        import importlib
        importlib.import_module("illumap.operator").VISIBILITY_DEFAULTS[
            "visibility_leaf_mode"] = args.leaf_mode
    if args.creases:
        _save_creases(args.creases)
    import bpy
    runs = {}
    for name in args.scenes:
        runs[name] = one(pipeline, name, args)
    for run_ in runs.values():
        mesh = runs.get(run_["twin"])
        if run_["solved"] and mesh is not None and mesh is not run_:
            against_mesh(bpy, run_, mesh)


if __name__ == "__main__":
    main()
