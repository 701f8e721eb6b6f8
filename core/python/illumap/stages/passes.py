"""One run, as values (no bpy): ``Scene`` → ``Lit`` → ``Solved`` → ``Gathered``, and the one
loop over a run's passes. An adaptive run solves a first pass to find where the light varies;
its reader (``next_pass``: the add-on resamples its meshes, on Blender's main thread) makes
the scene of the next pass from it. The last pass's light is evaluated where the user sees
it (``illumap.gather``).

The operator, the batch command and Python callers all run this loop (``run``)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ..gather import receive
from ..settings import check
from .choices import occluder_shape
from .errors import RunError
from .light import Lit, check_light, light
from .scene import Progress, Scene
from .scene import with_occluders
from .solve import Solved, solve

#: ``next_pass(solved) -> Scene | None``: the scene of the pass after ``solved`` (whose scene
#: has ``refine`` set), or None to end the run with this pass.
NextPass = Callable[[Solved], "Scene | None"]


@dataclass(frozen=True)
class Gathered:
    """A run's result: the surfels' light and the light at the receivers (outgoing radiance,
    3 channels, never negative)."""

    solved: Solved
    radiosity: np.ndarray          # (N, 3) the surfels' (straddling ones evaluated afresh)
    corners: dict = field(default_factory=dict)   # mesh object name → (L, 3) per corner
    points: dict = field(default_factory=dict)    # point cloud name → (P, 3) per point
    timings: dict = field(default_factory=dict)   # seconds of every phase
    stats: dict = field(default_factory=dict)
    warnings: tuple = ()

    @property
    def scene(self) -> Scene:
        """The scene of the last pass (with its occluders built)."""
        return self.solved.lit.scene


def run(scene: "Scene | Lit", progress: Progress | None = None, *,
        next_pass: NextPass | None = None) -> Gathered:
    """Light, solve and gather ``scene``: every pass (the adaptive first pass, then the
    scene ``next_pass`` makes from it), then the light at the receivers of the last. A
    ``Lit`` scene starts at its solve.
    Without ``next_pass`` the run ends with the scene given: a first pass (``refine`` set)
    is then solved only, its ``Gathered`` holding the surfels' light and no receivers.

    Raises the core's Cancelled when ``progress`` returns False, NoLight when no light
    reaches any surface (nothing is solved), RunError on bad input or a failed solve,
    SettingsError on settings the core cannot run."""
    settings = (scene.scene if isinstance(scene, Lit) else scene).settings
    check(settings)
    occluder_shape(settings)   # an unknown shape is refused before any work
    lit = scene if isinstance(scene, Lit) else light(scene, progress)
    scene = None   # the lit scene holds what the passes need; this frame holds nothing more
    while True:
        solved = solve_lit(lit, progress)
        if lit.scene.refine is None:   # the last pass: the light where the user sees it
            return gather(solved, progress)
        following = None if next_pass is None else next_pass(solved)
        if following is None:
            return Gathered(solved=solved, radiosity=solved.radiosity, timings=solved.timings,
                            stats=solved.stats, warnings=solved.warnings)
        lit = light(following, progress)


def solve_lit(lit: Lit, progress: Progress | None = None) -> Solved:
    """``solve`` after refusing a scene that no light reaches (``check_light``)."""
    check_light(lit)
    return solve(lit, progress)


def gather(solved: Solved, progress: Progress | None = None) -> Gathered:
    """The light at the receivers of a solved scene (``illumap.gather.receive``): its corners'
    and points' values, checked finite and clipped at 0, with a warning for closed meshes
    lit only from inside."""
    lit = solved.lit
    if lit.scene.occluders is None:   # released during the solve (``run``): built again
        lit = replace(lit, scene=with_occluders(lit.scene, progress, "gather"))
        solved = replace(solved, lit=lit)
    scene = lit.scene
    estimate = (solved.stats.get("accuracy") or {}).get("estimate", {}).get("total")
    try:
        light_ = receive(scene, lit.direct, lit.direct_lamps, solved.radiosity, progress,
                         surfel_estimate=estimate, enclosed=solved.enclosed)
    except Exception as exc:  # noqa: BLE001
        from .._progress import Cancelled
        if isinstance(exc, (Cancelled, RunError)):
            raise
        raise RunError(f"Evaluating the light at the receivers failed: "
                       f"{type(exc).__name__}: {exc}", "solver") from exc
    timings = dict(solved.timings) | light_.timings
    stats = dict(solved.stats)
    if light_.stats is not None:
        stats["receivers"] = light_.stats
    corners = {name: _final(name, values) for name, values in light_.corners.items()}
    points = {name: _final(name, values) for name, values in light_.points.items()}
    stats["negative_receivers"] = int(sum(n for _, n in corners.values())
                                      + sum(n for _, n in points.values()))
    warnings = list(solved.warnings) + list(light_.warnings)
    dark = lit_only_inside(scene, light_.radiosity)
    if dark:
        warnings.append(dark)
    return Gathered(solved=solved, radiosity=light_.radiosity,
                    corners={k: v for k, (v, _) in corners.items()},
                    points={k: v for k, (v, _) in points.items()},
                    timings=timings, stats=stats, warnings=tuple(warnings))


def _final(name: str, values: np.ndarray) -> tuple[np.ndarray, int]:
    """A receiver set's values as written, never negative, and how many were negative; a
    non-finite value is a failure, and nothing is written."""
    if not np.all(np.isfinite(values)):
        bad = int((~np.isfinite(values)).any(axis=1).sum())
        raise RunError(f"Evaluating the light at '{name}' gave {bad} non-finite "
                       "value(s): nothing was written", "solver")
    negative = int((values < 0).any(axis=1).sum())
    return np.maximum(values, 0.0), negative


def lit_only_inside(scene: Scene, radiosity: np.ndarray) -> str | None:
    """A warning for closed meshes that no light reaches although a lamp or an emitter lies
    within their bounds: their normals face out while the light is inside them, and Illumap,
    as a renderer does for a closed surface, takes the inside of a closed mesh for its back,
    which is never lit. Cycles would light the back faces; flipping the normals does here."""
    two_sided = {src.name for src in scene.sources if src.kind == "BACK"}
    lit_by = [(lamp.name, lamp.position[None] if lamp.triangles is None
               else lamp.triangles.mean(axis=1)) for lamp in scene.all_lamps
              if lamp.kind != "WORLD" and lamp.kind != "SUN"]
    names = []
    for src in scene.sources:
        if src.kind != "MESH" or src.name in two_sided or src.stop <= src.start:
            continue
        rows = slice(src.start, src.stop)
        if radiosity[rows].max() > 0 or scene.emission[rows].max() > 0:
            continue
        lo, hi = scene.positions[rows].min(axis=0), scene.positions[rows].max(axis=0)
        inside = [name for name, at in lit_by if name != src.name
                  and np.any(np.all((at > lo) & (at < hi), axis=1))]
        if inside:
            names.append((src.name, inside[0]))
    if not names:
        return None
    obj, light_name = names[0]
    more = f" (and {len(names) - 1} more)" if len(names) > 1 else ""
    return (f"Object '{obj}'{more} is closed and receives no light, while '{light_name}' lies "
            "inside it: its normals face outward, and the inside of a closed mesh is its back, "
            "which Illumap does not light (Cycles would). Flip its normals (Edit Mode, Mesh > "
            "Normals > Flip) to light it from inside")
