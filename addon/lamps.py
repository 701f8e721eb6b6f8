"""Direct light from Blender lamps (and optional uniform world light) on surfels.

Everything here is *incident radiance* H in Blender/Cycles units: irradiance / π, the value a
Cycles DIFFUSE bake with the DIRECT pass gives. A surfel with albedo ρ then emits ρ·H, which is
added to its own emission before the radiosity solve (emitting meshes are surfels, not lamps).

Cycles conventions, measured with bakes on this machine (bpy 5.0.1; see tests/blender/test_lamps.py):

* Point / spot, power P [W], colour c, radius r, distance d, receiver cosine cos θ:
  ``H = P c cos θ / (4π² (d² + r²))`` (r = 0 is a true point; r > 0 is Cycles' sphere light,
  whose on-axis value is exactly this). Spots are not renormalised by their cone.
* Spot cone: with t = cos(angle from the axis), t0 = cos(spot_size/2) and
  s = (1 − t0)·spot_blend, the factor is 0 for t < t0, else smoothstep(0, 1, (t − t0)/s) (1 if s = 0).
* Sun, strength S [W/m²]: ``H = S c cos θ / π`` (the sun's angular size is ignored).
* Area, power P over world area A: radiance ``L = P c / (π A)``, one-sided (emits along the
  lamp's −Z), ``H = L · F`` with F the exact point-to-polygon form factor (Lambert's contour
  integral after clipping the lamp to the receiver's upper half-space). Disk/ellipse lamps are
  48-gons scaled to the same area. Spread < 180° is ignored (warned).
* World: a constant world colour × strength C adds ``H = C`` (an unoccluded hemisphere).

Shadows: none yet. Every term is multiplied by ``visibility(positions, normals, lamp_points)``
when a callable is given: it must return, per surfel, the fraction (0..1) of ``lamp_points``
(world positions, shape (K, 3); a single point for point/spot lamps, far-away points along the
light direction for suns) that the surfel sees. The ray-cast visibility of a later issue slots
in there; ``None`` means unshadowed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

Visibility = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]

_DISK_SIDES = 48
_CHUNK = 16384


@dataclass
class Lamp:
    """A lamp in world space, numpy only (no bpy)."""

    name: str
    kind: str                    # 'POINT' | 'SPOT' | 'SUN' | 'AREA'
    color: np.ndarray            # (3,) colour × energy (W, or W/m² for suns)
    position: np.ndarray         # (3,) m
    direction: np.ndarray        # (3,) unit, where the lamp points (its −Z axis)
    radius: float = 0.0          # m, point/spot
    spot_size: float = np.pi     # full cone angle, rad
    spot_blend: float = 0.0
    polygon: np.ndarray | None = None  # (V, 3) area lamp outline, world space
    area: float = 0.0            # m², area lamp


def read_lamps(depsgraph, warnings: list[str]) -> list[Lamp]:
    """The renderable lamps of the evaluated scene as ``Lamp`` records (main thread only)."""
    lamps = []
    for inst in depsgraph.object_instances:
        obj = inst.object
        if obj.type != "LIGHT":
            continue
        if obj.original.hide_render:
            continue
        light = obj.data
        m = np.array(inst.matrix_world, dtype=np.float64)
        lin, pos = m[:3, :3], m[:3, 3].copy()
        direction = -lin[:, 2]
        direction /= np.linalg.norm(direction)
        color = np.array(light.color, dtype=np.float64) * float(light.energy)
        kind = light.type
        if kind in ("POINT", "SPOT"):
            lamp = Lamp(obj.name, kind, color, pos, direction, radius=float(light.shadow_soft_size))
            if kind == "SPOT":
                lamp.spot_size, lamp.spot_blend = float(light.spot_size), float(light.spot_blend)
        elif kind == "SUN":
            lamp = Lamp(obj.name, kind, color, pos, direction)
        elif kind == "AREA":
            sx = float(light.size)
            sy = float(light.size_y) if light.shape in ("RECTANGLE", "ELLIPSE") else sx
            ax, ay = lin[:, 0] * sx / 2, lin[:, 1] * sy / 2
            if light.shape in ("SQUARE", "RECTANGLE"):
                corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=np.float64)
                area = 4 * np.linalg.norm(np.cross(ax, ay))
            else:
                phi = 2 * np.pi * np.arange(_DISK_SIDES) / _DISK_SIDES
                # Scale the polygon so its area equals the ellipse's.
                k = np.sqrt(2 * np.pi / (_DISK_SIDES * np.sin(2 * np.pi / _DISK_SIDES)))
                corners = k * np.column_stack([np.cos(phi), np.sin(phi)])
                area = np.pi * np.linalg.norm(np.cross(ax, ay))
            polygon = pos + corners[:, :1] * ax + corners[:, 1:] * ay
            if getattr(light, "spread", np.pi) < np.pi - 1e-6:
                warnings.append(f"Lamp '{obj.name}': area light spread is ignored (treated as 180°)")
            lamp = Lamp(obj.name, kind, color, pos, direction, polygon=polygon, area=area)
        else:
            warnings.append(f"Lamp '{obj.name}': type {kind} is not supported; ignored")
            continue
        lamps.append(lamp)
    return lamps


def world_ambient(scene) -> np.ndarray:
    """Uniform world radiance (3,): the unlinked Background colour × strength, or world colour."""
    world = scene.world
    if world is None:
        return np.zeros(3)
    tree = world.node_tree
    if tree is not None:
        out = tree.get_output_node("CYCLES") if hasattr(tree, "get_output_node") else None
        if out is not None and out.inputs["Surface"].is_linked:
            node = out.inputs["Surface"].links[0].from_node
            if node.type == "BACKGROUND" and not node.inputs["Color"].is_linked \
                    and not node.inputs["Strength"].is_linked:
                return np.array(node.inputs["Color"].default_value[:3]) * node.inputs["Strength"].default_value
    return np.array(world.color[:3], dtype=np.float64)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def _point_like(lamp: Lamp, p: np.ndarray, n: np.ndarray) -> np.ndarray:
    d = lamp.position - p
    dist2 = np.einsum("ij,ij->i", d, d)
    cos_r = np.maximum(np.einsum("ij,ij->i", n, d), 0.0) / np.sqrt(np.maximum(dist2, 1e-300))
    h = cos_r / (4 * np.pi ** 2 * (dist2 + lamp.radius ** 2))
    if lamp.kind == "SPOT":
        t = -np.einsum("ij,j->i", d, lamp.direction) / np.sqrt(np.maximum(dist2, 1e-300))
        t0 = np.cos(lamp.spot_size / 2)
        smooth = (1 - t0) * lamp.spot_blend
        att = (t > t0).astype(np.float64)
        if smooth > 0:
            att *= _smoothstep((t - t0) / smooth)
        h *= att
    return h


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


def _lamp_points(lamp: Lamp) -> np.ndarray:
    if lamp.kind == "SUN":
        return (lamp.position - 1e6 * lamp.direction)[None, :]
    if lamp.kind == "AREA":
        return lamp.polygon.mean(axis=0)[None, :]
    return lamp.position[None, :]


def incident_radiance(lamps: list[Lamp], positions: np.ndarray, normals: np.ndarray, *,
                      ambient: np.ndarray | None = None,
                      visibility: Visibility | None = None) -> np.ndarray:
    """Incident radiance H (N, 3) at surfels from ``lamps`` and uniform ``ambient`` radiance.

    ``visibility`` (optional) multiplies each lamp's term; see the module docstring.
    """
    p = np.asarray(positions, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    h = np.zeros((len(p), 3))
    for lamp in lamps:
        if lamp.kind == "SUN":
            scalar = np.maximum(n @ -lamp.direction, 0.0) / np.pi
        elif lamp.kind == "AREA":
            scalar = _area(lamp, p, n)
        else:
            scalar = _point_like(lamp, p, n)
        if visibility is not None:
            scalar = scalar * np.asarray(visibility(p, n, _lamp_points(lamp)), dtype=np.float64)
        h += scalar[:, None] * lamp.color[None, :]
    if ambient is not None:
        h += np.asarray(ambient, dtype=np.float64)[None, :]
    return h
