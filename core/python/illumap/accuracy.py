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
against N, both interpolated log-log. Beyond the measured sizes time follows its fitted slope;
an error only in its discretization part, which falls as the kind's direct curve does, while
what the setting adds there is held (a node-pair visibility model converges far slower).
An error curve holds everything the setting does: density, expansion, visibility model
(the FMM classifies node pairs as visible / hidden / partial from sampled rays, which blurs
shadows at large θ) and the solver at its tolerance. For each candidate setting the model gives
the N that meets ``SAFETY`` × target and the time it takes there; the cheapest wins.

Leaf size: each FMM setting was swept with leaves of 32 surfels; bench/leaf_size.py solves the
same surfels with leaves of 16 and 64 right after, and each setting's ``leaf_variants`` keep the
worst paired error ratio (``error_factor``, credited below 1 only at the sizes measured) and the
paired time ratios against N. A variant is a candidate like any setting: smaller leaves move
node pairs from the near field (per-pair visibility) to the classified far field, larger ones
the other way, so the leaf size trades error against time differently per scene and size.

Sampling: the curves are of the calibration's samplings; another sampling of the same scene
at the same N and settings lands elsewhere (up to 1.25× on a mesh, more on random surfels).
Each kind's ``sampling`` factor (bench/sampling_spread.py: errors of a near-exact setting on six
further samplings over the model, fitted by bench/calibrate.py to exp(mean + SAMPLING_Z·sd) of
their log ratios per size, never below 1) scales the discretization part of its predictions
(what moves between samplings; expansion and visibility-model errors stay), so that a target
holds for the user's sampling, not just for ours. Grids are deterministic and have none.

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

import bisect
import copy
import math
import time

import numpy as np

from .operator import DEFAULT_LEAF_SIZE, VISIBILITY_DEFAULTS, TransportOperator
from .solver import MAX_BOUND_ALBEDO
from .surfels import InputError, Surfels

__all__ = ["choose_settings", "choose_mesh_settings", "solve_keywords", "estimate_error", "solve",
           "solve_triangles", "scene_summary", "occlusion_probe", "visibility_keywords",
           "adaptive_time_ratio",
           "CALIBRATION", "FMM_ERROR", "EXACT_KEYWORDS", "PRESETS", "KINDS"]

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
#: The automatic mode's probe first runs on this share of PROBE_SURFELS and stops there when it
#: measures visibility="none" at PROBE_DECISIVE x the target or more (no setting without
#: visibility can then meet it), at about half the cost. On 100 surfels it measured 0.11-1.66x
#: the 200-surfel value (five samplings each of the bunny, the Cornell box, its triangles and
#: the room): stopping wrongly would take an overestimate by more than 2x.
PROBE_FIRST_SHARE = 0.5
PROBE_DECISIVE = 2.0
PROBE_WORTH = 0.25   # s
PROBE_GAIN = 0.67
#: The settings are chosen to meet SAFETY × target by the models (scenes that differ from the
#: calibration ones; the spread between samplings is the kinds' sampling factors).
SAFETY = 0.95
#: The sampling factor's quantile: exp(mean + SAMPLING_Z·sd) of the log error ratios (about
#: the 98th percentile of a log-normal spread), fitted by bench/calibrate.py.
SAMPLING_Z = 2.0
#: The solve stops once its own error estimate (``illumap.solve``'s ``error_tol``: the bounce
#: gain times the residual over the radiosity, RMS over the non-emitting surfels) is within
#: this share of the target, or at the calibrated ``tol``, whichever comes first. It spares
#: the iterations that a residual relative to the emission (a small bright light dominates
#: it) asks for beyond what the target needs. The result then keeps 0.13-0.86 of the estimate
#: (bench/solver_estimate.py: the benchmark scenes at their targets and the Cornell box at
#: albedo 0.95, 1 to 6 CG steps, errors ≥ 5e-4; the solve closes with the Jacobi step its
#: last residual holds, which multiplies the error by ρ∘K), so at most 0.2 of the target.
SOLVER_ERROR_SHARE = 0.2
#: The error a solve keeps over its estimate, at most, where the estimate is large: a closed
#: box lit by four surfels, the first two or three steps of CG or GMRES, whose iterates' bounce
#: gain is still growing (1.30-1.54; tests/core/test_solver.py). Below 3% the estimate held
#: everywhere measured. The a-posteriori estimate's solver part is the estimate times this,
#: at most the bound.
SOLVER_ESTIMATE_MARGIN = 1.6
#: Fewest surfels recommended per kind when the calibration has none (small lights and
#: occluders are not resolved below it).
DEFAULT_N_MIN = 250

# --- calibration (generated by bench/calibrate.py; do not edit by hand) ---
CALIBRATION = {
    'source': 'bench/results/accuracy_speed.json',
    'date': '2026-12-02 07:09 UTC',
    'mode': 'full',
    'core_commit': '2c7323d',
    'solve_tol': 0.0001,
    'time_holdout': {'settings': 100, 'mean': -0.166, 'rms': 0.417},
    'leaf_source': {'date': '2026-12-02 07:15 UTC', 'core_commit': '2c7323d'},
    'sampling_source': {'date': '2026-12-02 07:33 UTC', 'core_commit': '2c7323d'},
    'grid_steps_source': {'date': '2026-12-02 17:59 UTC', 'core_commit': '60ab6a4', 'cells': [9, 26]},
    'kinds': {
        'grid': {
            'scene': 'cornell',
            'n_min': 506,
            'reference_check': 0.005023,
            'discretization': 'direct vis=exact',
            'sweep': {'date': '2026-11-22 14:35 UTC', 'core_commit': '457db45'},
            'settings': {
                'direct vis=none': {'keywords': {'method': 'direct', 'visibility': 'none'}, 'error': {'points': [[506, 0.4249], [608, 0.4249], [718, 0.4249], [905, 0.4249], [1036, 0.4249], [1171, 0.4249], [1349, 0.4249], [1560, 0.4249], [1746, 0.4249], [1927, 0.4249], [2222, 0.4249], [2437, 0.4249], [2634, 0.4249], [2987, 0.4249], [3233, 0.4249], [3471, 0.4249], [3770, 0.4249], [4128, 0.4098], [8295, 0.4005]], 'slope': 0.05}, 'cost': {'points': [[506, 0.0063], [608, 0.006969], [718, 0.008267], [905, 0.0105], [1036, 0.01197], [1171, 0.01197], [1349, 0.02012], [1560, 0.02015], [1746, 0.02015], [1927, 0.03779], [2222, 0.03945], [2437, 0.04248], [2634, 0.04248], [2987, 0.04661], [3233, 0.05751], [3471, 0.05751], [3770, 0.06635], [4128, 0.09004], [8295, 0.3497]], 'slope': 1.944}, 'n_range': [506, 8295]},
                'FMM p=0 vis=none': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4441], [608, 0.4441], [718, 0.4441], [905, 0.4441], [1036, 0.4441], [1171, 0.4441], [1349, 0.4441], [1560, 0.4441], [1746, 0.4441], [1927, 0.4441], [2222, 0.4441], [2437, 0.4441], [2634, 0.4441], [2987, 0.4441], [3233, 0.4441], [3471, 0.4441], [3770, 0.4435], [4128, 0.4435], [8295, 0.4205], [12236, 0.4205]], 'slope': 0.05}, 'cost': {'points': [[506, 0.01018], [608, 0.01117], [718, 0.01117], [905, 0.01218], [1036, 0.01218], [1171, 0.01218], [1349, 0.01487], [1560, 0.01487], [1746, 0.01487], [1927, 0.02075], [2222, 0.02149], [2437, 0.02149], [2634, 0.02149], [2987, 0.02149], [3233, 0.02149], [3471, 0.02149], [3770, 0.02298], [4128, 0.03266], [8295, 0.06561], [12236, 0.07536]], 'slope': 1.0}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 2.74, 'n_range': [506, 8295], 'time_ratio': [[506, 1.03], [1036, 0.942], [1927, 1.05], [4128, 1.13], [8295, 0.92]]}, '64': {'error_factor': 1.0, 'n_range': [506, 8295], 'time_ratio': [[506, 1.15], [1036, 1.04], [1927, 1.03], [4128, 1.61], [8295, 1.14]]}}},
                'FMM p=2 vis=none': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.434], [608, 0.434], [718, 0.434], [905, 0.434], [1036, 0.434], [1171, 0.434], [1349, 0.434], [1560, 0.434], [1746, 0.434], [1927, 0.434], [2222, 0.434], [2437, 0.434], [2634, 0.434], [2987, 0.434], [3233, 0.434], [3471, 0.434], [3770, 0.434], [4128, 0.4153], [8295, 0.4121], [12236, 0.4121]], 'slope': 0.05}, 'cost': {'points': [[506, 0.01193], [608, 0.01277], [718, 0.01277], [905, 0.01415], [1036, 0.01415], [1171, 0.01415], [1349, 0.01812], [1560, 0.01812], [1746, 0.01812], [1927, 0.02483], [2222, 0.02848], [2437, 0.02848], [2634, 0.02959], [2987, 0.02959], [3233, 0.02959], [3471, 0.02959], [3770, 0.03986], [4128, 0.04656], [8295, 0.08202], [12236, 0.1293]], 'slope': 1.172}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.59, 'n_range': [506, 8295], 'time_ratio': [[506, 1.08], [1036, 0.909], [1927, 1.08], [4128, 1.29], [8295, 1.31]]}, '64': {'error_factor': 1.01, 'n_range': [506, 8295], 'time_ratio': [[506, 0.944], [1036, 0.996], [1927, 0.891], [4128, 1.05], [8295, 0.942]]}}},
                'FMM p=3 vis=none': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4246], [608, 0.4246], [718, 0.4246], [905, 0.4246], [1036, 0.4246], [1171, 0.4246], [1349, 0.4246], [1560, 0.4246], [1746, 0.4246], [1927, 0.4246], [2222, 0.4246], [2437, 0.4246], [2634, 0.4246], [2987, 0.4246], [3233, 0.4246], [3471, 0.4246], [3770, 0.4246], [4128, 0.4093], [8295, 0.404], [12236, 0.404]], 'slope': 0.05}, 'cost': {'points': [[506, 0.01031], [608, 0.01293], [718, 0.01554], [905, 0.01733], [1036, 0.01761], [1171, 0.01761], [1349, 0.02237], [1560, 0.02324], [1746, 0.02324], [1927, 0.02399], [2222, 0.03575], [2437, 0.03575], [2634, 0.03769], [2987, 0.03769], [3233, 0.03769], [3471, 0.03889], [3770, 0.04372], [4128, 0.06623], [8295, 0.1151], [12236, 0.1849]], 'slope': 1.22}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.64, 'n_range': [506, 8295], 'time_ratio': [[506, 1.36], [1036, 1.39], [1927, 1.37], [4128, 1.23], [8295, 1.38]]}, '64': {'error_factor': 1.0, 'n_range': [506, 8295], 'time_ratio': [[506, 1.01], [1036, 0.848], [1927, 1.3], [4128, 0.996], [8295, 0.925]]}}},
                'FMM p=4 vis=none': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4246], [608, 0.4246], [718, 0.4246], [905, 0.4246], [1036, 0.4246], [1171, 0.4246], [1349, 0.4246], [1560, 0.4246], [1746, 0.4246], [1927, 0.4246], [2222, 0.4246], [2437, 0.4246], [2634, 0.4246], [2987, 0.4246], [3233, 0.4246], [3471, 0.4246], [3770, 0.4246], [4128, 0.4098], [8295, 0.4039], [12236, 0.4039]], 'slope': 0.05}, 'cost': {'points': [[506, 0.01143], [608, 0.01419], [718, 0.01701], [905, 0.02282], [1036, 0.02282], [1171, 0.02282], [1349, 0.02795], [1560, 0.02815], [1746, 0.02815], [1927, 0.03092], [2222, 0.04377], [2437, 0.04377], [2634, 0.04377], [2987, 0.05679], [3233, 0.05679], [3471, 0.0573], [3770, 0.06491], [4128, 0.07612], [8295, 0.1708], [12236, 0.2911]], 'slope': 1.372}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.51, 'n_range': [506, 8295], 'time_ratio': [[506, 1.55], [1036, 1.09], [1927, 1.35], [4128, 1.05], [8295, 1.49]]}, '64': {'error_factor': 1.0, 'n_range': [506, 8295], 'time_ratio': [[506, 1.03], [1036, 0.666], [1927, 1.26], [4128, 0.677], [8295, 0.956]]}}},
                'FMM p=6 vis=none': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4245], [608, 0.4245], [718, 0.4245], [905, 0.4245], [1036, 0.4245], [1171, 0.4245], [1349, 0.4245], [1560, 0.4196], [1746, 0.4196], [1927, 0.4196]], 'slope': 0.05}, 'cost': {'points': [[506, 0.01376], [608, 0.01993], [718, 0.02291], [905, 0.04953], [1036, 0.04953], [1171, 0.04953], [1349, 0.0592], [1560, 0.0592], [1746, 0.0592], [1927, 0.07921]], 'slope': 2.5}, 'n_range': [506, 1927]},
                'FMM p=8 vis=none': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[506, 0.4245], [608, 0.4245], [718, 0.4245], [905, 0.4245], [1036, 0.4245], [1171, 0.4245], [1349, 0.4245], [1560, 0.4197], [1746, 0.4197], [1927, 0.4197]], 'slope': 0.05}, 'cost': {'points': [[506, 0.02127], [608, 0.02737], [718, 0.04144], [905, 0.1247], [1036, 0.1247], [1171, 0.1278], [1349, 0.1524], [1560, 0.1524], [1746, 0.1524], [1927, 0.1556]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'direct vis=seed': {'keywords': {'method': 'direct', 'visibility': 'seed'}, 'error': {'points': [[506, 0.1891], [608, 0.1851], [718, 0.1851], [905, 0.1539], [1036, 0.1508], [1171, 0.1414], [1349, 0.1267], [1560, 0.1173], [1746, 0.1151], [1927, 0.1151]], 'slope': 0.4273}, 'cost': {'points': [[506, 0.06304], [608, 0.1013], [718, 0.1341], [905, 0.1823], [1036, 0.2329], [1171, 0.3089], [1349, 0.4249], [1560, 0.6668], [1746, 0.768], [1927, 0.9063]], 'slope': 1.679}, 'n_range': [506, 1927]},
                'FMM p=0 vis=seed': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.2106], [608, 0.2106], [718, 0.2106], [905, 0.2106], [1036, 0.2106], [1171, 0.1938], [1349, 0.1938], [1560, 0.1887], [1746, 0.1887], [1927, 0.1887], [2222, 0.1887], [2437, 0.1887], [2634, 0.1887], [2987, 0.1887], [3233, 0.1887], [3471, 0.1887], [3770, 0.1887], [4128, 0.1887]], 'slope': 0.05}, 'cost': {'points': [[506, 0.03837], [608, 0.05172], [718, 0.05172], [905, 0.05172], [1036, 0.05473], [1171, 0.05473], [1349, 0.06175], [1560, 0.06567], [1746, 0.06774], [1927, 0.06774], [2222, 0.1031], [2437, 0.1063], [2634, 0.1063], [2987, 0.119], [3233, 0.1302], [3471, 0.1353], [3770, 0.1478], [4128, 0.1767]], 'slope': 1.97}, 'n_range': [506, 4128]},
                'FMM p=2 vis=seed': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.187], [608, 0.1741], [718, 0.1741], [905, 0.1741], [1036, 0.1741], [1171, 0.1557], [1349, 0.1459], [1560, 0.1452], [1746, 0.14], [1927, 0.14], [2222, 0.1316], [2437, 0.1316], [2634, 0.1316], [2987, 0.1316], [3233, 0.1093], [3471, 0.1024], [3770, 0.1024], [4128, 0.09254]], 'slope': 0.292}, 'cost': {'points': [[506, 0.03949], [608, 0.05116], [718, 0.05116], [905, 0.05116], [1036, 0.05116], [1171, 0.06201], [1349, 0.06817], [1560, 0.06817], [1746, 0.06817], [1927, 0.07174], [2222, 0.1091], [2437, 0.1092], [2634, 0.1145], [2987, 0.1243], [3233, 0.1399], [3471, 0.1481], [3770, 0.1656], [4128, 0.2072]], 'slope': 2.472}, 'n_range': [506, 4128]},
                'FMM p=3 vis=seed': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.1896], [608, 0.1763], [718, 0.1763], [905, 0.1763], [1036, 0.1763], [1171, 0.1568], [1349, 0.1476], [1560, 0.1464], [1746, 0.1406], [1927, 0.1406], [2222, 0.1323], [2437, 0.1323], [2634, 0.1323], [2987, 0.1323], [3233, 0.1097], [3471, 0.1025], [3770, 0.1025], [4128, 0.09101]], 'slope': 0.2971}, 'cost': {'points': [[506, 0.03942], [608, 0.05471], [718, 0.05471], [905, 0.05933], [1036, 0.06015], [1171, 0.06548], [1349, 0.07146], [1560, 0.07146], [1746, 0.07146], [1927, 0.07683], [2222, 0.1022], [2437, 0.1022], [2634, 0.1239], [2987, 0.1357], [3233, 0.178], [3471, 0.1812], [3770, 0.2137], [4128, 0.2376]], 'slope': 1.168}, 'n_range': [506, 4128]},
                'FMM p=4 vis=seed': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.19], [608, 0.1762], [718, 0.1762], [905, 0.1762], [1036, 0.1762], [1171, 0.1566], [1349, 0.1476], [1560, 0.1462], [1746, 0.1404], [1927, 0.1404], [2222, 0.1322], [2437, 0.1322], [2634, 0.1322], [2987, 0.1322], [3233, 0.1095], [3471, 0.1024], [3770, 0.1024], [4128, 0.09072]], 'slope': 0.2986}, 'cost': {'points': [[506, 0.03955], [608, 0.05639], [718, 0.05639], [905, 0.06625], [1036, 0.06625], [1171, 0.0709], [1349, 0.08087], [1560, 0.08087], [1746, 0.08087], [1927, 0.08767], [2222, 0.1221], [2437, 0.1361], [2634, 0.1374], [2987, 0.1591], [3233, 0.2082], [3471, 0.2082], [3770, 0.2665], [4128, 0.287]], 'slope': 1.0}, 'n_range': [506, 4128]},
                'FMM p=6 vis=seed': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.1895], [608, 0.1762], [718, 0.1762], [905, 0.1762], [1036, 0.1762], [1171, 0.1566], [1349, 0.1475], [1560, 0.1461], [1746, 0.1405], [1927, 0.1405]], 'slope': 0.2159}, 'cost': {'points': [[506, 0.04301], [608, 0.06401], [718, 0.06832], [905, 0.09885], [1036, 0.1059], [1171, 0.1323], [1349, 0.1442], [1560, 0.1442], [1746, 0.1442], [1927, 0.1551]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'FMM p=8 vis=seed': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[506, 0.1896], [608, 0.1761], [718, 0.1761], [905, 0.1761], [1036, 0.1761], [1171, 0.1566], [1349, 0.1475], [1560, 0.1461], [1746, 0.1405], [1927, 0.1405]], 'slope': 0.216}, 'cost': {'points': [[506, 0.05047], [608, 0.07377], [718, 0.09415], [905, 0.1765], [1036, 0.2345], [1171, 0.2404], [1349, 0.2751], [1560, 0.2751], [1746, 0.2751], [1927, 0.2812]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'direct vis=exact': {'keywords': {'method': 'direct', 'visibility': 'exact'}, 'error': {'points': [[506, 0.07275], [608, 0.07275], [718, 0.05924], [905, 0.05081], [1036, 0.05029], [1171, 0.04766], [1349, 0.04524], [1560, 0.03789], [1746, 0.03661], [1927, 0.03661], [2222, 0.02981], [2437, 0.02943], [2634, 0.02943], [2987, 0.02469], [3233, 0.02425], [3471, 0.02424], [3770, 0.02263], [4128, 0.02197], [8295, 0.01239], [12236, 0.01114]], 'slope': 0.6147}, 'cost': {'points': [[506, 0.01894], [608, 0.0265], [718, 0.03934], [905, 0.06112], [1036, 0.0686], [1171, 0.07831], [1349, 0.1152], [1560, 0.1632], [1746, 0.1716], [1927, 0.2208], [2222, 0.3192], [2437, 0.387], [2634, 0.5138], [2987, 0.6143], [3233, 0.7257], [3471, 0.8006], [3770, 0.8006], [4128, 1.038], [8295, 4.559], [12236, 12.35]], 'slope': 2.5}, 'n_range': [506, 12236]},
                'FMM p=0 vis=exact': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1829], [608, 0.1829], [718, 0.1829], [905, 0.1829], [1036, 0.1829], [1171, 0.1829], [1349, 0.1829], [1560, 0.1829], [1746, 0.1829], [1927, 0.1829], [2222, 0.1829], [2437, 0.1829], [2634, 0.1829], [2987, 0.1829], [3233, 0.1829], [3471, 0.1829], [3770, 0.1829], [4128, 0.1829], [8295, 0.1771], [12236, 0.1728]], 'slope': 0.05}, 'cost': {'points': [[506, 0.01961], [608, 0.01963], [718, 0.01963], [905, 0.02198], [1036, 0.02198], [1171, 0.02198], [1349, 0.02304], [1560, 0.02304], [1746, 0.02379], [1927, 0.02379], [2222, 0.02888], [2437, 0.03865], [2634, 0.03865], [2987, 0.04147], [3233, 0.04147], [3471, 0.04147], [3770, 0.04806], [4128, 0.05517], [8295, 0.09932], [12236, 0.1745]], 'slope': 1.45}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.48, 'n_range': [506, 12236], 'time_ratio': [[506, 0.884], [1036, 0.922], [1927, 1.32], [4128, 1.11], [8295, 1.49], [12236, 1.44]]}, '64': {'error_factor': 1.0, 'n_range': [506, 12236], 'time_ratio': [[506, 0.979], [1036, 2.15], [1927, 1.01], [4128, 1.26], [8295, 0.745], [12236, 0.873]]}}},
                'FMM p=2 vis=exact': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1353], [608, 0.1353], [718, 0.1353], [905, 0.1353], [1036, 0.1353], [1171, 0.1153], [1349, 0.1153], [1560, 0.1153], [1746, 0.1153], [1927, 0.1138], [2222, 0.11], [2437, 0.11], [2634, 0.1044], [2987, 0.1044], [3233, 0.08569], [3471, 0.07933], [3770, 0.07933], [4128, 0.07215], [8295, 0.06659], [12236, 0.06585]], 'slope': 0.1803}, 'cost': {'points': [[506, 0.01851], [608, 0.01957], [718, 0.02136], [905, 0.02136], [1036, 0.02518], [1171, 0.02518], [1349, 0.02723], [1560, 0.02723], [1746, 0.02723], [1927, 0.02723], [2222, 0.03841], [2437, 0.04983], [2634, 0.04983], [2987, 0.05355], [3233, 0.05537], [3471, 0.05537], [3770, 0.07305], [4128, 0.08062], [8295, 0.1493], [12236, 0.2425]], 'slope': 1.248}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.22, 'n_range': [506, 12236], 'time_ratio': [[506, 0.979], [1036, 0.961], [1927, 1.48], [4128, 1.16], [8295, 2.15], [12236, 1.52]]}, '64': {'error_factor': 1.65, 'n_range': [506, 12236], 'time_ratio': [[506, 1.06], [1036, 2.03], [1927, 1.54], [4128, 0.969], [8295, 0.812], [12236, 0.741]]}}},
                'FMM p=3 vis=exact': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1368], [608, 0.1368], [718, 0.1368], [905, 0.1368], [1036, 0.1368], [1171, 0.1153], [1349, 0.1153], [1560, 0.1153], [1746, 0.1153], [1927, 0.1135], [2222, 0.1096], [2437, 0.1096], [2634, 0.1049], [2987, 0.1049], [3233, 0.08511], [3471, 0.07851], [3770, 0.07851], [4128, 0.06962], [8295, 0.06598], [12236, 0.06411]], 'slope': 0.1931}, 'cost': {'points': [[506, 0.01765], [608, 0.01798], [718, 0.0243], [905, 0.02787], [1036, 0.02787], [1171, 0.03022], [1349, 0.03211], [1560, 0.03211], [1746, 0.03211], [1927, 0.03284], [2222, 0.0532], [2437, 0.05551], [2634, 0.06049], [2987, 0.0635], [3233, 0.0774], [3471, 0.0774], [3770, 0.1128], [4128, 0.1131], [8295, 0.1771], [12236, 0.3477]], 'slope': 1.735}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.2, 'n_range': [506, 12236], 'time_ratio': [[506, 1.18], [1036, 0.821], [1927, 1.63], [4128, 1.11], [8295, 2.14], [12236, 1.57]]}, '64': {'error_factor': 1.73, 'n_range': [506, 12236], 'time_ratio': [[506, 1.16], [1036, 1.39], [1927, 1.45], [4128, 0.928], [8295, 1.02], [12236, 0.742]]}}},
                'FMM p=4 vis=exact': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1366], [608, 0.1366], [718, 0.1366], [905, 0.1366], [1036, 0.1366], [1171, 0.1153], [1349, 0.1153], [1560, 0.1153], [1746, 0.1153], [1927, 0.1135], [2222, 0.1098], [2437, 0.1098], [2634, 0.1047], [2987, 0.1047], [3233, 0.085], [3471, 0.07833], [3770, 0.07833], [4128, 0.06936], [8295, 0.06575], [12236, 0.06402]], 'slope': 0.1957}, 'cost': {'points': [[506, 0.01864], [608, 0.01902], [718, 0.02286], [905, 0.03484], [1036, 0.03484], [1171, 0.04251], [1349, 0.04251], [1560, 0.04251], [1746, 0.04251], [1927, 0.04251], [2222, 0.06497], [2437, 0.07195], [2634, 0.07919], [2987, 0.09345], [3233, 0.1309], [3471, 0.1387], [3770, 0.1785], [4128, 0.1785], [8295, 0.2657], [12236, 0.5415]], 'slope': 1.832}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.19, 'n_range': [506, 12236], 'time_ratio': [[506, 1.44], [1036, 1.05], [1927, 2.11], [4128, 1.42], [8295, 2.95], [12236, 1.89]]}, '64': {'error_factor': 1.74, 'n_range': [506, 12236], 'time_ratio': [[506, 1.02], [1036, 1.38], [1927, 1.13], [4128, 0.591], [8295, 1.09], [12236, 0.587]]}}},
                'FMM p=6 vis=exact': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1365], [608, 0.1365], [718, 0.1365], [905, 0.1365], [1036, 0.1365], [1171, 0.1152], [1349, 0.1152], [1560, 0.1152], [1746, 0.1152], [1927, 0.1135]], 'slope': 0.05}, 'cost': {'points': [[506, 0.02003], [608, 0.02416], [718, 0.03573], [905, 0.06313], [1036, 0.09015], [1171, 0.09425], [1349, 0.09451], [1560, 0.09451], [1746, 0.09451], [1927, 0.09451]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'FMM p=8 vis=exact': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1365], [608, 0.1365], [718, 0.1365], [905, 0.1365], [1036, 0.1365], [1171, 0.1152], [1349, 0.1152], [1560, 0.1152], [1746, 0.1152], [1927, 0.1135]], 'slope': 0.05}, 'cost': {'points': [[506, 0.02793], [608, 0.03545], [718, 0.06738], [905, 0.1589], [1036, 0.2046], [1171, 0.2284], [1349, 0.2284], [1560, 0.2284], [1746, 0.2284], [1927, 0.2284]], 'slope': 1.0}, 'n_range': [506, 1927]},
                'FMM p=2 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1222], [608, 0.1222], [718, 0.1222], [905, 0.1222], [1036, 0.1222], [1171, 0.1142], [1349, 0.1056], [1560, 0.1056], [1746, 0.1056], [1927, 0.1056], [2222, 0.09537], [2437, 0.09537], [2634, 0.09537], [2987, 0.0883], [3233, 0.07803], [3471, 0.07112], [3770, 0.07045], [4128, 0.06029], [8295, 0.05536], [12236, 0.04663]], 'slope': 0.1437}, 'cost': {'points': [[506, 0.02021], [608, 0.0234], [718, 0.0234], [905, 0.02656], [1036, 0.0286], [1171, 0.0343], [1349, 0.04078], [1560, 0.04473], [1746, 0.04473], [1927, 0.04655], [2222, 0.06957], [2437, 0.06957], [2634, 0.0733], [2987, 0.0733], [3233, 0.0733], [3471, 0.08469], [3770, 0.119], [4128, 0.1221], [8295, 0.2119], [12236, 0.3942]], 'slope': 1.597}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.28, 'n_range': [506, 12236], 'time_ratio': [[506, 0.856], [1036, 0.965], [1927, 1.31], [4128, 0.938], [8295, 1.91], [12236, 1.43]]}, '64': {'error_factor': 1.47, 'n_range': [506, 12236], 'time_ratio': [[506, 0.946], [1036, 1.6], [1927, 1.16], [4128, 1.56], [8295, 1.11], [12236, 0.964]]}}},
                'FMM p=3 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1224], [608, 0.1224], [718, 0.1224], [905, 0.1224], [1036, 0.1224], [1171, 0.1143], [1349, 0.1059], [1560, 0.1059], [1746, 0.1059], [1927, 0.1059], [2222, 0.09549], [2437, 0.09549], [2634, 0.09549], [2987, 0.08849], [3233, 0.07808], [3471, 0.07107], [3770, 0.0705], [4128, 0.0602], [8295, 0.0554], [12236, 0.04668]], 'slope': 0.1437}, 'cost': {'points': [[506, 0.01988], [608, 0.02229], [718, 0.02736], [905, 0.02736], [1036, 0.03068], [1171, 0.04074], [1349, 0.04524], [1560, 0.0493], [1746, 0.0493], [1927, 0.0493], [2222, 0.06892], [2437, 0.08021], [2634, 0.09273], [2987, 0.09854], [3233, 0.09856], [3471, 0.1198], [3770, 0.1456], [4128, 0.1475], [8295, 0.2949], [12236, 0.5463]], 'slope': 1.586}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.28, 'n_range': [506, 12236], 'time_ratio': [[506, 1.1], [1036, 0.981], [1927, 1.66], [4128, 1.01], [8295, 2.05], [12236, 1.68]]}, '64': {'error_factor': 1.47, 'n_range': [506, 12236], 'time_ratio': [[506, 0.895], [1036, 1.46], [1927, 1.11], [4128, 1.27], [8295, 0.92], [12236, 0.877]]}}},
                'FMM p=4 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[506, 0.1223], [608, 0.1223], [718, 0.1223], [905, 0.1223], [1036, 0.1223], [1171, 0.1143], [1349, 0.1058], [1560, 0.1058], [1746, 0.1058], [1927, 0.1058], [2222, 0.09544], [2437, 0.09544], [2634, 0.09544], [2987, 0.08843], [3233, 0.07805], [3471, 0.07103], [3770, 0.07047], [4128, 0.06017], [8295, 0.05539], [12236, 0.04667]], 'slope': 0.1438}, 'cost': {'points': [[506, 0.01821], [608, 0.02442], [718, 0.02898], [905, 0.03115], [1036, 0.04511], [1171, 0.04729], [1349, 0.05392], [1560, 0.05392], [1746, 0.05392], [1927, 0.05392], [2222, 0.0843], [2437, 0.0981], [2634, 0.1015], [2987, 0.143], [3233, 0.143], [3471, 0.1966], [3770, 0.24], [4128, 0.2543], [8295, 0.41], [12236, 0.8321]], 'slope': 1.821}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.28, 'n_range': [506, 12236], 'time_ratio': [[506, 1.24], [1036, 1.0], [1927, 2.09], [4128, 1.37], [8295, 2.65], [12236, 1.84]]}, '64': {'error_factor': 1.47, 'n_range': [506, 12236], 'time_ratio': [[506, 1.09], [1036, 1.19], [1927, 1.19], [4128, 1.02], [8295, 0.97], [12236, 0.66]]}}},
                'FMM p=2 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[506, 0.07452], [608, 0.07367], [718, 0.07251], [905, 0.07251], [1036, 0.07251], [1171, 0.06797], [1349, 0.06797], [1560, 0.06797], [1746, 0.06797], [1927, 0.06797], [2222, 0.06797], [2437, 0.06797], [2634, 0.06797], [2987, 0.06797], [3233, 0.06797], [3471, 0.06797], [3770, 0.06797], [4128, 0.05866], [8295, 0.05177], [12236, 0.04289]], 'slope': 0.1152}, 'cost': {'points': [[506, 0.01947], [608, 0.02346], [718, 0.02703], [905, 0.02703], [1036, 0.03747], [1171, 0.03951], [1349, 0.05161], [1560, 0.05759], [1746, 0.06235], [1927, 0.0759], [2222, 0.08822], [2437, 0.1162], [2634, 0.1162], [2987, 0.1162], [3233, 0.1162], [3471, 0.1449], [3770, 0.1596], [4128, 0.1857], [8295, 0.3966], [12236, 0.6253]], 'slope': 1.172}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.39, 'n_range': [506, 12236], 'time_ratio': [[506, 1.06], [1036, 0.99], [1927, 1.07], [4128, 0.755], [8295, 1.61], [12236, 1.3]]}, '64': {'error_factor': 1.29, 'n_range': [506, 12236], 'time_ratio': [[506, 1.0], [1036, 1.28], [1927, 1.14], [4128, 1.47], [8295, 1.23], [12236, 1.07]]}}},
                'FMM p=3 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[506, 0.07452], [608, 0.07367], [718, 0.07253], [905, 0.07253], [1036, 0.07253], [1171, 0.06801], [1349, 0.06801], [1560, 0.06801], [1746, 0.06801], [1927, 0.06801], [2222, 0.06801], [2437, 0.06801], [2634, 0.06801], [2987, 0.06801], [3233, 0.06801], [3471, 0.06801], [3770, 0.06801], [4128, 0.05868], [8295, 0.05178], [12236, 0.04287]], 'slope': 0.1151}, 'cost': {'points': [[506, 0.01723], [608, 0.02396], [718, 0.02476], [905, 0.02709], [1036, 0.03649], [1171, 0.04309], [1349, 0.05619], [1560, 0.05888], [1746, 0.06445], [1927, 0.07823], [2222, 0.1001], [2437, 0.1177], [2634, 0.132], [2987, 0.1321], [3233, 0.1381], [3471, 0.2028], [3770, 0.21], [4128, 0.2309], [8295, 0.5046], [12236, 0.7804]], 'slope': 1.122}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.4, 'n_range': [506, 12236], 'time_ratio': [[506, 0.885], [1036, 0.969], [1927, 1.59], [4128, 1.02], [8295, 2.56], [12236, 1.47]]}, '64': {'error_factor': 1.29, 'n_range': [506, 12236], 'time_ratio': [[506, 1.0], [1036, 1.24], [1927, 1.01], [4128, 1.35], [8295, 1.28], [12236, 0.948]]}}},
                'FMM p=4 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[506, 0.07452], [608, 0.07367], [718, 0.07253], [905, 0.07253], [1036, 0.07253], [1171, 0.068], [1349, 0.068], [1560, 0.068], [1746, 0.068], [1927, 0.068], [2222, 0.068], [2437, 0.068], [2634, 0.068], [2987, 0.068], [3233, 0.068], [3471, 0.068], [3770, 0.068], [4128, 0.05867], [8295, 0.05178], [12236, 0.04288]], 'slope': 0.1152}, 'cost': {'points': [[506, 0.0181], [608, 0.02418], [718, 0.02503], [905, 0.02874], [1036, 0.03792], [1171, 0.04774], [1349, 0.05977], [1560, 0.06153], [1746, 0.06153], [1927, 0.08044], [2222, 0.1025], [2437, 0.1199], [2634, 0.1324], [2987, 0.1591], [3233, 0.1715], [3471, 0.2755], [3770, 0.311], [4128, 0.311], [8295, 0.6656], [12236, 1.521]], 'slope': 2.126}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.39, 'n_range': [506, 12236], 'time_ratio': [[506, 1.26], [1036, 1.0], [1927, 1.82], [4128, 1.12], [8295, 2.91], [12236, 1.92]]}, '64': {'error_factor': 1.29, 'n_range': [506, 12236], 'time_ratio': [[506, 0.976], [1036, 1.18], [1927, 1.19], [4128, 1.02], [8295, 1.08], [12236, 0.823]]}}},
                'FMM p=2 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[506, 0.06825], [608, 0.06825], [718, 0.06031], [905, 0.06031], [1036, 0.06031], [1171, 0.05558], [1349, 0.04663], [1560, 0.04461], [1746, 0.04461], [1927, 0.04461], [2222, 0.04299], [2437, 0.04299], [2634, 0.04299], [2987, 0.03825], [3233, 0.03602], [3471, 0.03602], [3770, 0.03602], [4128, 0.03602], [8295, 0.02509], [12236, 0.02509]], 'slope': 0.3667}, 'cost': {'points': [[506, 0.02084], [608, 0.02084], [718, 0.02656], [905, 0.02909], [1036, 0.03637], [1171, 0.03637], [1349, 0.04519], [1560, 0.05982], [1746, 0.05982], [1927, 0.07656], [2222, 0.1185], [2437, 0.1229], [2634, 0.1304], [2987, 0.1342], [3233, 0.1342], [3471, 0.1342], [3770, 0.1762], [4128, 0.2002], [8295, 0.8081], [12236, 1.443]], 'slope': 1.492}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.16, 'n_range': [506, 12236], 'time_ratio': [[506, 1.0], [1036, 1.01], [1927, 1.1], [4128, 0.655], [8295, 0.836], [12236, 0.828]]}, '64': {'error_factor': 1.41, 'n_range': [506, 12236], 'time_ratio': [[506, 1.09], [1036, 1.44], [1927, 1.14], [4128, 0.956], [8295, 0.985], [12236, 1.14]]}}},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[506, 0.0689], [608, 0.06831], [718, 0.06029], [905, 0.06029], [1036, 0.06029], [1171, 0.05515], [1349, 0.04661], [1560, 0.04385], [1746, 0.04385], [1927, 0.04385], [2222, 0.04315], [2437, 0.04315], [2634, 0.04315], [2987, 0.03751], [3233, 0.03274], [3471, 0.03274], [3770, 0.03041], [4128, 0.03041], [8295, 0.02283], [12236, 0.02283]], 'slope': 0.431}, 'cost': {'points': [[506, 0.01888], [608, 0.0258], [718, 0.02655], [905, 0.03206], [1036, 0.03783], [1171, 0.04947], [1349, 0.06159], [1560, 0.06551], [1746, 0.06807], [1927, 0.07387], [2222, 0.1173], [2437, 0.13], [2634, 0.1426], [2987, 0.1624], [3233, 0.1624], [3471, 0.1904], [3770, 0.1923], [4128, 0.1923], [8295, 0.8249], [12236, 1.476]], 'slope': 1.496}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.26, 'n_range': [506, 12236], 'time_ratio': [[506, 1.06], [1036, 1.06], [1927, 1.04], [4128, 1.05], [8295, 1.01], [12236, 0.774]]}, '64': {'error_factor': 1.66, 'n_range': [506, 12236], 'time_ratio': [[506, 0.952], [1036, 1.2], [1927, 0.792], [4128, 1.39], [8295, 0.95], [12236, 1.05]]}}},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[506, 0.06949], [608, 0.0692], [718, 0.06105], [905, 0.06105], [1036, 0.06105], [1171, 0.05013], [1349, 0.04342], [1560, 0.04047], [1746, 0.04047], [1927, 0.04047], [2222, 0.03894], [2437, 0.03894], [2634, 0.03264], [2987, 0.02702], [3233, 0.02686], [3471, 0.02686], [3770, 0.02453], [4128, 0.02226], [8295, 0.01501], [12236, 0.01444]], 'slope': 0.5442}, 'cost': {'points': [[506, 0.02], [608, 0.02671], [718, 0.02947], [905, 0.03731], [1036, 0.04541], [1171, 0.05162], [1349, 0.06982], [1560, 0.08377], [1746, 0.08377], [1927, 0.08377], [2222, 0.1235], [2437, 0.147], [2634, 0.1713], [2987, 0.1848], [3233, 0.1861], [3471, 0.1861], [3770, 0.2721], [4128, 0.2985], [8295, 1.043], [12236, 1.651]], 'slope': 1.181}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.18, 'n_range': [506, 12236], 'time_ratio': [[506, 1.14], [1036, 0.996], [1927, 1.14], [4128, 1.04], [8295, 1.15], [12236, 0.872]]}, '64': {'error_factor': 1.15, 'n_range': [506, 12236], 'time_ratio': [[506, 1.02], [1036, 1.08], [1927, 1.15], [4128, 1.28], [8295, 1.4], [12236, 1.06]]}}},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[506, 0.06892], [608, 0.06827], [718, 0.0596], [905, 0.0596], [1036, 0.0596], [1171, 0.04849], [1349, 0.04194], [1560, 0.03952], [1746, 0.03952], [1927, 0.03741], [2222, 0.03307], [2437, 0.03307], [2634, 0.03307], [2987, 0.02828], [3233, 0.02828], [3471, 0.02828], [3770, 0.02828], [4128, 0.02505], [8295, 0.01461], [12236, 0.01461]], 'slope': 0.5568}, 'cost': {'points': [[506, 0.01847], [608, 0.02128], [718, 0.02794], [905, 0.0318], [1036, 0.04152], [1171, 0.04152], [1349, 0.05232], [1560, 0.06627], [1746, 0.06627], [1927, 0.07707], [2222, 0.1175], [2437, 0.1317], [2634, 0.1459], [2987, 0.1767], [3233, 0.1838], [3471, 0.1838], [3770, 0.2324], [4128, 0.2324], [8295, 1.056], [12236, 1.757]], 'slope': 1.309}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.31, 'n_range': [506, 12236], 'time_ratio': [[506, 1.28], [1036, 0.99], [1927, 1.28], [4128, 1.03], [8295, 1.04], [12236, 1.02]]}, '64': {'error_factor': 1.41, 'n_range': [506, 12236], 'time_ratio': [[506, 0.915], [1036, 1.21], [1927, 1.05], [4128, 1.21], [8295, 0.892], [12236, 1.08]]}}},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[506, 0.06946], [608, 0.06916], [718, 0.05716], [905, 0.05499], [1036, 0.0511], [1171, 0.04772], [1349, 0.04341], [1560, 0.0393], [1746, 0.03613], [1927, 0.03499], [2222, 0.03184], [2437, 0.03184], [2634, 0.03083], [2987, 0.02672], [3233, 0.02672], [3471, 0.02672], [3770, 0.02383], [4128, 0.02218], [8295, 0.01414], [12236, 0.01414]], 'slope': 0.5648}, 'cost': {'points': [[506, 0.02186], [608, 0.0265], [718, 0.02993], [905, 0.04578], [1036, 0.04685], [1171, 0.0539], [1349, 0.07083], [1560, 0.07225], [1746, 0.08737], [1927, 0.08737], [2222, 0.1283], [2437, 0.1431], [2634, 0.1633], [2987, 0.1838], [3233, 0.2226], [3471, 0.2263], [3770, 0.3131], [4128, 0.3618], [8295, 1.229], [12236, 2.16]], 'slope': 1.451}, 'n_range': [506, 12236], 'leaf_variants': {'16': {'error_factor': 1.13, 'n_range': [506, 12236], 'time_ratio': [[506, 1.1], [1036, 1.14], [1927, 1.26], [4128, 1.03], [8295, 1.2], [12236, 1.04]]}, '64': {'error_factor': 1.09, 'n_range': [506, 12236], 'time_ratio': [[506, 1.02], [1036, 1.03], [1927, 0.894], [4128, 1.05], [8295, 1.02], [12236, 1.04]]}}},
            },
        },
        'mesh': {
            'scene': 'cornell_mesh',
            'n_min': 482,
            'reference_check': 0.005023,
            'discretization': 'direct vis=exact',
            'sweep': {'date': '2026-11-22 14:35 UTC', 'core_commit': '457db45'},
            'sampling': {'points': [[2021, 1.25], [8082, 1.23], [16162, 1.33]], 'z': 2.0, 'log_sd': 0.0872, 'samplings': 6, 'setting': 'FMM p=3 vis=exact all-pairs s=32 θ=0.5'},
            'settings': {
                'direct vis=none': {'keywords': {'method': 'direct', 'visibility': 'none'}, 'error': {'points': [[482, 0.5137], [966, 0.4074], [1926, 0.4074], [3859, 0.4074], [7718, 0.4074]], 'slope': 0.06715}, 'cost': {'points': [[482, 0.008774], [966, 0.01485], [1926, 0.03012], [3859, 0.181], [7718, 0.3831]], 'slope': 1.082}, 'n_range': [482, 7718]},
                'FMM p=0 vis=none': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5156], [966, 0.3893], [1926, 0.3893], [3859, 0.3893], [7718, 0.388], [15432, 0.3517]], 'slope': 0.07437}, 'cost': {'points': [[482, 0.0159], [966, 0.02597], [1926, 0.02597], [3859, 0.06553], [7718, 0.09454], [15432, 0.09659]], 'slope': 1.0}, 'n_range': [482, 15432], 'leaf_variants': {'16': {'error_factor': 26.5, 'n_range': [482, 7718], 'time_ratio': [[483, 1.04], [963, 1.09], [1926, 1.07], [3857, 1.06], [7715, 1.01]]}, '64': {'error_factor': 1.0, 'n_range': [482, 7718], 'time_ratio': [[483, 1.06], [963, 1.18], [1926, 0.992], [3857, 1.18], [7715, 1.16]]}}},
                'FMM p=2 vis=none': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5145], [966, 0.4171], [1926, 0.4171], [3859, 0.4171], [7718, 0.4171], [15432, 0.3843]], 'slope': 0.05316}, 'cost': {'points': [[482, 0.01691], [966, 0.02779], [1926, 0.0307], [3859, 0.1057], [7718, 0.1057], [15432, 0.1577]], 'slope': 1.0}, 'n_range': [482, 15432], 'leaf_variants': {'16': {'error_factor': 8.48, 'n_range': [482, 7718], 'time_ratio': [[483, 1.05], [963, 1.05], [1926, 1.32], [3857, 1.05], [7715, 1.34]]}, '64': {'error_factor': 1.01, 'n_range': [482, 7718], 'time_ratio': [[483, 1.03], [963, 0.966], [1926, 1.02], [3857, 0.889], [7715, 1.03]]}}},
                'FMM p=3 vis=none': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5139], [966, 0.4081], [1926, 0.4081], [3859, 0.4081], [7718, 0.4081], [15432, 0.3757]], 'slope': 0.05745}, 'cost': {'points': [[482, 0.01729], [966, 0.03007], [1926, 0.03812], [3859, 0.1402], [7718, 0.1402], [15432, 0.2424]], 'slope': 1.0}, 'n_range': [482, 15432], 'leaf_variants': {'16': {'error_factor': 7.78, 'n_range': [482, 7718], 'time_ratio': [[483, 1.45], [963, 0.894], [1926, 1.63], [3857, 0.957], [7715, 1.69]]}, '64': {'error_factor': 1.02, 'n_range': [482, 7718], 'time_ratio': [[483, 0.96], [963, 0.72], [1926, 0.935], [3857, 0.744], [7715, 0.873]]}}},
                'FMM p=4 vis=none': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5137], [966, 0.407], [1926, 0.407], [3859, 0.407], [7718, 0.407], [15432, 0.3742]], 'slope': 0.05901}, 'cost': {'points': [[482, 0.01892], [966, 0.04825], [1926, 0.04825], [3859, 0.1798], [7718, 0.1798], [15432, 0.4178]], 'slope': 1.217}, 'n_range': [482, 15432], 'leaf_variants': {'16': {'error_factor': 7.92, 'n_range': [482, 7718], 'time_ratio': [[483, 2.09], [963, 0.814], [1926, 1.88], [3857, 1.2], [7715, 1.76]]}, '64': {'error_factor': 1.02, 'n_range': [482, 7718], 'time_ratio': [[483, 1.25], [963, 0.52], [1926, 0.926], [3857, 0.611], [7715, 0.932]]}}},
                'FMM p=6 vis=none': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5137], [966, 0.3933], [1926, 0.3738]], 'slope': 0.2297}, 'cost': {'points': [[482, 0.02188], [966, 0.08203], [1926, 0.1017]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'FMM p=8 vis=none': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[482, 0.5137], [966, 0.3932], [1926, 0.3738]], 'slope': 0.2298}, 'cost': {'points': [[482, 0.02943], [966, 0.2193], [1926, 0.2622]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'direct vis=seed': {'keywords': {'method': 'direct', 'visibility': 'seed'}, 'error': {'points': [[482, 0.2817], [966, 0.2173], [1926, 0.1933]], 'slope': 0.2717}, 'cost': {'points': [[482, 0.08045], [966, 0.3018], [1926, 1.242]], 'slope': 2.05}, 'n_range': [482, 1926]},
                'FMM p=0 vis=seed': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2705], [966, 0.228], [1926, 0.208], [3859, 0.1759]], 'slope': 0.1995}, 'cost': {'points': [[482, 0.06047], [966, 0.08044], [1926, 0.136], [3859, 0.3198]], 'slope': 1.23}, 'n_range': [482, 3859]},
                'FMM p=2 vis=seed': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2705], [966, 0.1868], [1926, 0.1746], [3859, 0.1121]], 'slope': 0.3913}, 'cost': {'points': [[482, 0.05982], [966, 0.07974], [1926, 0.1486], [3859, 0.4031]], 'slope': 1.436}, 'n_range': [482, 3859]},
                'FMM p=3 vis=seed': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2706], [966, 0.1896], [1926, 0.1771], [3859, 0.1122]], 'slope': 0.3912}, 'cost': {'points': [[482, 0.06092], [966, 0.08378], [1926, 0.1514], [3859, 0.5936]], 'slope': 1.966}, 'n_range': [482, 3859]},
                'FMM p=4 vis=seed': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2706], [966, 0.1886], [1926, 0.1765], [3859, 0.1117]], 'slope': 0.3927}, 'cost': {'points': [[482, 0.06182], [966, 0.09508], [1926, 0.1449], [3859, 0.5615]], 'slope': 1.949}, 'n_range': [482, 3859]},
                'FMM p=6 vis=seed': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2706], [966, 0.1887], [1926, 0.1764]], 'slope': 0.3092}, 'cost': {'points': [[482, 0.06373], [966, 0.1719], [1926, 0.2119]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'FMM p=8 vis=seed': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[482, 0.2706], [966, 0.1887], [1926, 0.1764]], 'slope': 0.3092}, 'cost': {'points': [[482, 0.07103], [966, 0.3129], [1926, 0.3988]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'direct vis=exact': {'keywords': {'method': 'direct', 'visibility': 'exact'}, 'error': {'points': [[482, 0.2417], [966, 0.1688], [1926, 0.1149], [3859, 0.08049], [7718, 0.06113]], 'slope': 0.5035}, 'cost': {'points': [[482, 0.02425], [966, 0.08943], [1926, 0.2785], [3859, 1.483], [7718, 5.828]], 'slope': 1.974}, 'n_range': [482, 7718]},
                'FMM p=0 vis=exact': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2967], [484, 0.2967], [961, 0.2168], [966, 0.2168], [1926, 0.1941], [1927, 0.1941], [3855, 0.182], [3859, 0.1783], [7712, 0.1783], [7718, 0.1783], [15430, 0.1329], [15432, 0.1297]], 'slope': 0.1712}, 'cost': {'points': [[482, 0.02115], [966, 0.03619], [1926, 0.04781], [3859, 0.114], [7718, 0.1239], [15432, 0.3451]], 'slope': 1.479}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.19, 'n_range': [482, 15432], 'time_ratio': [[483, 0.83], [963, 0.92], [1926, 1.31], [3857, 1.0], [7715, 2.15], [15431, 0.914]]}, '64': {'error_factor': 1.07, 'n_range': [482, 15432], 'time_ratio': [[483, 1.0], [963, 2.09], [1926, 1.26], [3857, 1.17], [7715, 1.25], [15431, 0.638]]}}},
                'FMM p=2 vis=exact': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2911], [484, 0.2911], [961, 0.175], [966, 0.175], [1926, 0.14], [1927, 0.14], [3855, 0.1054], [3859, 0.1054], [7712, 0.1034], [7718, 0.1034], [15430, 0.06179], [15432, 0.06179]], 'slope': 0.3892}, 'cost': {'points': [[482, 0.02452], [966, 0.04782], [1926, 0.05225], [3859, 0.1441], [7718, 0.1563], [15432, 0.449]], 'slope': 1.523}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.05, 'n_range': [482, 15432], 'time_ratio': [[483, 1.02], [963, 0.995], [1926, 1.77], [3857, 1.07], [7715, 2.37], [15431, 1.13]]}, '64': {'error_factor': 1.19, 'n_range': [482, 15432], 'time_ratio': [[483, 0.973], [963, 1.52], [1926, 1.25], [3857, 1.05], [7715, 1.02], [15431, 0.581]]}}},
                'FMM p=3 vis=exact': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.292], [484, 0.292], [961, 0.1776], [966, 0.1776], [1926, 0.1424], [1927, 0.1424], [3855, 0.1053], [3859, 0.1053], [7712, 0.1042], [7718, 0.1042], [15430, 0.06184], [15432, 0.06184]], 'slope': 0.3901}, 'cost': {'points': [[482, 0.03091], [966, 0.05387], [1926, 0.05826], [3859, 0.1672], [7718, 0.1672], [15432, 0.924]], 'slope': 2.467}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.05, 'n_range': [482, 15432], 'time_ratio': [[483, 1.17], [963, 0.957], [1926, 1.99], [3857, 1.03], [7715, 3.64], [15431, 1.09]]}, '64': {'error_factor': 1.18, 'n_range': [482, 15432], 'time_ratio': [[483, 0.998], [963, 1.38], [1926, 1.26], [3857, 0.838], [7715, 1.05], [15431, 0.485]]}}},
                'FMM p=4 vis=exact': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2924], [484, 0.2924], [961, 0.1766], [966, 0.1766], [1926, 0.1419], [1927, 0.1419], [3855, 0.1049], [3859, 0.1049], [7712, 0.1041], [7718, 0.1041], [15430, 0.06177], [15432, 0.06177]], 'slope': 0.3903}, 'cost': {'points': [[482, 0.02764], [966, 0.06898], [1926, 0.07749], [3859, 0.2624], [7718, 0.2624], [15432, 1.395]], 'slope': 2.412}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.05, 'n_range': [482, 15432], 'time_ratio': [[483, 1.46], [963, 0.997], [1926, 2.51], [3857, 1.1], [7715, 3.29], [15431, 1.13]]}, '64': {'error_factor': 1.19, 'n_range': [482, 15432], 'time_ratio': [[483, 0.997], [963, 1.17], [1926, 1.05], [3857, 0.653], [7715, 0.853], [15431, 0.293]]}}},
                'FMM p=6 vis=exact': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2333], [966, 0.1767], [1926, 0.1344]], 'slope': 0.3984}, 'cost': {'points': [[482, 0.03002], [966, 0.1241], [1926, 0.1573]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'FMM p=8 vis=exact': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2333], [966, 0.1767], [1926, 0.1344]], 'slope': 0.3984}, 'cost': {'points': [[482, 0.03761], [966, 0.2945], [1926, 0.3426]], 'slope': 1.0}, 'n_range': [482, 1926]},
                'FMM p=2 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2959], [484, 0.2959], [961, 0.1781], [966, 0.1781], [1926, 0.1325], [1927, 0.1325], [3855, 0.1032], [3859, 0.1032], [7712, 0.0925], [7718, 0.08588], [15430, 0.04924], [15432, 0.04924]], 'slope': 0.4345}, 'cost': {'points': [[482, 0.02723], [966, 0.04469], [1926, 0.09403], [3859, 0.2751], [7718, 0.3296], [15432, 0.8178]], 'slope': 1.312}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.08, 'n_range': [482, 15432], 'time_ratio': [[483, 1.12], [963, 1.12], [1926, 1.28], [3857, 1.0], [7715, 2.1], [15431, 0.865]]}, '64': {'error_factor': 1.24, 'n_range': [482, 15432], 'time_ratio': [[483, 1.07], [963, 1.42], [1926, 1.15], [3857, 1.71], [7715, 1.26], [15431, 1.08]]}}},
                'FMM p=3 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2959], [484, 0.2959], [961, 0.1784], [966, 0.1784], [1926, 0.1327], [1927, 0.1327], [3855, 0.1033], [3859, 0.1033], [7712, 0.09262], [7718, 0.08595], [15430, 0.04923], [15432, 0.04923]], 'slope': 0.4342}, 'cost': {'points': [[482, 0.02322], [966, 0.05286], [1926, 0.09699], [3859, 0.3391], [7718, 0.4112], [15432, 1.086]], 'slope': 1.402}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.08, 'n_range': [482, 15432], 'time_ratio': [[483, 1.31], [963, 1.01], [1926, 1.58], [3857, 1.01], [7715, 2.5], [15431, 1.46]]}, '64': {'error_factor': 1.24, 'n_range': [482, 15432], 'time_ratio': [[483, 0.938], [963, 1.15], [1926, 0.961], [3857, 1.16], [7715, 1.18], [15431, 0.713]]}}},
                'FMM p=4 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2959], [484, 0.2959], [961, 0.1784], [966, 0.1784], [1926, 0.1326], [1927, 0.1326], [3855, 0.1033], [3859, 0.1033], [7712, 0.09261], [7718, 0.08594], [15430, 0.04919], [15432, 0.04919]], 'slope': 0.4343}, 'cost': {'points': [[482, 0.02721], [966, 0.05646], [1926, 0.1053], [3859, 0.5559], [7718, 0.5559], [15432, 2.046]], 'slope': 1.88}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.08, 'n_range': [482, 15432], 'time_ratio': [[483, 1.71], [963, 0.974], [1926, 2.35], [3857, 1.03], [7715, 3.09], [15431, 1.07]]}, '64': {'error_factor': 1.24, 'n_range': [482, 15432], 'time_ratio': [[483, 1.01], [963, 1.17], [1926, 1.03], [3857, 1.08], [7715, 1.47], [15431, 0.493]]}}},
                'FMM p=2 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2959], [484, 0.2959], [961, 0.1654], [966, 0.1619], [1926, 0.1235], [1927, 0.1235], [3855, 0.1036], [3859, 0.09229], [7712, 0.08749], [7718, 0.08596], [15430, 0.04589], [15432, 0.04456]], 'slope': 0.447}, 'cost': {'points': [[482, 0.03428], [966, 0.0501], [1926, 0.1235], [3859, 0.3465], [7718, 0.515], [15432, 1.413]], 'slope': 1.457}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.14, 'n_range': [482, 15432], 'time_ratio': [[483, 1.13], [963, 1.06], [1926, 1.3], [3857, 0.987], [7715, 2.49], [15431, 1.05]]}, '64': {'error_factor': 1.3, 'n_range': [482, 15432], 'time_ratio': [[483, 1.01], [963, 1.06], [1926, 0.99], [3857, 1.47], [7715, 1.63], [15431, 1.6]]}}},
                'FMM p=3 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2959], [484, 0.2959], [961, 0.1654], [966, 0.1619], [1926, 0.1235], [1927, 0.1235], [3855, 0.1037], [3859, 0.0923], [7712, 0.08751], [7718, 0.08598], [15430, 0.04592], [15432, 0.04459]], 'slope': 0.4468}, 'cost': {'points': [[482, 0.02859], [966, 0.05161], [1926, 0.1271], [3859, 0.4356], [7718, 0.5896], [15432, 1.975]], 'slope': 1.745}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.14, 'n_range': [482, 15432], 'time_ratio': [[483, 1.21], [963, 0.993], [1926, 1.64], [3857, 0.992], [7715, 2.49], [15431, 1.11]]}, '64': {'error_factor': 1.29, 'n_range': [482, 15432], 'time_ratio': [[483, 1.09], [963, 1.33], [1926, 1.04], [3857, 1.25], [7715, 1.2], [15431, 0.891]]}}},
                'FMM p=4 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[482, 0.2959], [484, 0.2959], [961, 0.1654], [966, 0.1619], [1926, 0.1235], [1927, 0.1235], [3855, 0.1036], [3859, 0.0923], [7712, 0.08751], [7718, 0.08597], [15430, 0.04592], [15432, 0.04459]], 'slope': 0.4468}, 'cost': {'points': [[482, 0.02602], [966, 0.06258], [1926, 0.1314], [3859, 0.7367], [7718, 0.7367], [15432, 3.053]], 'slope': 2.052}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.14, 'n_range': [482, 15432], 'time_ratio': [[483, 1.39], [963, 1.03], [1926, 2.37], [3857, 1.01], [7715, 2.17], [15431, 1.0]]}, '64': {'error_factor': 1.29, 'n_range': [482, 15432], 'time_ratio': [[483, 1.03], [963, 1.09], [1926, 1.08], [3857, 0.941], [7715, 1.01], [15431, 0.589]]}}},
                'FMM p=2 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[482, 0.3012], [484, 0.3012], [961, 0.1604], [966, 0.1551], [1926, 0.1161], [1927, 0.1161], [3855, 0.08783], [3859, 0.08134], [7712, 0.06419], [7718, 0.06246], [15430, 0.04204], [15432, 0.03772]], 'slope': 0.5185}, 'cost': {'points': [[482, 0.02705], [966, 0.05598], [1926, 0.1337], [3859, 0.4132], [7718, 0.894], [15432, 2.232]], 'slope': 1.32}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.23, 'n_range': [482, 15432], 'time_ratio': [[483, 1.06], [963, 1.02], [1926, 1.14], [3857, 0.998], [7715, 1.17], [15431, 0.956]]}, '64': {'error_factor': 1.15, 'n_range': [482, 15432], 'time_ratio': [[483, 1.13], [963, 1.18], [1926, 1.04], [3857, 1.32], [7715, 1.08], [15431, 1.41]]}}},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[482, 0.3012], [484, 0.3012], [961, 0.1622], [966, 0.1561], [1926, 0.1179], [1927, 0.1179], [3855, 0.08833], [3859, 0.08095], [7712, 0.06531], [7718, 0.06247], [15430, 0.0421], [15432, 0.03791]], 'slope': 0.5184}, 'cost': {'points': [[482, 0.02513], [966, 0.06446], [1926, 0.1541], [3859, 0.421], [7718, 0.9023], [15432, 2.296]], 'slope': 1.348}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.22, 'n_range': [482, 15432], 'time_ratio': [[483, 1.17], [963, 1.08], [1926, 1.23], [3857, 1.09], [7715, 1.05], [15431, 0.967]]}, '64': {'error_factor': 1.15, 'n_range': [482, 15432], 'time_ratio': [[483, 0.889], [963, 1.09], [1926, 1.05], [3857, 1.36], [7715, 1.07], [15431, 1.41]]}}},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[482, 0.311], [484, 0.311], [961, 0.1644], [966, 0.1615], [1926, 0.1235], [1927, 0.1235], [3855, 0.08804], [3859, 0.07982], [7712, 0.06231], [7718, 0.05745], [15430, 0.04198], [15432, 0.0363]], 'slope': 0.5398}, 'cost': {'points': [[482, 0.0294], [966, 0.08207], [1926, 0.1603], [3859, 0.5638], [7718, 1.128], [15432, 3.015]], 'slope': 1.419}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.03, 'n_range': [482, 15432], 'time_ratio': [[483, 1.25], [963, 0.977], [1926, 1.25], [3857, 0.967], [7715, 1.58], [15431, 0.824]]}, '64': {'error_factor': 1.08, 'n_range': [482, 15432], 'time_ratio': [[483, 0.979], [963, 1.1], [1926, 1.06], [3857, 1.15], [7715, 1.09], [15431, 1.34]]}}},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[482, 0.3013], [484, 0.3013], [961, 0.1657], [966, 0.1657], [1926, 0.1211], [1927, 0.1211], [3855, 0.09159], [3859, 0.08213], [7712, 0.06247], [7718, 0.05924], [15430, 0.04137], [15432, 0.03716]], 'slope': 0.5313}, 'cost': {'points': [[482, 0.02754], [966, 0.06275], [1926, 0.146], [3859, 0.7365], [7718, 1.103], [15432, 2.596]], 'slope': 1.235}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.05, 'n_range': [482, 15432], 'time_ratio': [[483, 1.35], [963, 0.98], [1926, 1.45], [3857, 1.1], [7715, 1.2], [15431, 1.04]]}, '64': {'error_factor': 1.11, 'n_range': [482, 15432], 'time_ratio': [[483, 0.956], [963, 1.1], [1926, 0.992], [3857, 1.11], [7715, 1.0], [15431, 1.18]]}}},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[482, 0.311], [484, 0.311], [961, 0.1669], [966, 0.1669], [1926, 0.1232], [1927, 0.1232], [3855, 0.0919], [3859, 0.08017], [7712, 0.06186], [7718, 0.05881], [15430, 0.04108], [15432, 0.03647]], 'slope': 0.54}, 'cost': {'points': [[482, 0.02791], [966, 0.06456], [1926, 0.1598], [3859, 0.7878], [7718, 1.183], [15432, 3.536]], 'slope': 1.581}, 'n_range': [482, 15432], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.03, 'n_range': [482, 15432], 'time_ratio': [[483, 1.29], [963, 1.17], [1926, 1.53], [3857, 1.14], [7715, 1.22], [15431, 0.996]]}, '64': {'error_factor': 1.09, 'n_range': [482, 15432], 'time_ratio': [[483, 0.991], [963, 1.02], [1926, 1.1], [3857, 1.01], [7715, 0.999], [15431, 1.16]]}}},
            },
        },
        'point_cloud': {
            'scene': 'bunny',
            'n_min': 848,
            'reference_check': 0.006732,
            'discretization': 'direct vis=exact',
            'sweep': {'date': '2026-11-22 14:35 UTC', 'core_commit': '457db45'},
            'sampling': {'points': [[2033, 1.2], [6057, 1.28], [14150, 1.08]], 'z': 2.0, 'log_sd': 0.0768, 'samplings': 6, 'setting': 'FMM p=3 vis=exact all-pairs s=32 θ=0.5'},
            'settings': {
                'direct vis=none': {'keywords': {'method': 'direct', 'visibility': 'none'}, 'error': {'points': [[848, 0.5572], [1583, 0.5572], [3067, 0.5572], [4613, 0.5572], [6132, 0.5572]], 'slope': 0.05}, 'cost': {'points': [[848, 0.008488], [1583, 0.02601], [3067, 0.07414], [4613, 0.157], [6132, 0.2674]], 'slope': 1.87}, 'n_range': [848, 6132]},
                'FMM p=0 vis=none': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.6504], [1583, 0.6504], [3067, 0.6504], [4613, 0.6504], [6132, 0.6504], [9070, 0.6504], [12034, 0.6504], [18085, 0.6504]], 'slope': 0.05}, 'cost': {'points': [[848, 0.03264], [1583, 0.05104], [3067, 0.09269], [4613, 0.1341], [6132, 0.1927], [9070, 0.364], [12034, 0.4507], [18085, 0.9051]], 'slope': 1.712}, 'n_range': [848, 18085], 'leaf_variants': {'16': {'error_factor': 1.26, 'n_range': [848, 6132], 'time_ratio': [[850, 1.26], [1580, 1.12], [3109, 1.42], [4615, 1.1], [6123, 1.27]]}, '64': {'error_factor': 1.22, 'n_range': [848, 6132], 'time_ratio': [[850, 0.943], [1580, 0.817], [3109, 0.884], [4615, 0.901], [6123, 0.865]]}}},
                'FMM p=2 vis=none': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.56], [1583, 0.56], [3067, 0.56], [4613, 0.56], [6132, 0.56], [9070, 0.56], [12034, 0.56], [18085, 0.56]], 'slope': 0.05}, 'cost': {'points': [[848, 0.0417], [1583, 0.0832], [3067, 0.1268], [4613, 0.2549], [6132, 0.3259], [9070, 0.5727], [12034, 0.7101], [18085, 1.554]], 'slope': 1.922}, 'n_range': [848, 18085], 'leaf_variants': {'16': {'error_factor': 1.24, 'n_range': [848, 6132], 'time_ratio': [[850, 1.33], [1580, 1.29], [3109, 1.83], [4615, 1.26], [6123, 1.2]]}, '64': {'error_factor': 1.27, 'n_range': [848, 6132], 'time_ratio': [[850, 0.967], [1580, 0.817], [3109, 0.742], [4615, 0.599], [6123, 0.713]]}}},
                'FMM p=3 vis=none': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.5669], [1583, 0.5669], [3067, 0.5669], [4613, 0.5669], [6132, 0.5669], [9070, 0.5669], [12034, 0.5669], [18085, 0.5669]], 'slope': 0.05}, 'cost': {'points': [[848, 0.05335], [1583, 0.1062], [3067, 0.1619], [4613, 0.3896], [6132, 0.5638], [9070, 1.024], [12034, 1.024], [18085, 2.617]], 'slope': 2.303}, 'n_range': [848, 18085], 'leaf_variants': {'16': {'error_factor': 1.44, 'n_range': [848, 6132], 'time_ratio': [[850, 1.6], [1580, 1.34], [3109, 2.16], [4615, 1.34], [6123, 1.31]]}, '64': {'error_factor': 1.25, 'n_range': [848, 6132], 'time_ratio': [[850, 0.86], [1580, 0.643], [3109, 0.781], [4615, 0.486], [6123, 0.492]]}}},
                'FMM p=4 vis=none': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.5666], [1583, 0.5666], [3067, 0.5666], [4613, 0.5666], [6132, 0.5666], [9070, 0.5666], [12034, 0.5666], [18085, 0.5666]], 'slope': 0.05}, 'cost': {'points': [[848, 0.0516], [1583, 0.1131], [3067, 0.2372], [4613, 0.7051], [6132, 0.8574], [9070, 1.387], [12034, 1.612], [18085, 4.131]], 'slope': 2.31}, 'n_range': [848, 18085], 'leaf_variants': {'16': {'error_factor': 1.09, 'n_range': [848, 6132], 'time_ratio': [[850, 1.88], [1580, 1.63], [3109, 2.42], [4615, 1.09], [6123, 1.1]]}, '64': {'error_factor': 1.2, 'n_range': [848, 6132], 'time_ratio': [[850, 0.753], [1580, 0.572], [3109, 0.646], [4615, 0.423], [6123, 0.41]]}}},
                'FMM p=6 vis=none': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.4499], [1583, 0.4499]], 'slope': 0.05}, 'cost': {'points': [[848, 0.08687], [1583, 0.2718]], 'slope': 1.828}, 'n_range': [848, 1583]},
                'FMM p=8 vis=none': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[848, 0.4498], [1583, 0.4498]], 'slope': 0.05}, 'cost': {'points': [[848, 0.1763], [1583, 0.6944]], 'slope': 2.196}, 'n_range': [848, 1583]},
                'direct vis=seed': {'keywords': {'method': 'direct', 'visibility': 'seed'}, 'error': {'points': [[848, 0.3988], [1583, 0.3683]], 'slope': 0.1271}, 'cost': {'points': [[848, 0.1021], [1583, 0.2971]], 'slope': 1.712}, 'n_range': [848, 1583]},
                'FMM p=0 vis=seed': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4276], [1583, 0.3415], [3067, 0.2593]], 'slope': 0.3894}, 'cost': {'points': [[848, 0.05442], [1583, 0.1377], [3067, 0.2702]], 'slope': 1.019}, 'n_range': [848, 3067]},
                'FMM p=2 vis=seed': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4149], [1583, 0.3353], [3067, 0.2474]], 'slope': 0.4027}, 'cost': {'points': [[848, 0.05642], [1583, 0.1391], [3067, 0.2734]], 'slope': 1.022}, 'n_range': [848, 3067]},
                'FMM p=3 vis=seed': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4151], [1583, 0.3354], [3067, 0.2475]], 'slope': 0.4029}, 'cost': {'points': [[848, 0.06342], [1583, 0.1469], [3067, 0.3253]], 'slope': 1.202}, 'n_range': [848, 3067]},
                'FMM p=4 vis=seed': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4152], [1583, 0.3352], [3067, 0.2474]], 'slope': 0.4034}, 'cost': {'points': [[848, 0.0727], [1583, 0.1845], [3067, 0.3825]], 'slope': 1.103}, 'n_range': [848, 3067]},
                'FMM p=6 vis=seed': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4152], [1583, 0.3352]], 'slope': 0.343}, 'cost': {'points': [[848, 0.1033], [1583, 0.2962]], 'slope': 1.688}, 'n_range': [848, 1583]},
                'FMM p=8 vis=seed': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[848, 0.4152], [1583, 0.3352]], 'slope': 0.343}, 'cost': {'points': [[848, 0.1538], [1583, 0.6317]], 'slope': 2.263}, 'n_range': [848, 1583]},
                'direct vis=exact': {'keywords': {'method': 'direct', 'visibility': 'exact'}, 'error': {'points': [[848, 0.1501], [1583, 0.1052], [3067, 0.07598], [4613, 0.05426], [6132, 0.043], [9070, 0.0384], [12034, 0.02941]], 'slope': 0.6113}, 'cost': {'points': [[848, 0.02849], [1583, 0.09347], [3067, 0.384], [4613, 0.7362], [6132, 1.444], [9070, 3.31], [12034, 5.578]], 'slope': 1.846}, 'n_range': [848, 12034]},
                'FMM p=0 vis=exact': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.2487], [852, 0.2186], [1577, 0.2056], [1583, 0.1925], [3067, 0.1877], [3152, 0.1877], [4613, 0.1657], [4618, 0.1657], [6115, 0.1657], [6132, 0.145], [9070, 0.145], [9116, 0.145], [12034, 0.145], [12101, 0.145], [17973, 0.145], [18085, 0.145]], 'slope': 0.2063}, 'cost': {'points': [[848, 0.03117], [1583, 0.05399], [3067, 0.1333], [4613, 0.2741], [6132, 0.358], [9070, 0.6558], [12034, 0.7587], [18085, 2.054]], 'slope': 2.445}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.18, 'n_range': [848, 18085], 'time_ratio': [[850, 1.25], [1580, 1.12], [3109, 1.81], [4615, 1.11], [6123, 1.1], [9093, 1.58], [12067, 2.78], [18029, 1.42]]}, '64': {'error_factor': 1.73, 'n_range': [848, 18085], 'time_ratio': [[850, 1.13], [1580, 1.08], [3109, 1.02], [4615, 0.654], [6123, 0.695], [9093, 0.766], [12067, 0.951], [18029, 0.545]]}}},
                'FMM p=2 vis=exact': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.2135], [852, 0.1955], [1577, 0.1706], [1583, 0.1692], [3067, 0.1542], [3152, 0.1542], [4613, 0.1293], [4618, 0.1293], [6115, 0.1255], [6132, 0.1114], [9070, 0.1097], [9116, 0.1097], [12034, 0.1097], [12101, 0.1097], [17973, 0.1015], [18085, 0.09287]], 'slope': 0.2811}, 'cost': {'points': [[848, 0.03687], [1583, 0.05912], [3067, 0.1732], [4613, 0.3164], [6132, 0.4271], [9070, 0.7612], [12034, 0.9007], [18085, 2.73]], 'slope': 2.5}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.13, 'n_range': [848, 18085], 'time_ratio': [[850, 1.39], [1580, 1.15], [3109, 1.97], [4615, 1.04], [6123, 1.09], [9093, 1.69], [12067, 2.8], [18029, 1.49]]}, '64': {'error_factor': 1.5, 'n_range': [848, 18085], 'time_ratio': [[850, 1.05], [1580, 1.08], [3109, 0.9], [4615, 0.53], [6123, 0.651], [9093, 0.731], [12067, 1.01], [18029, 0.496]]}}},
                'FMM p=3 vis=exact': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.2141], [852, 0.1947], [1577, 0.1717], [1583, 0.1694], [3067, 0.155], [3152, 0.155], [4613, 0.1295], [4618, 0.1295], [6115, 0.1255], [6132, 0.1115], [9070, 0.1103], [9116, 0.1103], [12034, 0.1103], [12101, 0.1103], [17973, 0.1013], [18085, 0.09505]], 'slope': 0.2796}, 'cost': {'points': [[848, 0.04024], [1583, 0.1108], [3067, 0.1876], [4613, 0.4702], [6132, 0.5785], [9070, 1.16], [12034, 1.16], [18085, 3.509]], 'slope': 2.5}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.15, 'n_range': [848, 18085], 'time_ratio': [[850, 1.65], [1580, 1.23], [3109, 2.18], [4615, 1.17], [6123, 1.14], [9093, 1.87], [12067, 2.78], [18029, 1.49]]}, '64': {'error_factor': 1.52, 'n_range': [848, 18085], 'time_ratio': [[850, 1.06], [1580, 0.903], [3109, 0.804], [4615, 0.54], [6123, 0.546], [9093, 0.681], [12067, 0.957], [18029, 0.494]]}}},
                'FMM p=4 vis=exact': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.2146], [852, 0.1947], [1577, 0.1716], [1583, 0.1693], [3067, 0.1549], [3152, 0.1549], [4613, 0.1295], [4618, 0.1295], [6115, 0.1251], [6132, 0.1115], [9070, 0.1102], [9116, 0.1102], [12034, 0.1102], [12101, 0.1102], [17973, 0.1013], [18085, 0.09479]], 'slope': 0.2801}, 'cost': {'points': [[848, 0.05071], [1583, 0.09895], [3067, 0.2507], [4613, 0.666], [6132, 0.8079], [9070, 1.422], [12034, 1.765], [18085, 5.011]], 'slope': 2.5}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.15, 'n_range': [848, 18085], 'time_ratio': [[850, 1.87], [1580, 1.32], [3109, 2.05], [4615, 1.4], [6123, 1.06], [9093, 2.19], [12067, 3.04], [18029, 1.61]]}, '64': {'error_factor': 1.53, 'n_range': [848, 18085], 'time_ratio': [[850, 0.975], [1580, 0.778], [3109, 0.683], [4615, 0.413], [6123, 0.506], [9093, 0.685], [12067, 0.822], [18029, 0.435]]}}},
                'FMM p=6 vis=exact': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.2145], [1583, 0.1693]], 'slope': 0.3792}, 'cost': {'points': [[848, 0.07954], [1583, 0.2156]], 'slope': 1.598}, 'n_range': [848, 1583]},
                'FMM p=8 vis=exact': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[848, 0.2145], [1583, 0.1693]], 'slope': 0.3792}, 'cost': {'points': [[848, 0.1609], [1583, 0.5024]], 'slope': 1.824}, 'n_range': [848, 1583]},
                'FMM p=2 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[848, 0.185], [852, 0.1691], [1577, 0.1691], [1583, 0.1691], [3067, 0.1504], [3152, 0.1504], [4613, 0.125], [4618, 0.125], [6115, 0.1163], [6132, 0.1105], [9070, 0.09959], [9116, 0.09959], [12034, 0.09959], [12101, 0.09959], [17973, 0.09519], [18085, 0.07249]], 'slope': 0.2719}, 'cost': {'points': [[848, 0.03236], [1583, 0.0678], [3067, 0.154], [4613, 0.2841], [6132, 0.4675], [9070, 0.9253], [12034, 1.055], [18085, 2.508]], 'slope': 2.125}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.12, 'n_range': [848, 18085], 'time_ratio': [[850, 1.27], [1580, 1.13], [3109, 1.9], [4615, 1.12], [6123, 1.02], [9093, 1.5], [12067, 2.41], [18029, 1.53]]}, '64': {'error_factor': 1.45, 'n_range': [848, 18085], 'time_ratio': [[850, 1.12], [1580, 0.96], [3109, 1.18], [4615, 0.733], [6123, 0.777], [9093, 0.939], [12067, 0.956], [18029, 0.59]]}}},
                'FMM p=3 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[848, 0.1853], [852, 0.1693], [1577, 0.1693], [1583, 0.1693], [3067, 0.1505], [3152, 0.1505], [4613, 0.125], [4618, 0.125], [6115, 0.1163], [6132, 0.1105], [9070, 0.09957], [9116, 0.09957], [12034, 0.09957], [12101, 0.09957], [17973, 0.09512], [18085, 0.07246]], 'slope': 0.2722}, 'cost': {'points': [[848, 0.04607], [1583, 0.07542], [3067, 0.1754], [4613, 0.4616], [6132, 0.6435], [9070, 1.038], [12034, 1.196], [18085, 3.347]], 'slope': 2.5}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.12, 'n_range': [848, 18085], 'time_ratio': [[850, 1.37], [1580, 1.08], [3109, 2.01], [4615, 1.2], [6123, 1.33], [9093, 1.7], [12067, 2.78], [18029, 1.38]]}, '64': {'error_factor': 1.45, 'n_range': [848, 18085], 'time_ratio': [[850, 1.1], [1580, 0.861], [3109, 0.93], [4615, 0.662], [6123, 0.658], [9093, 0.926], [12067, 0.941], [18029, 0.511]]}}},
                'FMM p=4 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[848, 0.1853], [852, 0.1692], [1577, 0.1692], [1583, 0.1692], [3067, 0.1505], [3152, 0.1505], [4613, 0.125], [4618, 0.125], [6115, 0.1164], [6132, 0.1105], [9070, 0.09958], [9116, 0.09958], [12034, 0.09958], [12101, 0.09958], [17973, 0.09512], [18085, 0.07247]], 'slope': 0.2721}, 'cost': {'points': [[848, 0.05063], [1583, 0.1058], [3067, 0.2428], [4613, 0.6319], [6132, 0.7788], [9070, 1.443], [12034, 1.443], [18085, 5.1]], 'slope': 2.5}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.12, 'n_range': [848, 18085], 'time_ratio': [[850, 1.65], [1580, 1.03], [3109, 2.11], [4615, 1.09], [6123, 1.18], [9093, 1.6], [12067, 2.93], [18029, 1.5]]}, '64': {'error_factor': 1.45, 'n_range': [848, 18085], 'time_ratio': [[850, 0.952], [1580, 0.773], [3109, 0.864], [4615, 0.503], [6123, 0.527], [9093, 0.746], [12067, 0.814], [18029, 0.5]]}}},
                'FMM p=2 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[848, 0.1667], [852, 0.165], [1577, 0.1407], [1583, 0.1407], [3067, 0.1407], [3152, 0.1407], [4613, 0.1223], [4618, 0.1223], [6115, 0.1082], [6132, 0.1065], [9070, 0.09431], [9116, 0.09431], [12034, 0.09431], [12101, 0.09431], [17973, 0.09159], [18085, 0.06069]], 'slope': 0.2521}, 'cost': {'points': [[848, 0.03306], [1583, 0.08045], [3067, 0.1758], [4613, 0.3749], [6132, 0.4675], [9070, 0.9024], [12034, 1.019], [18085, 2.578]], 'slope': 2.278}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.15, 'n_range': [848, 18085], 'time_ratio': [[850, 1.28], [1580, 1.06], [3109, 1.46], [4615, 1.14], [6123, 1.03], [9093, 1.34], [12067, 1.95], [18029, 1.34]]}, '64': {'error_factor': 1.37, 'n_range': [848, 18085], 'time_ratio': [[850, 0.978], [1580, 0.908], [3109, 1.06], [4615, 0.854], [6123, 1.02], [9093, 1.07], [12067, 0.992], [18029, 0.722]]}}},
                'FMM p=3 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[848, 0.1666], [852, 0.1649], [1577, 0.1406], [1583, 0.1406], [3067, 0.1406], [3152, 0.1406], [4613, 0.1223], [4618, 0.1223], [6115, 0.1083], [6132, 0.1066], [9070, 0.09426], [9116, 0.09426], [12034, 0.09426], [12101, 0.09426], [17973, 0.09157], [18085, 0.06066]], 'slope': 0.252}, 'cost': {'points': [[848, 0.03755], [1583, 0.09575], [3067, 0.1847], [4613, 0.4681], [6132, 0.589], [9070, 1.288], [12034, 1.288], [18085, 3.317]], 'slope': 2.322}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.15, 'n_range': [848, 18085], 'time_ratio': [[850, 1.48], [1580, 1.15], [3109, 1.68], [4615, 1.15], [6123, 1.24], [9093, 1.4], [12067, 2.46], [18029, 1.32]]}, '64': {'error_factor': 1.37, 'n_range': [848, 18085], 'time_ratio': [[850, 1.06], [1580, 0.871], [3109, 1.12], [4615, 0.767], [6123, 0.866], [9093, 0.975], [12067, 0.991], [18029, 0.615]]}}},
                'FMM p=4 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[848, 0.1666], [852, 0.1649], [1577, 0.1406], [1583, 0.1406], [3067, 0.1406], [3152, 0.1406], [4613, 0.1223], [4618, 0.1223], [6115, 0.1083], [6132, 0.1066], [9070, 0.09426], [9116, 0.09426], [12034, 0.09426], [12101, 0.09426], [17973, 0.09157], [18085, 0.06066]], 'slope': 0.252}, 'cost': {'points': [[848, 0.03503], [1583, 0.1032], [3067, 0.2209], [4613, 0.6324], [6132, 0.8183], [9070, 1.267], [12034, 1.667], [18085, 4.023]], 'slope': 2.163}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.15, 'n_range': [848, 18085], 'time_ratio': [[850, 1.89], [1580, 1.25], [3109, 2.05], [4615, 1.27], [6123, 1.3], [9093, 1.55], [12067, 2.77], [18029, 1.52]]}, '64': {'error_factor': 1.37, 'n_range': [848, 18085], 'time_ratio': [[850, 1.0], [1580, 0.698], [3109, 0.926], [4615, 0.62], [6123, 0.717], [9093, 0.805], [12067, 0.85], [18029, 0.558]]}}},
                'FMM p=2 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[848, 0.1492], [852, 0.1407], [1577, 0.1196], [1583, 0.1044], [3067, 0.09296], [3152, 0.09296], [4613, 0.06718], [4618, 0.06718], [6115, 0.05902], [6132, 0.05857], [9070, 0.05857], [9116, 0.05857], [12034, 0.05857], [12101, 0.05857], [17973, 0.05857], [18085, 0.05857]], 'slope': 0.4569}, 'cost': {'points': [[848, 0.03693], [1583, 0.09306], [3067, 0.1997], [4613, 0.494], [6132, 0.7527], [9070, 1.551], [12034, 2.112], [18085, 5.897]], 'slope': 2.5}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.64, 'n_range': [848, 18085], 'time_ratio': [[850, 1.24], [1580, 1.05], [3109, 1.4], [4615, 1.07], [6123, 1.01], [9093, 1.33], [12067, 1.53], [18029, 1.07]]}, '64': {'error_factor': 1.92, 'n_range': [848, 18085], 'time_ratio': [[850, 1.02], [1580, 0.882], [3109, 1.0], [4615, 0.726], [6123, 0.83], [9093, 0.997], [12067, 1.01], [18029, 0.766]]}}},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[848, 0.1493], [852, 0.1406], [1577, 0.1195], [1583, 0.1043], [3067, 0.09401], [3152, 0.09401], [4613, 0.0671], [4618, 0.0671], [6115, 0.06143], [6132, 0.06143], [9070, 0.06143], [9116, 0.06143], [12034, 0.06143], [12101, 0.06143], [17973, 0.06143], [18085, 0.06143]], 'slope': 0.4551}, 'cost': {'points': [[848, 0.04391], [1583, 0.09368], [3067, 0.2365], [4613, 0.5523], [6132, 0.8635], [9070, 1.582], [12034, 2.166], [18085, 6.444]], 'slope': 2.5}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.71, 'n_range': [848, 18085], 'time_ratio': [[850, 1.33], [1580, 1.08], [3109, 1.64], [4615, 1.06], [6123, 1.08], [9093, 1.35], [12067, 1.8], [18029, 1.04]]}, '64': {'error_factor': 2.02, 'n_range': [848, 18085], 'time_ratio': [[850, 0.952], [1580, 0.823], [3109, 0.964], [4615, 0.741], [6123, 0.751], [9093, 0.97], [12067, 1.06], [18029, 0.759]]}}},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[848, 0.1496], [852, 0.1496], [1577, 0.1182], [1583, 0.1053], [3067, 0.08271], [3152, 0.08271], [4613, 0.06786], [4618, 0.06786], [6115, 0.04287], [6132, 0.04287], [9070, 0.0332], [9116, 0.0332], [12034, 0.0332], [12101, 0.0332], [17973, 0.01955], [18085, 0.01827]], 'slope': 0.6665}, 'cost': {'points': [[848, 0.05008], [1583, 0.1213], [3067, 0.2911], [4613, 0.6513], [6132, 1.006], [9070, 2.062], [12034, 2.814], [18085, 7.161]], 'slope': 2.293}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.15, 'n_range': [848, 18085], 'time_ratio': [[850, 1.27], [1580, 1.09], [3109, 1.48], [4615, 1.03], [6123, 1.02], [9093, 1.32], [12067, 1.68], [18029, 1.18]]}, '64': {'error_factor': 1.2, 'n_range': [848, 18085], 'time_ratio': [[850, 0.987], [1580, 0.786], [3109, 0.967], [4615, 0.72], [6123, 0.766], [9093, 0.917], [12067, 0.934], [18029, 0.789]]}}},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[848, 0.1493], [852, 0.1406], [1577, 0.1211], [1583, 0.1043], [3067, 0.08295], [3152, 0.08295], [4613, 0.07044], [4618, 0.07044], [6115, 0.05102], [6132, 0.04806], [9070, 0.04269], [9116, 0.04213], [12034, 0.04213], [12101, 0.04213], [17973, 0.02729], [18085, 0.02473]], 'slope': 0.5603}, 'cost': {'points': [[848, 0.03781], [1583, 0.1507], [3067, 0.2373], [4613, 0.4654], [6132, 0.9028], [9070, 1.607], [12034, 2.214], [18085, 5.836]], 'slope': 2.38}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.17, 'n_range': [848, 18085], 'time_ratio': [[850, 1.45], [1580, 1.06], [3109, 1.68], [4615, 1.03], [6123, 1.02], [9093, 1.37], [12067, 1.64], [18029, 1.15]]}, '64': {'error_factor': 1.16, 'n_range': [848, 18085], 'time_ratio': [[850, 0.881], [1580, 0.871], [3109, 1.01], [4615, 0.712], [6123, 0.769], [9093, 0.937], [12067, 0.991], [18029, 0.807]]}}},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[848, 0.1496], [852, 0.1496], [1577, 0.1183], [1583, 0.1053], [3067, 0.0827], [3152, 0.0827], [4613, 0.06854], [4618, 0.06854], [6115, 0.0475], [6132, 0.04411], [9070, 0.03935], [9116, 0.03527], [12034, 0.03362], [12101, 0.03362], [17973, 0.01978], [18085, 0.01978]], 'slope': 0.6459}, 'cost': {'points': [[848, 0.05278], [1583, 0.121], [3067, 0.2535], [4613, 0.6187], [6132, 1.041], [9070, 1.898], [12034, 2.827], [18085, 7.216]], 'slope': 2.3}, 'n_range': [848, 18085], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.2, 'n_range': [848, 18085], 'time_ratio': [[850, 1.28], [1580, 1.12], [3109, 1.52], [4615, 1.07], [6123, 1.01], [9093, 1.28], [12067, 1.72], [18029, 1.2]]}, '64': {'error_factor': 1.1, 'n_range': [848, 18085], 'time_ratio': [[850, 0.982], [1580, 0.857], [3109, 0.99], [4615, 0.739], [6123, 0.737], [9093, 0.99], [12067, 0.993], [18029, 0.745]]}}},
            },
        },
        'random': {
            'scene': 'interior',
            'n_min': 508,
            'reference_check': 0.04003,
            'discretization': 'direct vis=exact',
            'sweep': {'date': '2026-12-02 07:09 UTC', 'core_commit': '2c7323d'},
            'sampling': {'points': [[2000, 1.3], [4045, 1.37], [8000, 1.13], [16163, 1.05]], 'z': 2.0, 'log_sd': 0.121, 'samplings': 6, 'setting': 'FMM p=3 vis=exact all-pairs s=32 θ=0.5'},
            'settings': {
                'direct vis=none': {'keywords': {'method': 'direct', 'visibility': 'none'}, 'error': {'points': [[508, 0.8999], [1003, 0.85], [2000, 0.85], [3000, 0.85], [3999, 0.85], [6003, 0.795], [8000, 0.7838]], 'slope': 0.05}, 'cost': {'points': [[508, 0.009032], [1003, 0.01508], [2000, 0.04428], [3000, 0.06992], [3999, 0.1221], [6003, 0.2572], [8000, 0.4078]], 'slope': 1.604}, 'n_range': [508, 8000]},
                'FMM p=0 vis=none': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.9601], [1003, 0.9036], [2000, 0.9036], [3000, 0.9036], [3999, 0.9036], [6003, 0.9036], [8000, 0.9036], [11998, 0.9036], [15999, 0.9036]], 'slope': 0.05}, 'cost': {'points': [[508, 0.01499], [1003, 0.01943], [2000, 0.03527], [3000, 0.04873], [3999, 0.05646], [6003, 0.08814], [8000, 0.1022], [11998, 0.1102], [15999, 0.1674]], 'slope': 1.453}, 'n_range': [508, 15999], 'leaf_variants': {'16': {'error_factor': 3.95, 'n_range': [508, 8000], 'time_ratio': [[508, 0.838], [1003, 0.994], [2000, 1.08], [3000, 1.2], [3999, 1.05], [6003, 1.12], [8000, 1.08]]}, '64': {'error_factor': 0.933, 'n_range': [508, 8000], 'time_ratio': [[508, 0.958], [1003, 1.14], [2000, 1.15], [3000, 1.26], [3999, 1.25], [6003, 0.919], [8000, 0.892]]}}},
                'FMM p=2 vis=none': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.8972], [1003, 0.8549], [2000, 0.8549], [3000, 0.8549], [3999, 0.8549], [6003, 0.8528], [8000, 0.8528], [11998, 0.8528], [15999, 0.8528]], 'slope': 0.05}, 'cost': {'points': [[508, 0.01888], [1003, 0.02447], [2000, 0.05073], [3000, 0.07049], [3999, 0.08994], [6003, 0.1296], [8000, 0.1445], [11998, 0.1849], [15999, 0.2676]], 'slope': 1.284}, 'n_range': [508, 15999], 'leaf_variants': {'16': {'error_factor': 3.74, 'n_range': [508, 8000], 'time_ratio': [[508, 1.07], [1003, 0.964], [2000, 1.05], [3000, 1.12], [3999, 1.47], [6003, 1.61], [8000, 1.25]]}, '64': {'error_factor': 0.993, 'n_range': [508, 8000], 'time_ratio': [[508, 0.895], [1003, 0.784], [2000, 0.85], [3000, 0.96], [3999, 1.12], [6003, 0.997], [8000, 0.817]]}}},
                'FMM p=3 vis=none': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.895], [1003, 0.8507], [2000, 0.8507], [3000, 0.8507], [3999, 0.8507], [6003, 0.8495], [8000, 0.8495], [11998, 0.8495], [15999, 0.8495]], 'slope': 0.05}, 'cost': {'points': [[508, 0.01887], [1003, 0.03112], [2000, 0.05791], [3000, 0.08519], [3999, 0.1197], [6003, 0.1658], [8000, 0.2012], [11998, 0.2628], [15999, 0.4014]], 'slope': 1.471}, 'n_range': [508, 15999], 'leaf_variants': {'16': {'error_factor': 3.4, 'n_range': [508, 8000], 'time_ratio': [[508, 0.992], [1003, 1.12], [2000, 1.33], [3000, 1.31], [3999, 1.24], [6003, 1.68], [8000, 1.65]]}, '64': {'error_factor': 0.989, 'n_range': [508, 8000], 'time_ratio': [[508, 0.784], [1003, 0.877], [2000, 0.955], [3000, 0.977], [3999, 0.842], [6003, 0.808], [8000, 0.822]]}}},
                'FMM p=4 vis=none': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.9007], [1003, 0.8499], [2000, 0.8499], [3000, 0.8499], [3999, 0.8499], [6003, 0.8482], [8000, 0.8482], [11998, 0.8482], [15999, 0.8482]], 'slope': 0.05}, 'cost': {'points': [[508, 0.01982], [1003, 0.03399], [2000, 0.08044], [3000, 0.1105], [3999, 0.1777], [6003, 0.255], [8000, 0.3312], [11998, 0.5432], [15999, 0.7777]], 'slope': 1.247}, 'n_range': [508, 15999], 'leaf_variants': {'16': {'error_factor': 3.42, 'n_range': [508, 8000], 'time_ratio': [[508, 1.31], [1003, 1.37], [2000, 1.72], [3000, 1.18], [3999, 1.36], [6003, 1.96], [8000, 1.78]]}, '64': {'error_factor': 1.23, 'n_range': [508, 8000], 'time_ratio': [[508, 0.756], [1003, 0.81], [2000, 0.79], [3000, 0.597], [3999, 0.61], [6003, 0.724], [8000, 0.651]]}}},
                'FMM p=6 vis=none': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.8997], [1003, 0.8407], [2000, 0.7891]], 'slope': 0.09575}, 'cost': {'points': [[508, 0.0311], [1003, 0.06595], [2000, 0.1664]], 'slope': 1.341}, 'n_range': [508, 2000]},
                'FMM p=8 vis=none': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'none'}, 'error': {'points': [[508, 0.8999], [1003, 0.8407], [2000, 0.7891]], 'slope': 0.09589}, 'cost': {'points': [[508, 0.0535], [1003, 0.1465], [2000, 0.362]], 'slope': 1.311}, 'n_range': [508, 2000]},
                'direct vis=seed': {'keywords': {'method': 'direct', 'visibility': 'seed'}, 'error': {'points': [[508, 0.3855], [1003, 0.2875], [2000, 0.2061], [3000, 0.1796]], 'slope': 0.4382}, 'cost': {'points': [[508, 0.08107], [1003, 0.2923], [2000, 1.481], [3000, 3.299]], 'slope': 1.975}, 'n_range': [508, 3000]},
                'FMM p=0 vis=seed': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3892], [1003, 0.3488], [2000, 0.2755], [3000, 0.2257], [3999, 0.225]], 'slope': 0.2924}, 'cost': {'points': [[508, 0.05787], [1003, 0.08777], [2000, 0.194], [3000, 0.2181], [3999, 0.2821]], 'slope': 1.0}, 'n_range': [508, 3999]},
                'FMM p=2 vis=seed': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3826], [1003, 0.3307], [2000, 0.2514], [3000, 0.1989], [3999, 0.1897]], 'slope': 0.3627}, 'cost': {'points': [[508, 0.05419], [1003, 0.08321], [2000, 0.1907], [3000, 0.2396], [3999, 0.3249]], 'slope': 1.059}, 'n_range': [508, 3999]},
                'FMM p=3 vis=seed': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3832], [1003, 0.3327], [2000, 0.2527], [3000, 0.1998], [3999, 0.1903]], 'slope': 0.362}, 'cost': {'points': [[508, 0.06073], [1003, 0.09031], [2000, 0.1887], [3000, 0.2734], [3999, 0.3397]], 'slope': 1.0}, 'n_range': [508, 3999]},
                'FMM p=4 vis=seed': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3834], [1003, 0.3327], [2000, 0.2529], [3000, 0.1999], [3999, 0.1905]], 'slope': 0.3619}, 'cost': {'points': [[508, 0.06399], [1003, 0.09886], [2000, 0.2458], [3000, 0.3145], [3999, 0.4545]], 'slope': 1.282}, 'n_range': [508, 3999]},
                'FMM p=6 vis=seed': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3835], [1003, 0.3325], [2000, 0.2527]], 'slope': 0.3045}, 'cost': {'points': [[508, 0.06447], [1003, 0.1291], [2000, 0.3786]], 'slope': 1.559}, 'n_range': [508, 2000]},
                'FMM p=8 vis=seed': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'seed'}, 'error': {'points': [[508, 0.3835], [1003, 0.3326], [2000, 0.2527]], 'slope': 0.3045}, 'cost': {'points': [[508, 0.08665], [1003, 0.267], [2000, 0.7535]], 'slope': 1.503}, 'n_range': [508, 2000]},
                'direct vis=exact': {'keywords': {'method': 'direct', 'visibility': 'exact'}, 'error': {'points': [[508, 0.2865], [1003, 0.1527], [2000, 0.1235], [3000, 0.09291], [3999, 0.08084], [6003, 0.08084], [8000, 0.07503], [11998, 0.04256]], 'slope': 0.5155}, 'cost': {'points': [[508, 0.02379], [1003, 0.1142], [2000, 0.3385], [3000, 0.877], [3999, 1.445], [6003, 3.259], [8000, 6.85], [11998, 11.99]], 'slope': 1.381}, 'n_range': [508, 11998]},
                'FMM p=0 vis=exact': {'keywords': {'method': 'fmm', 'order': 0, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.3012], [1003, 0.26], [2000, 0.2219], [3000, 0.175], [3999, 0.175], [6003, 0.175], [8000, 0.175], [11998, 0.1679], [15999, 0.1558]], 'slope': 0.1879}, 'cost': {'points': [[508, 0.02125], [1003, 0.04841], [2000, 0.06358], [3000, 0.07108], [3999, 0.1031], [6003, 0.1253], [8000, 0.1598], [11998, 0.3544], [15999, 0.3544]], 'slope': 1.0}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.27, 'n_range': [508, 15999], 'time_ratio': [[508, 0.833], [1003, 0.96], [2000, 0.968], [3000, 1.18], [3999, 1.33], [6003, 2.09], [8000, 1.62], [11998, 1.15], [15999, 1.6]]}, '64': {'error_factor': 1.31, 'n_range': [508, 15999], 'time_ratio': [[508, 1.18], [1003, 1.58], [2000, 1.48], [3000, 1.79], [3999, 1.85], [6003, 1.03], [8000, 0.842], [11998, 0.645], [15999, 0.821]]}}},
                'FMM p=2 vis=exact': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2992], [1003, 0.2299], [2000, 0.1916], [3000, 0.1219], [3999, 0.1108], [6003, 0.1079], [8000, 0.1053], [11998, 0.09627], [15999, 0.09627]], 'slope': 0.3779}, 'cost': {'points': [[508, 0.02172], [1003, 0.0546], [2000, 0.06664], [3000, 0.09832], [3999, 0.1358], [6003, 0.1358], [8000, 0.2162], [11998, 0.4815], [15999, 0.4815]], 'slope': 1.0}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.18, 'n_range': [508, 15999], 'time_ratio': [[508, 1.01], [1003, 1.05], [2000, 1.2], [3000, 1.11], [3999, 1.42], [6003, 2.41], [8000, 2.13], [11998, 1.14], [15999, 1.37]]}, '64': {'error_factor': 1.59, 'n_range': [508, 15999], 'time_ratio': [[508, 1.14], [1003, 1.57], [2000, 1.26], [3000, 1.22], [3999, 1.46], [6003, 1.05], [8000, 0.785], [11998, 0.586], [15999, 0.595]]}}},
                'FMM p=3 vis=exact': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2992], [1003, 0.2311], [2000, 0.1934], [3000, 0.1224], [3999, 0.1113], [6003, 0.1085], [8000, 0.105], [11998, 0.09573], [15999, 0.09573]], 'slope': 0.3799}, 'cost': {'points': [[508, 0.02531], [1003, 0.04644], [2000, 0.09075], [3000, 0.1323], [3999, 0.1746], [6003, 0.1808], [8000, 0.3301], [11998, 0.7673], [15999, 0.8909]], 'slope': 1.0}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.18, 'n_range': [508, 15999], 'time_ratio': [[508, 0.927], [1003, 1.16], [2000, 1.54], [3000, 1.05], [3999, 1.42], [6003, 2.76], [8000, 2.56], [11998, 1.26], [15999, 1.71]]}, '64': {'error_factor': 1.6, 'n_range': [508, 15999], 'time_ratio': [[508, 0.891], [1003, 1.31], [2000, 1.18], [3000, 0.939], [3999, 1.1], [6003, 0.929], [8000, 0.752], [11998, 0.43], [15999, 0.588]]}}},
                'FMM p=4 vis=exact': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2992], [1003, 0.2317], [2000, 0.1933], [3000, 0.1226], [3999, 0.1112], [6003, 0.1089], [8000, 0.1048], [11998, 0.09578], [15999, 0.09578]], 'slope': 0.3798}, 'cost': {'points': [[508, 0.02793], [1003, 0.05963], [2000, 0.1122], [3000, 0.2133], [3999, 0.2844], [6003, 0.3229], [8000, 0.502], [11998, 1.204], [15999, 1.522]], 'slope': 1.0}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.18, 'n_range': [508, 15999], 'time_ratio': [[508, 1.15], [1003, 1.34], [2000, 1.78], [3000, 1.24], [3999, 1.38], [6003, 3.06], [8000, 2.6], [11998, 1.08], [15999, 1.58]]}, '64': {'error_factor': 1.59, 'n_range': [508, 15999], 'time_ratio': [[508, 0.893], [1003, 1.18], [2000, 0.956], [3000, 0.676], [3999, 0.823], [6003, 0.916], [8000, 0.713], [11998, 0.343], [15999, 0.432]]}}},
                'FMM p=6 vis=exact': {'keywords': {'method': 'fmm', 'order': 6, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2734], [1003, 0.2002], [2000, 0.1714]], 'slope': 0.3406}, 'cost': {'points': [[508, 0.04325], [1003, 0.104], [2000, 0.2662]], 'slope': 1.362}, 'n_range': [508, 2000]},
                'FMM p=8 vis=exact': {'keywords': {'method': 'fmm', 'order': 8, 'theta': 0.5, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2734], [1003, 0.2002], [2000, 0.1714]], 'slope': 0.3405}, 'cost': {'points': [[508, 0.0717], [1003, 0.2086], [2000, 0.5894]], 'slope': 1.505}, 'n_range': [508, 2000]},
                'FMM p=2 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2994], [1003, 0.1851], [2000, 0.14], [3000, 0.1231], [3999, 0.11], [6003, 0.1079], [8000, 0.1016], [11998, 0.0945], [15999, 0.0945]], 'slope': 0.3466}, 'cost': {'points': [[508, 0.03136], [1003, 0.052], [2000, 0.137], [3000, 0.1624], [3999, 0.2036], [6003, 0.2314], [8000, 0.3875], [11998, 0.6578], [15999, 0.8495]], 'slope': 1.0}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.1, 'n_range': [508, 15999], 'time_ratio': [[508, 1.02], [1003, 0.998], [2000, 0.905], [3000, 1.0], [3999, 1.23], [6003, 2.07], [8000, 1.82], [11998, 1.03], [15999, 1.34]]}, '64': {'error_factor': 1.29, 'n_range': [508, 15999], 'time_ratio': [[508, 1.04], [1003, 1.24], [2000, 1.28], [3000, 2.26], [3999, 3.07], [6003, 1.1], [8000, 1.04], [11998, 0.754], [15999, 0.947]]}}},
                'FMM p=3 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2994], [1003, 0.1853], [2000, 0.14], [3000, 0.1232], [3999, 0.1101], [6003, 0.1081], [8000, 0.1017], [11998, 0.09449], [15999, 0.09449]], 'slope': 0.3465}, 'cost': {'points': [[508, 0.02779], [1003, 0.05938], [2000, 0.1564], [3000, 0.1929], [3999, 0.2506], [6003, 0.2852], [8000, 0.4166], [11998, 0.9066], [15999, 1.234]], 'slope': 1.07}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.11, 'n_range': [508, 15999], 'time_ratio': [[508, 1.04], [1003, 1.1], [2000, 1.16], [3000, 1.09], [3999, 1.46], [6003, 2.52], [8000, 2.33], [11998, 1.13], [15999, 1.51]]}, '64': {'error_factor': 1.29, 'n_range': [508, 15999], 'time_ratio': [[508, 1.01], [1003, 1.09], [2000, 1.12], [3000, 1.76], [3999, 2.29], [6003, 1.04], [8000, 0.925], [11998, 0.561], [15999, 0.728]]}}},
                'FMM p=4 vis=exact θ=0.3': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.3, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2994], [1003, 0.1853], [2000, 0.14], [3000, 0.1232], [3999, 0.11], [6003, 0.1081], [8000, 0.1016], [11998, 0.0945], [15999, 0.0945]], 'slope': 0.3465}, 'cost': {'points': [[508, 0.02677], [1003, 0.06107], [2000, 0.167], [3000, 0.2541], [3999, 0.3228], [6003, 0.4183], [8000, 0.6645], [11998, 1.542], [15999, 2.035]], 'slope': 1.0}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.11, 'n_range': [508, 15999], 'time_ratio': [[508, 1.02], [1003, 1.27], [2000, 1.45], [3000, 1.3], [3999, 1.7], [6003, 2.85], [8000, 2.66], [11998, 1.27], [15999, 1.58]]}, '64': {'error_factor': 1.29, 'n_range': [508, 15999], 'time_ratio': [[508, 1.05], [1003, 1.11], [2000, 0.998], [3000, 1.26], [3999, 1.56], [6003, 0.97], [8000, 0.784], [11998, 0.46], [15999, 0.548]]}}},
                'FMM p=2 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2993], [1003, 0.1864], [2000, 0.1325], [3000, 0.1098], [3999, 0.09452], [6003, 0.09452], [8000, 0.09452], [11998, 0.09452], [15999, 0.09452]], 'slope': 0.3674}, 'cost': {'points': [[508, 0.02556], [1003, 0.05264], [2000, 0.1667], [3000, 0.2072], [3999, 0.3115], [6003, 0.5497], [8000, 0.6733], [11998, 1.008], [15999, 1.082]], 'slope': 1.0}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.13, 'n_range': [508, 15999], 'time_ratio': [[508, 0.965], [1003, 0.944], [2000, 0.884], [3000, 1.01], [3999, 1.12], [6003, 1.46], [8000, 1.14], [11998, 1.2], [15999, 1.53]]}, '64': {'error_factor': 1.04, 'n_range': [508, 15999], 'time_ratio': [[508, 0.95], [1003, 1.1], [2000, 1.16], [3000, 1.51], [3999, 1.94], [6003, 1.04], [8000, 1.11], [11998, 1.57], [15999, 2.06]]}}},
                'FMM p=3 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2993], [1003, 0.1864], [2000, 0.1325], [3000, 0.1098], [3999, 0.09455], [6003, 0.09455], [8000, 0.09455], [11998, 0.09455], [15999, 0.09455]], 'slope': 0.3673}, 'cost': {'points': [[508, 0.02538], [1003, 0.06116], [2000, 0.1655], [3000, 0.2318], [3999, 0.3574], [6003, 0.6043], [8000, 0.8097], [11998, 1.399], [15999, 1.573]], 'slope': 1.0}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.13, 'n_range': [508, 15999], 'time_ratio': [[508, 1.02], [1003, 1.09], [2000, 1.04], [3000, 1.15], [3999, 1.35], [6003, 1.9], [8000, 1.61], [11998, 1.22], [15999, 1.47]]}, '64': {'error_factor': 1.04, 'n_range': [508, 15999], 'time_ratio': [[508, 0.871], [1003, 1.11], [2000, 0.943], [3000, 1.44], [3999, 1.78], [6003, 1.08], [8000, 1.08], [11998, 1.07], [15999, 1.41]]}}},
                'FMM p=4 vis=exact θ=0.2': {'keywords': {'method': 'fmm', 'order': 4, 'theta': 0.2, 'visibility': 'exact'}, 'error': {'points': [[508, 0.2993], [1003, 0.1864], [2000, 0.1325], [3000, 0.1098], [3999, 0.09455], [6003, 0.09455], [8000, 0.09455], [11998, 0.09455], [15999, 0.09455]], 'slope': 0.3673}, 'cost': {'points': [[508, 0.03014], [1003, 0.06277], [2000, 0.185], [3000, 0.2582], [3999, 0.3573], [6003, 0.6851], [8000, 1.065], [11998, 2.001], [15999, 2.427]], 'slope': 1.0}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.13, 'n_range': [508, 15999], 'time_ratio': [[508, 1.06], [1003, 1.17], [2000, 1.46], [3000, 1.17], [3999, 1.72], [6003, 2.81], [8000, 2.22], [11998, 1.19], [15999, 1.72]]}, '64': {'error_factor': 1.04, 'n_range': [508, 15999], 'time_ratio': [[508, 1.07], [1003, 1.03], [2000, 0.999], [3000, 1.01], [3999, 1.51], [6003, 1.02], [8000, 1.2], [11998, 0.69], [15999, 1.03]]}}},
                'FMM p=2 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 2, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[508, 0.3085], [1003, 0.1828], [2000, 0.1259], [3000, 0.1037], [3999, 0.08319], [6003, 0.08149], [8000, 0.07592], [11998, 0.06668], [15999, 0.06668]], 'slope': 0.4647}, 'cost': {'points': [[508, 0.02484], [1003, 0.05969], [2000, 0.1797], [3000, 0.2893], [3999, 0.4261], [6003, 0.8628], [8000, 1.361], [11998, 1.773], [15999, 2.714]], 'slope': 1.48}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.05, 'n_range': [508, 15999], 'time_ratio': [[508, 0.886], [1003, 1.06], [2000, 0.907], [3000, 0.978], [3999, 1.07], [6003, 1.03], [8000, 0.882], [11998, 0.971], [15999, 0.999]]}, '64': {'error_factor': 1.14, 'n_range': [508, 15999], 'time_ratio': [[508, 0.979], [1003, 1.11], [2000, 1.07], [3000, 1.35], [3999, 1.7], [6003, 1.05], [8000, 1.13], [11998, 1.35], [15999, 1.51]]}}},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[508, 0.3084], [1003, 0.1837], [2000, 0.1264], [3000, 0.1044], [3999, 0.08337], [6003, 0.08153], [8000, 0.07538], [11998, 0.0661], [15999, 0.0661]], 'slope': 0.467}, 'cost': {'points': [[508, 0.02773], [1003, 0.06053], [2000, 0.189], [3000, 0.314], [3999, 0.462], [6003, 0.9868], [8000, 1.279], [11998, 2.002], [15999, 2.774]], 'slope': 1.133}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.05, 'n_range': [508, 15999], 'time_ratio': [[508, 1.0], [1003, 1.06], [2000, 0.987], [3000, 1.04], [3999, 1.05], [6003, 1.09], [8000, 1.02], [11998, 1.07], [15999, 1.06]]}, '64': {'error_factor': 1.14, 'n_range': [508, 15999], 'time_ratio': [[508, 0.965], [1003, 1.12], [2000, 1.03], [3000, 1.38], [3999, 1.43], [6003, 0.985], [8000, 1.02], [11998, 1.35], [15999, 1.48]]}}},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.5': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.5, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[508, 0.309], [1003, 0.1846], [2000, 0.1245], [3000, 0.1031], [3999, 0.08221], [6003, 0.08221], [8000, 0.07501], [11998, 0.06439], [15999, 0.06439]], 'slope': 0.4731}, 'cost': {'points': [[508, 0.02984], [1003, 0.06504], [2000, 0.2351], [3000, 0.3335], [3999, 0.5426], [6003, 1.211], [8000, 1.576], [11998, 2.816], [15999, 4.081]], 'slope': 1.289}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.01, 'n_range': [508, 15999], 'time_ratio': [[508, 1.02], [1003, 1.09], [2000, 1.1], [3000, 0.99], [3999, 1.06], [6003, 1.13], [8000, 1.03], [11998, 1.03], [15999, 1.11]]}, '64': {'error_factor': 1.01, 'n_range': [508, 15999], 'time_ratio': [[508, 0.956], [1003, 0.948], [2000, 1.04], [3000, 1.14], [3999, 1.41], [6003, 1.07], [8000, 1.07], [11998, 1.34], [15999, 1.36]]}}},
                'FMM p=3 vis=exact all-pairs s=16 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 16}, 'error': {'points': [[508, 0.3084], [1003, 0.1842], [2000, 0.1243], [3000, 0.1031], [3999, 0.0831], [6003, 0.0831], [8000, 0.07512], [11998, 0.06552], [15999, 0.06552]], 'slope': 0.4675}, 'cost': {'points': [[508, 0.02793], [1003, 0.05794], [2000, 0.2095], [3000, 0.3259], [3999, 0.4363], [6003, 0.9443], [8000, 1.504], [11998, 2.594], [15999, 3.642]], 'slope': 1.179}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.05, 'n_range': [508, 15999], 'time_ratio': [[508, 0.899], [1003, 1.11], [2000, 1.11], [3000, 0.934], [3999, 1.13], [6003, 1.13], [8000, 1.07], [11998, 1.08], [15999, 1.01]]}, '64': {'error_factor': 1.13, 'n_range': [508, 15999], 'time_ratio': [[508, 0.927], [1003, 1.11], [2000, 1.01], [3000, 1.13], [3999, 1.26], [6003, 1.04], [8000, 1.02], [11998, 1.32], [15999, 1.3]]}}},
                'FMM p=3 vis=exact all-pairs s=32 θ=0.3': {'keywords': {'method': 'fmm', 'order': 3, 'theta': 0.3, 'visibility': 'exact', 'visibility_leaf_mode': 'per_pair_all', 'visibility_samples': 32}, 'error': {'points': [[508, 0.309], [1003, 0.1851], [2000, 0.1239], [3000, 0.1028], [3999, 0.08367], [6003, 0.08367], [8000, 0.07529], [11998, 0.06457], [15999, 0.06457]], 'slope': 0.4706}, 'cost': {'points': [[508, 0.02623], [1003, 0.06747], [2000, 0.2318], [3000, 0.3863], [3999, 0.5721], [6003, 1.124], [8000, 1.789], [11998, 2.955], [15999, 4.833]], 'slope': 1.709}, 'n_range': [508, 15999], 'samplings': 2, 'leaf_variants': {'16': {'error_factor': 1.01, 'n_range': [508, 15999], 'time_ratio': [[508, 1.07], [1003, 1.12], [2000, 1.16], [3000, 1.06], [3999, 1.19], [6003, 1.29], [8000, 1.11], [11998, 1.06], [15999, 1.12]]}, '64': {'error_factor': 1.0, 'n_range': [508, 15999], 'time_ratio': [[508, 0.988], [1003, 0.981], [2000, 1.06], [3000, 0.993], [3999, 1.22], [6003, 1.0], [8000, 1.1], [11998, 1.18], [15999, 1.36]]}}},
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


def _probe_error(sub: Surfels, kind: str) -> float:
    """Relative RMS difference (non-emitters) between the direct solutions of ``sub`` without
    and with exact visibility."""
    from .solver import solve as _solve
    # a few per cent is all it needs; one thread: a second costs more than it saves on a few
    # hundred surfels (1.6 -> 1.1 ms and 3.4 -> 2.9 ms on the bunny)
    plain = _solve(sub, method="direct", tol=1e-3, threads=1)
    occluded = _solve(sub, method="direct", tol=1e-3, threads=1, visibility="exact",
                      **visibility_keywords("exact", kind))
    m = ~(sub.emission.max(axis=1) > 0)
    ref = occluded.radiosity[m]
    den = float(np.sqrt(np.mean(ref ** 2))) or 1.0
    return float(np.sqrt(np.mean((plain.radiosity[m] - ref) ** 2))) / den


def occlusion_probe(surfels: Surfels, count: int = PROBE_SURFELS, seed: int = 0,
                    kind: str = "random", decisive: float | None = None) -> dict:
    """How much occlusion changes this scene: relative RMS difference (non-emitters) between
    the direct solutions without and with exact visibility on about ``count`` of its surfels.

    decisive : an error of ``visibility="none"`` that settles the question (the caller's
        choice no longer depends on it beyond that). When given, the probe first runs on
        PROBE_FIRST_SHARE of ``count`` and stops there if it measures at least ``decisive``.

    Returns ``error_none`` (that difference, the error of ``visibility="none"``), ``surfels``
    (of the last stage) and ``seconds``."""
    t0 = time.perf_counter()
    stages = [count]
    first = int(PROBE_FIRST_SHARE * count)
    if decisive is not None and surfels.n > first:
        stages.insert(0, first)
    for size in stages:
        sub = surfels if surfels.n <= size else _probe_subset(surfels, size, seed)
        if not (sub.emission > 0).any():
            return dict(error_none=0.0, surfels=sub.n, seconds=time.perf_counter() - t0)
        err = _probe_error(sub, kind)
        if decisive is not None and err >= decisive:
            break
    return dict(error_none=err, surfels=sub.n, seconds=time.perf_counter() - t0)


# --- choosing ------------------------------------------------------------------------------------

def _kind_table(kind: str) -> dict:
    kinds = CALIBRATION.get("kinds", {})
    for k in (kind, "random", "grid", *kinds):   # the closest calibrated kind
        if k in kinds:
            return kinds[k]
    raise InputError("illumap.accuracy has no calibration (run bench/calibrate.py)")


#: Scene kinds whose error curves are steps between the measured sizes (the value at the
#: measured size below), not log-log interpolations: on grids the error is not monotone in N
#: (grid lines move across shadow and light edges: on the Cornell box 3.25% at 2437 surfels,
#: between 3.16% at 1927 and 2.22% at 4128), and the interpolation missed its 3% target there.
STEP_KINDS = ("grid",)


def _steps(table: dict) -> bool:
    kinds = CALIBRATION.get("kinds", {})
    return any(table is kinds.get(k) for k in STEP_KINDS)


#: Curves as sorted lists with their logarithms, by id (checked against the object itself, so a
#: curve rebuilt at the same address is read afresh): the choice evaluates a few thousand of
#: them per call, and rebuilding the lists each time was most of its cost.
_CURVE_CACHE: dict = {}


def _curve(points) -> tuple:
    """(points, ns, values, log ns, log values) of ``[[n, value], …]``."""
    hit = _CURVE_CACHE.get(id(points))
    if hit is None or hit[0] is not points:
        ns = [float(p[0]) for p in points]
        vs = [float(p[1]) for p in points]
        hit = (points, ns, vs, [math.log(n) for n in ns],
               [math.log(v) if v > 0 else -math.inf for v in vs])
        if len(_CURVE_CACHE) > 4096:
            _CURVE_CACHE.clear()
        _CURVE_CACHE[id(points)] = hit
    return hit


def _loglog(model: dict, n: float, *, error: bool, steps: bool = False) -> float:
    """A calibrated curve at ``n``: log-log interpolation between the measured points (with
    ``steps``, for an error: the value at the largest measured size ≤ n); beyond them the
    model's slope (error ∝ N^-slope, time ∝ N^slope), and below the first point, for time,
    proportional to N."""
    _, ns, vs, lns, lvs = _curve(model["points"])
    if n <= ns[0]:
        return vs[0] * (ns[0] / n) ** model["slope"] if error else vs[0] * n / ns[0]
    if n >= ns[-1]:
        k = -model["slope"] if error else model["slope"]
        return vs[-1] * (n / ns[-1]) ** k
    i = bisect.bisect_right(ns, n) - 1
    if error and steps:
        return vs[i]
    w = (math.log(n) - lns[i]) / (lns[i + 1] - lns[i])
    return math.exp((1 - w) * lvs[i] + w * lvs[i + 1])


def _leaf_factor(entry: dict, n: float) -> float:
    """A leaf variant's error factor against its setting's leaf-32 error at ``n`` (1 for the
    calibrated setting itself): the paired ratio measured at sizes around ``n``; beyond the
    measured sizes never below 1 (a smaller error is credited only where it was seen)."""
    f = float(entry.get("error_factor", 1.0))
    lo, hi = entry.get("factor_range", (0, math.inf))
    return f if lo / 1.5 <= n <= 1.5 * hi else max(f, 1.0)


def _interp_log_n(points, n: float) -> float:
    """``[[n, value], …]`` at ``n``: interpolated in log N, held beyond the ends; 1 if empty."""
    if not points:
        return 1.0
    _, ns, vs, lns, _ = _curve(points)
    if n <= ns[0]:
        return vs[0]
    if n >= ns[-1]:
        return vs[-1]
    i = bisect.bisect_right(ns, n) - 1
    w = (math.log(n) - lns[i]) / (lns[i + 1] - lns[i])
    return (1 - w) * vs[i] + w * vs[i + 1]


def _leaf_time_ratio(entry: dict, n: float) -> float:
    """A leaf variant's time against its setting's leaf-32 time at ``n`` (paired, one run)."""
    return _interp_log_n(entry.get("time_ratio"), n)


def _settings_with_leaves(table: dict):
    """(label, entry) of every calibrated setting and of each of its leaf variants
    (``leaf_variants``, from bench/leaf_size.py): the setting's keywords with that
    ``leaf_size``, its error and cost curves, the variant's ``error_factor`` and
    ``time_ratio``."""
    for label, entry in table["settings"].items():
        yield label, entry
        for leaf, variant in entry.get("leaf_variants", {}).items():
            yield f"{label} leaf={leaf}", dict(
                entry, keywords=dict(entry["keywords"], leaf_size=int(leaf)),
                error_factor=variant["error_factor"], factor_range=variant["n_range"],
                time_ratio=variant["time_ratio"])


def _predicted_time(entry: dict, n: float) -> float:
    return _loglog(entry["cost"], n, error=False) * _leaf_time_ratio(entry, n)


def _predicted_error(entry: dict, table: dict, n: float, e_occlusion,
                     scale: float = 1.0, sampling: bool = True) -> float | None:
    """The model's error of one calibrated setting at ``n`` surfels (None: not usable), its
    discretization part (the direct exact-visibility model) times ``scale`` (an adaptive
    sampling's ratio): what the setting adds to it (expansion, visibility model) stays. A leaf
    variant scales what its setting's error is measured against (the whole error with
    visibility, the expansion error without) by its factor. With ``sampling`` the kind's
    sampling factor scales the discretization part too (what moves from one sampling to
    the next), not what the setting adds."""
    kw = entry["keywords"]
    vis = kw.get("visibility", "none")
    factor = _leaf_factor(entry, n)
    spread = _sampling_factor(table, n) if sampling else 1.0
    if vis != "none":
        e = factor * _setting_error(entry, table, n)
        e_disc = (_discretization(table, n, sampling=False)
                  if scale != 1.0 or spread != 1.0 else None)
        if e_disc is None:
            return e
        e_rest2 = max(0.0, e * e - e_disc * e_disc)
        return math.sqrt((spread * scale * min(e_disc, e)) ** 2 + e_rest2)
    if e_occlusion is None:
        return None
    base = table["settings"].get(table.get("discretization", ""))
    if base is None:
        return None
    e_fmm = 0.0
    if kw["method"] == "fmm":
        row = min((t for t in FMM_ERROR if t >= kw["theta"]), default=max(FMM_ERROR))
        e_fmm = factor * FMM_ERROR[row].get(kw["order"], FMM_ERROR[row][0])
    e_disc = spread * scale * _loglog(base["error"], n, error=True, steps=_steps(table))
    return math.sqrt(e_disc ** 2 + e_fmm ** 2 + e_occlusion ** 2)


def _setting_error(entry: dict, table: dict, n: float) -> float:
    """A setting's calibrated error at ``n``. Beyond its largest measured size only the
    discretization part keeps falling, as the kind's direct curve does; what the setting adds
    there (its expansion and visibility model: sqrt(e² − e_disc²) at that size) is held, as a
    node-pair visibility model at fixed θ and leaf size converges far slower, if at all
    (bench/fmm_against_direct.py, Cornell box at 1927 / 4128 / 8295 surfels: the distance to
    the direct solution of the same surfels is 1.62 / 1.44 / 1.19% with all-pairs s = 16,
    θ = 0.3, and 11.3 / 7.1 / 7.0% in the default leaf mode, while the direct solution's own
    error falls from 3.4 to 1.2%)."""
    curve = entry["error"]
    steps = _steps(table)
    n_max = curve["points"][-1][0]
    base = table["settings"].get(table.get("discretization", ""))
    if n <= n_max or base is None or base["error"] is curve:   # the direct curve itself
        return _loglog(curve, n, error=True, steps=steps)
    e_max = _loglog(curve, n_max, error=True, steps=steps)
    d_max = _loglog(base["error"], n_max, error=True, steps=steps)
    d0 = min(d_max, e_max)   # continuous at n_max (the direct curve may be extrapolated there)
    rest2 = e_max * e_max - d0 * d0
    d = d0 * _loglog(base["error"], n, error=True, steps=steps) / d_max
    return math.sqrt(d * d + rest2)


def _sampling_factor(table: dict, n: float) -> float:
    """The kind's sampling factor at ``n`` (1 without one)."""
    return _interp_log_n(table.get("sampling", {}).get("points"), n)


def _discretization(table: dict, n: float, sampling: bool = True) -> float | None:
    """The kind's discretization model at ``n`` (the direct exact-visibility curve), with its
    sampling factor unless ``sampling`` is False."""
    base = table["settings"].get(table.get("discretization", ""))
    if base is None:
        return None
    e = _loglog(base["error"], n, error=True, steps=_steps(table))
    return e * _sampling_factor(table, n) if sampling else e


def _needed_n(entry, table, target, e_occlusion, n_min, cap, scale=1.0):
    """Smallest N in [n_min, cap] with predicted error <= target (None when none is)."""
    lo = max(n_min, 2)
    if _predicted_error(entry, table, lo, e_occlusion, scale) is None:
        return None
    if _predicted_error(entry, table, lo, e_occlusion, scale) <= target:
        return lo
    if _predicted_error(entry, table, cap, e_occlusion, scale) > target:
        return None
    if _steps(table):   # a step curve first meets the target at a measured size
        for n in sorted({p[0] for p in entry["error"]["points"]}):
            if lo < n <= cap and _predicted_error(entry, table, n, e_occlusion, scale) <= target:
                return int(n)
    hi = cap
    for _ in range(60):   # bisection on log N (the error decreases with N)
        mid = math.sqrt(lo * hi)
        if _predicted_error(entry, table, mid, e_occlusion, scale) <= target:
            hi = mid
        else:
            lo = mid
        if hi / lo < 1.01:
            break
    return int(math.ceil(hi))


def _candidates(table, s, fixed, target, e_occ, n_min, cap, allow_direct, scale=1.0,
                unoccluded_only=False):
    """Every calibrated setting with its N, predicted error and time, and whether it meets
    ``target`` (at the scene's own N when ``fixed``); ``order``: its place among them. With
    ``unoccluded_only`` the settings without visibility alone (the only ones ``e_occ``
    changes)."""
    out = []
    for order, (label, entry) in enumerate(_settings_with_leaves(table)):
        kw = entry["keywords"]
        if kw["method"] == "direct" and not allow_direct:
            continue
        if unoccluded_only and kw.get("visibility", "none") != "none":
            continue
        if fixed:   # the count the target needs is found for the chosen setting only
            n = s["n"]
            err = _predicted_error(entry, table, n, e_occ, scale)
            if err is None:
                continue
            need = None
            ok = err <= target
        else:
            need = _needed_n(entry, table, target, e_occ, n_min, cap, scale)
            n = need if need is not None else cap
            err = _predicted_error(entry, table, n, e_occ, scale)
            if err is None:
                continue
            ok = need is not None
        out.append(dict(label=label, entry=entry, n=n, need=need, error=err, ok=ok,
                        time=_predicted_time(entry, n), order=order))
    return out


def choose_settings(scene, target_error, *, kind: str | None = None, allow_direct: bool = True,
                    max_surfels: int | None = None, min_surfels: int | None = None,
                    probe="auto", discretization_scale: float = 1.0) -> dict:
    """Settings meeting ``target_error`` (relative RMS per surfel) at the least modelled time.

    scene : Surfels (its N is then fixed: the setting is chosen for it, and ``n`` reports the
        count the target needs), or a summary dict with at least ``n`` (surfels available:
        the points of a scan; any large number for meshes) and ``total_area`` (m²).
    target_error : float in (0, 1), or a preset name from :data:`PRESETS`.
    kind : "grid" | "random" | "point_cloud"; default guessed (equal areas → "grid").
    allow_direct : when False, only FMM settings are considered.
    max_surfels : cap on the recommended surfel count (e.g. the points of a scan).
    min_surfels : floor on the recommended surfel count (default: the calibration's n_min).
    discretization_scale : the sampling's discretization error against the uniform one the
        models were fitted on (ADAPTIVE_ERROR_RATIO for an adaptive sampling); it scales the
        discretization part of each setting's error, not what its expansion and visibility
        model add.
    probe : "auto" (default): run :func:`occlusion_probe` on Surfels when a setting without
        visibility would be at least 1/PROBE_GAIN times faster were the scene unoccluded and
        the best setting with visibility is predicted above PROBE_WORTH seconds (below, the
        probe costs about what it could save); True: whenever such a setting could win;
        False: never (``visibility="none"`` is then not chosen); or a probe result to reuse.

    Returns a dict: ``target_error``, ``kind``, ``density`` (surfels per m²), ``n``
    (recommended count), ``method``, ``order``, ``theta``, ``leaf_size``, ``visibility``,
    ``visibility_keywords``, ``solver``, ``tol``, ``label`` (the calibrated setting),
    ``predicted`` (``total`` error and ``discretization``, the setting's error at N),
    ``predicted_time`` (s, calibration machine), ``discretization_scale`` (as given),
    ``probe`` and ``notes``. Pass it to
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
    n_min = min(max(int(table.get("n_min", DEFAULT_N_MIN)), int(min_surfels or 0)), cap)
    probe_info = probe if isinstance(probe, dict) else None

    def rank(e_occ, unoccluded_only=False):
        # aim a little below the target: the fits are of a few sampled scenes
        return _candidates(table, s, fixed, SAFETY * target, e_occ, n_min, cap, allow_direct,
                           float(discretization_scale), unoccluded_only=unoccluded_only)
    candidates = rank(None if probe_info is None else float(probe_info["error_none"]))
    if fixed and (probe is True or probe == "auto"):
        # probe when a setting without visibility could win were the scene unoccluded, and
        # ("auto") when that would save more than the probe costs
        meeting = [c for c in candidates if c["ok"]]
        best_time = min((c["time"] for c in meeting), default=math.inf)
        worth = probe is True or best_time > PROBE_WORTH
        if worth and any(c["ok"] and c["time"] < PROBE_GAIN * best_time
                         for c in rank(0.0, unoccluded_only=True)):
            probe_info = occlusion_probe(scene, kind=s["kind"],
                                         decisive=PROBE_DECISIVE * target)
            # without a probe the settings without visibility were left out; only they change
            candidates = sorted(candidates + rank(float(probe_info["error_none"]),
                                                  unoccluded_only=True),
                                key=lambda c: c["order"])
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
    rho = min(s["albedo_max"], MAX_BOUND_ALBEDO)
    tol = float(min(1e-4, max(1e-8, 0.01 * target * (1 - rho) / 0.2)))
    if fixed:
        need = _needed_n(best["entry"], table, SAFETY * target, e_occ, n_min, 10 ** 9,
                         float(discretization_scale))
        n_out = need or s["n"]
    else:
        n_out = best["n"]
    e_disc = _discretization(table, n_out)
    if e_disc is not None:
        e_disc *= float(discretization_scale)
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
        error_tol=float(f"{SOLVER_ERROR_SHARE * target:.6g}"),
        label=best["label"],
        predicted=dict(total=float(best["error"]), discretization=e_disc,
                       occlusion=e_occ if vis == "none" else None),
        predicted_time=float(best["time"]),
        discretization_scale=float(discretization_scale),
        probe=probe_info,
        notes=notes,
    )


def solve_keywords(settings: dict) -> dict:
    """The ``illumap.solve`` keywords of a :func:`choose_settings` result."""
    kw = dict(method=settings["method"], solver=settings.get("solver", "auto"),
              tol=settings["tol"])
    if settings.get("error_tol") is not None:
        kw["error_tol"] = settings["error_tol"]
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


def _neumann_bound(surfels: Surfels) -> float:
    """1/(1 − ρ_max): how much any error can grow over the bounces (ρ_max at most
    MAX_BOUND_ALBEDO)."""
    return 1.0 / (1.0 - min(float(surfels.albedo.max()), MAX_BOUND_ALBEDO))


def bounce_gain(radiosity, surfels: Surfels, operator: TransportOperator) -> float:
    """How much an error made in one bounce grows over all of them, as the scene's own light
    did: ‖B − E‖ / ‖ρ K E‖ (all indirect light over its first bounce, RMS over the surfels),
    within [1, 1/(1 − ρ_max)]. One application of ``operator``. The bound 1/(1 − ρ_max) holds
    for any error; this gain is that of an error spread like the light (measured 1.4 on the
    Cornell box against 3.6 for the bound)."""
    bound = _neumann_bound(surfels)
    first = _rms(surfels.albedo * operator.apply(surfels.emission))
    if first <= 0.0:
        return bound
    indirect = _rms(np.asarray(radiosity) - surfels.emission)
    return float(min(max(indirect / first, 1.0), bound))


def estimate_error(solution, surfels: Surfels, *, operator: TransportOperator | None = None,
                   probe: int = 256, coarse: bool = False, settings: dict | None = None,
                   kind: str | None = None, seed: int = 0,
                   discretization_scale: float | None = None) -> dict:
    """A-posteriori estimate of the relative RMS error (emitters excluded) of ``solution``.

    * ``solver``: SOLVER_ESTIMATE_MARGIN × the solve's ``stats["solver_error_estimate"]``
      (the bounce gain times ‖r‖/‖B‖ for the final residual r = E − (B − ρ K B), RMS over the
      non-emitting surfels), at most its bound ``stats["solver_error_bound"]`` (1/(1 − ρ_max)
      in place of the gain); without them, the bound from ``final_residual``.
    * ``fmm``: the FMM applied to B against the exact per-pair sum (with the same visibility,
      applied per pair) on ``probe`` random receivers, times ρ, relative to B there, amplified
      by the scene's bounce gain (``gain``: all indirect light over its first bounce,
      ‖B − E‖ / ‖ρ K E‖, within [1, 1/(1 − ρ_max)]; an operator error spreads over the
      bounces as the light does, not as the worst case 1/(1 − ρ_max) bound): expansion error
      plus the visibility classification of node pairs. Zero for a direct solution.
    * ``occlusion``: for ``visibility="none"``, the probe's estimate from ``settings`` (the
      :func:`choose_settings` result), else 0.
    * ``discretization``: with ``coarse=True`` measured on a spatially even half of the surfels
      (e ≈ d/(√2 − 1)); otherwise the calibrated model of the scene kind at this N, times
      ``discretization_scale`` (the models are of uniform density: ADAPTIVE_ERROR_RATIO for an
      adaptive sampling; default: that of ``settings``, else 1), None when there is no
      calibration.
    ``total`` = sqrt of the sum of squares (independent sources); ``numerical`` = solver + fmm.
    """
    t0 = time.perf_counter()
    if discretization_scale is None:
        discretization_scale = (settings or {}).get("discretization_scale", 1.0)
    rng = np.random.default_rng(seed)
    B = np.asarray(solution.radiosity)
    stats = solution.stats
    amplification = _neumann_bound(surfels)
    non_emit = ~(surfels.emission.max(axis=1) > 0)
    if not non_emit.any():
        non_emit = np.ones(surfels.n, bool)
    b_rms = _rms(B[non_emit]) or 1.0
    e_norm = math.sqrt(float(np.sum(surfels.emission ** 2)))
    bound = stats.get("solver_error_bound")
    if bound is not None and math.isfinite(bound):   # the solve's own, over the same surfels
        e_solver = float(bound)
        if stats.get("solver_error_estimate") is not None:
            e_solver = min(e_solver, SOLVER_ESTIMATE_MARGIN * float(stats["solver_error_estimate"]))
    else:
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
    gain = None
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
        gain = bounce_gain(B, surfels, operator)
        e_fmm = _rms(diff) / (_rms(B[rows]) or 1.0) * gain
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
                gain=gain, probe_rows=int(rows.size), seconds=time.perf_counter() - t0)


# --- one call ----------------------------------------------------------------------------------------

def solve(surfels: Surfels, target_error, *, kind: str | None = None, allow_direct: bool = True,
          estimate: bool = True, coarse: bool = False, settings: dict | None = None,
          discretization_scale: float = 1.0, progress=None, **overrides):
    """Choose settings for ``target_error`` (or use ``settings``, a :func:`choose_settings`
    result) and solve ``surfels``; ``stats["accuracy"]`` holds the chosen settings, the solve
    keywords and (``estimate=True``) the a-posteriori estimate. ``discretization_scale``: as
    in :func:`choose_settings` (ADAPTIVE_ERROR_RATIO for the second pass of an adaptive
    sampling). ``overrides`` replace chosen solve keywords (e.g. ``solver="jacobi"``)."""
    from .solver import solve as _solve
    chosen = settings if settings is not None else choose_settings(
        surfels, target_error, kind=kind, allow_direct=allow_direct,
        discretization_scale=discretization_scale)
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
#: measured on the Cornell box's triangles against the 48k-surfel reference
#: (bench/bench_adaptive.py, bench/results/adaptive.json: 1.5k, 3k and 6k surfels, exact
#: visibility): 0.69-0.73 for the direct method, 0.69-0.81 for FMM settings, whose expansion
#: and visibility error the second pass does not lower. It scales the discretization part of a
#: setting's error only; 0.75 there (the direct method's range, rounded up) was optimistic: the
#: automatic mode at 10% chose 3152 surfels and measured 10.2% on the benchmark's sampling
#: (2026-12-01), so it takes the upper end measured for any setting.
ADAPTIVE_ERROR_RATIO = 0.8
#: Solve time of the second pass against a uniform pass of the same count and settings
#: (paired, bench/bench_adaptive.py, bench/results/adaptive.json, 2026-12-02): the median over
#: five settings at each count, interpolated in log N and held beyond. A varying density packs
#: surfels into fewer octree cells, whose near field (per-pair visibility rays) grows:
#: 0.97-1.41 at 1.5k, 0.84-1.37 at 3k, 0.85-1.15 at 6k, 0.97-1.86 at 12k surfels.
ADAPTIVE_TIME_RATIO = [[1447, 1.18], [2873, 0.96], [5731, 1.02], [11422, 1.39]]
#: Two passes run (uncapped) only where predicted at most this share of one uniform pass's
#: time, exp(-rms) of the time models' own error: each setting's largest swept size predicted
#: from the smaller ones (bench/calibrate.py's ``time_holdout``, kept in CALIBRATION: 0.42 rms
#: in log time; 0.66). Twice on the triangles at 5%, two passes predicted at
#: 0.78x one pass's time measured 1.28x and 1.35x, and missed the target on one sampling
#: (5.11%) where one pass met it. 0.7 without a hold-out in the calibration.
ADAPTIVE_TIME_MARGIN = (round(math.exp(-CALIBRATION["time_holdout"]["rms"]), 2)
                        if "time_holdout" in CALIBRATION else 0.7)
#: Fewest surfels for which that ratio is assumed (measured from 2k up; at 1383 surfels, a first
#: pass of 690, the automatic mode's adaptive run got 0.83 of the uniform model's error).
ADAPTIVE_MIN_COUNT = 2000


def choose_mesh_settings(scene: dict, target_error, *, kind: str = "mesh", adaptive: bool = True,
                         max_surfels: int | None = None) -> dict:
    """:func:`choose_settings` for meshes to be sampled (``scene``: a summary dict, ``n``
    any large number and ``total_area`` in m²), as :func:`solve_triangles` and the add-on
    sample them. With ``adaptive`` (two passes: ADAPTIVE_FIRST_SHARE of the count uniformly,
    then the count denser where that solution varies) the models' discretization part is
    scaled by ADAPTIVE_ERROR_RATIO where the count is at least ADAPTIVE_MIN_COUNT (below it a
    first pass is too coarse to find where the illumination varies, so the count is raised to
    it). The two passes' modelled time (pass 1 with the same settings at its share of the
    count, pass 2 scaled by ADAPTIVE_TIME_RATIO as its density varies) must be at most
    ADAPTIVE_TIME_MARGIN times one uniform pass's (within the time models' error one pass is
    the simpler and surer choice); two passes also run where ``max_surfels`` caps the count
    below what one uniform pass needs (they lower the error at that count). The result's
    ``adaptive`` says which (False: one uniform pass), ``discretization_scale`` what the
    models were scaled by (``estimate_error`` and the second pass's :func:`solve` take it
    from there), ``predicted_time`` the total (``predicted_time_passes``: each pass's)."""
    uniform = choose_settings(scene, target_error, kind=kind, max_surfels=max_surfels)
    uniform["adaptive"] = False
    if not adaptive:
        return uniform
    two = choose_settings(scene, target_error, kind=kind, max_surfels=max_surfels,
                          discretization_scale=ADAPTIVE_ERROR_RATIO,
                          min_surfels=ADAPTIVE_MIN_COUNT)
    if two["n"] < ADAPTIVE_MIN_COUNT:   # capped below where the ratio was measured
        two = copy.deepcopy(uniform)
    first = _setting_time(two, ADAPTIVE_FIRST_SHARE * two["n"])   # same settings, its share
    time_ratio = adaptive_time_ratio(two["n"])
    second = time_ratio * two["predicted_time"]
    two["predicted_time_passes"] = [first, second]
    two["predicted_time"] = first + second
    reached = uniform["predicted"]["total"] <= SAFETY * uniform["target_error"] + 1e-12
    if reached and two["predicted_time"] > ADAPTIVE_TIME_MARGIN * uniform["predicted_time"]:
        uniform["notes"].append(
            f"adaptive: one uniform pass ({uniform['predicted_time']:.3g} s) is chosen: two "
            f"passes are predicted at {two['predicted_time']:.3g} s, more than "
            f"{ADAPTIVE_TIME_MARGIN} of it (the adaptive error ratio {ADAPTIVE_ERROR_RATIO} "
            f"from {ADAPTIVE_MIN_COUNT} surfels, pass 2's time ratio {time_ratio:.3g})")
        return uniform
    two["adaptive"] = True
    why = (f"predicted at most {ADAPTIVE_TIME_MARGIN} of one uniform pass's time "
           f"({uniform['predicted_time']:.3g} s)"
           if reached else "one uniform pass of the capped count is predicted to miss the target")
    two["notes"].append(f"adaptive: two passes, the models' discretization error scaled by "
                        f"{two['discretization_scale']:g} (adaptive error ratio "
                        f"{ADAPTIVE_ERROR_RATIO} from {ADAPTIVE_MIN_COUNT} surfels), {why}")
    return two


def adaptive_time_ratio(n: float) -> float:
    """Modelled solve time of an adaptive second pass of ``n`` surfels over a uniform pass's
    (ADAPTIVE_TIME_RATIO at ``n``)."""
    return _interp_log_n(ADAPTIVE_TIME_RATIO, n)


def _setting_time(chosen: dict, n: float) -> float:
    """The modelled time of the setting ``chosen`` (a choose_settings result) at ``n``."""
    entry = dict(_settings_with_leaves(_kind_table(chosen["kind"])))[chosen["label"]]
    return _predicted_time(entry, n)


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
    adaptive : two passes where :func:`choose_mesh_settings` predicts them faster than one
        uniform pass (the uniform-density models' discretization part scaled by
        ADAPTIVE_ERROR_RATIO from ADAPTIVE_MIN_COUNT surfels up); pass 1 solves
        ADAPTIVE_FIRST_SHARE of the count, uniformly; pass 2
        resamples the full count with a density multiplier per region that grows with how
        much pass 1's luminance varies there (``illumap.sampling``), and solves again. Without
        it: one uniform pass of the count chosen for the target.
    keep : optional callable, positions (N, 3) → bool (N,): which samples become surfels
        (e.g. not those inside a closed solid).
    count : samples of the (final) pass instead of the chosen count (a budget: the settings
        and the number of passes are chosen for at most that many surfels).
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
    chosen = choose_mesh_settings(
        dict(n=10 ** 9, total_area=float(areas.sum()), kind=kind, albedo_max=float(rho.max()),
             albedo_mean=float(np.average(rho.mean(axis=1), weights=areas))),
        target, kind=kind, adaptive=adaptive,
        max_surfels=None if count is None else max(int(count), 1))
    adaptive = bool(chosen["adaptive"])
    scale = chosen["discretization_scale"]
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
    info = dict(settings=chosen, solve_keywords=kw, adaptive=bool(adaptive), passes=passes,
                discretization_scale=scale)
    if estimate:
        info["estimate"] = estimate_error(sol, surfels, settings=chosen, kind=kind)
    sol.stats["accuracy"] = info
    return sol, surfels
