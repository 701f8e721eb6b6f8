"""The measured tables the automatic mode's models read.

``CALIBRATION``: the error and time curves per scene kind and setting, fitted on the
benchmarks by bench/calibration/calibrate.py and stored in the package's data/calibration.json;
:data:`FMM_ERROR`, the expansion error alone; the scene kinds, and the visibility keywords the
calibration was measured with (which the automatic mode must therefore use).
"""

from __future__ import annotations

import json
from importlib import resources

from ..surfels import InputError

#: The scene kinds the models are calibrated for: meshes sampled on grids (the Cornell box),
#: stratified samples of triangles, random samples, scans.
KINDS = ("grid", "mesh", "random", "point_cloud")

#: Worst relative RMS difference (FMM solution − direct solution, same surfels, no visibility,
#: residual 1e-9) over the benchmark scenes, by theta then order p: the expansion error alone.
#: (Measured with visibility "none" before the exact near field; settings at a smaller theta
#: use the 0.35 row, an upper bound.)
FMM_ERROR = {
    0.35: {0: 1.2e-01, 2: 4.6e-03, 3: 1.1e-03, 4: 2.5e-04, 6: 1.7e-05, 8: 1.3e-06},
    0.5: {0: 1.6e-01, 2: 1.9e-02, 3: 6.9e-03, 4: 2.8e-03, 6: 4.8e-04, 8: 9.0e-05},
    0.7: {0: 2.3e-01, 2: 4.7e-02, 3: 2.5e-02, 4: 1.1e-02, 6: 3.5e-03, 8: 1.3e-03},
}

#: Keywords of ``visibility="exact"`` that the automatic mode uses (and the benchmarks that
#: calibrate it), per scene kind: occluders within one disc radius of either end of a ray are
#: ignored (the default 0.05 lets neighbouring discs on a curved or scanned surface shadow a
#: surfel's grazing rays). Disc radius (``coverage``, in spacings): a grid is closed at the
#: default 1.3 (a square cell's corners lie at 1.25), and wider discs stick out past edges,
#: which doubles the Cornell box reference's refinement difference (0.84% → 1.67%); irregular
#: samples leave holes between 1.3-spacing discs that leak light through thin walls and scans,
#: so they get 1.7, the add-on's width.
EXACT_KEYWORDS = {"grid": {"endpoint_offset": 1.0},
                  "mesh": {"endpoint_offset": 1.0, "coverage": 1.7},
                  "random": {"endpoint_offset": 1.0, "coverage": 1.7},
                  "point_cloud": {"endpoint_offset": 1.0, "coverage": 1.7}}


def visibility_keywords(visibility: str, kind: str = "random") -> dict:
    """The operator keywords the automatic mode uses with ``visibility`` on a scene of
    ``kind`` (one of :data:`KINDS`): :data:`EXACT_KEYWORDS` for "exact", none otherwise."""
    if visibility != "exact":
        return {}
    if kind not in EXACT_KEYWORDS:
        raise InputError(f"kind: expected one of {KINDS}, got {kind!r}")
    return dict(EXACT_KEYWORDS[kind])


#: Visibility keywords a calibrated setting may fix itself (bench/calibration/calibrate.py keeps them):
#: "per_pair_all" leaf pairs and more samples per node pair take the FMM's visibility error
#: down to the direct method's.
SETTING_VISIBILITY_KEYS = ("visibility_leaf_mode", "visibility_samples")

#: The sampling factor's quantile: exp(mean + SAMPLING_Z·sd) of the log error ratios (about
#: the 98th percentile of a log-normal spread), fitted by bench/calibration/calibrate.py.
SAMPLING_Z = 2.0

#: Fewest surfels recommended per kind when the calibration has none (small lights and
#: occluders are not resolved below it).
DEFAULT_N_MIN = 250


def _load_calibration() -> dict:
    """The calibration fitted by bench/calibration/calibrate.py (``--write``), from the package's
    data/calibration.json."""
    path = resources.files("illumap") / "data" / "calibration.json"
    return json.loads(path.read_text(encoding="utf-8"))


#: The fitted error and time models per scene kind (see the module docstring), with the
#: sweeps they were fitted on: data/calibration.json, written by bench/calibration/calibrate.py.
CALIBRATION = _load_calibration()


def kind_table(kind: str) -> dict:
    """The calibration of ``kind``, else of the closest calibrated kind."""
    kinds = CALIBRATION.get("kinds", {})
    for k in (kind, "random", "grid", *kinds):   # the closest calibrated kind
        if k in kinds:
            return kinds[k]
    raise InputError("illumap.accuracy has no calibration (run bench/calibration/calibrate.py)")
