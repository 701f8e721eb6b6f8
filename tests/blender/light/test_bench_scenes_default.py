"""The mesh bench scenes keep the accuracy Illumap publishes for them at its default settings.

Each scene is built by ``bench/scenes``, computed at the default settings (seed 0) and scored over
every baked vertex against its cached 2048-sample Cycles reference (``bench/results/reference``),
as ``bench/experiments/default_against_cached.py`` does. The bounds are the product's stated
standard, not today's figures: <= 1% relative RMS for the mesh bench scenes and <= 1.5% for
Suzanne (issue "Light is conserved"). The held-out window room (1.8%, published as such in
docs/results.md) is not held to 1%. A gather change that darkened the lamps scene's awning once
passed every other test; this one sees it.
"""

import numpy as np
import pytest

from illumap_bpy_testing import requires_core

from bench.reference import run

#: scene -> largest relative RMS a correct default run meets against its cached reference.
BOUNDS = {"cornell": 0.010, "room": 0.010, "lamps": 0.010, "near": 0.010, "world": 0.010,
          "monkey": 0.015}


@requires_core
@pytest.mark.parametrize("name", sorted(BOUNDS))
def test_mesh_bench_scene_at_default(name, registered_addon):
    import bpy
    from addon import pipeline

    scene = run.scenes.build(name)
    reference = run.load_reference(scene, 1)
    if reference is None:      # another Blender may build other vertices: no reference to hold
        pytest.skip(f"the cached reference of '{name}' does not match the meshes this Blender "
                    f"builds")
    objects, spans = run.scan_objects(scene)
    assert not spans, f"'{name}' is a mesh scene"
    settings = run.make_settings(pipeline, dict(dict(run.ILLUMAP_SETTINGS)["default"], seed=0))
    pipeline.compute(bpy.context, objects, settings)
    values = {o.name: run.read_illumination(o) for o in scene.scored}
    assert all(np.isfinite(v).all() for v in values.values())
    row = run._scored_row(scene, "default", "illumap", values, reference["outgoing"], 0.0)
    assert row["relative_rms"] <= BOUNDS[name], (
        f"{name}: {100 * row['relative_rms']:.3f}% against the cached reference "
        f"(bound {100 * BOUNDS[name]:.1f}%), per object "
        + ", ".join(f"{k} {100 * v['relative_rms']:.2f}% (worst at {v.get('max_error_at')})"
                    for k, v in row["objects"].items()))
