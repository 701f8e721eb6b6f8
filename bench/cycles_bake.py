#!/usr/bin/env python3
"""Cycles "Bake to Color Attribute" against Illumap on the same vertices (the Cornell box).

For each grid n, the Cornell box of bench/scenes.py is built as Blender meshes whose interior
vertices are exactly Illumap's surfels (``scenes.cornell_mesh``). Cycles bakes
``bpy.ops.object.bake(type='DIFFUSE', pass_filter={'DIRECT','INDIRECT'},
target='VERTEX_COLORS')`` into a POINT FLOAT_COLOR attribute at 4, 16, 64, 256, 1024 and 4096
samples (CPU, 64 diffuse bounces, no clamping, no world); that is incident radiance, and the
outgoing radiance is ``albedo x baked + emission`` (DESIGN.md section 4). The bake call alone is
timed (scene set-up excluded). In the same run Illumap solves the same surfels with a few
settings, timed the same way. Both are scored against the converged direct reference of
bench/accuracy_speed.py (same ``--ref-n``), evaluated at these vertices.

    .venv/bin/python bench/cycles_bake.py --quick --out bench/results/cycles_bake.json
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import illumap  # noqa: E402

import scenes as S  # noqa: E402

SAMPLES = (4, 16, 64, 256, 1024, 4096)
#: (grid cells per wall side, sample counts): the bake costs samples x vertices, so the finer
#: grids stop at fewer samples
QUICK = dict(ref_n=12000, grids=((8, SAMPLES[:4]), (14, SAMPLES[:3])))
FULL = dict(ref_n=24000, grids=((8, SAMPLES), (14, SAMPLES[:5]), (20, SAMPLES[:4])))
ILLUMAP_SETTINGS = [
    ("FMM p=2", dict(method="fmm", order=2, theta=0.5, tol=1e-3)),
    ("FMM p=3", dict(method="fmm", order=3, theta=0.5, tol=1e-3)),
    ("FMM p=4", dict(method="fmm", order=4, theta=0.5, tol=1e-4)),
    ("direct", dict(method="direct", tol=1e-4)),
]


def _material(bpy, name, albedo=None, emission=None):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    if emission is not None:
        node = nodes.new("ShaderNodeEmission")
        strength = float(max(emission))
        node.inputs["Color"].default_value = (*[c / strength for c in emission], 1.0)
        node.inputs["Strength"].default_value = strength
        mat.node_tree.links.new(node.outputs["Emission"], out.inputs["Surface"])
    else:
        node = nodes.new("ShaderNodeBsdfDiffuse")
        node.inputs["Color"].default_value = (*albedo, 1.0)
        mat.node_tree.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    return mat


def build_blender_scene(bpy, n):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    walls = []
    for w in S.cornell_mesh(n):
        mesh = bpy.data.meshes.new(w["name"])
        mesh.from_pydata([tuple(p) for p in w["verts"]], [], [tuple(f) for f in w["faces"]])
        mesh.validate()
        if w["name"] == "Light":
            mesh.materials.append(_material(bpy, "Light", emission=tuple(w["emission"])))
        else:
            mesh.materials.append(_material(bpy, w["name"], albedo=tuple(w["albedo"])))
        obj = bpy.data.objects.new(w["name"], mesh)
        bpy.context.scene.collection.objects.link(obj)
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
    args = ap.parse_args(argv)
    cfg = dict(FULL if args.full else QUICK)
    try:
        import bpy
    except ImportError as exc:
        print(f"Cycles bake skipped: the bpy module is not importable ({exc})")
        return 1
    t0 = time.perf_counter()
    ref = S.build("cornell", cfg["ref_n"], seed=12345)
    ref_sol = S.reference_solution(ref)
    print(f"reference N={ref.n} {time.perf_counter() - t0:.1f}s", flush=True)
    points = []
    for n, sample_counts in cfg["grids"]:
        surf = S.cornell(n)
        B_ref = S.reference_at(ref, ref_sol.radiosity, surf)
        walls_mask = ~(surf.emission.max(axis=1) > 0)
        for label, kw in ILLUMAP_SETTINGS:
            best = None
            for _ in range(3):   # best of 3: the machine is shared
                t = time.perf_counter()
                sol = illumap.solve(surf, **kw)
                dt = time.perf_counter() - t
                best = dt if best is None else min(best, dt)
            err = S.relative_rms(sol.radiosity, B_ref, surf.emission)
            points.append(dict(tool="illumap", label=label, grid=n, n=surf.n, time=best,
                               error=err, settings=kw))
            print(f"grid {n:3d} N={surf.n:5d} Illumap {label:10s} {best:8.3f}s err={err:.4f}",
                  flush=True)
        walls = build_blender_scene(bpy, n)
        for samples in sample_counts:
            B_walls, dt = bake(bpy, walls, samples)
            err = S.relative_rms(B_walls, B_ref[walls_mask])
            points.append(dict(tool="cycles", label=f"Cycles {samples} spp", grid=n, n=surf.n,
                               samples=samples, time=dt, error=err))
            print(f"grid {n:3d} N={surf.n:5d} Cycles {samples:5d} spp {dt:8.3f}s err={err:.4f}",
                  flush=True)
    results = dict(mode="full" if args.full else "quick", config=cfg,
                   reference=dict(n=ref.n, visibility="none"),
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
