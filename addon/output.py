"""Writing results into Blender: the surfel object, transfer onto meshes, file exports.

The surfel object ``Illumap Surfels`` is a PointCloud with point attributes ``illumination``
(FLOAT_COLOR, outgoing radiance), ``normal`` (FLOAT_VECTOR), ``radius`` (FLOAT, disc radius
sqrt(A/π) in m), ``albedo`` and ``emission`` (FLOAT_COLOR). bpy 5.0.1 cannot resize a
PointCloud, so the points are built as a vertex-only mesh and converted (should the conversion
operator be unavailable in some context, the vertex-only mesh with the same point attributes is
kept, as docs/architecture.md allows). A re-run swaps the new
data into the existing object (keeping its modifiers — e.g. the preview — and materials) and
deletes the old data.
"""

from __future__ import annotations

import os

import numpy as np

from .neighbours import knn

SURFEL_OBJECT = "Illumap Surfels"
ATTRIBUTE = "illumination"
#: Nearest surfels a lightmap texel averages (``export_lightmap``).
TRANSFER_K = 8


def _rgba(rgb: np.ndarray) -> np.ndarray:
    out = np.ones((len(rgb), 4), dtype=np.float32)
    out[:, :3] = rgb
    return out.ravel()


def _build_pointcloud(context, positions, normals, radius, colors: dict[str, np.ndarray]):
    """A new PointCloud datablock with the given point attributes (via a temporary mesh)."""
    n = len(positions)
    mesh = bpy_data().meshes.new(SURFEL_OBJECT)
    mesh.vertices.add(n)
    mesh.vertices.foreach_set("co", np.asarray(positions, dtype=np.float32).ravel())
    attr = mesh.attributes.new("normal", "FLOAT_VECTOR", "POINT")
    attr.data.foreach_set("vector", np.asarray(normals, dtype=np.float32).ravel())
    attr = mesh.attributes.new("radius", "FLOAT", "POINT")
    attr.data.foreach_set("value", np.asarray(radius, dtype=np.float32))
    for name, rgb in colors.items():
        attr = mesh.attributes.new(name, "FLOAT_COLOR", "POINT")
        attr.data.foreach_set("color", _rgba(rgb))
    tmp = bpy_data().objects.new(SURFEL_OBJECT + " (building)", mesh)
    context.scene.collection.objects.link(tmp)
    try:
        try:
            with context.temp_override(active_object=tmp, object=tmp, selected_objects=[tmp],
                                       selected_editable_objects=[tmp]):
                import bpy
                bpy.ops.object.convert(target="POINTCLOUD")
        except RuntimeError:
            pass  # e.g. an operator poll failing in an unusual context: keep the mesh
        result = tmp.data
    finally:
        bpy_data().objects.remove(tmp)
    if is_pointcloud(result):
        if ".select_vert" in result.attributes:
            result.attributes.remove(result.attributes[".select_vert"])
        if mesh.users == 0:
            bpy_data().meshes.remove(mesh)
    return result


def is_pointcloud(data) -> bool:
    """True for a PointCloud datablock."""
    import bpy
    return isinstance(data, bpy.types.PointCloud)


def bpy_data():
    """``bpy.data`` (imported lazily so that this module imports without bpy for docs/tests)."""
    import bpy
    return bpy.data


def write_surfels(context, positions: np.ndarray, normals: np.ndarray, areas: np.ndarray,
                  illumination: np.ndarray, albedo: np.ndarray, emission: np.ndarray):
    """Create or replace the ``Illumap Surfels`` object; returns it.

    Positions in m (world space; the object keeps an identity transform), areas in m²,
    colours as linear RGB radiance / reflectance.
    """
    radius = np.sqrt(np.asarray(areas, dtype=np.float64) / np.pi)
    cloud = _build_pointcloud(context, positions, normals, radius, {
        ATTRIBUTE: illumination, "albedo": albedo, "emission": emission})
    data = bpy_data()
    obj = data.objects.get(SURFEL_OBJECT)
    kind = "POINTCLOUD" if is_pointcloud(cloud) else "MESH"
    if obj is not None and obj.type != kind:
        # A stale object of another type under our name: replace it entirely.
        old = obj.data
        data.objects.remove(obj)
        if old is not None and old.users == 0:
            _remove_data(old)
        obj = None
    if obj is None:
        obj = data.objects.new(SURFEL_OBJECT, cloud)
        context.scene.collection.objects.link(obj)
    else:
        old = obj.data
        for mat in old.materials:
            cloud.materials.append(mat)
        obj.data = cloud
        obj.matrix_world.identity()
        if old.users == 0:
            _remove_data(old)
    cloud.name = SURFEL_OBJECT
    if obj.name not in context.scene.objects:
        context.scene.collection.objects.link(obj)
    return obj


def _remove_data(datablock) -> None:
    for coll in (bpy_data().meshes, bpy_data().pointclouds):
        if datablock.name in coll and coll[datablock.name] == datablock:
            coll.remove(datablock)
            return


def write_mesh_values(obj, receivers, corner_values: np.ndarray, domain: str = "CORNER") -> None:
    """Write radiance evaluated at ``obj``'s own corners (``sampling.Receivers``; (L, 3)) as
    the FLOAT_COLOR attribute ``illumination`` in ``domain`` ('CORNER', or 'POINT': the mean
    of each vertex's corners)."""
    mesh = obj.data
    values = np.asarray(corner_values, dtype=np.float64)
    if domain == "POINT":
        values = receivers.per_vertex(values)
    _replace_colors(mesh, domain, values)


def write_point_values(obj, values: np.ndarray) -> None:
    """Write radiance per point (n, 3) of a point-cloud object, or of a mesh that has vertices
    only, as its FLOAT_COLOR point attribute ``illumination``."""
    _replace_colors(obj.data, "POINT", np.asarray(values, dtype=np.float64))


def _replace_colors(data, domain: str, values: np.ndarray) -> None:
    """(Re)create the FLOAT_COLOR attribute ``illumination`` of a mesh or point cloud in
    ``domain`` with ``values`` (n, 3)."""
    attr = data.attributes.get(ATTRIBUTE)
    if attr is not None:
        data.attributes.remove(attr)
    if is_pointcloud(data):
        attr = data.attributes.new(ATTRIBUTE, "FLOAT_COLOR", domain)
    else:
        attr = data.color_attributes.new(ATTRIBUTE, "FLOAT_COLOR", domain)
    attr.data.foreach_set("color", _rgba(values))
    if is_pointcloud(data):
        data.update_tag()
    else:
        data.update()


def point_count(obj) -> int:
    """Points of a point-cloud object, or vertices of a mesh."""
    data = obj.data
    return len(data.points) if is_pointcloud(data) else len(data.vertices)


def export_npz(path: str, **arrays: np.ndarray) -> None:
    """Save surfel arrays (positions m, normals, areas m², albedo, emission, illumination)."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    np.savez_compressed(path, **{k: np.asarray(v) for k, v in arrays.items()})


def _write_exr(path: str, pixels: np.ndarray) -> None:
    """Write (H, W, C) float32 pixels, row 0 at the top, as a zip-compressed linear EXR."""
    import OpenImageIO as oiio

    h, w, c = pixels.shape
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    spec = oiio.ImageSpec(w, h, c, oiio.FLOAT)
    spec.attribute("compression", "zip")
    if c == 4:
        spec.channelnames = ("R", "G", "B", "A")
    out = oiio.ImageOutput.create(path)
    if out is None:
        raise OSError(f"OpenImageIO cannot write '{path}': {oiio.geterror()}")
    try:
        if not out.open(path, spec) or not out.write_image(np.ascontiguousarray(pixels, np.float32)):
            raise OSError(f"OpenImageIO failed writing '{path}': {out.geterror()}")
    finally:
        out.close()


def export_lightmap(path: str, uv: np.ndarray, values: np.ndarray, size: int = 256,
                    k: int = TRANSFER_K) -> np.ndarray:
    """Write one object's illumination as a UV-space lightmap (linear RGBA EXR); returns pixels.

    Each texel centre takes the inverse-distance blend of the k surfels nearest in UV space.
    Texels farther than twice the typical surfel spacing (in UV) from any surfel lie outside
    the UV islands: RGB 0 and alpha 0 (alpha 1 inside). Islands that touch in UV space but not
    on the surface can blend along their borders (a known limit of UV-space interpolation).
    Row 0 of the file is v = 1 (images are stored top-down).
    """
    uv = np.asarray(uv, dtype=np.float64)
    pts = np.column_stack([uv, np.zeros(len(uv))])
    centres = (np.arange(size) + 0.5) / size
    tu, tv = np.meshgrid(centres, centres[::-1])
    texels = np.column_stack([tu.ravel(), tv.ravel(), np.zeros(tu.size)])
    _, self_dist = knn(pts, pts, min(2, len(pts)))
    spacing = float(np.median(self_dist[:, -1])) if len(pts) > 1 else 1.0
    idx, dist = knn(pts, texels, min(k, len(pts)))
    w = 1.0 / (dist ** 2 + (0.1 * spacing) ** 2 + 1e-30)
    w /= w.sum(axis=1, keepdims=True)
    rgb = np.einsum("mk,mkc->mc", w, np.asarray(values, dtype=np.float64)[idx])
    inside = dist[:, 0] <= 2.0 * max(spacing, 0.5 / size)
    img = np.zeros((size * size, 4), dtype=np.float32)
    img[inside, :3] = rgb[inside]
    img[inside, 3] = 1.0
    img = img.reshape(size, size, 4)
    _write_exr(path, img)
    return img


def export_exr(path: str, illumination: np.ndarray, width: int | None = None) -> None:
    """Write the per-surfel illumination as a linear float RGB EXR via OpenImageIO.

    Surfels are laid out row by row (``width`` columns, default ⌈√N⌉; unused pixels are 0), so
    the file is a lossless linear dump of the values for compositing or inspection.
    """
    vals = np.asarray(illumination, dtype=np.float32)
    n = len(vals)
    width = int(width or max(1, int(np.ceil(np.sqrt(n)))))
    height = max(1, -(-n // width))
    img = np.zeros((height * width, 3), dtype=np.float32)
    img[:n] = vals
    _write_exr(path, img.reshape(height, width, 3))
