"""Every limit on an Illumap input, in one table: the Python API, the add-on's settings and
checks, the batch command and the native core take their bounds from here.

Each :class:`Limit` names a keyword or setting, its range (closed or open at each end), its
unit and what it means. The native core's own checks use the constants it exposes as
``illumap._core.LIMITS``; ``illumap.operator`` refuses to import a native module whose limits
differ from this table, so the two cannot disagree. The add-on's properties take their
``min``/``max``/``soft_min``/``soft_max`` from :meth:`Limit.ui`.

``docs/limits.md`` is generated from this table::

    .venv/bin/python scripts/limits_page.py

This module imports neither numpy nor the native core, nor bpy.
"""

from __future__ import annotations

import math
import numbers
import struct
from dataclasses import dataclass

__all__ = ["Limit", "LIMITS", "limit", "MAX_INT32", "MAX_INT64", "markdown"]

#: The largest count the native core takes (a C ``int``), and Blender's integer properties.
MAX_INT32 = 2 ** 31 - 1
#: The largest signed 64-bit integer.
MAX_INT64 = 2 ** 63 - 1


def _float32(x: float) -> float:
    """``x`` rounded to single precision (what a Blender float property stores)."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def _float32_step(x: float, up: bool) -> float:
    """The single-precision neighbour of the single-precision ``x``, towards +inf if ``up``."""
    if x == 0.0:
        tiny = struct.unpack("<f", struct.pack("<I", 1))[0]
        return tiny if up else -tiny
    bits = struct.unpack("<I", struct.pack("<f", x))[0]
    bits += 1 if (x > 0) == up else -1
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def _number(x) -> str:
    if x is None or x == math.inf:
        return "inf"
    if x == -math.inf:
        return "-inf"
    return str(x) if isinstance(x, int) else f"{x:g}"


@dataclass(frozen=True)
class Limit:
    """One input's range.

    ``low``/``high``: the bounds (``None``: none; integers for integer limits), open where
    ``low_open``/``high_open``. Floats must also be finite. ``ui_low``/``ui_high``: where the
    add-on's field stops, when that differs from the bound (the bound is open, or the UI
    offers a narrower, useful range); ``soft_low``/``soft_high``: the field's slider range.
    ``native``: the core's ``_core.LIMITS`` holds this limit and checks it natively too.
    ``enforced``: where the limit is checked (for docs/limits.md).
    """

    name: str
    kind: type
    low: float | int | None
    high: float | int | None
    unit: str
    meaning: str
    enforced: str
    low_open: bool = False
    high_open: bool = False
    ui_low: float | int | None = None
    ui_high: float | int | None = None
    soft_low: float | int | None = None
    soft_high: float | int | None = None
    native: bool = False

    def __post_init__(self):
        assert self.kind in (int, float), self.name
        for x in (self.ui_low, self.ui_high):
            assert x is None or self._inside(x), f"{self.name}: UI bound {x} outside the limit"

    # --- checking -----------------------------------------------------------------------
    def _inside(self, x: float) -> bool:
        if self.low is not None and (x <= self.low if self.low_open else x < self.low):
            return False
        if self.high is not None and (x >= self.high if self.high_open else x > self.high):
            return False
        return True

    def contains(self, value) -> bool:
        """Whether ``value`` is accepted: the right type (no bool), finite, inside the range."""
        if isinstance(value, bool):
            return False
        if self.kind is int:
            return isinstance(value, numbers.Integral) and self._inside(int(value))
        return (isinstance(value, numbers.Real) and math.isfinite(float(value))
                and self._inside(float(value)))

    def interval(self) -> str:
        """The range as text: ``0..10``, ``>= 1``, ``(0, 1)``, ``[0, inf)``."""
        lo = "-inf" if self.low is None else _number(self.low)
        hi = "inf" if self.high is None else _number(self.high)
        if self.kind is int:
            if self.high is None:
                return f">= {lo}"
            return f"{lo}..{hi}"
        left = "(" if self.low_open or self.low is None else "["
        right = ")" if self.high_open or self.high is None else "]"
        return f"{left}{lo}, {hi}{right}"

    def expected(self) -> str:
        """What is expected, as the messages say it: ``an integer >= 0 and <= 10``,
        ``a number in (0, 1)``."""
        if self.kind is int:
            text = f"an integer >= {_number(self.low)}"
            return text + (f" and <= {_number(self.high)}" if self.high is not None else "")
        return f"a number in {self.interval()}"

    def message(self, value, label: str | None = None) -> str:
        """The refusal of ``value``: ``order: expected an integer >= 0 and <= 10, got 11``."""
        if isinstance(value, numbers.Integral) and not isinstance(value, bool):
            value = int(value)      # numpy scalars as plain numbers
        elif isinstance(value, numbers.Real):
            value = float(value)
        return f"{label or self.name}: expected {self.expected()}, got {value!r}"

    def check(self, value, error: type[Exception] = ValueError, label: str | None = None):
        """``value`` as ``int`` or ``float`` when :meth:`contains` it, else ``error`` with
        :meth:`message`."""
        if not self.contains(value):
            raise error(self.message(value, label))
        return self.kind(value)

    # --- the add-on's field -------------------------------------------------------------
    def ui(self) -> dict:
        """``min``/``max``/``soft_min``/``soft_max`` for a Blender property: the limit, or
        ``ui_low``/``ui_high`` where given; an open bound becomes the nearest value inside
        it. Float bounds are single precision (what Blender stores), rounded inwards;
        integer bounds within Blender's 32-bit range."""
        out = {}
        for key, bound, explicit, is_open, up in (
                ("min", self.low, self.ui_low, self.low_open, True),
                ("max", self.high, self.ui_high, self.high_open, False)):
            value = explicit if explicit is not None else bound
            if value is None:
                continue
            if self.kind is int:
                if explicit is None and is_open:
                    value += 1 if up else -1
                value = max(-MAX_INT32 - 1, min(MAX_INT32, int(value)))
            else:
                value = _float32(float(value))
                while not self._inside(value):    # rounded outside, or on an open bound
                    value = _float32_step(value, up)
            out[key] = value
        for key, value in (("soft_min", self.soft_low), ("soft_max", self.soft_high)):
            if value is not None:
                out[key] = self.kind(value)
        return out


_API = "Python API"
_NATIVE = "native core"
_UI = "add-on field"
_CHECK = "add-on settings check"
_BATCH = "batch command"


def _int(name, low, high, unit, meaning, enforced, **kw) -> Limit:
    return Limit(name, int, low, high, unit, meaning, enforced, **kw)


def _float(name, low, high, unit, meaning, enforced, **kw) -> Limit:
    return Limit(name, float, low, high, unit, meaning, enforced, **kw)


#: Every limit, in the order of docs/limits.md.
LIMITS: tuple[Limit, ...] = (
    # --- the transport operator (illumap.TransportOperator, illumap.solve) ------------------
    _int("order", 0, 10, "", "Expansion order p of the FMM; the native expansions stop at 10.",
         f"{_API}, {_NATIVE}, {_UI}, {_CHECK}", ui_low=1, native=True),
    _float("theta", 0.0, 1.0, "", "Opening angle of the dual-tree traversal (separation ratio).",
           f"{_API}, {_NATIVE}, {_UI}, {_CHECK}", low_open=True, high_open=True,
           ui_low=0.05, ui_high=0.95, native=True),
    _int("leaf_size", 1, MAX_INT32, "surfels", "Most surfels per octree leaf.",
         f"{_API}, {_NATIVE}, {_UI}, {_CHECK}", soft_high=256, native=True),
    _int("threads", 0, MAX_INT32, "threads", "Worker threads (0: all hardware threads).",
         f"{_API}, {_NATIVE}", native=True),
    _int("visibility_samples", 1, 4096, "pairs",
         "Facing point pairs sampled per node pair to classify its visibility.",
         f"{_API}, {_NATIVE}", native=True),
    _float("coverage", 0.0, None, "", "Exact visibility: occluder radius over the surfel's own.",
           f"{_API}, {_NATIVE}", low_open=True),
    _float("endpoint_offset", 0.0, None, "", "Exact visibility: occluders this close (in the "
           "endpoint's radii) to a ray's end plane are ignored.", f"{_API}, {_NATIVE}"),
    _float("seed_delta", 0.0, None, "", "Seed visibility: an occluder's reach, in its radii.",
           f"{_API}, {_NATIVE}", low_open=True),
    _int("seed_k", 1, MAX_INT32, "surfels", "Seed visibility: neighbours per occluder.",
         f"{_API}, {_NATIVE}", native=True),
    _float("seed_t1", 0.0, 1.0, "", "Seed visibility: first threshold.", f"{_API}, {_NATIVE}"),
    _float("seed_t2", 0.0, 1.0, "", "Seed visibility: second threshold.", f"{_API}, {_NATIVE}"),
    _float("seed_t3", 0.0, 1.0, "", "Seed visibility: third threshold.", f"{_API}, {_NATIVE}"),
    _int("seed_leaf_points", 1, MAX_INT32, "points", "Seed visibility: points per leaf.",
         f"{_API}, {_NATIVE}", native=True),
    # --- the solver (illumap.solve) -------------------------------------------------------
    _float("tol", 0.0, 1.0, "", "Relative residual at which the solver stops.",
           f"{_API}, {_UI}, {_CHECK}, {_BATCH}", low_open=True, high_open=True, ui_low=1e-12),
    _int("max_iterations", 1, MAX_INT32, "iterations", "Most solver iterations.",
         f"{_API}, {_UI}, {_CHECK}", soft_high=10000),
    _float("error_tol", 0.0, 1.0, "", "Stop once the solver's own error estimate is this small.",
           _API, low_open=True, high_open=True),
    _int("restart", 1, MAX_INT32, "iterations", "GMRES restart length.", _API),
    _float("target_error", 0.0, 1.0, "", "Relative RMS error wanted; chooses the surfels and "
           "solver settings.", f"{_API}, {_UI}, {_CHECK}, {_BATCH}", low_open=True,
           high_open=True, ui_low=0.001, ui_high=0.5),
    _float("adaptive_first_pass", 0.0, 1.0, "", "Adaptive density: the first pass's share of "
           "the surfels.", _CHECK, low_open=True),
    _float("adaptive_max_ratio", 1.0, None, "", "Adaptive density: the largest density "
           "multiplier.", _CHECK),
    # --- the scene --------------------------------------------------------------------------
    _float("coordinate", -1e12, 1e12, "m", "Largest absolute coordinate of a surfel, triangle or point "
           "(a scene beyond it overflows the kernels).", f"{_API}, add-on"),
    _float("area", 1e-24, 1e24, "m²", "Surfel areas (radii from 1e-12 m to 1e12 m).", _API),
    _float("albedo", 0.0, 1.0, "", "Surfel albedo (diffuse reflectance); 1 conserves energy "
           "and has no solution.", _API, high_open=True),
    _float("material_albedo", 0.0, 0.999, "", "Albedo the add-on reads from materials, "
           "clamped to this with a warning.", "add-on"),
    _float("density", 0.0, None, "surfels/m²", "Surfel density.",
           f"{_API}, {_UI}, {_CHECK}, {_BATCH}", low_open=True, ui_low=0.001, soft_high=1e5),
    _int("budget", 1, 2 ** 62, "surfels", "Surfels over all objects (the memory guard refuses "
         "what would not fit).", f"{_UI}, {_CHECK}, {_BATCH}", soft_high=1_000_000),
    _int("seed", 0, MAX_INT64, "", "Sampling seed.", f"{_UI}, {_CHECK}, {_BATCH}"),
    _int("memory_limit", 1, 2 ** 62, "bytes", "Memory a run may plan to use.", _CHECK),
    # --- light ------------------------------------------------------------------------------
    _int("shadow_samples", 1, MAX_INT32, "rays", "Shadow rays per surfel for each lamp with a "
         "size.", f"{_UI}, {_CHECK}, {_BATCH}", soft_high=128),
    _int("gather_rays", 1, MAX_INT32, "rays", "Gather rays per mesh vertex or corner.",
         f"{_UI}, {_CHECK}, {_BATCH}", soft_high=4096),
    _float("gather_cache", 0.0, 1.0, "", "Irradiance cache accuracy (Ward's a) with which a "
           "point cloud's points share their final gathers; 0: every point gathers itself.",
           f"{_UI}, {_CHECK}, {_BATCH}", soft_high=0.5),
    _int("receiver_shadow_samples", 1, MAX_INT32, "rays", "Shadow rays per mesh vertex or "
         "corner for each lamp or emitter with a size.", f"{_UI}, {_CHECK}", soft_high=1024),
    _int("light_triangles", 0, 256, "triangles", "Emissive triangles integrated exactly as "
         "lights; beyond, an object's light comes from its surfels.", "add-on"),
    # --- output -----------------------------------------------------------------------------
    _int("lightmap_size", 1, 16384, "px", "Lightmap side (16k × 16k float RGBA is 4 GiB).",
         f"{_CHECK}, {_BATCH}"),
    _float("disc_scale", 0.0, None, "", "Preview disc radius over the surfel's own.", _UI,
           soft_high=4.0),
    _int("frames", 1, 10_000, "frames", "Frames one batch job computes (split longer ranges "
         "over jobs).", _BATCH),
    _int("resolution", 1, 65536, "px", "Render size (Blender's limit).", _BATCH),
    _int("samples", 1, MAX_INT32, "samples", "Render samples.", _BATCH),
)

_BY_NAME = {lim.name: lim for lim in LIMITS}
assert len(_BY_NAME) == len(LIMITS), "duplicate limit names"


def limit(name: str) -> Limit:
    """The limit called ``name`` (KeyError for an unknown name)."""
    return _BY_NAME[name]


def native_limits() -> dict:
    """The limits the native core checks itself, as ``_core.LIMITS`` must hold them:
    name -> (low, high)."""
    return {lim.name: (lim.low, lim.high) for lim in LIMITS if lim.native}


def check_native(core_limits) -> None:
    """Raise ImportError when the native module's ``LIMITS`` differ from this table (a module
    built from other sources)."""
    want = native_limits()
    got = {name: tuple(value) for name, value in dict(core_limits).items()}
    if got != want:
        diff = sorted(set(want.items()) ^ set(got.items()))
        raise ImportError("illumap._core was built with other limits than illumap.limits "
                          f"({diff}); rebuild the native core")


def markdown() -> str:
    """docs/limits.md: the table as Markdown."""
    lines = [
        "# Limits",
        "",
        "Every limit on an Illumap input, generated from the one table that the Python API, the "
        "add-on, the batch command and the native core use (`core/python/illumap/limits.py`). "
        "Do not edit this page: change the table and run",
        "",
        "    .venv/bin/python scripts/limits_page.py",
        "",
        "Ranges: `a..b` integers from a to b; `(a, b)` open and `[a, b]` closed intervals of "
        "finite numbers. *Add-on field* gives where the add-on's field stops, where it differs "
        "from the range, and its slider range.",
        "",
        "| name | range | unit | add-on field | meaning | enforced by |",
        "|---|---|---|---|---|---|",
    ]
    for lim in LIMITS:
        lines.append(f"| `{lim.name}` | {lim.interval()} | {lim.unit} | {_field(lim)} | "
                     f"{lim.meaning} | {lim.enforced} |")
    return "\n".join(lines) + "\n"


def _field(lim: Limit) -> str:
    """The add-on field's range where it differs from the limit's, and its slider range."""
    if _UI not in lim.enforced:
        return ""
    parts = []
    if lim.kind is int:
        ui = lim.ui()
        lo, hi = ui.get("min", lim.low), ui.get("max", lim.high)
        if (lo, hi) != (lim.low, lim.high):
            parts.append(f"{_number(lo)}..{_number(hi)}")
    elif lim.ui_low is not None or lim.ui_high is not None:
        left = ("[" + _number(lim.ui_low) if lim.ui_low is not None
                else ("(" if lim.low_open or lim.low is None else "[") + _number(lim.low))
        right = (_number(lim.ui_high) + "]" if lim.ui_high is not None
                 else _number(lim.high) + (")" if lim.high_open or lim.high is None else "]"))
        parts.append(f"{left}, {right}")
    if lim.soft_high is not None:
        parts.append(f"slider up to {_number(lim.soft_high)}")
    return "; ".join(parts)

