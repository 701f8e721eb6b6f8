#!/usr/bin/env python3
"""Exact visibility at scale: the Cornell grid's surfels occluded by the box's own 32 triangles
(``occluder_triangles``) against occluder discs, build and solve timed, each in this process.

    .venv/bin/python bench/micro/scaling_triangles.py 100000 1000000

Measured 2026-12-04 (2 cores, FMM order 4, θ 0.5, tol 1e-4; one run each): 100k surfels 2.2 s
(triangles) against 2.7 s (discs); 1M surfels 41 s (build 7.2 s, 1.06 GB) against 81 s
(build 37 s, 1.22 GB; those two each in a process of its own: ``peak_gb`` is the process's peak
so far); six iterations each, mean radiosity equal to 0.1%.
"""

from __future__ import annotations

import json
import os
import resource
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # bench/
import illumap  # noqa: E402

import scenes as S  # noqa: E402


def box_triangles() -> np.ndarray:
    """The Cornell box's quads (bench/scenes.py) as triangles (T, 3, 3), metres."""
    tris = []
    for q in S.cornell_geometry():
        o, u, v = (np.asarray(q[k], dtype=np.float64) for k in ("origin", "u", "v"))
        tris += [[o, o + u, o + u + v], [o, o + u + v, o + v]]
    return np.array(tris)


def run(n: int, occluders: str) -> dict:
    """Build and solve the Cornell grid at about ``n`` surfels with ``occluders`` 'triangles'
    or 'discs'; times in seconds."""
    s = S.build("cornell", n, seed=1)
    kw = dict(visibility="exact")
    if occluders == "triangles":
        kw["occluder_triangles"] = box_triangles()
    else:
        kw.update(S.exact_keywords("cornell"))
    t = time.perf_counter()
    op = illumap.TransportOperator(s, method="fmm", order=4, theta=0.5, **kw)
    build = time.perf_counter() - t
    sol = illumap.solve(s, operator=op, tol=1e-4)
    total = time.perf_counter() - t
    return dict(n=s.n, occluders=occluders, build=round(build, 2), total=round(total, 2),
                iterations=sol.iterations, converged=bool(sol.converged),
                peak_gb=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20, 2),
                mean_radiosity=float(sol.radiosity.mean()))


if __name__ == "__main__":
    for size in [int(a) for a in sys.argv[1:]] or [100_000]:
        for kind in ("triangles", "discs"):
            print(json.dumps(run(size, kind)), flush=True)
