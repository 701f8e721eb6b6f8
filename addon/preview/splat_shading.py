"""The splats' shading on the Blender side: each scan point's light gradient across its
splat (``point_splats.splat_shading``, native), written into hidden point attributes
(``SHADING_ATTRIBUTES``) that the point preview's node group copies to its instances and its
material reads (``mesh_preview.splat_material``: base + X dx + Y dy). Written at every build:
they follow the light, where the splats' frames follow only the points."""

from __future__ import annotations

import numpy as np

from . import point_splats
from ..kinds import ATTRIBUTE

#: The hidden point attributes: each splat's value at its ellipse's centre and its change per
#: unit of the instanced disc's X and Y (RGB).
SHADING_ATTRIBUTES = {key: f".illumap_splat_{key}" for key in ("base", "dx", "dy")}
#: The same, as the instances carry them for the material (an Attribute node reads these).
SHADING_NAMES = {key: f"illumap_splat_{key}" for key in ("base", "dx", "dy")}
#: Shade each splat with its light's gradient (False: one flat value per splat).
SPLAT_SHADING = True


def vector_attribute(attrs, name: str):
    """The FLOAT_VECTOR point attribute ``name`` of ``attrs``, made (or remade, where one of
    another type or domain has that name)."""
    attr = attrs.get(name)
    if attr is not None and (attr.data_type != "FLOAT_VECTOR" or attr.domain != "POINT"):
        attrs.remove(attr)
        attr = None
    return attr if attr is not None else attrs.new(name, "FLOAT_VECTOR", "POINT")


def point_colours(obj, name: str) -> np.ndarray | None:
    """The point-domain colour attribute ``name`` of ``obj`` as (n, 4) float32, or None."""
    attr = obj.data.attributes.get(name)
    if attr is None or attr.domain != "POINT" or attr.data_type not in ("FLOAT_COLOR",
                                                                        "BYTE_COLOR"):
        return None
    out = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", out)
    return out.reshape(-1, 4)


def write_shading(obj, positions: np.ndarray, frames: dict, key: str | None = None) -> None:
    """Write the splats' shading from ``obj``'s ``illumination`` into its hidden attributes
    ``SHADING_ATTRIBUTES``: the light's gradient across each splat (``positions`` (n, 3) its
    points in its own coordinates, ``frames`` their splats), or flat splats (``SPLAT_SHADING``
    off, or no illumination). ``key``: the splats' fingerprint (their search's neighbours are
    reused where still kept)."""
    values = point_colours(obj, ATTRIBUTE)
    if values is None:
        values = np.zeros((len(positions), 4), np.float32)
    if SPLAT_SHADING:
        # The run's worker shaded these splats from the values just written (a preview right
        # after Compute); otherwise here.
        shading = point_splats.taken_shading(key, values) if key is not None else None
        if shading is None:
            shading = point_splats.splat_shading(positions, frames, values, key)
    else:
        zero = np.zeros((len(positions), 3), np.float32)
        shading = {"base": np.ascontiguousarray(values[:, :3]), "dx": zero, "dy": zero}
    for name_key, name in SHADING_ATTRIBUTES.items():
        vector_attribute(obj.data.attributes, name).data.foreach_set(
            "vector", np.ascontiguousarray(shading[name_key], np.float32).ravel())
