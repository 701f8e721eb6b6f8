#!/usr/bin/env python3
"""Same scene, same light, frame after frame: two short sequences rendered through the batch
(``scripts/blender -b … --python scripts/illumap_batch.py -- --frames …``), one job for all
frames as a farm runs it, scored where the true light did not change.

* ``turntable``: the open scene (``scenes.meshes.world``: floor, box, sphere, wall, emissive panel,
  under the sky) plus a sun, with a camera circling it. Nothing lit moves, so every vertex
  must read the same on every frame: the change is reported as the largest |difference|.
* ``moving``: the same scene with the box moved by 1% of its size (1 cm) from frame to frame.
  The light at vertices more than a metre from the box must change by no more than Cycles
  says it changes there, plus 0.1% (of the scene's mean value). Cycles bakes frames 1 and 2
  with one seed and ``--samples``: its change is the reference (its noise, correlated between
  the two bakes, is reported by baking frame 1 with a second seed).
* ``identical_runs``: each bench scene (``scenes.SCENES``) saved once and run twice through the
  batch, with the world on and off: the two runs must agree bit for bit.

Writes ``bench/results/temporal.json`` and prints a table.

    .venv/bin/python bench/reference/temporal.py               # 4 frames, 1024-sample bakes
    .venv/bin/python bench/reference/temporal.py --frames 3 --samples 256
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_ROOT = os.path.dirname(os.path.dirname(HERE))
if REPO_ROOT not in sys.path:          # ``import addon``, as tests/blender/conftest.py does
    sys.path.insert(0, REPO_ROOT)

import bpy  # noqa: E402

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

DEFAULT_OUT = os.path.join(REPO_ROOT, "bench", "results", "temporal.json")
#: How far (m) from the moving box a vertex's light must not change beyond the reference's.
FAR = 1.0
#: The box moves by this share of its size per frame.
STEP = 0.01
#: What the change may exceed the reference's by, relative to the scored vertices' mean.
ALLOWANCE = 1e-3


def build(sequence: str, frames: int) -> list[str]:
    """The open scene with a sun, a camera and the sequence's animation; the scored names."""
    scene = scenes.build("world")
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.6, 0.3, 0.5)
    bpy.context.scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    bpy.context.scene.collection.objects.link(cam)
    bpy.context.scene.camera = cam
    box = bpy.data.objects["Box"]
    for f in range(1, frames + 1):
        angle = 2 * math.pi * (f - 1) / max(frames, 1)
        cam.location = (8 * math.cos(angle), 8 * math.sin(angle), 4.0)
        cam.rotation_euler = (1.15, 0.0, angle + math.pi / 2)
        cam.keyframe_insert("location", frame=f)
        cam.keyframe_insert("rotation_euler", frame=f)
        if sequence == "moving":
            box.location = (STEP * (f - 1) * 1.0, 0.0, 0.0)   # the box is 1 m wide
            box.keyframe_insert("location", frame=f)
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, frames
    bpy.context.scene.frame_set(1)
    return [o.name for o in scene.scored]


def run_batch(blend: str, frames: int, folder: str, extra=(), tag: str = "") -> tuple[list[str], float]:
    """One batch job over the frames; the output .blend of each frame and the job's seconds."""
    pattern = os.path.join(folder, os.path.basename(blend)[:-6] + tag + "_####.blend")
    cmd = [os.path.join(REPO_ROOT, "scripts", "blender"), "-b", blend, "--python",
           os.path.join(REPO_ROOT, "scripts", "illumap_batch.py"), "--",
           "--frames", f"1-{frames}", "--output", pattern, "--transfer", "point", "--overwrite",
           *extra]
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"batch failed ({done.returncode}):\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    return [pattern.replace("####", f"{f:04d}") for f in range(1, frames + 1)], seconds


def frame_values(path: str, names: list[str]) -> dict[str, np.ndarray]:
    bpy.ops.wm.open_mainfile(filepath=path)
    return {n: reference_run.read_illumination(bpy.data.objects[n]) for n in names}


def far_mask(names: list[str]) -> dict[str, np.ndarray]:
    """Vertices farther than FAR from the box's bounds at frame 1 (the box itself left out)."""
    box = bpy.data.objects["Box"]
    corners = np.array([box.matrix_world @ v.co for v in box.data.vertices])
    lo, hi = corners.min(axis=0), corners.max(axis=0) + np.array([STEP * 10, 0.0, 0.0])
    out = {}
    for n in names:
        p = bake.vertex_positions(bpy.data.objects[n])
        gap = np.linalg.norm(np.maximum(np.maximum(lo - p, p - hi), 0.0), axis=1)
        out[n] = (gap > FAR) & (n != "Box") & bake.baked_vertices(bpy.data.objects[n])
    return out


def changes(a: dict, b: dict, mask: dict, scale: float) -> dict:
    """RMS and largest |b − a| over the masked vertices, relative to ``scale``."""
    d = np.concatenate([(b[n] - a[n])[mask[n]].ravel() for n in a])
    return dict(rms=float(np.sqrt(np.mean(d ** 2)) / scale), max=float(np.abs(d).max() / scale),
                vertices=int(sum(m.sum() for m in mask.values())))


def outgoing(names: list[str], samples: int, seed: int) -> dict[str, np.ndarray]:
    """Cycles' outgoing radiance per vertex of the named objects at the current frame."""
    objs = [bpy.data.objects[n] for n in names]
    incident, _ = bake.bake_incident(objs, samples, seed)
    out = {}
    for obj in objs:
        albedo, emission = scenes.vertex_materials(obj)
        out[obj.name] = albedo * incident[obj.name] + emission
    return out


def identical_runs(names: list[str], folder: str) -> dict:
    """Each bench scene saved once and run twice through the batch in fresh processes, with
    the world on and off: the largest |difference| between the two runs' vertex values."""
    out = {}
    for name in names:
        for world in (True, False):
            scene = scenes.build(name)
            scored = [o.name for o in scene.scored]
            blend = os.path.join(folder, f"{name}.blend")
            bpy.ops.wm.save_as_mainfile(filepath=blend)
            runs = []
            for k in range(2):
                extra = [] if world else ["--no-world"]
                outputs, _ = run_batch(blend, 1, folder, extra + ["--seed", "0"], tag=f"_{k}")
                runs.append(frame_values(outputs[0], scored))
            diff = max(float(np.abs(runs[0][n] - runs[1][n]).max()) for n in scored)
            out[f"{name}/{'world' if world else 'no world'}"] = diff
            print(f"  {name:8s} world {'on ' if world else 'off'}: largest difference {diff:.3g}")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--samples", type=int, default=1024, help="Cycles samples of each bake")
    ap.add_argument("--scenes", nargs="*", choices=list(scenes.SCENES), default=list(scenes.SCENES),
                    help="bench scenes run twice each (world on and off) and compared bit for bit")
    ap.add_argument("--out", default=DEFAULT_OUT)
    args = ap.parse_args(argv)
    if args.frames < 2:
        ap.error("--frames: at least 2")
    doc = dict(commit=reference_run._commit(), blender=bpy.app.version_string,
               date=datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
               frames=args.frames, step=STEP, far=FAR, allowance=ALLOWANCE,
               cycles_samples=args.samples)
    with tempfile.TemporaryDirectory() as folder:
        # Turntable: the camera moves, nothing lit does.
        names = build("turntable", args.frames)
        blend = os.path.join(folder, "turntable.blend")
        bpy.ops.wm.save_as_mainfile(filepath=blend)
        outputs, seconds = run_batch(blend, args.frames, folder)
        values = [frame_values(p, names) for p in outputs]
        largest = max(float(np.abs(v[n] - values[0][n]).max()) for v in values[1:] for n in names)
        doc["turntable"] = dict(seconds=seconds, max_change=largest,
                                identical=bool(largest == 0.0))
        print(f"turntable: {args.frames} frames in {seconds:.1f} s; largest change at any vertex "
              f"{largest:.3g} ({'identical' if largest == 0.0 else 'NOT identical'})")

        # Moving box: 1% of its size per frame.
        names = build("moving", args.frames)
        blend = os.path.join(folder, "moving.blend")
        bpy.ops.wm.save_as_mainfile(filepath=blend)
        outputs, seconds = run_batch(blend, args.frames, folder)
        values = [frame_values(p, names) for p in outputs]
        bpy.ops.wm.open_mainfile(filepath=blend)
        mask = far_mask(names)
        scale = float(np.mean(np.concatenate([values[0][n][mask[n]].ravel() for n in names])))
        ours = [changes(values[k], values[k + 1], mask, scale) for k in range(args.frames - 1)]
        # Cycles: frames 1 and 2 with one seed (its change), frame 1 with another (its noise).
        refs = []
        for frame, seed in ((1, 0), (2, 0), (1, 1)):
            bpy.ops.wm.open_mainfile(filepath=blend)
            bpy.context.scene.frame_set(frame)
            refs.append(outgoing(names, args.samples, seed))
        cycles_change = changes(refs[0], refs[1], mask, scale)
        cycles_noise = changes(refs[0], refs[2], mask, scale)
        worst = max(c["rms"] for c in ours)
        doc["moving"] = dict(seconds=seconds, scale=scale, ours=ours, cycles_change=cycles_change,
                             cycles_noise=cycles_noise, worst_rms=worst,
                             met=bool(worst <= cycles_change["rms"] + ALLOWANCE))
        print(f"moving box ({STEP:.0%} of its size a frame), {ours[0]['vertices']} vertices "
              f"farther than {FAR} m, relative to their mean {scale:.3g}:")
        for k, c in enumerate(ours):
            print(f"  Illumap frame {k + 1}->{k + 2}: RMS change {c['rms']:.2e}, max {c['max']:.2e}")
        print(f"  Cycles frame 1->2 (one seed): RMS change {cycles_change['rms']:.2e}, "
              f"max {cycles_change['max']:.2e}; its noise (two seeds) RMS {cycles_noise['rms']:.2e}")
        print(f"  target: Illumap <= Cycles + {ALLOWANCE:.1%}: "
              f"{'met' if doc['moving']['met'] else 'MISSED'}")
        if args.scenes:
            print("two runs of each bench scene in fresh processes:")
            doc["identical_runs"] = identical_runs(args.scenes, folder)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(doc, f, indent=1)
    print(f"wrote {os.path.relpath(args.out, REPO_ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
