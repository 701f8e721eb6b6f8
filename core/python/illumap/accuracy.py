"""Automatic accuracy: the user asks for an error, Illumap chooses how to get it cheaply.

``choose_settings(scene, target_error)`` turns a target error (relative RMS per surfel, emitters
excluded, against a converged reference with exact visibility, as in bench/accuracy_speed.py)
into settings: surfel count (density), method (direct or FMM), expansion order p, opening angle
theta, leaf size, visibility mode (``none``, ``seed`` or ``exact``) and solver tolerance.

The error models are calibrated on the benchmarks (bench/accuracy_speed.py, fitted by
bench/calibrate.py into :data:`CALIBRATION`): for each scene kind ("grid": meshes sampled on
grids, the Cornell box; "random": randomly sampled meshes, the room with occluders;
"point_cloud": scans, the bunny) and each benchmarked setting (method, p, θ, visibility), the
measured error against N, as a non-increasing upper envelope, and the measured wall time
against N, both interpolated log-log (and extrapolated with fitted slopes beyond the measured
sizes). An error curve holds everything the setting does: density, expansion, visibility model
(the FMM classifies node pairs as visible / hidden / partial from sampled rays, which blurs
shadows at large θ) and the solver at its tolerance. For each candidate setting the model gives
the N that meets ``SAFETY`` × target and the time it takes there; the cheapest wins.

Visibility: settings without occlusion (``visibility="none"``) are modelled as
``sqrt(e_exact(N)² + e_fmm(p, θ)² + e_occlusion²)``, where ``e_exact`` is the direct exact-
visibility fit of the scene kind, ``e_fmm`` the expansion error table :data:`FMM_ERROR` and
``e_occlusion`` a probe of the scene: the direct solution on a few hundred of its surfels with
and without exact visibility (:func:`occlusion_probe`, tens of milliseconds). A convex or
open scene has ``e_occlusion`` ≈ 0 and gets the cheap ``none``; a scene with occluders gets
``exact`` (or ``seed`` where its fit says so). The probe runs only where a setting without
visibility could win and the saving could exceed its cost (``probe="auto"``); without
surfels (a summary dict) no probe runs and ``none`` is not chosen.

Density here is a surfel count over the scene's area, sampled uniformly by the caller; denser
sampling where the illumination varies is the add-on's second pass (``illumap.sampling``).

``estimate_error(solution, surfels)`` is the a-posteriori estimate: the solver part from the
final residual, the FMM part (expansion and visibility classification) from one FMM
application against the exact per-pair sum on a random subset of receivers (``apply_rows``,
which applies visibility per pair), the discretization part from the calibrated model at the
solution's N (or, with ``coarse=True``, measured on a spatially even half of the surfels).

``solve(surfels, target_error)`` does both and puts the chosen settings and the estimate in
``Solution.stats["accuracy"]``.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .operator import DEFAULT_LEAF_SIZE, VISIBILITY_DEFAULTS, TransportOperator
from .surfels import InputError, Surfels

__all__ = ["choose_settings", "solve_keywords", "estimate_error", "solve", "solve_triangles",
           "scene_summary", "occlusion_probe", "visibility_keywords", "CALIBRATION", "FMM_ERROR",
           "EXACT_KEYWORDS", "PRESETS", "KINDS"]

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


#: Visibility keywords a calibrated setting may fix itself (bench/calibrate.py keeps them):
#: "per_pair_all" leaf pairs and more samples per node pair take the FMM's visibility error
#: down to the direct method's.
SETTING_VISIBILITY_KEYS = ("visibility_leaf_mode", "visibility_samples")

#: Named presets of the add-on → target error.
PRESETS = {"draft": 0.10, "preview": 0.10, "medium": 0.03, "high": 0.01, "final": 0.01,
           "reference": 0.003}

#: Surfels of the occlusion probe, and when it runs (see choose_settings: ``probe``).
PROBE_SURFELS = 200
PROBE_WORTH = 0.25   # s
PROBE_GAIN = 0.67
#: The settings are chosen to meet SAFETY × target by the models (sampling noise, scenes that
#: differ from the calibration ones).
SAFETY = 0.95
#: Fewest surfels recommended per kind when the calibration has none (small lights and
#: occluders are not resolved below it).
DEFAULT_N_MIN = 250

# --- calibration (generated by bench/calibrate.py; do not edit by hand) ---
CALIBRATION = {
    'source': 'bench/results/accuracy_speed.json',
    'date': '2026-11-22 11:39 UTC',
    'mode': 'full',
    'core_commit': 'add8f44',
    'solve_tol': 0.0001,
    'kinds': {
        'grid': {
            'scene': 'cornell',
            'n_min': 506,
            'reference_check': 0.008059,
            'discretization': 'direct vis=exact',
            'settings': {
                'direct vis=none': {'keywords': {'method': 'direct', 'visibility': 'none'}, 'error': {'points': [[506, 0.4134], [1036, 0.4134], [1927, 0.4134], [4128, 0.4027], [8295, 0.4027]], 'slope': 0.05}, 'cost': {'points': [[506, 0.00737], [1036, 0.01467], [1927, 0.02872], [4128, 0.09726], [8295, 0.2952]], 'slope': 1.591}, 'n_range': [506, 8295]},
                'FMM p=0 vis=none': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4345], [1036, 0.4345], [1927, 0.4345], [4128, 0.4345], [8295, 0.4028]], 'slope': 0.05}, 'cost': {'points': [[506, 0.01071], [1036, 0.01424], [1927, 0.02254], [4128, 0.02719], [8295, 0.03944]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=2 vis=none': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4202], [1036, 0.4202], [1927, 0.4202], [4128, 0.4128], [8295, 0.4128]], 'slope': 0.05}, 'cost': {'points': [[506, 0.0118], [1036, 0.01882], [1927, 0.03035], [4128, 0.04231], [8295, 0.05343]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=3 vis=none': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4128], [1036, 0.4128], [1927, 0.4128], [4128, 0.4022], [8295, 0.4022]], 'slope': 0.05}, 'cost': {'points': [[506, 0.01395], [1036, 0.02332], [1927, 0.03366], [4128, 0.06159], [8295, 0.0912]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=4 vis=none': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4132], [1036, 0.4132], [1927, 0.4132], [4128, 0.4021], [8295, 0.4021]], 'slope': 0.05}, 'cost': {'points': [[506, 0.01354], [1036, 0.02733], [1927, 0.04292], [4128, 0.1023], [8295, 0.1076]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=6 vis=none': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4134], [1036, 0.4134], [1927, 0.4134]], 'slope': 0.05}, 'cost': {'points': [[506, 0.01685], [1036, 0.08092], [1927, 0.08785]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'FMM p=8 vis=none': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4134], [1036, 0.4134], [1927, 0.4134]], 'slope': 0.05}, 'cost': {'points': [[506, 0.02376], [1036, 0.15], [1927, 0.2045]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'direct vis=seed': {'keywords': {'method': 'direct', 'visibility': 'seed'}, 'error': {'points': [[506, 0.1871], [1036, 0.1489], [1927, 0.1053]], 'slope': 0.4268}, 'cost': {'points': [[506, 0.06721], [1036, 0.2826], [1927, 1.082]], 'slope': 2.163}, 'n_range': [506, 1927]},
                'FMM p=0 vis=seed': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.2097], [1036, 0.2097], [1927, 0.1877], [4128, 0.1877]], 'slope': 0.05}, 'cost': {'points': [[506, 0.0436], [1036, 0.06206], [1927, 0.08201], [4128, 0.1984]], 'slope': 1.16}, 'n_range': [506, 4128]},
                'FMM p=2 vis=seed': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.1848], [1036, 0.1729], [1927, 0.1385], [4128, 0.08703]], 'slope': 0.3605}, 'cost': {'points': [[506, 0.04329], [1036, 0.06714], [1927, 0.09107], [4128, 0.1924]], 'slope': 1.0}, 'n_range': [506, 4128]},
                'FMM p=3 vis=seed': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.1875], [1036, 0.1751], [1927, 0.1392], [4128, 0.08499]], 'slope': 0.3783}, 'cost': {'points': [[506, 0.04342], [1036, 0.0733], [1927, 0.09542], [4128, 0.2028]], 'slope': 1.0}, 'n_range': [506, 4128]},
                'FMM p=4 vis=seed': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.1879], [1036, 0.175], [1927, 0.1391], [4128, 0.08457]], 'slope': 0.3814}, 'cost': {'points': [[506, 0.05371], [1036, 0.08569], [1927, 0.1218], [4128, 0.34]], 'slope': 1.347}, 'n_range': [506, 4128]},
                'FMM p=6 vis=seed': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.1874], [1036, 0.1749], [1927, 0.1391]], 'slope': 0.2193}, 'cost': {'points': [[506, 0.05243], [1036, 0.1404], [1927, 0.1945]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'FMM p=8 vis=seed': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.1874], [1036, 0.1749], [1927, 0.1391]], 'slope': 0.2196}, 'cost': {'points': [[506, 0.06493], [1036, 0.2742], [1927, 0.3932]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'direct vis=exact': {'keywords': {'method': 'direct', 'visibility': 'exact'}, 'error': {'points': [[506, 0.06851], [1036, 0.0481], [1927, 0.03227], [4128, 0.01896], [8295, 0.01011]], 'slope': 0.6829}, 'cost': {'points': [[506, 0.02325], [1036, 0.07025], [1927, 0.2881], [4128, 1.083], [8295, 4.153]], 'slope': 1.925}, 'n_range': [506, 8295]},
                'FMM p=0 vis=exact': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1817], [1036, 0.1817], [1927, 0.1817], [4128, 0.1817], [8295, 0.1769]], 'slope': 0.05}, 'cost': {'points': [[506, 0.02241], [1036, 0.02329], [1927, 0.03698], [4128, 0.06099], [8295, 0.08482]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=2 vis=exact': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1346], [1036, 0.1346], [1927, 0.114], [4128, 0.06629], [8295, 0.06629]], 'slope': 0.2359}, 'cost': {'points': [[506, 0.02292], [1036, 0.02811], [1927, 0.04357], [4128, 0.09431], [8295, 0.1078]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=3 vis=exact': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1361], [1036, 0.1361], [1927, 0.1137], [4128, 0.06561], [8295, 0.06561]], 'slope': 0.2572}, 'cost': {'points': [[506, 0.02357], [1036, 0.03793], [1927, 0.05355], [4128, 0.1301], [8295, 0.1984]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=4 vis=exact': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1359], [1036, 0.1359], [1927, 0.1137], [4128, 0.06539], [8295, 0.06539]], 'slope': 0.2604}, 'cost': {'points': [[506, 0.02469], [1036, 0.05233], [1927, 0.07322], [4128, 0.1871], [8295, 0.1906]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=6 vis=exact': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1358], [1036, 0.1358], [1927, 0.1137]], 'slope': 0.05}, 'cost': {'points': [[506, 0.02913], [1036, 0.1015], [1927, 0.1461]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'FMM p=8 vis=exact': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1358], [1036, 0.1358], [1927, 0.1137]], 'slope': 0.05}, 'cost': {'points': [[506, 0.03997], [1036, 0.2479], [1927, 0.291]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'FMM p=2 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1214], [1036, 0.1214], [1927, 0.1058], [4128, 0.05511], [8295, 0.05511]], 'slope': 0.2004}, 'cost': {'points': [[506, 0.02536], [1036, 0.04197], [1927, 0.05213], [4128, 0.1294], [8295, 0.171]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=3 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1216], [1036, 0.1216], [1927, 0.106], [4128, 0.05514], [8295, 0.05514]], 'slope': 0.2007}, 'cost': {'points': [[506, 0.0245], [1036, 0.04707], [1927, 0.06151], [4128, 0.1934], [8295, 0.3337]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=4 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1215], [1036, 0.1215], [1927, 0.1059], [4128, 0.05513], [8295, 0.05513]], 'slope': 0.2008}, 'cost': {'points': [[506, 0.02628], [1036, 0.05813], [1927, 0.06801], [4128, 0.2772], [8295, 0.4641]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=2 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[506, 0.07255], [1036, 0.07101], [1927, 0.0517], [4128, 0.0517], [8295, 0.05143]], 'slope': 0.1412}, 'cost': {'points': [[506, 0.02521], [1036, 0.04951], [1927, 0.09003], [4128, 0.2025], [8295, 0.3503]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=3 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[506, 0.07255], [1036, 0.07103], [1927, 0.05174], [4128, 0.05174], [8295, 0.05144]], 'slope': 0.141}, 'cost': {'points': [[506, 0.02519], [1036, 0.05013], [1927, 0.08677], [4128, 0.2636], [8295, 0.4287]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=4 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[506, 0.07255], [1036, 0.07103], [1927, 0.05172], [4128, 0.05172], [8295, 0.05144]], 'slope': 0.1411}, 'cost': {'points': [[506, 0.02509], [1036, 0.04974], [1927, 0.08874], [4128, 0.3903], [8295, 0.632]], 'slope': 1.0}, 'n_range': [506, 8295]},
                'FMM p=2 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[506, 0.06533], [1036, 0.05852], [1927, 0.04327], [4128, 0.03437], [8295, 0.02135]], 'slope': 0.397}, 'cost': {'points': [[506, 0.02563], [1036, 0.05104], [1927, 0.09062], [4128, 0.2362], [8295, 0.7664]], 'slope': 1.687}, 'n_range': [506, 8295]},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[506, 0.06628], [1036, 0.05844], [1927, 0.04242], [4128, 0.02834], [8295, 0.01576]], 'slope': 0.5164}, 'cost': {'points': [[506, 0.02535], [1036, 0.05573], [1927, 0.09614], [4128, 0.2684], [8295, 0.7792]], 'slope': 1.527}, 'n_range': [506, 8295]},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[506, 0.06684], [1036, 0.05914], [1927, 0.03498], [4128, 0.01949], [8295, 0.01356]], 'slope': 0.6163}, 'cost': {'points': [[506, 0.02893], [1036, 0.08647], [1927, 0.1128], [4128, 0.3295], [8295, 0.951]], 'slope': 1.519}, 'n_range': [506, 8295]},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[506, 0.0663], [1036, 0.05767], [1927, 0.03364], [4128, 0.02245], [8295, 0.01025]], 'slope': 0.6702}, 'cost': {'points': [[506, 0.02651], [1036, 0.05449], [1927, 0.1043], [4128, 0.2996], [8295, 1.029]], 'slope': 1.768}, 'n_range': [506, 8295]},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[506, 0.06681], [1036, 0.0489], [1927, 0.03051], [4128, 0.01921], [8295, 0.0103]], 'slope': 0.6699}, 'cost': {'points': [[506, 0.02462], [1036, 0.05572], [1927, 0.1265], [4128, 0.3888], [8295, 0.9194]], 'slope': 1.233}, 'n_range': [506, 8295]},
            },
        },
        'mesh': {
            'scene': 'cornell_mesh',
            'n_min': 482,
            'reference_check': 0.008059,
            'discretization': 'direct vis=exact',
            'settings': {
                'direct vis=none': {'keywords': {'method': 'direct', 'visibility': 'none'}, 'error': {'points': [[482, 0.5162], [966, 0.4101], [1926, 0.4101], [3859, 0.4101], [7718, 0.4101]], 'slope': 0.06659}, 'cost': {'points': [[482, 0.005812], [966, 0.01366], [1926, 0.0329], [3859, 0.07362], [7718, 0.268]], 'slope': 1.864}, 'n_range': [482, 7718]},
                'FMM p=0 vis=none': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5181], [966, 0.3918], [1926, 0.3918], [3859, 0.3918], [7718, 0.3905]], 'slope': 0.08029}, 'cost': {'points': [[482, 0.0117], [966, 0.01573], [1926, 0.02589], [3859, 0.03327], [7718, 0.04379]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=2 vis=none': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.517], [966, 0.4197], [1926, 0.4197], [3859, 0.4197], [7718, 0.4197]], 'slope': 0.06011}, 'cost': {'points': [[482, 0.01279], [966, 0.01992], [1926, 0.03103], [3859, 0.05142], [7718, 0.05901]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=3 vis=none': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5164], [966, 0.4107], [1926, 0.4107], [3859, 0.4107], [7718, 0.4107]], 'slope': 0.06588}, 'cost': {'points': [[482, 0.01263], [966, 0.02581], [1926, 0.03383], [3859, 0.07125], [7718, 0.07962]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=4 vis=none': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5162], [966, 0.4096], [1926, 0.4096], [3859, 0.4096], [7718, 0.4096]], 'slope': 0.067}, 'cost': {'points': [[482, 0.01427], [966, 0.03457], [1926, 0.05066], [3859, 0.1143], [7718, 0.1143]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=6 vis=none': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5162], [966, 0.3957], [1926, 0.3762]], 'slope': 0.2285}, 'cost': {'points': [[482, 0.01357], [966, 0.06921], [1926, 0.09476]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'FMM p=8 vis=none': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5162], [966, 0.3957], [1926, 0.3762]], 'slope': 0.2286}, 'cost': {'points': [[482, 0.01852], [966, 0.1518], [1926, 0.2097]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'direct vis=seed': {'keywords': {'method': 'direct', 'visibility': 'seed'}, 'error': {'points': [[482, 0.2806], [966, 0.216], [1926, 0.1919]], 'slope': 0.2742}, 'cost': {'points': [[482, 0.06397], [966, 0.2236], [1926, 1.098]], 'slope': 2.306}, 'n_range': [482, 1926]},
                'FMM p=0 vis=seed': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2696], [966, 0.2268], [1926, 0.207], [3859, 0.1754]], 'slope': 0.1993}, 'cost': {'points': [[482, 0.0572], [966, 0.06179], [1926, 0.1], [3859, 0.2559]], 'slope': 1.352}, 'n_range': [482, 3859]},
                'FMM p=2 vis=seed': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2696], [966, 0.1853], [1926, 0.1735], [3859, 0.1106]], 'slope': 0.3953}, 'cost': {'points': [[482, 0.05787], [966, 0.07119], [1926, 0.1098], [3859, 0.2874]], 'slope': 1.384}, 'n_range': [482, 3859]},
                'FMM p=3 vis=seed': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2697], [966, 0.1881], [1926, 0.1759], [3859, 0.1107]], 'slope': 0.3951}, 'cost': {'points': [[482, 0.0583], [966, 0.07831], [1926, 0.1167], [3859, 0.3255]], 'slope': 1.476}, 'n_range': [482, 3859]},
                'FMM p=4 vis=seed': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2697], [966, 0.187], [1926, 0.1753], [3859, 0.1102]], 'slope': 0.3967}, 'cost': {'points': [[482, 0.05858], [966, 0.09622], [1926, 0.1509], [3859, 0.4127]], 'slope': 1.448}, 'n_range': [482, 3859]},
                'FMM p=6 vis=seed': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2697], [966, 0.1871], [1926, 0.1752]], 'slope': 0.3116}, 'cost': {'points': [[482, 0.05796], [966, 0.1472], [1926, 0.2223]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'FMM p=8 vis=seed': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2697], [966, 0.1872], [1926, 0.1752]], 'slope': 0.3115}, 'cost': {'points': [[482, 0.05809], [966, 0.2973], [1926, 0.3968]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'direct vis=exact': {'keywords': {'method': 'direct', 'visibility': 'exact'}, 'error': {'points': [[482, 0.2405], [966, 0.1667], [1926, 0.1123], [3859, 0.07845], [7718, 0.05789]], 'slope': 0.5196}, 'cost': {'points': [[482, 0.01953], [966, 0.07132], [1926, 0.3061], [3859, 1.301], [7718, 4.26]], 'slope': 1.711}, 'n_range': [482, 7718]},
                'FMM p=0 vis=exact': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.232], [966, 0.2156], [1926, 0.1775], [3859, 0.1775], [7718, 0.1775]], 'slope': 0.1074}, 'cost': {'points': [[482, 0.01748], [966, 0.03578], [1926, 0.04779], [3859, 0.08331], [7718, 0.1091]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=2 vis=exact': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2322], [966, 0.1735], [1926, 0.1315], [3859, 0.1041], [7718, 0.1013]], 'slope': 0.3128}, 'cost': {'points': [[482, 0.01845], [966, 0.03652], [1926, 0.05793], [3859, 0.1202], [7718, 0.1202]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=3 vis=exact': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2322], [966, 0.176], [1926, 0.1337], [3859, 0.104], [7718, 0.1021]], 'slope': 0.3128}, 'cost': {'points': [[482, 0.0184], [966, 0.04403], [1926, 0.06695], [3859, 0.1341], [7718, 0.1517]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=4 vis=exact': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2322], [966, 0.175], [1926, 0.1329], [3859, 0.1036], [7718, 0.1021]], 'slope': 0.3128}, 'cost': {'points': [[482, 0.01901], [966, 0.05353], [1926, 0.08635], [3859, 0.2184], [7718, 0.2408]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=6 vis=exact': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2322], [966, 0.1751], [1926, 0.1327]], 'slope': 0.4037}, 'cost': {'points': [[482, 0.02127], [966, 0.1154], [1926, 0.1568]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'FMM p=8 vis=exact': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2322], [966, 0.1751], [1926, 0.1328]], 'slope': 0.4037}, 'cost': {'points': [[482, 0.02786], [966, 0.2345], [1926, 0.3671]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'FMM p=2 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2308], [966, 0.1762], [1926, 0.1223], [3859, 0.102], [7718, 0.08375]], 'slope': 0.3713}, 'cost': {'points': [[482, 0.02054], [966, 0.03667], [1926, 0.09795], [3859, 0.168], [7718, 0.2252]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=3 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2308], [966, 0.1765], [1926, 0.1226], [3859, 0.102], [7718, 0.08384]], 'slope': 0.3712}, 'cost': {'points': [[482, 0.02126], [966, 0.04371], [1926, 0.09132], [3859, 0.2337], [7718, 0.2742]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=4 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2308], [966, 0.1764], [1926, 0.1226], [3859, 0.102], [7718, 0.08383]], 'slope': 0.3712}, 'cost': {'points': [[482, 0.02713], [966, 0.05107], [1926, 0.1126], [3859, 0.3411], [7718, 0.3724]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=2 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2308], [966, 0.1598], [1926, 0.1032], [3859, 0.09084], [7718, 0.08392]], 'slope': 0.3733}, 'cost': {'points': [[482, 0.02464], [966, 0.04988], [1926, 0.1312], [3859, 0.2575], [7718, 0.4367]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=3 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2308], [966, 0.1598], [1926, 0.1032], [3859, 0.09085], [7718, 0.08394]], 'slope': 0.3732}, 'cost': {'points': [[482, 0.02314], [966, 0.05204], [1926, 0.1309], [3859, 0.3155], [7718, 0.4372]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=4 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2308], [966, 0.1598], [1926, 0.1032], [3859, 0.09084], [7718, 0.08393]], 'slope': 0.3733}, 'cost': {'points': [[482, 0.02362], [966, 0.05401], [1926, 0.1347], [3859, 0.436], [7718, 0.7224]], 'slope': 1.0}, 'n_range': [482, 7718]},
                'FMM p=2 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[482, 0.2396], [966, 0.1532], [1926, 0.1059], [3859, 0.07938], [7718, 0.0594]], 'slope': 0.4972}, 'cost': {'points': [[482, 0.02563], [966, 0.05283], [1926, 0.1351], [3859, 0.2944], [7718, 0.7601]], 'slope': 1.368}, 'n_range': [482, 7718]},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[482, 0.2396], [966, 0.1542], [1926, 0.1071], [3859, 0.07896], [7718, 0.05943]], 'slope': 0.4988}, 'cost': {'points': [[482, 0.02595], [966, 0.05624], [1926, 0.1402], [3859, 0.309], [7718, 0.763]], 'slope': 1.304}, 'n_range': [482, 7718]},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[482, 0.24], [966, 0.1595], [1926, 0.1112], [3859, 0.07787], [7718, 0.05427]], 'slope': 0.5324}, 'cost': {'points': [[482, 0.02725], [966, 0.06653], [1926, 0.1608], [3859, 0.3683], [7718, 0.8572]], 'slope': 1.219}, 'n_range': [482, 7718]},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[482, 0.2396], [966, 0.1636], [1926, 0.1091], [3859, 0.0801], [7718, 0.05606]], 'slope': 0.5221}, 'cost': {'points': [[482, 0.02491], [966, 0.05996], [1926, 0.1429], [3859, 0.3487], [7718, 0.8799]], 'slope': 1.335}, 'n_range': [482, 7718]},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[482, 0.24], [966, 0.1648], [1926, 0.1105], [3859, 0.07813], [7718, 0.05557]], 'slope': 0.5298}, 'cost': {'points': [[482, 0.02602], [966, 0.06716], [1926, 0.1415], [3859, 0.4499], [7718, 1.18]], 'slope': 1.391}, 'n_range': [482, 7718]},
            },
        },
        'point_cloud': {
            'scene': 'bunny',
            'n_min': 848,
            'reference_check': 0.01679,
            'discretization': 'direct vis=exact',
            'settings': {
                'direct vis=none': {'keywords': {'method': 'direct', 'visibility': 'none'}, 'error': {'points': [[848, 0.7694], [1583, 0.7694], [3067, 0.7694], [4613, 0.7694], [6132, 0.7694]], 'slope': 0.05}, 'cost': {'points': [[848, 0.01103], [1583, 0.02097], [3067, 0.0665], [4613, 0.1265], [6132, 0.2196]], 'slope': 1.938}, 'n_range': [848, 6132]},
                'FMM p=0 vis=none': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.8134], [1583, 0.8134], [3067, 0.8134], [4613, 0.8134], [6132, 0.8134], [9070, 0.7901], [12034, 0.7805], [18085, 0.7805]], 'slope': 0.05}, 'cost': {'points': [[848, 0.02049], [1583, 0.02795], [3067, 0.06624], [4613, 0.1266], [6132, 0.1452], [9070, 0.2838], [12034, 0.3949], [18085, 0.9194]], 'slope': 2.074}, 'n_range': [848, 18085]},
                'FMM p=2 vis=none': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.7647], [1583, 0.7647], [3067, 0.7647], [4613, 0.7647], [6132, 0.7647], [9070, 0.7313], [12034, 0.7119], [18085, 0.7119]], 'slope': 0.05}, 'cost': {'points': [[848, 0.02296], [1583, 0.03822], [3067, 0.08409], [4613, 0.1616], [6132, 0.2943], [9070, 0.4849], [12034, 0.6078], [18085, 1.662]], 'slope': 2.469}, 'n_range': [848, 18085]},
                'FMM p=3 vis=none': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.7703], [1583, 0.7703], [3067, 0.7703], [4613, 0.7703], [6132, 0.7703], [9070, 0.736], [12034, 0.716], [18085, 0.716]], 'slope': 0.05}, 'cost': {'points': [[848, 0.03046], [1583, 0.05772], [3067, 0.1214], [4613, 0.2938], [6132, 0.4465], [9070, 0.7142], [12034, 0.8458], [18085, 2.629]], 'slope': 2.5}, 'n_range': [848, 18085]},
                'FMM p=4 vis=none': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.7699], [1583, 0.7699], [3067, 0.7699], [4613, 0.7699], [6132, 0.7699], [9070, 0.7356], [12034, 0.716], [18085, 0.716]], 'slope': 0.05}, 'cost': {'points': [[848, 0.0352], [1583, 0.08415], [3067, 0.1599], [4613, 0.5829], [6132, 0.9208], [9070, 1.069], [12034, 1.294], [18085, 4.085]], 'slope': 2.5}, 'n_range': [848, 18085]},
                'FMM p=6 vis=none': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.6268], [1583, 0.6268]], 'slope': 0.05}, 'cost': {'points': [[848, 0.06482], [1583, 0.2161]], 'slope': 1.929}, 'n_range': [848, 1583]},
                'FMM p=8 vis=none': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.6268], [1583, 0.6268]], 'slope': 0.05}, 'cost': {'points': [[848, 0.1731], [1583, 0.5513]], 'slope': 1.856}, 'n_range': [848, 1583]},
                'direct vis=seed': {'keywords': {'method': 'direct', 'visibility': 'seed'}, 'error': {'points': [[848, 0.3915], [1583, 0.3622]], 'slope': 0.1246}, 'cost': {'points': [[848, 0.1062], [1583, 0.2796]], 'slope': 1.552}, 'n_range': [848, 1583]},
                'FMM p=0 vis=seed': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4833], [1583, 0.4081], [3067, 0.3212]], 'slope': 0.3184}, 'cost': {'points': [[848, 0.05053], [1583, 0.1103], [3067, 0.2171]], 'slope': 1.024}, 'n_range': [848, 3067]},
                'FMM p=2 vis=seed': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4701], [1583, 0.3857], [3067, 0.3065]], 'slope': 0.3328}, 'cost': {'points': [[848, 0.05262], [1583, 0.1124], [3067, 0.2115]], 'slope': 1.0}, 'n_range': [848, 3067]},
                'FMM p=3 vis=seed': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4717], [1583, 0.3867], [3067, 0.3065]], 'slope': 0.3353}, 'cost': {'points': [[848, 0.05628], [1583, 0.1318], [3067, 0.2283]], 'slope': 1.0}, 'n_range': [848, 3067]},
                'FMM p=4 vis=seed': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4722], [1583, 0.3867], [3067, 0.3065]], 'slope': 0.3363}, 'cost': {'points': [[848, 0.0634], [1583, 0.1542], [3067, 0.2699]], 'slope': 1.0}, 'n_range': [848, 3067]},
                'FMM p=6 vis=seed': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4719], [1583, 0.3867]], 'slope': 0.3191}, 'cost': {'points': [[848, 0.08444], [1583, 0.2669]], 'slope': 1.843}, 'n_range': [848, 1583]},
                'FMM p=8 vis=seed': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4719], [1583, 0.3867]], 'slope': 0.3191}, 'cost': {'points': [[848, 0.17], [1583, 0.5649]], 'slope': 1.924}, 'n_range': [848, 1583]},
                'direct vis=exact': {'keywords': {'method': 'direct', 'visibility': 'exact'}, 'error': {'points': [[848, 0.242], [1583, 0.1854], [3067, 0.106], [4613, 0.0995], [6132, 0.0995], [9070, 0.09151], [12034, 0.03655]], 'slope': 0.5867}, 'cost': {'points': [[848, 0.03255], [1583, 0.08717], [3067, 0.2337], [4613, 0.7005], [6132, 1.271], [9070, 2.581], [12034, 5.477]], 'slope': 2.5}, 'n_range': [848, 12034]},
                'FMM p=0 vis=exact': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.3657], [1583, 0.3324], [3067, 0.2842], [4613, 0.2842], [6132, 0.2842], [9070, 0.2366], [12034, 0.1786], [18085, 0.1602]], 'slope': 0.2549}, 'cost': {'points': [[848, 0.02584], [1583, 0.05408], [3067, 0.0961], [4613, 0.2184], [6132, 0.336], [9070, 0.512], [12034, 0.7362], [18085, 1.948]], 'slope': 2.389}, 'n_range': [848, 18085]},
                'FMM p=2 vis=exact': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.3375], [1583, 0.2882], [3067, 0.2537], [4613, 0.2537], [6132, 0.2537], [9070, 0.2034], [12034, 0.1476], [18085, 0.1314]], 'slope': 0.2881}, 'cost': {'points': [[848, 0.03012], [1583, 0.0655], [3067, 0.1127], [4613, 0.2586], [6132, 0.4536], [9070, 0.5913], [12034, 0.8644], [18085, 2.648]], 'slope': 2.5}, 'n_range': [848, 18085]},
                'FMM p=3 vis=exact': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.3387], [1583, 0.2904], [3067, 0.2546], [4613, 0.2546], [6132, 0.2546], [9070, 0.2043], [12034, 0.1486], [18085, 0.1314]], 'slope': 0.2886}, 'cost': {'points': [[848, 0.03605], [1583, 0.08175], [3067, 0.1338], [4613, 0.3536], [6132, 0.6469], [9070, 0.7239], [12034, 1.113], [18085, 3.048]], 'slope': 2.474}, 'n_range': [848, 18085]},
                'FMM p=4 vis=exact': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.3393], [1583, 0.2903], [3067, 0.2545], [4613, 0.2545], [6132, 0.2545], [9070, 0.2042], [12034, 0.1485], [18085, 0.1314]], 'slope': 0.2891}, 'cost': {'points': [[848, 0.04109], [1583, 0.1023], [3067, 0.2163], [4613, 0.539], [6132, 0.9416], [9070, 1.142], [12034, 1.366], [18085, 3.723]], 'slope': 2.462}, 'n_range': [848, 18085]},
                'FMM p=6 vis=exact': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.3391], [1583, 0.2902]], 'slope': 0.2498}, 'cost': {'points': [[848, 0.06638], [1583, 0.2214]], 'slope': 1.93}, 'n_range': [848, 1583]},
                'FMM p=8 vis=exact': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.3392], [1583, 0.2902]], 'slope': 0.2498}, 'cost': {'points': [[848, 0.128], [1583, 0.6144]], 'slope': 2.5}, 'n_range': [848, 1583]},
                'FMM p=2 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[848, 0.3056], [1583, 0.2482], [3067, 0.2482], [4613, 0.2482], [6132, 0.2482], [9070, 0.1924], [12034, 0.1381], [18085, 0.1284]], 'slope': 0.258}, 'cost': {'points': [[848, 0.03081], [1583, 0.06957], [3067, 0.1283], [4613, 0.2714], [6132, 0.4401], [9070, 0.6093], [12034, 0.9029], [18085, 2.277]], 'slope': 2.27}, 'n_range': [848, 18085]},
                'FMM p=3 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[848, 0.3061], [1583, 0.2484], [3067, 0.2484], [4613, 0.2484], [6132, 0.2484], [9070, 0.1925], [12034, 0.138], [18085, 0.1285]], 'slope': 0.2584}, 'cost': {'points': [[848, 0.033], [1583, 0.07852], [3067, 0.1507], [4613, 0.3444], [6132, 0.5393], [9070, 0.7589], [12034, 1.096], [18085, 2.949]], 'slope': 2.43}, 'n_range': [848, 18085]},
                'FMM p=4 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[848, 0.3063], [1583, 0.2484], [3067, 0.2484], [4613, 0.2484], [6132, 0.2484], [9070, 0.1926], [12034, 0.138], [18085, 0.1285]], 'slope': 0.2586}, 'cost': {'points': [[848, 0.03814], [1583, 0.1021], [3067, 0.1965], [4613, 0.4733], [6132, 0.8589], [9070, 0.9271], [12034, 1.434], [18085, 4.031]], 'slope': 2.5}, 'n_range': [848, 18085]},
                'FMM p=2 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[848, 0.2495], [1583, 0.239], [3067, 0.239], [4613, 0.239], [6132, 0.239], [9070, 0.1814], [12034, 0.1328], [18085, 0.1105]], 'slope': 0.2047}, 'cost': {'points': [[848, 0.03264], [1583, 0.07766], [3067, 0.1468], [4613, 0.2974], [6132, 0.3674], [9070, 0.7129], [12034, 1.04], [18085, 2.646]], 'slope': 2.293}, 'n_range': [848, 18085]},
                'FMM p=3 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[848, 0.2495], [1583, 0.2391], [3067, 0.2391], [4613, 0.2391], [6132, 0.2391], [9070, 0.1814], [12034, 0.1328], [18085, 0.1105]], 'slope': 0.2046}, 'cost': {'points': [[848, 0.03252], [1583, 0.08968], [3067, 0.1697], [4613, 0.3834], [6132, 0.6105], [9070, 0.8673], [12034, 1.102], [18085, 3.249]], 'slope': 2.5}, 'n_range': [848, 18085]},
                'FMM p=4 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[848, 0.2495], [1583, 0.2391], [3067, 0.2391], [4613, 0.2391], [6132, 0.2391], [9070, 0.1814], [12034, 0.1328], [18085, 0.1105]], 'slope': 0.2046}, 'cost': {'points': [[848, 0.02705], [1583, 0.08587], [3067, 0.2164], [4613, 0.5533], [6132, 0.7944], [9070, 1.091], [12034, 1.46], [18085, 4.102]], 'slope': 2.5}, 'n_range': [848, 18085]},
                'FMM p=2 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[848, 0.2431], [1583, 0.1921], [3067, 0.1197], [4613, 0.1046], [6132, 0.1046], [9070, 0.09563], [12034, 0.06399], [18085, 0.05777]], 'slope': 0.4636}, 'cost': {'points': [[848, 0.02622], [1583, 0.08724], [3067, 0.1713], [4613, 0.3991], [6132, 0.7121], [9070, 1.11], [12034, 1.916], [18085, 4.703]], 'slope': 2.204}, 'n_range': [848, 18085]},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[848, 0.2433], [1583, 0.1924], [3067, 0.1196], [4613, 0.1045], [6132, 0.1045], [9070, 0.09554], [12034, 0.06595], [18085, 0.05765]], 'slope': 0.4608}, 'cost': {'points': [[848, 0.02786], [1583, 0.08408], [3067, 0.1743], [4613, 0.4314], [6132, 0.727], [9070, 1.4], [12034, 1.914], [18085, 5.525]], 'slope': 2.5}, 'n_range': [848, 18085]},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[848, 0.2425], [1583, 0.1845], [3067, 0.1078], [4613, 0.09967], [6132, 0.09967], [9070, 0.0918], [12034, 0.0518], [18085, 0.0518]], 'slope': 0.5466}, 'cost': {'points': [[848, 0.03075], [1583, 0.09463], [3067, 0.2369], [4613, 0.5468], [6132, 0.8657], [9070, 1.749], [12034, 2.504], [18085, 6.532]], 'slope': 2.354}, 'n_range': [848, 18085]},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[848, 0.2434], [1583, 0.1869], [3067, 0.1204], [4613, 0.1043], [6132, 0.1043], [9070, 0.09758], [12034, 0.05854], [18085, 0.05854]], 'slope': 0.497}, 'cost': {'points': [[848, 0.02911], [1583, 0.07439], [3067, 0.2002], [4613, 0.4777], [6132, 0.8213], [9070, 1.345], [12034, 2.135], [18085, 5.311]], 'slope': 2.237}, 'n_range': [848, 18085]},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[848, 0.2426], [1583, 0.1845], [3067, 0.1078], [4613, 0.09914], [6132, 0.09914], [9070, 0.0929], [12034, 0.05234], [18085, 0.05234]], 'slope': 0.5434}, 'cost': {'points': [[848, 0.0405], [1583, 0.09246], [3067, 0.2051], [4613, 0.5449], [6132, 0.9595], [9070, 1.469], [12034, 2.505], [18085, 6.985]], 'slope': 2.5}, 'n_range': [848, 18085]},
            },
        },
        'random': {
            'scene': 'interior',
            'n_min': 508,
            'reference_check': 0.0452,
            'discretization': 'direct vis=exact',
            'settings': {
                'direct vis=none': {'keywords': {'method': 'direct', 'visibility': 'none'}, 'error': {'points': [[508, 0.9053], [1003, 0.8556], [2000, 0.8556], [3000, 0.8556], [3999, 0.8556], [6003, 0.8], [8000, 0.7874]], 'slope': 0.05}, 'cost': {'points': [[508, 0.006672], [1003, 0.01734], [2000, 0.0463], [3000, 0.0739], [3999, 0.09131], [6003, 0.2059], [8000, 0.3579]], 'slope': 1.926}, 'n_range': [508, 8000]},
                'FMM p=0 vis=none': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.9658], [1003, 0.888], [2000, 0.888], [3000, 0.888], [3999, 0.888], [6003, 0.8632], [8000, 0.8632]], 'slope': 0.05}, 'cost': {'points': [[508, 0.01384], [1003, 0.02225], [2000, 0.03897], [3000, 0.03897], [3999, 0.03897], [6003, 0.06808], [8000, 0.09517]], 'slope': 1.167}, 'n_range': [508, 8000]},
                'FMM p=2 vis=none': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.9026], [1003, 0.8605], [2000, 0.8605], [3000, 0.8605], [3999, 0.8605], [6003, 0.803], [8000, 0.7927]], 'slope': 0.05}, 'cost': {'points': [[508, 0.01534], [1003, 0.02986], [2000, 0.05113], [3000, 0.06187], [3999, 0.06292], [6003, 0.09614], [8000, 0.1319]], 'slope': 1.101}, 'n_range': [508, 8000]},
                'FMM p=3 vis=none': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.9004], [1003, 0.8562], [2000, 0.8562], [3000, 0.8562], [3999, 0.8562], [6003, 0.8008], [8000, 0.788]], 'slope': 0.05}, 'cost': {'points': [[508, 0.01505], [1003, 0.03565], [2000, 0.06335], [3000, 0.07948], [3999, 0.07948], [6003, 0.1363], [8000, 0.1813]], 'slope': 1.0}, 'n_range': [508, 8000]},
                'FMM p=4 vis=none': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.9061], [1003, 0.8555], [2000, 0.8555], [3000, 0.8555], [3999, 0.8555], [6003, 0.7998], [8000, 0.7871]], 'slope': 0.05}, 'cost': {'points': [[508, 0.01744], [1003, 0.03562], [2000, 0.08473], [3000, 0.1249], [3999, 0.1249], [6003, 0.2068], [8000, 0.2712]], 'slope': 1.0}, 'n_range': [508, 8000]},
                'FMM p=6 vis=none': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.9051], [1003, 0.8458], [2000, 0.7979]], 'slope': 0.09197}, 'cost': {'points': [[508, 0.02531], [1003, 0.07122], [2000, 0.19]], 'slope': 1.421}, 'n_range': [508, 2000]},
                'FMM p=8 vis=none': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.9053], [1003, 0.8458], [2000, 0.7979]], 'slope': 0.09211}, 'cost': {'points': [[508, 0.04535], [1003, 0.158], [2000, 0.4443]], 'slope': 1.498}, 'n_range': [508, 2000]},
                'direct vis=seed': {'keywords': {'method': 'direct', 'visibility': 'seed'}, 'error': {'points': [[508, 0.3813], [1003, 0.2871], [2000, 0.2078], [3000, 0.177]], 'slope': 0.437}, 'cost': {'points': [[508, 0.08445], [1003, 0.3159], [2000, 1.488], [3000, 3.494]], 'slope': 2.105}, 'n_range': [508, 3000]},
                'FMM p=0 vis=seed': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3849], [1003, 0.3491], [2000, 0.2792], [3000, 0.2256], [3999, 0.2255]], 'slope': 0.2865}, 'cost': {'points': [[508, 0.0601], [1003, 0.0871], [2000, 0.1964], [3000, 0.2185], [3999, 0.2185]], 'slope': 1.0}, 'n_range': [508, 3999]},
                'FMM p=2 vis=seed': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3786], [1003, 0.331], [2000, 0.254], [3000, 0.1984], [3999, 0.1925]], 'slope': 0.3535}, 'cost': {'points': [[508, 0.05499], [1003, 0.08729], [2000, 0.2184], [3000, 0.2484], [3999, 0.2484]], 'slope': 1.0}, 'n_range': [508, 3999]},
                'FMM p=3 vis=seed': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3791], [1003, 0.333], [2000, 0.2554], [3000, 0.1994], [3999, 0.193]], 'slope': 0.353}, 'cost': {'points': [[508, 0.05151], [1003, 0.08784], [2000, 0.2411], [3000, 0.2811], [3999, 0.2811]], 'slope': 1.0}, 'n_range': [508, 3999]},
                'FMM p=4 vis=seed': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3793], [1003, 0.333], [2000, 0.2556], [3000, 0.1995], [3999, 0.1931]], 'slope': 0.3529}, 'cost': {'points': [[508, 0.05536], [1003, 0.09528], [2000, 0.2704], [3000, 0.3543], [3999, 0.3543]], 'slope': 1.0}, 'n_range': [508, 3999]},
                'FMM p=6 vis=seed': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3794], [1003, 0.3328], [2000, 0.2555]], 'slope': 0.2888}, 'cost': {'points': [[508, 0.06486], [1003, 0.1462], [2000, 0.4316]], 'slope': 1.568}, 'n_range': [508, 2000]},
                'FMM p=8 vis=seed': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3794], [1003, 0.3328], [2000, 0.2555]], 'slope': 0.2887}, 'cost': {'points': [[508, 0.08754], [1003, 0.2822], [2000, 0.8866]], 'slope': 1.659}, 'n_range': [508, 2000]},
                'direct vis=exact': {'keywords': {'method': 'direct', 'visibility': 'exact'}, 'error': {'points': [[508, 0.2808], [1003, 0.1551], [2000, 0.1274], [3000, 0.09084], [3999, 0.0837], [6003, 0.08075], [8000, 0.08075]], 'slope': 0.4656}, 'cost': {'points': [[508, 0.02514], [1003, 0.09187], [2000, 0.3397], [3000, 0.8746], [3999, 1.181], [6003, 3.254], [8000, 6.129]], 'slope': 2.204}, 'n_range': [508, 8000]},
                'FMM p=0 vis=exact': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2779], [1003, 0.2216], [2000, 0.2137], [3000, 0.1788], [3999, 0.1788], [6003, 0.1788], [8000, 0.1788]], 'slope': 0.1853}, 'cost': {'points': [[508, 0.02435], [1003, 0.03943], [2000, 0.06446], [3000, 0.08215], [3999, 0.08799], [6003, 0.1291], [8000, 0.1721]], 'slope': 1.003}, 'n_range': [508, 8000]},
                'FMM p=2 vis=exact': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.267], [1003, 0.1992], [2000, 0.1742], [3000, 0.1176], [3999, 0.1176], [6003, 0.1109], [8000, 0.1109]], 'slope': 0.3532}, 'cost': {'points': [[508, 0.02824], [1003, 0.04418], [2000, 0.07472], [3000, 0.09754], [3999, 0.1179], [6003, 0.1585], [8000, 0.2263]], 'slope': 1.241}, 'n_range': [508, 8000]},
                'FMM p=3 vis=exact': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2673], [1003, 0.2012], [2000, 0.1755], [3000, 0.1178], [3999, 0.1178], [6003, 0.1106], [8000, 0.1106]], 'slope': 0.3531}, 'cost': {'points': [[508, 0.02864], [1003, 0.04981], [2000, 0.1053], [3000, 0.1416], [3999, 0.1593], [6003, 0.2426], [8000, 0.3293]], 'slope': 1.065}, 'n_range': [508, 8000]},
                'FMM p=4 vis=exact': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.268], [1003, 0.2013], [2000, 0.1757], [3000, 0.1178], [3999, 0.1178], [6003, 0.1104], [8000, 0.1104]], 'slope': 0.3538}, 'cost': {'points': [[508, 0.0334], [1003, 0.06461], [2000, 0.1381], [3000, 0.2289], [3999, 0.2441], [6003, 0.3107], [8000, 0.5972]], 'slope': 2.276}, 'n_range': [508, 8000]},
                'FMM p=6 vis=exact': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.268], [1003, 0.2011], [2000, 0.1756]], 'slope': 0.3082}, 'cost': {'points': [[508, 0.04824], [1003, 0.1056], [2000, 0.2818]], 'slope': 1.422}, 'n_range': [508, 2000]},
                'FMM p=8 vis=exact': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.268], [1003, 0.2012], [2000, 0.1756]], 'slope': 0.3081}, 'cost': {'points': [[508, 0.0816], [1003, 0.2634], [2000, 0.7376]], 'slope': 1.492}, 'n_range': [508, 2000]},
                'FMM p=2 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[508, 0.279], [1003, 0.1513], [2000, 0.1445], [3000, 0.1167], [3999, 0.1167], [6003, 0.1072], [8000, 0.1072]], 'slope': 0.3307}, 'cost': {'points': [[508, 0.02795], [1003, 0.06488], [2000, 0.1505], [3000, 0.1505], [3999, 0.1585], [6003, 0.2633], [8000, 0.3409]], 'slope': 1.0}, 'n_range': [508, 8000]},
                'FMM p=3 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[508, 0.279], [1003, 0.1513], [2000, 0.1446], [3000, 0.1167], [3999, 0.1167], [6003, 0.1072], [8000, 0.1072]], 'slope': 0.3305}, 'cost': {'points': [[508, 0.03217], [1003, 0.06541], [2000, 0.1648], [3000, 0.1725], [3999, 0.2156], [6003, 0.3173], [8000, 0.4124]], 'slope': 1.0}, 'n_range': [508, 8000]},
                'FMM p=4 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[508, 0.279], [1003, 0.1513], [2000, 0.1446], [3000, 0.1167], [3999, 0.1167], [6003, 0.1072], [8000, 0.1072]], 'slope': 0.3306}, 'cost': {'points': [[508, 0.03405], [1003, 0.06943], [2000, 0.1994], [3000, 0.2789], [3999, 0.3043], [6003, 0.4354], [8000, 0.6673]], 'slope': 1.486}, 'n_range': [508, 8000]},
                'FMM p=2 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2794], [1003, 0.1512], [2000, 0.1369], [3000, 0.09523], [3999, 0.09523], [6003, 0.09514], [8000, 0.09514]], 'slope': 0.4129}, 'cost': {'points': [[508, 0.02858], [1003, 0.06479], [2000, 0.1855], [3000, 0.2372], [3999, 0.2788], [6003, 0.5982], [8000, 0.7255]], 'slope': 1.0}, 'n_range': [508, 8000]},
                'FMM p=3 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2794], [1003, 0.1512], [2000, 0.1369], [3000, 0.0952], [3999, 0.0952], [6003, 0.09515], [8000, 0.09515]], 'slope': 0.4129}, 'cost': {'points': [[508, 0.02814], [1003, 0.06731], [2000, 0.1895], [3000, 0.272], [3999, 0.3096], [6003, 0.6023], [8000, 0.7948]], 'slope': 1.0}, 'n_range': [508, 8000]},
                'FMM p=4 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2794], [1003, 0.1512], [2000, 0.1369], [3000, 0.09521], [3999, 0.09521], [6003, 0.09515], [8000, 0.09515]], 'slope': 0.4129}, 'cost': {'points': [[508, 0.02976], [1003, 0.06934], [2000, 0.196], [3000, 0.3252], [3999, 0.3579], [6003, 0.6933], [8000, 1.021]], 'slope': 1.349}, 'n_range': [508, 8000]},
                'FMM p=2 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[508, 0.2789], [1003, 0.1543], [2000, 0.1264], [3000, 0.08899], [3999, 0.08556], [6003, 0.08153], [8000, 0.08153]], 'slope': 0.4648}, 'cost': {'points': [[508, 0.031], [1003, 0.06957], [2000, 0.2287], [3000, 0.294], [3999, 0.3622], [6003, 0.8971], [8000, 1.106]], 'slope': 1.0}, 'n_range': [508, 8000]},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[508, 0.2795], [1003, 0.1551], [2000, 0.1277], [3000, 0.08964], [3999, 0.08541], [6003, 0.08109], [8000, 0.08109]], 'slope': 0.4631}, 'cost': {'points': [[508, 0.03271], [1003, 0.06486], [2000, 0.1989], [3000, 0.2866], [3999, 0.403], [6003, 0.8884], [8000, 1.279]], 'slope': 1.268}, 'n_range': [508, 8000]},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[508, 0.2807], [1003, 0.1558], [2000, 0.1283], [3000, 0.09024], [3999, 0.08321], [6003, 0.08063], [8000, 0.08063]], 'slope': 0.4671}, 'cost': {'points': [[508, 0.03364], [1003, 0.07632], [2000, 0.2181], [3000, 0.3179], [3999, 0.6068], [6003, 1.054], [8000, 1.456]], 'slope': 1.126}, 'n_range': [508, 8000]},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[508, 0.2799], [1003, 0.1552], [2000, 0.1272], [3000, 0.08992], [3999, 0.08541], [6003, 0.08092], [8000, 0.08092]], 'slope': 0.4627}, 'cost': {'points': [[508, 0.03148], [1003, 0.07256], [2000, 0.2587], [3000, 0.3101], [3999, 0.4383], [6003, 1.093], [8000, 1.357]], 'slope': 1.0}, 'n_range': [508, 8000]},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[508, 0.2807], [1003, 0.1559], [2000, 0.1277], [3000, 0.09044], [3999, 0.08383], [6003, 0.08099], [8000, 0.08099]], 'slope': 0.4638}, 'cost': {'points': [[508, 0.03383], [1003, 0.07973], [2000, 0.2568], [3000, 0.3577], [3999, 0.719], [6003, 1.323], [8000, 1.705]], 'slope': 1.0}, 'n_range': [508, 8000]},
            },
        },
    },
}
# --- end calibration ---


# --- scene summary -------------------------------------------------------------------------------

def _grid_like(surfels: Surfels) -> bool:
    """True when most areas are equal (regular sampling)."""
    a = surfels.areas
    med = float(np.median(a))
    return bool(np.mean(np.abs(a - med) <= 1e-6 * med) > 0.5)


def scene_summary(scene, kind: str | None = None) -> dict:
    """What :func:`choose_settings` needs: ``n``, ``total_area`` (m²), ``albedo_max``,
    ``albedo_mean``, ``emitter_area_fraction``, ``kind`` ("grid", "random" or
    "point_cloud"). ``scene`` is Surfels or such a dict (``n`` and ``total_area`` required)."""
    if isinstance(scene, Surfels):
        emitters = scene.emission.max(axis=1) > 0
        return dict(n=scene.n, total_area=scene.total_area,
                    albedo_max=float(scene.albedo.max()),
                    albedo_mean=float(np.average(scene.albedo.mean(axis=1), weights=scene.areas)),
                    emitter_area_fraction=float(scene.areas[emitters].sum() / scene.total_area),
                    kind=kind or ("grid" if _grid_like(scene) else "random"))
    if isinstance(scene, dict):
        missing = {"n", "total_area"} - set(scene)
        if missing:
            raise InputError(f"scene summary: missing {sorted(missing)}")
        out = dict(albedo_max=0.8, albedo_mean=0.6, emitter_area_fraction=0.02, kind="random")
        out.update(scene)
        if kind:
            out["kind"] = kind
        return out
    raise InputError(f"scene: expected Surfels or a summary dict, got {type(scene).__name__}")


def _check_target(target_error) -> float:
    if isinstance(target_error, str):
        key = target_error.lower()
        if key not in PRESETS:
            raise InputError(f"target_error: unknown preset {target_error!r}; "
                             f"expected a number or one of {sorted(PRESETS)}")
        return PRESETS[key]
    if isinstance(target_error, bool):
        raise InputError(f"target_error: expected a number, got {target_error!r}")
    try:
        t = float(target_error)
    except (TypeError, ValueError):
        raise InputError(f"target_error: expected a number, got {target_error!r}") from None
    if not (math.isfinite(t) and 0 < t < 1):
        raise InputError(f"target_error: expected a relative error in (0, 1), got {target_error!r}")
    return t


# --- occlusion probe -----------------------------------------------------------------------------

def _probe_subset(surfels: Surfels, count: int, seed: int) -> Surfels:
    """About ``count`` surfels drawn at random, emitters and the rest apart, each group's areas
    scaled to keep its total (and so each light's power and each surface's disc coverage)."""
    rng = np.random.default_rng(seed)
    emit = surfels.emission.max(axis=1) > 0
    parts = []
    for group, share in ((np.flatnonzero(emit), 0.25), (np.flatnonzero(~emit), 0.75)):
        if group.size == 0:
            continue
        k = min(group.size, max(8, int(share * count)))
        pick = np.sort(rng.choice(group, k, replace=False))
        parts.append((pick, group.size / k))
    idx = np.concatenate([p for p, _ in parts])
    scale = np.concatenate([np.full(p.size, s) for p, s in parts])
    return Surfels(surfels.positions[idx], surfels.normals[idx], surfels.areas[idx] * scale,
                   surfels.albedo[idx], surfels.emission[idx])


def occlusion_probe(surfels: Surfels, count: int = PROBE_SURFELS, seed: int = 0,
                    kind: str = "random") -> dict:
    """How much occlusion changes this scene: relative RMS difference (non-emitters) between
    the direct solutions without and with exact visibility on about ``count`` of its surfels.
    Returns ``error_none`` (that difference, the error of ``visibility="none"``), ``surfels``
    and ``seconds``."""
    from .solver import solve as _solve
    t0 = time.perf_counter()
    sub = surfels if surfels.n <= count else _probe_subset(surfels, count, seed)
    if not (sub.emission > 0).any():
        return dict(error_none=0.0, surfels=sub.n, seconds=time.perf_counter() - t0)
    plain = _solve(sub, method="direct", tol=1e-3)   # a few per cent is all it needs
    occluded = _solve(sub, method="direct", tol=1e-3, visibility="exact",
                      **visibility_keywords("exact", kind))
    m = ~(sub.emission.max(axis=1) > 0)
    ref = occluded.radiosity[m]
    den = float(np.sqrt(np.mean(ref ** 2))) or 1.0
    err = float(np.sqrt(np.mean((plain.radiosity[m] - ref) ** 2))) / den
    return dict(error_none=err, surfels=sub.n, seconds=time.perf_counter() - t0)


# --- choosing ------------------------------------------------------------------------------------

def _kind_table(kind: str) -> dict:
    kinds = CALIBRATION.get("kinds", {})
    for k in (kind, "random", "grid", *kinds):   # the closest calibrated kind
        if k in kinds:
            return kinds[k]
    raise InputError("illumap.accuracy has no calibration (run bench/calibrate.py)")


def _loglog(model: dict, n: float, *, error: bool) -> float:
    """A calibrated curve at ``n``: log-log interpolation between the measured points; beyond
    them the model's slope (error ∝ N^-slope, time ∝ N^slope), and below the first point, for
    time, proportional to N."""
    pts = model["points"]
    ns = [p[0] for p in pts]
    vs = [p[1] for p in pts]
    if n <= ns[0]:
        return vs[0] * (ns[0] / n) ** model["slope"] if error else vs[0] * n / ns[0]
    if n >= ns[-1]:
        k = -model["slope"] if error else model["slope"]
        return vs[-1] * (n / ns[-1]) ** k
    i = int(np.searchsorted(ns, n)) - 1
    w = math.log(n / ns[i]) / math.log(ns[i + 1] / ns[i])
    return math.exp((1 - w) * math.log(vs[i]) + w * math.log(vs[i + 1]))


def _predicted_error(entry: dict, table: dict, n: float, e_occlusion) -> float | None:
    """The model's error of one calibrated setting at ``n`` surfels (None: not usable)."""
    kw = entry["keywords"]
    vis = kw.get("visibility", "none")
    if vis != "none":
        return _loglog(entry["error"], n, error=True)
    if e_occlusion is None:
        return None
    base = table["settings"].get(table.get("discretization", ""))
    if base is None:
        return None
    e_fmm = 0.0
    if kw["method"] == "fmm":
        row = min((t for t in FMM_ERROR if t >= kw["theta"]), default=max(FMM_ERROR))
        e_fmm = FMM_ERROR[row].get(kw["order"], FMM_ERROR[row][0])
    e_disc = _loglog(base["error"], n, error=True)
    return math.sqrt(e_disc ** 2 + e_fmm ** 2 + e_occlusion ** 2)


def _discretization(table: dict, n: float) -> float | None:
    base = table["settings"].get(table.get("discretization", ""))
    return None if base is None else _loglog(base["error"], n, error=True)


def _needed_n(entry, table, target, e_occlusion, n_min, cap):
    """Smallest N in [n_min, cap] with predicted error <= target (None when none is)."""
    lo = max(n_min, 2)
    if _predicted_error(entry, table, lo, e_occlusion) is None:
        return None
    if _predicted_error(entry, table, lo, e_occlusion) <= target:
        return lo
    if _predicted_error(entry, table, cap, e_occlusion) > target:
        return None
    hi = cap
    for _ in range(60):   # bisection on log N (the error decreases with N)
        mid = math.sqrt(lo * hi)
        if _predicted_error(entry, table, mid, e_occlusion) <= target:
            hi = mid
        else:
            lo = mid
        if hi / lo < 1.01:
            break
    return int(math.ceil(hi))


def _candidates(table, s, fixed, target, e_occ, n_min, cap, allow_direct):
    """Every calibrated setting with its N, predicted error and time, and whether it meets
    ``target`` (at the scene's own N when ``fixed``)."""
    out = []
    for label, entry in table["settings"].items():
        kw = entry["keywords"]
        if kw["method"] == "direct" and not allow_direct:
            continue
        if fixed:
            n = s["n"]
            err = _predicted_error(entry, table, n, e_occ)
            if err is None:
                continue
            need = _needed_n(entry, table, target, e_occ, n_min, 10 ** 9)
            ok = err <= target
        else:
            need = _needed_n(entry, table, target, e_occ, n_min, cap)
            n = need if need is not None else cap
            err = _predicted_error(entry, table, n, e_occ)
            if err is None:
                continue
            ok = need is not None
        out.append(dict(label=label, entry=entry, n=n, need=need, error=err, ok=ok,
                        time=_loglog(entry["cost"], n, error=False)))
    return out


def choose_settings(scene, target_error, *, kind: str | None = None, allow_direct: bool = True,
                    max_surfels: int | None = None, probe="auto") -> dict:
    """Settings meeting ``target_error`` (relative RMS per surfel) at the least modelled time.

    scene : Surfels (its N is then fixed: the setting is chosen for it, and ``n`` reports the
        count the target needs), or a summary dict with at least ``n`` (surfels available:
        the points of a scan; any large number for meshes) and ``total_area`` (m²).
    target_error : float in (0, 1), or a preset name from :data:`PRESETS`.
    kind : "grid" | "random" | "point_cloud"; default guessed (equal areas → "grid").
    allow_direct : when False, only FMM settings are considered.
    max_surfels : cap on the recommended surfel count (e.g. the points of a scan).
    probe : "auto" (default): run :func:`occlusion_probe` on Surfels when a setting without
        visibility would be at least 1/PROBE_GAIN times faster were the scene unoccluded and
        the best setting with visibility is predicted above PROBE_WORTH seconds (below, the
        probe costs about what it could save); True: whenever such a setting could win;
        False: never (``visibility="none"`` is then not chosen); or a probe result to reuse.

    Returns a dict: ``target_error``, ``kind``, ``density`` (surfels per m²), ``n``
    (recommended count), ``method``, ``order``, ``theta``, ``leaf_size``, ``visibility``,
    ``visibility_keywords``, ``solver``, ``tol``, ``label`` (the calibrated setting),
    ``predicted`` (``total`` error and ``discretization``, the setting's error at N),
    ``predicted_time`` (s, calibration machine), ``probe`` and ``notes``. Pass it to
    :func:`solve_keywords` for ``illumap.solve``.
    """
    target = _check_target(target_error)
    s = scene_summary(scene, kind)
    table = _kind_table(s["kind"])
    notes = []
    fixed = isinstance(scene, Surfels)
    cap = s["n"] if (fixed or s["kind"] == "point_cloud") else 10 ** 9
    if max_surfels is not None:
        cap = min(cap, int(max_surfels))
    n_min = min(int(table.get("n_min", DEFAULT_N_MIN)), cap)
    probe_info = probe if isinstance(probe, dict) else None

    def rank(e_occ):   # aim a little below the target: the fits are of a few sampled scenes
        return _candidates(table, s, fixed, SAFETY * target, e_occ, n_min, cap, allow_direct)
    candidates = rank(None if probe_info is None else float(probe_info["error_none"]))
    if fixed and (probe is True or probe == "auto"):
        # probe when a setting without visibility could win were the scene unoccluded, and
        # ("auto") when that would save more than the probe costs
        meeting = [c for c in candidates if c["ok"]]
        best_time = min((c["time"] for c in meeting), default=math.inf)
        worth = probe is True or best_time > PROBE_WORTH
        if worth and any(c["ok"] and c["time"] < PROBE_GAIN * best_time for c in rank(0.0)
                         if c["entry"]["keywords"].get("visibility", "none") == "none"):
            probe_info = occlusion_probe(scene, kind=s["kind"])
            candidates = rank(float(probe_info["error_none"]))
    e_occ = None if probe_info is None else float(probe_info["error_none"])
    if not candidates:
        raise InputError("illumap.accuracy: no calibrated setting applies")
    meeting = [c for c in candidates if c["ok"]]
    if meeting:
        best = min(meeting, key=lambda c: c["time"])
    else:
        best = min(candidates, key=lambda c: (c["error"], c["time"]))
        notes.append(f"no calibrated setting reaches {target:.3g} with {cap} surfels; "
                     f"the most accurate one is predicted at {best['error']:.3g}")
    kw = best["entry"]["keywords"]
    vis = kw.get("visibility", "none")
    if e_occ is None:
        notes.append("visibility: no occlusion probe (a summary, probe=False, or too small a "
                     "scene for it to pay off): visibility='none' not considered")
    else:
        notes.append(f"visibility: the probe puts the error of visibility='none' at "
                     f"{e_occ:.3g}")
    rho = min(s["albedo_max"], 0.995)
    tol = float(min(1e-4, max(1e-8, 0.01 * target * (1 - rho) / 0.2)))
    n_out = best["n"] if not fixed else (best["need"] or s["n"])
    e_disc = _discretization(table, n_out)
    return dict(
        target_error=target,
        kind=s["kind"],
        density=n_out / s["total_area"],
        n=int(n_out),
        method=kw["method"],
        order=int(kw.get("order", 0)),
        theta=float(kw.get("theta", 0.5)),
        leaf_size=int(kw.get("leaf_size", DEFAULT_LEAF_SIZE)),
        visibility=vis,
        visibility_keywords={**visibility_keywords(vis, s["kind"]),
                             **{k: kw[k] for k in SETTING_VISIBILITY_KEYS if k in kw}},
        solver="auto",
        tol=tol,
        label=best["label"],
        predicted=dict(total=float(best["error"]), discretization=e_disc,
                       occlusion=e_occ if vis == "none" else None),
        predicted_time=float(best["time"]),
        probe=probe_info,
        notes=notes,
    )


def solve_keywords(settings: dict) -> dict:
    """The ``illumap.solve`` keywords of a :func:`choose_settings` result."""
    kw = dict(method=settings["method"], solver=settings.get("solver", "auto"),
              tol=settings["tol"])
    if settings["method"] == "fmm":
        kw.update(order=settings["order"], theta=settings["theta"],
                  leaf_size=settings["leaf_size"])
    if settings.get("visibility", "none") != "none":
        kw["visibility"] = settings["visibility"]
        kw.update(settings.get("visibility_keywords", {}))
    return kw


# --- a-posteriori estimate -------------------------------------------------------------------------

def _rms(x) -> float:
    return float(math.sqrt(np.mean(np.square(x)))) if x.size else 0.0


def _morton_keys(points, bits=20):
    lo = points.min(axis=0)
    span = float((points.max(axis=0) - lo).max()) or 1.0
    q = np.minimum(((points - lo) / span * (2 ** bits - 1)).astype(np.uint64), 2 ** bits - 1)
    key = np.zeros(len(points), dtype=np.uint64)
    for b in range(bits):
        for axis in range(3):
            key |= ((q[:, axis] >> np.uint64(b)) & np.uint64(1)) << np.uint64(3 * b + axis)
    return key


def _even_half(surfels: Surfels):
    """Every other surfel along a Morton curve, per orientation class and emitter flag (so that
    each surface and each light keeps about half of its surfels): a spatially even half."""
    order = np.argsort(_morton_keys(surfels.positions), kind="stable")
    axis = np.argmax(np.abs(surfels.normals), axis=1)
    dominant = (axis * 2 + (surfels.normals[np.arange(surfels.n), axis] > 0)) * 2 + (
        surfels.emission.max(axis=1) > 0)
    keep, areas = [], []
    for g in np.unique(dominant):
        members = order[dominant[order] == g]
        kept = members[::2]
        keep.append(kept)   # each class keeps its total area (and each light its power)
        areas.append(surfels.areas[kept] * (surfels.areas[members].sum()
                                            / surfels.areas[kept].sum()))
    keep = np.concatenate(keep)
    areas = np.concatenate(areas)
    order = np.argsort(keep)
    return keep[order], areas[order]


_OPERATOR_STATS = ("method", "order", "theta", "leaf_size", "near_field", "visibility")


def estimate_error(solution, surfels: Surfels, *, operator: TransportOperator | None = None,
                   probe: int = 256, coarse: bool = False, settings: dict | None = None,
                   kind: str | None = None, seed: int = 0,
                   discretization_scale: float = 1.0) -> dict:
    """A-posteriori estimate of the relative RMS error (emitters excluded) of ``solution``.

    * ``solver``: ‖r‖/((1 − ρ_max)‖B‖) from the final true residual (r = E − (B − ρ K B)).
    * ``fmm``: the FMM applied to B against the exact per-pair sum (with the same visibility,
      applied per pair) on ``probe`` random receivers, times ρ, relative to B there, amplified
      by 1/(1 − ρ_max): expansion error plus the visibility classification of node pairs.
      Zero for a direct solution.
    * ``occlusion``: for ``visibility="none"``, the probe's estimate from ``settings`` (the
      :func:`choose_settings` result), else 0.
    * ``discretization``: with ``coarse=True`` measured on a spatially even half of the surfels
      (e ≈ d/(√2 − 1)); otherwise the calibrated model of the scene kind at this N, times
      ``discretization_scale`` (the models are of uniform density: ADAPTIVE_ERROR_RATIO for an
      adaptive sampling), None when there is no calibration.
    ``total`` = sqrt of the sum of squares (independent sources); ``numerical`` = solver + fmm.
    """
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    B = np.asarray(solution.radiosity)
    stats = solution.stats
    rho_max = min(float(surfels.albedo.max()), 0.995)
    amplification = 1.0 / (1.0 - rho_max)
    non_emit = ~(surfels.emission.max(axis=1) > 0)
    if not non_emit.any():
        non_emit = np.ones(surfels.n, bool)
    b_rms = _rms(B[non_emit]) or 1.0
    e_norm = math.sqrt(float(np.sum(surfels.emission ** 2)))
    res = float(stats.get("final_residual", 0.0) or 0.0)
    e_solver = res * e_norm / math.sqrt(max(non_emit.sum(), 1)) * amplification / b_rms
    vis = stats.get("visibility", "none")
    # The solve's own visibility keywords (its stats), else the chosen ones, else the kind's.
    vis_kw = visibility_keywords(vis, kind if kind in EXACT_KEYWORDS else "random")
    if settings is not None:
        vis_kw = dict(settings.get("visibility_keywords", vis_kw))
    if vis != "none":
        vis_kw.update({k: stats[k] for k in VISIBILITY_DEFAULTS if k in stats})
    method = stats.get("method", "direct")
    e_fmm = 0.0
    rows = np.array([], dtype=np.int64)
    if method == "fmm":
        kw = {k: stats[k] for k in _OPERATOR_STATS if k in stats}
        kw.pop("method", None)
        if vis != "none":
            kw.update(vis_kw)
        if operator is None:
            operator = TransportOperator(surfels, method="fmm", **kw)
        candidates = np.flatnonzero(non_emit)
        rows = np.sort(rng.choice(candidates, min(probe, len(candidates)), replace=False))
        fmm_y = operator.apply(B)[rows]
        exact_y = operator.apply_rows(B, rows)   # exact per pair, same visibility
        diff = surfels.albedo[rows] * (fmm_y - exact_y)
        e_fmm = _rms(diff) / (_rms(B[rows]) or 1.0) * amplification
    e_occ = 0.0
    if vis == "none" and settings is not None and settings.get("predicted", {}).get("occlusion"):
        e_occ = float(settings["predicted"]["occlusion"])
    e_disc = None
    source = None
    if coarse:
        from .solver import solve as _solve
        half, half_areas = _even_half(surfels)
        sub = Surfels(surfels.positions[half], surfels.normals[half], half_areas,
                      surfels.albedo[half], surfels.emission[half])
        keys = {k: stats[k] for k in _OPERATOR_STATS if k in stats}
        if keys.get("method") == "direct":
            keys = {k: v for k, v in keys.items() if k in ("method", "near_field", "visibility")}
        if vis != "none":
            keys.update(vis_kw)
        coarse_sol = _solve(sub, tol=max(float(stats.get("tol", 1e-6)), 1e-10), **keys)
        m = non_emit[half]
        d = _rms(coarse_sol.radiosity[m] - B[half][m]) / (_rms(B[half][m]) or 1.0)
        e_disc = d / (math.sqrt(2.0) - 1.0)
        source = "coarse"
    elif CALIBRATION.get("kinds"):
        k = kind or (settings or {}).get("kind") or scene_summary(surfels)["kind"]
        e_disc = _discretization(_kind_table(k), surfels.n)
        if e_disc is not None:
            e_disc *= float(discretization_scale)
            source = "model"
    total = math.sqrt(e_solver ** 2 + e_fmm ** 2 + e_occ ** 2 + (e_disc or 0.0) ** 2)
    return dict(solver=e_solver, fmm=e_fmm, occlusion=e_occ, discretization=e_disc,
                discretization_source=source, total=total, numerical=e_solver + e_fmm,
                probe_rows=int(rows.size), seconds=time.perf_counter() - t0)


# --- one call ----------------------------------------------------------------------------------------

def solve(surfels: Surfels, target_error, *, kind: str | None = None, allow_direct: bool = True,
          estimate: bool = True, coarse: bool = False, settings: dict | None = None,
          progress=None, **overrides):
    """Choose settings for ``target_error`` (or use ``settings``, a :func:`choose_settings`
    result) and solve ``surfels``; ``stats["accuracy"]`` holds the chosen settings, the solve
    keywords and (``estimate=True``) the a-posteriori estimate. ``overrides`` replace chosen
    solve keywords (e.g. ``solver="jacobi"``)."""
    from .solver import solve as _solve
    chosen = settings if settings is not None else choose_settings(
        surfels, target_error, kind=kind, allow_direct=allow_direct)
    kw = solve_keywords(chosen)
    kw.update(overrides)
    sol = _solve(surfels, progress=progress, **kw)
    info = dict(settings=chosen, solve_keywords=kw)
    if estimate:
        info["estimate"] = estimate_error(sol, surfels, settings=chosen, coarse=coarse, kind=kind)
    sol.stats["accuracy"] = info
    return sol


# --- meshes: automatic density, adaptive ---------------------------------------------------------

#: Adaptive runs: pass 1 takes this share of the chosen count (its only use is to find where the
#: illumination varies), regions hold about this many pass-1 surfels, variation is measured
#: against this many neighbours, and density multipliers stay within [1, ADAPTIVE_MAX_RATIO].
ADAPTIVE_FIRST_SHARE = 0.5
ADAPTIVE_SURFELS_PER_REGION = 6
ADAPTIVE_NEIGHBOURS = 8
ADAPTIVE_MAX_RATIO = 4.0
#: Error of an adaptive run against a uniform one of the same count, as the count is chosen:
#: measured 0.60-0.73 on the Cornell box's triangles (bench/bench_adaptive.py: 2k, 4k and 8k
#: surfels, direct and FMM p = 3, θ = 0.2, exact visibility); rounded up.
ADAPTIVE_ERROR_RATIO = 0.75


def _mesh_surfels(samples, albedo, emission, keep):
    mask = np.ones(len(samples.positions), bool) if keep is None else \
        np.asarray(keep(samples.positions), bool)
    tri = samples.triangle[mask]
    return Surfels(samples.positions[mask], samples.normals[mask], samples.areas[mask],
                   albedo[tri], emission[tri]), mask


def solve_triangles(corners, albedo, emission, target_error, *, kind: str = "mesh",
                    adaptive: bool = True, seed: int = 0, keep=None, count: int | None = None,
                    estimate: bool = True, progress=None, **overrides):
    """Sample a triangle mesh for ``target_error`` and solve it, denser where the
    illumination varies.

    corners : (T, 3, 3) triangle corners, m (normal = (b − a) × (c − a)).
    albedo, emission : (T, 3) per triangle (reflectance in [0, 1), radiance W/(m²·sr)).
    target_error : relative RMS per surfel, or a preset name (:data:`PRESETS`).
    kind : the calibrated scene kind whose error model sets the count ("mesh": stratified
        samples of triangles, uniform density, as in bench/scenes.py ``cornell_mesh``; the
        second pass only lowers the error).
    adaptive : two passes. The count is chosen for target / ADAPTIVE_ERROR_RATIO under the
        uniform-density model; pass 1 solves ADAPTIVE_FIRST_SHARE of it, uniformly; pass 2
        resamples the full count with a density multiplier per region that grows with how
        much pass 1's luminance varies there (``illumap.sampling``), and solves again. Without
        it: one uniform pass of the count chosen for the target.
    keep : optional callable, positions (N, 3) → bool (N,): which samples become surfels
        (e.g. not those inside a closed solid).
    count : samples of the (final) pass instead of the chosen count (a budget).
    overrides : replace chosen solve keywords.

    Returns ``(Solution, Surfels)``; ``stats["accuracy"]`` holds the chosen settings, the solve
    keywords, ``passes`` (surfels, iterations and seconds of each) and, with ``estimate``, the
    a-posteriori estimate of the final pass.
    """
    from . import sampling
    from . import _core
    from .solver import solve as _solve
    c = np.asarray(corners, dtype=np.float64)
    rho = np.asarray(albedo, dtype=np.float64)
    emit = np.asarray(emission, dtype=np.float64)
    if rho.shape != (len(c), 3) or emit.shape != (len(c), 3):
        raise InputError(f"albedo and emission: expected shape (T, 3) = ({len(c)}, 3), got "
                         f"{rho.shape} and {emit.shape}")
    areas = sampling.triangle_areas(c)
    target = _check_target(target_error)
    # the error models are of uniform sampling; the second pass lowers the error by a factor
    uniform_target = min(target / ADAPTIVE_ERROR_RATIO, 0.99) if adaptive else target
    chosen = choose_settings(dict(n=10 ** 9, total_area=float(areas.sum()), kind=kind,
                                  albedo_max=float(rho.max()),
                                  albedo_mean=float(np.average(rho.mean(axis=1), weights=areas))),
                             uniform_target, kind=kind)
    if adaptive:
        chosen["notes"].append(f"adaptive: chosen for {uniform_target:.3g} with uniform "
                               f"density (adaptive error ratio {ADAPTIVE_ERROR_RATIO})")
        chosen["target_error"] = target
    kw = solve_keywords(chosen)
    kw.update(overrides)
    if count is None:
        count = int(chosen["n"])
    elif int(count) < 1:
        raise InputError(f"count: expected at least 1 sample, got {count}")
    count = int(count)
    rng = np.random.default_rng(seed)
    passes = []

    def run(samples):
        surfels, mask = _mesh_surfels(samples, rho, emit, keep)
        t0 = time.perf_counter()
        sol = _solve(surfels, progress=progress, **kw)
        passes.append(dict(surfels=surfels.n, iterations=int(sol.iterations),
                           seconds=time.perf_counter() - t0))
        return sol, surfels, mask

    if not adaptive:
        sol, surfels, _ = run(sampling.sample_triangles(c, count, rng))
    else:
        first_count = max(int(ADAPTIVE_FIRST_SHARE * count), 1)
        first = sampling.sample_triangles(c, first_count, rng)
        sol1, s1, mask = run(first)
        t0 = time.perf_counter()
        pts = np.ascontiguousarray(s1.positions)
        luminance = sol1.radiosity @ np.array([0.2126, 0.7152, 0.0722])
        k = min(ADAPTIVE_NEIGHBOURS + 1, s1.n)
        idx, _ = _core.knn(pts, pts, k)
        variation = sampling.local_variation(luminance, np.asarray(idx)[:, 1:])
        regions = sampling.Regions.build(c, ADAPTIVE_SURFELS_PER_REGION * areas.sum() / s1.n)
        located = regions.locate(first.triangle[mask], first.bary[mask])
        # regions too small to hold a pass-1 surfel take the variation of the nearest one
        nearest, _ = _core.knn(pts, np.ascontiguousarray(regions.corners.mean(axis=1)), 1)
        weights = sampling.density_multipliers(located, variation, regions.count,
                                               max_ratio=ADAPTIVE_MAX_RATIO,
                                               fill=variation[np.asarray(nearest)[:, 0]])
        second = sampling.sample_triangles(regions.corners, count, rng, weights=weights)
        second.triangle, second.bary = regions.to_parent(second.triangle, second.bary)
        refine_seconds = time.perf_counter() - t0
        sol, surfels, _ = run(second)
        passes[-1]["refinement_seconds"] = refine_seconds
    info = dict(settings=chosen, solve_keywords=kw, adaptive=bool(adaptive), passes=passes)
    if estimate:
        info["estimate"] = estimate_error(
            sol, surfels, settings=chosen, kind=kind,
            discretization_scale=ADAPTIVE_ERROR_RATIO if adaptive else 1.0)
    sol.stats["accuracy"] = info
    return sol, surfels
