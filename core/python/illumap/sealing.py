"""Enclosed surfels: the ones that the light of the sky and the lamps reaches only through a
slit, or not at all, and the first-hit transport that lights them without leaks.

Light reaches a surfel only along a path of first hits: from the sky, a lamp or an emitter, to
a surface that sees it, to a surface that sees that one, and so on. The hemisphere rays that
bound each transport row (``conservation.hemisphere_hits``) already find those first hits;
``LINK_RAYS`` of each surfel's hits on lit faces are given to the surfels that carry them
(``resolve_hits``), and the pairs (ray's surfel, hit's surfel) make a sparse first-hit
transport W (``Links``: row i holds surfel i's hit share, spread over the surfels its rays met).
A surfel whose own sky share reaches ``THRESHOLD``, or that a lamp lights or that emits, is a
source: its row is left empty (``Hemisphere.enclosed`` casts the linking rays of the others
only, once the direct light is known), so that in a scene under the sky or under lamps few
rays need a surfel found for them.

A part of the scene that no path joins to a source is sealed (the inside of a closed part):
its light is exactly 0. A part joined only through a slit (the pocket behind Suzanne's eyes,
whose rims leave a hair's breadth to the head) is nearly so: Cycles reads it 0.002-0.016 in a
white furnace at albedo 0.999, because the slit lets in about 1e-5 of what the pocket absorbs.
The kernel's rows couple neighbours across an intersection line with a leak of about 1%, and
a pocket that leaks 1% reads 0.9. So the light a white scene carries in ``BOUNCES`` bounces
of W from the sources is followed (``reach``); where it stays under ``THRESHOLD`` of the
sky's the surfel is enclosed, and its row of the operator is its row of W, which leaks only
where its rays do (``TransportOperator(hemisphere_enclosed=, hemisphere_links=)``). A deep
slot with an open mouth is reached within a few dozen bounces and keeps its kernel row.

A hit is given to the nearest surfel that faces the side it was hit on and that sees the hit
point along a path bent off the surface (``LINK_CLEARANCE``), so that a hit on a triangle that
runs under a rim into a pocket does not take a surfel on the far side of the rim. A scan's
bumpy splats hide many hit points from the surfels beside them: a surfel whose row of W is
mostly unknown (``KNOWN_SHARE``) is never enclosed.

A hit that no surfel sees is given to its own part's nearest surfel facing the hit side, seen
or not (``Parts.resolve``; a part is a set of a mesh's triangles joined at corners), where
that surfel is itself enclosed along the hits that surfels do see (``Links.spare``): the
socket round Suzanne's eyes looks, a few mm off, into the back of an eyeball whose surfels
that face it lie behind the head's surface, and a hit left to no surfel keeps the socket's
kernel row, which leaks (0.7 where Cycles reads 0.002). A lit surfel is never taken so: the
eyeball's inside looks at the socket, whose nearest head surfel lies outside the eye, lit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Rays per surfel, of its hemisphere's rays, whose hits are given to surfels (every
#: (64 / this)-th of its lattice, which spread over the whole hemisphere).
LINK_RAYS = 16
#: Surfels whose linking rays are cast in one batch.
CHUNK = 65536
#: Surfels considered for a hit: its nearest this many.
LINK_NEIGHBOURS = 8
#: Facing candidates tested for visibility, nearest first, before a hit is left unlinked.
LINK_TRIES = 3
#: A surfel faces a hit's side when its normal's cosine with the side's normal exceeds this.
LINK_SIDE_COS = 0.3
#: The path from a hit to its surfel bends this share of their distance off the surfaces, so
#: that a surface lying closer over them than that (the rim of an eyeball in its socket)
#: separates them: a straight path lifted only a ray offset off the surface slips under such
#: a rim into the pocket beyond.
LINK_CLEARANCE = 0.25
#: Surfels of the hit's part considered for a hit that no surfel sees: its nearest this many.
PART_NEIGHBOURS = 32
#: A surfel's first-hit row is known when at least this share of its linking rays that met a
#: lit face found the surfel there.
KNOWN_SHARE = 0.5
#: Bounces of the first-hit transport that carry a white scene's light from its sources. In
#: 128, the bottom of a slot 20 times deeper than wide is reached to 0.57, one 10 times to
#: 0.95, the inside of a box through a slit of a twentieth of its lid to 0.67; Suzanne's
#: pockets stay under 0.1 (4,700 surfels below 0.05 in 64 bounces, 50 between 0.05 and 0.8).
BOUNCES = 128
#: A surfel whose reached light stays under this share of the sky's is enclosed (the
#: Suzanne furnace reads 6.4% at 0.05 or 0.2 in 64 bounces, 6.5% at 0.1 in 128; 21% at 0.01).
#: 8 rays per surfel read it 6.43% as 16 do, at 0.42 s of linking on the window scene, not
#: 1.1, but enclose 23 surfels in the gap under the bunny scan with normals, whose sparse
#: first-hit rows read it darker (5.3% -> 5.9%; 12 rays 6.0%): LINK_RAYS stays 16.
THRESHOLD = 0.1


@dataclass
class Links:
    """The first-hit transport of one set of hemisphere rays: ``(W r)_i = Σ_k weights_k
    r_{cols_k}`` over the entries k with ``rows_k = i``; each surfel's weights sum to its hit
    share (the share of its rays that met a lit face), dimensionless."""

    rows: np.ndarray      # (M,) int64
    cols: np.ndarray      # (M,) int64
    weights: np.ndarray   # (M,) float64
    #: (N,) bool: surfels most of whose linking rays that met a lit face found its surfel
    #: (a scan's bumpy splats can hide a hit point from the surfel beside it).
    known: np.ndarray
    #: s spent casting and resolving the linking rays (``link_rays``) and the reach.
    seconds: float = 0.0
    #: The resolved rays (``links``' ``src``, ``dst``; -1: none), each surfel's hit share,
    #: and for each ray that no surfel sees the surfel of its part that would carry it
    #: (``Parts.resolve``; -1: none), taken where that surfel is enclosed (``enclosed``).
    src: np.ndarray | None = None
    dst: np.ndarray | None = None
    hits: np.ndarray | None = None
    spare: np.ndarray | None = None

    def apply(self, r: np.ndarray) -> np.ndarray:
        """W r for r (N,)."""
        return np.bincount(self.rows, self.weights * r[self.cols], minlength=len(r))


def resolve_hits(occluders, positions: np.ndarray, normals: np.ndarray, hits: np.ndarray,
                 sides: np.ndarray, *, k: int = LINK_NEIGHBOURS,
                 tries: int = LINK_TRIES) -> np.ndarray:
    """The surfel (M,) int64 that carries each hit point ``hits`` (M, 3, m) on a face whose
    lit side has unit normal ``sides`` (M, 3): the nearest of its ``k`` nearest surfels
    (``positions``, ``normals`` (N, 3)) that faces that side and sees the hit point past
    ``occluders`` (``receivers.MeshOccluders``); -1 where none of the first ``tries`` facing
    ones does."""
    from . import _core
    m = len(hits)
    out = np.full(m, -1, dtype=np.int64)
    if m == 0 or len(positions) == 0:
        return out
    k = min(int(k), len(positions))
    near, _ = _core.knn(positions, np.ascontiguousarray(hits), k)
    near = near.reshape(m, k)
    facing = np.einsum("mkc,mc->mk", normals[near], sides) > LINK_SIDE_COS
    lifted = hits + occluders.offset * sides
    # Each try takes the nearest facing candidate left in each row and strikes it off where
    # it does not see the hit: only the rows still open are indexed (a window scene's 290k
    # linking hits, most of them settled by their first candidate).
    todo = np.flatnonzero(facing.any(axis=1))
    for _ in range(int(tries)):
        if len(todo) == 0:
            break
        first = np.argmax(facing[todo], axis=1)
        has = facing[todo, first]
        todo, first = todo[has], first[has]
        cand = near[todo, first].astype(np.int64)
        target = positions[cand] + occluders.offset * normals[cand]
        seen = (occluders.visible(lifted[todo], target) > 0.5 if LINK_CLEARANCE <= 0.0
                else _sees(occluders, lifted[todo], target, sides[todo], normals[cand]))
        out[todo[seen]] = cand[seen]
        facing[todo[~seen], first[~seen]] = False
        todo = todo[~seen]
    return out


def link_rays(occluders, positions, normals, origins, ids, seed: int, count: int, lit_backs,
              hits, rows, *, faces=None, triangles=None) -> Links:
    """The first-hit transport (``Links`` over all N surfels) of the surfels ``rows``: every
    (count / ``LINK_RAYS``)-th ray of each one's hemisphere lattice (``receivers.
    cosine_directions`` with ``ids`` and ``seed``, as ``conservation.hemisphere_hits`` casts
    them from ``origins``, lifted) whose first hit is a lit face (front, or a back where
    ``lit_backs`` (T,) says so; None: all) is given to the surfel there (``resolve_hits``).
    ``hits`` (N,): each surfel's hit share, which its row spreads. ``faces`` (N, 3): each
    surfel's face normal (0: none), below which its rays meet nothing
    (``conservation.hemisphere_hits``). ``triangles`` (N,): the occluder triangle each
    surfel lies on (-1: none); a hit no surfel sees then goes to its part's
    (``resolve_on_parts``)."""
    import time
    from . import receivers as rc
    begin = time.perf_counter()
    rows = np.asarray(rows, dtype=np.int64).reshape(-1)
    picked = np.arange(0, count, max(1, count // LINK_RAYS))      # spread over the lattice
    part_of = None               # built at the first hit that needs it (1M triangles: ~3 s)
    if triangles is not None:
        triangles = np.asarray(triangles, dtype=np.int64).reshape(-1)
    src, dst = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    spare = [np.zeros(0, np.int64)]
    for start in range(0, len(rows), CHUNK):
        chunk = rows[start:start + CHUNK]
        dirs = rc.cosine_directions(normals[chunk], count, ids[chunk], seed)[:, picked]
        dirs = np.ascontiguousarray(dirs.reshape(-1, 3))
        o = np.repeat(origins[chunk], len(picked), axis=0)
        tri, dist, front = occluders.intersect(o, dirs)
        met = tri >= 0
        lit = met if lit_backs is None else met & (front | lit_backs[np.maximum(tri, 0)])
        if faces is not None:
            f = faces[chunk]
            lit &= ((np.einsum("mkc,mc->mk", dirs.reshape(len(chunk), -1, 3), f) > 0.0)
                    | ~f.any(axis=1)[:, None]).ravel()
        ray = np.flatnonzero(lit)
        # The hit triangles' unit normals only (all of a scan's splats: 0.3 GB, and twice
        # that in temporaries, at 1M points).
        corners = occluders.corners[tri[ray]]
        tn = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        tn /= np.maximum(np.linalg.norm(tn, axis=1), 1e-300)[:, None]
        side = tn * np.where(front[ray], 1.0, -1.0)[:, None]
        at = o[ray] + dist[ray, None] * dirs[ray]
        src.append(chunk[ray // len(picked)])
        got = resolve_hits(occluders, positions, normals, at, side)
        other = np.full(len(got), -1, dtype=np.int64)
        # A scan's points keep to the hits they see: the floor under a bunny scan, dark
        # along seen hits, is lit through hundreds of bounces (scan_normals 3.08 -> 3.10%).
        lost = (np.zeros(0, np.int64) if triangles is None else
                np.flatnonzero((got < 0) & (triangles[chunk[ray // len(picked)]] >= 0)))
        if len(lost):
            if part_of is None:
                part_of = Parts(occluders.corners, triangles)
            other[lost] = part_of.resolve(positions, normals, at[lost], side[lost],
                                          tri[ray][lost])
        dst.append(got)
        spare.append(other)
    src, dst, spare = np.concatenate(src), np.concatenate(dst), np.concatenate(spare)
    w = links(src, dst, hits)
    if np.any(spare >= 0):
        w.src, w.dst, w.hits, w.spare = src, dst, np.asarray(hits, dtype=np.float64), spare
    w.seconds = time.perf_counter() - begin
    return w


class Parts:
    """The parts of a set of triangles (``corners`` (T, 3, 3), m): the triangles joined
    through shared corners, the first ``max(triangles) + 1`` only (a mesh's, before a scan's
    splats), and the part (N,) of each surfel on triangle ``triangles`` (-1: none)."""

    def __init__(self, corners: np.ndarray, triangles: np.ndarray):
        triangles = np.asarray(triangles, dtype=np.int64).reshape(-1)
        t = int(triangles.max()) + 1 if len(triangles) else 0
        self.count = t
        self.label = triangle_parts(np.asarray(corners)[:t])
        self.surfel = np.where(triangles >= 0, self.label[np.maximum(triangles, 0)], -1) \
            if t else np.full(len(triangles), -1, dtype=np.int64)
        self.order = np.argsort(self.surfel, kind="stable")        # each part's surfels
        self.sorted = self.surfel[self.order]

    def resolve(self, positions: np.ndarray, normals: np.ndarray, hits: np.ndarray,
                sides: np.ndarray, hit_triangles: np.ndarray,
                k: int = PART_NEIGHBOURS) -> np.ndarray:
        """The surfel (M,) int64 for each hit point ``hits`` (M, 3) on triangle
        ``hit_triangles`` (M,) lit on the side of unit normal ``sides`` (M, 3): the nearest of
        its part's ``k`` surfels nearest to it that faces that side, whether it
        sees the hit or not; -1 where none does or the triangle has no part."""
        from . import _core
        m = len(hits)
        out = np.full(m, -1, dtype=np.int64)
        tri = np.asarray(hit_triangles, dtype=np.int64)
        rows = np.flatnonzero(tri < self.count)
        if len(rows) == 0 or len(positions) == 0:
            return out
        part = self.label[tri[rows]]
        # Each part's own surfels only: a small part (an eyeball) among a dense one (the
        # head) has none among the hit's nearest surfels of all parts.
        for label in np.unique(part):
            q = rows[part == label]
            own = self.order[np.searchsorted(self.sorted, label, side="left"):
                             np.searchsorted(self.sorted, label, side="right")]
            if len(own) == 0:
                continue
            kk = min(int(k), len(own))
            near, _ = _core.knn(np.ascontiguousarray(positions[own]),
                                np.ascontiguousarray(hits[q]), kk)
            near = own[near.reshape(len(q), kk).astype(np.int64)]
            ok = np.einsum("mkc,mc->mk", normals[near], sides[q]) > LINK_SIDE_COS
            first = np.argmax(ok, axis=1)              # knn lists the nearest first
            has = ok[np.arange(len(q)), first]
            out[q[has]] = near[has, first[has]]
        return out


def triangle_parts(corners: np.ndarray) -> np.ndarray:
    """(T,) int64: a label per triangle (``corners`` (T, 3, 3)), equal for triangles joined
    through corners at the same point."""
    t = len(corners)
    if t == 0:
        return np.zeros(0, dtype=np.int64)
    _, vertex = np.unique(np.asarray(corners, dtype=np.float64).reshape(-1, 3), axis=0,
                          return_inverse=True)
    vertex = vertex.reshape(t, 3)
    label = np.arange(int(vertex.max()) + 1, dtype=np.int64)
    while True:
        # Hook each triangle's corners onto their smallest label, then jump pointers.
        low = label[vertex].min(axis=1)
        before = label.copy()
        for c in range(3):
            np.minimum.at(label, label[vertex[:, c]], low)
            np.minimum.at(label, vertex[:, c], low)
        while True:
            jumped = label[label]
            if np.array_equal(jumped, label):
                break
            label = jumped
        if np.array_equal(label, before):
            return label[vertex[:, 0]]


def _sees(occluders, a: np.ndarray, b: np.ndarray, na: np.ndarray, nb: np.ndarray) -> np.ndarray:
    """(M,) bool: no triangle meets the path a -> m -> b, m their midpoint moved
    ``LINK_CLEARANCE`` × |b − a| along the mean of their unit normals ``na``, ``nb``."""
    up = na + nb
    length = np.linalg.norm(up, axis=1)
    up = np.where(length[:, None] > 1e-6, up / np.maximum(length, 1e-300)[:, None], na)
    mid = 0.5 * (a + b) + LINK_CLEARANCE * np.linalg.norm(b - a, axis=1)[:, None] * up
    seen = occluders.visible(a, mid) > 0.5
    rows = np.flatnonzero(seen)
    seen[rows] = occluders.visible(mid[rows], b[rows]) > 0.5
    return seen


def links(src: np.ndarray, dst: np.ndarray, hits: np.ndarray) -> Links:
    """The first-hit transport from resolved rays: ray k of surfel ``src[k]`` met surfel
    ``dst[k]`` (-1: a lit face that no surfel carries there). Each surfel's ``hits`` share
    (N,) is spread evenly over its resolved rays; one without any keeps none."""
    src = np.asarray(src, dtype=np.int64)
    dst = np.asarray(dst, dtype=np.int64)
    n = len(hits)
    got = dst >= 0
    met = np.bincount(src, minlength=n)
    known = np.bincount(src[got], minlength=n) >= KNOWN_SHARE * met
    src, dst = src[got], dst[got]
    key = src * n + dst
    key, count = np.unique(key, return_counts=True)
    rows, cols = key // n, key % n
    per_row = np.bincount(rows, count, minlength=n)
    weights = np.asarray(hits, dtype=np.float64)[rows] * count / per_row[rows]
    return Links(rows, cols, weights, known)


def reach(w: Links, sky: np.ndarray, sources: np.ndarray, *,
          bounces: int = BOUNCES) -> np.ndarray:
    """The light (N,) a white scene carries along the first-hit transport ``w`` in
    ``bounces`` bounces, as a share of the sky's: each surfel receives its ``sky`` share
    (N,) directly, and ``sources`` (N,) bool (lamp-lit, emitting) and the surfels whose sky
    share reaches ``THRESHOLD`` hold 1. In [0, 1]."""
    sky = np.asarray(sky, dtype=np.float64)
    src = np.asarray(sources, dtype=bool) | (sky >= THRESHOLD)
    r = np.where(src, 1.0, sky)
    for _ in range(int(bounces)):
        nxt = np.minimum(sky + w.apply(r), 1.0)
        nxt[src] = 1.0
        if np.array_equal(nxt, r):
            break
        r = nxt
    return r


def enclosed(w: Links, sky: np.ndarray, sources: np.ndarray, *, bounces: int = BOUNCES,
             threshold: float = THRESHOLD) -> np.ndarray:
    """(N,) bool: surfels whose ``reach`` stays under ``threshold`` and whose row of ``w`` is
    known (``Links.known``): their light is their first hits' (0 where sealed)."""
    import time
    begin = time.perf_counter()
    if w.spare is not None:
        # The rays no surfel sees go to their part's surfel where that one is enclosed along
        # the rays that surfels do see; the links are rebuilt from those each call.
        strict = links(w.src, w.dst, w.hits)
        dark = (reach(strict, sky, sources, bounces=bounces) < threshold) & strict.known
        take = (w.dst < 0) & (w.spare >= 0)
        take[take] = dark[w.spare[take]]
        full = links(w.src, np.where(take, w.spare, w.dst), w.hits)
        w.rows, w.cols, w.weights, w.known = full.rows, full.cols, full.weights, full.known
    out = (reach(w, sky, sources, bounces=bounces) < threshold) & w.known
    w.seconds += time.perf_counter() - begin
    return out
