#!/usr/bin/env python3
"""What decides whether the point preview stays interactive at a million display points, measured
headless (a viewport cannot be opened without a window): the depsgraph's work after each kind
of edit, on a scan of N points (``preview_build.scan``: a point cloud and a vertex-only mesh,
each point with its ``radius``) shown by the Illumap Point Preview modifier, and beside it the
disc preview of the same points as surfels (one instanced disc each).

For each, after the preview is built and evaluated once:

* ``geometry``: the object's data tagged (``obj.data.update_tag()``, what an edit of its points
  or attributes does), then ``view_layer.update()``: the Geometry Nodes tree runs again;
* ``move``: the object moved (``location.x``), then ``view_layer.update()``: a transform only,
  which must not run the tree again;
* ``frame``: ``scene.frame_set`` to the next frame (playback): nothing depends on time, so
  nothing should run;
* ``selection``: the object selected and made active, then ``view_layer.update()``.

Each is repeated ``--repeats`` times (median and maximum kept). Whether the tree ran is read
from the depsgraph itself: a ``depsgraph_update_post`` handler records the object's
``is_updated_geometry`` for every update, and the evaluated modifier's ``execution_time``
(Blender's own timing of the tree) is read after each. Memory: the process's resident set
(``/proc/self/status`` VmRSS) before the preview is built and after its first evaluation, and
the bytes of the evaluated geometry's attributes (points) or instances (transforms plus the
point attributes they carry).

``--eevee`` also renders one 64×64 frame of the point preview with EEVEE at 1 sample (camera
above the scan), twice, and once with the scan hidden, and records which GPU backend drew it
(``eevee_frame``).

    .venv/bin/python bench/micro/preview_interactive.py [--points 1000000] [--repeats 7] [--eevee]

Writes bench/results/preview_interactive.json.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path[:0] = [REPO, HERE]

import bpy  # noqa: E402

from addon.preview import mesh_preview, surfel_preview as preview  # noqa: E402
from preview_build import scan  # noqa: E402

OUT = os.path.join(REPO, "bench", "results", "preview_interactive.json")

#: Bytes per element of each attribute type.
ATTRIBUTE_BYTES = {"FLOAT": 4, "INT": 4, "FLOAT_VECTOR": 12, "FLOAT_COLOR": 16,
                   "BYTE_COLOR": 4, "BOOLEAN": 1, "FLOAT2": 8, "INT8": 1, "QUATERNION": 16,
                   "FLOAT4X4": 64, "INT32_2D": 8, "STRING": 0}


def rss_mib() -> float:
    """The process's resident set in MiB."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _attribute_bytes(attributes) -> int:
    return sum(ATTRIBUTE_BYTES.get(a.data_type, 0) * len(a.data) for a in attributes)


def evaluated_bytes(obj) -> dict:
    """Points or instances of ``obj``'s evaluated geometry and the bytes of their attributes
    (instances: their 4×4 transforms count as one FLOAT4X4 attribute if not listed)."""
    geometry = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).evaluated_geometry()
    if geometry.pointcloud is not None:
        cloud = geometry.pointcloud
        return {"kind": "points", "count": len(cloud.points),
                "attributes": sorted(a.name for a in cloud.attributes),
                "bytes": _attribute_bytes(cloud.attributes)}
    inst = geometry.instances_pointcloud()
    names = {a.name for a in inst.attributes}
    extra = 0 if "instance_transform" in names else 64 * len(inst.points)
    return {"kind": "instances", "count": len(inst.points), "attributes": sorted(names),
            "bytes": _attribute_bytes(inst.attributes) + extra}


class Updates:
    """Records, per depsgraph update, whether ``name``'s geometry was re-evaluated."""

    def __init__(self, name: str) -> None:
        self.name, self.geometry = name, []

    def __call__(self, scene, depsgraph) -> None:
        hit = [u for u in depsgraph.updates if isinstance(u.id, bpy.types.Object)
               and u.id.name == self.name]
        self.geometry.append(any(u.is_updated_geometry for u in hit))

    def __enter__(self):
        bpy.app.handlers.depsgraph_update_post.append(self)
        return self

    def __exit__(self, *exc) -> None:
        bpy.app.handlers.depsgraph_update_post.remove(self)


def _execution_time(obj, name: str) -> float:
    mod = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).modifiers.get(name)
    return float(mod.execution_time) if mod is not None else float("nan")


def measure(obj, modifier: str, repeats: int) -> dict:
    """Median and maximum seconds of each edit (module docstring), whether the tree ran."""
    scene, view_layer = bpy.context.scene, bpy.context.view_layer

    def geometry():
        obj.data.update_tag()
        view_layer.update()

    def move():
        obj.location.x += 0.001
        view_layer.update()

    def frame():
        scene.frame_set(scene.frame_current + 1)

    def selection():
        obj.select_set(not obj.select_get())
        view_layer.objects.active = obj
        view_layer.update()

    out = {}
    for label, edit in (("geometry", geometry), ("move", move), ("frame", frame),
                        ("selection", selection)):
        times, ran, tree = [], [], []
        for _ in range(repeats):
            with Updates(obj.name) as updates:
                t0 = time.perf_counter()
                edit()
                times.append(time.perf_counter() - t0)
            ran.append(any(updates.geometry))
            tree.append(_execution_time(obj, modifier))
        out[label] = {"median_s": statistics.median(times), "max_s": max(times),
                      "geometry_evaluated": sum(ran), "of": repeats,
                      "tree_execution_time_s": statistics.median(tree)}
    return out


def eevee_frame(obj) -> dict:
    """One 64×64 EEVEE frame of ``obj`` from above at 1 sample, timed twice (the first compiles
    the shaders), and the same frame with ``obj`` hidden (the renderer's fixed cost); or why it
    could not render. The GPU backend's renderer is recorded: headless without a GPU, Blender
    draws through Mesa's software rasteriser (llvmpipe), whose times measure the CPU
    emulation, not a graphics card."""
    scene = bpy.context.scene
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 11.0
    cam.location = (5.0, 5.0, 10.0)
    scene.camera = cam
    engines = [e.identifier for e in
               bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items]
    engine = next((e for e in ("BLENDER_EEVEE_NEXT", "BLENDER_EEVEE") if e in engines), None)
    if engine is None:
        return {"ran": False, "why": f"no EEVEE engine among {engines}"}
    scene.render.engine = engine
    scene.eevee.taa_render_samples = 1
    scene.render.resolution_x = scene.render.resolution_y = 64
    scene.render.resolution_percentage = 100

    def frame() -> float:
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=False)
        return time.perf_counter() - t0

    try:
        first, second = frame(), frame()
        obj.hide_render = True
        hidden = frame()
        obj.hide_render = False
    except Exception as exc:   # noqa: BLE001 - reported, not raised: no GPU context here
        return {"ran": False, "engine": engine, "why": f"{type(exc).__name__}: {exc}"}
    try:
        import gpu
        renderer = f"{gpu.platform.renderer_get()} ({gpu.platform.backend_type_get()})"
    except Exception as exc:   # noqa: BLE001
        renderer = f"unknown ({type(exc).__name__})"
    return {"ran": True, "engine": engine, "renderer": renderer, "samples": 1,
            "size": [64, 64], "first_s": first, "second_s": second, "hidden_s": hidden}


def run(points: int, kind: str, which: str, repeats: int, eevee: bool) -> dict:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = scan(points, kind)
    before = rss_mib()
    t0 = time.perf_counter()
    if which == "point":
        mesh_preview.build_mesh_preview([obj])
        modifier = mesh_preview.POINT_MODIFIER_NAME
    else:
        preview.build_preview(bpy.context, obj)
        modifier = preview.MODIFIER_NAME
    bpy.context.view_layer.update()
    first = time.perf_counter() - t0
    row = {"points": points, "source": kind, "preview": which, "first_evaluation_s": first,
           "rss_before_mib": before, "rss_after_mib": rss_mib(),
           "evaluated": evaluated_bytes(obj), "edits": measure(obj, modifier, repeats)}
    row["rss_added_mib"] = row["rss_after_mib"] - before
    if eevee and which == "point":
        row["eevee"] = eevee_frame(obj)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--eevee", action="store_true", help="also time one EEVEE frame")
    ap.add_argument("--out", default=None, help="default: results/preview_interactive.json "
                    "at 1M points, else preview_interactive_<points>.json")
    args = ap.parse_args()
    if args.out is None:
        args.out = OUT if args.points == 1_000_000 else OUT.replace(
            ".json", f"_{args.points}.json")
    rows = []
    for kind in ("POINTCLOUD", "MESH"):
        for which in ("point", "disc"):
            row = run(args.points, kind, which, args.repeats, args.eevee)
            rows.append(row)
            e = row["edits"]
            print(f"{args.points:,} {kind:<10} {which:<5} first {row['first_evaluation_s']:.3f} s, "
                  f"+{row['rss_added_mib']:.0f} MiB RSS, evaluated {row['evaluated']['count']:,} "
                  f"{row['evaluated']['kind']} {row['evaluated']['bytes'] / 2**20:.0f} MiB; "
                  + "; ".join(f"{k} {v['median_s'] * 1e3:.2f} ms (tree ran {v['geometry_evaluated']}"
                              f"/{v['of']})" for k, v in e.items())
                  + (f"; EEVEE {row['eevee']}" if "eevee" in row else ""), flush=True)
    with open(args.out, "w") as f:
        json.dump({"blender": bpy.app.version_string, "repeats": args.repeats,
                   "cpu_count": os.cpu_count(), "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
