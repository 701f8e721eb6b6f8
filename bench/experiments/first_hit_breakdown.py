#!/usr/bin/env python3
"""Where a white-furnace case's squared error lies, vertex by vertex (a diagnostic).

Runs ``bench/reference/furnace.py``'s case against its cached Cycles reference and splits the
summed squared error (the numerator of the relative RMS) by object, by the reference's value
(sealed 0, contact 0.5/0.75 means of a POINT bake, lit 1), by height above the floor, and
lists the worst vertices with their position, Illumap's value and the reference's; the arrays
go to out/breakdown/<case>.npz.

    .venv/bin/python bench/experiments/first_hit_breakdown.py intersecting resting monkey

``--split LO HI`` adds, for the vertices of the first scored mesh whose reference lies in
[LO, HI), a re-gather independent of Illumap's ray engine (Blender's BVH): cosine rays about
each corner's normal from the vertex, as Cycles bakes it, those below the corner's triangle
dropped, the sky 1 where they leave, and at a front hit the reference's (or Illumap's) vertex
values interpolated across the hit triangle (a back hit: 0, a closed part's inside). Where
the re-gather from the reference's values matches the reference but the one from Illumap's
values matches Illumap, the rays are right and the light they gather is not.

    .venv/bin/python bench/experiments/first_hit_breakdown.py --split 0.7 0.8 monkey
"""

from __future__ import annotations

import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "reference"))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))

from reference import furnace, bake  # noqa: E402


def breakdown(name: str, samples: int = furnace.DEFAULT_SAMPLES, worst: int = 25,
              save: str | None = None) -> dict:
    """Print the case's error breakdown; returns the arrays (got, ref, positions, owner)."""
    case = furnace.build(name)
    if case.max_samples:
        samples = min(samples, case.max_samples)
    ref = furnace.load_reference(case, samples, furnace.illumap_albedo())
    if ref is None:
        raise SystemExit(f"{name}: no cached reference at {samples} samples")
    ref_values, noise = furnace.reference_values(case, ref)
    case = furnace.build(name)
    values, result, seconds = furnace.run_illumap(case)
    got, owner = furnace._stack(case, values)
    pos = np.concatenate([bake.vertex_positions(o)[bake.baked_vertices(o)]
                          for o in case.scene.scored])
    err2 = (got - ref_values) ** 2
    total = err2.sum()
    denom = (ref_values ** 2).sum()
    print(f"\n== {name}: rel. RMS {np.sqrt(total / denom):.4f} ({len(got)} points, "
          f"{seconds:.2f} s, noise {noise:.5f})")
    print("  by object:")
    for k, obj in enumerate(case.scene.scored):
        m = owner == k
        print(f"    {obj.name:12s} share {err2[m].sum() / total:6.1%}  "
              f"rms-contrib {np.sqrt(err2[m].sum() / denom):.4f}  points {m.sum()}")
    print("  by reference value:")
    for lo, hi in ((-1, 0.05), (0.05, 0.45), (0.45, 0.55), (0.55, 0.7), (0.7, 0.8),
                   (0.8, 0.95), (0.95, 2)):
        m = (ref_values >= lo) & (ref_values < hi)
        if m.any():
            print(f"    ref in [{max(lo, 0):.2f},{hi:.2f}) points {m.sum():6d} share "
                  f"{err2[m].sum() / total:6.1%} mean got {got[m].mean():.4f} ref "
                  f"{ref_values[m].mean():.4f}")
    print("  by height z:")
    for lo, hi in ((-1, 0.005), (0.005, 0.05), (0.05, 0.2), (0.2, 10)):
        m = (pos[:, 2] >= lo) & (pos[:, 2] < hi)
        if m.any():
            print(f"    z in [{lo:.3f},{hi:.3f}) points {m.sum():6d} share "
                  f"{err2[m].sum() / total:6.1%} mean signed {np.mean(got[m] - ref_values[m]):+.4f}")
    order = np.argsort(-err2)[:worst]
    print(f"  worst {worst}: object, position, got, ref")
    for i in order:
        print(f"    {case.scene.scored[owner[i]].name:10s} {np.round(pos[i], 3)} "
              f"{got[i]:.3f} {ref_values[i]:.3f}")
    out = dict(got=got, ref=ref_values, pos=pos, owner=owner)
    if save:
        np.savez(save, **out)
    return out


def first_hit_split(name: str, got: np.ndarray, ref: np.ndarray, lo: float, hi: float,
                    rays: int = 128, albedo: float = 0.999, seed: int = 1) -> dict:
    """The re-gather of ``--split`` (module docstring) over the first scored mesh's vertices
    whose reference lies in [lo, hi): means of the reference, of Illumap, of the re-gathers
    from each one's vertex values, and the shares of rays dropped below the face and open."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree
    case = furnace.build(name)
    verts, tris, start = [], [], 0
    for obj in case.scene.scored:
        mesh = obj.data
        mesh.calc_loop_triangles()
        verts.append(bake.vertex_positions(obj))
        tris.append(np.array([t.vertices[:] for t in mesh.loop_triangles]) + start)
        start += len(verts[-1])
    v, t = np.concatenate(verts), np.concatenate(tris)
    if len(v) != len(got):
        raise SystemExit(f"{name}: --split needs every vertex baked")
    tn = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    tn /= np.linalg.norm(tn, axis=1, keepdims=True)
    bvh = BVHTree.FromPolygons([Vector(p) for p in v], [tuple(map(int, k)) for k in t],
                               epsilon=0.0)
    mesh = case.scene.scored[0].data
    loop_vertex = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", loop_vertex)
    normals = np.empty(len(mesh.loops) * 3)
    mesh.corner_normals.foreach_get("vector", normals)
    normals = normals.reshape(-1, 3)
    first = {}                 # a corner's triangle: the first that holds it, as a bake takes
    for k, tri in enumerate(mesh.loop_triangles):
        for loop in tri.loops:
            first.setdefault(loop, k)
    rng = np.random.default_rng(seed)
    chosen = np.flatnonzero((ref[:len(verts[0])] >= lo) & (ref[:len(verts[0])] < hi))
    out = np.zeros((len(chosen), 4))          # from the reference, from Illumap, drop, sky
    for row, vi in enumerate(chosen):
        loops = np.flatnonzero(loop_vertex == vi)
        for loop in loops:
            face, n = tn[first[int(loop)]], normals[loop]
            u = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
            u /= np.linalg.norm(u)
            w = np.cross(n, u)
            r1, r2 = rng.random(rays), 2 * np.pi * rng.random(rays)
            dirs = ((np.sqrt(r1) * np.cos(r2))[:, None] * u + (np.sqrt(r1) * np.sin(r2))[:, None]
                    * w + np.sqrt(1 - r1)[:, None] * n)
            for d in dirs:
                if d @ face <= 0.0:
                    out[row, 2] += 1
                    continue
                hit, _, k, _ = bvh.ray_cast(Vector(v[vi] + 1e-6 * face + 1e-6 * d), Vector(d))
                if k is None:
                    out[row, [0, 1, 3]] += 1
                elif d @ tn[k] < 0.0:                    # a front face
                    b = _barycentric(v[t[k]], np.array(hit))
                    out[row, 0] += b @ ref[t[k]]
                    out[row, 1] += b @ got[t[k]]
        out[row] /= len(loops) * rays
    out[:, :2] *= albedo
    result = dict(vertices=len(chosen), reference=float(ref[chosen].mean()),
                  illumap=float(got[chosen].mean()), from_reference=float(out[:, 0].mean()),
                  from_illumap=float(out[:, 1].mean()), dropped=float(out[:, 2].mean()),
                  sky=float(out[:, 3].mean()))
    print(f"  split of the {len(chosen)} vertices with reference in [{lo}, {hi}): reference "
          f"{result['reference']:.4f}, re-gathered from it {result['from_reference']:.4f}; "
          f"Illumap {result['illumap']:.4f}, re-gathered from it {result['from_illumap']:.4f} "
          f"(dropped {result['dropped']:.3f}, sky {result['sky']:.3f})")
    return result


def _barycentric(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (3,) of point ``p`` in triangle ``tri`` (3, 3)."""
    e1, e2, q = tri[1] - tri[0], tri[2] - tri[0], p - tri[0]
    d00, d01, d11, d20, d21 = e1 @ e1, e1 @ e2, e2 @ e2, q @ e1, q @ e2
    den = d00 * d11 - d01 * d01
    b1, b2 = (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den
    return np.array([1.0 - b1 - b2, b1, b2])


if __name__ == "__main__":
    args = sys.argv[1:]
    split = None
    if args[:1] == ["--split"]:
        split, args = (float(args[1]), float(args[2])), args[3:]
    furnace.reference_run.register_addon()
    folder = os.path.join(os.path.dirname(os.path.dirname(HERE)), "out", "breakdown")
    os.makedirs(folder, exist_ok=True)
    for case_name in args or ["intersecting", "resting", "monkey"]:
        arrays = breakdown(case_name, save=os.path.join(folder, f"{case_name}.npz"))
        if split is not None:
            first_hit_split(case_name, arrays["got"], arrays["ref"], *split)
