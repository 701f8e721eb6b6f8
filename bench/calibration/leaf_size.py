#!/usr/bin/env python3
"""Leaf size against the default 32, paired: the same surfels, the same run.

For every FMM setting the automatic mode can choose (bench/calibration/accuracy_speed.py's FMM settings at
p ≤ 4 with visibility "none" or "exact"), on each benchmark scene at the sweep's sizes and on
``--samplings`` samplings (the grid scene has one), the setting is solved with leaves of 16, 32
and 64 surfels, one right after the other, and for each leaf size the error and the wall time
(best of 3 under 0.5 s) are recorded. Error: against the scene's reference (as in
accuracy_speed.py) with visibility "exact"; with visibility "none", whose error against that
reference is the missing occlusion, the FMM's own error against the direct solution without
visibility on the same surfels (sizes up to the sweep's ``direct_max``).

bench/calibration/calibrate.py turns the pairs into each setting's leaf variants: an error factor (the
largest ratio error(leaf) / error(32) over sizes and samplings) and time ratios against N. A
paired ratio does not carry the sampling noise (±10–15% between samplings at equal N) that
fitting each leaf size's own error curve did.

    .venv/bin/python bench/calibration/leaf_size.py --full --out bench/results/leaf_size.json
"""
from __future__ import annotations

import os
import sys
import time

# bench/ for the scenes, bench/calibration for the other calibration steps.
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import illumap  # noqa: E402

import accuracy_speed as A  # noqa: E402
from scenes import surfels as S  # noqa: E402

LEAF_SIZES = (16, 32, 64)
BASE_LEAF = 32
#: Samplings of the random scenes (the sweep's is 0; the automatic mode's benchmark uses
#: A.AUTO_SEED, kept out of the calibration).
SEEDS = (0, 2)


def leaf_settings(name, visibilities):
    """The sweep's FMM settings at p <= 4 without seed visibility: (label, keywords)."""
    out = []
    for family, label, kw in A.settings(A.ORDERS, visibilities, name):
        if family == "solver" or kw["method"] != "fmm" or kw["order"] > 4:
            continue
        if kw.get("visibility", "none") not in ("none", "exact"):
            continue
        out.append((label, kw))
    return out


def run_scene(name, cfg, visibilities, samplings, log, labels=None):
    ref, ref_B, ref_info = A.reference(name, cfg, log)
    sizes = cfg["sizes"][name] if isinstance(cfg["sizes"], dict) else cfg["sizes"]
    seeds = SEEDS[:samplings] if name != "cornell" else SEEDS[:1]
    rows = []
    chosen = [(l, kw) for l, kw in leaf_settings(name, visibilities)
              if labels is None or l in labels]
    for seed in seeds:
        for n in sizes:
            q = S.build(name, n, seed=seed)
            idx = S.error_subset(q, cfg["error_points"])
            B_ref = S.reference_at(ref, ref_B, S.subset(q, idx), ref_info["scene"])
            B_plain = None
            for label, kw in chosen:
                vis = kw.get("visibility", "none")
                if vis == "none":
                    if q.n > cfg["direct_max"]:
                        continue
                    if B_plain is None:
                        B_plain = illumap.solve(q, method="direct", tol=1e-7).radiosity[idx]
                    against = B_plain
                else:
                    against = B_ref
                row = dict(scene=name, label=label, n=q.n, size=n, seed=seed,
                           error_against="direct vis=none" if vis == "none" else "reference",
                           settings=dict(kw), leaves={})
                for leaf in LEAF_SIZES:
                    sol, dt = A.best_of_three(
                        lambda: A.timed_solve(q, dict(kw, leaf_size=leaf)))
                    row["leaves"][str(leaf)] = dict(
                        time=dt, error=S.relative_rms(sol.radiosity[idx], against),
                        iterations=sol.iterations)
                rows.append(row)
                base = row["leaves"][str(BASE_LEAF)]
                log(f"  {name} seed={seed} N={q.n:6d} {label:36s} "
                    + " ".join(f"L{leaf}: {v['time']:.3f}s {v['error']:.4f}"
                               f" ({v['time'] / base['time']:.2f}x,"
                               f" {v['error'] / max(base['error'], 1e-12):.2f})"
                               for leaf, v in ((int(k), v) for k, v in row["leaves"].items())))
    return dict(reference=ref_info, rows=rows)


def main(argv=None):
    ap = A.mode_parser(__doc__, full_help="the full sweep's sizes")
    ap.add_argument("--scenes", nargs="+", default=list(S.SCENES), choices=S.SCENES)
    ap.add_argument("--samplings", type=int, default=len(SEEDS), choices=range(1, len(SEEDS) + 1))
    ap.add_argument("--out", default="bench/results/leaf_size.json")
    ap.add_argument("--merge", action="store_true",
                    help="replace only the scenes run in an existing --out file, keep the others")
    args = ap.parse_args(argv)
    cfg = A.config(args)
    visibilities, _ = A.available_visibilities()
    results = dict(mode="full" if args.full else "quick", leaf_sizes=list(LEAF_SIZES),
                   base_leaf=BASE_LEAF, seeds=list(SEEDS[:args.samplings]),
                   solve_tol=A.SOLVE_TOL, core=S.provenance(),
                   date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), scenes={})
    t0 = time.perf_counter()
    partial = args.out + ".partial"
    for name in args.scenes:
        results["scenes"][name] = run_scene(name, cfg, visibilities, args.samplings,
                                            lambda s: print(s, flush=True))
        S.write_json(partial, results, quiet=True)
    A.write_results(results, args.out, t0, merge=args.merge)


if __name__ == "__main__":
    main()
