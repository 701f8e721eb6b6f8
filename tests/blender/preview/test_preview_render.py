"""What the user sees after Compute, rendered from the scene camera, against a path-traced
view of the same scene (``bench/scenes/preview.py`` builds the scenes,
``preview_vs_cycles.py`` derives the figures):

* ``mesh_room``: a Cornell-like room of meshes; the default after Compute shows the meshes'
  own ``illumination`` (the solve's surfels hidden).
* ``scan_room``: the same room as a scan of 14.6k points without normals (its walls and block
  as jittered 2 cm grids, the emitter a mesh): the default shows every point as a splat.
* ``scan_room_normals``: the same scan with each point's normal given (the scanned meshes'
  vertex normals; the block's corners welded, their normal the faces' mean): the splats end
  0.05 of their radius past a convex crease and each is shaded with its light's gradient
  (at the start of that work 4.84% at 64², the block's top hidden by its faces' splats).
* ``scan_bunny``: the Stanford bunny's 35,947 scanned points without normals on a mesh floor
  of 2.5 cm cells, sky and sun.

Each scene renders ``SIZE``² pixels: the path-traced view twice (seeds 0 and 1, ``SAMPLES``
each, no denoising, 64 bounces), the preview (emission only, ``PREVIEW_SAMPLES`` converge
its pixel filter). The figures leave out the pixels the emitter covers or touches (its own
radiance is the same in both and would dominate every sum of squares):

* the **noise-corrected relative RMS**: the mean squared difference from the mean of the two
  path-traced renders, less a quarter of their own mean squared difference (an unbiased
  estimate of the noise their mean carries), over the mean's mean square;
* the **share of lit 2×2 blocks off by more than 25%** (luminance): a rim over an edge or a
  seam in a corner is a line of pixels tens of percent off; the light's own smooth errors
  (a few percent) are not.

The bounds (``BOUNDS``) are the issue's targets for a preview that stands in for a render:
3% relative RMS and 1% of lit pixels off by more than 25%. Why a correct preview meets them
here, and the reference's noise needs no margin: the RMS has the reference's noise taken out
(what remains is its standard error, ~0.1%), and on 2×2 blocks the reference's noise is ~1%
RMS at these samples, so the share that noise alone would charge a perfect preview (the noise
floor, measured from the two renders) is asserted to stay below a tenth of the bound. A
correct preview shows the solve's values, 0.9–1.2% from Cycles on the reference rooms at
default settings (bench/README.md); the splats, the mesh's interpolation over its grid and
the pixel filter share the rest.

For the scans the light at the points is part of the figure: showing the scan's values on the
scanned meshes without splats (``preview_vs_cycles.py --scene``) separates it from the
splats' own error (docs/results.md).

Measured (``pytest -s``), Blender 5.2, after the points beside a crease were lit about their
own plane and a crease point's strip kept its side: mesh room 1.18% ± 0.09%, 0 of 641 lit
blocks off (0.45% of lit pixels); room scan 1.81% ± 0.14%, 0.16% of blocks (0.69% of pixels);
room scan with normals 2.35% ± 0.12%, 0 (0.53%); bunny scan 1.83% ± 0.12%, 0 (0.20%). Before,
12-sided splats: mesh room 1.17% ± 0.09%, 0 of 641
lit blocks off (0.45% of lit pixels); room scan 2.52% ± 0.22%, 0.31% of blocks (0.77% of
pixels); room scan with normals 2.34% ± 0.12%, 0 (0.53%); bunny scan 1.84% ± 0.12%, 0 of 1024
(0.20%); with 16 sides 2.51%, 2.33%, 1.84%. Before the splats' shading and convex creases:
room scan 2.62%, bunny 1.89%. Blender 5.0 (before): 1.15%, 0; 2.62%, 0.31% (1.10% of pixels);
1.85%, 0. At the start of this issue's splat work the room scan gave 10.3% and 15.8% of blocks
(docs/results.md). About 55–110 s for the four on 2 loaded cores.
"""

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import requires_core

from bench.scenes import preview as preview_scenes
from bench.reference.preview_vs_cycles import emitter_mask, off_shares, relative_rms, render

pytestmark = [requires_core, pytest.mark.slow]

BOUNDS = dict(rms=0.03, share_off=0.01)
SIZE = 64
SAMPLES = 256
PREVIEW_SAMPLES = 32
BLOCK = 2
#: The rooms' grid (m) for each scene; the bunny's floor is its own.
CELL = {"mesh_room": 0.05, "scan_room": 0.02, "scan_room_normals": 0.02, "scan_bunny": 0.025}


def views(name: str) -> dict:
    """The scene's two path-traced views, its preview after Compute at default settings and
    the pixels the figures read."""
    scene = preview_scenes.build(name, CELL[name])
    emitter = scene["emitter"]
    scanned = scene["surfaces"][:1] if name == "scan_bunny" else scene["surfaces"]
    if scene["scan"] is not None:        # the path-traced view sees the scanned surfaces
        scene["scan"].hide_render = True
        for obj in scanned:
            obj.hide_render = False
    surfaces = ~emitter_mask([emitter], SIZE) if emitter else np.ones((SIZE, SIZE), bool)
    c1, _ = render(SIZE, SAMPLES, seed=0)
    c2, _ = render(SIZE, SAMPLES, seed=1)
    if scene["scan"] is not None:
        scene["scan"].hide_render = False
        for obj in scanned:
            obj.hide_render = True
    result = preview_scenes.compute_and_show(scene)
    surfel_object = bpy.data.objects.get(result.object_name)
    preview, _ = render(SIZE, PREVIEW_SAMPLES)
    return {"c1": c1, "c2": c2, "preview": preview, "surfaces": surfaces,
            "surfels_hidden": surfel_object is None or surfel_object.hide_render,
            "shown": [o.name for o in bpy.data.objects if any(
                m.name.startswith("Illumap") and m.show_render for m in getattr(o, "modifiers", []))]}


@pytest.fixture(scope="module")
def rendered(addon_module):
    """Each scene's views, rendered once for the module's tests."""
    cache = {}

    def get(name):
        if name not in cache:
            bpy.ops.wm.read_factory_settings(use_empty=True)
            cache[name] = views(name)
        return cache[name]
    return get


def figures(v: dict, label: str) -> tuple[dict, dict]:
    rms = relative_rms(v["preview"], v["c1"], v["c2"], keep=v["surfaces"])
    share = off_shares(v["preview"], v["c1"], v["c2"], BLOCK, keep=v["surfaces"])
    per_pixel = off_shares(v["preview"], v["c1"], v["c2"], 1, keep=v["surfaces"])
    print(f"\n{label}, {SIZE}² px, {SAMPLES} samples × 2 seeds: relative RMS "
          f"{rms['noise_corrected']:.4f} ± {rms['noise_corrected_uncertainty']:.4f} (plain "
          f"{rms['plain']:.4f}, reference noise {rms['reference_noise']:.4f}); lit "
          f"{BLOCK}×{BLOCK} blocks off by more than 25%: {share['share_off']:.2%} of "
          f"{share['lit']} (noise floor {share['noise_floor']:.2%}); lit pixels off: "
          f"{per_pixel['share_off']:.2%} (noise floor {per_pixel['noise_floor']:.2%})")
    # The reference is good enough for the bounds to mean something.
    assert share["lit"] > 400
    assert share["noise_floor"] <= BOUNDS["share_off"] / 10
    assert rms["reference_noise"] < BOUNDS["rms"]
    return rms, share


@pytest.mark.parametrize("name", ["mesh_room", "scan_room", "scan_room_normals", "scan_bunny"])
def test_the_default_after_compute_looks_like_the_render(rendered, name):
    v = rendered(name)
    assert v["surfels_hidden"]
    shown = {"mesh_room": {"Floor", "Back", "Left", "Right", "Block", "Emitter"},
             "scan_room": {"Scan", "Emitter"}, "scan_room_normals": {"Scan", "Emitter"},
             "scan_bunny": {"Scan", "Floor"}}[name]
    assert shown <= set(v["shown"])
    rms, share = figures(v, name)
    assert rms["noise_corrected"] <= BOUNDS["rms"]
    assert share["share_off"] <= BOUNDS["share_off"]
