#!/usr/bin/env python3
"""The bundled Cornell box from its camera: Illumap's mesh preview against Cycles' path-traced
render of the same meshes, scored against the truth rather than against Cycles' noise.

All images render at the same size with Cycles and the Standard view transform (no denoising,
no clamping, 64 bounces). The path-traced reference renders **twice**, with seeds 0 and 1 and
``--samples`` samples each: C1 and C2. The preview renders after ``pipeline.compute`` at
default settings with the mesh preview on: P. It is emission only, but its pixels still
integrate Cycles' pixel filter over whatever they cover: at 4 samples the anti-aliased outline
of the light (radiance 17, the walls' ~0.2) alone gave 11.6% relative RMS over all pixels at
192²; ``--preview-samples`` 256 take that to 0.3%.

Two pixel sets: **all pixels**, and the **surfaces**: all but the pixels the light covers or
touches through the pixel filter (a render of the light alone, grown by one pixel). The light
covers 1% of the pixels but makes 99% of the reference's sum of squares, so a relative RMS over all
pixels measures little beyond its outline; the surfaces' figure is the one about light.

The estimators, with T the converged path-traced image and C_i = T + n_i, where n1, n2 are the
two renders' independent, zero-mean Monte Carlo noise of per-pixel variance s² (in Cycles each
pixel's samples are its own, so pixels are independent too):

* **plain relative RMS**: sqrt(mean((P − C̄)²) / mean(C̄²)) against C̄ = (C1 + C2) / 2, over
  the set's pixels and channels. It carries the reference's noise: E(P − C̄)² = (P − T)² + s²/2.
* **noise-corrected relative RMS**: sqrt(max(0, mean((P − C̄)²) − mean((C1 − C2)²) / 4) /
  mean(C̄²)). Since E(C1 − C2)² = 2 s², a quarter of the two renders' squared difference is
  an unbiased estimate, pixel by pixel, of the s²/2 that C̄'s noise adds; subtracting its mean
  leaves an unbiased estimate of mean((P − T)²). (The denominator keeps mean(C̄²) = mean(T²) +
  mean(s²)/2: a relative bias of half the squared relative noise, ~1e-4 here.)
  ``noise_corrected_uncertainty`` is one standard error of the corrected figure, from the
  pixel-to-pixel spread of the per-pixel terms; ``reference_noise`` is sqrt(mean((C1 − C2)²)
  / 4 / mean(C̄²)), the relative RMS that C̄'s own noise contributes.
* **share of lit pixels off by more than 25%** (luminance; lit: C̄ above 5% of its mean), per
  pixel and on the image binned in k×k blocks (block means of P, C1 and C2; with the surfaces,
  only blocks wholly on them). A k×k block averages k² independent pixels, so its noise falls
  by k. For each k the script reports the reference's own relative noise on the lit blocks
  (|C1 − C2| / 2 / C̄, which estimates the standard deviation of C̄ relative to it: RMS and
  99th percentile) and the **noise floor**: the share of lit blocks where C1 alone is off C̄ by
  more than 25%. C1 − C̄ = (n1 − n2) / 2 has the same distribution as C̄ − T, so the floor is
  the share that a perfect preview would be charged by the noise alone.
  The target reads k = 4 (``--block``): there the reference's noise is 0.5% RMS and 1.7% at
  the 99th percentile of blocks, where 25% lies 15 of those percentiles away, so a
  block counted off is the preview's error; 4 px at 192² is 2% of the image, finer than any
  shadow or edge the figure is about. At 1024 samples the floor is already 0 per pixel (noise
  1.9% RMS, 6.9% at the 99th percentile), so the per-pixel share is also the preview's own;
  at 128 samples it is not (floor 0.7% per pixel at 64²).

Measured (bpy 5.2.3, 2 cores; ``bench/results/preview_vs_cycles.json``): 192² px, 1024
samples × 2 seeds, 46 s per Cycles render; surfaces: relative RMS 1.64% plain, 1.08% ± 0.05%
noise-corrected (the reference's noise 1.23%); lit pixels off by more than 25%: 0.15% per
pixel, 0.085% on 2×2, 0.049% on 4×4 blocks, 0 on 8×8, noise floor 0 throughout. All pixels:
0.30% plain, 0.27% corrected.

Prints the figures and the times, writes ``bench/results/preview_vs_cycles.json`` and
``docs/images/cornell_vs_cycles.png`` (preview | Cycles, the mean of both renders |
|difference| × 4).

    .venv/bin/python bench/reference/preview_vs_cycles.py [--size 192] [--samples 1024]
        [--preview-samples 256] [--block 4] [--no-write]

With ``--scene mesh_room|scan_room|scan_bunny`` it runs one of ``bench/scenes/preview.py``'s scenes
instead, the default after Compute (``preview_scene_run.py``), and for the scans also the
values at the points without splats.
"""

from __future__ import annotations

import argparse
import json
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
RESULTS = os.path.join(REPO_ROOT, "bench", "results", "preview_vs_cycles.json")
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
#: A pixel (block) is lit when the reference's luminance exceeds this fraction of its mean.
LIT = 0.05
#: The error threshold of the share: off by more than this fraction of the reference.
OFF = 0.25
SEEDS = (0, 1)
#: The sample's emitters: their pixels are left out of the "surfaces" figures.
EMITTERS = ("Light",)
#: The scenes of bench/scenes/preview.py (``--scene``; preview_scene_run.py runs them).
SCENE_NAMES = ("mesh_room", "scan_room", "scan_room_normals", "scan_bunny")


def render(size: int, samples: int, seed: int = 0) -> tuple[np.ndarray, float]:
    """Render the scene's camera at size × size with Cycles (CPU, ``samples`` samples, seed
    ``seed``): linear RGB (size, size, 3) and seconds."""
    scene = bpy.context.scene
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x = r.resolution_y = size
    r.resolution_percentage = 100
    r.film_transparent = False
    cyc = scene.cycles
    cyc.device = "CPU"
    cyc.samples = samples
    cyc.seed = seed
    cyc.use_animated_seed = False
    cyc.use_denoising = False
    cyc.use_adaptive_sampling = False
    cyc.sample_clamp_direct = cyc.sample_clamp_indirect = 0.0
    cyc.max_bounces = cyc.diffuse_bounces = 64
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


def bin_blocks(img: np.ndarray, k: int) -> np.ndarray:
    """Means over k×k blocks of an (h, w, ...) image (trailing rows and columns dropped)."""
    h, w = (img.shape[0] // k) * k, (img.shape[1] // k) * k
    img = img[:h, :w]
    return img.reshape(h // k, k, w // k, k, *img.shape[2:]).mean(axis=(1, 3))


def emitter_mask(emitters, size: int) -> np.ndarray:
    """Pixels (size, size) that the ``emitters`` cover or touch through the pixel filter: a
    render of them alone (a few samples), above 1e-4, grown by one pixel. Their own emission
    is the same in both images and, at a radiance tens of times the walls', would otherwise
    dominate every sum of squares."""
    scene = bpy.context.scene
    hidden = [(o, o.hide_render) for o in scene.objects if o.type in ("MESH", "POINTCLOUD")]
    for obj, _ in hidden:
        obj.hide_render = obj not in emitters
    try:
        img, _ = render(size, 16)
    finally:
        for obj, was in hidden:
            obj.hide_render = was
    mask = img.max(axis=-1) > 1e-4
    grown = mask.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            grown[max(dy, 0):size + min(dy, 0), max(dx, 0):size + min(dx, 0)] |= \
                mask[max(-dy, 0):size + min(-dy, 0), max(-dx, 0):size + min(-dx, 0)]
    return grown


def relative_rms(preview: np.ndarray, c1: np.ndarray, c2: np.ndarray, keep=None) -> dict:
    """Plain and noise-corrected relative RMS of ``preview`` against the truth that the two
    independent renders ``c1``, ``c2`` estimate (see the module docstring), over the pixels
    ``keep`` (a boolean image; all when None)."""
    if keep is not None:
        preview, c1, c2 = preview[keep], c1[keep], c2[keep]
    mean = (c1 + c2) / 2
    err2 = ((preview - mean) ** 2).reshape(-1, 3)
    noise2 = ((c1 - c2) ** 2 / 4).reshape(-1, 3)
    norm = float(np.mean(mean ** 2))
    corrected2 = float(np.mean(err2) - np.mean(noise2))
    terms = (err2 - noise2).mean(axis=1)
    stderr2 = float(terms.std() / np.sqrt(len(terms)))
    corrected = float(np.sqrt(max(0.0, corrected2) / norm))
    # One standard error of the corrected figure: d sqrt(x) = dx / (2 sqrt(x)), and never more
    # than sqrt(dx) (the figure's reach from zero).
    spread = np.sqrt(stderr2 / norm)
    uncertainty = min(stderr2 / norm / (2 * corrected), spread) if corrected > 0 else spread
    return {
        "pixels": int(len(terms)),
        "plain": float(np.sqrt(np.mean(err2) / norm)),
        "noise_corrected": corrected,
        "noise_corrected_uncertainty": float(uncertainty),
        "reference_noise": float(np.sqrt(np.mean(noise2) / norm)),
    }


def off_shares(preview: np.ndarray, c1: np.ndarray, c2: np.ndarray, k: int, keep=None) -> dict:
    """On k×k blocks of luminance (those whose pixels are all in ``keep``, when given): the
    share of lit blocks where ``preview`` is off the mean reference by more than ``OFF``, the
    reference's own relative noise on them, and the noise floor (the share at which one render
    is off the mean by more than ``OFF``)."""
    lum = lambda x: bin_blocks(x @ LUMINANCE, k)  # noqa: E731
    p, a, b = lum(preview), lum(c1), lum(c2)
    mean = (a + b) / 2
    lit = mean > LIT * mean.mean()
    if keep is not None:
        lit &= bin_blocks(keep.astype(np.float64), k) == 1.0
    off = np.abs(p - mean) > OFF * mean
    noise = np.abs(a - b) / 2 / np.where(lit, mean, 1.0)
    return {
        "k": k,
        "lit": int(lit.sum()),
        "share_off": float(off[lit].mean()),
        "reference_noise_rms": float(np.sqrt(np.mean(noise[lit] ** 2))),
        "reference_noise_p99": float(np.percentile(noise[lit], 99)),
        "noise_floor": float((noise[lit] > OFF).mean()),
    }


def compare(preview: np.ndarray, c1: np.ndarray, c2: np.ndarray, blocks=(1, 2, 4, 8),
            keep=None) -> dict:
    """All the figures over the pixels ``keep`` (all when None): ``relative_rms`` and
    ``off_shares`` for each block size."""
    return {"relative_rms": relative_rms(preview, c1, c2, keep),
            "off_by_25_percent": {str(k): off_shares(preview, c1, c2, k, keep) for k in blocks}}


def report(label: str, figures: dict) -> None:
    """Print one pixel set's figures."""
    rms = figures["relative_rms"]
    print(f"{label} ({rms['pixels']} pixels): relative RMS plain {rms['plain']:.4f}, "
          f"noise-corrected {rms['noise_corrected']:.4f} ± {rms['noise_corrected_uncertainty']:.4f}"
          f" (reference noise {rms['reference_noise']:.4f})")
    for k, s in figures["off_by_25_percent"].items():
        print(f"  lit {k}×{k} blocks off by more than 25%: {s['share_off']:.4%} of {s['lit']} "
              f"(reference noise RMS {s['reference_noise_rms']:.4f}, p99 "
              f"{s['reference_noise_p99']:.4f}; noise floor {s['noise_floor']:.4%})")


def main(argv: list[str] | None = None) -> int:
    """Command line: see the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=192)
    ap.add_argument("--samples", type=int, default=1024, help="per reference render")
    ap.add_argument("--preview-samples", type=int, default=256)
    ap.add_argument("--block", type=int, default=4, help="k of the k×k blocks the target reads")
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument("--scene", choices=("cornell",) + SCENE_NAMES, default="cornell",
                    help="the bundled Cornell box (default), or a scene of "
                    "bench/scenes/preview.py")
    ap.add_argument("--cell", type=float, default=None,
                    help="the preview scenes' grid (m; default: the tests')")
    ap.add_argument("--splat-cone", type=float, default=None,
                    help="the splats' cone height (mesh_preview.SPLAT_CONE; 0: flat discs)")
    args = ap.parse_args(argv)
    if args.scene != "cornell":
        from bench.reference.preview_scene_run import run_scene  # noqa: PLC0415
        return run_scene(args)
    bpy.ops.wm.open_mainfile(filepath=SAMPLE)
    refs, t_refs = [], []
    for seed in SEEDS:
        img, seconds = render(args.size, args.samples, seed)
        refs.append(img)
        t_refs.append(seconds)
    import addon
    addon.register()
    from addon.preview import mesh_preview
    from addon import pipeline
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    surfaces = ~emitter_mask([bpy.data.objects[n] for n in EMITTERS], args.size)
    t0 = time.perf_counter()
    result = pipeline.compute(bpy.context, meshes, pipeline.Settings())
    t_illumap = time.perf_counter() - t0
    bpy.data.objects[result.object_name].hide_render = True
    mesh_preview.build_mesh_preview(meshes)
    preview, t_preview = render(args.size, args.preview_samples)
    blocks = sorted({1, 2, 4, 8, args.block})
    figures = {"all_pixels": compare(preview, refs[0], refs[1], blocks),
               "surfaces": compare(preview, refs[0], refs[1], blocks, keep=surfaces)}
    print(f"Cycles reference: {args.size}² px, {args.samples} samples, seeds {SEEDS}: "
          f"{t_refs[0]:.1f} s + {t_refs[1]:.1f} s; preview render ({args.preview_samples} "
          f"samples) {t_preview:.1f} s; Illumap default settings {t_illumap:.2f} s "
          f"({result.count} surfels)")
    report("all pixels", figures["all_pixels"])
    report("surfaces (the emitter's pixels left out)", figures["surfaces"])
    if args.no_write:
        return 0
    record = {
        "scene": "sample_blends/cornell_box.blend, scene camera",
        "settings": "pipeline.Settings() (defaults), mesh preview",
        "size": args.size, "samples": args.samples, "seeds": list(SEEDS),
        "preview_samples": args.preview_samples, "block": args.block,
        "blender": bpy.app.version_string,
        "seconds": {"cycles_per_render": t_refs, "preview_render": t_preview,
                    "illumap": t_illumap},
        "surfels": result.count,
        "targets": {"relative_rms": 0.03, "share_off_by_25_percent": 0.01},
        **figures,
        "command": "OMP_NUM_THREADS=2 .venv/bin/python bench/reference/preview_vs_cycles.py "
                   f"--size {args.size} --samples {args.samples} --preview-samples "
                   f"{args.preview_samples} --block {args.block}",
    }
    with open(RESULTS, "w") as fh:
        json.dump(record, fh, indent=2)
        fh.write("\n")
    print(f"wrote {RESULTS}")
    # Side by side, sRGB-encoded for the PNG.
    def encode(x):
        x = np.clip(x, 0, 1)
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    mean = (refs[0] + refs[1]) / 2
    strip = np.concatenate([encode(preview), encode(mean), encode(4 * np.abs(preview - mean))],
                           axis=1)
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
