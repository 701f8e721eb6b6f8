#!/usr/bin/env python3
"""Where a dense scan's time goes: the Cornell box scanned at ``--cell`` m (as
bench/scaling_scans.py builds it), prepared and run at default settings under cProfile.
Prints the run's phases, its CPU seconds and the top functions by own and cumulative time
(CPU seconds of all threads; native calls show as the Python functions that enter them).

    .venv/bin/python bench/micro/scan_profile.py --cell 0.01 [--top 40] [--out prof.txt]
    .venv/bin/python bench/micro/scan_profile.py --cell 0.007 --prepare-only   # 990k, prepare
"""
from __future__ import annotations

import argparse
import cProfile
import io
import os
import pstats
import sys
import time

BENCH = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REPO = os.path.dirname(BENCH)
sys.path.insert(0, REPO)
sys.path.insert(0, BENCH)


def _logged_gathers() -> list:
    """Each ``Gatherer.gather`` call's receivers, rays, rays cast and seconds, in order."""
    from illumap import receivers
    calls, inner = [], receivers.Gatherer.gather

    def gather(self, positions, normals, *, rays, **kw):
        c0, t0 = time.process_time(), time.perf_counter()
        g = inner(self, positions, normals, rays=rays, **kw)
        r = rays if __import__("numpy").ndim(rays) == 0 else "per"
        calls.append((len(positions), r, g.rays, time.perf_counter() - t0,
                      time.process_time() - c0))
        return g
    receivers.Gatherer.gather = gather
    return calls


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cell", type=float, default=0.01)
    ap.add_argument("--top", type=int, default=40)
    ap.add_argument("--out", default=None, help="also write the report here")
    ap.add_argument("--prepare-only", action="store_true",
                    help="profile only pipeline.prepare (the scan's normals, kNN, splats, BVH)")
    args = ap.parse_args(argv)
    import bpy
    from reference import run
    from scenes import blender as scenes
    pipeline = run.register_addon()
    objects, spans = run.scan_objects(scenes.cornell_scan(args.cell))
    points = sum(count for _, count in spans.values())
    depsgraph = bpy.context.evaluated_depsgraph_get()
    settings = run.make_settings(pipeline, {})
    calls = _logged_gathers()
    prof = cProfile.Profile(time.process_time)   # CPU seconds, all threads: the machine is shared
    c0, t0 = time.process_time(), time.perf_counter()
    prof.enable()
    job = pipeline.prepare(depsgraph, objects, settings)
    c1 = time.process_time()
    if args.prepare_only:
        prof.disable()
        return _report_prepare(prof, points, c1 - c0, time.perf_counter() - t0, args)
    result = pipeline.run(job)
    prof.disable()
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    out = io.StringIO()
    print(f"points {points}  wall {wall:.1f} s  cpu {cpu:.1f} s  (prepare cpu {c1 - c0:.1f} s)"
          f"  load {os.getloadavg()[0]:.2f}", file=out)
    for k, v in result.timings.items():
        print(f"  {k:40s} {v:8.2f}", file=out)
    rec = result.stats.get("receivers", {})
    print(f"rays {rec.get('rays')}  records {rec.get('cache_records')}", file=out)
    print("gathers (receivers, rays, rays cast, wall s, cpu s):", file=out)
    for row in calls:
        print("  %9d %5s %11d %7.2f %7.2f" % row, file=out)
    return _finish(prof, out, args)


def _report_prepare(prof, points: int, cpu: float, wall: float, args) -> int:
    """Print (and write to ``--out``) the prepare phase's CPU seconds and top functions."""
    out = io.StringIO()
    print(f"points {points}  prepare wall {wall:.1f} s  cpu {cpu:.1f} s"
          f"  load {os.getloadavg()[0]:.2f}", file=out)
    return _finish(prof, out, args)


def _finish(prof, out: io.StringIO, args) -> int:
    """Append the profile's top functions (own and cumulative time) to ``out``, print it and
    write it to ``--out``."""
    stats = pstats.Stats(prof, stream=out)
    stats.sort_stats("tottime").print_stats(args.top)
    stats.sort_stats("cumulative").print_stats(args.top)
    text = out.getvalue()
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
