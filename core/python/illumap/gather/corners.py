"""The mesh corners as receivers (no bpy): each moved clear of the ray engine's rounding
inside its face, and the corners of one vertex that see the same light evaluated once."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import lights
from ..stages.scene import RECEIVER_INSET


#: A corner lies this many times the ray engine's rounding (``MeshOccluders.rounding``) inside
#: its triangle, at least RECEIVER_INSET and at most RECEIVER_INSET_MAX of the way to its
#: centroid.
ROUNDING_CLEARANCE = 4.0
RECEIVER_INSET_MAX = 0.05


def clear_of_rounding(occ, rec):
    """``rec`` with each corner moved far enough inside its triangle that its rays meet a
    wall standing on its edge: at a room's corner the adjacent wall is as near as the corner
    is inside its face, and rays skip the first ``occ.rounding`` of their way (more, the
    farther the scene reaches from its centre: 20 m out a corner 3e-5 inside saw past the
    wall and read 20% dark)."""
    if rec.inward is None or len(rec.points) == 0:
        return rec
    reach = np.linalg.norm(rec.inward, axis=1)
    share = np.clip(ROUNDING_CLEARANCE * occ.rounding(rec.points) / np.maximum(reach, 1e-300),
                    RECEIVER_INSET, RECEIVER_INSET_MAX)
    points = rec.points + (share - RECEIVER_INSET)[:, None] * rec.inward
    # A corner whose lifted ray origin lies beyond another surface (a floor's vertex under
    # a sphere's pole, where the pole's fan rises 0.1 m per metre: the origin 3e-5 m up lay
    # inside the sphere, and the vertex read 0 where Cycles bakes the wedge at 0.86) starts
    # RECEIVER_INSET_MAX of the way in instead, where the wedge has opened.
    blocked = lift_blocked(occ, points, rec.normals)
    if blocked.any():
        points[blocked] = rec.points[blocked] + (RECEIVER_INSET_MAX - RECEIVER_INSET) \
            * rec.inward[blocked]
    return replace(rec, points=points)


#: A surface met between a receiver and its lifted ray origin nearer to the origin than this
#: share of the lift is another surface, not the receiver's own (met at the full lift).
LIFT_CLEAR = 0.9


def lift_blocked(occ, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """bool (M,): receivers whose ray origin, lifted ``occ.offset`` along the normal, lies
    beyond another surface: a ray cast back from it meets a triangle before the receiver's
    own plane (which lies ``occ.offset`` back along the normal, whatever the shading)."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    n = np.asarray(normals, dtype=np.float64)
    tri, dist, _ = occ.intersect(points + occ.offset * n, -n, tmax=occ.offset)
    return (tri >= 0) & (dist < LIFT_CLEAR * occ.offset)


def merged_corners(occ, rec, lamps_=(), pressed=None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which corners of ``rec`` share one evaluation: corners of one vertex with one normal
    (a flat grid's four) see the same light unless a wall stands on the vertex between them
    or a shadow edge runs through it, so each joins the first such corner when a ray between
    their points (lifted off the surface) is free and, for each of ``lamps_`` (the world
    aside), a shadow ray from each point to the lamp's centre (a sun's central direction)
    finds both lit or both shadowed. A box standing on a floor's grid lines, lit along them,
    puts its shadow's edge through the floor's vertices: the corners on either side of it,
    all the lead's, had read the vertex fully lit or fully dark, where it is half lit.
    ``pressed`` (a callable: bool per corner of the rows it is given): corners another
    surface lies against. A vertex one of whose corners is pressed has a solid standing on it
    (a box's corner on a floor's vertex), and the ray between its other corners grazes that
    solid's edge, which rounding decides: its corners are evaluated each in its own face.
    A corner whose rays stop at its face (``rec.faces``: a smooth normal off its triangle)
    sees its own share of the hemisphere: the joined corners of each face plane are a row of
    their own, which casts no rays of its own but takes its caster's (the lead's row) in its
    own face (``Gatherer.gather``'s ``shares``): one gather per vertex, as many values as
    face planes. Returns (the rows to evaluate, each corner's row among them, each row's
    caster among them: itself where it casts its own rays)."""
    empty = np.zeros(0, dtype=np.int64)
    if len(rec.points) == 0:
        return empty, empty, empty
    key = np.column_stack([rec.corner_vertex, np.round(rec.normals * 1e5).astype(np.int64)])
    _, group = np.unique(key, axis=0, return_inverse=True)
    group = group.ravel()
    # The lead is the corner of least identity, not the first in Blender's loop order, which
    # changes from session to session: the vertex is then evaluated inside the same face.
    by_group = np.lexsort((rec.ids, group))
    starts = np.flatnonzero(np.r_[True, np.diff(group[by_group]) != 0])
    lead = by_group[starts][group]
    others = np.flatnonzero(lead != np.arange(len(lead)))
    joined = np.arange(len(lead))
    if others.size and pressed is not None:
        shared = np.unique(np.concatenate([lead[others], others]))
        touched = np.zeros(len(lead), dtype=bool)
        touched[shared] = pressed(shared)
        solid = np.zeros(int(group.max()) + 1, dtype=bool)
        solid[group[touched]] = True
        others = others[~solid[group[others]]]
    if others.size:
        lift = occ.offset * rec.normals
        free = occ.visible(rec.points[lead[others]] + lift[lead[others]],
                           rec.points[others] + lift[others]) > 0
        for lamp in lamps_:
            if lamp.kind == "WORLD" or not free.any():
                continue
            pair = others[free]
            ends = np.unique(np.concatenate([lead[pair], pair]))   # a lead once, not per pair
            lit = np.zeros(len(lead), dtype=bool)
            grazing = np.zeros(len(lead), dtype=bool)
            lit[ends], cos = _toward_lamp_centre(occ, lamp, rec.points[ends], rec.normals[ends],
                                                 with_cos=True)
            grazing[ends] = cos < GRAZING_COS
            split = (lit[lead[pair]] != lit[pair]) & ~grazing[lead[pair]] & ~grazing[pair]
            free[np.flatnonzero(free)[split]] = False
        joined[others[free]] = lead[others[free]]
    return face_rows(rec, joined)


def face_rows(rec, joined: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows of ``merged_corners`` from each corner's lead (``joined``, itself where it
    joins none): the corners of one lead in one face plane (``rec.faces``; None: the normal)
    are one row, led by the corner of least identity (the lead's own row: the lead), and
    each row's caster is its lead's row."""
    faces = rec.normals if getattr(rec, "faces", None) is None else rec.faces
    key = np.column_stack([joined, np.round(faces * 1e5).astype(np.int64)])
    _, plane = np.unique(key, axis=0, return_inverse=True)
    plane = plane.ravel()
    by_plane = np.lexsort((rec.ids, plane))
    starts = np.flatnonzero(np.r_[True, np.diff(plane[by_plane]) != 0])
    own = by_plane[starts][plane]
    rows, index = np.unique(own, return_inverse=True)
    return rows, index.ravel(), np.searchsorted(rows, joined[rows])


#: A lamp whose centre a receiver sees within asin(this) of its own plane (0.6°) sends it
#: under 1% of its light head-on, and its shadow ray grazes the surface: its answer flips with
#: the last bit of the scene's placement (an emitter 1 mm under a ceiling split the corners
#: of two ceiling vertices in one placement and not in another, 0.9% apart). Corners do not
#: split on it.
GRAZING_COS = 0.01


def _toward_lamp_centre(occ, lamp, points: np.ndarray, normals: np.ndarray, *,
                        with_cos: bool = False):
    """bool (M,): whether one shadow ray from each receiver to the middle of ``lamp`` (its
    samples' pattern at its centre: a sun's central direction, an area lamp's centre) is
    free, cast as the receivers' shadow rays are; ``with_cos``: and the cosine (M,) between
    each receiver's normal and the direction to that centre."""
    centre = np.full((len(points), 1, 2), 0.5)
    targets, _ = lights._lamp_samples(lamp, points, normals, 1, centre,
                                     4.0 * max(occ.extent, 1e-3))
    targets = targets.reshape(-1, 3)
    query = occ.segment_query(normals)
    lit = np.asarray(query(points, targets, np.arange(len(points)))) > 0
    if not with_cos:
        return lit
    to = targets - points
    cos = np.einsum("ij,ij->i", to, normals) / np.maximum(np.linalg.norm(to, axis=1), 1e-300)
    return lit, cos
