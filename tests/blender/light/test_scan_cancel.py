"""A scan's shared gather (the irradiance cache) can be cancelled between its steps, not only
inside the native gathers: the run passes its progress to the cache, and a cancel there stops
the run with IllumapCancelled before the cache weighs its receivers again."""

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import add_lamp, requires_core

from addon import pipeline
from addon.errors import IllumapCancelled
from reference_helpers import closed_box, diffuse, plane

pytestmark = requires_core


def _scan_in_a_lit_box():
    """A floor and a closed box scanned as one point cloud (the meshes hidden), lit by an
    area lamp."""
    white = diffuse("W")
    floor = plane("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], 0.04, white)
    box = closed_box("Box", (-0.3, -0.3, 0.0), (0.3, 0.3, 0.6), 0.04, white)
    add_lamp("AREA", location=(0.6, -0.5, 1.8), energy=300.0, size=0.4)
    pos = []
    for m in (floor, box):
        p = np.empty(len(m.data.vertices) * 3)
        m.data.vertices.foreach_get("co", p)
        pos.append(p.reshape(-1, 3) + np.asarray(m.location))
        m.hide_set(True)
        m.hide_render = True
    pos = np.concatenate(pos)
    data = bpy.data.meshes.new("ScanData")
    data.vertices.add(len(pos))
    data.vertices.foreach_set("co", pos.ravel())
    scan = bpy.data.objects.new("Scan", data)
    bpy.context.scene.collection.objects.link(scan)
    return scan


def test_a_cancel_while_the_cache_weighs_its_receivers_stops_the_run(monkeypatch):
    import illumap.irradiance_cache as ic
    scan = _scan_in_a_lit_box()
    given = []
    real_cache, real_weights = ic.cached_gather, ic._weights

    def cache(*args, progress=None, **kwargs):
        given.append(progress)
        return real_cache(*args, progress=progress, **kwargs)

    weighed = []
    monkeypatch.setattr(ic, "cached_gather", cache)
    monkeypatch.setattr(ic, "_weights", lambda *a, **k: weighed.append(1) or real_weights(*a, **k))
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [scan], pipeline.Settings())
    asked = []

    def progress(fraction, phase=""):
        asked.append(phase)
        return not weighed            # cancel at the first report after the cache weighs

    with pytest.raises(IllumapCancelled):
        pipeline.run(job, progress)
    assert len(given) == 1 and given[0] is not None
    assert len(weighed) == 1 and asked[-1] == ic.PHASE


def test_a_cancel_during_the_points_lamp_shadows_stops_the_run(monkeypatch):
    """The receivers' lamp shadows (39 rays per point at default settings) hear the run's
    progress: a cancel while they are cast stops the run there, before the gather."""
    import types
    import illumap.gather.evaluation as ev
    import illumap.irradiance_cache as ic
    scan = _scan_in_a_lit_box()
    real = ev.lights
    casting = []

    def incident_radiance(*args, shadows=None, **kwargs):
        casting.append(shadows is not None and shadows.progress is not None)
        try:
            return real.incident_radiance(*args, shadows=shadows, **kwargs)
        finally:
            casting.append(False)

    monkeypatch.setattr(ev, "lights", types.SimpleNamespace(
        Shadows=real.Shadows, incident_radiance=incident_radiance))
    gathered = []
    monkeypatch.setattr(ic, "cached_gather", lambda *a, **k: gathered.append(1))
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [scan], pipeline.Settings())
    heard = []

    def progress(fraction, phase=""):
        if casting and casting[-1]:
            heard.append(phase)
            return False              # cancel while the points' shadows are cast
        return True

    with pytest.raises(IllumapCancelled):
        pipeline.run(job, progress)
    assert heard and casting[0] is True and not gathered
