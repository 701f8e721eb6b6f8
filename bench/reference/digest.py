#!/usr/bin/env python3
"""Fingerprints of the light on every bench scene at default settings, to show that a change
which should not move the light (a refactor, a build change) moves no bit.

Runs each scene of ``bench/scenes/meshes.py`` (``REFERENCE``) through the add-on (``pipeline.compute`` with
the default settings, as ``run.py`` does) and writes, per scene, the SHA-256 of the surfels'
light and of each scored object's ``illumination`` attribute (float32 bytes), with the
surfel count. ``--repo`` runs another checkout's add-on and scenes (its ``illumap`` package
must be the one installed in the interpreter running this), so two revisions compare as::

    git worktree add /tmp/before <old-commit>
    .venv/bin/python bench/reference/digest.py --out /tmp/after.json
    <a venv with the old illumap>/bin/python bench/reference/digest.py --repo /tmp/before \\
        --out /tmp/before.json
    .venv/bin/python bench/reference/digest.py --compare /tmp/before.json /tmp/after.json

``--compare`` exits 1 when any fingerprint differs and names the scenes.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_ROOT = os.path.dirname(os.path.dirname(HERE))


def _digest(values) -> str:
    import numpy as np
    return hashlib.sha256(np.ascontiguousarray(values, dtype=np.float32).tobytes()).hexdigest()


def fingerprints(repo: str, names: list[str] | None) -> dict:
    """Scene name → {surfels, surfel light digest, object → attribute digest}."""
    sys.path.insert(0, repo)
    import bpy  # noqa: F401  (bpy before illumap: the native module's TBB)
    import numpy as np
    from addon import pipeline
    from bench.reference import run
    try:
        from bench.scenes import blender as scenes
    except ImportError:                   # a checkout from before the one scene library
        from bench.reference import scenes

    out = {}
    for name in names or list(scenes.SCENES):
        scene = scenes.build(name)
        objects, _ = run.scan_objects(scene)      # what the bench lights, as run.py does
        result = pipeline.compute(bpy.context, objects, pipeline.Settings())
        objs = {}
        for obj in objects:
            attr = obj.data.attributes.get("illumination")
            if attr is None:
                continue
            rgba = np.empty(len(attr.data) * 4, dtype=np.float32)
            attr.data.foreach_get("color", rgba)
            objs[obj.name] = _digest(rgba)
        out[name] = dict(surfels=int(result.count), light=_digest(result.radiosity),
                         objects=objs)
        print(f"{name}: {result.count} surfels, {len(objs)} objects", flush=True)
    return out


def compare(before: dict, after: dict) -> list[str]:
    """The scenes whose fingerprints differ (or that only one side has)."""
    return sorted(name for name in set(before) | set(after) if before.get(name) != after.get(name))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repo", default=REPO_ROOT, help="the checkout whose add-on runs")
    ap.add_argument("--scenes", nargs="*", help="scene names (default: all)")
    ap.add_argument("--out", help="write the fingerprints here (JSON)")
    ap.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"))
    args = ap.parse_args(argv)
    if args.compare:
        with open(args.compare[0]) as f, open(args.compare[1]) as g:
            differ = compare(json.load(f), json.load(g))
        print("identical" if not differ else f"differ: {', '.join(differ)}")
        return 1 if differ else 0
    prints = fingerprints(os.path.abspath(args.repo), args.scenes)
    if args.out:
        with open(args.out, "w") as f:
            json.dump(prints, f, indent=1, sort_keys=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
