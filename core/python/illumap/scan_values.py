"""The values at a scan's points after the gather: specks (isolated points whose value the
gather's noise left far from their neighbours') replaced, each smooth patch's outward side
chosen as a whole, and the faces that meet at a crease point (numpy and the native neighbour
search; used by the add-on's light at the receivers)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .pointcloud import plane_through
from .receivers import _rows3
from .refinement import LUMINANCE_WEIGHTS


#: Neighbours a point's light is compared with by ``remove_specks``.
SPECK_NEIGHBOURS = 8
#: Neighbours count as the same surface when |cos| between the normals is at least this.
SPECK_MIN_COS = 0.5
#: A speck lies below (1 − SPECK_RATIO) × the darkest, or above the brightest ÷ (1 −
#: SPECK_RATIO), of its same-surface neighbours (by luminance), beyond SPECK_FLOOR × the
#: cloud's median luminance.
SPECK_RATIO = 0.25
SPECK_FLOOR = 0.02


def remove_specks(points, normals, values, *, k: int = SPECK_NEIGHBOURS,
                  neighbours: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Values at scan points with isolated specks replaced: (values (P, 3), specks replaced).

    A point evaluated on a splat model can come out far darker than everything around it (a
    neighbour's splat, tilted by scan noise, shadows it) or far brighter (light through a
    hole in the splats reaches a side that faces into the object). Light varies smoothly
    along a surface except across shadow edges, and a point on a shadow edge has neighbours
    on both sides of it. So a point whose luminance lies outside the range of all its
    same-surface neighbours (``k`` nearest with |n·n'| ≥ ``SPECK_MIN_COS``, at least four of
    them) by ``SPECK_RATIO`` is a speck and takes the value of its median neighbour; points on
    shadow edges, gradients and extremes of smooth light keep theirs. Positions in metres,
    values in any radiance unit. ``neighbours`` (P, k + 1): the points' own k + 1 nearest
    (``_core.knn(points, points, k + 1)``, as ``ScanPatches.neighbours`` holds them), not
    searched again.
    """
    p = _rows3("points", points)
    n = _rows3("normals", normals, len(p))
    v = _rows3("values", values, len(p))
    if len(p) <= 4:
        return v.copy(), 0
    kk = int(min(k, len(p) - 1))
    if neighbours is not None and np.shape(neighbours) == (len(p), kk + 1):
        idx = np.asarray(neighbours)[:, 1:]
    else:
        idx, _ = _core.knn(p, p, kk + 1)
        idx = np.asarray(idx)[:, 1:]
    lum = v @ LUMINANCE_WEIGHTS
    same = np.abs(np.einsum("pc,pkc->pk", n, n[idx])) >= SPECK_MIN_COS
    neighbour = np.where(same, lum[idx], np.nan)
    count = same.sum(axis=1)
    with np.errstate(all="ignore"):
        lo = np.nanmin(np.where(count[:, None] > 0, neighbour, 0.0), axis=1)
        hi = np.nanmax(np.where(count[:, None] > 0, neighbour, 0.0), axis=1)
    floor = SPECK_FLOOR * float(np.median(lum))
    speck = (count >= 4) & ((lum < (1 - SPECK_RATIO) * lo - floor) |
                            (lum > hi / (1 - SPECK_RATIO) + floor))
    out = v.copy()
    rows = np.flatnonzero(speck)
    if len(rows):
        # The same-surface neighbour of median luminance (others sort last).
        keyed = np.where(same[rows], neighbour[rows], np.inf)
        order = np.argsort(keyed, axis=1)
        pick = order[np.arange(len(rows)), (count[rows] - 1) // 2]
        out[rows] = v[idx[rows, pick]]
    return out, int(len(rows))


#: Neighbours that join a smooth patch: k nearest with |n·n'| at least PATCH_MIN_COS (~25°).
PATCH_NEIGHBOURS = 8
PATCH_MIN_COS = 0.9


def outward_sides(points, normals, front, back, *, k: int = PATCH_NEIGHBOURS) -> np.ndarray:
    """Which side of each two-sided scan point faces out: (P,) bool, True where ``normals``
    do (``front``, the light seen along them, is kept), False where ``back`` is.

    A scan without normals cannot tell the inside of a room from the outside of a statue, so
    both sides are evaluated. Choosing point by point lets one stray ray decide: light seeping
    through a hole in the splats makes the inward side of a few points brighter than their
    shadowed outer side, which then read lit. A patch (``ScanPatches``) has one outside: the
    side that receives more light over the whole patch. A wall of a room, a face of a box,
    the smooth body of a scanned object each decide as one; a lone point decides for itself.
    """
    return ScanPatches(points, normals, k=k).sides(front, back)[0]


#: A patch's side is settled by a probe when the light of its two sides differs by this
#: many standard errors of the probe's gather ...
SIDE_SETTLED_SIGMAS = 4.0
#: ... and by this share of the two together (a gather that found no spread can still be off).
SIDE_SETTLED_SHARE = 0.05


class ScanPatches:
    """The smooth patches of a scan's points: points joined through ``k``-nearest neighbours
    whose normals agree to ``PATCH_MIN_COS``, oriented consistently along those links (where
    orientation carries reliably). Each patch has one outside (``outward_sides``)."""

    def __init__(self, points, normals, *, k: int = PATCH_NEIGHBOURS):
        p = _rows3("points", points)
        n = _rows3("normals", normals, len(p))
        if len(p) < 2:
            self.part = np.zeros(len(p), dtype=np.int64)
            self.along_front = np.ones(len(p), dtype=bool)
            self.neighbours = None
            return
        kk = int(min(k, len(p) - 1))
        idx, _ = _core.knn(p, p, kk + 1)
        idx = np.asarray(idx, dtype=np.int64)
        #: (P, k + 1) each point's nearest, itself among them: ``remove_specks`` takes them
        #: too, rather than search the same neighbours again
        self.neighbours = idx
        smooth = np.abs(np.einsum("pc,pkc->pk", n, n[idx])) >= PATCH_MIN_COS
        idx = np.ascontiguousarray(np.where(smooth, idx, np.arange(len(p))[:, None]))
        oriented, part = _core.orient_normals(p, n, idx)
        #: (P,) bool: the patch's common orientation runs along the point's normal
        self.along_front = np.einsum("pc,pc->p", np.asarray(oriented), n) > 0
        #: (P,) int: the patch of each point
        self.part = np.asarray(part, dtype=np.int64)

    def sides(self, front, back, front_noise=None, back_noise=None,
              rows=None) -> tuple[np.ndarray, np.ndarray]:
        """(side, settled), (P,) bool each. ``side``: True where the point's normal faces out
        (see ``outward_sides``), from the radiance ``front`` and ``back`` (P, 3) seen along
        and against the normals. ``settled``: where the patch's two sides differ by
        ``SIDE_SETTLED_SIGMAS`` standard errors and ``SIDE_SETTLED_SHARE`` of their sum, given
        each value's standard error ``front_noise``, ``back_noise`` (P,) in luminance; all
        False without them. ``rows`` (M,): the values are those of these points only (a
        patch none of them lies in is neither side's and not settled)."""
        part = self.part if rows is None else self.part[rows]
        along_front = self.along_front if rows is None else self.along_front[rows]
        parts = int(self.part.max()) + 1 if len(self.part) else 0
        lum_f = _rows3("front", front, len(part)) @ LUMINANCE_WEIGHTS
        lum_b = _rows3("back", back, len(part)) @ LUMINANCE_WEIGHTS
        along = np.bincount(part, np.where(along_front, lum_f, lum_b), minlength=parts)
        against = np.bincount(part, np.where(along_front, lum_b, lum_f), minlength=parts)
        side = (along >= against)[self.part] == self.along_front
        if front_noise is None or back_noise is None:
            return side, np.zeros(len(side), dtype=bool)
        var = np.bincount(part, np.asarray(front_noise, dtype=np.float64) ** 2
                          + np.asarray(back_noise, dtype=np.float64) ** 2, minlength=parts)
        gap = np.abs(along - against)
        settled = (gap > SIDE_SETTLED_SIGMAS * np.sqrt(var)) & \
            (gap > SIDE_SETTLED_SHARE * (along + against))
        return side, settled[self.part]

    def sample(self, share: float, whole: int, most: int | None = None) -> np.ndarray:
        """Points (ascending rows) that stand for their patches: every point of a patch of at
        most ``whole`` points, about ``share`` of a larger one's (every 1/share-th in row
        order), at least ``whole`` of each; with ``most``, about that many at most of each
        (every ceil(size / most)-th): a wall of a dense scan decides its side on its sums as
        well from thousands of points as from hundreds of thousands."""
        order = np.argsort(self.part, kind="stable")
        sizes = np.bincount(self.part)
        starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        rank = np.empty(len(order), dtype=np.int64)
        rank[order] = np.arange(len(order)) - starts[self.part[order]]
        size = sizes[self.part]
        stride = np.maximum(1, np.minimum(np.rint(1.0 / share), size // max(whole, 1))).astype(np.int64)
        if most is not None:
            stride = np.maximum(stride, -(-size // max(int(most), 1)))
        return np.flatnonzero(rank % stride == 0)


#: Neighbours searched for the surfaces that meet at a scan point.
CREASE_NEIGHBOURS = 12
#: The point lies on a neighbour's surface when within CREASE_ON_PLANE × the median
#: neighbour distance of the neighbour's tangent plane.
CREASE_ON_PLANE = 0.2
#: Normals that agree to this cosine (~25°) are one surface ...
CREASE_SAME_COS = 0.9
#: ... which needs this many neighbours (one stray normal is noise; the point's own counts).
CREASE_MIN_VOTES = 2
#: Groups of normals looked for around a point: a box corner has three faces and three edges.
CREASE_MAX_SURFACES = 6
#: A face's value is taken this far (× the median neighbour distance) into the face, and as
#: far off it.
CREASE_INSET = 0.03
#: An edge lies in a face when the sine of the angle between them is below this (~10°).
CREASE_EDGE_SIN = 0.17


@dataclass
class Creases:
    """The surfaces that meet at scan points, for :func:`crease_surfaces`."""

    rows: np.ndarray          # (E,) int64 points with a face to evaluate, ascending
    normals: np.ndarray       # (E, 3) that surface's unit outward normal
    points: np.ndarray        # (E, 3) m, where to evaluate it: a hair into and off the face
    own: np.ndarray           # (P,) bool: the point is lit by its own normal (not a crease)

    def mean(self, own_values: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Each point's light (P, C): the mean over its surfaces of ``own_values`` (P, C), lit
        along its own normal, and ``values`` (E, C), lit along ``normals``."""
        out = np.where(self.own[:, None], own_values, 0.0)
        np.add.at(out, self.rows, values)
        count = self.own + np.bincount(self.rows, minlength=len(own_values))
        return out / np.maximum(count, 1)[:, None]


def crease_surfaces(points, normals, *, k: int = CREASE_NEIGHBOURS, albedo=None,
                    progress=None) -> Creases:
    """The faces that meet at each scan point on a crease, to light it by instead of the
    point's own outward ``normals`` (P, 3). Positions in metres.

    A point on the edge of a box lies on two faces (three at a corner), while its fitted
    normal is one face's, or a tilt between them. What a scanner records there, like what a
    mesh vertex shared by those faces shows, is the mean of the faces' light; so the point is
    evaluated once per face, with that face's normal, a hair into and off the face (as a
    mesh corner is lit a hair inside its face): from the crease line itself, rays along one
    face would start on the other's plane and pass through it. The faces are the groups of
    agreeing normals (``CREASE_SAME_COS``, at least ``CREASE_MIN_VOTES`` each) among the
    neighbours whose tangent plane the point lies on, each face's normal that of the plane
    through the point and the group's points; a group whose points lie on a line through the
    point (the edge's own points, their fits tilted between the faces) is no face. A point
    near an edge but not on it lies on one face's planes only and keeps its own value.
    Concave creases count as convex ones do; so do twins (points at the same position, where
    two scanned objects touch), which cannot be told apart by place and both take the faces'
    mean. Their colour can tell them apart: given the points' ``albedo`` (P, 3), a point
    leaves out the faces whose points are all of another colour (``CREASE_OTHER_COLOUR``: a
    red wall's point where it meets a white floor takes the wall's light alone), unless all
    its faces are; one surface scanned with noisy colour, or a checkered floor's twin (the
    floor has its colour too), takes them all.
    ``progress(fraction, phase)`` hears each chunk of points (phase "creases"); returning
    False or raising cancels with ``illumap.Cancelled``.
    """
    from ._progress import ProgressGuard
    guard = ProgressGuard(progress)
    p = _rows3("points", points)
    n = _rows3("normals", normals, len(p))
    colour = None if albedo is None else _rows3("albedo", albedo, len(p))
    P = len(p)
    nothing = Creases(np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3)),
                      np.ones(P, dtype=bool))
    if P <= CREASE_MIN_VOTES:
        return nothing
    kk = int(min(k, P - 1))
    idx, dist = _core.knn(p, p, kk + 1)
    idx, dist = np.asarray(idx, dtype=np.int64), np.asarray(dist)
    crease = np.zeros(P, dtype=bool)
    found = []
    for lo in range(0, P, _CREASE_CHUNK):
        guard.check(lo / P, "creases")
        rows = np.arange(lo, min(lo + _CREASE_CHUNK, P))
        rows = rows[_may_crease(p, n, rows, idx[rows], dist[rows])]
        if len(rows):
            found.append(_crease_faces(p, n, rows, idx[rows], dist[rows], crease, colour))
    r = np.concatenate([f[0] for f in found]) if found else np.zeros(0, dtype=np.int64)
    if len(r) == 0:
        return nothing
    return Creases(r, np.concatenate([f[1] for f in found]),
                   np.concatenate([f[2] for f in found]), ~crease)


#: Points grouped at once by ``crease_surfaces`` (~60 MB of neighbour offsets at k = 12).
_CREASE_CHUNK = 32768


def _may_crease(p, n, rows, idx, dist) -> np.ndarray:
    """Which of the points ``rows`` ``_crease_faces`` can find on a crease: a second face
    needs a neighbour whose tangent plane the point lies on and whose normal the point's own
    does not share (its first group is the point's own normal's). Points missing from their
    own neighbours (twins) are always looked at. The rest, most of a scan, lie on one face."""
    me = idx == rows[:, None]
    scale = np.median(dist[:, 1:], axis=1)
    nb_n = n[idx]
    offsets = p[idx] - p[rows, None, :]
    free = me | (np.abs(np.einsum("pkc,pkc->pk", offsets, nb_n)) <= CREASE_ON_PLANE * scale[:, None])
    # a hair of margin: a neighbour on the boundary is looked at, whichever way it rounds
    differ = np.einsum("pkc,pc->pk", nb_n, n[rows]) < CREASE_SAME_COS + 1e-9
    return ~me.any(axis=1) | (free & differ).any(axis=1)


def _crease_faces(p, n, rows, idx, dist, crease, colour=None) -> tuple:
    """``crease_surfaces`` for the points ``rows`` (their ``idx``, ``dist``: k + 1 nearest,
    themselves included): marks ``crease[rows]`` and returns (point, face normal, where to
    evaluate) per face of a crease point."""
    me = idx == rows[:, None]
    scale = np.median(dist[:, 1:], axis=1)
    nb_n = n[idx]                                                        # (R, k + 1, 3)
    offsets = p[idx] - p[rows, None, :]
    free = me | (np.abs(np.einsum("pkc,pkc->pk", offsets, nb_n)) <= CREASE_ON_PLANE * scale[:, None])
    # Group the normals: the point's own first, then the nearest left.
    G = CREASE_MAX_SURFACES
    R = len(rows)
    local = np.arange(R)
    mean_normal = np.zeros((R, G, 3))
    members = np.zeros((R, G, idx.shape[1], 3))          # each group's offsets, 0 elsewhere
    in_group = np.zeros((R, G, idx.shape[1]), dtype=bool)
    found = np.zeros((R, G), dtype=bool)
    key = np.where(me, -1.0, dist)
    for g in range(G):
        left = free.any(axis=1)
        seed = np.argmin(np.where(free, key, np.inf), axis=1)
        member = free & (np.einsum("pc,pkc->pk", nb_n[local, seed], nb_n) >= CREASE_SAME_COS)
        total = (member[..., None] * nb_n).sum(axis=1)
        length = np.linalg.norm(total, axis=1)
        found[:, g] = left & (member.sum(axis=1) >= CREASE_MIN_VOTES) & (length > 0)
        mean_normal[:, g] = total / np.maximum(length, 1e-300)[:, None]
        members[:, g] = member[..., None] * offsets
        in_group[:, g] = member
        free &= ~member
    faces, on_line = plane_through(members)
    faces *= np.where(np.einsum("pgc,pgc->pg", faces, mean_normal) < 0, -1.0, 1.0)[..., None]
    face = found & ~on_line
    er, en, eat = _corner_faces(p, rows, face.any(axis=1), face, faces, found & on_line,
                                mean_normal, members, scale)
    mine = face.sum(axis=1) + np.bincount(er, minlength=len(rows)) >= 2
    crease[rows] = mine
    keep = mine[er]
    er, en, eat = er[keep], en[keep], eat[keep]
    r, g = np.nonzero(face & mine[:, None])
    centre = members[r, g].sum(axis=1)
    length = np.linalg.norm(centre, axis=1)
    inward = centre / np.maximum(length, 1e-300)[:, None]
    # A face whose points lie all around the point (twins where scans meet, a room's corner)
    # gives no direction. Where the corner's faces are known in full (one was found through
    # its edge), into it is away from the others: behind their planes at a convex crease (the
    # neighbours lie behind the point's own normal), in front of them at a concave one.
    short = np.flatnonzero((length < 0.5 * scale[r]) & np.isin(r, er))
    if short.size:
        others = np.zeros((len(rows), 3))
        np.add.at(others, np.concatenate([r, er]), np.concatenate([faces[r, g], en]))
        side = np.where(np.einsum("pkc,pc->p", offsets, n[rows]) > 0, 1.0, -1.0)
        rs = r[short]
        v = side[rs, None] * (others[rs] - faces[rs, g[short]])
        v -= np.einsum("ec,ec->e", v, faces[rs, g[short]])[:, None] * faces[rs, g[short]]
        norm = np.linalg.norm(v, axis=1, keepdims=True)
        inward[short] = np.where(norm > 1e-12, v / np.maximum(norm, 1e-300), inward[short])
    _open_side(inward, r, g, face & mine[:, None], faces, members, er, en, scale)
    # A hair off the face too: near an edge the neighbours' splats tilt a little, and from
    # the face's exact plane a receiver would start behind them.
    at = p[rows[r]] + CREASE_INSET * scale[r, None] * (inward + faces[r, g])
    keep = np.ones(len(r), dtype=bool) if colour is None else \
        _faces_of_own_colour(colour, rows, idx, r, in_group[r, g], offsets[r], scale[r])
    r, g, at = r[keep], g[keep], at[keep]
    out = np.concatenate([rows[r], rows[er]]).astype(np.int64)
    order = np.argsort(out, kind="stable")
    return out[order], np.concatenate([faces[r, g], en])[order], np.concatenate([at, eat])[order]


#: A face is of another colour than a crease point when every one of its points' albedos
#: differs from the point's by more than this in some channel (scan noise stays below it).
CREASE_OTHER_COLOUR = 0.1


def _faces_of_own_colour(colour, rows, idx, r, member, offsets, scale) -> np.ndarray:
    """Which found faces (E,) a crease point keeps by colour (``crease_surfaces``): all but
    those of another colour (``CREASE_OTHER_COLOUR``; itself and its twins, at its position,
    left out), unless all are. A surface of one colour scanned with noise, or a checkered
    floor (which has both colours), is never another colour. ``r``: each face's row among
    ``rows``; ``member`` (E, k + 1): the face's points among the row's neighbours ``idx``;
    ``offsets`` (E, k + 1, 3) m, theirs from the point."""
    use = member & (np.linalg.norm(offsets, axis=2) > 1e-6 * scale[:, None])
    apart = np.abs(colour[idx[r]] - colour[rows[r]][:, None, :]).max(axis=2)
    other = np.where(use, apart, np.inf).min(axis=1) > CREASE_OTHER_COLOUR
    own = np.bincount(r, ~other, minlength=len(rows)) > 0
    return ~other | ~own[r]


def _open_side(inward, r, g, face, faces, members, er, en, scale) -> None:
    """Point each face that goes on past the point into its open part, in place: where
    another face of the point rests on it or crosses it (a block standing on a floor,
    intersecting parts), the face's points lie on both sides of the other's plane, and only
    the side the other faces is open; evaluated the other way (into the block) it reads
    dark. ``inward`` (E, 3): the direction into each face (``r``, ``g``: its point and group)
    so far; ``er``, ``en``: the faces ``_corner_faces`` inferred."""
    if not len(r):
        return
    towards = np.zeros((len(r), 3))
    margin = CREASE_ON_PLANE * scale[r]

    def add(entries, normal, ok):
        side = np.einsum("ekc,ec->ek", members[r[entries], g[entries]], normal)
        both = ok & (side > margin[entries, None]).any(axis=1) & \
            (side < -margin[entries, None]).any(axis=1)
        np.add.at(towards, entries[both], normal[both])

    every = np.arange(len(r))
    for h in range(face.shape[1]):                      # the other faces found at the point
        add(every, faces[r, h], face[r, h] & (g != h))
    lo = np.searchsorted(r, er, side="left")            # the inferred ones (r is sorted)
    hi = np.searchsorted(r, er, side="right")
    for step in range(face.shape[1]):
        pick = lo + step < hi
        if pick.any():
            add(lo[pick] + step, en[pick], np.ones(int(pick.sum()), dtype=bool))
    own = faces[r, g]
    towards -= np.einsum("ec,ec->e", towards, own)[:, None] * own
    length = np.linalg.norm(towards, axis=1, keepdims=True)
    moved = length[:, 0] > 0.1
    inward[moved] = towards[moved] / length[moved]


def _corner_faces(p, rows, mine, face, faces, line, line_normal, members, scale) -> tuple:
    """Faces of an edge or corner that ``_crease_faces`` missed (looked for at the rows
    ``mine``): a face's own points may all lie beyond the nearest neighbours, but the edge
    it shares with a face found there does not (a group of points on a line through the
    point, their fitted normals halfway between the two faces). The missing face's normal
    is the found one's mirrored about that edge's normal. Returns (row index into ``rows``,
    normal, where to evaluate)."""
    G = face.shape[1]
    out_r, out_n, out_at = [], [], []
    known = np.where(face[..., None], faces, 0.0)                      # (R, G, 3)
    for l in range(G):
        for f in range(G):
            c = np.einsum("rc,rc->r", line_normal[:, l], faces[:, f])
            ok = mine & line[:, l] & face[:, f] & (c > 0.5) & (c < CREASE_SAME_COS)
            if not ok.any():
                continue
            other = 2.0 * c[:, None] * line_normal[:, l] - faces[:, f]
            other /= np.maximum(np.linalg.norm(other, axis=1, keepdims=True), 1e-300)
            # The edge: its points' offsets, all on one side of the point (not twins at it),
            # and in both faces' planes.
            edge = members[:, l].sum(axis=1)
            length = np.linalg.norm(edge, axis=1)
            along = edge / np.maximum(length, 1e-300)[:, None]
            ok &= length > 0.5 * scale
            ok &= (np.abs(np.einsum("rc,rc->r", along, other)) < CREASE_EDGE_SIN) & \
                  (np.abs(np.einsum("rc,rc->r", along, faces[:, f])) < CREASE_EDGE_SIN)
            new = ok & (np.einsum("rgc,rc->rg", known, other).max(axis=1) < CREASE_SAME_COS)
            i = np.flatnonzero(new)
            if not i.size:
                continue
            # Into the new face: along the edge, and behind the found face's plane where the
            # faces meet convexly (in front of it where concavely).
            along = along[i]
            convex = np.einsum("rkc,rc->r", members[i, f], other[i]) < 0
            inward = along + np.where(convex, -1.0, 1.0)[:, None] * faces[i, f]
            inward -= np.einsum("rc,rc->r", inward, other[i])[:, None] * other[i]
            inward /= np.maximum(np.linalg.norm(inward, axis=1, keepdims=True), 1e-300)
            out_r.append(i)
            out_n.append(other[i])
            out_at.append(p[rows[i]] + CREASE_INSET * scale[i, None] * (inward + other[i]))
            # The inferred face counts for the next groups' check.
            slot = np.argmin(np.abs(known[i]).sum(axis=2), axis=1)
            known[i, slot] = other[i]
    if not out_r:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3))
    return np.concatenate(out_r), np.concatenate(out_n), np.concatenate(out_at)
