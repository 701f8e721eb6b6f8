#!/usr/bin/env python3
"""The bundled Cornell box from its camera: Illumap's mesh preview against Cycles' path-traced
render of the same meshes, side by side, with the error over pixels.

Both render at the same size with Cycles and the Standard view transform: the path-traced
image with ``--samples`` samples (no denoising, clamps off), the preview (emission only, so a
few samples suffice) after ``pipeline.compute`` at default settings. Prints the relative RMS
over all pixels and the share of lit pixels (reference above 5% of its mean) off by more than
25%, and writes ``docs/images/cornell_vs_cycles.png`` (preview | Cycles | |difference| × 4).

    .venv/bin/python bench/reference/preview_vs_cycles.py [--size 256] [--samples 1024]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_ROOT = os.path.dirname(os.path.dirname(HERE))
if REPO_ROOT not in sys.path:
    sys.path.insert(0, REPO_ROOT)

import bpy  # noqa: E402

SAMPLE = os.path.join(REPO_ROOT, "sample_blends", "cornell_box.blend")
OUT = os.path.join(REPO_ROOT, "docs", "images", "cornell_vs_cycles.png")


def render(size: int, samples: int) -> tuple[np.ndarray, float]:
    """Render the scene's camera at size × size: linear RGB (size, size, 3) and seconds."""
    scene = bpy.context.scene
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x = r.resolution_y = size
    r.resolution_percentage = 100
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.sample_clamp_direct = scene.cycles.sample_clamp_indirect = 0.0
    scene.cycles.max_bounces = scene.cycles.diffuse_bounces = 64
    scene.view_settings.view_transform = "Standard"
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    with tempfile.TemporaryDirectory() as tmp:
        r.filepath = os.path.join(tmp, "r.exr")
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds = time.perf_counter() - t0
        img = bpy.data.images.load(r.filepath)
        px = np.empty(size * size * 4, np.float32)
        img.pixels.foreach_get(px)
        bpy.data.images.remove(img)
    return px.reshape(size, size, 4)[..., :3].astype(np.float64), seconds


def main(argv: list[str] | None = None) -> int:
    """Command line: see the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--samples", type=int, default=1024)
    args = ap.parse_args(argv)
    bpy.ops.wm.open_mainfile(filepath=SAMPLE)
    reference, t_ref = render(args.size, args.samples)
    import addon
    addon.register()
    from addon import mesh_preview, pipeline
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    t0 = time.perf_counter()
    result = pipeline.compute(bpy.context, meshes, pipeline.Settings())
    t_illumap = time.perf_counter() - t0
    bpy.data.objects[result.object_name].hide_render = True
    mesh_preview.build_mesh_preview(meshes)
    preview, _ = render(args.size, 4)
    diff = preview - reference
    rel_rms = float(np.sqrt(np.mean(diff ** 2) / np.mean(reference ** 2)))
    lum = reference @ [0.2126, 0.7152, 0.0722]
    lit = lum > 0.05 * lum.mean()
    off = np.abs((preview - reference) @ [0.2126, 0.7152, 0.0722]) > 0.25 * lum
    share = float(off[lit].mean())
    print(f"Cycles {args.samples} spp: {t_ref:.1f} s; Illumap default settings: {t_illumap:.2f} s "
          f"({result.count} surfels)")
    print(f"preview against Cycles over {args.size}² pixels: relative RMS {rel_rms:.4f}; lit "
          f"pixels off by more than 25%: {share:.4%}")
    # Side by side, sRGB-encoded for the PNG.
    def encode(x):
        x = np.clip(x, 0, 1)
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    strip = np.concatenate([encode(preview), encode(reference), encode(4 * np.abs(diff))], axis=1)
    h, w = strip.shape[:2]
    img = bpy.data.images.new("side_by_side", w, h, alpha=False)
    rgba = np.concatenate([strip, np.ones((h, w, 1))], axis=2).astype(np.float32)
    img.pixels.foreach_set(rgba.ravel())
    img.filepath_raw = OUT
    img.file_format = "PNG"
    img.save()
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
