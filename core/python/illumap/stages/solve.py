"""The solve stage (no bpy): ``Lit`` → ``Solved``. B = E + ρ F V B for the surfels, with the
settings' method and visibility, or with a target error the error models' choice
(``illumap.accuracy``); the surfels' transport rows bounded by their hemispheres where the
light stage measured them."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .choices import SURFEL_COVERAGE, occluder_shape, surfel_target
from .errors import RunError
from .light import Lit
from .scene import Progress


@dataclass(frozen=True)
class Solved:
    """A lit scene solved: the surfels' outgoing radiance, never negative."""

    lit: Lit
    radiosity: np.ndarray          # (N, 3) outgoing radiance (the lamps' emission included)
    iterations: int
    residuals: tuple
    converged: bool
    timings: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)
    warnings: tuple = ()
    #: (N,) bool: surfels whose rows came from their first hits (``Hemisphere.enclosed``:
    #: light reaches them only through a slit, or not at all), or None
    enclosed: np.ndarray | None = None


def scan_surfels(scene) -> np.ndarray | None:
    """(N,) int64: the point cloud (1, 2, … in ``scene.clouds``' order) each surfel stands for
    a point of (both sides of a point), 0 for a mesh's; None when the scene has no cloud."""
    number = {cloud.name: k + 1 for k, cloud in enumerate(scene.clouds)}
    if not number:
        return None
    out = np.zeros(scene.count, dtype=np.int64)
    for src in scene.sources:
        if src.name in number and src.kind in ("POINTS", "BACK"):
            out[src.start:src.stop] = number[src.name]
    return out if out.any() else None


def _solver_call(lit: Lit, progress: Progress | None) -> tuple:
    """(the solve function, its keywords) for this lit scene's settings."""
    import illumap
    scene = lit.scene
    s = scene.settings
    shape = occluder_shape(s)
    if s.target_error is not None:
        from .. import accuracy
        solve = accuracy.solve
        # Surfels always see each other past occluders: the error model's occlusion probe
        # measures how much skipping visibility would cost, which does not prove a scene needs
        # none (an open scene's sphere read 2% bright at Target 3%). The occluders are the
        # shadows' own.
        # The estimate scores every surfel that is not a light: the lamps' direct light that
        # the solve takes as emission is light a receiver sees like any other.
        kwargs = dict(target_error=surfel_target(s), progress=progress, near_field=s.near_field,
                      coverage=SURFEL_COVERAGE, probe=False,
                      scored=~(scene.emission.max(axis=1) > 0))
        if scene.triangles_occlude:
            kwargs["occluder_triangles"] = scene.triangles   # as without a target (below)
            if scene.occluders is not None:   # casts against the gather's ray scene
                kwargs["occluders"] = scene.occluders
        chosen = scene.accuracy or {}
        if scene.refine is not None and chosen:
            # An adaptive pass 1 only finds where the light varies: the final count's settings
            # (chosen for these surfels, the model would buy pass 1 the whole target), and no
            # error estimate.
            kwargs.update(settings=chosen, estimate=False)
        else:
            kwargs.update(kind=chosen.get("kind"),
                          discretization_scale=chosen.get("discretization_scale", 1.0))
    else:
        solve = illumap.solve
        kwargs = dict(method=s.method, solver=s.solver, tol=s.tol,
                      max_iterations=s.max_iterations, progress=progress,
                      near_field=s.near_field)
        if s.method == "fmm":
            kwargs.update(order=s.order, theta=s.theta, leaf_size=s.leaf_size)
        if s.visibility != "none":
            kwargs["visibility"] = s.visibility
        if s.visibility == "exact":
            if scene.triangles_occlude:
                # Meshes only: surfels see each other past the true triangles (what lamp
                # shadows and receivers see too), not past discs that overhang outlines.
                kwargs["occluder_triangles"] = scene.triangles
                if scene.occluders is not None:   # its fill casts against the gather's
                    kwargs["occluders"] = scene.occluders
            else:  # the lamp shadows' occluders
                kwargs.update(coverage=SURFEL_COVERAGE, visibility_shape=shape)
    scan = scan_surfels(scene)
    if scan is not None:
        kwargs["scan_surfels"] = scan
    if lit.hemisphere is not None:
        kwargs["hemisphere_hits"] = lit.hemisphere.hits
        # Surfels that light reaches only through a slit take their rows from first hits.
        kwargs["hemisphere_enclosed"] = lit.hemisphere.enclosed(
            lit.direct_lamps, lit.scene.emission, lit.scene.solve_emission)
        kwargs["hemisphere_links"] = lit.hemisphere.links
    return solve, kwargs


def solve(lit: Lit, progress: Progress | None = None) -> Solved:
    """Solve the lit scene's surfels. Raises the core's Cancelled when ``progress`` returns
    False, RunError on bad input ("input") or a solver failure ("solver")."""
    import illumap
    scene = lit.scene
    s = scene.settings
    try:
        surfels = illumap.Surfels(scene.positions, scene.normals, scene.areas, scene.albedo,
                                  scene.solve_emission + lit.direct)
    except illumap.InputError as exc:
        raise RunError(f"Invalid surfels: {exc}", "input") from None
    solve_, kwargs = _solver_call(lit, progress)
    t0 = time.perf_counter()
    try:
        sol = solve_(surfels, **kwargs)
    except illumap.Cancelled:
        raise
    except illumap.InputError as exc:
        raise RunError(f"Invalid input: {exc}", "input") from None
    except RunError:
        raise
    except Exception as exc:  # noqa: BLE001 - anything from the solver is a solver failure
        raise RunError(f"Solver failed: {type(exc).__name__}: {exc}", "solver") from exc
    timings = dict(lit.timings)
    timings.update({f"solve: {k}": float(v) for k, v in dict(getattr(sol, "timings", {}) or {}).items()})
    timings["solve"] = time.perf_counter() - t0
    warnings = list(lit.warnings)
    if not sol.converged:
        reason = (getattr(sol, "stats", None) or {}).get("warning")
        warnings.append(f"Solver did not converge in {sol.iterations} iterations "
                        f"(residual {float(sol.residuals[-1]) if len(sol.residuals) else float('nan'):.3g})"
                        + (f": {reason}" if reason else "")
                        + "; the result is written but is not the converged light")
    # The emission that lamps carried is still what those surfels send to the eye.
    radiosity = np.asarray(sol.radiosity, dtype=np.float64) + (scene.emission - scene.solve_emission)
    if not np.all(np.isfinite(radiosity)):
        raise RunError("Solver returned non-finite values", "solver")
    # Light is never negative: what the approximations leave below 0 (a few surfels of
    # interpenetrating solids) is 0, here and at the receivers (``passes``).
    negative = int((radiosity < 0).any(axis=1).sum())
    np.maximum(radiosity, 0.0, out=radiosity)
    stats = dict(getattr(sol, "stats", {}) or {})
    stats.update(lit.stats)
    shape = occluder_shape(s)
    stats["occluder_shape"] = shape
    if s.visibility == "exact":
        stats["visibility_occluders"] = ("triangles" if "occluder_triangles" in kwargs
                                         else f"{stats.get('visibility_shape', shape)}s")
    stats["negative_surfels"] = negative
    return Solved(lit=lit, radiosity=radiosity, iterations=int(sol.iterations),
                  residuals=tuple(sol.residuals), converged=bool(sol.converged),
                  timings=timings, stats=stats, warnings=tuple(warnings),
                  enclosed=kwargs.get("hemisphere_enclosed"))
