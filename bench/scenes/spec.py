"""A scene as plain data: its materials, meshes, lamps, world and camera, in the order a
builder creates them (``blender.build`` makes Blender objects of it; no bpy here)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Material:
    """A purely diffuse surface or an emitter. ``kind``: "diffuse" (Diffuse BSDF), "matte"
    (Principled BSDF, no specular layer; ``image``: a checker texture's name), "emit" (emits
    ``radiance`` from the front face only), "emit_both" (a plain Emission shader, both faces)."""

    name: str
    kind: str
    color: tuple = (0.0, 0.0, 0.0)      # linear albedo
    radiance: tuple = (0.0, 0.0, 0.0)   # W/(m² sr), linear RGB
    image: str | None = None            # "checker": the room's packed sRGB checker


@dataclass(frozen=True)
class Mesh:
    """A mesh object. ``shape``: "parts" (``parts``: [(verts, faces, uvs)], m), "uv_sphere"
    (``centre``, ``radius``: Blender's 32 × 16 primitive) or "monkey" (Suzanne, subdivided once
    and smoothed, resting on z = 0). ``weld`` merges coincident vertices, ``triangulate``
    splits the quads, ``uv`` adds the parts' UVs; ``role``: "scored" or "emitter"."""

    name: str
    material: Material
    shape: str = "parts"
    parts: list = field(default_factory=list)
    centre: tuple = (0.0, 0.0, 0.0)
    radius: float = 0.0
    weld: bool = True
    triangulate: bool = False
    uv: bool = False
    role: str = "scored"


@dataclass(frozen=True)
class Lamp:
    """A lamp: ``kind`` POINT, SPOT, SUN or AREA at ``location`` (m), turned by ``rotation``
    (Euler XYZ, radians) or aimed (−Z) at ``aim``; ``props`` set on the light data (energy in
    W, or W/m² for the sun; shadow_soft_size, spot_size, spot_blend, angle, size)."""

    name: str
    kind: str
    location: tuple
    props: dict = field(default_factory=dict)
    rotation: tuple = (0.0, 0.0, 0.0)
    aim: tuple | None = None


@dataclass(frozen=True)
class Camera:
    """The scene camera at ``location`` looking at ``target`` (m), ``lens`` in mm."""

    location: tuple
    target: tuple
    lens: float


@dataclass
class Scene:
    """A scene as data. ``objects``: meshes and lamps in creation order; ``sky``: None for a
    black world, else (colour, strength); ``scored``: the scored meshes' order when it is not
    their creation order. The rest is what the reference bench reads (``blender.ReferenceScene``)."""

    name: str
    objects: list
    notes: str = ""
    sky: tuple | None = None
    camera: Camera | None = None
    scored: tuple = ()
    groups: dict = field(default_factory=dict)
    scan: list = field(default_factory=list)
    reference: str = ""
    reference_samples: int = 0
    only_settings: tuple = ()
    cycles_samples: tuple = ()

    def meshes(self, role: str) -> list[Mesh]:
        """The meshes of ``role`` ("scored" in ``scored``'s order when given)."""
        found = [o for o in self.objects if isinstance(o, Mesh) and o.role == role]
        if role == "scored" and self.scored:
            by_name = {m.name: m for m in found}
            return [by_name[n] for n in self.scored]
        return found

    def lamps(self) -> list[Lamp]:
        """The lamps, in creation order."""
        return [o for o in self.objects if isinstance(o, Lamp)]


def raw_part(verts: np.ndarray, faces: np.ndarray) -> tuple:
    """A part of given vertices and faces without UVs (a scan's triangles)."""
    return verts, faces, None
