"""The add-on's UI: registration, settings and presets, the Compute operator (synchronous path,
errors, cancel, undo), the worker's state machine, the panel, and the reduced UI.

Notes on what the bpy module allows headless:

* An operator called from Python that reports an ERROR makes ``bpy.ops`` raise RuntimeError
  with the report's text (that is how Blender hands reports to scripts); the operator itself
  returned CANCELLED without a traceback. Tests check that text.
* Operators called from Python push no undo step, and undo starts disabled in background mode;
  the UI pushes a step after every operator with the UNDO flag. The undo test does the same
  with ``ed.undo_push`` and then checks that ``ed.undo`` restores the file.
* Timers never fire, so the modal path is tested by driving ``ComputeTask`` and
  ``finish_task`` (what ``modal`` calls) directly.
"""

import dataclasses
import importlib
import os
import sys
import threading
import time
import types

import numpy as np
import pytest

import bpy

from illumap import lights
from illumap_bpy_testing import (REPO_ROOT, diffuse_material, emission_material, make_plane,
                                 requires_core, select_only, snapshot)

SURFELS = "Illumap Surfels"


# --- a stand-in pipeline (the contract of docs/architecture.md, no native code) -------------

class FakeCancelled(Exception):
    pass


def _make_fake_pipeline():
    fake = types.ModuleType("addon.pipeline")

    from illumap.settings import Settings   # the one declaration, as the real pipeline

    @dataclasses.dataclass
    class Job:
        settings: object
        positions: np.ndarray

    @dataclasses.dataclass
    class Result:
        radiosity: np.ndarray
        iterations: int
        residuals: list
        converged: bool
        timings: dict
        count: int
        warnings: list = dataclasses.field(default_factory=list)
        object_name: str = ""

    fake.calls = []
    fake.fail_with = None
    fake.steps = 5
    fake.step_delay = 0.0

    def prepare(depsgraph, objects, settings, build=True):
        fake.calls.append(("prepare", [o.name for o in objects], settings))
        chunks = []
        for obj in objects:
            mesh = obj.evaluated_get(depsgraph).data
            co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
            mesh.vertices.foreach_get("co", co)
            co = co.reshape(-1, 3) @ np.array(obj.matrix_world)[:3, :3].T + \
                np.array(obj.matrix_world)[:3, 3]
            chunks.append(co)
        return Job(settings, np.concatenate(chunks))

    def run(job, progress=None):
        for k in range(fake.steps):
            if progress is not None and progress(k / fake.steps, "solve") is False:
                raise FakeCancelled("Cancelled")
            time.sleep(fake.step_delay)
        if fake.fail_with is not None:
            raise fake.fail_with
        n = len(job.positions)
        return Result(radiosity=np.full((n, 3), 0.5), iterations=3, residuals=[1.0, 0.1, 0.01],
                      converged=True, timings={"sampling": 0.1, "solve": 0.2}, count=n,
                      warnings=["material 'X' fell back to grey"])

    def run_passes(job, progress=None, on_main=None):
        return run(job, progress)     # one pass: the fake has no second

    def write(context, job, result):
        n = len(job.positions)
        mesh = bpy.data.meshes.new(SURFELS)
        mesh.vertices.add(n)
        mesh.vertices.foreach_set("co", job.positions.astype(np.float32).ravel())
        for name, kind, key, values in (
                ("illumination", "FLOAT_COLOR", "color", np.c_[result.radiosity, np.ones(n)]),
                ("normal", "FLOAT_VECTOR", "vector", np.tile([0.0, 0.0, 1.0], (n, 1))),
                ("radius", "FLOAT", "value", np.full(n, 0.05)),
                ("albedo", "FLOAT_COLOR", "color", np.tile([0.8, 0.8, 0.8, 1.0], (n, 1))),
                ("emission", "FLOAT_COLOR", "color", np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)))):
            attr = mesh.attributes.new(name, kind, "POINT")
            attr.data.foreach_set(key, np.asarray(values, dtype=np.float32).ravel())
        old = bpy.data.objects.get(SURFELS)
        if old is not None:
            old_mesh = old.data
            old.data = mesh
            bpy.data.meshes.remove(old_mesh)
            obj = old
        else:
            obj = bpy.data.objects.new(SURFELS, mesh)
            context.scene.collection.objects.link(obj)
        result.object_name = obj.name
        return obj

    def compute(context, objects, settings, progress=None):
        job = prepare(context.evaluated_depsgraph_get(), objects, settings)
        result = run(job, progress)
        write(context, job, result)
        return result

    fake.Settings, fake.Job, fake.Result = Settings, Job, Result
    fake.prepare, fake.run, fake.write, fake.compute = prepare, run, write, compute
    fake.run_passes = run_passes
    return fake


def _reregister(addon):
    addon.unregister()
    addon.register()


@pytest.fixture
def fake_pipeline(registered_addon):
    """Swap addon.pipeline for the stand-in and register the full UI with it."""
    addon = registered_addon
    saved_module = sys.modules.get("addon.pipeline")
    saved_attr = addon.__dict__.get("pipeline")
    saved_import = addon.core_status._import_native
    fake = _make_fake_pipeline()
    sys.modules["addon.pipeline"] = fake
    addon.pipeline = fake
    addon.core_status._import_native = lambda: None
    _reregister(addon)
    try:
        yield fake
    finally:
        addon.core_status._import_native = saved_import
        if saved_module is not None:
            sys.modules["addon.pipeline"] = saved_module
        else:
            sys.modules.pop("addon.pipeline", None)
        if saved_attr is not None:
            addon.pipeline = saved_attr
        else:
            addon.__dict__.pop("pipeline", None)
        _reregister(addon)


@pytest.fixture
def two_planes():
    floor = make_plane("Floor", 1.0, material=diffuse_material("White", (0.8, 0.8, 0.8)))
    light = make_plane("Light", 0.2, location=(0.0, 0.0, 1.0), flip=True,
                       material=emission_material("Light", (1.0, 1.0, 1.0)))
    select_only(floor, light)
    return floor, light


# --- registration, preferences, settings -----------------------------------------------------

def test_registered(registered_addon):
    for name in ("VIEW3D_PT_illumap", "VIEW3D_PT_illumap_advanced", "VIEW3D_PT_illumap_preview",
                 "VIEW3D_PT_illumap_stats", "ILLUMAP_OT_build_preview",
                 "ILLUMAP_OT_clear_results", "ILLUMAP_OT_reset_settings"):
        assert hasattr(bpy.types, name), name
    assert bpy.types.VIEW3D_PT_illumap.bl_category == "Illumap"
    assert bpy.types.VIEW3D_PT_illumap_advanced.bl_options == {"DEFAULT_CLOSED"}
    # The preview a user meets is on the main panel (Preview On/Off); its options and the
    # last run's details are folded away under Advanced.
    for name in ("VIEW3D_PT_illumap_preview", "VIEW3D_PT_illumap_stats"):
        panel_type = getattr(bpy.types, name)
        assert panel_type.bl_parent_id == "VIEW3D_PT_illumap_advanced"
        assert panel_type.bl_options == {"DEFAULT_CLOSED"}
    assert isinstance(bpy.context.scene.illumap, bpy.types.PropertyGroup)
    if registered_addon.core_error() is None:
        assert hasattr(bpy.types, "ILLUMAP_OT_compute_illumination_map")
        op = bpy.ops.illumap.compute_illumination_map
        assert op.get_rna_type().name == "Compute Illumination Map"
        assert {"REGISTER", "UNDO"} <= set(bpy.types.ILLUMAP_OT_compute_illumination_map.bl_options)


def test_compute_operator_registered_with_pipeline(fake_pipeline):
    assert hasattr(bpy.types, "ILLUMAP_OT_compute_illumination_map")
    assert bpy.ops.illumap.compute_illumination_map.poll()


def test_preferences_package_name():
    from addon.ui import preferences
    assert preferences._addon_package("bl_ext.user_default.illumap.addon") == \
        "bl_ext.user_default.illumap"
    assert preferences._addon_package("illumap.addon") == "illumap"
    assert preferences._addon_package("addon") == "addon"
    assert preferences.IllumapPreferences.bl_idname == preferences.ADDON_PACKAGE == "addon"
    # From a checkout the add-on is not enabled, so callers fall back to built-in defaults.
    assert preferences.get_preferences() is None


def test_scene_settings_start_from_defaults_and_presets_fill_fields(registered_addon):
    from addon.ui import properties
    props = bpy.context.scene.illumap
    assert props.initialized  # load_post ran after the factory reset
    assert props.preset == "MEDIUM"
    for name in ("DRAFT", "MEDIUM", "HIGH"):
        props.preset = name
        for key, value in properties.PRESET_PROPERTY_VALUES[name].items():
            got = getattr(props, key)
            assert got == pytest.approx(value, rel=1e-6) if isinstance(value, float) else got == value
        assert props.preset == name  # applying a preset does not mark it Custom
    assert set(properties.PRESET_PROPERTY_VALUES) == {"DRAFT", "MEDIUM", "HIGH"}
    assert properties.PRESET_PROPERTY_VALUES["HIGH"]["order"] > properties.PRESET_PROPERTY_VALUES["DRAFT"]["order"]
    assert properties.PRESET_PROPERTY_VALUES["HIGH"]["budget"] > properties.PRESET_PROPERTY_VALUES["DRAFT"]["budget"]
    assert properties.PRESET_PROPERTY_VALUES["HIGH"]["gather_rays"] > properties.PRESET_PROPERTY_VALUES["DRAFT"]["gather_rays"]
    props.preset = "DRAFT"
    props.build_preview = False  # not a solver setting: stays Draft
    assert props.preset == "DRAFT"
    props.order = 7
    assert props.preset == "CUSTOM"
    props.preset = "HIGH"
    assert props.order == properties.PRESET_PROPERTY_VALUES["HIGH"]["order"]


def test_settings_reach_the_pipeline_settings(registered_addon):
    from addon import pipeline
    from addon.ui import properties
    props = bpy.context.scene.illumap
    props.preset = "DRAFT"
    props.solver = "GMRES"
    settings = properties.make_settings(props, pipeline.Settings)
    assert isinstance(settings, pipeline.Settings)
    draft = pipeline.QUALITY_PRESETS["DRAFT"]
    assert settings.budget == draft["budget"] and settings.density is None
    assert settings.order == draft["order"]
    assert settings.visibility == draft["visibility"] == "exact"
    assert settings.gather_rays == draft["gather_rays"]
    assert settings.tol == pytest.approx(draft["tol"], rel=1e-6)
    assert settings.solver == "gmres"
    props.budget = 1234
    settings = properties.make_settings(props, pipeline.Settings)
    assert settings.budget == 1234 and settings.density is None
    props.sampling = "DENSITY"
    props.density = 55.0
    settings = properties.make_settings(props, pipeline.Settings)
    assert settings.budget is None and settings.density == pytest.approx(55.0)


def test_a_target_error_chooses_the_count_in_the_ui(registered_addon):
    """With Target Error on, neither the Budget nor the Density field reaches the pipeline
    (a preset's budget would silently cap the count the target asks for), and the panel
    greys them out."""
    from addon.ui import panel, properties
    from addon import pipeline
    props = bpy.context.scene.illumap
    props.preset = "MEDIUM"
    for sampling in ("BUDGET", "DENSITY"):
        props.sampling = sampling
        props.use_target_error, props.target_error = True, 0.01
        settings = properties.make_settings(props, pipeline.Settings)
        assert settings.target_error == pytest.approx(0.01)
        assert settings.budget is None and settings.density is None
        layout = LayoutRecorder()
        panel.draw_advanced(layout, bpy.context)
        assert "sampling" in layout.inactive_props(), layout.inactive_props()
        props.use_target_error = False
        settings = properties.make_settings(props, pipeline.Settings)
        assert (settings.budget is None) == (sampling == "DENSITY")
        layout = LayoutRecorder()
        panel.draw_advanced(layout, bpy.context)
        assert "sampling" not in layout.inactive_props()


def test_occluder_shape_reaches_the_pipeline_settings(registered_addon):
    """Occluder Shape: discs by default, the core's spelling in the pipeline's settings; like
    the solver it is no preset's value, so changing it keeps the preset."""
    from addon import pipeline
    from addon.ui import properties
    props = bpy.context.scene.illumap
    props.preset = "HIGH"
    assert properties.make_settings(props, pipeline.Settings).occluder_shape == "disc"
    props.occluder_shape = "OCTAGON"
    assert properties.make_settings(props, pipeline.Settings).occluder_shape == "octagon"
    assert props.preset == "HIGH"
    from illumap.settings import spec
    offered = {item.identifier.lower()
               for item in props.bl_rna.properties["occluder_shape"].enum_items}
    assert offered == set(spec("occluder_shape").values)
    from illumap.occluders import OCCLUDER_SHAPES   # the core's spelling of the same shapes
    assert offered == set(OCCLUDER_SHAPES)


def test_reset_settings_operator(registered_addon):
    props = bpy.context.scene.illumap
    props.preset = "HIGH"
    props.order = 9
    assert bpy.ops.illumap.reset_settings() == {"FINISHED"}
    assert props.preset == "MEDIUM" and props.order != 9


# --- the Compute operator, synchronous path (stand-in pipeline) ------------------------------

def test_compute_writes_attribute_stats_and_preview(fake_pipeline, two_planes):
    """The stand-in lights no object (no transfer): the surfels' discs are what there is to
    show, so they are shown."""
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    obj = bpy.data.objects[SURFELS]
    assert "illumination" in obj.data.attributes
    assert [m.name for m in obj.modifiers] == ["Illumap Preview"]
    stats = bpy.context.scene.illumap.stats
    assert stats.valid and stats.surfels == 8 and stats.iterations == 3
    assert stats.residual == pytest.approx(0.01)
    assert {p.name for p in stats.phases} == {"sampling", "solve"}
    _, names, settings = fake_pipeline.calls[0]
    assert sorted(names) == ["Floor", "Light"]
    assert settings.order == bpy.context.scene.illumap.order
    # A re-run replaces the surfel object and keeps one preview modifier.
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    assert [o.name for o in bpy.data.objects if o.name.startswith(SURFELS)] == [SURFELS]
    assert len(bpy.data.objects[SURFELS].modifiers) == 1


def test_nothing_selected_is_reported(fake_pipeline):
    make_plane("Floor")
    select_only()
    before = snapshot()
    with pytest.raises(RuntimeError, match="Nothing selected: select the mesh or point-cloud"):
        bpy.ops.illumap.compute_illumination_map()
    assert snapshot() == before
    assert fake_pipeline.calls == []


def test_only_unsupported_objects_selected_is_reported(fake_pipeline):
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    bpy.context.scene.collection.objects.link(cam)
    select_only(cam)
    with pytest.raises(RuntimeError, match=r"No mesh or point-cloud objects selected \(selected: camera\)"):
        bpy.ops.illumap.compute_illumination_map()


def test_surfel_object_alone_is_not_an_input(fake_pipeline, two_planes):
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    select_only(bpy.data.objects[SURFELS])
    with pytest.raises(RuntimeError, match="Only Illumap's surfel object is selected"):
        bpy.ops.illumap.compute_illumination_map()
    # Selected together with the sources, it is left out of the input.
    select_only(bpy.data.objects[SURFELS], *two_planes)
    fake_pipeline.calls.clear()
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    assert sorted(fake_pipeline.calls[0][1]) == ["Floor", "Light"]


def test_pipeline_error_is_reported_and_nothing_written(fake_pipeline, two_planes):
    from addon.errors import IllumapError
    fake_pipeline.fail_with = IllumapError("Object 'Floor' has zero-area faces")
    before = snapshot()
    with pytest.raises(RuntimeError, match="Illumap failed: Object 'Floor' has zero-area faces"):
        bpy.ops.illumap.compute_illumination_map()
    assert snapshot() == before
    assert not bpy.context.scene.illumap.stats.valid


def test_unexpected_error_names_its_type(fake_pipeline, two_planes):
    fake_pipeline.fail_with = KeyError("boom")
    with pytest.raises(RuntimeError, match="Illumap failed: KeyError: 'boom'"):
        bpy.ops.illumap.compute_illumination_map()


def test_undo_restores_the_file(fake_pipeline, two_planes):
    bpy.ops.ed.undo_push(message="before")  # undo starts disabled in background mode
    before = snapshot()
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    bpy.ops.ed.undo_push(message="Compute Illumination Map")  # what the UI does after UNDO ops
    assert SURFELS in bpy.data.objects
    bpy.ops.ed.undo()
    assert snapshot() == before
    bpy.ops.ed.redo()
    assert SURFELS in bpy.data.objects


# --- the worker's state machine (the modal path without timers) ------------------------------

def _task_for(fake, objects):
    from addon.ui import operators
    settings = fake.Settings()
    job = fake.prepare(bpy.context.evaluated_depsgraph_get(), objects, settings)
    return operators.ComputeTask(job, fake.run)


def test_task_runs_on_a_worker_thread_and_writes_on_finish(fake_pipeline, two_planes):
    from addon.ui import operators
    seen = []
    original_run = fake_pipeline.run

    def run(job, progress):
        seen.append(threading.current_thread().name)
        return original_run(job, progress)

    task = _task_for(fake_pipeline, two_planes)
    task._run = run
    assert task.state == "PENDING"
    task.start()
    assert task.wait(10) == "DONE"
    assert seen == ["illumap-compute"] and task.fraction == pytest.approx(0.8)
    assert task.phase == "solve"
    reports = []
    assert operators.finish_task(bpy.context, task, lambda k, m: reports.append((k, m))) == \
        {"FINISHED"}
    assert "illumination" in bpy.data.objects[SURFELS].data.attributes
    assert bpy.context.scene.illumap.stats.surfels == 8
    assert any(k == {"WARNING"} and "fell back" in m for k, m in reports)
    assert reports[-1][0] == {"INFO"}


def test_cancelled_task_leaves_the_file_untouched(fake_pipeline, two_planes):
    from addon.ui import operators
    fake_pipeline.steps = 200
    fake_pipeline.step_delay = 0.005
    before = snapshot()
    task = _task_for(fake_pipeline, two_planes).start()
    while task.fraction == 0.0 and task.state == "RUNNING":
        time.sleep(0.002)
    assert task.state == "RUNNING"
    assert "Esc to cancel" in task.status_text()
    task.cancel()  # what Esc does in modal()
    assert "cancelling" in task.status_text()
    assert task.wait(10) == "CANCELLED"
    assert isinstance(task.error, FakeCancelled) and task.result is None
    reports = []
    assert operators.finish_task(bpy.context, task, lambda k, m: reports.append((k, m))) == \
        {"CANCELLED"}
    assert reports == [({"WARNING"}, "Illumap: cancelled, nothing was written")]
    assert snapshot() == before


def test_cancel_after_the_result_arrived_still_writes_nothing(fake_pipeline, two_planes):
    from addon.ui import operators
    before = snapshot()
    task = _task_for(fake_pipeline, two_planes).start()
    task.wait(10)
    task.cancel()  # Esc pressed between the worker finishing and the next timer tick
    assert task.state == "CANCELLED"
    assert operators.finish_task(bpy.context, task, lambda k, m: None) == {"CANCELLED"}
    assert snapshot() == before


def test_failed_task_is_reported(fake_pipeline, two_planes):
    from addon.ui import operators
    from addon.errors import IllumapError
    fake_pipeline.fail_with = IllumapError("Solver failed: diverged")
    before = snapshot()
    task = _task_for(fake_pipeline, two_planes).start()
    assert task.wait(10) == "FAILED"
    reports = []
    assert operators.finish_task(bpy.context, task, lambda k, m: reports.append((k, m))) == \
        {"CANCELLED"}
    assert reports == [({"ERROR"}, "Illumap failed: Solver failed: diverged")]
    assert snapshot() == before


def _fake_operator(task):
    """An object that borrows the operator's modal methods, to drive ``modal`` without a
    window: timers and events cannot be made headless, so events are plain namespaces."""
    cls = bpy.types.ILLUMAP_OT_compute_illumination_map
    fake = types.SimpleNamespace(_task=task, _timer=None, reports=[])
    fake.report = lambda kind, message: fake.reports.append((kind, message))
    fake._status = types.MethodType(cls._status, fake)
    fake._cleanup = types.MethodType(cls._cleanup, fake)
    fake.modal = types.MethodType(cls.modal, fake)
    return fake


def _event(kind, value="NOTHING"):
    return types.SimpleNamespace(type=kind, value=value)


def test_modal_steps_cancel_on_esc(fake_pipeline, two_planes):
    fake_pipeline.steps = 400
    fake_pipeline.step_delay = 0.005
    before = snapshot()
    task = _task_for(fake_pipeline, two_planes).start()
    op = _fake_operator(task)
    while task.phase == "starting" and task.state == "RUNNING":
        time.sleep(0.002)
    assert op.modal(bpy.context, _event("MOUSEMOVE")) == {"PASS_THROUGH"}
    assert op.modal(bpy.context, _event("TIMER")) == {"RUNNING_MODAL"}
    # While it runs, the panel shows progress instead of the Compute button.
    from addon.ui import operators, panel
    operators._current["task"] = task
    layout = LayoutRecorder()
    panel.draw_main(layout, bpy.context)
    assert layout.texts("label")[0].startswith("Computing: solve")
    assert "illumap.compute_illumination_map" not in layout.texts("operator")
    assert op.modal(bpy.context, _event("ESC", "PRESS")) == {"RUNNING_MODAL"}
    assert task.cancel_requested
    task.wait(10)
    assert op.modal(bpy.context, _event("TIMER")) == {"CANCELLED"}
    assert operators.current_task() is None and operators._current["task"] is None
    assert op.reports == [({"WARNING"}, "Illumap: cancelled, nothing was written")]
    assert snapshot() == before


def test_modal_finishes_and_writes(fake_pipeline, two_planes):
    task = _task_for(fake_pipeline, two_planes).start()
    op = _fake_operator(task)
    task.wait(10)
    assert op.modal(bpy.context, _event("TIMER")) == {"FINISHED"}
    assert "illumination" in bpy.data.objects[SURFELS].data.attributes
    assert op.reports[-1][0] == {"INFO"}


def test_invoke_headless_runs_synchronously(fake_pipeline, two_planes):
    assert bpy.app.background
    assert bpy.ops.illumap.compute_illumination_map("INVOKE_DEFAULT") == {"FINISHED"}
    assert SURFELS in bpy.data.objects


# --- the real pipeline and core ------------------------------------------------------------

@requires_core
def test_compute_with_the_real_pipeline(registered_addon, two_planes):
    props = bpy.context.scene.illumap
    props.preset = "DRAFT"
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    obj = bpy.data.objects[SURFELS]
    attrs = obj.data.attributes
    for name in ("illumination", "normal", "radius", "albedo", "emission"):
        assert name in attrs, name
    assert attrs["illumination"].data_type == "FLOAT_COLOR"
    n = len(attrs["illumination"].data)
    values = np.empty(n * 4, dtype=np.float32)
    attrs["illumination"].data.foreach_get("color", values)
    values = values.reshape(n, 4)
    assert np.isfinite(values).all() and values[:, :3].max() > 0.0
    assert props.stats.valid and props.stats.surfels == n
    # What the user meets: the light on their own meshes (Object Preview); the surfels are
    # a diagnostic, hidden in the viewport and in renders, with no preview of their own.
    assert obj.modifiers[:] == [] and obj.hide_viewport and obj.hide_render
    for name in ("Floor", "Light"):
        assert [m.name for m in bpy.data.objects[name].modifiers] == ["Illumap Mesh Preview"]
    # Asked for, they show (and render); hidden again on request.
    assert bpy.ops.illumap.build_preview() == {"FINISHED"}
    assert [m.name for m in obj.modifiers] == ["Illumap Preview"]
    assert not obj.hide_viewport and not obj.hide_render
    assert bpy.ops.illumap.build_preview(show=False) == {"FINISHED"}
    assert obj.modifiers[:] == [] and obj.hide_viewport and obj.hide_render
    # Show Surfels: after the next Compute they show beside the Object Preview.
    props.show_surfels = True
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    obj = bpy.data.objects[SURFELS]
    assert [m.name for m in obj.modifiers] == ["Illumap Preview"] and not obj.hide_render
    assert "Illumap Mesh Preview" in bpy.data.objects["Floor"].modifiers
    # Clear Results removes the object and its point cloud, and the stats.
    assert bpy.ops.illumap.clear_results() == {"FINISHED"}
    assert SURFELS not in bpy.data.objects and SURFELS not in bpy.data.pointclouds
    assert SURFELS not in bpy.data.meshes and not props.stats.valid


@requires_core
def test_real_pipeline_cancel_leaves_the_file_untouched(registered_addon, two_planes):
    """pipeline.run with a progress that cancels at once: IllumapCancelled, nothing written."""
    from addon.ui import operators, properties
    from addon import pipeline
    settings = properties.make_settings(bpy.context.scene.illumap, pipeline.Settings)
    before = snapshot()
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), list(two_planes), settings)
    task = operators.ComputeTask(job, pipeline.run)
    task.cancel()
    task.start()
    assert task.wait(60) == "CANCELLED"
    assert operators.finish_task(bpy.context, task, lambda k, m: None) == {"CANCELLED"}
    assert snapshot() == before


JOB_ARRAYS = ("positions", "normals", "areas", "albedo", "emission", "solve_emission",
              "triangles", "two_sided", "mesh_triangle_start")


@requires_core
def test_the_worker_builds_the_scene_the_main_thread_read(registered_addon, two_planes):
    """An interactive run reads the scene on the main thread (``prepare(build=False)``) and
    builds the job on its worker (splats, ray-casting structure, the open surfaces' back
    faces): the job is the one ``prepare`` builds at once, and the run writes as usual."""
    from addon.ui import operators, properties
    from addon import pipeline
    settings = properties.make_settings(bpy.context.scene.illumap, pipeline.Settings)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    built = pipeline.prepare(depsgraph, list(two_planes), settings)
    unbuilt = pipeline.prepare(depsgraph, list(two_planes), settings, build=False)
    assert isinstance(unbuilt, pipeline.UnbuiltJob)
    with pytest.raises(TypeError):
        pipeline.run(unbuilt)
    task = operators.ComputeTask(unbuilt, pipeline.run).start()
    assert task.wait(60) == "DONE", task.error
    assert isinstance(task.job, pipeline.Job)
    assert task.job.occluders is not None      # open planes: their back faces were probed
    for name in JOB_ARRAYS:
        np.testing.assert_array_equal(getattr(task.job, name), getattr(built, name), err_msg=name)
    assert operators.finish_task(bpy.context, task, lambda k, m: None) == {"FINISHED"}
    assert "illumination" in bpy.data.objects[SURFELS].data.attributes


@requires_core
def test_building_a_read_scene_needs_no_blender_data(registered_addon, two_planes):
    """What the worker builds from holds no Blender data: it builds the same job after the
    objects, their meshes and materials are gone, and a cancel while it builds stops it."""
    from addon import pipeline
    from addon.ui import properties
    from addon.errors import IllumapCancelled
    settings = properties.make_settings(bpy.context.scene.illumap, pipeline.Settings)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    built = pipeline.prepare(depsgraph, list(two_planes), settings)
    unbuilt = pipeline.prepare(depsgraph, list(two_planes), settings, build=False)
    cancelled = pipeline.prepare(depsgraph, list(two_planes), settings, build=False)
    for obj in two_planes:
        mesh = obj.data
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)
    for material in list(bpy.data.materials):
        bpy.data.materials.remove(material)
    job = unbuilt.build()
    for name in JOB_ARRAYS:
        np.testing.assert_array_equal(getattr(job, name), getattr(built, name), err_msg=name)
    phases = []
    with pytest.raises(IllumapCancelled):
        cancelled.build(lambda fraction, phase="": phases.append(phase) or False)
    assert phases == [pipeline.BUILD_PHASE]


@requires_core
def test_real_pipeline_modal_logic_writes(registered_addon, two_planes):
    from addon.ui import operators, properties
    from addon import pipeline
    props = bpy.context.scene.illumap
    props.preset = "DRAFT"
    settings = properties.make_settings(props, pipeline.Settings)
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), list(two_planes), settings)
    task = operators.ComputeTask(job, pipeline.run).start()
    assert task.wait(60) == "DONE", task.error
    assert operators.finish_task(bpy.context, task, lambda k, m: None) == {"FINISHED"}
    assert "illumination" in bpy.data.objects[SURFELS].data.attributes


@requires_core
def test_real_pipeline_modal_runs_the_adaptive_second_pass(registered_addon, two_planes):
    """With a target error the worker runs both passes in one loop (``illumap.run``): when
    pass 1 is done it waits for the timer handler, which reads pass 2 on the main thread
    (``ComputeTask.serve_main``); the result is written only after pass 2, and the file is
    untouched in between."""
    from addon.ui import operators, properties
    from addon import pipeline
    props = bpy.context.scene.illumap
    props.use_target_error, props.target_error, props.adaptive = True, 0.1, True
    settings = properties.make_settings(props, pipeline.Settings)
    assert settings.target_error == pytest.approx(0.1) and settings.adaptive
    settings.budget = 400           # a cap, as the batch job's --budget gives, to fix the counts
    before = snapshot()
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), list(two_planes), settings)
    assert job.count == 200 and job.refine is not None
    task = operators.ComputeTask.all_passes(job, pipeline.run_passes).start()
    op = _fake_operator(task)
    deadline = time.monotonic() + 60
    while task.state == "RUNNING" and not task.waiting_on_main and time.monotonic() < deadline:
        time.sleep(0.005)
    assert task.state == "RUNNING" and task.waiting_on_main, (task.state, task.error)
    assert snapshot() == before
    assert op.modal(bpy.context, _event("TIMER")) == {"RUNNING_MODAL"}   # reads pass 2
    assert not task.waiting_on_main and op._task is task
    assert task.wait(60) == "DONE", task.error
    assert task.job.count == 400 and task.job.refine is None   # the last pass's job
    assert snapshot() == before
    assert op.modal(bpy.context, _event("TIMER")) == {"FINISHED"}
    stats = props.stats
    assert stats.surfels == 400 and stats.first_pass_surfels == 200
    assert any(p.name.startswith("pass 1: ") for p in stats.phases)
    assert operators._current["task"] is None
    from addon.ui import panel
    layout = LayoutRecorder()
    panel.draw_stats(layout, bpy.context)
    labels = layout.texts("label")
    assert any(t.startswith("Density for target: ") for t in labels), labels
    assert any(t.startswith("Adaptive pass 1: 200 surfels") for t in labels), labels
    layout = LayoutRecorder()
    panel.draw_main(layout, bpy.context)
    panel.draw_advanced(layout, bpy.context)
    for name in ("use_target_error", "target_error", "adaptive", "lamp_shadows", "shadow_samples"):
        assert name in layout.texts("prop"), name


@requires_core
def test_real_pipeline_modal_cancel_during_second_pass(registered_addon, two_planes):
    from addon.ui import operators, properties
    from addon import pipeline
    props = bpy.context.scene.illumap
    props.use_target_error, props.target_error = True, 0.1
    settings = properties.make_settings(props, pipeline.Settings)
    settings.budget = 400
    before = snapshot()
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), list(two_planes), settings)
    task = operators.ComputeTask.all_passes(job, pipeline.run_passes).start()
    op = _fake_operator(task)
    deadline = time.monotonic() + 60
    while task.state == "RUNNING" and not task.waiting_on_main and time.monotonic() < deadline:
        time.sleep(0.005)
    assert task.waiting_on_main, (task.state, task.error)
    assert op.modal(bpy.context, _event("TIMER")) == {"RUNNING_MODAL"}   # reads pass 2
    task.cancel()           # Esc while pass 2 runs
    assert task.wait(60) == "CANCELLED"
    assert op.modal(bpy.context, _event("TIMER")) == {"CANCELLED"}
    assert snapshot() == before and operators._current["task"] is None


def _waiting(task, seconds=10.0):
    deadline = time.monotonic() + seconds
    while task.state == "RUNNING" and not task.waiting_on_main and time.monotonic() < deadline:
        time.sleep(0.002)
    return task.waiting_on_main


def test_a_worker_waiting_for_the_main_thread_is_cancelled_and_hears_its_errors():
    """``call_on_main``: the worker waits until the timer serves its call, gets the call's
    value, or what it raised; Esc while it waits stops it at once."""
    from addon.ui import operators
    task = operators.ComputeTask.all_passes(
        None, lambda job, progress, on_main: on_main(lambda: "read on the main thread")).start()
    assert _waiting(task) and task.serve_main() and not task.serve_main()
    assert task.wait(10) == "DONE" and task.result == "read on the main thread"

    def broken():
        raise ValueError("the scene changed")
    task = operators.ComputeTask.all_passes(
        None, lambda job, progress, on_main: on_main(broken)).start()
    assert _waiting(task) and task.serve_main()
    assert task.wait(10) == "FAILED" and isinstance(task.error, ValueError)

    task = operators.ComputeTask.all_passes(
        None, lambda job, progress, on_main: on_main(lambda: "never served")).start()
    assert _waiting(task)
    task.cancel()
    assert task.wait(10) == "CANCELLED" and task.result is None
    assert not task.serve_main()     # nothing left to serve


def _lamp_scene(size=4.0):
    """A floor under a plate and a sized area lamp: every floor surfel casts shadow rays."""
    mat = diffuse_material("White", (0.8, 0.8, 0.8))
    floor = make_plane("Floor", size, material=mat)
    plate = make_plane("Plate", 1.0, location=(0.0, 0.0, 1.0), material=mat)
    lamp = bpy.data.lights.new("Area", "AREA")
    lamp.energy, lamp.size = 100.0, 0.5
    obj = bpy.data.objects.new("Area", lamp)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = (0.0, 0.0, 3.0)
    select_only(floor, plate)
    return floor, plate


def _lamp_settings(**values):
    from addon import pipeline
    from addon.ui import properties
    props = bpy.context.scene.illumap
    props.preset = "DRAFT"
    props.lamps = props.lamp_shadows = True
    for name, value in values.items():
        setattr(props, name, value)
    if "density" in values:
        props.sampling = "DENSITY"
    return properties.make_settings(props, pipeline.Settings)


@requires_core
def test_real_pipeline_modal_cancel_during_lamp_shadows(registered_addon, monkeypatch):
    """Shadow rays run on the worker (prepare casts none), the status line names the phase,
    and Esc stops them mid-phase: the worker returns before the remaining ray batches, the
    report is clear and the file is untouched."""
    from addon.ui import operators
    from addon import pipeline
    _lamp_scene()
    # (16 + 1) m² × 6400 = 108,800 lit surfels × 64 rays: seven batches of 2^20 rays.
    settings = _lamp_settings(density=6400.0, shadow_samples=64)
    from illumap.stages import light as light_stage
    real = light_stage.shadow_query
    calls = {"started": 0, "finished": 0}

    def counting(job, normals, progress=None):
        query = real(job, normals, progress)

        def visible(origins, targets, skip, progress=None):
            calls["started"] += 1
            out = query(origins, targets, skip, progress)
            calls["finished"] += 1
            return out
        return visible

    monkeypatch.setattr(light_stage, "shadow_query", counting)
    before = snapshot()
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), bpy.context.selected_objects,
                           settings)
    assert job.direct is None and calls["started"] == 0 and "shadow rays" not in job.timings
    assert job.count > 100_000
    task = operators.ComputeTask(job, pipeline.run).start()
    op = _fake_operator(task)
    deadline = time.monotonic() + 120
    while calls["started"] == 0 and task.state == "RUNNING" and time.monotonic() < deadline:
        time.sleep(0.005)
    assert task.state == "RUNNING" and task.phase == lights.PHASE, (task.state, task.error)
    assert op.modal(bpy.context, _event("TIMER")) == {"RUNNING_MODAL"}
    assert task.status_text().startswith("Illumap: lamp shadows ")
    assert op.modal(bpy.context, _event("ESC", "PRESS")) == {"RUNNING_MODAL"}
    assert task.wait(60) == "CANCELLED", task.error
    assert isinstance(task.error, pipeline.IllumapCancelled) and task.result is None
    # Stopped within the phase: at most the batch in flight completed, no light was stored.
    assert calls["finished"] <= 2 < 7
    assert job.direct is None and "direct light" not in job.timings
    assert op.modal(bpy.context, _event("TIMER")) == {"CANCELLED"}
    assert op.reports == [({"WARNING"}, "Illumap: cancelled, nothing was written")]
    assert snapshot() == before and operators._current["task"] is None


@requires_core
def test_real_pipeline_lamp_shadow_phase_reports_progress_and_timings(registered_addon):
    """The worker reports the shadow phase from 0 to 1 before the solve, and its time reaches
    the result and the statistics; the synchronous operator path records the same phases."""
    from addon.ui import operators
    from addon import pipeline
    _lamp_scene(size=2.0)
    settings = _lamp_settings(density=400.0, shadow_samples=16)
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), bpy.context.selected_objects,
                           settings)
    task = operators.ComputeTask(job, pipeline.run)
    seen = []
    report = task.progress

    def recording(fraction, phase=""):
        seen.append((fraction, phase))
        return report(fraction, phase)
    task.progress = recording
    started = time.perf_counter()
    assert task.start().wait(120) == "DONE", task.error
    elapsed = time.perf_counter() - started
    shadow = [f for f, ph in seen if ph == lights.PHASE]
    first_other = next(i for i, (_, ph) in enumerate(seen) if ph != lights.PHASE)
    assert seen[0][1] == lights.PHASE and all(ph != lights.PHASE for _, ph in seen[first_other:])
    assert shadow[0] == 0.0 and shadow[-1] == 1.0 and np.all(np.diff(shadow) >= 0)
    assert len(shadow) >= 3
    timings = task.result.timings
    # seconds of nested spans: the shadows within the direct light, within the whole run
    assert 0 < timings["shadow rays"] <= timings["direct light"] <= elapsed, (timings, elapsed)
    assert task.result.stats["shadow_rays"] > 16 * 1600 * 0.5
    assert operators.finish_task(bpy.context, task, lambda k, m: None) == {"FINISHED"}
    phases = {p.name: p.seconds for p in bpy.context.scene.illumap.stats.phases}
    assert phases["shadow rays"] == pytest.approx(timings["shadow rays"])
    assert "direct light" in phases and "solve" in phases
    # The synchronous path (background, scripts) runs the same phase.
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    stats = bpy.context.scene.illumap.stats
    assert {"direct light", "shadow rays"} <= {p.name for p in stats.phases}
    assert stats.shadow_rays > 0


# --- panel drawing and the reduced UI -------------------------------------------------------

class LayoutRecorder:
    """Stands in for bpy.types.UILayout: records labels, props and operators."""

    def __init__(self, log=None):
        object.__setattr__(self, "log", [] if log is None else log)

    def __setattr__(self, name, value):
        object.__setattr__(self, name, value)

    def _child(self, *args, **kwargs):
        child = LayoutRecorder(self.log)
        child.active = getattr(self, "active", True)    # Blender's children inherit it
        return child

    row = column = box = split = _child

    def label(self, text="", **kwargs):
        self.log.append(("label", text))

    def prop(self, data, name, **kwargs):
        assert hasattr(data, name), name
        self.log.append(("prop", name))
        if not getattr(self, "active", True):
            self.log.append(("inactive", name))

    def operator(self, idname, **kwargs):
        self.log.append(("operator", idname))
        return types.SimpleNamespace()

    def separator(self, **kwargs):
        pass

    def texts(self, kind):
        return [v for k, v in self.log if k == kind]

    def inactive_props(self):
        return self.texts("inactive")


def test_panel_draws_settings_and_stats(fake_pipeline, two_planes):
    from addon.ui import panel
    layout = LayoutRecorder()
    panel.draw_main(layout, bpy.context)
    assert "illumap.compute_illumination_map" in layout.texts("operator")
    assert "preset" in layout.texts("prop")
    # The Object Preview's switch is on the main panel, beside Compute.
    assert "illumap.mesh_preview" in layout.texts("operator")
    layout = LayoutRecorder()
    panel.draw_advanced(layout, bpy.context)
    props = set(layout.texts("prop"))
    assert {"budget", "order", "visibility", "occluder_shape", "tol", "solver",
            "gather_rays"} <= props
    layout = LayoutRecorder()
    panel.draw_stats(layout, bpy.context)
    assert layout.texts("label") == ["No result yet"]
    bpy.ops.illumap.compute_illumination_map()
    layout = LayoutRecorder()
    panel.draw_stats(layout, bpy.context)
    labels = layout.texts("label")
    assert "Surfels: 8" in labels and "Iterations: 3" in labels
    assert "Final residual: 1.000e-02" in labels and "solve" in labels
    layout = LayoutRecorder()
    panel.draw_preview(layout, bpy.context)
    assert "illumap.build_preview" in layout.texts("operator")
    assert {"build_preview", "show_surfels"} <= set(layout.texts("prop"))


def test_reduced_ui_when_the_core_is_missing(registered_addon):
    addon = registered_addon
    from addon.ui import panel

    def missing():
        raise ModuleNotFoundError("No module named 'illumap'", name="illumap")

    saved = addon.core_status._import_native
    addon.core_status._import_native = missing
    try:
        _reregister(addon)
        assert not hasattr(bpy.types, "ILLUMAP_OT_compute_illumination_map")
        assert hasattr(bpy.types, "VIEW3D_PT_illumap")
        assert hasattr(bpy.types, "ILLUMAP_OT_build_preview")
        error = addon.core_error()
        assert "The native module 'illumap' is not installed." in error
        assert "%d.%d" % sys.version_info[:2] in error  # Blender's Python, whichever it is
        assert not bpy.types.VIEW3D_PT_illumap_advanced.poll(bpy.context)
        layout = LayoutRecorder()
        panel.draw_native_missing(layout, error)
        labels = layout.texts("label")
        assert "Illumap is unavailable" in labels
        assert "The native module 'illumap' is not installed." in labels
        assert not layout.texts("operator")
        # The preferences say it too.
        from addon.ui import preferences
        fake_prefs = types.SimpleNamespace(layout=LayoutRecorder(), default_preset="MEDIUM",
                                           default_lamps=True, default_lamp_shadows=True,
                                           default_world_ambient=False,
                                           default_build_preview=True, default_disc_scale=1.5)
        preferences.IllumapPreferences.draw(fake_prefs, bpy.context)
        labels = fake_prefs.layout.texts("label")
        assert labels[0] == "The native module 'illumap' is not installed."
        assert "default_preset" in fake_prefs.layout.texts("prop")
        # A broken build says what failed to load.
        addon.core_status._import_native = lambda: importlib.import_module("illumap._no_such_module")
        assert "could not be loaded" in addon.check_native()
    finally:
        addon.core_status._import_native = saved
        _reregister(addon)
    assert addon.core_error() is None or "illumap" in addon.core_error()


def test_preferences_as_an_installed_extension(tmp_path):
    """Installed as bl_ext.user_default.illumap, the preferences register under that name and
    new files take their defaults from them. The zip holds only the add-on (the core comes from
    this environment), so this runs in seconds; tests/blender/ui/test_extension.py checks the real
    package with its wheel."""
    import subprocess
    import textwrap
    import zipfile
    root = REPO_ROOT
    manifest = []
    with open(os.path.join(root, "blender_manifest.toml")) as f:
        skipping = False
        for line in f:
            if line.startswith("[build]"):
                break
            if line.startswith("wheels"):
                skipping = True
            if not skipping:
                manifest.append(line)
            if skipping and line.strip() == "]":
                skipping = False
    zip_path = tmp_path / "illumap_addon_only.zip"
    with zipfile.ZipFile(zip_path, "w") as z:
        z.writestr("blender_manifest.toml", "".join(manifest))
        z.write(os.path.join(root, "__init__.py"), "__init__.py")
        for folder, _dirs, names in sorted(os.walk(os.path.join(root, "addon"))):
            for name in sorted(names):
                if name.endswith(".py"):
                    path = os.path.join(folder, name)
                    z.write(path, os.path.relpath(path, root).replace(os.sep, "/"))
    code = f"""
        import sys, bpy
        bpy.ops.extensions.package_install_files(repo="user_default", filepath={str(zip_path)!r},
                                                 enable_on_install=True)
        name = "bl_ext.user_default.illumap"
        prefs_module = sys.modules[name + ".addon.ui.preferences"]
        assert prefs_module.ADDON_PACKAGE == name, prefs_module.ADDON_PACKAGE
        prefs = bpy.context.preferences.addons[name].preferences
        assert type(prefs).__name__ == "IllumapPreferences"
        assert prefs_module.get_preferences() == prefs
        prefs.default_preset = "DRAFT"
        prefs.default_build_preview = False
        bpy.ops.wm.read_homefile(use_empty=True)
        props = bpy.context.scene.illumap
        assert props.preset == "DRAFT" and not props.build_preview, (props.preset, props.build_preview)
        print("PREFS OK")
    """
    env = {**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "user")}
    result = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], text=True,
                            capture_output=True, env=env, timeout=300, cwd=str(tmp_path))
    assert result.returncode == 0 and "PREFS OK" in result.stdout, result.stdout + result.stderr


def test_scene_defaults_match_the_pipeline_defaults(registered_addon):
    """Knobs the presets do not set start where the batch script's Settings start."""
    from addon import pipeline
    from addon.ui import properties
    settings = properties.make_settings(bpy.context.scene.illumap, pipeline.Settings)
    defaults = pipeline.Settings()
    for name in ("leaf_size", "solver", "near_field", "max_iterations", "lamps",
                 "lamp_shadows", "shadow_samples", "adaptive", "target_error",
                 "world_ambient", "transfer", "transfer_domain", "seed", "method"):
        assert getattr(settings, name) == getattr(defaults, name), name
    assert settings.gather_cache == pytest.approx(defaults.gather_cache, rel=1e-6)   # float32
