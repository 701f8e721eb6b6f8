"""One scene of ``bench/scenes/preview.py`` from its camera: the default after Compute against the
path-traced view (``preview_vs_cycles.py --scene NAME``; the figures are that script's).

For a scan it also renders the scan's values on the scanned meshes without splats
(``preview_scenes.points_on_meshes``): that image against the path-traced view is the light's
error (the values at the points and their linear interpolation), and the preview against it
the splats' (plain relative RMS and lit pixels off by more than 25%: both images are
emission only, without Monte Carlo noise beyond the pixel filter's).

Writes ``bench/results/preview_vs_cycles_<scene>.json`` and
``docs/images/preview_<scene>.png`` (preview | path-traced, the mean of both renders |
|difference| × 4), unless ``--no-write``.
"""

from __future__ import annotations

import json
import os
import time

import bpy
import numpy as np

from bench.scenes import preview as preview_scenes
from bench.reference.preview_vs_cycles import (OUT, RESULTS, SEEDS, compare, emitter_mask,
                                               off_shares, relative_rms, render, report)

#: The grid each scene is built with unless ``--cell`` (tests/blender/preview/test_preview_render.py).
CELL = {"mesh_room": 0.05, "scan_room": 0.02, "scan_room_normals": 0.02, "scan_bunny": 0.025}


def _views(scene: dict, name: str, args) -> dict:
    """The path-traced views (seeds 0, 1), the preview after Compute, the surfaces' mask and
    (scans) the values at the points on the meshes, with their seconds."""
    scanned = scene["surfaces"][:1] if name == "scan_bunny" else scene["surfaces"]
    scan = scene["scan"]
    if scan is not None:
        scan.hide_render = True
        for obj in scanned:
            obj.hide_render = False
    emitter = scene["emitter"]
    surfaces = ~emitter_mask([emitter], args.size) if emitter else np.ones(
        (args.size, args.size), bool)
    out = {"surfaces": surfaces, "seconds": {}}
    for seed in SEEDS:
        out[f"c{seed + 1}"], out["seconds"][f"cycles_seed_{seed}"] = render(
            args.size, args.samples, seed)
    if scan is not None:
        scan.hide_render = False
        for obj in scanned:
            obj.hide_render = True
    t0 = time.perf_counter()
    result = preview_scenes.compute_and_show(scene)
    out["seconds"]["illumap_and_preview"] = time.perf_counter() - t0
    out["result"] = result
    out["preview"], out["seconds"]["preview_render"] = render(args.size, args.preview_samples)
    if scan is not None:
        preview_scenes.points_on_meshes(scan, scanned)
        out["points"], _ = render(args.size, args.preview_samples)
    return out


def _picture(path: str, preview: np.ndarray, reference: np.ndarray) -> None:
    """preview | reference | |difference| × 4, sRGB-encoded, as a PNG."""
    def encode(x):
        x = np.clip(x, 0, 1)
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    strip = np.concatenate([encode(preview), encode(reference),
                            encode(4 * np.abs(preview - reference))], axis=1)
    h, w = strip.shape[:2]
    img = bpy.data.images.new("side_by_side", w, h, alpha=False)
    rgba = np.concatenate([strip, np.ones((h, w, 1))], axis=2).astype(np.float32)
    img.pixels.foreach_set(rgba.ravel())
    img.filepath_raw = path
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


def run_scene(args) -> int:
    """Run ``args.scene`` (see ``preview_vs_cycles.main``); prints and writes the figures."""
    import addon  # noqa: PLC0415
    from addon.preview import mesh_preview  # noqa: PLC0415
    if not hasattr(bpy.types.Scene, "illumap"):
        addon.register()
    if args.splat_cone is not None:
        mesh_preview.SPLAT_CONE = args.splat_cone
    name = args.scene
    cell = args.cell if args.cell is not None else CELL[name]
    scene = preview_scenes.build(name, cell)
    v = _views(scene, name, args)
    blocks = sorted({1, 2, 4, args.block})
    figures = {"surfaces": compare(v["preview"], v["c1"], v["c2"], blocks, keep=v["surfaces"])}
    points = None
    if "points" in v:
        figures["points_vs_path_traced"] = compare(v["points"], v["c1"], v["c2"], blocks,
                                                   keep=v["surfaces"])
        keep = v["surfaces"]
        points = {"relative_rms": relative_rms(v["preview"], v["points"], v["points"], keep)["plain"],
                  "share_off_per_pixel": off_shares(v["preview"], v["points"], v["points"], 1,
                                                    keep)["share_off"],
                  "share_off_2x2": off_shares(v["preview"], v["points"], v["points"], 2,
                                              keep)["share_off"]}
        figures["splats_vs_points"] = points
    result = v["result"]
    scan_points = len(scene["scan"].data.vertices) if scene["scan"] is not None else 0
    print(f"{name}: {args.size}² px, {args.samples} samples × seeds {SEEDS}, preview "
          f"{args.preview_samples} samples; cell {cell:g} m; {scan_points} scan points; "
          f"Illumap + preview {v['seconds']['illumap_and_preview']:.1f} s ({result.count} "
          f"surfels)")
    report("preview against the path-traced view (the emitter's pixels left out)",
           figures["surfaces"])
    if points is not None:
        report("the values at the points on the meshes, no splats, against the path-traced view",
               figures["points_vs_path_traced"])
        print(f"splats against the values at the points on the meshes: relative RMS "
              f"{points['relative_rms']:.4f}, pixels off by more than 25% "
              f"{points['share_off_per_pixel']:.2%} (2×2 blocks {points['share_off_2x2']:.2%})")
    if args.no_write:
        return 0
    suffix = "" if args.splat_cone is None else f"_cone{args.splat_cone:g}"
    results = RESULTS.replace(".json", f"_{name}{suffix}.json")
    command = (f"OMP_NUM_THREADS=2 .venv/bin/python bench/reference/preview_vs_cycles.py --scene "
               f"{name} --size {args.size} --samples {args.samples} --preview-samples "
               f"{args.preview_samples} --block {args.block}"
               + ("" if args.cell is None else f" --cell {args.cell:g}")
               + ("" if args.splat_cone is None else f" --splat-cone {args.splat_cone:g}"))
    record = {
        "scene": f"bench/scenes/preview.py {name}, cell {cell:g} m, scene camera",
        "settings": "pipeline.Settings() (defaults), the default after Compute "
                    "(operators.after_write)",
        "scan_points": scan_points, "size": args.size, "samples": args.samples,
        "seeds": list(SEEDS), "preview_samples": args.preview_samples, "block": args.block,
        "splat_cone": mesh_preview.SPLAT_CONE, "blender": bpy.app.version_string,
        "seconds": v["seconds"], "surfels": result.count,
        "targets": {"relative_rms": 0.03, "share_off_by_25_percent": 0.01},
        **figures, "command": command,
    }
    with open(results, "w") as fh:
        json.dump(record, fh, indent=2)
        fh.write("\n")
    print(f"wrote {results}")
    if args.splat_cone is None:
        picture = OUT.replace("cornell_vs_cycles.png", f"preview_{name}.png")
        _picture(picture, v["preview"], (v["c1"] + v["c2"]) / 2)
        print(f"wrote {picture}")
    return 0
