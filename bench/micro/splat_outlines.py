#!/usr/bin/env python3
"""A scan's splats in the receivers' ray scene, as fans of triangles against one outline per
point (``MeshOccluders(..., splats=...)``, mesh_scene.cpp): build time, memory and the CPU
cost of closest-hit rays and shadow segments, both scenes in one process on the same rays.

The scan: jittered points on the five faces of a box open at the bottom, standing on a mesh
floor (as tests/core/test_splat_outlines.py, larger). Rays from a shell about the box towards
random points in and under it. Process CPU seconds (all threads), each measured ``--rounds``
times, the best kept; resident memory from /proc/self/statm before and after each build
(the scene of the other kind released first).

    .venv/bin/python bench/micro/splat_outlines.py                    # 60 x 60 per face: 18k points
    .venv/bin/python bench/micro/splat_outlines.py --grid 200 --rays 2000000
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import time

import numpy as np


def rss_gb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e9


def box_scan(n: int, rng) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Jittered points (n x n per face) on the unit box's faces but its bottom."""
    pts, nrm, area = [], [], []
    cell = 1.0 / n
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n)))
    for axis, value, normal in ((2, 1.0, (0, 0, 1)), (0, 0.0, (-1, 0, 0)), (0, 1.0, (1, 0, 0)),
                                (1, 0.0, (0, -1, 0)), (1, 1.0, (0, 1, 0))):
        uv = (np.column_stack([i, j]) + rng.uniform(0.1, 0.9, (n * n, 2))) * cell
        q = np.zeros((n * n, 3))
        others = [k for k in range(3) if k != axis]
        q[:, others[0]], q[:, others[1]], q[:, axis] = uv[:, 0], uv[:, 1], value
        pts.append(q)
        nrm.append(np.tile(normal, (n * n, 1)).astype(float))
        area.append(np.full(n * n, cell * cell))
    return np.concatenate(pts), np.concatenate(nrm), np.concatenate(area)


def rays(n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    o = rng.normal(size=(n, 3))
    o = 0.5 + 2.5 * o / np.linalg.norm(o, axis=1, keepdims=True)
    o[:, 2] = np.abs(o[:, 2] - 0.5) + 0.05
    d = rng.uniform([-0.2, -0.2, 0.0], [1.2, 1.2, 1.1], size=(n, 3)) - o
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def best_cpu(fn, rounds: int) -> float:
    best = np.inf
    for _ in range(rounds):
        c = time.process_time()
        fn()
        best = min(best, time.process_time() - c)
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--grid", type=int, default=60, help="points per face side")
    ap.add_argument("--rays", type=int, default=500_000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", help="write the results here (JSON)")
    args = ap.parse_args(argv)
    import illumap  # noqa: F401
    from illumap import splats
    from illumap.receivers import MeshOccluders
    rng = np.random.default_rng(1)
    pts, nrm, area = box_scan(args.grid, rng)
    tri, outlines = splats.splat_triangles(pts, nrm, area, outlines=True)
    floor = np.array([[[-1, -1, 0], [3, -1, 0], [3, 3, 0]],
                      [[-1, -1, 0], [3, 3, 0], [-1, 3, 0]]], dtype=float)
    corners = np.ascontiguousarray(np.concatenate([floor, tri]))
    del tri
    o, d = rays(args.rays, np.random.default_rng(2))
    target = o + np.random.default_rng(3).uniform(0.5, 4.0, len(o))[:, None] * d
    rows, answers = {}, {}
    for kind in ("outlines", "fans"):   # outlines first: the fans' freed pages would hide its growth
        gc.collect()
        before = rss_gb()
        c0 = time.process_time()
        occ = MeshOccluders(corners, splats=outlines if kind == "outlines" else None)
        build = time.process_time() - c0
        held = rss_gb() - before
        hits = occ.intersect(o, d)
        answers[kind] = (hits[0] >= 0, occ.visible(o, target) > 0.5)
        rows[kind] = dict(build_cpu_s=round(build, 3), rss_gb=round(held, 4),
                          intersect_cpu_s=round(best_cpu(lambda: occ.intersect(o, d), args.rounds), 3),
                          visible_cpu_s=round(best_cpu(lambda: occ.visible(o, target), args.rounds), 3))
        del occ
    f, s = rows["fans"], rows["outlines"]
    result = dict(points=len(pts), triangles=len(corners), rays=args.rays, rows=rows,
                  ratios={k: round(s[k] / f[k], 3) if f[k] else None for k in f},
                  hit_agreement=float((answers["fans"][0] == answers["outlines"][0]).mean()),
                  shadow_agreement=float((answers["fans"][1] == answers["outlines"][1]).mean()))
    print(json.dumps(result, indent=1))
    if args.out:
        with open(args.out, "w") as fh:
            json.dump(result, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
