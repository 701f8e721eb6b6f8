#!/usr/bin/env python3
"""Time and peak memory of a full solve against N (log-log), with the fitted slope.

Scene: ``illumap.scenes.box_room(N)`` (random surfels in a room with a box, a sphere and a
panel). Each (method, N) runs in its own subprocess so that its peak RSS (``ru_maxrss``) is its
own; the time is the wall time of ``illumap.solve`` (operator build + CG to 1e-4) and the
build and solve phases are recorded apart. FMM: order p=3, theta=0.5 (the Pareto choice at
1-3% on the benchmarks); the direct operator up to --direct-max.

    .venv/bin/python bench/scaling.py --quick --out bench/results/scaling.json
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time

import numpy as np

QUICK = dict(sizes=(10_000, 30_000, 100_000, 300_000), direct_max=30_000)
FULL = dict(sizes=(10_000, 30_000, 100_000, 300_000, 1_000_000, 2_000_000), direct_max=60_000)
ORDER, THETA, TOL = 3, 0.5, 1e-4

CHILD = r"""
import json, resource, sys, time
import illumap
from illumap import scenes
n, method, order, theta, tol = int(sys.argv[1]), sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
s = scenes.box_room(n, seed=1)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t = time.perf_counter()
op = illumap.TransportOperator(s, method=method, order=order, theta=theta)
t_build = time.perf_counter() - t
sol = illumap.solve(s, operator=op, tol=tol)
t_total = time.perf_counter() - t
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps(dict(n=s.n, method=method, build=t_build, total=t_total,
                      solve=t_total - t_build, iterations=sol.iterations,
                      converged=bool(sol.converged), peak_rss=peak * 1024,
                      rss_before_solve=base * 1024,
                      operator_bytes=op.stats.get("bytes"))))
"""


def run_one(n, method, timeout):
    cmd = [sys.executable, "-c", CHILD, str(n), method, str(ORDER), str(THETA), str(TOL)]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return dict(n=n, method=method, error=f"timed out after {timeout}s")
    if out.returncode != 0:
        return dict(n=n, method=method, error=out.stderr.strip().splitlines()[-1:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def slope(points, key):
    every = [p for p in points if key in p and p.get(key)]
    ok = [p for p in every if p["n"] >= 30_000]
    if len(ok) < 2:
        ok = every
    if len(ok) < 2:
        return None
    x = np.log([p["n"] for p in ok])
    y = np.log([p[key] for p in ok])
    return float(np.polyfit(x, y, 1)[0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true")
    mode.add_argument("--full", action="store_true")
    ap.add_argument("--timeout", type=int, default=900, help="seconds per size")
    ap.add_argument("--out", default="bench/results/scaling.json")
    args = ap.parse_args(argv)
    cfg = dict(FULL if args.full else QUICK)
    t0 = time.perf_counter()
    points = []
    for method in ("fmm", "direct"):
        for n in cfg["sizes"]:
            if method == "direct" and n > cfg["direct_max"]:
                continue
            r = run_one(n, method, args.timeout)
            points.append(r)
            if "error" in r:
                print(f"{method} N={n}: {r['error']}", flush=True)
                break
            print(f"{method:6s} N={r['n']:8d} total={r['total']:8.2f}s build={r['build']:6.2f}s "
                  f"iterations={r['iterations']} peak={r['peak_rss'] / 2**20:8.1f} MiB",
                  flush=True)
    fits = {m: dict(time=slope([p for p in points if p["method"] == m and "error" not in p],
                               "total"),
                    memory=slope([p for p in points if p["method"] == m and "error" not in p],
                                 "peak_rss"))
            for m in ("fmm", "direct")}
    print("fitted log-log slopes:", fits)
    results = dict(mode="full" if args.full else "quick", config=cfg, order=ORDER, theta=THETA,
                   tol=TOL, points=points, slopes=fits,
                   machine=dict(platform=platform.platform(), cpus=os.cpu_count()),
                   date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                   wall_time=time.perf_counter() - t0)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(results, f, indent=1)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
