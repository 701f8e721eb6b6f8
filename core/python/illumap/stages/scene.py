"""The scene as plain data (DESIGN.md §1): what the add-on reads from Blender, or a Python
caller builds, for ``illumap.run``. Numpy arrays in frozen values; no stage writes into them,
each returns a new value (``Scene`` → ``Lit`` → ``Solved`` → ``Gathered``)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Callable

import numpy as np

from ..settings import Settings

#: ``progress(fraction, phase)``: called during long phases; returns False to cancel.
Progress = Callable[[float, str], "bool | None"]

#: A mesh corner is evaluated this share of the way from its vertex to its triangle's
#: centroid: a hair inside its face (the gather moves it farther where rounding asks).
RECEIVER_INSET = 1e-3


@dataclass(frozen=True)
class Source:
    """Which surfels came from which object, for transfer and reporting."""

    name: str
    kind: str      # 'MESH' | 'POINTS' | 'BACK' (an open surface's or a scan's back faces)
    start: int
    stop: int
    area: float    # m²


@dataclass(frozen=True)
class PointCloud:
    """A point cloud as read, every point a receiver (numpy only): positions and the normals
    it is lit about (P, 3), albedo and emission (P, 3), and the surfel (row in its own
    source) that stands for each point in the solve."""

    name: str
    positions: np.ndarray
    normals: np.ndarray
    albedo: np.ndarray
    emission: np.ndarray
    surfel: np.ndarray


@dataclass
class Receivers:
    """The corners of one object's own mesh, where its ``illumination`` is evaluated: each
    corner is lit at its point (a hair inside its face) with its normal, and has its own
    albedo and emission."""

    name: str
    corner_vertex: np.ndarray      # (L,) int64 vertex of each corner
    points: np.ndarray             # (L, 3) m, world space
    normals: np.ndarray            # (L, 3) unit, world space
    albedo: np.ndarray             # (L, 3) front-face albedo per corner
    emission: np.ndarray           # (L, 3) front-face emission per corner (radiance)
    vertex_count: int
    inward: np.ndarray | None = None   # (L, 3) m, from each corner to its triangle's centroid
    corner_id: np.ndarray | None = None  # (L,) int64 stable identity; None: the row
    # (L, 3) unit geometric normal of each corner's face: its gather drops the directions of
    # the smooth normal's hemisphere below that face, as a renderer does; None: none dropped
    faces: np.ndarray | None = None

    @property
    def ids(self) -> np.ndarray:
        """Each receiver's identity (L,) int64, which its rays follow from."""
        return (np.arange(len(self.points), dtype=np.int64) if self.corner_id is None
                else self.corner_id)

    def per_vertex(self, corner_values: np.ndarray) -> np.ndarray:
        """Mean of the corner values (L, C) of each vertex (V, C); 0 for unused vertices."""
        count = np.bincount(self.corner_vertex, minlength=self.vertex_count).astype(np.float64)
        out = np.zeros((self.vertex_count, corner_values.shape[1]))
        np.add.at(out, self.corner_vertex, corner_values)
        return out / np.maximum(count, 1.0)[:, None]


@dataclass(frozen=True)
class Scene:
    """Everything a run needs, numpy only: the surfels (N rows) with their materials, the
    lights, the scene's surface as triangles, and where the user sees the light (mesh
    corners, point clouds' points).

    Emission that a lamp carries (an emissive mesh sampled as ``emitters``) is in
    ``emission`` but not in ``solve_emission``: the lamp's direct light brings it, and the
    surfels still show it. Which emission a lamp carries is data here (``emission -
    solve_emission``), fixed when the scene is built, not a flag a later step reads."""

    settings: Settings
    positions: np.ndarray          # (N, 3) m
    normals: np.ndarray            # (N, 3) unit
    areas: np.ndarray              # (N,) m²
    albedo: np.ndarray             # (N, 3)
    emission: np.ndarray           # (N, 3) self-emission (radiance)
    solve_emission: np.ndarray     # (N, 3) emission left to the solve (not in a lamp)
    sources: tuple = ()            # Source per part, in row order
    lamps: tuple = ()              # lights.Lamp records
    emitters: tuple = ()           # lights.Lamp 'MESH' records of emissive meshes
    world: Any = None              # lights.Lamp of the world ('WORLD'), or None
    uv: np.ndarray | None = None             # (N, 2) active UV per surfel (NaN: none)
    triangle: np.ndarray | None = None       # (N,) int64 triangle in its mesh (-1: point)
    bary: np.ndarray | None = None           # (N, 3) barycentric coordinates (NaN: point)
    material_index: np.ndarray | None = None  # (N,) int64 material slot (-1: point)
    triangles: np.ndarray | None = None      # (T, 3, 3) the meshes' triangles and splats, m
    two_sided: np.ndarray | None = None      # (T,) bool: its mesh is an open surface
    mesh_triangle_start: np.ndarray | None = None  # first row in ``triangles`` of each mesh
    splat_point: np.ndarray | None = None    # (T,) point (over all clouds) whose splat each
                                             # triangle is, -1: a mesh's own
    clouds: tuple = ()             # PointCloud per point source, as read
    receivers: tuple = ()          # Receivers per mesh whose corners get the light
    occluders: Any = None          # receivers.MeshOccluders on ``triangles``, once built
    accuracy: dict | None = None   # with a target error: the settings the model chose
    refine: Any = None             # the reader's handle for a further pass; None: last pass
    warnings: tuple = ()           # what reading the scene found
    timings: dict = field(default_factory=dict)   # seconds of the reading
    stats: dict = field(default_factory=dict)     # what reading chose (density, thinning)

    @property
    def count(self) -> int:
        """Number of surfels."""
        return len(self.areas)

    @property
    def triangles_occlude(self) -> bool:
        """Whether triangles are this scene's occluders (lamp shadows, exact visibility,
        receivers): the meshes' own and the point clouds' splats."""
        return self.triangles is not None

    @property
    def all_lamps(self) -> list:
        """The lamps and the emissive meshes' lamps, in that order (the world aside)."""
        return list(self.lamps) + list(self.emitters)

    def back_rows(self) -> np.ndarray:
        """bool (N,): the surfels of back faces (open surfaces, scans of unknown side)."""
        back = np.zeros(self.count, dtype=bool)
        for src in self.sources:
            if src.kind == "BACK":
                back[src.start:src.stop] = True
        return back


def with_occluders(scene: Scene, progress: Progress | None = None, phase: str | None = None) -> Scene:
    """``scene`` with its triangles built into a ray-casting scene
    (``illumap.receivers.MeshOccluders``) once; the same scene when it has them or has no
    triangles. ``progress`` hears the build under ``phase`` (default: the lamp shadows')."""
    if scene.occluders is not None or scene.triangles is None or not len(scene.triangles):
        return scene
    from ..lights import PHASE
    from ..receivers import MeshOccluders
    phase = phase or PHASE
    build = None if progress is None else (lambda f, _phase="": progress(0.0, phase))
    return replace(scene, occluders=MeshOccluders(scene.triangles, progress=build))
