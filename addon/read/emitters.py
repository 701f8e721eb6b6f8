"""Emissive mesh triangles as lights: their direct light is integrated exactly.

An emissive object's light reaches each surfel and each receiver through Lambert's
point-to-polygon form factor of every emissive triangle, shadowed by rays to samples on it
(``lights.mesh_light``), instead of through emitting surfels: the point kernel of a surfel
cannot resolve a surface a few millimetres from a light, and the FMM's far field cannot carry
a sharp shadow. Such surfels keep their reflection but leave their emission out of the solve.

Emission from each face follows Cycles: an Emission shader emits from both faces; Geometry ▸
Backfacing mixing it with black makes a one-sided light (``materials``: each side evaluated).
Objects with more than ``MAX_LIGHT_TRIANGLES`` emissive triangles in all stay emitting
surfels (the exact integral costs a form factor per triangle and receiver).
"""

from __future__ import annotations

import numpy as np
from illumap.limits import limit
from illumap import lights

from . import materials
from .sampling import MeshSamples, TriangleMesh

#: Emissive triangles integrated exactly, over all objects (the rest emit through surfels).
MAX_LIGHT_TRIANGLES = limit("light_triangles").high


def triangle_emission(tm: TriangleMesh) -> tuple[np.ndarray, np.ndarray]:
    """Front and back emission (T, 3) of each triangle, evaluated at its centroid."""
    t = len(tm.area)
    centroids = MeshSamples(mesh=tm, positions=tm.corners.mean(axis=1), normals=tm.normal,
                            areas=tm.area, triangle=np.arange(t),
                            bary=np.full((t, 3), 1.0 / 3.0), material_index=tm.material_index)
    scratch: list[str] = []   # the surfels' evaluation already warns about these materials
    _, front = materials.surfel_materials(centroids, scratch, side="front")
    _, back = materials.surfel_materials(centroids, scratch, side="back")
    return front, back


def mesh_lights(tri_meshes: list[TriangleMesh],
                notes: list[str]) -> tuple[list[lights.Lamp], list[np.ndarray]]:
    """Lamps for the emissive triangles of ``tri_meshes``, and per mesh the triangles (T,)
    bool whose emission the lamps now carry (their surfels' emission leaves the solve:
    ``read_scene._surfel_parts`` takes these masks). Objects over the triangle budget keep
    emitting surfels, with a note."""
    found, used, masks = [], 0, []
    for tm in tri_meshes:
        front, back = triangle_emission(tm)
        mask = np.zeros(len(tm.area), dtype=bool)
        masks.append(mask)
        emits = (front > 0).any(axis=1) | (back > 0).any(axis=1)
        count = int(emits.sum())
        if count == 0:
            continue
        if used + count > MAX_LIGHT_TRIANGLES:
            notes.append(f"Object '{tm.name}': {count} emissive triangles exceed the "
                         f"{MAX_LIGHT_TRIANGLES} integrated exactly; its light comes from surfels")
            continue
        used += count
        rows = np.flatnonzero(emits)
        f, b = front[rows], back[rows]
        same = np.allclose(f, b)
        mask[rows] = True
        if same:
            found.append(lights.mesh_light(tm.name, tm.corners[rows], f, two_sided=True))
            continue
        if (f > 0).any():
            found.append(lights.mesh_light(tm.name, tm.corners[rows], f, two_sided=False))
        if (b > 0).any():
            flipped = tm.corners[rows][:, ::-1]   # reversed winding: the back faces forward
            found.append(lights.mesh_light(tm.name + " (back)", flipped, b, two_sided=False))
    return found, masks
