#!/usr/bin/env python3
"""Benchmark of the native FMM transport operator against the exact direct sum.

Scene: random surfels on a closed box room (4 x 4 x 3, normals into the room) with three boxes
inside (outward normals, five faces each). For each size N, order p and opening angle theta it
reports tree/list build time, apply time, relative error against the direct operator (full
direct at N <= --full-direct, else the exact sum on --subset random receivers via apply_rows),
peak RSS of the process running the configuration (each configuration runs in its own
subprocess), and the FMM/direct time ratio (direct time estimated from apply_rows timing).
All figures come from this run on this machine; compare ratios, not absolute times.

    python bench/micro/bench_fmm.py --sizes 10000 100000 1000000 --orders 2 3 4 --thetas 0.5 \
        --out bench.json
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOM = (4.0, 4.0, 3.0)
BOXES = [((0.5, 0.6, 0.0), (1.5, 1.8, 1.2)), ((2.4, 2.2, 0.0), (3.3, 3.4, 0.7)),
         ((2.5, 0.5, 0.8), (3.2, 1.2, 1.6))]  # (min corner, max corner); the last one floats


def _faces():
    """(origin, edge u, edge v, normal) for every sampled face."""
    faces = []
    X, Y, Z = ROOM
    # room: normals into the room
    faces += [((0, 0, 0), (X, 0, 0), (0, Y, 0), (0, 0, 1)),
              ((0, 0, Z), (X, 0, 0), (0, Y, 0), (0, 0, -1)),
              ((0, 0, 0), (0, Y, 0), (0, 0, Z), (1, 0, 0)),
              ((X, 0, 0), (0, Y, 0), (0, 0, Z), (-1, 0, 0)),
              ((0, 0, 0), (X, 0, 0), (0, 0, Z), (0, 1, 0)),
              ((0, Y, 0), (X, 0, 0), (0, 0, Z), (0, -1, 0))]
    for (a, b) in BOXES:
        ax, ay, az = a
        bx, by, bz = b
        dx, dy, dz = bx - ax, by - ay, bz - az
        faces += [((ax, ay, bz), (dx, 0, 0), (0, dy, 0), (0, 0, 1)),
                  ((ax, ay, az), (0, dy, 0), (0, 0, dz), (-1, 0, 0)),
                  ((bx, ay, az), (0, dy, 0), (0, 0, dz), (1, 0, 0)),
                  ((ax, ay, az), (dx, 0, 0), (0, 0, dz), (0, -1, 0)),
                  ((ax, by, az), (dx, 0, 0), (0, 0, dz), (0, 1, 0))]
        if az > 0:  # a floating box shows its bottom too
            faces.append(((ax, ay, az), (dx, 0, 0), (0, dy, 0), (0, 0, -1)))
    return [tuple(np.array(v, float) for v in f) for f in faces]


def box_room(n, seed=0):
    """n random surfels (positions, normals, areas), uniform by area over all faces."""
    rng = np.random.default_rng(seed)
    faces = _faces()
    areas = np.array([np.linalg.norm(np.cross(u, v)) for (_, u, v, _) in faces])
    which = rng.choice(len(faces), size=n, p=areas / areas.sum())
    s, t = rng.random(n), rng.random(n)
    O = np.array([f[0] for f in faces])[which]
    U = np.array([f[1] for f in faces])[which]
    V = np.array([f[2] for f in faces])[which]
    Nrm = np.array([f[3] for f in faces])[which]
    P = O + s[:, None] * U + t[:, None] * V
    A = np.full(n, areas.sum() / n)
    return np.ascontiguousarray(P), np.ascontiguousarray(Nrm), A


def _reference(n, seed, subset, cache):
    """Exact y on the receivers `rows` (all receivers if subset == 0), cached per N and per
    build of the native module (a rebuilt kernel must not be compared with an old reference)."""
    from illumap import _core
    stat = os.stat(_core.__file__)
    build = f"{stat.st_size:x}{int(stat.st_mtime):x}"
    path = os.path.join(cache, f"ref_{n}_{seed}_{subset}_{build}.npz")
    if os.path.exists(path):
        z = np.load(path)
        return z["rows"], z["y"], float(z["t"])
    P, N, A = box_room(n, seed)
    x = np.random.default_rng(seed + 1).random((n, 3))
    op = _core.Operator(P, N, A, method="direct")
    rows = (np.arange(n, dtype=np.int64) if subset == 0 else
            np.sort(np.random.default_rng(seed + 2).choice(n, subset, replace=False)).astype(np.int64))
    t0 = time.perf_counter()
    y = op.apply_rows(x, rows)
    t = (time.perf_counter() - t0) * n / len(rows)  # direct apply time, scaled to all rows
    np.savez(path, rows=rows, y=y, t=t)
    return rows, y, t


def worker(n, p, theta, leaf, seed, subset, cache):
    from illumap import _core
    rows, yref, tdirect = _reference(n, seed, subset, cache)
    P, N, A = box_room(n, seed)
    x = np.random.default_rng(seed + 1).random((n, 3))
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    op = _core.Operator(P, N, A, method="fmm", order=p, theta=theta, leaf_size=leaf)
    tbuild = time.perf_counter() - t0
    t0 = time.perf_counter()
    y = op.apply(x)
    tapply = time.perf_counter() - t0
    err = float(np.linalg.norm(y[rows] - yref) / np.linalg.norm(yref))
    st = op.stats
    return dict(n=n, order=p, theta=theta, leaf_size=leaf, build_s=tbuild, apply_s=tapply,
                rel_error=err, direct_s=tdirect, ratio=tdirect / tapply,
                peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                rss_before_mb=rss0 / 1024, us_per_surfel=1e6 * tapply / n,
                m2l_pairs=st["m2l_pairs"], p2p_pairs=st["p2p_pairs"], nodes=st["nodes"],
                depth=st["depth"], bytes=st["bytes"],
                phases={k[5:]: v for k, v in st.items() if k.startswith("time_")})


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--orders", type=int, nargs="+", default=[0, 2, 3, 4, 6, 8])
    ap.add_argument("--thetas", type=float, nargs="+", default=[0.3, 0.5, 0.7])
    ap.add_argument("--leaf-size", type=int, nargs="+", default=[32])
    ap.add_argument("--subset", type=int, default=1000, help="receivers for the exact reference")
    ap.add_argument("--full-direct", type=int, default=20_000,
                    help="use every receiver as reference up to this N")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "illumap_bench"))
    ap.add_argument("--out", default=None, help="write the results as JSON here")
    ap.add_argument("--worker", nargs=5, help=argparse.SUPPRESS)
    a = ap.parse_args()
    os.makedirs(a.cache, exist_ok=True)
    if a.worker:
        n, p, th, leaf, sub = a.worker
        print(json.dumps(worker(int(n), int(p), float(th), int(leaf), a.seed, int(sub), a.cache)))
        return
    results = []
    print("| N | p | θ | leaf | build s | apply s | rel. error | direct s (est.) | direct/FMM | "
          "peak RSS MB | µs/surfel | M2L pairs | P2P pairs |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in a.sizes:
        sub = 0 if n <= a.full_direct else a.subset
        for leaf in a.leaf_size:
            for th in a.thetas:
                for p in a.orders:
                    cmd = [sys.executable, os.path.abspath(__file__), "--seed", str(a.seed),
                           "--cache", a.cache, "--worker", str(n), str(p), str(th), str(leaf),
                           str(sub)]
                    out = subprocess.run(cmd, capture_output=True, text=True)
                    if out.returncode != 0:
                        print(f"| {n} | {p} | {th} | {leaf} | failed: {out.stderr.strip()[-200:]} |")
                        continue
                    r = json.loads(out.stdout.strip().splitlines()[-1])
                    results.append(r)
                    print(f"| {n} | {p} | {th} | {leaf} | {r['build_s']:.2f} | {r['apply_s']:.3f} | "
                          f"{r['rel_error']:.2e} | {r['direct_s']:.1f} | {r['ratio']:.0f} | "
                          f"{r['peak_rss_mb']:.0f} | {r['us_per_surfel']:.2f} | {r['m2l_pairs']} | "
                          f"{r['p2p_pairs']} |", flush=True)
    # time-per-surfel growth 100k -> 1M for matching settings
    growth = []
    by = {(r["n"], r["order"], r["theta"], r["leaf_size"]): r for r in results}
    for (n, p, th, leaf), r in sorted(by.items()):
        if n == 1_000_000 and (100_000, p, th, leaf) in by:
            g = r["us_per_surfel"] / by[(100_000, p, th, leaf)]["us_per_surfel"]
            growth.append(dict(order=p, theta=th, leaf_size=leaf, growth=g))
            print(f"time per surfel 100k -> 1M (p={p}, θ={th}, leaf={leaf}): × {g:.2f}")
    if a.out:
        with open(a.out, "w") as f:
            json.dump(dict(results=results, growth=growth), f, indent=1)


if __name__ == "__main__":
    main()
