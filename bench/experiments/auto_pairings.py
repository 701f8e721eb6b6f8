"""Repeat the automatic mode's time ratio against its robust best hand-picked setting: the same
two solves that bench/calibration/accuracy_speed.py paired once, paired again ``--pairings`` times (each a
set of alternating rounds, least time of each), so that a ratio near a limit can be told from
the machine's noise. Reads the pairing from bench/results/accuracy_speed.json; writes
bench/results/auto_pairings.json (one entry per scene, target and best).

    .venv/bin/python bench/experiments/auto_pairings.py [--scene bunny] [--target 0.1]
        [--pairings 8]

Point-sampled scenes only (the automatic mode on a scene's own surfels: cornell, bunny,
interior). Here (2026-12-04, core 7767883) the bunny at 10%: 1.445-1.476 over 8 pairings,
25 s; at 3%: 1.435-1.461, 143 s.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # bench/
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "calibration"))
import accuracy_speed as AS  # noqa: E402
from scenes import surfels as S  # noqa: E402

RESULTS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "results")


def best_point(name: str, auto: dict, key: str, points: list) -> dict:
    """The hand-picked sweep point ``auto[key]`` names (its label and sweep time), with its
    settings."""
    best = auto[key]
    pool = (points + AS.leaf_points(AS.LEAF_RESULTS, name)
            + AS.grid_step_points(AS.GRID_STEPS_RESULTS, name))
    for p in pool:
        if (p.get("label") == best["label"] and p.get("time") == best["sweep_time"]
                and "settings" in p):
            return p
    raise SystemExit(f"{name}: no sweep point {best['label']} with sweep time "
                     f"{best['sweep_time']} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default="bunny", choices=["cornell", "bunny", "interior"])
    ap.add_argument("--target", type=float, default=0.1)
    ap.add_argument("--pairings", type=int, default=8)
    ap.add_argument("--against", default="best_robust",
                    choices=["best_hand", "best_steady", "best_robust", "best_robust_aim"])
    args = ap.parse_args()
    with open(os.path.join(RESULTS, "accuracy_speed.json")) as f:
        data = json.load(f)
    points = data["scenes"][args.scene]["points"]
    auto = [p for p in points if p.get("family") == "auto" and p.get("target") == args.target
            and p.get("n")]
    if not auto or args.against not in auto[0]:
        raise SystemExit(f"{args.scene} at {args.target:g}: no automatic-mode point with "
                         f"{args.against} in accuracy_speed.json")
    auto = auto[0]
    best = best_point(args.scene, auto, args.against, points)
    kind = auto["chosen"]["kind"]
    q = S.build_at_least(args.scene, auto["chosen"]["n"], seed=AS.AUTO_SEED)
    qh = S.build(args.scene, best["size"], seed=AS.AUTO_SEED)
    t0 = time.perf_counter()
    rows = []
    for k in range(args.pairings):
        ta, tb = AS.paired_times(lambda: AS.timed_auto(q, args.target, kind),
                                 lambda: AS.timed_solve(qh, best["settings"]))
        rows.append(dict(auto=ta, best=tb, ratio=ta / tb))
        print(f"pairing {k}: automatic mode {ta:.4f} s, {best['label']} {tb:.4f} s, "
              f"ratio {ta / tb:.3f}", flush=True)
    ratios = [r["ratio"] for r in rows]
    out = dict(scene=args.scene, target=args.target, against=args.against,
               best=dict(label=best["label"], n=qh.n), auto_n=q.n, pairings=rows,
               ratio_min=min(ratios), ratio_median=statistics.median(ratios),
               ratio_max=max(ratios), seconds=time.perf_counter() - t0,
               date=S.utc_now(), core=S.provenance())
    print(f"ratio min {out['ratio_min']:.3f} median {out['ratio_median']:.3f} "
          f"max {out['ratio_max']:.3f} ({out['seconds']:.0f} s)")
    path = os.path.join(RESULTS, "auto_pairings.json")
    runs = {}
    if os.path.exists(path):
        with open(path) as f:
            runs = json.load(f)
    runs[f"{args.scene} {args.target:g} {args.against}"] = out
    with open(path, "w") as f:
        json.dump(runs, f, indent=1, sort_keys=True)


if __name__ == "__main__":
    main()
