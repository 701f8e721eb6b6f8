"""The surfels whose disc reaches through another surface, evaluated as receivers are (no
bpy): their solved values scatter where the light is smooth, and a receiver at the line where
the surfaces meet sees them at close range."""

from __future__ import annotations

import numpy as np

from ..stages.scene import Scene
from .ids import back_field_normals, surfel_ids


def regather_straddling(scene: Scene, direct: np.ndarray | None, radiosity: np.ndarray, occ,
                        sent: np.ndarray, back: np.ndarray, owners, back_owners, rays: int,
                        background, sides, back_rows=None,
                        enclosed: np.ndarray | None = None) -> tuple[int, np.ndarray]:
    """Evaluate the surfels whose disc reaches through another surface
    (``illumap.receivers.straddling_surfels``: a floor's along a wall, a crease's in a scan)
    as receivers are: their direct light plus a gather of the other surfels' light. Their
    solved values scatter by tens of percent where the light is smooth, and a receiver at the
    line where the surfaces meet sees them at close range. Their direct light is the lamps'
    and emitters' (``direct``: ``Lit.direct_lamps``); the world's comes through the gather's rays that
    leave the scene (``background``); ``sides``: ``gather_sides``; ``back_rows``: the back
    field's surfels (``back_field_rows``; default those in ``back``). ``enclosed`` (N,) bool:
    the surfels whose solved rows came from their first hits (``Solved.enclosed``): those
    in ``back`` keep their solved values; None: none.
    Updates ``sent`` in place; returns how many were evaluated and the surfels' outgoing
    radiance with theirs (``radiosity``, the solved one, itself when none was)."""
    from .. import receivers as rc
    if direct is None:
        return 0, radiosity
    bad = rc.straddling_surfels(scene.positions, scene.normals, scene.areas)
    evaluated = bad.copy()
    if enclosed is not None:
        # An enclosed back surfel (the inside of an open part that another part closes:
        # Suzanne's head behind its eyes) keeps its row of first hits (``sealing``); a gather
        # from its disc's centre, on the line where the other part passes through, finds
        # light that the sealed surfels round it do not (one in Suzanne's socket solved
        # 0.026 and gathered 0.37, against Cycles' 0.003 round it). It stays out of the
        # fields the others gather from, as before (in them, the intersecting boxes'
        # furnace read 0.48% for 0.46%). Enclosed front surfels are re-evaluated still:
        # kept as solved too, the bench Suzanne read 1.071% for 1.064%.
        evaluated &= ~(np.asarray(enclosed, dtype=bool) & back)
    rows = np.flatnonzero(evaluated)
    if not rows.size or bad.all():
        return 0, radiosity

    def good_field(side, normals, owner_rows):
        """The field of this side's surfels (rows ``side``, their ``normals``) that are not
        re-evaluated, and splat owners (rows of the whole side's field) as rows of it."""
        good = ~bad[side]
        if not good.any():
            return None, None if owner_rows is None else np.full_like(owner_rows, -1)
        remap = np.full(len(side), -1, dtype=np.int64)
        remap[good] = np.arange(int(good.sum()))
        own = (None if owner_rows is None
               else np.where(owner_rows >= 0, remap[np.maximum(owner_rows, 0)], -1))
        rows_ = side[good]
        # Walled-off points read dark on meshes; a scan's splats, with the re-evaluated
        # surfels left out, wall off points that are lit (dark there too, the white furnace
        # read scan_normals 1.15% for 0.92%, scan 1.59% for 1.55%).
        return rc.SurfelField(scene.positions[rows_], normals[good], sent[rows_],
                              light_field=owners is None and back_owners is None), own

    front = np.flatnonzero(~back)
    front_field, own_front = good_field(front, scene.normals[front], owners)
    if back_rows is None:
        back_rows = np.flatnonzero(back)
    back_field_, own_back = (good_field(back_rows, back_field_normals(scene, back, back_rows),
                                        back_owners)
                             if len(back_rows) else (None, None))
    if front_field is None:
        return 0, radiosity
    # The triangles no good surfel stands for (the re-evaluated surfels' splats, the meshes'
    # own) are tabulated only where that takes fewer lookups than the rays (a dense scan's
    # straddling surfels stand for hundreds of thousands of splat triangles).
    untabled = sum(int((o < 0).sum()) for o in (own_front, own_back) if o is not None) \
        if own_front is not None else 2 * len(scene.triangles)
    g = rc.gather(occ, front_field, scene.positions[rows], scene.normals[rows], rays=rays,
                  seed=scene.settings.seed, ids=surfel_ids(scene)[rows],
                  background=background, back_field=back_field_, two_sided=sides, owners=own_front,
                  back_owners=own_back, tabulate=3 * untabled <= rows.size * rays)
    sent[rows] = scene.solve_emission[rows] + direct[rows] + scene.albedo[rows] * g.radiance
    radiosity = radiosity.copy()
    radiosity[rows] = sent[rows] + scene.emission[rows] - scene.solve_emission[rows]
    return int(rows.size), radiosity
