#!/usr/bin/env python3
"""The final gather's noise estimate against its measured noise, on the reference scenes.

For each scene and ray count: sample and solve the surfels once, then evaluate the light at
the meshes' corners (``illumap.stages.passes.gather``) twice with two gather seeds, everything else
(surfels, shadow rays) the same. Each seed shifts the gather's ray lattice independently, so
the two results' difference is the gather's own error times √2: the measured noise is
relative RMS of luminance over the corners, as ``stats['receivers']['gather_noise']`` (the
estimate) is. Writes ``bench/results/gather_noise.json`` and prints a table.

    .venv/bin/python bench/reference/gather_noise.py
    .venv/bin/python bench/reference/gather_noise.py --scenes cornell --rays 64 512
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_ROOT = os.path.dirname(os.path.dirname(HERE))
for path in (REPO_ROOT, os.path.dirname(HERE)):
    if path not in sys.path:
        sys.path.insert(0, path)

import bpy  # noqa: E402

from reference import run  # noqa: E402
from scenes import blender as scenes  # noqa: E402

DEFAULT_OUT = os.path.join(REPO_ROOT, "bench", "results", "gather_noise.json")
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def measure(name: str, rays: int, pipeline) -> dict:
    """Estimated and measured gather noise on scene ``name`` at ``rays`` per receiver."""
    from illumap import receivers as rc
    from illumap.stages import passes
    from illumap.stages.light import light
    scene = scenes.build(name)
    objects, _ = run.scan_objects(scene)
    settings = run.make_settings(pipeline, dict(gather_rays=rays))
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects, settings)
    solved = passes.solve_lit(light(pipeline.to_scene(job)))
    gather, shift = rc.Gatherer.gather, {"seed": 0}

    def shifted(self, *args, seed=0, **kwargs):     # the gather's seed only
        return gather(self, *args, seed=seed + 1000 * shift["seed"], **kwargs)

    values, stats = [], []
    rc.Gatherer.gather = shifted
    try:
        for seed in (0, 1):
            shift["seed"] = seed
            gathered = passes.gather(solved)
            values.append({k: v @ LUMINANCE for k, v in gathered.corners.items()})
            stats.append(dict(gathered.stats["receivers"]))
    finally:
        rc.Gatherer.gather = gather
    diff2 = sum(float(((values[0][k] - values[1][k]) ** 2).sum()) for k in values[0]) / 2.0
    light2 = sum(float((((values[0][k] + values[1][k]) / 2.0) ** 2).sum()) for k in values[0])
    measured = math.sqrt(diff2 / light2)
    estimate = 0.5 * (stats[0]["gather_noise"] + stats[1]["gather_noise"])
    return dict(scene=name, rays=rays, corners=stats[0]["corners"], estimate=estimate,
                measured=measured, ratio=estimate / measured if measured > 0 else None)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", default=["cornell", "room", "lamps", "near", "world"],
                        choices=sorted(scenes.SCENES))
    parser.add_argument("--rays", nargs="+", type=int, default=[64, 512, 2048])
    parser.add_argument("--out", default=DEFAULT_OUT)
    args = parser.parse_args(argv)
    pipeline = run.register_addon()
    rows = []
    print("| scene | rays | corners | estimate | measured | estimate / measured |")
    print("|---|---|---|---|---|---|")
    for name in args.scenes:
        for rays in args.rays:
            row = measure(name, rays, pipeline)
            rows.append(row)
            print(f"| {name} | {rays} | {row['corners']} | {row['estimate']:.4f} | "
                  f"{row['measured']:.4f} | {row['ratio']:.2f} |", flush=True)
    with open(args.out, "w") as f:
        json.dump(dict(commit=run._commit(), rows=rows), f, indent=1)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
