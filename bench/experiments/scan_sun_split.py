#!/usr/bin/env python3
"""How much of a scan scene's error is the lamps' direct light at its points (a diagnostic):
Illumap at default on ``scan_object`` (or ``scan_room``), recording the lamps' direct
incident radiance H at the scan's points as the run casts it against the splats, and
computing it again at the same points with the same normals, lamps and samples against the
meshes Cycles bakes (the scanned meshes' own triangles and the other objects'). The split:
ρ·(H_splats − H_meshes) against the final error (x − r), by height above the lowest point.

    .venv/bin/python bench/experiments/scan_sun_split.py scan_object
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))

from reference import bake, run  # noqa: E402


def _world_triangles(objs) -> np.ndarray:
    out = []
    for o in objs:
        if o.type != "MESH":
            continue
        m = o.data
        m.calc_loop_triangles()
        tri = np.empty(len(m.loop_triangles) * 3, dtype=np.int64)
        m.loop_triangles.foreach_get("vertices", tri)
        co = np.empty(len(m.vertices) * 3)
        m.vertices.foreach_get("co", co)
        mw = np.array(o.matrix_world)
        co = co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3]
        out.append(co[tri.reshape(-1, 3)])
    return np.concatenate(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("--dump", default="", help="save the split as this .npz")
    args = parser.parse_args()
    import bpy
    import illumap.lights as lights
    from illumap.receivers import MeshOccluders
    pipeline = run.register_addon()
    scene = run.scenes.build(args.scene)
    reference = run.load_reference(scene, 1)["outgoing"]
    meshes = [o for o in scene.objects if o.type == "MESH"]
    truth = MeshOccluders(_world_triangles(meshes))
    objects, spans = run.scan_objects(scene)
    calls = []
    inner = lights.incident_radiance

    def recording(lamps, positions, normals, *, shadows=None, world_apart=False):
        h = inner(lamps, positions, normals, shadows=shadows, world_apart=world_apart)
        if shadows is not None and not world_apart and lamps:
            calls.append((lamps, np.array(positions), np.array(normals), np.array(h),
                          shadows.samples, None if shadows.ids is None else np.array(shadows.ids)))
        return h
    lights.incident_radiance = recording
    pipeline.compute(bpy.context, objects, run.make_settings(pipeline, {}))
    lights.incident_radiance = inner
    print("calls:", [(len(c[1]), c[4]) for c in calls])
    values = run.read_scan(spans)
    for name, (start, count) in spans.items():
        obj = bpy.data.objects[name]
        pos = bake.vertex_positions(obj)
        keep = bake.baked_vertices(obj)
        rho = scene.albedo[name]
        # The calls' rows at the scan's points (each point's last row: the side kept).
        from scipy.spatial import cKDTree
        at = []
        for lamps, p, n, h, samples, ids in calls:
            dist, row = cKDTree(p).query(pos)
            if (dist < 1e-9).all():
                at.append((lamps, p[row], n[row], h[row], samples,
                           None if ids is None else ids[row]))
        x, r = values[name], reference[name]
        err = x - r
        total = float(np.sum(r[keep] ** 2))
        print(f"{name}: {len(at)} direct calls at its points; final "
              f"{np.sqrt(np.sum(err[keep] ** 2) / total):.4f}")
        z = pos[:, 2] - pos[:, 2].min()
        for i, (lamps, p, n, h, samples, ids) in enumerate(at):
            sh = lights.Shadows(truth.segment_query(n), samples=samples, seed=0,
                                extent=truth.extent, ids=ids)
            h_true = inner(lamps, p, n, shadows=sh)
            d = rho * (h - h_true)
            rest = err - d
            print(f"  call {i}: direct against splats {h.mean():.4f}, against meshes "
                  f"{h_true.mean():.4f}; error without the difference "
                  f"{np.sqrt(np.sum(rest[keep] ** 2) / total):.4f}")
            bands = [(0, 0.005), (0.005, 0.01), (0.01, 0.02), (0.02, 0.05), (0.05, 1.0)]
            for lo, hi in bands:
                m = keep & (z >= lo) & (z < hi)
                print(f"    z {lo:.3f}-{hi:.3f} m: {int(m.sum())} points, error part "
                      f"{np.sqrt(np.sum(err[m] ** 2) / total):.4f}, direct difference part "
                      f"{np.sqrt(np.sum(d[m] ** 2) / total):.4f}, rest "
                      f"{np.sqrt(np.sum(rest[m] ** 2) / total):.4f}")
            if args.dump:
                np.savez(f"{args.dump}_{i}.npz", p=p, n=n, h=h, h_true=h_true, x=x, r=r,
                         keep=keep, rho=rho)


if __name__ == "__main__":
    main()
