"""Operator error of the FMM's visibility leaf modes against the direct exact-visibility sum.

For each scene and size: the converged direct exact-visibility radiosity x, then
``F_fmm·V x`` against ``F_direct·V x`` (relative RMS), the build time and the rays cast, for
the leaf modes "per_pair" (a partial far leaf pair keeps one sampled fraction) and
"per_pair_all" (per-pair V in every partial leaf pair), at several samples per node pair.
``--cost-only`` skips the direct reference (N² rays) and measures build, rays and blocks only,
for sizes the direct operator cannot reach.

    .venv/bin/python bench/micro/bench_leaf_modes.py [--scenes interior,cornell] [--n 6000]
        [--cost-only] [--out bench/results/leaf_modes.json]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # bench/
import illumap  # noqa: E402
from scenes import surfels as S  # noqa: E402

MODES = (("per_pair", 8), ("per_pair", 32), ("per_pair_all", 8), ("per_pair_all", 16),
         ("per_pair_all", 32))


def relative_rms(a, b) -> float:
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, 1)) / np.mean(np.sum(b ** 2, 1))))


def measure(name: str, n: int, order: int, theta: float, cost_only: bool = False) -> list[dict]:
    q = S.build(name, n)
    kw = S.exact_keywords(name)
    rows, x, exact = [], np.ones((q.n, 3)), None
    if not cost_only:
        x = illumap.solve(q, method="direct", visibility="exact", tol=1e-6, **kw).radiosity
        t = time.perf_counter()
        exact = illumap.TransportOperator(q, "direct", visibility="exact", **kw).apply(x)
        rows.append(dict(scene=name, n=q.n, mode="direct", samples=None, error=0.0,
                         seconds=time.perf_counter() - t))
    for mode, samples in MODES:
        t = time.perf_counter()
        op = illumap.TransportOperator(q, "fmm", order=order, theta=theta, visibility="exact",
                                       visibility_leaf_mode=mode, visibility_samples=samples,
                                       **kw)
        y = op.apply(x)
        st = op.stats
        rows.append(dict(scene=name, n=q.n, mode=mode, samples=samples, order=order,
                         theta=theta, error=None if exact is None else relative_rms(y, exact),
                         seconds=time.perf_counter() - t, rays=int(st["visibility_queries"]),
                         far_fractions=int(st["visibility_m2l_weighted"]),
                         blocks=int(st["visibility_p2p_blocks"]),
                         block_bytes=int(st.get("visibility_block_bytes", 0))))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="interior,cornell")
    ap.add_argument("--n", type=int, default=6000)
    ap.add_argument("--order", type=int, default=3)
    ap.add_argument("--theta", type=float, default=0.3)
    ap.add_argument("--cost-only", action="store_true")
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    rows = []
    for name in a.scenes.split(","):
        for r in measure(name, a.n, a.order, a.theta, a.cost_only):
            rows.append(r)
            label = r["mode"] if r["samples"] is None else f"{r['mode']} s={r['samples']}"
            extra = "" if r["samples"] is None else (
                f" rays {r['rays'] / 1e6:.2f}M, far fractions {r['far_fractions']}, "
                f"blocks {r['blocks']} ({r['block_bytes'] / 1e6:.1f} MB)")
            error = "–" if r["error"] is None else f"{r['error']:.4f}"
            print(f"{name} N={r['n']} {label:18s} error {error} "
                  f"build+apply {r['seconds']:.2f}s{extra}", flush=True)
    if a.out:
        S.write_json(a.out, dict(rows=rows, core=S.provenance(), date=S.utc_now()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
