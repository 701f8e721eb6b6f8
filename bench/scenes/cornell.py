"""The Cornell box, declared once (numpy only): Cornell's published measurements, its
reflectances and its light, and the two forms the benches use.

* ``published_quads(scale)``: the published quads as given (slightly irregular walls, the
  blocks without bottoms), turned into Blender's frame (Z up) and scaled: the box the Blender
  scenes build (``meshes.cornell``: × 0.005, a 2.8 m room).
* ``regular_quads()``: the same box made regular for the surfel benchmarks (a 0.556 m cube
  open at y = 0, the blocks standing on the published footprints at the published heights, the
  published 130 × 105 mm light centred 0.1 mm under the ceiling), as planar quads with their
  reflectance and emission.

Source: https://www.graphics.cornell.edu/online/box/data.html (millimetres, Y up, x to the
left seen from the open front).
"""

from __future__ import annotations

import numpy as np

#: Cornell's reflectances (RGB values in common use) and the light's radiance.
WHITE, RED, GREEN = (0.725, 0.71, 0.68), (0.63, 0.065, 0.05), (0.14, 0.45, 0.091)
RADIANCE = (17.0, 12.0, 4.0)

#: Cornell's published geometry (mm, Y up): quads per surface, blocks without bottoms; the
#: light in the ceiling plane. Each block's first quad is its top.
PUBLISHED_MM = {
    "Floor": [[(552.8, 0, 0), (0, 0, 0), (0, 0, 559.2), (549.6, 0, 559.2)]],
    "Ceiling": [[(556, 548.8, 0), (556, 548.8, 559.2), (0, 548.8, 559.2), (0, 548.8, 0)]],
    "BackWall": [[(549.6, 0, 559.2), (0, 0, 559.2), (0, 548.8, 559.2), (556, 548.8, 559.2)]],
    "RightWall": [[(0, 0, 559.2), (0, 0, 0), (0, 548.8, 0), (0, 548.8, 559.2)]],
    "LeftWall": [[(552.8, 0, 0), (549.6, 0, 559.2), (556, 548.8, 559.2), (556, 548.8, 0)]],
    "ShortBlock": [
        [(130, 165, 65), (82, 165, 225), (240, 165, 272), (290, 165, 114)],
        [(290, 0, 114), (290, 165, 114), (240, 165, 272), (240, 0, 272)],
        [(130, 0, 65), (130, 165, 65), (290, 165, 114), (290, 0, 114)],
        [(82, 0, 225), (82, 165, 225), (130, 165, 65), (130, 0, 65)],
        [(240, 0, 272), (240, 165, 272), (82, 165, 225), (82, 0, 225)]],
    "TallBlock": [
        [(423, 330, 247), (265, 330, 296), (314, 330, 456), (472, 330, 406)],
        [(423, 0, 247), (423, 330, 247), (472, 330, 406), (472, 0, 406)],
        [(472, 0, 406), (472, 330, 406), (314, 330, 456), (314, 0, 456)],
        [(314, 0, 456), (314, 330, 456), (265, 330, 296), (265, 0, 296)],
        [(265, 0, 296), (265, 330, 296), (423, 330, 247), (423, 0, 247)]],
    "Light": [[(343, 548.8, 227), (343, 548.8, 332), (213, 548.8, 332), (213, 548.8, 227)]],
}
#: Each published surface's reflectance (the light has none).
COLOURS = {"Floor": WHITE, "Ceiling": WHITE, "BackWall": WHITE, "RightWall": GREEN,
           "LeftWall": RED, "ShortBlock": WHITE, "TallBlock": WHITE}
#: The centre of the published room (mm), to face the walls inwards.
ROOM_CENTRE_MM = (278, 274.4, 279.6)

#: The regular box's edge (m): the published width, 556 mm.
BOX = 0.556
#: Half the published light (130 × 105 mm), m.
LIGHT_HALF = (0.065, 0.0525)


def to_blender(mm, scale: float) -> np.ndarray:
    """Published coordinates (mm, Y up, x to the left seen from the open front) to Blender's
    frame (Z up): (556 − x, z, y) × ``scale`` (a rotation: orientation kept), m."""
    p = np.asarray(mm, dtype=np.float64)
    return np.stack([556.0 - p[..., 0], p[..., 2], p[..., 1]], axis=-1) * scale


def published_quads(scale: float) -> dict[str, list[np.ndarray]]:
    """Every published surface's quads (4, 3) in Blender's frame, scaled (m per mm)."""
    return {name: [to_blender(q, scale) for q in quads] for name, quads in PUBLISHED_MM.items()}


# --- the regular box of the surfel benchmarks ------------------------------------------------

def _regular_xy(x_mm, z_mm) -> np.ndarray:
    """Published (x, depth) in mm to the regular box's (x, y) in m: x mirrored so that the red
    wall is at x = 0."""
    return np.array([BOX - 1e-3 * x_mm, 1e-3 * z_mm])


def block_footprints() -> list[tuple[np.ndarray, float]]:
    """The two blocks' published footprints (4 × 2, counter-clockwise seen from above) and
    heights, in the regular box's frame, m."""
    out = []
    for name in ("ShortBlock", "TallBlock"):
        top = PUBLISHED_MM[name][0]
        fp = np.array([_regular_xy(x, z) for x, _, z in top])
        c = fp.mean(axis=0)
        ang = np.arctan2(fp[:, 1] - c[1], fp[:, 0] - c[0])
        out.append((fp[np.argsort(ang)], 1e-3 * top[0][1]))
    return out


def inside_footprints(xy: np.ndarray) -> np.ndarray:
    """True for the points (K × 2, m) that lie inside a block's footprint."""
    inside = np.zeros(len(xy), bool)
    for fp, _ in block_footprints():
        ok = np.ones(len(xy), bool)
        for k in range(4):
            a, b = fp[k], fp[(k + 1) % 4]
            ok &= (b[0] - a[0]) * (xy[:, 1] - a[1]) - (b[1] - a[1]) * (xy[:, 0] - a[0]) > 0
        inside |= ok
    return inside


def behind_light(p: np.ndarray) -> np.ndarray:
    """True for the points (K × 3, m) of the regular box's ceiling that the light covers."""
    return ((np.abs(p[:, 2] - BOX) < 1e-9) & (np.abs(p[:, 0] - BOX / 2) < LIGHT_HALF[0])
            & (np.abs(p[:, 1] - BOX / 2) < LIGHT_HALF[1]))


def regular_quads(blocks: bool = True) -> list[dict]:
    """The regular box as planar quads: dicts ``name``, ``origin``, ``u``, ``v`` (edge vectors,
    m; normal = u × v, into the box or out of a block), ``albedo``, ``emission`` (radiance).
    The box is 0.556 m wide, deep and high, open at y = 0; each block side stands on a
    published footprint edge, each block top is the parallelogram on three published corners
    (the published tops are 2–3 mm off a parallelogram); the light (last) is the published
    130 × 105 mm quad, centred, 0.1 mm below the ceiling."""
    L = BOX
    quads = [
        ("Floor", (0, 0, 0), (L, 0, 0), (0, L, 0), WHITE),
        ("Back", (0, L, 0), (L, 0, 0), (0, 0, L), WHITE),
        ("Left", (0, 0, 0), (0, L, 0), (0, 0, L), RED),       # x = 0, normal +x
        ("Right", (L, 0, 0), (0, 0, L), (0, L, 0), GREEN),    # x = L, normal -x
        ("Ceiling", (0, 0, L), (0, L, 0), (L, 0, 0), WHITE),  # normal -z
    ]
    if blocks:
        for label, (fp, height) in zip(("Short", "Tall"), block_footprints()):
            quads.append((f"{label}Top", (*fp[0], height), (*(fp[1] - fp[0]), 0),
                          (*(fp[3] - fp[0]), 0), WHITE))
            for k in range(4):
                a, b = fp[k], fp[(k + 1) % 4]
                quads.append((f"{label}Side{k}", (*a, 0), (*(b - a), 0), (0, 0, height), WHITE))
    out = []
    for name, origin, u, v, albedo in quads:
        origin, u, v = (np.array(x, float) for x in (origin, u, v))
        normal = np.cross(u, v)
        if name.endswith("Top") and normal[2] < 0:
            u, v = v, u
        out.append(dict(name=name, origin=origin, u=u, v=v, albedo=np.array(albedo, float),
                        emission=np.zeros(3)))
    c = np.array([L / 2, L / 2])
    out.append(dict(name="Light", origin=np.array([c[0] - LIGHT_HALF[0], c[1] - LIGHT_HALF[1],
                                                   L - 1e-4]),
                    u=np.array([0, 2 * LIGHT_HALF[1], 0.0]), v=np.array([2 * LIGHT_HALF[0], 0, 0.0]),
                    albedo=np.zeros(3), emission=np.array(RADIANCE, float)))
    return out
