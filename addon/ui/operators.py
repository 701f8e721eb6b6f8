"""The Compute Illumination Map operator and the worker it runs on. The other operators (the
previews, Clear Results, Export Lightmaps, Reset Settings) are in ``tool_operators``.

Compute has two paths (docs/architecture.md, add-on contract):

* ``execute`` — synchronous: ``pipeline.compute`` on the main thread. Used in background mode,
  from scripts (``bpy.ops.illumap.compute_illumination_map()``), and for redo.
* ``invoke`` in an interactive session — ``pipeline.prepare`` on the main thread (reads the
  scene, samples surfels), then ``pipeline.run_passes`` on a worker thread (no bpy there: the
  one loop over the passes, ``illumap.run``: lamp shadow rays, the solve, the light at the
  receivers; an adaptive run's second pass is read on the main thread, handed over through
  ``ComputeTask.call_on_main``), polled by a modal timer that drives the progress bar and
  status line with the current phase and serves those calls; Esc cancels either phase. On success ``pipeline.write`` runs on the main
  thread. The UNDO flag makes Blender push one undo step when the modal operator finishes, so
  the write is undoable and no extra ``ed.undo_push`` is needed (it would add an empty step).

``ComputeTask`` (``compute_task.py``) is the worker's state machine, kept free of operator
state so that tests can drive it without timers or a window.
"""

import numbers
import time

import bpy

from ..preview import mesh_preview, solid_preview
from ..write import output
from . import preferences, properties
from .. import threads
# The worker and the runs' ids (tests drive them through this module too).
from ..compute_task import (  # noqa: F401
    ComputeTask, _class_names, _is_cancelled_error, begin_run, is_latest
)
from ..kinds import HELPER_TYPES, is_instancer
from ..kinds import SUPPORTED_TYPES as _SUPPORTED_TYPES


def _pipeline():
    from .. import pipeline  # imported late: it needs the native module
    return pipeline


_USER_ERRORS = {"IllumapError", "InputError", "ValueError", "RuntimeError", "MemoryError"}


def _is_no_light(error):
    """The pipeline's NoLightError: the scene has no light, the solve was skipped."""
    return "NoLightError" in _class_names(error)


def error_message(error):
    """A one-line message for the user: the text of errors meant for users, else type: text."""
    text = str(error).strip() or type(error).__name__
    if _class_names(error) & _USER_ERRORS:
        return text
    return f"{type(error).__name__}: {text}"


def surfel_objects(scene=None):
    """Surfel objects written by Illumap (``output.is_illumap_object``: its marker, or for older
    files the name with the surfel attributes). A user's own object of that name is not one."""
    objs = scene.objects if scene is not None else bpy.data.objects
    return [o for o in objs if output.is_illumap_object(o)]


def input_objects(context):
    """Selected objects Illumap can compute on, and a message when there are none."""
    selected = list(context.selected_objects) if hasattr(context, "selected_objects") else []
    surfels = set(o.name for o in surfel_objects())
    objects = [o for o in selected if (o.type in _SUPPORTED_TYPES or is_instancer(o))
               and o.name not in surfels]
    if objects:
        # What the run cannot read goes along, to be named in its warnings.
        return objects + [o for o in selected if o.type not in HELPER_TYPES
                          and o.type not in _SUPPORTED_TYPES], None
    if not selected:
        return [], "Nothing selected: select the mesh or point-cloud objects to light"
    if all(o.name in surfels for o in selected):
        return [], ("Only Illumap's surfel object is selected: select the mesh or point-cloud "
                    "objects to light")
    kinds = ", ".join(sorted({o.type.lower() for o in selected}))
    return [], (f"No mesh or point-cloud objects selected (selected: {kinds}); "
                "Illumap computes on meshes and point clouds")


def scene_settings(context):
    """The pipeline's Settings for the scene, initialised from the preferences if needed."""
    props = context.scene.illumap
    if not props.initialized:
        preferences.apply_defaults(props, preferences.get_preferences(context))
    settings = properties.make_settings(props, _pipeline().Settings)
    settings.preview_splats = bool(props.build_preview)   # the preview after the run
    return settings


# --- statistics ----------------------------------------------------------------------------

def _first(obj, *names, default=None):
    for name in names:
        value = obj.get(name) if isinstance(obj, dict) else getattr(obj, name, None)
        if value is not None:
            return value
    return default


def record_stats(stats, result, seconds):
    """Store what a Result reports in ``scene.illumap.stats`` (tolerant of missing fields)."""
    stats.clear()
    solution = _first(result, "solution", default=result)
    surfels = _first(result, "count", "n_surfels", "surfel_count", "num_surfels", "surfels")
    if surfels is not None and not isinstance(surfels, numbers.Integral):
        try:
            surfels = len(surfels)
        except TypeError:
            surfels = None
    if surfels is None:
        radiosity = _first(result, "radiosity", default=_first(solution, "radiosity"))
        surfels = 0 if radiosity is None else len(radiosity)
    stats.surfels = int(surfels)
    iterations = _first(result, "iterations", default=_first(solution, "iterations", default=0))
    stats.iterations = int(iterations)
    residual = _first(result, "residual", "final_residual")
    if residual is None or residual != residual:  # missing or nan
        residuals = _first(result, "residuals", default=_first(solution, "residuals"))
        residual = float(residuals[-1]) if residuals is not None and len(residuals) else 0.0
    stats.residual = float(residual)
    stats.converged = bool(_first(result, "converged", default=_first(solution, "converged",
                                                                         default=False)))
    timings = dict(_first(solution, "timings", default={}) or {})
    timings.update(dict(_first(result, "timings", default={}) or {}))
    for phase, value in timings.items():
        item = stats.phases.add()
        item.name = str(phase)
        item.seconds = float(value)
    stats.total_seconds = float(seconds)
    extra = dict(_first(result, "stats", default={}) or {})
    density = extra.get("density") or {}
    stats.density = float(density.get("density", 0.0))
    stats.predicted_error = float(density.get("predicted_discretization", 0.0))
    first = (extra.get("adaptive") or {}).get("pass1") or {}
    stats.first_pass_surfels = int(first.get("surfels", 0))
    stats.first_pass_iterations = int(first.get("iterations", 0))
    stats.shadow_rays = int(extra.get("shadow_rays", 0))
    stats.occluder_shape = str(extra.get("shadow_occluders", extra.get("occluder_shape", "")))
    accuracy = extra.get("accuracy") or {}
    chosen = accuracy.get("settings") or {}
    if chosen.get("label"):
        stats.chosen_settings = f"{chosen['label']}, tol {chosen['tol']:.0e}" + (
            f" or solver error ≤ {chosen['error_tol']:.1%}" if chosen.get("error_tol") else "")
    stats.estimated_error = float((accuracy.get("estimate") or {}).get("total") or 0.0)
    stats.estimated_error_at_objects = float((extra.get("receivers") or {}).get("estimate") or 0.0)
    stats.valid = True
    stats.summary = run_summary(result, stats)
    return stats


def result_location(result) -> str:
    """Where a run's light is, in words: the objects whose 'illumination' attribute holds it,
    else the surfel object."""
    names = list((getattr(result, "receiver_values", None) or {}).keys())
    names += [n for n in (getattr(result, "point_receiver_values", None) or {})
              if n not in names]
    if names:
        shown = ", ".join(f"'{n}'" for n in names[:3])
        more = f" and {len(names) - 3} more" if len(names) > 3 else ""
        return f"the 'illumination' colour attribute of {shown}{more}"
    surfels = getattr(result, "object_name", "") or "Illumap Surfels"
    return f"the surfel object '{surfels}' (Transfer to Meshes is off)"


def run_summary(result, stats) -> str:
    """The Info line after a run: how long it took, the estimated error of the light at the
    objects, the warnings that affect the picture, and where the result is."""
    parts = [f"done in {stats.total_seconds:.1f} s"]
    if stats.estimated_error_at_objects > 0:
        parts.append(f"estimated error at the objects {stats.estimated_error_at_objects:.1%}")
    elif stats.estimated_error > 0:
        parts.append(f"estimated error of the surfels {stats.estimated_error:.1%}")
    if not stats.converged:
        parts.append("the solve stopped before converging")
    warnings = list(_first(result, "warnings", default=[]) or [])
    if warnings:
        parts.append(f"{counted(len(warnings), 'warning')} (see above)")
    if stats.first_pass_surfels:
        parts.append("adaptive, 2 passes")
    parts.append(f"result in {result_location(result)}")
    return "; ".join(parts)


def report_warnings(result, report, limit=5):
    """Pass the run's warnings (materials that fell back, skipped objects…) to the user."""
    warnings = list(_first(result, "warnings", default=[]) or [])
    for text in warnings[:limit]:
        report({"WARNING"}, f"Illumap: {text}")
    if len(warnings) > limit:
        report({"WARNING"}, f"Illumap: {len(warnings) - limit} more warnings (see the console)")
        for text in warnings[limit:]:
            print(f"Illumap warning: {text}")


def counted(n: int, noun: str) -> str:
    """"1 mesh", "2 meshes", "0 objects": for reports."""
    return f"{n} {noun}{'' if n == 1 else 'es' if noun.endswith(('s', 'sh', 'ch', 'x')) else 's'}"


def lit_objects(context, result) -> list:
    """The objects a run wrote ``illumination`` to: its meshes, then its point clouds."""
    names = list((getattr(result, "receiver_values", None) or {}).keys())
    names += [n for n in (getattr(result, "point_receiver_values", None) or {}) if n not in names]
    objects = context.blend_data.objects
    return [objects[n] for n in names if n in objects]


def after_write(context, props, surfel_object, result=None):
    """What the user sees after a run (``mesh_preview.show_result``): with Preview After
    Compute on, the lit objects themselves through the Object Preview; the solve's surfels
    only when asked for (Show Surfels), or where no object was lit (Transfer off), else
    hidden in the viewport and in renders. Returns the names of the objects shown."""
    return mesh_preview.show_result(
        context, lit_objects(context, result), surfel_object, objects=props.build_preview,
        surfels=props.show_surfels, mode=props.preview_mode, disc_scale=props.disc_scale)


def after_run(context, result):
    """While Solid Preview is on, the meshes the run lit show its result in Solid mode too
    (``solid_preview.after_run``)."""
    names = list((getattr(result, "receiver_values", None) or {}).keys())
    return solid_preview.after_run(context, names)


def _written_object(result, write_return=None):
    if isinstance(write_return, bpy.types.Object):
        return write_return
    obj = _first(result, "object", "surfel_object")
    if isinstance(obj, bpy.types.Object):
        return obj
    name = _first(result, "object_name")
    if name and name in bpy.data.objects:
        return bpy.data.objects[name]
    objs = surfel_objects()
    return objs[0] if objs else None


# The interactive run in progress, if any (one at a time; the panel shows its progress); the
# id of the latest run started is ``compute_task.begin_run``'s: only that run may write.
_current = {"task": None}


def current_task():
    """The ComputeTask of the interactive run in progress, or None."""
    task = _current["task"]
    return task if task is not None and task.state == "RUNNING" else None


def run_in_flight():
    """The interactive run that has not finished writing (its worker may be done, its result
    not yet written), or None. A second run is refused while there is one."""
    task = _current["task"]
    return task if task is not None and task.state in ("PENDING", "RUNNING", "DONE") else None


ALREADY_RUNNING = ("An Illumap computation is already running: wait for it to finish, or "
                   "press Esc to cancel it, before starting another")


def finish_task(context, task, report):
    """Main thread, after the worker stopped: write on success, report otherwise.

    Returns the operator's return set. ``report(kind_set, message)`` is the operator's report.
    """
    state = task.state
    if state == "RUNNING" or state == "PENDING":
        raise RuntimeError("finish_task called while the task is not finished")
    if state == "CANCELLED":
        report({"WARNING"}, "Illumap: cancelled, nothing was written")
        return {"CANCELLED"}
    if state == "FAILED":
        if _is_no_light(task.error):
            report({"WARNING"}, f"Illumap: {error_message(task.error)}")
        else:
            report({"ERROR"}, f"Illumap failed: {error_message(task.error)}")
        return {"CANCELLED"}
    if not is_latest(task.run_id):
        # An older run must never overwrite a newer one's result.
        report({"WARNING"}, "Illumap: the result of an older run was discarded: a newer run "
                            "was started since, nothing was written")
        return {"CANCELLED"}
    props = context.scene.illumap
    try:
        # One transaction: on failure nothing of the result is in the file.
        written = _pipeline().write(context, task.job, task.result)
    except Exception as error:
        text = error_message(error)
        if not text.startswith("Illumap could not write"):
            text = f"Illumap could not write the result: {text}"
        report({"ERROR"}, text)
        return {"CANCELLED"}
    try:
        obj = _written_object(task.result, written)
        record_stats(props.stats, task.result, task.seconds)
        after_run(context, task.result)
        after_write(context, props, obj, task.result)
    except Exception as error:
        report({"ERROR"}, f"Illumap wrote the result but could not build its preview: "
                          f"{error_message(error)}")
        return {"FINISHED"}   # the result is in the file: its undo step must exist
    report_warnings(task.result, report)
    report({"INFO"}, "Illumap: " + props.stats.summary)
    return {"FINISHED"}


def _modal_step(self, context, event):
    """One event of the modal compute operator (``modal`` guards it)."""
    task = self._task
    if event.type == "ESC" and event.value == "PRESS":
        task.cancel()
        self._status(context, task.status_text())
        return {"RUNNING_MODAL"}
    if event.type != "TIMER":
        return {"PASS_THROUGH"}
    if task.state == "RUNNING":
        task.serve_main()   # an adaptive run's second pass reads the scene here
        context.window_manager.progress_update(task.fraction)
        self._status(context, task.status_text())
        for area in context.screen.areas if context.screen else ():
            if area.type == "VIEW_3D":
                area.tag_redraw()  # the panel shows the progress too
        return {"RUNNING_MODAL"}
    self._cleanup(context)
    return finish_task(context, task, self.report)


# --- operators ------------------------------------------------------------------------------

class ILLUMAP_OT_compute_illumination_map(bpy.types.Operator):
    """Compute diffuse global illumination on the selected meshes and point clouds"""

    bl_idname = "illumap.compute_illumination_map"
    bl_label = "Compute Illumination Map"
    bl_options = {"REGISTER", "UNDO"}

    _task = None
    _timer = None

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def execute(self, context):
        if run_in_flight() is not None:
            self.report({"ERROR"}, ALREADY_RUNNING)
            return {"CANCELLED"}
        objects, problem = input_objects(context)
        if problem:
            self.report({"ERROR"}, problem)
            return {"CANCELLED"}
        props = context.scene.illumap
        try:
            settings = scene_settings(context)
        except Exception as error:
            self.report({"ERROR"}, f"Illumap settings are invalid: {error_message(error)}")
            return {"CANCELLED"}
        threads.apply(context.scene)   # Blender's thread setting reaches the core
        start = time.perf_counter()
        begin_run()   # an interactive run still writing would now be discarded
        try:
            result = _pipeline().compute(context, objects, settings)
        except Exception as error:
            if _is_cancelled_error(error):
                self.report({"WARNING"}, "Illumap: cancelled, nothing was written")
            elif _is_no_light(error):
                self.report({"WARNING"}, f"Illumap: {error_message(error)}")
            else:
                self.report({"ERROR"}, f"Illumap failed: {error_message(error)}")
            return {"CANCELLED"}
        try:
            record_stats(props.stats, result, time.perf_counter() - start)
            after_run(context, result)
            after_write(context, props, _written_object(result), result)
        except Exception as error:
            self.report({"ERROR"}, f"Illumap wrote the result but could not build its preview: "
                                   f"{error_message(error)}")
            return {"FINISHED"}   # the result is in the file: its undo step must exist
        report_warnings(result, self.report)
        self.report({"INFO"}, "Illumap: " + props.stats.summary)
        return {"FINISHED"}

    def invoke(self, context, event):
        wm = context.window_manager
        if bpy.app.background or context.window is None:
            return self.execute(context)
        if run_in_flight() is not None:
            self.report({"ERROR"}, ALREADY_RUNNING)
            return {"CANCELLED"}
        objects, problem = input_objects(context)
        if problem:
            self.report({"ERROR"}, problem)
            return {"CANCELLED"}
        try:
            settings = scene_settings(context)
            # Transfer targets and export paths are checked before the scene is read (the
            # write checks them again: the user may change the scene while the run is going).
            output.check_targets(objects, settings)
            # Read on the main thread; a scan's normals, thinning and splats and the
            # ray-casting structure are built on the worker (a 486k-point scan: 8.8 s on the
            # main thread before, 0.6 s after; bench/micro/scan_prepare.py).
            job = _pipeline().prepare(context.evaluated_depsgraph_get(), objects, settings,
                                      build=False)
        except Exception as error:
            self.report({"ERROR"}, f"Illumap could not prepare the scene: {error_message(error)}")
            return {"CANCELLED"}
        threads.apply(context.scene)   # Blender's thread setting reaches the core
        self._task = ComputeTask.all_passes(job, _pipeline().run_passes).start()
        _current["task"] = self._task
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0.0, 1.0)
        self._status(context, self._task.status_text())
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        try:
            return _modal_step(self, context, event)
        except Exception as error:  # never leave the run marked in flight
            if self._task is not None:
                self._task.cancel()
            self._cleanup(context)
            self.report({"ERROR"}, f"Illumap failed: {error_message(error)}")
            return {"CANCELLED"}

    def cancel(self, context):
        # Blender cancels modal operators when it must (e.g. a file is loaded): stop the worker.
        if self._task is not None:
            self._task.cancel()
            self._task.wait(5.0)
        self._cleanup(context)

    def _status(self, context, text):
        try:
            context.workspace.status_text_set(text)
        except Exception:
            pass
        if context.area is not None:
            context.area.header_text_set(text)
            context.area.tag_redraw()

    def _cleanup(self, context):
        if _current["task"] is self._task:
            _current["task"] = None
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        try:
            context.workspace.status_text_set(None)
        except Exception:
            pass
        if context.area is not None:
            context.area.header_text_set(None)


# Registered only when the native module imports.
core_classes = (ILLUMAP_OT_compute_illumination_map,)
