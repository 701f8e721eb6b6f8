"""Blender's lamps and world as light records (``illumap.lights.Lamp``), read on the main
thread; the light model they feed, with its conventions measured against Cycles, is
``illumap.lights``.
"""

from __future__ import annotations

import numpy as np
from illumap.lights import Lamp

from ..errors import ExitCode, IllumapError
from .materials import describe_not_finite, not_finite

#: Disk and ellipse lamps are polygons of this many sides, scaled to the same area.
_DISK_SIDES = 48

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
        if not np.all(np.isfinite(m)):
            raise IllumapError(f"Lamp '{obj.name}' has a non-finite transform (NaN or infinite "
                               "location, rotation or scale, on it or on a parent, constraint "
                               "or driver)")
        lin, pos = m[:3, :3], m[:3, 3].copy()
        direction = -lin[:, 2]
        length = float(np.linalg.norm(direction))
        kind = light.type
        if not length > 0:
            warnings.append(f"Lamp '{obj.name}': its scale is zero, so it points nowhere and "
                            "emits no light; ignored")
            continue
        direction /= length
        _check_lamp_values(obj.name, light)
        color = np.array(light.color, dtype=np.float64) * float(light.energy)
        if not np.all(np.isfinite(color)):
            raise IllumapError(f"Lamp '{obj.name}': colour × power {tuple(color)} is not finite")
        if kind in ("POINT", "SPOT"):
            lamp = Lamp(obj.name, kind, color, pos, direction, radius=float(light.shadow_soft_size))
            if kind == "SPOT":
                lamp.spot_size, lamp.spot_blend = float(light.spot_size), float(light.spot_blend)
        elif kind == "SUN":
            lamp = Lamp(obj.name, kind, color, pos, direction, angle=float(light.angle))
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
            if not area > 0:
                # Its power would be spread over no area: infinite radiance, NaN form factors.
                warnings.append(f"Lamp '{obj.name}': area light of size 0 m² (size "
                                f"{sx:g} × {sy:g} m at its scale) emits no light; ignored — "
                                "give it a size")
                continue
            polygon = pos + corners[:, :1] * ax + corners[:, 1:] * ay
            if getattr(light, "spread", np.pi) < np.pi - 1e-6:
                warnings.append(f"Lamp '{obj.name}': area light spread is ignored (treated as 180°)")
            lamp = Lamp(obj.name, kind, color, pos, direction, polygon=polygon, area=area,
                        shape=light.shape, axes=np.array([ax, ay]))
        else:
            warnings.append(f"Lamp '{obj.name}': type {kind} is not supported; ignored")
            continue
        lamps.append(lamp)
    return lamps


def _check_lamp_values(name: str, light) -> None:
    """Refuse a lamp whose power or colour is NaN or infinite (Blender stores an infinite
    field as inf, or as 3.4e38): it would light everything with infinite light."""
    for label, values in (("power (Power/Strength)", [float(light.energy)]),
                          ("colour", list(light.color))):
        if not_finite(values).any():
            raise IllumapError(f"Lamp '{name}': its {label} is {describe_not_finite(values)}; "
                               "give it a finite value", ExitCode.INPUT)


def world_light(scene, warnings: list[str]) -> Lamp | None:
    """The world's light as a uniform sky (kind 'WORLD', ``color`` the radiance (3,)), or None
    when the world is black or absent (main thread only).

    Understood: a Background (or Emission) node on the World Output whose Color is a constant
    or an equirectangular Environment Texture (its solid-angle mean, linear), times a
    constant Strength; without a node tree, the world colour. Anything else is warned about
    and left out."""
    world = scene.world
    if world is None:
        return None
    radiance = _world_radiance(world, warnings)
    if radiance is not None and not_finite(radiance).any():
        raise IllumapError(f"World '{world.name}': its light (colour × strength) is "
                           f"{describe_not_finite(radiance)}; give it a finite colour and "
                           "strength", ExitCode.INPUT)
    if radiance is None or radiance.max() <= 0:
        return None
    return Lamp(f"World '{world.name}'", "WORLD", radiance, np.zeros(3), np.array([0.0, 0.0, -1.0]))


def _world_radiance(world, warnings: list[str]) -> np.ndarray | None:
    from ..compat import uses_nodes
    if not uses_nodes(world):
        return np.array(world.color[:3], dtype=np.float64)
    tree = world.node_tree
    out = tree.get_output_node("CYCLES") if hasattr(tree, "get_output_node") else None
    if out is None or not out.inputs["Surface"].is_linked:
        return None
    node = out.inputs["Surface"].links[0].from_node
    where = f"World '{world.name}'"
    if node.type not in ("BACKGROUND", "EMISSION"):
        warnings.append(f"{where}: its surface is a '{node.name}' node, which Illumap does not "
                        "evaluate (a Background node is): world light left out")
        return None
    strength_socket = node.inputs["Strength"]
    if strength_socket.is_linked:
        warnings.append(f"{where}: the Background strength is linked, which Illumap does not "
                        "evaluate: its unlinked value is used")
    strength = float(strength_socket.default_value)
    if not_finite(strength):    # inf is stored as 3.4e38, which a dim colour would hide
        raise IllumapError(f"{where}: its Strength is {describe_not_finite(strength)}; give it a "
                           "finite value", ExitCode.INPUT)
    color_socket = node.inputs["Color"]
    if not color_socket.is_linked:
        return np.array(color_socket.default_value[:3], dtype=np.float64) * strength
    source = color_socket.links[0].from_node
    if source.type == "TEX_ENVIRONMENT" and source.image is not None:
        try:
            return _environment_mean(source, warnings, where) * strength
        except Exception as exc:  # noqa: BLE001 - a missing file is a warning, not a failure
            warnings.append(f"{where}: environment image '{source.image.name}' could not be "
                            f"read ({exc}): world light left out")
            return None
    warnings.append(f"{where}: the Background colour comes from a '{source.name}' node, which "
                    "Illumap does not evaluate (a constant or an Environment Texture is): "
                    "world light left out")
    return None


def _environment_mean(node, warnings: list[str], where: str) -> np.ndarray:
    """Mean radiance (3,) of an Environment Texture's image over the sphere, linear."""
    from .materials import _image_pixels, srgb_to_linear
    px, srgb = _image_pixels(node.image)
    rgb = px[..., :3].astype(np.float64)
    if srgb:
        rgb = srgb_to_linear(rgb)
    h = rgb.shape[0]
    if node.projection == "EQUIRECTANGULAR":
        # Rows run from the south pole up; each covers a band of solid angle ∝ cos(latitude).
        latitude = ((np.arange(h) + 0.5) / h - 0.5) * np.pi
        weight = np.cos(latitude)
    else:
        warnings.append(f"{where}: the environment's {node.projection.lower()} projection is "
                        "averaged without solid-angle weights")
        weight = np.ones(h)
    rows = rgb.mean(axis=1)
    return (weight[:, None] * rows).sum(axis=0) / weight.sum()

