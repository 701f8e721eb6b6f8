"""The worker a Compute run goes on (no bpy): ``ComputeTask`` runs the run's passes on a
thread, reports its progress and phase, is cancelled through its progress callable, and hands
the calls that need Blender's main thread (an adaptive run's second pass reads the scene) to
the modal timer (``call_on_main`` / ``serve_main``). ``begin_run`` numbers the runs: only the
latest may write its result."""

import threading
import time

from .errors import IllumapCancelled

_runs = {"latest": 0}


def _class_names(error):
    return {cls.__name__ for cls in type(error).__mro__}


def _is_cancelled_error(error):
    """The core's ``Cancelled`` or the pipeline's ``IllumapCancelled`` (or a subclass)."""
    return any(name in ("Cancelled", "IllumapCancelled") for name in _class_names(error))


def begin_run():
    """A new run's id: from now on only this run may write its result."""
    _runs["latest"] += 1
    return _runs["latest"]


def is_latest(run_id):
    return run_id == _runs["latest"]


class ComputeTask:
    """Runs ``run(job, progress)`` on a worker thread and reports its state. A run that needs
    Blender's main thread (an adaptive run's second pass reads the scene) hands a call over
    with ``call_on_main``; the modal timer runs it (``serve_main``).

    ``progress(fraction, phase)`` is called by the core from the worker thread; it only stores
    numbers and strings (never touches bpy) and returns False once ``cancel()`` was called,
    which makes the core stop and raise ``Cancelled``.

    States: ``"PENDING"`` (not started), ``"RUNNING"``, ``"DONE"`` (a result), ``"CANCELLED"``
    (cancel was requested; any result is discarded), ``"FAILED"`` (``error`` holds why).
    """

    def __init__(self, job, run, run_id=None):
        self.job = job
        self._run = run
        # Which run this is (``begin_run``); the passes of one run share it.
        self.run_id = begin_run() if run_id is None else run_id
        self._cancel = threading.Event()
        self._thread = None
        self.fraction = 0.0
        self.phase = "starting"
        self.result = None
        self.error = None
        self.started = None
        self.finished = None
        self._main_call = None    # the worker's pending call for the main thread

    @classmethod
    def all_passes(cls, job, run_passes, run_id=None):
        """A task that runs every pass of ``job``'s run (``run_passes(job, progress,
        on_main=...)``), handing its main-thread calls to ``serve_main``."""
        task = cls(job, None, run_id)
        task._run = lambda job_, progress: run_passes(job_, progress, on_main=task.call_on_main)
        return task

    def call_on_main(self, call):
        """Worker thread: run ``call`` on the main thread (the modal timer's next
        ``serve_main``) and return its value, or raise what it raised. Raises
        IllumapCancelled when the run is cancelled while it waits."""
        box = {"call": call, "done": threading.Event()}
        self._main_call = box
        while not box["done"].wait(0.05):
            if self._cancel.is_set():
                self._main_call = None
                raise IllumapCancelled("Cancelled")
        if "error" in box:
            raise box["error"]
        return box["value"]

    @property
    def waiting_on_main(self):
        """Whether the worker waits for a call on the main thread (``serve_main``)."""
        return self._main_call is not None

    def serve_main(self):
        """Main thread: run the worker's pending call, if any; True when one ran."""
        box, self._main_call = self._main_call, None
        if box is None:
            return False
        try:
            box["value"] = box["call"]()
        except BaseException as error:  # raised again on the worker
            box["error"] = error
        box["done"].set()
        return True

    def progress(self, fraction, phase=""):
        try:
            self.fraction = min(1.0, max(0.0, float(fraction)))
        except (TypeError, ValueError):
            pass
        if phase:
            self.phase = str(phase)
        return not self._cancel.is_set()

    def _target(self):
        try:
            build = getattr(self.job, "build", None)   # a scene as read (``UnbuiltJob``)
            if callable(build):
                self.job = build(self.progress)
            self.result = self._run(self.job, self.progress)
            if getattr(self.result, "job", None) is not None:
                self.job = self.result.job    # the last pass's: what is written
            self._shade_splats()
        except BaseException as error:  # reported on the main thread
            self.error = error
        finally:
            self.finished = time.perf_counter()

    def _shade_splats(self):
        """Worker: shade the scans' preview splats from the run's values (numpy and the core),
        which the preview after the write would otherwise do on the main thread (0.7-1.0
        CPU-s at 1M points). Best effort: whatever fails here is left to the preview."""
        try:
            from .preview import point_splats
            if not point_splats.pending_shading():
                return
            from .pipeline import point_values
            point_splats.prepare_shading(point_values(self.job, self.result),
                                         progress=self.progress)
        except Exception:  # noqa: BLE001 - the preview shades them itself then
            pass

    def start(self):
        self.started = time.perf_counter()
        self._thread = threading.Thread(target=self._target, name="illumap-compute", daemon=True)
        self._thread.start()
        return self

    def cancel(self):
        self._cancel.set()

    @property
    def cancel_requested(self):
        return self._cancel.is_set()

    def wait(self, timeout=None):
        if self._thread is not None:
            self._thread.join(timeout)
        return self.state

    @property
    def seconds(self):
        if self.started is None:
            return 0.0
        return (self.finished or time.perf_counter()) - self.started

    @property
    def state(self):
        if self._thread is None:
            return "PENDING"
        if self._thread.is_alive():
            return "RUNNING"
        if self._cancel.is_set() or (self.error is not None and _is_cancelled_error(self.error)):
            return "CANCELLED"
        if self.error is not None:
            return "FAILED"
        return "DONE"

    def status_text(self):
        if self._cancel.is_set():
            return "Illumap: cancelling…"
        return f"Illumap: {self.phase} {100.0 * self.fraction:.0f} %  (Esc to cancel)"
