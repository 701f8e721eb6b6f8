"""Cycles' per-vertex reference: outgoing radiance at every vertex of a scene's scored meshes.

``bpy.ops.object.bake(type='DIFFUSE', pass_filter={'DIRECT', 'INDIRECT'},
target='VERTEX_COLORS')`` into a POINT-domain FLOAT_COLOR attribute gives the *incident*
radiance (irradiance / π) at each vertex: without 'COLOR' in the filter the diffuse colour is
divided out (DESIGN.md §4, checked there against an exact form factor). Outgoing radiance is
then ``albedo × incident + emission`` with the scene's per-vertex albedo (the image sampled at
the vertex UV for textured floors).

Cycles runs on the CPU with the given sample count, no adaptive sampling, 64 bounces of every
kind, no clamping (``sample_clamp_direct = sample_clamp_indirect = 0``), and the world the
scene set (black in every reference scene). The seed is a parameter: the reference and the
sample-count sweep use different seeds, so that the sweep is not correlated with it.
"""

from __future__ import annotations

import time

import bpy
import numpy as np

#: Name of the attribute Cycles bakes into (removed again afterwards).
BAKE_ATTRIBUTE = "reference_bake"
#: Bounces of every kind: deep enough that a white room's light has died out.
BOUNCES = 64


def configure_cycles(samples: int, seed: int = 0) -> None:
    """Cycles settings of a reference bake (see the module docstring)."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = int(samples)
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = int(seed)
    cycles.max_bounces = cycles.diffuse_bounces = BOUNCES
    cycles.glossy_bounces = cycles.transmission_bounces = BOUNCES
    cycles.transparent_max_bounces = BOUNCES
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    cycles.caustics_reflective = cycles.caustics_refractive = True
    cycles.blur_glossy = 0.0


def bake_incident(objects, samples: int, seed: int = 0) -> tuple[dict[str, np.ndarray], float]:
    """Incident radiance (V, 3) per vertex of each of ``objects`` (W/(m² sr), Blender units),
    from one Cycles DIFFUSE bake of all of them; and the seconds of the bake call alone.
    Renderable helpers (e.g. Illumap's surfel object) should be hidden from render first."""
    configure_cycles(samples, seed)
    view_layer = bpy.context.view_layer
    for obj in view_layer.objects:
        obj.select_set(False)
    for obj in objects:
        attrs = obj.data.color_attributes
        if BAKE_ATTRIBUTE in attrs:
            attrs.remove(attrs[BAKE_ATTRIBUTE])
        attrs.active_color = attrs.new(BAKE_ATTRIBUTE, "FLOAT_COLOR", "POINT")
        obj.select_set(True)
    view_layer.objects.active = objects[0]
    start = time.perf_counter()
    bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT"},
                        target="VERTEX_COLORS")
    seconds = time.perf_counter() - start
    incident = {}
    for obj in objects:
        attrs = obj.data.color_attributes
        rgba = np.empty(len(obj.data.vertices) * 4, dtype=np.float32)
        attrs[BAKE_ATTRIBUTE].data.foreach_get("color", rgba)
        incident[obj.name] = rgba.reshape(-1, 4)[:, :3].astype(np.float64)
        attrs.remove(attrs[BAKE_ATTRIBUTE])
    return incident, seconds


def bake_outgoing(scene, samples: int, seed: int = 0) -> tuple[dict[str, np.ndarray], float]:
    """Outgoing radiance (V, 3) per vertex of each scored object of ``scene`` (a
    ``scenes.ReferenceScene``): ``albedo × incident + emission``; and the bake's seconds."""
    incident, seconds = bake_incident(scene.scored, samples, seed)
    outgoing = {name: scene.albedo[name] * value + scene.emission[name]
                for name, value in incident.items()}
    return outgoing, seconds


def vertex_positions(obj) -> np.ndarray:
    """World-space vertex positions (V, 3) of a mesh object, m."""
    n = len(obj.data.vertices)
    co = np.empty(n * 3)
    obj.data.vertices.foreach_get("co", co)
    m = np.array(obj.matrix_world, dtype=np.float64)
    return co.reshape(n, 3) @ m[:3, :3].T + m[:3, 3]


def baked_vertices(obj) -> np.ndarray:
    """Mask (V,) of the vertices some face uses: only those get a baked value (Bake to Color
    Attribute averages a vertex's corners; a loose vertex, such as the ~3% of the Stanford
    bunny's points that its zippered mesh leaves out, has none and reads 0)."""
    mesh = obj.data
    corners = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", corners)
    used = np.zeros(len(mesh.vertices), dtype=bool)
    used[corners] = True
    return used
