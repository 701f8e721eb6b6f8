#!/usr/bin/env python3
"""The Cornell grid at every cell count between two sweep sizes: how erratic its error is.

The sweep (bench/accuracy_speed.py) measures the grid at 506 / 1036 / 1927 / … surfels (wall
cells n = 9, 13, 18, …); the automatic mode's step model can only choose those. This solves
the grid at each n in ``--cells`` with the direct method and the FMM settings that win at
5% (exact visibility), error on up to 4000 surfels against the cached 48k reference (that of
``accuracy_speed.py --full``), each time the least of three.

    .venv/bin/python bench/grid_steps.py --out bench/results/grid_steps.json
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

VIS = dict(visibility="exact", endpoint_offset=1.0)
ALL_PAIRS = dict(VIS, visibility_leaf_mode="per_pair_all", visibility_samples=16)
SETTINGS = {
    "direct vis=exact": dict(method="direct", **VIS),
    "FMM p=2 vis=exact all-pairs s=16 θ=0.5": dict(method="fmm", order=2, theta=0.5, **ALL_PAIRS),
    "FMM p=3 vis=exact all-pairs s=16 θ=0.3": dict(method="fmm", order=3, theta=0.3, **ALL_PAIRS),
    "FMM p=3 vis=exact all-pairs s=16 θ=0.3 leaf=16": dict(method="fmm", order=3, theta=0.3,
                                                           leaf_size=16, **ALL_PAIRS),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cells", nargs=2, type=int, default=(12, 19),
                    help="first and last cell count per wall side (inclusive)")
    ap.add_argument("--out", default="bench/results/grid_steps.json")
    args = ap.parse_args(argv)
    cfg = dict(AS.FULL)
    ref, ref_B, ref_info = AS.reference("cornell", cfg, lambda s: print(s, flush=True))
    rows = []
    for cells in range(args.cells[0], args.cells[1] + 1):
        q = S.cornell(cells)
        idx = S.error_subset(q, cfg["auto_error_points"])
        B_ref = S.reference_at(ref, ref_B, S.subset(q, idx), "cornell")
        for label, kw in SETTINGS.items():
            sol, dt = AS.best_of_three(lambda: AS.timed_solve(q, dict(kw, tol=AS.SOLVE_TOL)))
            err = S.relative_rms(sol.radiosity[idx], B_ref)
            rows.append(dict(cells=cells, n=q.n, label=label, error=err, time=dt))
            print(f"  n={cells:3d} N={q.n:5d} {label:48s} {100 * err:6.2f}% {1e3 * dt:7.1f} ms",
                  flush=True)
    out = dict(reference=ref_info, core=S.provenance(), rows=rows,
               date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()))
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(out, f, indent=1, default=float)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
