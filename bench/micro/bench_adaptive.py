#!/usr/bin/env python3
"""Adaptive against uniform sampling at equal surfel count, on the Cornell box's triangles.

For each count N and setting, ``illumap.accuracy.solve_triangles(..., count=N)`` runs once with
``adaptive=True`` (half N uniformly, then N resampled denser where that solution varies) and
once with ``adaptive=False`` (one uniform pass of N); both are measured against the Cornell
box's reference (bench/calibration/accuracy_speed.py, cached) on up to ERROR_POINTS non-emitting
surfels. The ratio of the errors is what ``illumap.accuracy.ADAPTIVE_ERROR_RATIO`` rounds up;
the ratio of pass 2's solve time to the uniform pass's (same count, same settings, paired) is
``illumap.accuracy.ADAPTIVE_TIME_RATIO``'s: a density that varies packs surfels into fewer
octree cells, whose near field (per-pair visibility rays) grows.

The target is TARGET for every run, low enough that the count caps it (two passes are then
always taken), so both runs get the same solver tolerance.

    .venv/bin/python bench/micro/bench_adaptive.py [--counts 1500 3000 6000 12000] [--quick]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # bench/
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "calibration"))
from illumap import accuracy  # noqa: E402
from illumap.accuracy import calibration, models  # noqa: E402

import accuracy_speed as AS  # noqa: E402
from scenes import surfels as S  # noqa: E402

# the settings the automatic mode picks for the triangles at 10% and 5%, and the one the ratio
# was first measured with; the leaf mode is set so none inherits the chosen setting's
SETTINGS = {"direct": dict(method="direct"),
            "FMM p=3 θ=0.2": dict(method="fmm", order=3, theta=0.2,
                                  visibility_leaf_mode="per_pair"),
            "FMM p=2 θ=0.3": dict(method="fmm", order=2, theta=0.3,
                                  visibility_leaf_mode="per_pair"),
            "FMM p=2 θ=0.5": dict(method="fmm", order=2, theta=0.5,
                                  visibility_leaf_mode="per_pair"),
            "FMM p=2 all-pairs s=16 θ=0.5": dict(method="fmm", order=2, theta=0.5,
                                                 visibility_leaf_mode="per_pair_all",
                                                 visibility_samples=16)}


#: every run's target: the budget (``count``) caps the count below what it needs, so
#: solve_triangles takes two passes where asked to, and the tolerance is the same for both
TARGET = 0.03
#: error surfels per run (all of them at the smaller counts)
ERROR_POINTS = 4000
#: the direct method's largest count (its exact visibility is N² rays)
DIRECT_MAX = 6000


def predicted(label, n, scale):
    """The calibrated model's error of the sweep setting ``label`` at ``n`` surfels."""
    table = calibration.CALIBRATION["kinds"]["mesh"]
    name = {"direct": "direct vis=exact",
            "FMM p=2 all-pairs s=16 θ=0.5": "FMM p=2 vis=exact all-pairs s=16 θ=0.5"}.get(
        label, label.replace(" θ", " vis=exact θ").replace(" vis=exact θ=0.5", " vis=exact"))
    entry = table["settings"].get(name)
    return None if entry is None else models.predicted_error(entry, table, n, None, scale)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--counts", nargs="+", type=int, default=[1500, 3000, 6000, 12000])
    ap.add_argument("--quick", action="store_true", help="the quick reference (12k surfels)")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "adaptive.json"))
    args = ap.parse_args(argv)
    cfg = AS.QUICK if args.quick else AS.FULL
    ref, ref_B, ref_info = AS.reference("cornell_mesh", cfg, lambda s: print(s, flush=True))
    corners, albedo, emission, keep = S.cornell_triangles()
    rows = []
    for n in args.counts:
        for label, kw in SETTINGS.items():
            if kw["method"] == "direct" and n > DIRECT_MAX:
                continue
            out = {}
            for adaptive in (True, False):
                t = time.perf_counter()
                sol, q = accuracy.solve_triangles(corners, albedo, emission, TARGET, keep=keep,
                                                  adaptive=adaptive, count=n, estimate=False,
                                                  **kw)
                dt = time.perf_counter() - t
                passes = sol.stats["accuracy"]["passes"]
                assert len(passes) == (2 if adaptive else 1), passes
                idx = S.error_subset(q, ERROR_POINTS)
                err = S.relative_rms(sol.radiosity[idx], S.reference_at(
                    ref, ref_B, S.subset(q, idx), ref_info["scene"]))
                out["adaptive" if adaptive else "uniform"] = dict(n=q.n, error=err, time=dt,
                                                                  passes=passes)
            ratio = out["adaptive"]["error"] / out["uniform"]["error"]
            time_ratio = (out["adaptive"]["passes"][-1]["seconds"]
                          / out["uniform"]["passes"][0]["seconds"])
            model = dict(uniform=predicted(label, out["uniform"]["n"], 1.0),
                         adaptive=predicted(label, out["adaptive"]["n"],
                                            accuracy.ADAPTIVE_ERROR_RATIO))
            rows.append(dict(count=n, setting=label, ratio=ratio, time_ratio=time_ratio,
                             model=model, **out))
            shown = "  ".join(f"model {k} {v:.4f}" for k, v in model.items() if v is not None)
            print(f"N={n:6d} {label:28s} uniform {out['uniform']['error']:.4f} "
                  f"({out['uniform']['time']:.2f}s)  adaptive {out['adaptive']['error']:.4f} "
                  f"({out['adaptive']['time']:.2f}s)  ratio {ratio:.2f}  pass-2 time ratio "
                  f"{time_ratio:.2f}  {shown}", flush=True)
    S.write_json(args.out, dict(reference=ref_info, core=S.provenance(), target=TARGET,
                                error_points=ERROR_POINTS, rows=rows, date=S.utc_now()))


if __name__ == "__main__":
    main()
