"""Per-surfel albedo and emission from Blender materials (Cycles node trees).

What is understood, after the active Material Output's Surface input:

* Diffuse BSDF: albedo = Color.
* Principled BSDF: albedo = Base Color × (1 − Metallic) × (1 − Transmission Weight) (the diffuse
  part Cycles bakes); emission = Emission Color × Emission Strength.
* Emission: emission = Color × Strength, albedo 0.
* Add Shader (sum) and Mix Shader (blend) with a constant Fac, or with Fac from Geometry ▸
  Backfacing (0 on the front, 1 on the back: the usual one-sided light) or Light Path ▸ Is
  Camera Ray (0: light never reaches a surface by a camera ray, so such a mix hides an emitter
  from the camera only). Each side of a surface is evaluated on its own (``side``).
* A colour input may be a constant, an RGB node, an Image Texture (sampled at the surfel's UV,
  from the node's UV Map / Texture Coordinate input or the active UV map; sRGB byte images are
  filtered as stored and linearised after, as Cycles does; flat projection, single images
  only), a Color Attribute node (without a name: the mesh's default, i.e. render, colour
  attribute, as Cycles reads it; never the active one, which only Solid shading shows and
  Solid Preview sets to ``illumination``), an Attribute node
  (geometry attribute by name), or a Mix Color node (Mix / Multiply / Add with a constant
  factor) of any of these. Reroutes are followed.

Anything else falls back to ``DEFAULT_ALBEDO`` (grey 0.8, Blender's default surface) and no
emission, with a warning that names the material. A NaN or infinite colour or strength (Blender
stores inf as 3.4e38) is refused with an IllumapError naming the material and the object. Objects without a material use the same grey
silently. Albedo is clamped to ``MAX_ALBEDO`` (< 1: the solver refuses albedo ≥ 1), with a
warning. Emission is radiance in Blender's units (strength 1, colour c ⇒ radiance c).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from illumap.limits import limit

from ..errors import ExitCode, IllumapError


class MeshSamples(Protocol):
    """What the material evaluator reads of sampled points (``sampling.MeshSamples``, and a
    point cloud's own stand-in): declared here, so that this module needs nothing above it."""

    areas: np.ndarray            # (N,) m²
    material_index: np.ndarray   # (N,) int64 slot
    mesh: object                 # .materials (slot list), .name

    def uv(self, name: str | None = None) -> np.ndarray | None: ...

    def color(self, name: str | None = None) -> np.ndarray | None: ...

DEFAULT_ALBEDO = (0.8, 0.8, 0.8)
MAX_ALBEDO = limit("material_albedo").high


#: Blender stores an infinite float socket value (typing "inf") as the largest float32:
#: a value this large stands for infinity.
FLT_MAX = 3.4028234663852886e38


class Unsupported(Exception):
    """A node setup that is not understood; the message says which node."""


class NotFinite(Exception):
    """A colour or value that is NaN or infinite; the message says which input."""


def not_finite(values) -> np.ndarray:
    """Per value: NaN, infinite, or at Blender's stand-in for infinity (``FLT_MAX``)."""
    values = np.asarray(values, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return ~(np.abs(values) < FLT_MAX)


def _finite(values) -> bool:
    return not not_finite(values).any()


def describe_not_finite(values) -> str:
    """What is wrong with ``values``: NaN, or infinite."""
    values = np.asarray(values, dtype=np.float64)
    if np.isnan(values).any():
        return "NaN"
    return "infinite (Blender stores inf as 3.4e38)"


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """The sRGB transfer function, inverted (IEC 61966-2-1)."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _follow(socket):
    """The output socket feeding ``socket`` (through reroutes), or None if unlinked."""
    while socket.is_linked:
        link = socket.links[0]
        if not link.is_valid or link.is_muted:
            return None
        out = link.from_socket
        node = out.node
        if node.type == "REROUTE":
            socket = node.inputs[0]
            continue
        return out
    return None


def _image_pixels(image) -> tuple[np.ndarray, bool]:
    """(H, W, 4) float pixels of ``image`` as stored, and whether they are sRGB-encoded bytes:
    those are filtered first and converted to linear after, as Cycles does."""
    w, h = image.size
    if w == 0 or h == 0:
        raise Unsupported(f"image '{image.name}' has no pixels (missing file?)")
    ch = image.channels
    px = np.empty(w * h * ch, dtype=np.float32)
    image.pixels.foreach_get(px)
    px = px.reshape(h, w, ch)  # float32: an 8k texture stays at 1 GiB
    if ch < 4:
        pad = np.ones((h, w, 4), dtype=np.float32)
        pad[..., :ch] = px
        if ch == 1:
            pad[..., 1:3] = px
        px = pad
    return px, (not image.is_float and image.colorspace_settings.name == "sRGB")


def sample_image(pixels: np.ndarray, uv: np.ndarray, *, interpolation: str = "Linear",
                 extension: str = "REPEAT") -> np.ndarray:
    """Sample (H, W, C) ``pixels`` at ``uv`` (N, 2) like Cycles: pixel i covers [i/W, (i+1)/W)."""
    h, w = pixels.shape[:2]
    uv = np.nan_to_num(np.asarray(uv, dtype=np.float64))

    def wrap(i, n):
        return np.mod(i, n) if extension == "REPEAT" else np.clip(i, 0, n - 1)

    if interpolation == "Closest":
        x = wrap(np.floor(uv[:, 0] * w).astype(np.int64), w)
        y = wrap(np.floor(uv[:, 1] * h).astype(np.int64), h)
        return pixels[y, x].astype(np.float64)
    fx, fy = uv[:, 0] * w - 0.5, uv[:, 1] * h - 0.5
    x0, y0 = np.floor(fx).astype(np.int64), np.floor(fy).astype(np.int64)
    tx, ty = (fx - x0)[:, None], (fy - y0)[:, None]
    xa, xb, ya, yb = wrap(x0, w), wrap(x0 + 1, w), wrap(y0, h), wrap(y0 + 1, h)
    return ((1 - ty) * ((1 - tx) * pixels[ya, xa] + tx * pixels[ya, xb])
            + ty * ((1 - tx) * pixels[yb, xa] + tx * pixels[yb, xb]))


class _Evaluator:
    """Evaluates one material's tree for a subset of surfels."""

    def __init__(self, samples: MeshSamples, rows: np.ndarray, images: dict | None = None,
                 side: str = "front") -> None:
        self.images = {} if images is None else images  # image name → pixels, read once
        self.side = side
        self.samples = samples
        self.rows = rows
        self.n = len(rows)

    def _uv(self, node) -> np.ndarray:
        name = None
        out = _follow(node.inputs["Vector"]) if "Vector" in node.inputs else None
        if out is not None:
            src = out.node
            if src.type == "UVMAP":
                name = src.uv_map or None
            elif src.type == "TEX_COORD" and out.name == "UV":
                name = None
            else:
                raise Unsupported(f"texture coordinates from node '{src.name}' ({src.type})")
        uv = self.samples.uv(name)
        if uv is None:
            raise Unsupported(f"node '{node.name}' needs UV map '{name or 'active'}', which the mesh lacks")
        return uv[self.rows]

    def color(self, socket) -> np.ndarray:
        """(n, 3) linear colour on a colour input; NotFinite where it is NaN or infinite."""
        rgb = self._color(socket)
        if not _finite(rgb):
            raise NotFinite(f"'{socket.name}' of node '{socket.node.name}' is "
                            f"{describe_not_finite(rgb)}")
        return rgb

    def _color(self, socket) -> np.ndarray:
        out = _follow(socket)
        if out is None:
            value = np.array(socket.default_value, dtype=np.float64).ravel()
            rgb = np.resize(value, 3) if value.size >= 3 else np.full(3, value[0])
            return np.broadcast_to(rgb[:3], (self.n, 3)).copy()
        node = out.node
        if node.type == "RGB":
            return np.broadcast_to(np.array(out.default_value[:3]), (self.n, 3)).copy()
        if node.type == "TEX_IMAGE" and out.name == "Color":
            if node.image is None:
                raise Unsupported(f"Image Texture '{node.name}' has no image")
            if node.projection != "FLAT" or node.image.source not in ("FILE", "GENERATED"):
                raise Unsupported(f"Image Texture '{node.name}' ({node.projection} projection, "
                                  f"{node.image.source} image): only flat single images")
            key = node.image.name_full
            if key not in self.images:
                self.images[key] = _image_pixels(node.image)
            px, srgb = self.images[key]
            rgb = sample_image(px, self._uv(node), interpolation=node.interpolation,
                               extension=node.extension)[:, :3]
            return srgb_to_linear(rgb) if srgb else rgb
        if node.type == "VERTEX_COLOR" and out.name == "Color":
            col = self.samples.color(node.layer_name or None)
            if col is None:
                raise Unsupported(f"Color Attribute '{node.layer_name or 'render (default)'}' "
                                  "not on the mesh")
            return col[self.rows, :3]
        if node.type == "ATTRIBUTE" and node.attribute_type == "GEOMETRY" and out.name == "Color":
            col = self.samples.color(node.attribute_name)
            if col is None:
                raise Unsupported(f"attribute '{node.attribute_name}' is not a colour attribute of the mesh")
            return col[self.rows, :3]
        if node.type == "MIX" and getattr(node, "data_type", "") == "RGBA" and out.name == "Result" \
                or node.type == "MIX_RGB":
            return self._mix(node)
        raise Unsupported(f"colour from node '{node.name}' ({node.type})")

    def _mix(self, node) -> np.ndarray:
        """Mix Color (MIX / MULTIPLY / ADD) with a constant factor."""
        if node.type == "MIX":
            fac_socket, a_socket, b_socket = node.inputs[0], node.inputs[6], node.inputs[7]
            clamp = node.clamp_result
        else:
            fac_socket, a_socket, b_socket = node.inputs[0], node.inputs[1], node.inputs[2]
            clamp = node.use_clamp
        fac = min(max(self.scalar(fac_socket), 0.0), 1.0)
        a, b = self.color(a_socket), self.color(b_socket)
        blend = node.blend_type
        if blend == "MIX":
            out = (1 - fac) * a + fac * b
        elif blend == "MULTIPLY":
            out = (1 - fac) * a + fac * a * b
        elif blend == "ADD":
            out = a + fac * b
        else:
            raise Unsupported(f"Mix node '{node.name}' blend mode {blend}")
        return np.clip(out, 0.0, 1.0) if clamp else out

    def scalar(self, socket) -> float:
        """A constant float input, or Geometry ▸ Backfacing (per ``side``) or Light Path ▸ Is
        Camera Ray (0) feeding it; other links are not understood. NotFinite where the
        constant is NaN or infinite."""
        out = _follow(socket)
        if out is None:
            value = float(socket.default_value)
            if not _finite(value):
                raise NotFinite(f"'{socket.name}' of node '{socket.node.name}' is "
                                f"{describe_not_finite(value)}")
            return value
        if out.node.type == "NEW_GEOMETRY" and out.name == "Backfacing":
            return 1.0 if self.side == "back" else 0.0
        if out.node.type == "LIGHT_PATH" and out.name == "Is Camera Ray":
            return 0.0
        raise Unsupported(f"linked input '{socket.name}' on node '{socket.node.name}'")

    def shader(self, socket) -> tuple[np.ndarray, np.ndarray]:
        """(albedo, emission), each (n, 3), of the shader on a shader socket."""
        zero = np.zeros((self.n, 3))
        out = _follow(socket)
        if out is None:
            return zero, zero.copy()  # an unconnected Surface renders black
        node = out.node
        kind = node.type
        if kind == "BSDF_DIFFUSE":
            return self.color(node.inputs["Color"]), zero
        if kind == "BSDF_PRINCIPLED":
            diffuse = (1.0 - self.scalar(node.inputs["Metallic"])) * (
                1.0 - self.scalar(node.inputs["Transmission Weight"]))
            albedo = self.color(node.inputs["Base Color"]) * diffuse
            emission = self.color(node.inputs["Emission Color"]) * self.scalar(node.inputs["Emission Strength"])
            return albedo, emission
        if kind == "EMISSION":
            return zero, self.color(node.inputs["Color"]) * self.scalar(node.inputs["Strength"])
        if kind == "ADD_SHADER":
            a1, e1 = self.shader(node.inputs[0])
            a2, e2 = self.shader(node.inputs[1])
            return a1 + a2, e1 + e2
        if kind == "MIX_SHADER":
            fac = min(max(self.scalar(node.inputs[0]), 0.0), 1.0)
            # The shader a factor of exactly 0 or 1 leaves out is not read: the idioms that
            # hide an emitter from the camera mix it with what Illumap has no use for (a
            # Transparent BSDF, a Holdout).
            if fac == 0.0:
                return self.shader(node.inputs[1])
            if fac == 1.0:
                return self.shader(node.inputs[2])
            a1, e1 = self.shader(node.inputs[1])
            a2, e2 = self.shader(node.inputs[2])
            return (1 - fac) * a1 + fac * a2, (1 - fac) * e1 + fac * e2
        raise Unsupported(f"shader node '{node.name}' ({kind})")


def material_values(material, samples: MeshSamples, rows: np.ndarray,
                    warnings: list[str], side: str = "front",
                    owner: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Albedo and emission (n, 3) for the surfels ``rows`` of ``samples`` that use ``material``,
    seen from ``side`` ('front' or 'back') of the surface. A colour or strength that is NaN
    or infinite (an Emission Strength of inf, a NaN Base Color, a texture or colour attribute
    holding such values) is refused with an IllumapError naming the material and ``owner``
    (the object): no light can be computed from it."""
    n = len(rows)
    default = np.broadcast_to(np.array(DEFAULT_ALBEDO), (n, 3)).copy()
    if material is None:
        return default, np.zeros((n, 3))
    tree = material.node_tree
    where = f"Material '{material.name}'" + (f" on object '{owner}'" if owner else "")
    if tree is None:
        colour = np.array(material.diffuse_color[:3], dtype=np.float64)
        if not _finite(colour):
            raise IllumapError(f"{where}: its colour is {describe_not_finite(colour)}; give it "
                               "a finite colour", ExitCode.INPUT)
        return np.broadcast_to(colour, (n, 3)).copy(), np.zeros((n, 3))
    output = tree.get_output_node("CYCLES")
    if output is None:
        warnings.append(f"Material '{material.name}': no Material Output node; using grey {DEFAULT_ALBEDO[0]}")
        return default, np.zeros((n, 3))
    try:
        albedo, emission = _Evaluator(samples, rows, side=side).shader(output.inputs["Surface"])
    except Unsupported as exc:
        warnings.append(f"Material '{material.name}': unsupported {exc}; using grey {DEFAULT_ALBEDO[0]} "
                        "and no emission")
        return default, np.zeros((n, 3))
    except NotFinite as exc:
        raise IllumapError(f"{where}: {exc}; give it a finite value", ExitCode.INPUT) from None
    for name, values in (("albedo", albedo), ("emission", emission)):
        if not _finite(values):     # finite inputs whose product overflows
            raise IllumapError(f"{where}: its {name} is {describe_not_finite(values)} (a colour "
                               "times a strength beyond any float); give it finite values",
                               ExitCode.INPUT)
    return albedo, emission


def surfel_materials(samples: MeshSamples, warnings: list[str],
                     side: str = "front") -> tuple[np.ndarray, np.ndarray]:
    """Albedo and emission (N, 3) for every surfel of ``samples`` (multi-material aware), on
    ``side`` ('front' or 'back') of the surface.

    Albedo is clamped to [0, MAX_ALBEDO] and emission to ≥ 0, with a warning when clamping.
    """
    n = len(samples.areas)
    albedo, emission = np.zeros((n, 3)), np.zeros((n, 3))
    mats = samples.mesh.materials
    for index in np.unique(samples.material_index):
        rows = np.flatnonzero(samples.material_index == index)
        material = mats[index] if 0 <= index < len(mats) else None
        albedo[rows], emission[rows] = material_values(material, samples, rows, warnings, side,
                                                       owner=samples.mesh.name)
    name = samples.mesh.name
    if (albedo > MAX_ALBEDO).any():
        warnings.append(f"Object '{name}': albedo above {MAX_ALBEDO} clamped (energy would not converge)")
    if (albedo < 0).any() or (emission < 0).any():
        warnings.append(f"Object '{name}': negative albedo or emission clamped to 0")
    bad = ~np.isfinite(albedo) | ~np.isfinite(emission)
    if bad.any():
        warnings.append(f"Object '{name}': non-finite material values replaced by 0")
        albedo[bad] = 0.0
        emission[bad] = 0.0
    return np.clip(albedo, 0.0, MAX_ALBEDO), np.maximum(emission, 0.0)
