#!/usr/bin/env python3
"""How long an interactive run holds Blender's main thread before its progress bar appears,
on a dense scan: the Cornell box's walls and blocks as grids of ``--cell`` m, their vertices
given as one point cloud without normals (the light kept as an open mesh, so the back faces of
open surfaces are probed too).

Per round, in one process: ``pipeline.prepare(…)`` (everything on the calling thread, as the
batch path and the add-on before the worker built the scene) and ``pipeline.prepare(…,
build=False)`` (what the operator's ``invoke`` runs on the main thread) followed by the
``UnbuiltJob``'s ``build()`` (what its worker runs). Reports each round's times, the
main-thread share, and checks the two jobs are equal.

    .venv/bin/python bench/micro/scan_prepare.py [--cell 0.01] [--rounds 2]

Writes bench/results/scan_prepare.json.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

BENCH = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REPO = os.path.dirname(BENCH)
sys.path.insert(0, REPO)
sys.path.insert(0, BENCH)

import bpy  # noqa: E402

from reference import run  # noqa: E402
from scenes import blender as scenes  # noqa: E402

OUT = os.path.join(REPO, "bench", "results", "scan_prepare.json")
JOB_ARRAYS = ("positions", "normals", "areas", "albedo", "emission", "triangles", "two_sided",
              "splat_point")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cell", type=float, default=0.01, help="scan spacing, m (0.01: 486k points)")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--out", default=OUT)
    args = ap.parse_args(argv)
    pipeline = run.register_addon()
    objects, spans = run.scan_objects(scenes.cornell_scan(args.cell))
    points = sum(count for _, count in spans.values())
    settings = run.make_settings(pipeline, {})
    depsgraph = bpy.context.evaluated_depsgraph_get()
    rows = []
    for index in range(args.rounds):
        t0 = time.perf_counter()
        whole = pipeline.prepare(depsgraph, objects, settings)
        t1 = time.perf_counter()
        unbuilt = pipeline.prepare(depsgraph, objects, settings, build=False)
        t2 = time.perf_counter()
        job = unbuilt.build()
        t3 = time.perf_counter()
        for name in JOB_ARRAYS:
            if not np.array_equal(getattr(job, name), getattr(whole, name)):
                raise SystemExit(f"the built job differs from prepare()'s in {name}")
        row = dict(round=index, prepare_s=round(t1 - t0, 3), main_thread_s=round(t2 - t1, 3),
                   worker_s=round(t3 - t2, 3), main_thread_share=round((t2 - t1) / (t1 - t0), 3))
        rows.append(row)
        print(f"round {index}: prepare() {row['prepare_s']:.2f} s on one thread; "
              f"main thread {row['main_thread_s']:.2f} s + worker {row['worker_s']:.2f} s "
              f"(main-thread share {row['main_thread_share']:.2f})", flush=True)
    commit = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    with open(args.out, "w") as f:
        json.dump(dict(blender=bpy.app.version_string, commit=commit, cell=args.cell,
                       points=points, surfels=int(job.count), triangles=int(len(job.triangles)),
                       date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), rows=rows),
                  f, indent=1)
    print(f"{points} points, {job.count} surfels, {len(job.triangles)} triangles; wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
