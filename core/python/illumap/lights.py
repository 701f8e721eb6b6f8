"""Direct light from lamps and a uniform sky on points: the light model of Blender's lamps, as
Cycles renders them, and their shadows.

Everything here is *incident radiance* H in Blender/Cycles units: irradiance / π, the value a
Cycles DIFFUSE bake with the DIRECT pass gives. A surfel with albedo ρ then emits ρ·H, which is
added to its own emission before the radiosity solve (emitting meshes are surfels, not lamps).

Cycles conventions, measured with bakes on this machine (bpy 5.0.1; see tests/blender/light/test_lamps.py):

* Point / spot, power P [W], colour c, radius r, distance d, receiver cosine cos θ:
  ``H = P c cos θ / (4π² (d² + r²))`` (r = 0 is a true point; r > 0 is Cycles' sphere light,
  whose on-axis value is exactly this). Spots are not renormalised by their cone.
* Spot cone: with t = cos(angle from the axis), t0 = cos(spot_size/2) and
  s = (1 − t0)·spot_blend, the factor is 0 for t < t0, else smoothstep(0, 1, (t − t0)/s) (1 if s = 0),
  averaged over the lamp's silhouette disc when it has a radius (``_spot_attenuation``).
* Sun, strength S [W/m²]: ``H = S c cos θ / π`` (the sun's angular size is ignored).
* Area, power P over world area A: radiance ``L = P c / (π A)``, one-sided (emits along the
  lamp's −Z), ``H = L · F`` with F the exact point-to-polygon form factor (Lambert's contour
  integral after clipping the lamp to the receiver's upper half-space). Disk/ellipse lamps are
  48-gons scaled to the same area. Spread < 180° is ignored (warned).
* World: a uniform sky of radiance C (Background colour × strength, or an environment image's
  mean) adds ``H = C · V``, V the cosine-weighted share of the hemisphere that sees the sky
  (1 without shadows; with them, estimated with cosine-distributed rays that leave the scene).

Shadows: with ``shadows`` (a ``Shadows`` record holding a segment query such as the core's
``illumap.Occluders(...).visible``), each lamp's analytic value is multiplied by the fraction
of the lamp a surfel sees. That fraction is estimated with rays from the surfel to stratified
sample points on the lamp: the sphere's silhouette disc for point and spot lamps with a radius
(one point when the radius is 0), the lamp's square, rectangle, disk or ellipse for area lamps,
and directions inside the sun's angular diameter (one direction when it is 0) towards a target
beyond the scene. Samples are weighted by their unshadowed contribution (cosines over squared
distance), and each surfel's pattern is shifted at random so that penumbrae show noise rather
than bands. When no ray is blocked the fraction is exactly 1, so the unshadowed value is
unchanged. Only lit surfels cast rays: the cost is about (lit surfels) × (samples) rays per lamp.

Numpy only (no bpy; the add-on's ``lamps`` reads Blender's lamps and world into ``Lamp``
records): the pipeline casts shadow rays on its worker thread, reporting the share of rays
cast through ``Shadows.progress`` (a ``progress(fraction, phase)`` that returns False to
cancel: :class:`illumap.Cancelled`).
"""

from __future__ import annotations

import time
import zlib
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ._progress import Cancelled
from .refinement import LUMINANCE_WEIGHTS

#: A segment query: origins (M, 3), targets (M, 3), skip (M,) surfel index to ignore per ray
#: (-1: none) → (M,) visibility in [0, 1] (1: the segment is free).
#: It may take a fourth argument, ``progress`` (fraction of its rays, phase) → False to cancel;
#: it is passed only when ``Shadows.progress`` is set.
SegmentQuery = Callable[..., np.ndarray]
_RAY_CHUNK = 1 << 20
#: The progress phase of shadow-ray casting.
PHASE = "lamp shadows"

_CHUNK = 16384


@dataclass
class Lamp:
    """A lamp in world space, numpy only (no bpy)."""

    name: str
    kind: str                    # 'POINT' | 'SPOT' | 'SUN' | 'AREA' | 'MESH' | 'WORLD'
    color: np.ndarray            # (3,) colour × energy (W, or W/m² for suns; radiance: world)
    position: np.ndarray         # (3,) m
    direction: np.ndarray        # (3,) unit, where the lamp points (its −Z axis)
    radius: float = 0.0          # m, point/spot
    spot_size: float = np.pi     # full cone angle, rad
    spot_blend: float = 0.0
    polygon: np.ndarray | None = None  # (V, 3) area lamp outline, world space
    area: float = 0.0            # m², area lamp
    shape: str = ""              # area lamp: 'SQUARE' | 'RECTANGLE' | 'DISK' | 'ELLIPSE'
    axes: np.ndarray | None = None  # (2, 3) area lamp half-axes (local x, y), m
    angle: float = 0.0           # sun: angular diameter, rad
    # 'MESH' (emissive triangles of one object): world corners (T, 3, 3), radiance (T, 3)
    triangles: np.ndarray | None = None
    radiance: np.ndarray | None = None
    two_sided: bool = False      # 'MESH': emits from both faces (Cycles' plain Emission)


@dataclass
class Shadows:
    """How lamp shadows are cast: the segment query and the samples per surfel and lamp.

    ``rays`` and ``seconds`` accumulate what was cast (for the statistics). ``progress``
    (optional) hears the share of the planned ``total`` rays cast so far."""

    visible: SegmentQuery
    samples: int = 16            # rays per surfel for lamps with a size (radius, area, angle)
    seed: int = 0
    extent: float = 1.0          # m, scene size: sun rays end this far beyond the surfel (×4)
    rays: int = 0
    seconds: float = 0.0
    progress: Callable[[float, str], "bool | None"] | None = None
    total: int = 0               # rays planned over all lamps (set by incident_radiance)
    # Each point's samples follow from its id (default: its row), so a subset of points can
    # be evaluated with the patterns they would have had among all of them.
    ids: np.ndarray | None = None
    # (M,) int: the probe of a sized lamp is shared within each group (≥ 0) of close points
    # (a dense scan's: ``illumap.shared_shadows``); None or -1: every point probes itself.
    groups: np.ndarray | None = None

    def report(self, done: float) -> None:
        """Tell ``progress`` that ``done`` of the planned rays were cast; raise
        Cancelled when it answers False."""
        if self.progress is None:
            return
        if self.progress(min(1.0, done / max(self.total, 1)), PHASE) is False:
            raise Cancelled("Cancelled")

    def _query_progress(self, start: int, count: int):
        """A progress callable for one query of ``count`` rays starting at ray ``start``."""
        if self.progress is None:
            return None
        total = max(self.total, 1)
        return lambda f, _phase="": self.progress(min(1.0, (start + f * count) / total), PHASE)


#: Rays per surfel that estimate how much of the sky a surfel sees (at most; fewer when the
#: shadow samples are fewer). Surfels only carry the world light on to the receivers, which
#: gather the sky with their own rays, so their noise averages out.
WORLD_SAMPLES = 64


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def _point_like(lamp: Lamp, p: np.ndarray, n: np.ndarray) -> np.ndarray:
    d = lamp.position - p
    dist2 = np.einsum("ij,ij->i", d, d)
    cos_r = np.maximum(np.einsum("ij,ij->i", n, d), 0.0) / np.sqrt(np.maximum(dist2, 1e-300))
    h = cos_r / (4 * np.pi ** 2 * (dist2 + lamp.radius ** 2))
    if lamp.kind == "SPOT":
        h *= _spot_attenuation(lamp, p, d, dist2)
    return h


#: Points on a sized spot lamp over which its cone's blend is averaged.
SPOT_CONE_SAMPLES = 32


def _spot_attenuation(lamp: Lamp, p: np.ndarray, d: np.ndarray, dist2: np.ndarray) -> np.ndarray:
    """The spot cone's factor (N,) at receivers p, d = lamp − p. A lamp with a radius is
    seen over its silhouette disc and Cycles applies the cone to each point of it, which
    softens the cone's edge: the factor is averaged over SPOT_CONE_SAMPLES stratified points
    of that disc (the open scene of bench/reference, against its 2048-sample Cycles bake:
    1.47% to 1.24% at default settings, its error had sat on the spot's edge)."""
    t0 = np.cos(lamp.spot_size / 2)
    smooth = (1 - t0) * lamp.spot_blend

    def factor(t):
        att = (t > t0).astype(np.float64)
        return att * _smoothstep((t - t0) / smooth) if smooth > 0 else att

    dist = np.sqrt(np.maximum(dist2, 1e-300))
    if lamp.radius <= 0:
        return factor(-(d @ lamp.direction) / dist)
    # Every point of the disc lies within atan(radius / dist) of its centre's direction: only
    # where that reaches the blend band do the samples differ.
    centre = np.arccos(np.clip(-(d @ lamp.direction) / dist, -1.0, 1.0))
    spread = np.arctan2(lamp.radius, dist) + 1e-9
    full, off = np.arccos(min(1.0, t0 + smooth)), np.arccos(t0)
    out = (centre + spread <= full).astype(np.float64)
    edge = np.flatnonzero((centre + spread > full) & (centre - spread < off))
    k = SPOT_CONE_SAMPLES
    disc = _disc(np.column_stack([(np.arange(k) + 0.5) / k,
                                  np.mod(np.arange(k) * 0.6180339887498949, 1.0)]))
    for start in range(0, len(edge), _CHUNK):
        r = edge[start:start + _CHUNK]
        u, v = _basis(d[r] / dist[r, None])
        q = lamp.position + lamp.radius * (disc[None, :, :1] * u[:, None] + disc[None, :, 1:] * v[:, None])
        to_p = q - p[r, None, :]
        t = -np.einsum("mkc,c->mk", to_p, lamp.direction) / np.linalg.norm(to_p, axis=2)
        out[r] = factor(t).mean(axis=1)
    return out


def _lambert(pts: np.ndarray, valid_next: np.ndarray | None, n: np.ndarray) -> np.ndarray:
    """Lambert's contour sum over closed outlines ``pts`` (N, V, 3) relative to the receivers.

    ``valid_next``: None (all V vertices used, cyclic) or (next index (N, V), mask (N, V)).
    """
    if valid_next is None:
        q = np.roll(pts, -1, axis=1)
        mask = None
    else:
        nxt, mask = valid_next
        q = np.take_along_axis(pts, nxt[..., None], axis=1)
    u = pts / np.maximum(np.linalg.norm(pts, axis=2, keepdims=True), 1e-300)
    w = q / np.maximum(np.linalg.norm(q, axis=2, keepdims=True), 1e-300)
    cr = np.cross(u, w)
    sin = np.linalg.norm(cr, axis=2)
    cos = np.einsum("nvc,nvc->nv", u, w)
    term = np.arctan2(sin, cos) * np.einsum("nvc,nc->nv", cr, n) / np.maximum(sin, 1e-300)
    if mask is not None:
        term = np.where(mask, term, 0.0)
    return np.abs(term.sum(axis=1)) / (2 * np.pi)


def polygon_form_factor(p: np.ndarray, n: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Point-to-polygon form factor (N,) for receivers ``p`` with normals ``n`` (N, 3).

    Lambert's formula F = |Σ_e γ_e n·(a×b)/|a×b|| / 2π over the outline (a, b unit vectors to
    consecutive vertices, γ_e their angle). Where the planar polygon crosses a receiver's
    tangent plane it is first clipped to the upper half-space (vectorised Sutherland-Hodgman).
    """
    nv = len(polygon)
    rel = polygon[None, :, :] - p[:, None, :]                      # (N, V, 3)
    s = np.einsum("nvc,nc->nv", rel, n)                             # heights above the plane
    above = s > 0
    out = np.zeros(len(p))
    full = above.all(axis=1)
    if full.any():
        out[full] = _lambert(rel[full], None, n[full])
    part = above.any(axis=1) & ~full
    if not part.any():
        return out
    rel, s, nn = rel[part], s[part], n[part]
    a, b = rel, np.roll(rel, -1, axis=1)
    sa, sb = s, np.roll(s, -1, axis=1)
    cut = (sa > 0) != (sb > 0)
    t = np.where(cut, sa / np.where(cut, sa - sb, 1.0), 0.0)
    inter = a + t[..., None] * (b - a)
    # Slot 2e = vertex e (kept if above), slot 2e+1 = crossing of edge e (if any).
    pts = np.empty((len(rel), 2 * nv, 3))
    pts[:, 0::2], pts[:, 1::2] = a, inter
    valid = np.empty((len(rel), 2 * nv), dtype=bool)
    valid[:, 0::2], valid[:, 1::2] = sa > 0, cut
    order = np.argsort(~valid, axis=1, kind="stable")               # valid slots first, in order
    pts = np.take_along_axis(pts, order[..., None], axis=1)
    count = valid.sum(axis=1)
    idx = np.arange(2 * nv)[None, :]
    nxt = np.where(idx + 1 < count[:, None], idx + 1, 0)
    out[part] = _lambert(pts, (nxt, idx < count[:, None]), nn)
    return out


def _area(lamp: Lamp, p: np.ndarray, n: np.ndarray) -> np.ndarray:
    front = np.einsum("ij,j->i", p - lamp.position, lamp.direction) > 0
    out = np.zeros(len(p))
    rows = np.flatnonzero(front)
    for start in range(0, len(rows), _CHUNK):
        r = rows[start:start + _CHUNK]
        out[r] = polygon_form_factor(p[r], n[r], lamp.polygon)
    return out / (np.pi * lamp.area)


def mesh_light(name: str, triangles: np.ndarray, radiance: np.ndarray,
               two_sided: bool) -> Lamp:
    """A lamp made of emissive triangles (T, 3, 3) with radiance (T, 3) each, emitting along
    their winding's normal (``two_sided``: both ways). Its light is exact (Lambert's
    point-to-polygon form factor per triangle); its shadows are sampled like an area lamp's."""
    tri = np.ascontiguousarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    centre = (tri.mean(axis=1) * area[:, None]).sum(axis=0) / max(area.sum(), 1e-300)
    return Lamp(name, "MESH", np.ones(3), centre, np.array([0.0, 0.0, -1.0]),
                area=float(area.sum()), triangles=tri,
                radiance=np.asarray(radiance, dtype=np.float64).reshape(-1, 3), two_sided=two_sided)


def _mesh(lamp: Lamp, p: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Incident radiance (N, 3) of a 'MESH' lamp, unshadowed: Σ_t L_t F_t."""
    out = np.zeros((len(p), 3))
    tri = lamp.triangles
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    for t in range(len(tri)):
        side = (p - tri[t, 0]) @ normals[t]
        rows = np.flatnonzero(side != 0 if lamp.two_sided else side > 0)
        for start in range(0, len(rows), _CHUNK):
            r = rows[start:start + _CHUNK]
            out[r] += polygon_form_factor(p[r], n[r], tri[t])[:, None] * lamp.radiance[t]
    return out


_MASK64 = (1 << 64) - 1


def _mix64(z: np.ndarray) -> np.ndarray:
    """SplitMix64's finaliser on uint64 arrays (wrapping arithmetic)."""
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def row_shifts(seed: int, salt: int, rows: np.ndarray) -> np.ndarray:
    """Uniform [0, 1)² shifts (len(rows), 1, 2), a fixed function of (seed, salt, row index).
    Each surfel or receiver keeps its own samples whichever other rows are lit, so moving,
    scaling or extending a scene does not reshuffle the noise."""
    key = np.uint64((int(seed) * 0x9E3779B97F4A7C15 + int(salt) * 0xD1B54A32D192ED03) & _MASK64)
    index = np.asarray(rows, dtype=np.uint64)[:, None] * np.uint64(2) + np.arange(2, dtype=np.uint64)
    with np.errstate(over="ignore"):
        z = _mix64(index * np.uint64(0x9E3779B97F4A7C15) + key)
    return ((z >> np.uint64(11)).astype(np.float64) * 2.0 ** -53)[:, None, :]


def _disc(uv: np.ndarray) -> np.ndarray:
    """Shirley's concentric map of [0,1)² points (..., 2) onto the unit disc (area-preserving)."""
    a, b = 2 * uv[..., 0] - 1, 2 * uv[..., 1] - 1
    first = np.abs(a) > np.abs(b)
    r = np.where(first, a, b)
    phi = np.where(first, (np.pi / 4) * b / np.where(a == 0, 1, a),
                   np.pi / 2 - (np.pi / 4) * a / np.where(b == 0, 1, b))
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)


def _basis(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (M, 3) perpendicular to unit vectors d (M, 3) and to each other."""
    helper = np.where((np.abs(d[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = np.cross(d, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(d, u)


def mesh_lamp_triangles(lamp: Lamp) -> dict[str, np.ndarray]:
    """A 'MESH' lamp's triangles as its samples use them: each one's first corner, edges
    (m), unit normal, the cumulative share of the area (T,) and the power (luminance of its
    radiance, T)."""
    tri = lamp.triangles
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    nrm = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(nrm, axis=1)
    nrm /= np.maximum(2 * area[:, None], 1e-300)
    return dict(corner=tri[:, 0], edge1=e1, edge2=e2, normal=nrm,
                cumulative=np.cumsum(area) / area.sum(),
                power=lamp.radiance @ LUMINANCE_WEIGHTS + 1e-12)


def _lamp_samples(lamp: Lamp, p: np.ndarray, n: np.ndarray, k: int, shifts: np.ndarray,
                  far: float) -> tuple[np.ndarray, np.ndarray]:
    """Sample points (M, k, 3) on ``lamp`` seen from receivers p (M, 3) and each sample's
    unshadowed weight (M, k) (relative contribution; only ratios matter); ``shifts`` (M, 1, 2)
    place each row's pattern (``row_shifts``): one rank-1 lattice (well stratified in both
    axes) per row, mapped onto the lamp. The world: cosine-distributed directions, each of
    weight 1. The sun: its disc of directions, weighted by the cosine at the receiver. A mesh
    lamp: a triangle by area (the first coordinate, rescaled within the triangle's interval),
    a point in it (square-root map), weighted by its power and both cosines over r⁴. An area
    lamp: its square or disc (Shirley's concentric map), both cosines over r⁴. Point and spot
    lamps: the sphere's silhouette disc facing the receiver, the receiver's cosine over r³.
    Native (``illumap._core.lamp_samples``), both threads."""
    from illumap import _core
    mesh = {}
    if lamp.kind == "MESH":
        mesh = {name: np.ascontiguousarray(a) for name, a in mesh_lamp_triangles(lamp).items()}
        mesh["two_sided"] = bool(lamp.two_sided)
    axes = np.zeros(6) if lamp.axes is None else np.asarray(lamp.axes, dtype=np.float64).reshape(6)
    pts, weight = _core.lamp_samples(
        lamp.kind, np.ascontiguousarray(p, dtype=np.float64),
        np.ascontiguousarray(n, dtype=np.float64),
        np.ascontiguousarray(np.asarray(shifts, dtype=np.float64).reshape(-1, 2)), int(k),
        float(far), position=[float(x) for x in lamp.position],
        direction=[float(x) for x in lamp.direction], axes=[float(x) for x in axes],
        radius=float(lamp.radius or 0.0), angle=float(lamp.angle or 0.0),
        disk=lamp.shape in ("DISK", "ELLIPSE"), **mesh)
    return np.asarray(pts), np.asarray(weight)


def rays_per_surfel(lamp: Lamp, shadows: Shadows) -> int:
    """Shadow rays per lit surfel: ``shadows.samples`` for a lamp with a size, else one."""
    if lamp.kind == "WORLD":
        return max(1, min(int(shadows.samples), WORLD_SAMPLES))
    sized = (lamp.kind in ("AREA", "MESH") or (lamp.kind == "SUN" and lamp.angle > 0)
             or (lamp.kind in ("POINT", "SPOT") and lamp.radius > 0))
    return max(1, int(shadows.samples)) if sized else 1


#: A sized lamp seen with many shadow rays is first probed with this many: where they all
#: agree (the whole lamp in view, or none of it), that is the answer; only the rest, the
#: penumbrae, take the full count. A shadow edge narrower than about 1/PROBE_SAMPLES of the
#: lamp can be missed by the probe. Never the world: a room's window is a few percent of
#: the sky, which all probe rays miss at most points inside, so those saw no sky at all (a
#: room lit through a window read 2-4% dark, every bounce of the sky's light short).
PROBE_SAMPLES = 32
_PROBE_SALT = 0x5BD1E995


def lamp_visibility(lamp: Lamp, p: np.ndarray, n: np.ndarray, rows: np.ndarray,
                    shadows: Shadows) -> np.ndarray:
    """Fraction (len(rows),) of ``lamp`` that surfels ``rows`` see (see the module docstring)."""
    k = rays_per_surfel(lamp, shadows)
    salt = zlib.crc32(lamp.name.encode())
    if k < 2 * PROBE_SAMPLES or lamp.kind == "WORLD":
        return _visible_fraction(lamp, p, n, rows, shadows, k, salt)

    def probe(r):
        return _visible_fraction(lamp, p, n, r, shadows, PROBE_SAMPLES, salt ^ _PROBE_SALT)
    if shadows.groups is None:
        out = probe(rows)
    else:
        from .shared_shadows import shared_probe
        out = shared_probe(probe, p, shadows.groups, rows)
    mixed = np.flatnonzero((out > 0.0) & (out < 1.0))
    if mixed.size:
        out[mixed] = _visible_fraction(lamp, p, n, rows[mixed], shadows, k, salt)
    return out


def _visible_fraction(lamp: Lamp, p: np.ndarray, n: np.ndarray, rows: np.ndarray,
                      shadows: Shadows, k: int, salt: int) -> np.ndarray:
    """``lamp_visibility`` with ``k`` shadow rays per point, patterns from ``salt``."""
    out = np.empty(len(rows))
    far = 4.0 * max(shadows.extent, 1e-3)
    per = max(1, _RAY_CHUNK // k)
    for start in range(0, len(rows), per):
        r = rows[start:start + per]
        ids = r if shadows.ids is None else shadows.ids[r]
        targets, weight = _lamp_samples(lamp, p[r], n[r], k, row_shifts(shadows.seed, salt, ids), far)
        origins = np.repeat(p[r], k, axis=0)
        skip = np.repeat(r.astype(np.int64), k)
        shadows.report(shadows.rays)
        t0 = time.perf_counter()
        if shadows.progress is None:
            vis = shadows.visible(origins, targets.reshape(-1, 3), skip)
        else:
            vis = shadows.visible(origins, targets.reshape(-1, 3), skip,
                                  shadows._query_progress(shadows.rays, len(origins)))
        vis = np.asarray(vis, dtype=np.float64)
        shadows.seconds += time.perf_counter() - t0
        shadows.rays += len(origins)
        vis = vis.reshape(len(r), k)
        wsum = weight.sum(axis=1)
        # Same operations with and without occlusion, so an unblocked lamp gives exactly 1.
        weighted = np.where(vis > 0, weight * vis, 0.0).sum(axis=1)
        plain = vis.mean(axis=1)
        out[start:start + per] = np.where(wsum > 0, weighted / np.where(wsum > 0, wsum, 1.0), plain)
    return np.clip(out, 0.0, 1.0)


def _lit(value: np.ndarray) -> np.ndarray:
    """Rows with any light: (N,) scalars, or (N, 3) colours of a 'MESH' lamp."""
    return (value > 0) if value.ndim == 1 else (value > 0).any(axis=1)


def incident_radiance(lamps: list[Lamp], positions: np.ndarray, normals: np.ndarray, *,
                      shadows: Shadows | None = None, world_apart: bool = False):
    """Incident radiance H (N, 3) at surfels from ``lamps`` (a 'WORLD' lamp among them is the
    uniform sky: H = its radiance × the share of the hemisphere that sees it). With
    ``world_apart``, (H of the other lamps, H of the world) instead.

    ``shadows`` (optional) shadows each lamp by ray casting; see the module docstring.
    """
    p = np.asarray(positions, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    h = np.zeros((len(p), 3))
    h_world = np.zeros((len(p), 3)) if world_apart else h
    scalars = []
    for lamp in lamps:
        if lamp.kind == "SUN":
            scalars.append(np.maximum(n @ -lamp.direction, 0.0) / np.pi)
        elif lamp.kind == "WORLD":
            scalars.append(np.ones(len(p)))
        elif lamp.kind == "AREA":
            scalars.append(_area(lamp, p, n))
        elif lamp.kind == "MESH":
            scalars.append(_mesh(lamp, p, n))
        else:
            scalars.append(_point_like(lamp, p, n))
        if shadows is not None:
            shadows.report(0)  # area lamps' form factors take seconds at millions of surfels
    if shadows is not None:
        # Every lamp's lit surfels are known before the first ray: progress over all rays.
        shadows.total = shadows.rays + sum(int(_lit(sc).sum()) * rays_per_surfel(lamp, shadows)
                                           for lamp, sc in zip(lamps, scalars))
    for lamp, scalar in zip(lamps, scalars):
        if shadows is not None:
            lit = np.flatnonzero(_lit(scalar))
            if lit.size:
                vis = lamp_visibility(lamp, p, n, lit, shadows)
                scalar[lit] *= vis[:, None] if scalar.ndim == 2 else vis
        (h_world if lamp.kind == "WORLD" else h)[:] += (
            scalar if scalar.ndim == 2 else scalar[:, None] * lamp.color[None, :])
    if shadows is not None:
        shadows.report(shadows.rays)
    return (h, h_world) if world_apart else h
