"""Files a run writes besides the blend: the surfels' data (.npz), their light as an EXR, and
UV-space lightmaps of the lit meshes (``illumap.lightmaps`` makes the images, Blender's own
image writer writes them, so no Python module beyond ``bpy`` is needed)."""

from __future__ import annotations

import os

import bpy
import numpy as np

from ..kinds import ATTRIBUTE


def lightmap_pattern(pattern: str) -> str:
    """A lightmap path pattern with ``{object}`` (appended before the extension if absent)."""
    if "{object}" not in pattern:
        root, ext = os.path.splitext(pattern)
        pattern = f"{root}_{{object}}{ext or '.exr'}"
    return pattern

def export_npz(path: str, **arrays: np.ndarray) -> None:
    """Save surfel arrays (positions m, normals, areas m², albedo, emission, illumination)."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    np.savez_compressed(path, **{k: np.asarray(v) for k, v in arrays.items()})


def exr_problem() -> str | None:
    """Why this Blender cannot write EXR files (a build without OpenEXR), or None. Checked
    with the export paths, before anything is read or solved."""
    items = bpy.types.ImageFormatSettings.bl_rna.properties["file_format"].enum_items
    if "OPEN_EXR" not in items.keys():
        return "this Blender build cannot write OpenEXR images"
    return None


def write_exr(path: str, pixels: np.ndarray) -> None:
    """Write (H, W, C) float32 pixels (C = 3 or 4), row 0 at the top, as a zip-compressed
    32-bit linear EXR with Blender's own image writer (``Image.save_render`` with EXR image
    settings on a scratch scene, so the user's scenes are not touched; a linear format takes
    no view transform). Needs no Python module beyond ``bpy``."""
    pixels = np.asarray(pixels, dtype=np.float32)
    h, w, c = pixels.shape
    if c not in (3, 4):
        raise ValueError(f"an EXR image needs 3 or 4 channels, not {c}")
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    rgba = np.ones((h, w, 4), dtype=np.float32)
    rgba[:, :, :c] = pixels
    image = bpy.data.images.new(".illumap-exr", w, h, alpha=c == 4, float_buffer=True)
    scene = bpy.data.scenes.new(".illumap-exr")
    try:
        image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())  # Blender: bottom row first
        settings = scene.render.image_settings
        settings.file_format = "OPEN_EXR"
        settings.color_mode = "RGBA" if c == 4 else "RGB"
        settings.color_depth = "32"
        settings.exr_codec = "ZIP"
        try:
            image.save_render(path, scene=scene)
        except RuntimeError as exc:
            raise OSError(f"Blender could not write '{path}': {str(exc).strip()}") from None
        if not os.path.isfile(path) or not os.path.getsize(path):
            raise OSError(f"Blender wrote no image to '{path}'")
    finally:
        bpy.data.images.remove(image)
        bpy.data.scenes.remove(scene)


def read_exr(path: str) -> np.ndarray:
    """(H, W, 4) float32 pixels of an EXR file, row 0 at the top, read with Blender's own
    image reader (linear values as stored)."""
    image = bpy.data.images.load(path, check_existing=False)
    try:
        image.colorspace_settings.is_data = True     # the values as stored
        w, h = image.size
        px = np.empty(w * h * 4, dtype=np.float32)
        image.pixels.foreach_get(px)
        return px.reshape(h, w, 4)[::-1].copy()
    finally:
        bpy.data.images.remove(image)


def mesh_uv_triangles(mesh) -> tuple[np.ndarray, np.ndarray] | None:
    """(UV per corner (L, 2), triangles as corner indices (T, 3)) of a mesh's active UV map,
    or None when it has none."""
    layer = mesh.uv_layers.active
    if layer is None:
        return None
    uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    layer.data.foreach_get("uv", uv)
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", tris)
    return uv.reshape(-1, 2).astype(np.float64), tris.reshape(-1, 3)


def export_lightmaps(result, pattern: str, size: int = 256,
                     margin: int | None = None) -> tuple[list[str], list[str]]:
    """Write a lightmap per mesh that a run lit at its corners (``result.receiver_values``),
    from that per-corner light (``corner_lightmap``) in the mesh's active UV map, to
    ``pattern`` with ``{object}`` replaced by the object's name made safe for a file name.
    Returns (the files written, warnings for the meshes left out)."""
    written, warnings = write_lightmaps(result.receiver_values, pattern, size, margin)
    if not result.receiver_values:
        warnings.append("No mesh was lit at its corners (Transfer off, or point clouds only): "
                        "no lightmap written")
    return written, warnings


def corner_values(mesh) -> np.ndarray | None:
    """The light written on ``mesh`` per corner (L, 3): its ``illumination`` attribute (Corner
    domain, or Point spread to the corners), None without one."""
    attr = mesh.color_attributes.get(ATTRIBUTE)
    if attr is None or attr.data_type != "FLOAT_COLOR" or attr.domain not in ("CORNER", "POINT"):
        return None
    rgba = np.empty(len(attr.data) * 4, dtype=np.float32)
    attr.data.foreach_get("color", rgba)
    rgb = rgba.reshape(-1, 4)[:, :3].astype(np.float64)
    if attr.domain == "CORNER":
        return rgb
    vertex = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", vertex)
    return rgb[vertex]


def write_lightmaps(values_by_name: dict, pattern: str, size: int = 256,
                    margin: int | None = None) -> tuple[list[str], list[str]]:
    """Write a lightmap per mesh object named in ``values_by_name`` (its per-corner light
    (L, 3)), as ``export_lightmaps`` does; returns (the files written, warnings)."""
    pattern = lightmap_pattern(pattern)
    written, warnings = [], []
    for name, values in values_by_name.items():
        obj = bpy.data.objects.get(name)
        if obj is None or obj.type != "MESH":
            continue
        found = mesh_uv_triangles(obj.data)
        if found is None:
            warnings.append(f"Object '{name}' has no UV map: no lightmap written")
            continue
        uv, tris = found
        if len(uv) != len(values):
            warnings.append(f"Object '{name}': its mesh changed since the run: no lightmap "
                            "written")
            continue
        safe = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in name)
        path = pattern.replace("{object}", safe)
        from illumap.lightmaps import corner_lightmap   # numpy: not in the reduced UI
        grow = {} if margin is None else {"margin": margin}   # None: the core's margin
        write_exr(path, corner_lightmap(uv, tris, values, size, **grow))
        written.append(path)
    return written, warnings


def export_lightmap(path: str, uv: np.ndarray, values: np.ndarray, size: int = 256,
                    k: int = 8) -> np.ndarray:
    """Write one object's illumination as a UV-space lightmap (linear RGBA EXR); returns pixels.

    Each texel centre takes the inverse-distance blend of the k surfels nearest in UV space.
    Texels farther than twice the typical surfel spacing (in UV) from any surfel lie outside
    the UV islands: RGB 0 and alpha 0 (alpha 1 inside). Islands that touch in UV space but not
    on the surface can blend along their borders (a known limit of UV-space interpolation).
    Row 0 of the file is v = 1 (images are stored top-down).
    """
    from illumap.lightmaps import surfel_lightmap   # the native search
    img = surfel_lightmap(uv, values, size, k)
    write_exr(path, img)
    return img


def export_exr(path: str, illumination: np.ndarray, width: int | None = None) -> None:
    """Write the per-surfel illumination as a linear float RGB EXR (Blender's image writer).

    Surfels are laid out row by row (``width`` columns, default ⌈√N⌉; unused pixels are 0), so
    the file is a lossless linear dump of the values for compositing or inspection.
    """
    vals = np.asarray(illumination, dtype=np.float32)
    n = len(vals)
    width = int(width or max(1, int(np.ceil(np.sqrt(n)))))
    height = max(1, -(-n // width))
    img = np.zeros((height * width, 3), dtype=np.float32)
    img[:n] = vals
    write_exr(path, img.reshape(height, width, 3))
