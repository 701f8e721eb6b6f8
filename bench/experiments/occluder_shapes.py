#!/usr/bin/env python3
"""Occluder shape, paired: the automatic mode's own settings with discs, quads and octagons.

For every automatic-mode row of bench/results/accuracy_speed.json (scenes with surfels of
their own: the Cornell grid, the bunny, the room) whose solve took at most ``--max-seconds``,
the chosen solve keywords are run on the same surfels (the automatic mode's samplings) with
``visibility_shape`` "disc" (the default, what the models are calibrated on), "quad" and
"octagon", one right after the other; error on 4000 surfels against the scene's cached full
reference (as accuracy_speed.py), time the least of three. What a default shape other than
the disc would change, before any re-calibration.

    .venv/bin/python bench/experiments/occluder_shapes.py --out bench/results/occluder_shapes.json
"""
from __future__ import annotations

import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # bench/
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "calibration"))
import accuracy_speed as AS  # noqa: E402
from scenes import surfels as S  # noqa: E402

SHAPES = ("disc", "quad", "octagon")
SCENES = ("cornell", "bunny", "interior")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", default="bench/results/accuracy_speed.json")
    ap.add_argument("--max-seconds", type=float, default=2.0)
    ap.add_argument("--out", default="bench/results/occluder_shapes.json")
    args = ap.parse_args(argv)
    with open(args.results) as f:
        acc = json.load(f)
    cfg = dict(AS.FULL)
    rows = []
    for name in SCENES:
        autos = [p for p in acc["scenes"][name]["points"] if p["family"] == "auto"
                 and p.get("time") and p["time"] <= args.max_seconds]
        if not autos:
            continue
        ref, ref_B, ref_info = AS.reference(name, cfg, lambda s: print(s, flush=True))
        for p in autos:
            for seed in AS.auto_seeds(name):
                q = S.build_at_least(name, p["chosen"]["n"], seed=seed)
                idx = S.error_subset(q, cfg["auto_error_points"])
                B_ref = S.reference_at(ref, ref_B, S.subset(q, idx), ref_info["scene"])
                row = dict(scene=name, target=p["target"], seed=seed, n=q.n,
                           label=p["chosen"]["label"], shapes={})
                for shape in SHAPES:
                    kw = dict(p["settings"], visibility_shape=shape)
                    sol, dt = AS.best_of_three(lambda: AS.timed_solve(q, kw))
                    row["shapes"][shape] = dict(error=S.relative_rms(sol.radiosity[idx], B_ref),
                                                time=dt)
                rows.append(row)
                print(f"  {name} {p['target']:g} sampling {seed} N={q.n}: " + "  ".join(
                    f"{k} {100 * v['error']:.2f}% {1e3 * v['time']:.1f} ms"
                    for k, v in row["shapes"].items()), flush=True)
    S.write_json(args.out, dict(results=args.results, core=S.provenance(), rows=rows,
                                date=S.utc_now()))


if __name__ == "__main__":
    main()
