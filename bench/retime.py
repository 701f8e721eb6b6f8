"""Re-time the accuracy sweep on the current core: every swept setting solved again on the
same surfels (the sweep's sampling), timed as the sweep times it, and its time replaced in
bench/results/accuracy_speed.json; errors are kept (a core change that leaves the results equal
to rounding changes only the time models, which bench/calibrate.py then refits).

    .venv/bin/python bench/retime.py [--scenes bunny ...] [--results bench/results/accuracy_speed.json]

Each re-timed point keeps its previous time as ``time_before``; the file records the run under
``retimed`` (date, core, seconds, scenes). The full sweep took 562 s here (2026-12-03).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import accuracy_speed as AS  # noqa: E402
import scenes as S  # noqa: E402


def retime(results: dict, scenes, log=print) -> int:
    """Re-time the sweep points of ``scenes`` in ``results`` in place; returns how many."""
    count = 0
    for name in scenes:
        built = {}
        points = [p for p in results["scenes"][name]["points"]
                  if p.get("family") not in ("auto", "solver") and p.get("time") is not None
                  and p.get("settings") and p.get("size") is not None]
        for p in points:
            if p["size"] not in built:
                built[p["size"]] = S.build(name, p["size"])
            q = built[p["size"]]
            if q.n != p["n"]:
                raise RuntimeError(f"{name} size {p['size']}: {q.n} surfels, the sweep had "
                                   f"{p['n']} (scene code changed since the sweep)")
            _, dt = AS.best_of_three(lambda: AS.timed_solve(q, p["settings"]))
            p.setdefault("time_before", p["time"])
            log(f"  {name} N={q.n:6d} {p['label']:48s} {p['time_before']:8.3f}s -> {dt:8.3f}s")
            p["time"] = dt
            count += 1
    return count


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                      "results", "accuracy_speed.json"))
    ap.add_argument("--scenes", nargs="+", default=None)
    args = ap.parse_args(argv)
    with open(args.results) as f:
        results = json.load(f)
    scenes = args.scenes or list(results["scenes"])
    t0 = time.perf_counter()
    n = retime(results, scenes, lambda s: print(s, flush=True))
    results["retimed"] = dict(date=S.utc_now(), core=S.provenance(), scenes=scenes, points=n,
                              seconds=time.perf_counter() - t0)
    S.write_json(args.results, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
