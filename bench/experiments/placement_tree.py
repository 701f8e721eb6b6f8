#!/usr/bin/env python3
"""The octree's placement independence (issue 57, item 5), and what it costs in accuracy and time.

Three parts, each run in this process on the core installed in the virtual environment:

``placement``  A room-like scene with and without one tiny surfel (1 cm², albedo 0.5) 1e2 … 1e8 m
               away (its two triangles join the occluder triangles where the scene has them):
               max over the room's surfels and channels of |B_far − B| / max(B of the
               non-emitting surfels). Scenes: the plate of tests/core/test_placement.py (no
               visibility), bench interior (random room) without and with exact visibility (discs),
               bench Cornell box with exact visibility against its triangles. FMM p 4, θ 0.5,
               CG to 1e-8.
``accuracy``   bench Cornell and interior at a couple of sizes, FMM p 4 θ 0.5 exact visibility
               (the scenes' exact keywords): relative RMS error against ``reference_solution``
               of the same surfels (direct O(N²) with exact visibility, CG 1e-9), and the
               least wall time of ``illumap.solve`` (operator build + solve) over ``--repeat`` runs.
``build``      1M surfels of bench/micro/bench_fmm.py's box room: tree, lists and apply times
               (``Operator.stats``), no visibility, p 4 θ 0.5, and the application's error on
               500 receivers.
``cache``      The irradiance cache (``illumap.irradiance_cache.cached_gather``) over a floor and a
               wall (two groups, a smooth made-up radiance), with and without a third group of
               300 receivers 1e4 m away: max |difference| / max at the room's receivers. (Its
               grid's origin, first cell and spacing come from every group's receivers.)

    .venv/bin/python bench/experiments/placement_tree.py placement accuracy build --out x.json
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))
sys.path.insert(0, os.path.join(HERE, "..", "micro"))
import illumap  # noqa: E402
from scenes import surfels as S  # noqa: E402

FAR = (1e2, 1e4, 1e6, 1e8)
FMM = dict(method="fmm", order=4, theta=0.5)


def plate_scene():
    def grid(n, z, normal, size=1.0):
        u = np.arange(n) / n
        x, y = np.meshgrid(u, u)
        jitter = np.random.default_rng(n).random((2, n * n)) / n
        pos = np.column_stack([(x.ravel() + jitter[0] - 0.5) * size,
                               (y.ravel() + jitter[1] - 0.5) * size, np.full(n * n, z)])
        return pos, np.tile([0.0, 0.0, normal], (n * n, 1)), np.full(n * n, (size / n) ** 2)
    parts = [grid(24, 0.0, 1.0, 2.0), grid(24, 0.5, -1.0), grid(24, 0.5, 1.0)]
    pos, nrm, area = (np.concatenate([p[i] for p in parts]) for i in range(3))
    emission = np.zeros((len(pos), 3))
    emission[:576] = 1.0
    albedo = np.full((len(pos), 3), 0.8)
    albedo[:576] = 0.0
    return illumap.Surfels(pos, nrm, area, albedo, emission)


def rewrap(s):
    """``s`` as Surfels made again from its arrays (Surfels normalises the normals it is given,
    and doing it twice can move their last bit: the scenes compared must be made alike)."""
    return illumap.Surfels(s.positions, s.normals, s.areas, s.albedo, s.emission)


def with_far(s, far, triangles=None):
    """``s`` with one 1 cm² surfel ``far`` metres away along a generic direction (facing +z),
    and the triangles with its two triangles."""
    c = np.median(s.positions, axis=0) + far * np.array([0.8, 0.36, 0.48])
    out = illumap.Surfels(np.vstack([s.positions, c]), np.vstack([s.normals, [0.0, 0.0, 1.0]]),
                          np.append(s.areas, 1e-4), np.vstack([s.albedo, [0.5] * 3]),
                          np.vstack([s.emission, [0.0] * 3]))
    if triangles is None:
        return out, None
    h = 0.01
    quad = np.array([[[0, 0, 0], [h, 0, 0], [h, h, 0]], [[0, 0, 0], [h, h, 0], [0, h, 0]]]) + c
    return out, np.concatenate([triangles, quad])


def placement(log):
    cases = [("plate", plate_scene(), {}, None)]
    room = S.build("interior", 4000)
    cases.append(("interior-none", room, {}, None))
    cases.append(("interior-exact", room, dict(visibility="exact", **S.exact_keywords("interior")),
                  None))
    cb = S.build("cornell", 4000)
    cases.append(("cornell-exact-triangles", cb,
                  dict(visibility="exact", **S.exact_keywords("cornell")), S.cornell_surface()))
    out = []
    for name, s, kw, tri in cases:
        kw = dict(FMM, **kw)
        extra = {} if tri is None else dict(occluder_triangles=tri)
        base = np.asarray(illumap.solve(rewrap(s), tol=1e-8, **kw, **extra).radiosity)
        lit = ~(s.emission.max(axis=1) > 0)
        ref = base[lit].max()
        row = dict(scene=name, n=s.n, far={})
        for far in FAR:
            q, t2 = with_far(s, far, tri)
            extra = {} if t2 is None else dict(occluder_triangles=t2)
            got = np.asarray(illumap.solve(q, tol=1e-8, **kw, **extra).radiosity)[:-1]
            d = np.abs(got - base)
            rms = float(np.sqrt((d ** 2).mean() / (base[lit] ** 2).mean()))
            row["far"][f"{far:g}"] = dict(max=float(d.max() / ref), rms=rms,
                                          identical=int((d == 0).all(axis=1).sum()))
            log(f"  {name:26s} N={s.n:5d} far {far:8.0e}: max {d.max() / ref:.2e} "
                f"rms {row['far'][f'{far:g}']['rms']:.2e} bit-identical surfels "
                f"{row['far'][f'{far:g}']['identical']}/{s.n}")
        out.append(row)
    return out


def reference(name, s, seed):
    """``reference_solution`` of these surfels, cached in $ILLUMAP_BENCH_CACHE (by scene, size
    and sampling), so that the trees compared are measured against the same reference (the
    direct operator sums every pair; only its rays' direction follows the tree's order)."""
    cache = os.environ.get("ILLUMAP_BENCH_CACHE", "/tmp/illumap_bench_cache")
    os.makedirs(cache, exist_ok=True)
    path = os.path.join(cache, f"placement_ref_{name}_{s.n}_{seed}.npy")
    if os.path.exists(path):
        return np.load(path)
    B = np.asarray(S.reference_solution(s, name).radiosity)
    np.save(path, B)
    return B


def accuracy(log, sizes, repeat, seeds):
    out = []
    for name in ("cornell", "interior"):
        for seed in (seeds if name == "interior" else (0,)):
            for n in sizes:
                s = S.build(name, n, seed=seed)
                ref = reference(name, s, seed)
                row = dict(scene=name, n=s.n, seed=seed)
                for vis in ("exact", "none"):
                    kw = dict(FMM, visibility=vis,
                              **(S.exact_keywords(name) if vis == "exact" else {}))
                    best = np.inf
                    for _ in range(repeat if vis == "exact" else 1):
                        t = time.perf_counter()
                        sol = illumap.solve(s, **kw)
                        best = min(best, time.perf_counter() - t)
                    if vis == "exact":
                        err = S.relative_rms(np.asarray(sol.radiosity), ref, s.emission)
                        st = illumap.TransportOperator(s, **kw).stats
                        row.update(error=err, time=best, iterations=sol.iterations,
                                   nodes=int(st["nodes"]), depth=int(st["depth"]),
                                   m2l_pairs=int(st["m2l_pairs"]), p2p_pairs=int(st["p2p_pairs"]),
                                   queries=int(st.get("visibility_queries", 0)))
                    else:
                        # the expansions' own error: against the direct operator without
                        # visibility, one application of K to the emission
                        e = np.ascontiguousarray(s.emission)
                        y = np.asarray(illumap.TransportOperator(s, **kw).apply(e))
                        yd = np.asarray(illumap.TransportOperator(s, method="direct").apply(e))
                        row["error_none_apply"] = float(np.linalg.norm(y - yd) / np.linalg.norm(yd))
                log(f"  {name:9s} seed {seed} N={s.n:6d} exact: err {row['error']:.3e} "
                    f"solve {row['time']:.3f}s it {row['iterations']} nodes {row['nodes']} "
                    f"depth {row['depth']} m2l {row['m2l_pairs']} p2p {row['p2p_pairs']} "
                    f"rays {row['queries']}; none: K(E) err {row['error_none_apply']:.2e}")
                out.append(row)
    return out


def build(log, n):
    """Operator set-up and one application at n surfels of bench_fmm's room (no visibility),
    and the application's relative error on 500 random receivers (exact ``apply_rows``)."""
    import bench_fmm
    from illumap import _core
    p, nrm, a = bench_fmm.box_room(n)
    x = np.random.default_rng(0).random((n, 3))
    rows = np.sort(np.random.default_rng(1).choice(n, 500, replace=False)).astype(np.int64)
    out = []
    for _ in range(2):
        t = time.perf_counter()
        op = _core.Operator(p, nrm, a, method="fmm", order=4, theta=0.5)
        total = time.perf_counter() - t
        st = op.stats
        t = time.perf_counter()
        y = np.asarray(op.apply(x))
        ta = time.perf_counter() - t
        if not out:
            exact = np.asarray(op.apply_rows(x, rows))
            err = float(np.linalg.norm(y[rows] - exact) / np.linalg.norm(exact))
        row = dict(n=n, construct=total, tree=st["time_build_tree"], lists=st["time_build_lists"],
                   apply=ta, error=err, nodes=int(st["nodes"]), depth=int(st["depth"]),
                   m2l_pairs=int(st["m2l_pairs"]), p2p_pairs=int(st["p2p_pairs"]))
        log(f"  build N={n}: construct {total:.2f}s tree {row['tree']:.3f}s lists "
            f"{row['lists']:.2f}s apply {ta:.2f}s error {err:.2e} nodes {row['nodes']} "
            f"depth {row['depth']} m2l {row['m2l_pairs']} p2p {row['p2p_pairs']}")
        out.append(row)
        del op
    return out


def cache(log):
    from illumap.irradiance_cache import cached_gather
    from illumap.receivers import GatherResult
    rng = np.random.default_rng(0)
    floor = np.column_stack([rng.random(3000) * 4, rng.random(3000) * 3, np.zeros(3000)])
    wall = np.column_stack([np.zeros(1500), rng.random(1500) * 3, rng.random(1500) * 2.5])
    P = np.vstack([floor, wall])
    N = np.vstack([np.tile([0, 0, 1.0], (3000, 1)), np.tile([1.0, 0, 0], (1500, 1))])
    G = np.r_[np.zeros(3000, int), np.ones(1500, int)]
    far = np.column_stack([1e4 + rng.random(300) * 0.5, rng.random(300) * 0.5, np.zeros(300)])

    def run(P, N, G, max_reach):
        def gather_rows(rows, rays=None):
            f = 1.0 / (1.0 + np.sum((P[rows] - [2, 1.5, 2.5]) ** 2, axis=1))
            return GatherResult(radiance=np.column_stack([f, f, f]),
                                stderr=np.full(len(rows), 1e-3), rays=len(rows) * 64,
                                reach=np.full(len(rows), 1.5))
        return cached_gather(gather_rows, P, N, max_reach=max_reach, groups=G).radiance
    a = run(P, N, G, 5.0)
    b = run(np.vstack([P, far]), np.vstack([N, np.tile([0, 0, 1.0], (300, 1))]),
            np.r_[G, np.full(300, 2)], 1e4)[:len(P)]
    d = float(np.abs(a - b).max() / a.max())
    log(f"  irradiance cache, 300 receivers 1e4 m away: room max |difference| / max {d:.2e}")
    return dict(max=d)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("parts", nargs="+", choices=("placement", "accuracy", "build", "cache"))
    ap.add_argument("--sizes", type=int, nargs="+", default=(2000, 8000))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seeds", type=int, nargs="+", default=(0,))
    ap.add_argument("--build-n", type=int, default=1_000_000)
    ap.add_argument("--out")
    args = ap.parse_args()
    log = lambda m: print(m, flush=True)  # noqa: E731
    doc = dict(octree=os.environ.get("ILLUMAP_OCTREE", "default"))
    if "placement" in args.parts:
        doc["placement"] = placement(log)
    if "accuracy" in args.parts:
        doc["accuracy"] = accuracy(log, args.sizes, args.repeat, args.seeds)
    if "build" in args.parts:
        doc["build"] = build(log, args.build_n)
    if "cache" in args.parts:
        doc["cache"] = cache(log)
    if args.out:
        with open(args.out, "w") as f:
            json.dump(doc, f, indent=1)


if __name__ == "__main__":
    main()
