#!/usr/bin/env python3
"""Cycles "Bake to Color Attribute" against Illumap on the same vertices (the Cornell box).

For each grid n, the Cornell box of bench/scenes/surfels.py (with its two blocks) is built as Blender
meshes whose interior vertices are exactly Illumap's surfels
(``scenes.cornell_grid_meshes``). Cycles bakes ``bpy.ops.object.bake(type='DIFFUSE', pass_filter={'DIRECT','INDIRECT'},
target='VERTEX_COLORS')`` into a POINT FLOAT_COLOR attribute at 4 ... 4096 samples (CPU, 64
diffuse bounces, no clamping, no world); that is incident radiance, and the outgoing radiance is
``albedo x baked + emission`` (DESIGN.md section 4). The bake call alone is timed (scene set-up
excluded). In the same run Illumap solves the same surfels with a few settings and the automatic
mode, timed the same way (best of 3 under 0.5 s). Both are scored on the same random subset of
vertices against the converged reference of bench/calibration/accuracy_speed.py (direct, exact visibility,
same ``ref_n``, shared cache), gathered at those vertices. Cycles at the highest sample count is
also the cross-check of that reference: it integrates the true geometry at the vertices.

    .venv/bin/python bench/reference/cycles_bake.py --quick --out bench/results/cycles_bake.json
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

BENCH = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, BENCH)
sys.path.insert(0, os.path.join(BENCH, "calibration"))
try:                                   # bpy before illumap: Blender's TBB, or bpy fails to load
    import bpy  # noqa: F401
except ImportError:
    pass
import illumap  # noqa: E402

from scenes import surfels as S  # noqa: E402
import accuracy_speed as AS  # noqa: E402

SAMPLES = (4, 16, 64, 256, 1024, 4096)
#: (grid cells per wall side, sample counts): the bake costs samples x vertices, so the finer
#: grids stop at fewer samples
QUICK = dict(grids=((8, SAMPLES[:4]), (14, SAMPLES[:3])))
FULL = dict(grids=((8, SAMPLES), (14, SAMPLES[:5]), (20, SAMPLES[:4]), (26, SAMPLES[:4])))
EXACT = dict(visibility="exact", **S.exact_keywords("cornell"))
ILLUMAP_SETTINGS = [
    ("FMM p=3 vis=none", dict(method="fmm", order=3, theta=0.5, tol=1e-4)),
    ("FMM p=2 vis=exact θ=0.3", dict(method="fmm", order=2, theta=0.3, tol=1e-4, **EXACT)),
    ("FMM p=3 vis=exact θ=0.2", dict(method="fmm", order=3, theta=0.2, tol=1e-4, **EXACT)),
    ("FMM p=3 vis=exact all-pairs s=32 θ=0.3",
     dict(method="fmm", order=3, theta=0.3, tol=1e-4, visibility_leaf_mode="per_pair_all",
          visibility_samples=32, **EXACT)),
    ("direct vis=exact", dict(method="direct", tol=1e-4, **EXACT)),
]
AUTO_TARGETS = (0.1, 0.03)


def build_blender_scene(bpy, n):
    """The Cornell box's grid meshes (``S.cornell_grid_meshes(n)``) in an empty file, through
    the library's Blender builder (a plain Emission shader on the light, as Cycles bakes it
    here); returns the non-emitting (object, grid mesh) pairs."""
    from scenes import blender as B  # noqa: PLC0415  (bpy is loaded: main imports it first)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    walls = []
    for w in S.cornell_grid_meshes(n):
        if w["name"] == "Light":
            mat = B.two_sided_emission("Light", tuple(w["emission"]))
        else:
            mat = B.diffuse_material(w["name"], tuple(w["albedo"]))
        obj = B.mesh_object(w["name"], [(w["verts"], w["faces"], None)], mat, weld=False)
        if w["name"] != "Light":
            walls.append((obj, w))
    return walls


def bake(bpy, walls, samples):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.max_bounces = scene.cycles.diffuse_bounces = 64
    scene.cycles.sample_clamp_direct = 0.0
    scene.cycles.sample_clamp_indirect = 0.0
    scene.world = None
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    for obj, _ in walls:
        if "bake" in obj.data.color_attributes:
            obj.data.color_attributes.remove(obj.data.color_attributes["bake"])
        attr = obj.data.color_attributes.new("bake", "FLOAT_COLOR", "POINT")
        obj.data.color_attributes.active_color = attr
        obj.select_set(True)
    bpy.context.view_layer.objects.active = walls[0][0]
    t = time.perf_counter()
    bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT"},
                        target="VERTEX_COLORS")
    dt = time.perf_counter() - t
    out = []
    for obj, w in walls:
        a = np.empty(len(obj.data.vertices) * 4, np.float32)
        obj.data.color_attributes["bake"].data.foreach_get("color", a)
        incident = a.reshape(-1, 4)[:, :3].astype(np.float64)
        out.append(w["albedo"] * incident[w["surfel"]])   # walls emit nothing
    return np.concatenate(out), dt


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true")
    mode.add_argument("--full", action="store_true")
    ap.add_argument("--out", default="bench/results/cycles_bake.json")
    ap.add_argument("--grids", nargs="*", default=None, metavar="N:S1,S2",
                    help="grid sizes and sample counts, e.g. 8:4,16,64 (default: the mode's)")
    ap.add_argument("--ref-n", type=int, default=None, help="reference size (default: the "
                    "mode's, as bench/calibration/accuracy_speed.py)")
    args = ap.parse_args(argv)
    cfg = dict(FULL if args.full else QUICK)
    acfg = dict(AS.FULL if args.full else AS.QUICK)
    if args.grids:
        cfg["grids"] = tuple((int(g.split(":")[0]), tuple(int(x) for x in g.split(":")[1]
                                                          .split(","))) for g in args.grids)
    if args.ref_n:
        acfg["ref_n"] = dict(acfg["ref_n"], cornell=args.ref_n)
    cfg["ref_n"] = acfg["ref_n"]["cornell"]
    try:
        import bpy
    except ImportError as exc:
        print(f"Cycles bake skipped: the bpy module is not importable ({exc})")
        return 1
    t0 = time.perf_counter()
    ref, ref_B, ref_info = AS.reference("cornell", acfg, lambda s: print(s, flush=True))
    points = []
    for n, sample_counts in cfg["grids"]:
        surf = S.cornell(n)
        idx = S.error_subset(surf, acfg["error_points"])
        B_ref = S.reference_at(ref, ref_B, S.subset(surf, idx), "cornell")
        runs = [(label, lambda kw=kw: AS.timed_solve(surf, kw), kw)
                for label, kw in ILLUMAP_SETTINGS]
        runs += [(f"auto {t:g}", lambda t=t: AS.timed_auto(surf, t, "grid"), None)
                 for t in AUTO_TARGETS]
        for label, fn, kw in runs:
            sol, best = AS.best_of_three(fn)
            if kw is None:
                kw = sol.stats["accuracy"]["solve_keywords"]
            err = S.relative_rms(sol.radiosity[idx], B_ref)
            points.append(dict(tool="illumap", label=label, grid=n, n=surf.n, time=best,
                               error=err, settings=kw))
            print(f"grid {n:3d} N={surf.n:5d} Illumap {label:26s} {best:8.3f}s err={err:.4f}",
                  flush=True)
        walls = build_blender_scene(bpy, n)
        pos = np.flatnonzero(~(surf.emission.max(axis=1) > 0))   # vertex rows of B_walls
        where = np.searchsorted(pos, idx)
        for samples in sample_counts:
            B_walls, dt = bake(bpy, walls, samples)
            err = S.relative_rms(B_walls[where], B_ref)
            points.append(dict(tool="cycles", label=f"Cycles {samples} spp", grid=n, n=surf.n,
                               samples=samples, time=dt, error=err))
            print(f"grid {n:3d} N={surf.n:5d} Cycles {samples:5d} spp {dt:8.3f}s err={err:.4f}",
                  flush=True)
    results = dict(mode="full" if args.full else "quick", config=cfg,
                   reference=ref_info, core=S.provenance(),
                   blender=bpy.app.version_string,
                   machine=dict(platform=platform.platform(), cpus=os.cpu_count()),
                   date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), points=points,
                   wall_time=time.perf_counter() - t0)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(results, f, indent=1)
    print(f"wrote {args.out} ({results['wall_time']:.0f}s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
