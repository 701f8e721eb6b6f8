#!/usr/bin/env python3
"""The light at a dense scan's points: the Cornell box's walls and blocks as grids of
``--cell`` m, their vertices given as one point cloud without normals (the light kept as a
mesh), at default settings, each ``--gather-cache`` value in turn on the same prepared job.

Reports the run's phases (sampling, solve, receivers), the rays the receivers cast and, for
each value after the first, the relative RMS difference of the points' values from the first
one's (a unit check of the cache against the gather it stands for, not an accuracy figure:
the bench scans' Cycles comparisons are those).

    .venv/bin/python bench/micro/scan_receivers.py [--cell 0.02] [--gather-cache 0 0.15]

Writes bench/results/scan_receivers.json (``--out``).
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

OUT = os.path.join(REPO, "bench", "results", "scan_receivers.json")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cell", type=float, default=0.02, help="scan spacing, m (0.02: 123k "
                    "points, 0.01: 486k)")
    ap.add_argument("--gather-cache", type=float, nargs="+", default=[0.15])
    ap.add_argument("--out", default=OUT)
    args = ap.parse_args(argv)
    pipeline = run.register_addon()
    objects, spans = run.scan_objects(scenes.cornell_scan(args.cell))
    points = sum(count for _, count in spans.values())
    depsgraph = bpy.context.evaluated_depsgraph_get()
    rows, first = [], None
    for cache in args.gather_cache:
        settings = run.make_settings(pipeline, dict(gather_cache=cache))
        job = pipeline.prepare(depsgraph, objects, settings)
        t0 = time.perf_counter()
        result = pipeline.run(job)
        seconds = time.perf_counter() - t0
        values = next(iter(result.point_receiver_values.values()))
        if first is None:
            first, difference = values, None
        else:
            difference = float(np.sqrt(((values - first) ** 2).sum() / (first ** 2).sum()))
        receivers = result.stats["receivers"]
        row = dict(gather_cache=cache, run_s=round(seconds, 2),
                   receivers_s=round(result.timings["receivers"], 2),
                   solve_s=round(result.timings["solve"], 2), rays=int(receivers["rays"]),
                   difference_from_first=difference)
        rows.append(row)
        print(f"gather cache {cache:g}: run {seconds:.1f} s, receivers {row['receivers_s']:.1f} s, "
              f"{row['rays'] / 1e6:.1f}M rays"
              + ("" if difference is None else f", {100 * difference:.2f}% from the first"),
              flush=True)
    commit = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    with open(args.out, "w") as f:
        json.dump(dict(blender=bpy.app.version_string, commit=commit, cell=args.cell,
                       points=points, date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                       rows=rows), f, indent=1)
    print(f"{points} points; wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
