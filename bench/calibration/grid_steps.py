#!/usr/bin/env python3
"""The Cornell grid at every cell count between two sweep sizes: how erratic its error is.

The sweep (bench/calibration/accuracy_speed.py) measures the grid at 506 / 1036 / 1927 / … surfels (wall
cells n = 9, 13, 18, …). This solves the grid at each n in ``--cells`` with the direct method
and the FMM settings that win at 5% (exact visibility), or with ``--all-settings`` with every
setting of the sweep (``--sweep``) up to the largest size the sweep ran it at; error on up to
4000 surfels against the cached 48k reference (that of ``accuracy_speed.py --full``), each
time the least of three. bench/calibration/calibrate.py adds the rows of calibrated settings to the grid
kind's curves, so that its step model can choose every cell count measured here.

    .venv/bin/python bench/calibration/grid_steps.py --all-settings --cells 9 26 \
        --out bench/results/grid_steps.json
"""
from __future__ import annotations

import argparse
import json
import os
import sys

# bench/ for the scenes, bench/calibration for the other calibration steps.
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import accuracy_speed as AS  # noqa: E402
from scenes import surfels as S  # noqa: E402

VIS = dict(visibility="exact", endpoint_offset=1.0)
ALL_PAIRS = dict(VIS, visibility_leaf_mode="per_pair_all", visibility_samples=16)
SETTINGS = {
    "direct vis=exact": dict(method="direct", **VIS),
    "FMM p=2 vis=exact all-pairs s=16 θ=0.5": dict(method="fmm", order=2, theta=0.5, **ALL_PAIRS),
    "FMM p=3 vis=exact all-pairs s=16 θ=0.3": dict(method="fmm", order=3, theta=0.3, **ALL_PAIRS),
    "FMM p=3 vis=exact all-pairs s=16 θ=0.3 leaf=16": dict(method="fmm", order=3, theta=0.3,
                                                           leaf_size=16, **ALL_PAIRS),
}


def swept_settings(path, scene="cornell"):
    """{label: (solve keywords, largest swept N)} of every hand-picked setting that the sweep
    in ``path`` ran on ``scene``."""
    with open(path) as f:
        points = json.load(f)["scenes"][scene]["points"]
    out = {}
    for p in points:
        if p["family"] in ("auto", "solver") or p.get("time") is None:
            continue
        kw, n_max = out.get(p["label"], (p["settings"], 0))
        out[p["label"]] = (kw, max(n_max, p["n"]))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cells", nargs=2, type=int, default=(12, 19),
                    help="first and last cell count per wall side (inclusive)")
    ap.add_argument("--out", default="bench/results/grid_steps.json")
    ap.add_argument("--all-settings", action="store_true",
                    help="every setting of the sweep (up to its largest swept size) as well")
    ap.add_argument("--sweep", default="bench/results/accuracy_speed.json")
    args = ap.parse_args(argv)
    settings = {label: (dict(kw, tol=AS.SOLVE_TOL), None) for label, kw in SETTINGS.items()}
    if args.all_settings:
        settings.update(swept_settings(args.sweep))
    cfg = dict(AS.FULL)
    ref, ref_B, ref_info = AS.reference("cornell", cfg, lambda s: print(s, flush=True))
    rows = []
    for cells in range(args.cells[0], args.cells[1] + 1):
        q = S.cornell(cells)
        idx = S.error_subset(q, cfg["auto_error_points"])
        B_ref = S.reference_at(ref, ref_B, S.subset(q, idx), "cornell")
        for label, (kw, n_max) in settings.items():
            if n_max is not None and q.n > n_max:
                continue
            sol, dt = AS.best_of_three(lambda: AS.timed_solve(q, kw))
            err = S.relative_rms(sol.radiosity[idx], B_ref)
            rows.append(dict(cells=cells, n=q.n, label=label, error=err, time=dt, settings=kw))
            print(f"  n={cells:3d} N={q.n:5d} {label:48s} {100 * err:6.2f}% {1e3 * dt:7.1f} ms",
                  flush=True)
    out = dict(reference=ref_info, core=S.provenance(), rows=rows, cells=list(args.cells),
               all_settings=args.all_settings,
               date=S.utc_now())
    S.write_json(args.out, out)


if __name__ == "__main__":
    main()
