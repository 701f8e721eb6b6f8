"""Re-time the benchmarks the time models come from, on the current core: every swept setting
of bench/results/accuracy_speed.json, and every leaf-size triple of
bench/results/leaf_size.json, solved again on the same surfels and timed as the original run
timed it; errors are kept (a core change that leaves the results equal to rounding changes only
the time models, which bench/calibration/calibrate.py then refits).

    .venv/bin/python bench/calibration/retime.py [--scenes bunny ...] [--only sweep|leaves]

Each re-timed solve keeps its first recorded time as ``time_before``; each file lists its runs
under ``retimed`` (date, core, seconds, scenes, points). Here (2026-12-03) the sweep took 562 s;
the leaf sizes, solved leaf after leaf for each row as bench/calibration/leaf_size.py does, about 34 min.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

# bench/ for the scenes, bench/calibration for the other calibration steps.
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import accuracy_speed as AS  # noqa: E402
from scenes import surfels as S  # noqa: E402

RESULTS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "results")


class _Surfels:
    """Each benchmark scene built once per (size, sampling), checked against the count the
    original run had (a mismatch means the scene code changed and the errors no longer hold)."""

    def __init__(self, name: str):
        self.name, self.built = name, {}

    def __call__(self, size: int, n: int, seed: int = 0):
        key = (size, seed)
        if key not in self.built:
            self.built[key] = S.build(self.name, size, seed=seed)
        q = self.built[key]
        if q.n != n:
            raise RuntimeError(f"{self.name} size {size} seed {seed}: {q.n} surfels, the run "
                               f"had {n} (scene code changed since it)")
        return q


def _timed(q, settings: dict) -> float:
    return AS.best_of_three(lambda: AS.timed_solve(q, settings))[1]


def retime(results: dict, scenes, log=print) -> int:
    """Re-time the sweep points of ``scenes`` in ``results`` (accuracy_speed.json) in place;
    returns how many."""
    count = 0
    for name in scenes:
        surfels = _Surfels(name)
        points = [p for p in results["scenes"][name]["points"]
                  if p.get("family") not in ("auto", "solver") and p.get("time") is not None
                  and p.get("settings") and p.get("size") is not None]
        for p in points:
            dt = _timed(surfels(p["size"], p["n"]), p["settings"])
            p.setdefault("time_before", p["time"])
            log(f"  {name} N={p['n']:6d} {p['label']:48s} {p['time_before']:8.3f}s -> {dt:8.3f}s")
            p["time"] = dt
            count += 1
    return count


def retime_leaves(results: dict, scenes, log=print) -> int:
    """Re-time the leaf-size rows of ``scenes`` in ``results`` (leaf_size.json) in place, the
    leaf sizes of a row one right after the other so that their ratios stay paired; returns
    how many rows."""
    count = 0
    for name in scenes:
        surfels = _Surfels(name)
        for row in results["scenes"][name]["rows"]:
            q = surfels(row["size"], row["n"], row.get("seed", 0))
            for leaf, v in row["leaves"].items():
                dt = _timed(q, dict(row["settings"], leaf_size=int(leaf)))
                v.setdefault("time_before", v["time"])
                v["time"] = dt
            log(f"  {name} seed={row.get('seed', 0)} N={row['n']:6d} {row['label']:40s} "
                + " ".join(f"L{leaf}: {v['time_before']:.3f}s -> {v['time']:.3f}s"
                           for leaf, v in row["leaves"].items()))
            count += 1
    return count


def _retime_file(path: str, fn, scenes) -> int:
    with open(path) as f:
        results = json.load(f)
    scenes = scenes or list(results["scenes"])
    t0 = time.perf_counter()
    n = fn(results, scenes, lambda s: print(s, flush=True))
    run = dict(date=S.utc_now(), core=S.provenance(), scenes=scenes, points=n,
               seconds=time.perf_counter() - t0)
    earlier = results.get("retimed", [])
    results["retimed"] = (earlier if isinstance(earlier, list) else [earlier]) + [run]
    S.write_json(path, results)
    return n


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", default=os.path.join(RESULTS, "accuracy_speed.json"))
    ap.add_argument("--leaf-results", default=os.path.join(RESULTS, "leaf_size.json"))
    ap.add_argument("--only", choices=("sweep", "leaves"), default=None)
    ap.add_argument("--scenes", nargs="+", default=None)
    args = ap.parse_args(argv)
    if args.only != "leaves":
        _retime_file(args.results, retime, args.scenes)
    if args.only != "sweep":
        _retime_file(args.leaf_results, retime_leaves, args.scenes)
    return 0


if __name__ == "__main__":
    sys.exit(main())
