"""Automatic accuracy: the user asks for an error, Illumap chooses how to get it cheaply.

``choose_settings(scene, target_error)`` turns a target error (relative RMS per surfel, emitters
excluded, against a converged reference with exact visibility, as in bench/calibration/accuracy_speed.py)
into settings: surfel count (density), method (direct or FMM), expansion order p, opening angle
theta, leaf size, visibility mode (``none``, ``seed`` or ``exact``) and solver tolerance.

The error models are calibrated on the benchmarks (bench/calibration/accuracy_speed.py, fitted by
bench/calibration/calibrate.py into data/calibration.json, loaded as
``calibration.CALIBRATION``): for each scene kind ("grid": meshes sampled on
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

Leaf size: each FMM setting was swept with leaves of 32 surfels; bench/calibration/leaf_size.py solves the
same surfels with leaves of 16 and 64 right after, and each setting's ``leaf_variants`` keep the
worst paired error ratio (``error_factor``, credited below 1 only at the sizes measured) and the
paired time ratios against N. A variant is a candidate like any setting: smaller leaves move
node pairs from the near field (per-pair visibility) to the classified far field, larger ones
the other way, so the leaf size trades error against time differently per scene and size.

Sampling: the curves are of the calibration's samplings; another sampling of the same scene
at the same N and settings lands elsewhere (up to 1.25× on a mesh, more on random surfels).
Each kind's ``sampling`` factor (bench/calibration/sampling_spread.py: errors of a near-exact setting on six
further samplings over the model, fitted by bench/calibration/calibrate.py to exp(mean + SAMPLING_Z·sd) of
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
``Solution.stats["accuracy"]`` (``illumap.solve(surfels, target_error=…)`` calls it).

Modules, one job each: ``calibration`` (the measured tables), ``models`` (error and time
models), ``inputs`` (targets, presets, scene summaries), ``probe`` (the occlusion probe),
``choice`` (``choose_settings``), ``estimate`` (``estimate_error``), ``automatic`` (``solve``:
choose, solve, estimate), ``adaptive`` (meshes in one or two passes: ``choose_mesh_settings``,
``solve_triangles``). This package re-exports their public names.
"""

from .adaptive import (ADAPTIVE_ERROR_RATIO, ADAPTIVE_FIRST_SHARE, ADAPTIVE_MAX_RATIO,
                       ADAPTIVE_MIN_COUNT,
                       ADAPTIVE_TIME_MARGIN, ADAPTIVE_TIME_RATIO, adaptive_time_ratio,
                       choose_mesh_settings, solve_triangles)
from .automatic import solve
from .calibration import (EXACT_KEYWORDS, FMM_ERROR, KINDS, SAMPLING_Z, SETTING_VISIBILITY_KEYS,
                          visibility_keywords)
from .choice import SAFETY, SOLVER_ERROR_SHARE, choose_settings, solve_keywords
from .estimate import SOLVER_ESTIMATE_MARGIN, bounce_gain, estimate_error
from .inputs import NO_SURFEL_LIMIT, TARGET_PRESETS, scene_summary
from .probe import PROBE_FIRST_SHARE, PROBE_SURFELS, occlusion_probe

__all__ = ["choose_settings", "choose_mesh_settings", "solve_keywords", "estimate_error", "solve",
           "solve_triangles", "scene_summary", "occlusion_probe", "visibility_keywords",
           "adaptive_time_ratio", "bounce_gain",
           "FMM_ERROR", "EXACT_KEYWORDS", "TARGET_PRESETS", "KINDS", "NO_SURFEL_LIMIT", "SAFETY",
           "SAMPLING_Z", "SETTING_VISIBILITY_KEYS", "SOLVER_ERROR_SHARE", "SOLVER_ESTIMATE_MARGIN",
           "PROBE_SURFELS", "PROBE_FIRST_SHARE", "ADAPTIVE_FIRST_SHARE", "ADAPTIVE_MAX_RATIO",
           "ADAPTIVE_ERROR_RATIO",
           "ADAPTIVE_TIME_RATIO", "ADAPTIVE_TIME_MARGIN", "ADAPTIVE_MIN_COUNT"]
