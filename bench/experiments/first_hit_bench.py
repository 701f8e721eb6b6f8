#!/usr/bin/env python3
"""The bench's scenes at Illumap's default settings against their cached Cycles references,
without the Cycles sweep: relative RMS and seconds per scene, and the seconds of the steps that
bound the transport (hemisphere rays, their first-hit links). For before/after comparisons of a
change to the operator in one session (run both on the same machine, one after the other).

    .venv/bin/python bench/experiments/first_hit_bench.py --scenes cornell monkey --out x.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, REPO_ROOT)
sys.path.insert(0, os.path.join(REPO_ROOT, "bench"))

import bpy  # noqa: E402  (before illumap: the bpy module's libraries load first)
from reference import run as reference_run, scenes  # noqa: E402

SCENES = ("cornell", "room", "near", "lamps", "world", "window", "monkey", "scan_room",
          "scan_object")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--out", default=None)
    ap.add_argument("--no-links", action="store_true",
                    help="cast the hemisphere rays without first-hit links: no surfel is "
                         "enclosed (the operator as before illumap.sealing)")
    args = ap.parse_args()
    if args.no_links:
        from illumap import conservation
        cast = conservation.hemisphere_hits

        def without_links(*a, **k):
            return cast(*a, **dict(k, links=False))
        conservation.hemisphere_hits = without_links
    pipeline = reference_run.register_addon()
    rows = []
    for name in args.scenes:
        scene = scenes.build(name)
        samples = min(reference_run.REFERENCE_SAMPLES, scene.reference_samples or 10 ** 9)
        ref = reference_run.load_reference(scene, samples)
        if ref is None:
            print(f"{name}: no cached reference")
            continue
        scene = scenes.build(name)
        objects, spans = reference_run.scan_objects(scene)
        start = time.perf_counter()
        result = pipeline.compute(bpy.context, objects, reference_run.make_settings(pipeline, {}))
        seconds = time.perf_counter() - start
        values = {o.name: reference_run.read_illumination(o) for o in scene.scored
                  if o.name not in spans}
        values.update(reference_run.read_scan(spans) if spans else {})
        row = reference_run._scored_row(scene, "default", "illumap", values, ref["outgoing"],
                                        seconds, surfels=int(result.count))
        row["hemisphere_seconds"] = float(result.timings.get("hemisphere", 0.0))
        row["enclosed"] = int(result.stats.get("hemisphere_enclosed", 0))
        row["links_seconds"] = float(result.stats.get("time_hemisphere_links", 0.0))
        row["warnings"] = [w for w in result.warnings if "positive definite" in w]
        rows.append(row)
        print(f"{name:12s} {row['surfels']:7d} surfels {seconds:7.2f} s  rel. RMS "
              f"{row['relative_rms']:.4f}  hemisphere {row['hemisphere_seconds']:.2f} s  links "
              f"{row['links_seconds']:.2f} s  "
              f"enclosed {row['enclosed']}  {row['warnings']}", flush=True)
    if args.out:
        with open(args.out, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
