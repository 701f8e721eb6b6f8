"""NaN and infinite light or colour in a scene (issue 57): refused, naming the material (and
the object), the lamp or the world, with ``ExitCode.INPUT``, and nothing written.

Blender stores an infinite socket value (typing "inf" into Emission Strength) as the largest
float, 3.4e38; before, that strength wrote 3.4e38 at every corner.
"""

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import (add_lamp, diffuse_material, emission_material, link, make_plane,
                                 requires_core, sky_world)

from addon import pipeline
from addon.errors import ExitCode, IllumapError

from test_bad_scenes import snapshot

pytestmark = requires_core

INF, NAN = float("inf"), float("nan")


def floor(material=None, name="Floor"):
    return make_plane(name, size=2.0, material=material or diffuse_material("Grey", (0.5,) * 3))


def principled(name, **inputs):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    for key, value in inputs.items():
        bsdf.inputs[key].default_value = value
    return mat


def _inf_emission_strength():
    lamp_floor = floor()
    panel = make_plane("Panel", size=0.5, location=(0, 0, 1), flip=True,
                       material=emission_material("Glow", (1, 1, 1), INF))
    return [lamp_floor, panel]


def _inf_principled_emission():
    add_lamp("POINT", location=(0, 0, 2), energy=100.0)
    return [floor(principled("Hot", **{"Emission Color": (1, 1, 1, 1),
                                       "Emission Strength": INF}), name="Slab")]


def _nan_base_color():
    add_lamp("POINT", location=(0, 0, 2), energy=100.0)
    return [floor(principled("Murky", **{"Base Color": (NAN, 0.5, 0.5, 1.0)}), name="Tile")]


def _inf_diffuse_color():
    add_lamp("POINT", location=(0, 0, 2), energy=100.0)
    return [floor(diffuse_material("Blinding", (INF, 0.5, 0.5)), name="Rug")]


def _huge_times_strength():
    """Finite inputs whose product overflows: 3e38 × 10."""
    return [floor(), make_plane("Panel", size=0.5, location=(0, 0, 1), flip=True,
                                material=_emission_colour_times("Sun", 3e38, 10.0))]


def _emission_colour_times(name, colour, strength):
    mat = emission_material(name, (1, 1, 1), strength)
    em = next(n for n in mat.node_tree.nodes if n.type == "EMISSION")
    em.inputs["Color"].default_value = (colour, colour, colour, 1.0)
    return mat


def _inf_lamp_energy():
    add_lamp("POINT", location=(0, 0, 2), energy=INF)
    return [floor()]


def _nan_lamp_colour():
    add_lamp("SPOT", location=(0, 0, 2), energy=100.0, color=(NAN, 1.0, 1.0))
    return [floor()]


def _inf_sun_strength():
    add_lamp("SUN", energy=INF)
    return [floor()]


def _inf_world_strength():
    sky_world((0.05, 0.05, 0.05), INF)    # stored as 3.4e38: times 0.05, still finite
    return [floor()]


def _nan_scan_colour():
    add_lamp("POINT", location=(0, 0, 2), energy=100.0)
    g = (np.arange(10) + 0.5) / 10 - 0.5
    x, y = np.meshgrid(g, g, indexing="ij")
    pos = np.c_[x.ravel(), y.ravel(), np.zeros(100)]
    data = bpy.data.meshes.new("Points")
    data.vertices.add(len(pos))
    data.vertices.foreach_set("co", pos.astype(np.float32).ravel())
    rgba = np.full((len(pos), 4), 0.5, np.float32)
    rgba[7, 1] = NAN
    data.color_attributes.new("Col", "FLOAT_COLOR", "POINT").data.foreach_set("color", rgba.ravel())
    return [link(bpy.data.objects.new("Points", data))]


CASES = [
    (_inf_emission_strength, r"Material 'Glow' on object 'Panel': 'Strength' of node "
                             r"'Emission' is infinite"),
    (_inf_principled_emission, r"Material 'Hot' on object 'Slab': 'Emission Strength' .* "
                               r"is infinite"),
    (_nan_base_color, r"Material 'Murky' on object 'Tile': 'Base Color' .* is NaN"),
    (_inf_diffuse_color, r"Material 'Blinding' on object 'Rug': 'Color' .* is infinite"),
    (_huge_times_strength, r"Material 'Sun' on object 'Panel': its emission is infinite"),
    (_inf_lamp_energy, r"Lamp 'LPOINT': its power .* is infinite"),
    (_nan_lamp_colour, r"Lamp 'LSPOT': its colour is NaN"),
    (_inf_sun_strength, r"Lamp 'LSUN': its power .* is infinite"),
    (_inf_world_strength, r"World 'Sky': its Strength is infinite"),
    (_nan_scan_colour, r"Point cloud 'Points': colour attribute 'Col' is NaN at 1 points"),
]


@pytest.mark.parametrize("build, pattern", CASES, ids=[c[0].__name__.strip("_") for c in CASES])
def test_non_finite_light_or_colour_is_refused_by_name(build, pattern):
    objects = build()
    before = snapshot()
    with pytest.raises(IllumapError, match=pattern) as caught:
        pipeline.compute(bpy.context, objects, pipeline.settings_from_preset("draft"))
    assert caught.value.exit_code == ExitCode.INPUT
    assert snapshot() == before


def test_a_large_finite_emission_is_still_light():
    """1e6 is bright, not infinite: it runs, and writes finite values."""
    lit = floor()
    panel = make_plane("Panel", size=0.5, location=(0, 0, 1), flip=True,
                       material=emission_material("Bright", (1, 1, 1), 1e6))
    pipeline.compute(bpy.context, [lit, panel], pipeline.settings_from_preset("draft"))
    attr = lit.data.attributes["illumination"]
    out = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", out)
    assert np.isfinite(out).all() and out.max() > 1e3
