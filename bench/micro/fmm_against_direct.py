#!/usr/bin/env python3
"""Distance of one FMM visibility setting's solution to the direct exact-visibility solution
of the same surfels, as N grows (Cornell box): whether what the node-pair visibility model adds
converges with N, which the automatic mode's extrapolation assumes it does not
(``illumap.accuracy.models.setting_error``).

    .venv/bin/python bench/micro/fmm_against_direct.py
"""
from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # bench/
import illumap  # noqa: E402

from scenes import surfels as S  # noqa: E402

SETTINGS = {"all-pairs s=16 θ=0.3": dict(order=3, theta=0.3, visibility_leaf_mode="per_pair_all",
                                         visibility_samples=16),
            "default leaf mode θ=0.5": dict(order=2, theta=0.5)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", nargs="+", type=int, default=[2000, 4000, 8000])
    args = ap.parse_args(argv)
    for size in args.sizes:
        q = S.build("cornell", size)
        kw = dict(visibility="exact", **S.exact_keywords("cornell"))
        direct = illumap.solve(q, method="direct", tol=1e-7, **kw).radiosity
        for label, setting in SETTINGS.items():
            fmm = illumap.solve(q, method="fmm", tol=1e-7, **setting, **kw).radiosity
            d = S.relative_rms(fmm, direct, q.emission)
            print(f"cornell N={q.n:6d} FMM {label:24s} against direct: {100 * d:.2f}%",
                  flush=True)


if __name__ == "__main__":
    main()
