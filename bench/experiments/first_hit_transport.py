#!/usr/bin/env python3
"""What a first-hit transport would give the white furnace: each surfel's row of the operator
built from its own hemisphere rays (the 64 that ``illumap.conservation.hemisphere_hits``
already casts), each ray sending its weight 1/64 to the surfel at its first hit, in place of
the kernel's row scaled to the share (the shipped ``scale_rows``).

A diagnostic, not the product: it replaces ``illumap.solve`` inside the add-on's pipeline for
one run of ``bench/reference/furnace.py``'s cases against their cached Cycles references, so
that the receivers (the final gather) see surfel values that no coupling leaks into.

Why (measured 2026-12-07 at dc35611): in the Suzanne furnace, 147 of 3,661 vertices that
Cycles bakes below 0.3 (mean 0.016: the slivers between the eyes and their sockets and the
head's inside, sealed) hold 79% of the squared error; Illumap reads them 0.975. Rays from
them meet back faces only (none open), but the surfels there read 0.97: the kernel couples
them to lit surfels across the eyes' intersection lines, and at albedo 0.999 a sealed region
that leaks a share ε of its light reads about ε/(ε + 0.001), so a leak of 1% reads 0.9. The
first-hit rows cannot leak where the rays do not, as long as a hit is given to a surfel on
its own side of the surface it hit: the surfel is taken among the ``--knn`` nearest whose
normal faces the hit side (cos > 0.3) and that the hit point sees (a segment lifted
``occluders.offset`` off both surfaces); a hit without one sends nothing.

    .venv/bin/python bench/experiments/first_hit_transport.py --cases monkey resting
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, REPO_ROOT)
sys.path.insert(0, os.path.join(REPO_ROOT, "bench"))

import bpy  # noqa: E402,F401  (before illumap: the bpy module's libraries load first)
from reference import furnace  # noqa: E402
from reference import run as reference_run  # noqa: E402

RAYS = 64
SIDE_COS = 0.3


def first_hit_rows(job, knn: int):
    """(rows, cols) of every ray that met a surfel (weight 1/RAYS each) and the open share
    (N,) of each surfel, from the job's hemisphere rays."""
    from scipy.spatial import cKDTree
    from addon import pipeline
    from illumap import receivers as rc
    from illumap.gather.ids import gather_sides, surfel_ids
    from illumap.stages.scene import with_occluders
    scene = with_occluders(pipeline.to_scene(job))
    occ = scene.occluders
    p, n = job.positions, job.normals
    ids = surfel_ids(scene)
    tri_all = job.triangles
    tn = np.cross(tri_all[:, 1] - tri_all[:, 0], tri_all[:, 2] - tri_all[:, 0])
    tn /= np.linalg.norm(tn, axis=1)[:, None]
    sides = gather_sides(scene)
    tree = cKDTree(p)
    rows, cols, open_ = [], [], np.zeros(len(p))
    for s0 in range(0, len(p), 8192):
        s1 = min(len(p), s0 + 8192)
        d = rc.cosine_directions(n[s0:s1], RAYS, ids[s0:s1], job.settings.seed + 0x51ED)
        d = d.reshape(-1, 3)
        o = np.repeat(p[s0:s1] + occ.offset * n[s0:s1], RAYS, axis=0)
        tri, dist, front = occ.intersect(o, d)
        src = np.repeat(np.arange(s0, s1), RAYS)
        met = tri >= 0
        open_[s0:s1] = (~met).reshape(-1, RAYS).mean(axis=1)
        t, f = tri[met], front[met]
        hit = o[met] + dist[met, None] * d[met]
        side = np.where(f[:, None], tn[t], -tn[t])
        _, near = tree.query(hit, k=knn)
        ok = np.einsum("mkc,mc->mk", n[near], side) > SIDE_COS
        lifted = np.repeat(hit + occ.offset * side, knn, axis=0)
        target = (p[near] + occ.offset * n[near]).reshape(-1, 3)
        cand = np.flatnonzero(ok.ravel())
        seen = np.zeros(ok.size, dtype=bool)
        seen[cand] = occ.visible(lifted[cand], target[cand]) > 0.5
        ok &= seen.reshape(ok.shape)
        first = np.argmax(ok, axis=1)
        has = ok[np.arange(len(ok)), first]
        lit = f | (np.asarray(sides)[t] if sides is not None else True)
        keep = has & lit
        rows.append(src[met][keep])
        cols.append(near[np.arange(len(ok)), first][keep])
    return np.concatenate(rows), np.concatenate(cols), open_


def patch_solve(knn: int) -> None:
    """``illumap.solve`` replaced by a solve of B = E + ρ W B with the first-hit rows W."""
    import illumap
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla
    from addon import pipeline
    state = {}
    light = pipeline.light

    def capture(job, progress=None):
        state["job"] = job
        return light(job, progress)

    def solve(surfels, **_):
        r, c, _ = first_hit_rows(state["job"], knn)
        W = sp.csr_matrix((np.full(len(r), 1.0 / RAYS), (r, c)), shape=(surfels.n, surfels.n))
        B = np.zeros_like(surfels.emission)
        for ch in range(3):
            A = sp.eye(surfels.n) - sp.diags(surfels.albedo[:, ch]) @ W
            B[:, ch], _ = sla.gmres(A, surfels.emission[:, ch], rtol=1e-8, restart=100,
                                    maxiter=2000)
        return illumap.Solution(B, 0, np.zeros(1), True, {}, {"solver": "first-hit"})

    pipeline.light = capture
    illumap.solve = solve


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", nargs="+", default=["monkey"], choices=list(furnace.CASES))
    ap.add_argument("--knn", type=int, default=32)
    args = ap.parse_args()
    reference_run.register_addon()
    patch_solve(args.knn)
    for name in args.cases:
        case = furnace.build(name)
        samples = min(furnace.DEFAULT_SAMPLES, case.max_samples or furnace.DEFAULT_SAMPLES)
        ref = furnace.load_reference(case, samples, furnace.illumap_albedo())
        if ref is None:
            print(f"{name}: no cached reference (run bench/reference/furnace.py first)")
            continue
        values_ref, _ = furnace.reference_values(case, ref)
        case = furnace.build(name)
        values, result, seconds = furnace.run_illumap(case)
        row = furnace.score(case, values, values_ref, result)
        print(f"{name}: first-hit rel. RMS {row['relative_rms']:.4f}, mean ratio "
              f"{row['mean_ratio']:.4f}, max {row['max']:.4f}, above {furnace.ABOVE}: "
              f"{row['above']:.2%} ({seconds:.1f} s)")
        for obj, o in row["objects"].items():
            print(f"    {obj:10s} rel. RMS {o['relative_rms']:.4f} mean {o['mean']:.4f} (Cycles "
                  f"{o['mean_reference']:.4f}); worst {o['worst']:.3f} against "
                  f"{o['worst_reference']:.3f} at {o['worst_at']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
