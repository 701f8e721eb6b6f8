"""What the add-on holds of a run, numpy only (no bpy, no native core): the job that
``pipeline.prepare`` reads from the scene (the fields of ``illumap.Scene``, which
``pipeline.run`` hands to ``illumap.run``, and the direct light once lit), and the result it
writes. ``pipeline`` and ``output`` read these, so they live below both.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from illumap.settings import Settings

#: ``progress(fraction, phase)``: called during long phases; returns False to cancel.
Progress = Callable[[float, str], "bool | None"]


@dataclass
class Job:
    """Everything ``run`` needs, numpy only (no bpy references)."""

    settings: Settings
    positions: np.ndarray
    normals: np.ndarray
    areas: np.ndarray
    albedo: np.ndarray
    emission: np.ndarray          # self-emission (radiance)
    direct: np.ndarray | None     # albedo × incident lamp/world radiance; None until ``light``
    uv: np.ndarray                # (N, 2) active UV per surfel (NaN: none)
    triangle: np.ndarray          # (N,) int64 triangle of the evaluated mesh (-1: point input)
    bary: np.ndarray              # (N, 3) barycentric coordinates in it (NaN: point input)
    material_index: np.ndarray    # (N,) int64 material slot (-1: point input)
    sources: list                 # illumap.Source per part, in row order
    warnings: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    stats: dict = field(default_factory=dict)   # density choice, shadow rays, adaptive passes
    # Pass 2 of an adaptive run (``next_pass``): the scene as read, for resampling on the main
    # thread. None when there is no further pass.
    refine: object | None = None     # read_scene._Scene
    lamps: list = field(default_factory=list)   # lights.Lamp records, lit by ``light``
    world: object | None = None                 # lights.Lamp of the world ('WORLD'), or None
    # With a target error: the settings the error model chose for the final count
    # (``target_density``); an adaptive pass 1 solves with them.
    accuracy: dict | None = None
    emitters: list = field(default_factory=list)   # lights.Lamp 'MESH' records (emitters.py)
    solve_emission: np.ndarray | None = None       # emission left to surfels (not in a lamp)
    direct_lamps: np.ndarray | None = None         # the part of ``direct`` from lamps and emitters
    # What each surfel's hemisphere meets (illumap.conservation.Hemisphere; set by ``light``
    # where triangles occlude): the world's share of its light and its transport row's bound
    hemisphere: object | None = None
    triangles: np.ndarray | None = None            # (T, 3, 3) every sampled mesh triangle, m
    two_sided: np.ndarray | None = None            # (T,) bool: its mesh is an open surface
    clouds: list = field(default_factory=list)     # illumap.PointCloud per point source
    mesh_triangle_start: np.ndarray | None = None  # first row in ``triangles`` of each mesh
    splat_point: np.ndarray | None = None          # (T,) point (over all clouds) whose splat
                                                   # each triangle is, -1: a mesh's own
    receivers: list = field(default_factory=list)  # illumap.Receivers: the meshes' corners
    occluders: object = None                       # illumap.receivers.MeshOccluders, built once

    @property
    def count(self) -> int:
        """Number of surfels."""
        return len(self.areas)



@dataclass
class Result:
    """A solved job: outgoing radiance per surfel and statistics."""

    radiosity: np.ndarray         # (N, 3) outgoing radiance
    iterations: int
    residuals: list
    converged: bool
    timings: dict[str, float]
    stats: dict
    count: int
    warnings: list[str] = field(default_factory=list)
    object_name: str = ""
    receiver_values: dict = field(default_factory=dict)  # object name → (corners, 3) radiance
    point_receiver_values: dict = field(default_factory=dict)  # point cloud → (points, 3)
    job: "Job | None" = None      # the job of the run's last pass (what ``write`` writes)

    @property
    def residual(self) -> float:
        """Final relative residual: the solver's last iterate's true residual when it reports
        one (``stats['final_residual']``; the result's own is smaller), else the last
        iteration's (nan if none)."""
        final = self.stats.get("final_residual") if isinstance(self.stats, dict) else None
        if final is not None:
            return float(final)
        return float(self.residuals[-1]) if len(self.residuals) else float("nan")
