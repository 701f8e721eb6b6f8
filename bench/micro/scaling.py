#!/usr/bin/env python3
"""Time and peak memory of a full solve against N (log-log), with fitted slopes.

Cases (scene, method, visibility), each size in its own subprocess so that its peak RSS
(``ru_maxrss``) is its own; the time is the wall time of ``illumap.solve`` (operator build + CG
to 1e-4), with the build and solve phases recorded apart. FMM: order p=3, theta=0.5.

* ``cornell`` (bench/scenes/surfels.py, the box with its two blocks, grid surfels), FMM, no
  visibility: 10k up to 4M surfels (--full).
* ``cornell``, FMM, exact visibility against the box's own mesh (``exact-mesh``: 10,368
  triangles, ``scenes.cornell_surface``, given as ``occluder_triangles`` as the add-on gives a
  mesh scene's triangles): up to 1M (2M with --full).
* ``cornell``, FMM, exact visibility against occluder discs made from the surfels (``exact``:
  what the core does for points without a surface, e.g. ``illumap.solve(visibility="exact")``
  with no triangles): up to 1M.
* ``interior`` (``illumap.scenes.box_room``: random surfels, a box, a sphere and a tilted
  panel), FMM, no visibility: up to 1M. Its curved and tilted surfaces put a growing share of
  pairs in the near field (the far field cannot carry the ``max(0, cos)`` clamp where a
  surface's tangent plane cuts another surface), so its slope is steeper; see
  docs/benchmarks.md.
* ``cornell``, direct O(N^2), no visibility: up to --direct-max.

A case stops at its first size that fails or times out. Slopes are fitted by least squares on
log N / log t over the sizes >= 100k that ran (all sizes if fewer than two). Each point also
records the process's CPU seconds (``build_cpu``, ``total_cpu``: all threads), steadier than
wall time when other jobs share the cores. ``--sizes`` replaces the mode's sizes for the
selected cases, e.g. the exact-visibility slope from 100k to 1M alone:

    .venv/bin/python bench/micro/scaling.py --only cornell/fmm/exact --sizes 100000 300000 1000000 \
        --out bench/results/scaling_exact_1m.json

    .venv/bin/python bench/micro/scaling.py --quick --out bench/results/scaling.json
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

BENCH = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, BENCH)

QUICK = dict(cases=[("cornell", "fmm", "none", (10_000, 30_000, 100_000, 300_000, 1_000_000)),
                    ("cornell", "fmm", "exact-mesh",
                     (10_000, 30_000, 100_000, 300_000, 1_000_000)),
                    ("cornell", "fmm", "exact", (10_000, 30_000, 100_000, 300_000)),
                    ("interior", "fmm", "none", (10_000, 30_000, 100_000, 300_000)),
                    ("cornell", "direct", "none", (10_000, 30_000))])
FULL = dict(cases=[("cornell", "fmm", "none",
                    (10_000, 30_000, 100_000, 300_000, 1_000_000, 2_000_000, 4_000_000)),
                   ("cornell", "fmm", "exact-mesh",
                    (10_000, 30_000, 100_000, 300_000, 1_000_000, 2_000_000)),
                   ("cornell", "fmm", "exact", (10_000, 30_000, 100_000, 300_000, 1_000_000,
                                                2_000_000)),
                   ("interior", "fmm", "none", (10_000, 30_000, 100_000, 300_000, 1_000_000)),
                   ("cornell", "direct", "none", (10_000, 30_000, 60_000))])
ORDER, THETA, TOL = 3, 0.5, 1e-4
FIT_MIN_N = 100_000

CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, sys.argv[7])
import illumap
from scenes import surfels as S
n, scene, method, order, theta, tol, vis = (int(sys.argv[1]), sys.argv[2], sys.argv[3],
                                            int(sys.argv[4]), float(sys.argv[5]),
                                            float(sys.argv[6]), sys.argv[8])
s = S.build(scene, n, seed=1)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
if vis == "none":
    kw = {}
elif vis == "exact-mesh":
    kw = dict(visibility="exact", occluder_triangles=S.cornell_surface())
else:
    kw = dict(visibility=vis, **S.exact_keywords(scene))
c = time.process_time()
t = time.perf_counter()
op = illumap.TransportOperator(s, method=method, order=order, theta=theta, **kw)
t_build = time.perf_counter() - t
c_build = time.process_time() - c
sol = illumap.solve(s, operator=op, tol=tol)
t_total = time.perf_counter() - t
c_total = time.process_time() - c
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
st = op.stats
print(json.dumps(dict(n=s.n, scene=scene, method=method, visibility=vis, build=t_build,
                      total=t_total, solve=t_total - t_build, build_cpu=c_build,
                      total_cpu=c_total, iterations=sol.iterations,
                      applications=sol.stats.get("operator_applications"),
                      converged=bool(sol.converged), peak_rss=peak * 1024,
                      rss_before_build=base * 1024, operator_bytes=st.get("bytes"),
                      p2p_pairs=st.get("p2p_pairs"), m2l_pairs=st.get("m2l_pairs"))))
"""


def run_one(scene, n, method, vis, timeout):
    cmd = [sys.executable, "-c", CHILD, str(n), scene, method, str(ORDER), str(THETA), str(TOL),
           BENCH, vis]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return dict(n=n, scene=scene, method=method, visibility=vis,
                    error=f"timed out after {timeout}s")
    if out.returncode != 0:
        tail = (out.stderr.strip().splitlines() or ["exit %d" % out.returncode])[-1]
        return dict(n=n, scene=scene, method=method, visibility=vis, error=tail)
    return json.loads(out.stdout.strip().splitlines()[-1])


def slope(points, key):
    """Least-squares slope of log(key) against log(n) over sizes >= FIT_MIN_N (all sizes when
    fewer than two)."""
    every = [p for p in points if p.get(key)]
    ok = [p for p in every if p["n"] >= FIT_MIN_N]
    if len(ok) < 2:
        ok = every
    if len(ok) < 2:
        return None
    x = np.log([p["n"] for p in ok])
    y = np.log([p[key] for p in ok])
    return float(np.polyfit(x, y, 1)[0])


def case_key(scene, method, vis):
    return f"{scene}/{method}/{vis}"


def main(argv=None):
    from scenes import surfels as S
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true")
    mode.add_argument("--full", action="store_true")
    ap.add_argument("--timeout", type=int, default=600, help="seconds per size")
    ap.add_argument("--only", nargs="*", default=None,
                    help="case keys scene/method/visibility to run (default: all)")
    ap.add_argument("--sizes", nargs="*", type=int, default=None,
                    help="sizes N to run for the selected cases instead of the mode's")
    ap.add_argument("--out", default="bench/results/scaling.json")
    args = ap.parse_args(argv)
    cfg = dict(FULL if args.full else QUICK)
    t0 = time.perf_counter()
    prov = S.provenance()
    points = []
    for scene, method, vis, sizes in cfg["cases"]:
        if args.only is not None and case_key(scene, method, vis) not in args.only:
            continue
        for n in (args.sizes or sizes):
            r = run_one(scene, n, method, vis, args.timeout)
            r.update(commit=prov["commit"], core_module_built=prov["core_module_built"],
                     date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()))
            points.append(r)
            if "error" in r:
                print(f"{case_key(scene, method, vis)} N={n}: {r['error']}", flush=True)
                break
            print(f"{case_key(scene, method, vis):24s} N={r['n']:8d} total={r['total']:8.2f}s "
                  f"build={r['build']:7.2f}s (CPU {r['total_cpu']:.1f} / {r['build_cpu']:.1f} s) "
                  f"it={r['iterations']} "
                  f"peak={r['peak_rss'] / 2**20:8.1f} MiB", flush=True)
    fits = {}
    for scene, method, vis, _ in cfg["cases"]:
        ok = [p for p in points if "error" not in p and p["scene"] == scene
              and p["method"] == method and p["visibility"] == vis]
        if ok:
            fits[case_key(scene, method, vis)] = dict(
                time=slope(ok, "total"), build=slope(ok, "build"), solve=slope(ok, "solve"),
                memory=slope(ok, "peak_rss"), largest=max(p["n"] for p in ok))
    print("fitted log-log slopes:", json.dumps(fits, indent=1))
    results = dict(mode="full" if args.full else "quick", order=ORDER, theta=THETA, tol=TOL,
                   fit_min_n=FIT_MIN_N, timeout=args.timeout,
                   cases=[case_key(*c[:3]) for c in cfg["cases"]], points=points, slopes=fits,
                   machine=dict(platform=platform.platform(), cpus=os.cpu_count()),
                   core=S.provenance(), date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                   wall_time=time.perf_counter() - t0)
    if args.only is not None and os.path.exists(args.out):   # merge into the existing file
        with open(args.out) as f:
            old = json.load(f)
        keep = [p for p in old.get("points", [])
                if case_key(p.get("scene", "interior"), p["method"], p.get("visibility", "none"))
                not in args.only]
        results["points"] = keep + points
        results["slopes"] = {**{k: v for k, v in old.get("slopes", {}).items()
                                if k not in args.only}, **fits}
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(results, f, indent=1)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
