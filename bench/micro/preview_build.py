#!/usr/bin/env python3
"""Building the point preview at scale: a scan of N points (a vertex-only mesh, as a PLY import
gives, and a point cloud) with an ``illumination`` attribute, shown by
``addon.mesh_preview.build_mesh_preview`` (every point a display point), timed with one
depsgraph evaluation; beside it the disc preview of the same N points as surfels
(``addon.preview.build_preview``: one instanced disc per point), timed the same way. Both in
this process, one after the other, so the ratio is measured in one run. "After a run": the
splats computed first as a run's worker does (``point_splats.prepare_frames``), then the same
build on the main thread, which only writes them (and their shading, which the worker
computed from the run's values; beside it, in the same run, the main thread shading them
itself, as it did before). Beside them, the splats alone: the native
``illumap.splats.splat_frames`` against the numpy version it replaced
(tests/core/splat_frames_reference.py) on the same points, with the scan's normals and with
normals estimated, one after the other in this run (their ratio; wall and process CPU
seconds, the CPU time less sensitive to other jobs on the machine), and the load average seen.
With ``--baseline DIR`` (DIR holding an earlier ``illumap`` package, e.g. a copy of an
earlier install's site-packages/illumap), the splats of that build too, on the same points in
a subprocess right after this one's: its seconds, the ratio, and whether the frames are the
same bit for bit.

    .venv/bin/python bench/micro/preview_build.py [--splats-only] [--baseline DIR] [1000000 ...]

Writes bench/results/preview_build.json for the default size (1M points, no arguments or
exactly ``1000000``); other sizes go to bench/results/preview_build_<sizes>.json, so a quick
run at another size never overwrites the recorded one.
"""

from __future__ import annotations

import json
import os
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, REPO)

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from addon.preview import (mesh_preview, point_splats, splat_shading,  # noqa: E402
                           surfel_preview as preview)

OUT = os.path.join(REPO, "bench", "results", "preview_build.json")
sys.path.insert(0, os.path.join(REPO, "tests", "core"))


def scan(n: int, kind: str, radius: bool = True) -> bpy.types.Object:
    """n random points on a 10 m × 10 m floor, illumination rising along x; without a
    ``radius`` attribute the point preview measures the spacing itself."""
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.random((n, 2)) * 10.0, np.zeros(n)]).astype(np.float32)
    mesh = bpy.data.meshes.new("Scan")
    mesh.vertices.add(n)
    mesh.vertices.foreach_set("co", pts.ravel())
    col = np.column_stack([pts[:, 0] / 10, np.full(n, 0.5), np.full(n, 0.2), np.ones(n)])
    for name, value in (("illumination", col), ("albedo", col), ("emission", 0 * col)):
        mesh.color_attributes.new(name, "FLOAT_COLOR", "POINT").data.foreach_set(
            "color", value.astype(np.float32).ravel())
    mesh.attributes.new("normal", "FLOAT_VECTOR", "POINT").data.foreach_set(
        "vector", np.tile(np.float32([0, 0, 1]), n))
    if radius:
        mesh.attributes.new("radius", "FLOAT", "POINT").data.foreach_set(
            "value", np.full(n, 10.0 / np.sqrt(n), np.float32))
    obj = bpy.data.objects.new("Scan", mesh)
    bpy.context.scene.collection.objects.link(obj)
    if kind == "POINTCLOUD":
        # The selection of a just-linked object is not seen by the operator headless (it
        # answered "No editable objects to convert" and left a mesh): name it in the context,
        # as output._build_pointcloud does.
        with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj],
                                       selected_editable_objects=[obj]):
            bpy.ops.object.convert(target="POINTCLOUD")
        if obj.type != "POINTCLOUD":
            raise RuntimeError("the scan could not be converted to a point cloud")
    return obj


def timed(build, obj) -> dict:
    """Seconds to build the preview and to evaluate it once (the evaluated geometry read back:
    its points, or its instances)."""
    c0, t0 = time.process_time(), time.perf_counter()
    build()
    c1, t1 = time.process_time(), time.perf_counter()
    geometry = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).evaluated_geometry()
    shown = (len(geometry.pointcloud.points) if geometry.pointcloud is not None
             else len(geometry.instances_pointcloud().points))
    t2 = time.perf_counter()
    return {"build_s": t1 - t0, "build_cpu_s": c1 - c0, "evaluate_s": t2 - t1,
            "total_s": t2 - t0, "shown": shown}


BASELINE_RUN = """
import json, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
from illumap.splats import splat_frames
n, given, out = int(sys.argv[2]), sys.argv[3] == "given", sys.argv[4]
rng = np.random.default_rng(0)
pts = np.column_stack([rng.random((n, 2)) * 10.0, np.zeros(n)]).astype(np.float32)
normals = np.tile(np.float32([0, 0, 1]), (n, 1)) if given else None
c0, t0 = time.process_time(), time.perf_counter()
frames = splat_frames(pts, normals)
c1, t1 = time.process_time(), time.perf_counter()
np.savez(out, **frames)
print(json.dumps({"wall_s": t1 - t0, "cpu_s": c1 - c0}))
"""


def baseline_splats(baseline: str, n: int, given: bool, new: dict) -> dict:
    """The splats of the same n points by the illumap package in ``baseline`` (a
    subprocess): its wall and CPU seconds, and whether its frames equal ``new``."""
    import subprocess  # noqa: PLC0415
    import tempfile  # noqa: PLC0415
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "frames.npz")
        done = subprocess.run([sys.executable, "-c", BASELINE_RUN, baseline, str(n),
                               "given" if given else "estimated", out],
                              capture_output=True, text=True, check=True)
        seconds = json.loads(done.stdout.strip().splitlines()[-1])
        old = np.load(out)
        seconds["identical"] = all(np.array_equal(old[k], new[k]) for k in new)
    return seconds


def splats_alone(n: int, baseline: str | None = None) -> list[dict]:
    """Seconds for the splats of n random points on the bench's floor (float32, as a scan
    gives them), native and numpy, with the given normals and with estimated ones; the largest
    difference between their frames."""
    import splat_frames_reference  # noqa: PLC0415 - the numpy version (tests/core)
    from illumap.splats import splat_frames  # noqa: PLC0415
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.random((n, 2)) * 10.0, np.zeros(n)]).astype(np.float32)
    rows = []
    for normals in (np.tile(np.float32([0, 0, 1]), (n, 1)), None):
        load = os.getloadavg()[0]
        c0, t0 = time.process_time(), time.perf_counter()
        new = splat_frames(pts, normals)
        c1, t1 = time.process_time(), time.perf_counter()
        old = splat_frames_reference.splat_frames(pts, normals)
        c2, t2 = time.process_time(), time.perf_counter()
        diff = max(float(np.abs(new[k] - old[k]).max()) for k in ("axis", "scale", "offset"))
        row = {"points": n, "normals": "given" if normals is not None else "estimated",
               "native_s": t1 - t0, "numpy_s": t2 - t1, "ratio": (t2 - t1) / (t1 - t0),
               "native_cpu_s": c1 - c0, "numpy_cpu_s": c2 - c1,
               "max_difference": diff,
               "clipped_differ": int((new["clipped"] != old["clipped"]).sum()),
               "load_before": load, "load_after": os.getloadavg()[0]}
        if baseline:
            base = baseline_splats(baseline, n, normals is not None, new)
            row.update(baseline_s=base["wall_s"], baseline_cpu_s=base["cpu_s"],
                       baseline_ratio=base["wall_s"] / row["native_s"],
                       baseline_cpu_ratio=base["cpu_s"] / row["native_cpu_s"],
                       baseline_identical=base["identical"])
            print(f"{n:>9,} splats, normals {row['normals']:<9}: baseline {base['wall_s']:.2f} s "
                  f"(CPU {base['cpu_s']:.2f} s): {row['baseline_ratio']:.2f}x the wall, "
                  f"{row['baseline_cpu_ratio']:.2f}x the CPU of this build; frames "
                  f"{'identical' if base['identical'] else 'DIFFER'}", flush=True)
        rows.append(row)
        print(f"{n:>9,} splats, normals {row['normals']:<9}: native {row['native_s']:.2f} s, "
              f"numpy {row['numpy_s']:.2f} s ({row['ratio']:.1f}x; CPU {row['native_cpu_s']:.2f} "
              f"vs {row['numpy_cpu_s']:.2f} s); frames differ by "
              f"{diff:.1e}, clipped flags by {row['clipped_differ']}; load average "
              f"{load:.1f} -> {row['load_after']:.1f}", flush=True)
    return rows


def main() -> None:
    args = sys.argv[1:]
    if "-h" in args or "--help" in args:
        print(__doc__)
        return
    only = "--splats-only" in args
    baseline = None
    if "--baseline" in args:
        at = args.index("--baseline")
        baseline = os.path.abspath(args[at + 1])
        del args[at:at + 2]
    sizes = [int(a) for a in args if a != "--splats-only"] or [1_000_000]
    rows = []
    splat_rows = []
    for n in sizes:
        splat_rows += splats_alone(n, baseline)
        if only:
            continue
        for kind in ("MESH", "POINTCLOUD"):
            for radius in (True, False):
                bpy.ops.wm.read_factory_settings(use_empty=True)
                obj = scan(n, kind, radius)
                points = timed(lambda: mesh_preview.build_mesh_preview([obj]), obj)
                # After a run: its worker computed the splats (point_splats.prepare_frames)
                # and shaded them from the run's values (prepare_shading, as ComputeTask
                # does), and the main thread only writes them; beside it, in this run, the
                # main thread shading them itself (as before prepare_shading).
                unshaded = None
                for shade in (False, True):
                    bpy.ops.wm.read_factory_settings(use_empty=True)
                    obj = scan(n, kind, radius)
                    t0 = time.perf_counter()
                    point_splats.prepare_frames(*mesh_preview.splat_inputs(obj))
                    if shade:
                        light = splat_shading.point_colours(obj, "illumination")[:, :3]
                        point_splats.prepare_shading({obj.name: light.astype(np.float64)})
                    worker = time.perf_counter() - t0
                    after = timed(lambda: mesh_preview.build_mesh_preview([obj]), obj)
                    after["worker_s"] = worker
                    if not shade:
                        unshaded = after
                after["main_thread_shading"] = unshaded
                bpy.ops.wm.read_factory_settings(use_empty=True)
                obj = scan(n, kind)
                discs = timed(lambda: preview.build_preview(bpy.context, obj), obj)
                rows.append({"points": n, "source": kind, "radius_attribute": radius,
                             "point_preview": points, "after_run": after,
                             "disc_preview": discs})
                print(f"{n:>9,} {kind:<10} radius {'given' if radius else 'spacing'}: point "
                      f"preview {points['total_s']:.2f} s (build {points['build_s']:.2f}, CPU "
                      f"{points['build_cpu_s']:.2f}, "
                      f"evaluate {points['evaluate_s']:.2f}); after a run "
                      f"{after['total_s']:.2f} s on the main thread (build CPU "
                      f"{after['build_cpu_s']:.2f} s; the worker's splats "
                      f"{after['worker_s']:.2f} s; shading on the main thread: build CPU "
                      f"{unshaded['build_cpu_s']:.2f} s); disc preview "
                      f"{discs['total_s']:.2f} s; shown {points['shown']:,} / "
                      f"{discs['shown']:,}", flush=True)
    out = OUT if sizes == [1_000_000] and not only else OUT.replace(
        ".json", "_" + "_".join(str(n) for n in sizes) + ("_splats" if only else "") + ".json")
    with open(out, "w") as f:
        json.dump({"blender": bpy.app.version_string, "cpus": os.cpu_count(), "rows": rows,
                   "splats": splat_rows}, f, indent=1)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
