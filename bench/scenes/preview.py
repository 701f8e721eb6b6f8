"""Scenes whose Object Preview is compared with a path-traced view of the same scene, from a
camera (``preview_vs_cycles.py --scene``, tests/blender/preview/test_preview_render.py).

* ``mesh_room``: a 1 m Cornell-like room (open at the front; red left wall, green right wall,
  white floor, ceiling and back wall, grids of ``cell``), a white block on the floor and a
  one-sided 0.3 m emitter under the ceiling; the meshes themselves are lit.
* ``scan_room``: the same room with its walls and block as a scan: jittered grids (each
  vertex moved up to ``JITTER`` of a cell in its plane, those on a patch's edge along it), so
  that the scan's points are the vertices of meshes that are still exactly the room's
  surfaces. Illumap is given one vertex-only object of those points (albedo in ``Col``, no
  normals, no radii); the emitter stays a mesh.
* ``scan_room_normals``: the same scan with each point's normal given (the scanned mesh's
  vertex normal, as a scanner that records normals gives).
* ``scan_bunny``: the Stanford bunny (a real range scan, ``shapes.BUNNY_CREDIT``) × 3.3 on a
  mesh floor under a dim sky and a sun; Illumap is given the bunny's vertices as a scan.

The scenes are declared as data in ``meshes.py`` (``preview_room``, ``preview_bunny``) and
built by ``blender.build_objects``; this module makes the scan of them and shows the result.

Because the scan's points are vertices of meshes that lie on the true surfaces, the **values
at the points** can be shown without splats: the scan's ``illumination`` copied to those
meshes and interpolated over their faces (``points_on_meshes``). That image separates the
preview's two errors: splats against it is the drawing's error alone, it against the
path-traced view the light's (the values at the points, and their linear interpolation).
"""

from __future__ import annotations

import bpy
import numpy as np

from . import blender
from .meshes import preview_bunny, preview_room

#: The scan's points move up to this fraction of a cell about their grid position.
JITTER = 0.35


def room(cell: float = 0.05, jitter: float = 0.0, seed: int = 0) -> dict:
    """The room in an empty file: ``{"surfaces": [meshes], "emitter": mesh}`` and the scene
    camera looking in through the open side."""
    scene = preview_room(cell, jitter, seed)
    objects = blender.build_objects(scene)
    return {"surfaces": [objects[m.name] for m in scene.meshes("scored")],
            "emitter": objects["Emitter"]}


def bunny(floor_cell: float = 0.05, stride: int = 1) -> dict:
    """The bunny on a 4 m floor of ``floor_cell`` grids under a dim sky and a sun (as
    ``meshes.scan_object``, whose 0.1 m floor cells are too coarse to show the bunny's shadow
    through their vertices) and a camera looking down at it: ``{"surfaces": [bunny, floor],
    "emitter": None, "stride": stride}``. The bunny mesh is the whole scan (the path-traced
    reference renders its triangles); ``stride`` is how ``build`` thins the scan Illumap gets."""
    scene = preview_bunny(floor_cell)
    objects = blender.build_objects(scene)
    return {"surfaces": [objects[m.name] for m in scene.meshes("scored")], "emitter": None,
            "stride": stride}


def as_scan(meshes, name: str = "Scan", stride: int = 1, normals: bool = False):
    """One vertex-only object holding the vertices of ``meshes`` (world space, albedo in
    ``Col`` from each mesh's material, no radii, and no normals unless ``normals``: then each
    vertex's normal in a ``normal`` attribute, as a scanner that records them gives; every
    ``stride``-th vertex); the meshes hidden from the viewport and renders. Returns the
    scan."""
    pos, albedo, nrm = [], [], []
    for obj in meshes:
        v = np.empty(len(obj.data.vertices) * 3)
        obj.data.vertices.foreach_get("co", v)
        vn = np.empty(len(obj.data.vertices) * 3)
        obj.data.vertices.foreach_get("normal", vn)
        nrm.append(vn.reshape(-1, 3) @ np.linalg.inv(np.array(obj.matrix_world)[:3, :3]))
        v = v.reshape(-1, 3) @ np.array(obj.matrix_world)[:3, :3].T + np.array(obj.matrix_world)[:3, 3]
        pos.append(v)
        albedo.append(np.tile(obj.data.materials[0]["albedo"], (len(v), 1)))
        obj.hide_set(True)
        obj.hide_render = True
    pos, albedo = np.concatenate(pos)[::stride], np.concatenate(albedo)[::stride]
    data = bpy.data.meshes.new(name)
    data.vertices.add(len(pos))
    data.vertices.foreach_set("co", pos.astype(np.float32).ravel())
    rgba = np.ones((len(pos), 4), np.float32)
    rgba[:, :3] = albedo
    data.color_attributes.new("Col", "FLOAT_COLOR", "POINT").data.foreach_set("color", rgba.ravel())
    if normals:
        vn = np.concatenate(nrm)[::stride]
        vn /= np.linalg.norm(vn, axis=1, keepdims=True)
        data.attributes.new("normal", "FLOAT_VECTOR", "POINT").data.foreach_set(
            "vector", vn.astype(np.float32).ravel())
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def scan_values(scan) -> np.ndarray:
    """The scan's ``illumination`` (n, 3)."""
    attr = scan.data.attributes["illumination"]
    out = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", out)
    return out.reshape(-1, 4)[:, :3].astype(np.float64)


def points_on_meshes(scan, meshes) -> None:
    """Show the values at the scan's points without splats: each mesh of ``meshes`` (whose
    vertices, in order, the scan was made of) gets the scan's ``illumination`` as a point
    attribute and the mesh preview; the scan is hidden and the meshes shown. Only for a scan
    of all their vertices (``stride`` 1)."""
    from addon.preview import mesh_preview  # noqa: PLC0415
    values = scan_values(scan)
    start = 0
    for obj in meshes:
        n = len(obj.data.vertices)
        rgba = np.ones((n, 4), np.float32)
        rgba[:, :3] = values[start:start + n]
        start += n
        attrs = obj.data.attributes
        if "illumination" in attrs:
            attrs.remove(attrs["illumination"])
        attrs.new("illumination", "FLOAT_COLOR", "POINT").data.foreach_set("color", rgba.ravel())
        obj.hide_set(False)
        obj.hide_render = False
    mesh_preview.build_mesh_preview(meshes)
    scan.hide_set(True)
    scan.hide_render = True


def show_scan(scan, meshes) -> None:
    """The scan's own preview shown again, the meshes hidden (after ``points_on_meshes``)."""
    for obj in meshes:
        obj.hide_set(True)
        obj.hide_render = True
    scan.hide_set(False)
    scan.hide_render = False


SCENES = ("mesh_room", "scan_room", "scan_room_normals", "scan_bunny")


def build(name: str, cell: float = 0.05, stride: int = 1) -> dict:
    """The scene ``name`` (one of SCENES) in an empty file: ``surfaces`` (the meshes of the
    true surfaces), ``emitter`` (or None), ``scan`` (the scan object, or None) and ``lit``
    (what Illumap is given); ``cell``: the rooms' grid or the bunny's floor's (m), ``stride``: the bunny scan keeps
    every stride-th vertex."""
    if name == "mesh_room":
        s = room(cell)
        return {**s, "scan": None, "lit": s["surfaces"] + [s["emitter"]]}
    if name in ("scan_room", "scan_room_normals"):
        s = room(cell, JITTER)
        scan = as_scan(s["surfaces"], normals=name == "scan_room_normals")
        return {**s, "scan": scan, "lit": [scan, s["emitter"]]}
    if name == "scan_bunny":
        s = bunny(floor_cell=cell, stride=stride)
        scan = as_scan(s["surfaces"][:1], stride=stride)
        return {**s, "scan": scan, "lit": [scan, s["surfaces"][1]],
                "scanned": s["surfaces"][:1]}
    raise ValueError(f"unknown preview scene {name!r}; known: {', '.join(SCENES)}")


def compute_and_show(scene: dict, settings=None):
    """Run Illumap on the scene's ``lit`` objects and show what the UI shows after Compute
    (``operators.after_write`` with the scene's default settings). Returns the result."""
    from addon.ui import operators  # noqa: PLC0415
    from addon import pipeline  # noqa: PLC0415
    context = bpy.context
    result = pipeline.compute(context, scene["lit"], settings or pipeline.Settings())
    surfel_object = bpy.data.objects.get(result.object_name)
    operators.after_write(context, context.scene.illumap, surfel_object, result)
    return result
