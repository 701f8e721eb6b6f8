"""Per-surfel albedo and emission from materials: Diffuse, Principled, image texture by UV,
colour attribute, emission, multi-material, unsupported nodes (fallback + warning)."""

import bpy
import numpy as np

from illumap_bpy_testing import diffuse_material, emission_material, make_plane

from addon.read import materials
from addon import pipeline


def prepare(*objs, **kw):
    kw.setdefault("density", 400.0)
    kw.setdefault("lamps", False)
    return pipeline.prepare(bpy.context.evaluated_depsgraph_get(), list(objs), pipeline.Settings(**kw))


def new_material(name):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    mat.node_tree.nodes.clear()
    out = mat.node_tree.nodes.new("ShaderNodeOutputMaterial")
    return mat, mat.node_tree.nodes, mat.node_tree.links, out


def test_diffuse_colour():
    obj = make_plane("P", material=diffuse_material("Red", (0.7, 0.2, 0.1)))
    job = prepare(obj)
    assert np.allclose(job.albedo, (0.7, 0.2, 0.1), atol=1e-6)
    assert np.all(job.emission == 0)
    assert not job.warnings


def test_principled_base_and_emission():
    mat, nodes, links, out = new_material("Pr")
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = (0.3, 0.5, 0.6, 1)
    bsdf.inputs["Emission Color"].default_value = (1.0, 0.5, 0.25, 1)
    bsdf.inputs["Emission Strength"].default_value = 4.0
    links.new(bsdf.outputs[0], out.inputs["Surface"])
    job = prepare(make_plane("P", material=mat))
    assert np.allclose(job.albedo, (0.3, 0.5, 0.6), atol=1e-6)
    assert np.allclose(job.emission, (4.0, 2.0, 1.0), atol=1e-6)


def test_emission_shader_strength():
    job = prepare(make_plane("E", material=emission_material("Em", (0.5, 1.0, 0.25), 3.0)))
    assert np.allclose(job.emission, (1.5, 3.0, 0.75), atol=1e-6)
    assert np.all(job.albedo == 0)


def test_image_texture_sampled_at_uv():
    # 8×4 float image: left half red, right half blue (linear, no colour transform).
    img = bpy.data.images.new("LR", 8, 4, float_buffer=True)
    px = np.zeros((4, 8, 4), np.float32)
    px[:, :4] = (0.9, 0.1, 0.0, 1.0)
    px[:, 4:] = (0.0, 0.2, 0.7, 1.0)
    img.pixels.foreach_set(px.ravel())
    mat, nodes, links, out = new_material("Tex")
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = img
    tex.interpolation = "Closest"
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    links.new(tex.outputs["Color"], bsdf.inputs["Color"])
    links.new(bsdf.outputs[0], out.inputs["Surface"])
    bpy.ops.mesh.primitive_plane_add(size=2.0)  # has a UV map: u = (x + 1)/2
    obj = bpy.context.active_object
    obj.data.materials.append(mat)
    job = prepare(obj)
    x = job.positions[:, 0]
    left, right = x < -0.05, x > 0.05
    assert left.sum() > 100 and right.sum() > 100
    assert np.allclose(job.albedo[left], (0.9, 0.1, 0.0), atol=1e-6)
    assert np.allclose(job.albedo[right], (0.0, 0.2, 0.7), atol=1e-6)


def test_byte_srgb_image_is_linearised():
    img = bpy.data.images.new("S", 2, 2)  # byte, sRGB
    img.pixels.foreach_set(np.full(16, 0.5, np.float32))
    px, srgb = materials._image_pixels(img)
    assert srgb and np.allclose(px[..., :3], 128 / 255, atol=2e-3)   # stored, not yet linear
    assert abs(materials.srgb_to_linear(px[0, 0, 0]) - 0.214) < 0.01


def test_byte_srgb_image_is_filtered_before_linearising():
    """Half black, half white sRGB bytes, bilinear: midway between the two texels Cycles
    reads the mean of the encoded values, linearised (0.214), not the mean of linear ones
    (0.5)."""
    img = bpy.data.images.new("Edge", 2, 1)  # byte, sRGB: black texel, white texel
    img.pixels.foreach_set(np.array([0, 0, 0, 1, 1, 1, 1, 1], np.float32))
    mat, nodes, links, out = new_material("EdgeTex")
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = img
    tex.extension = "EXTEND"
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    links.new(tex.outputs["Color"], bsdf.inputs["Color"])
    links.new(bsdf.outputs[0], out.inputs["Surface"])
    bpy.ops.mesh.primitive_plane_add(size=2.0)  # u = (x + 1) / 2
    obj = bpy.context.active_object
    obj.data.materials.append(mat)
    job = prepare(obj)
    mid = np.abs(job.positions[:, 0]) < 0.02           # u ≈ 0.5: halfway between texel centres
    assert mid.sum() > 3
    assert np.allclose(job.albedo[mid, 0], materials.srgb_to_linear(0.5), atol=0.02)


def test_colour_attribute_node():
    mat, nodes, links, out = new_material("VC")
    vc = nodes.new("ShaderNodeVertexColor")
    vc.layer_name = "paint"
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    links.new(vc.outputs["Color"], bsdf.inputs["Color"])
    links.new(bsdf.outputs[0], out.inputs["Surface"])
    obj = make_plane("P", size=1.0, material=mat)
    attr = obj.data.color_attributes.new("paint", "FLOAT_COLOR", "POINT")
    # vertices in order (-,-) (+,-) (+,+) (-,+): red on the x<0 side, green on x>0.
    cols = np.array([[1, 0, 0, 1], [0, 1, 0, 1], [0, 1, 0, 1], [1, 0, 0, 1]], np.float32)
    attr.data.foreach_set("color", cols.ravel())
    job = prepare(obj)
    x = job.positions[:, 0] + 0.5  # 0..1 across the plane: linear interpolation in x
    assert np.allclose(job.albedo[:, 0], np.clip(1 - x, 0, 0.999), atol=1e-5)
    assert np.allclose(job.albedo[:, 1], np.clip(x, 0, 0.999), atol=1e-5)


def test_multi_material():
    mesh = bpy.data.meshes.new("MM")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0)], [],
                     [(0, 1, 2, 3), (1, 4, 5, 2)])
    mesh.materials.append(diffuse_material("A", (0.2, 0.2, 0.2)))
    mesh.materials.append(emission_material("B", (1, 1, 1), 2.0))
    mi = np.array([0, 1], np.int32)
    mesh.polygons.foreach_set("material_index", mi)
    obj = bpy.data.objects.new("MM", mesh)
    bpy.context.scene.collection.objects.link(obj)
    job = prepare(obj)
    left = job.positions[:, 0] < 1
    assert np.allclose(job.albedo[left], 0.2) and np.all(job.emission[left] == 0)
    assert np.all(job.albedo[~left] == 0) and np.allclose(job.emission[~left], 2.0)


def test_unsupported_node_falls_back_with_warning():
    mat, nodes, links, out = new_material("Glassy")
    glass = nodes.new("ShaderNodeBsdfGlass")
    links.new(glass.outputs[0], out.inputs["Surface"])
    job = prepare(make_plane("P", material=mat))
    assert np.allclose(job.albedo, materials.DEFAULT_ALBEDO)
    assert any("Glassy" in w for w in job.warnings)


def test_albedo_clamped_below_one_with_warning():
    job = prepare(make_plane("P", material=diffuse_material("White", (1.0, 1.0, 1.0))))
    assert np.all(job.albedo < 1.0) and np.allclose(job.albedo, materials.MAX_ALBEDO)
    assert any("clamped" in w for w in job.warnings)


def test_no_material_is_default_grey_silently():
    job = prepare(make_plane("P"))
    assert np.allclose(job.albedo, 0.8) and not job.warnings


def test_mix_color_multiply_of_rgb_node():
    mat, nodes, links, out = new_material("Mixed")
    mix = nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "MULTIPLY"
    mix.inputs["Factor"].default_value = 1.0
    mix.inputs[6].default_value = (0.5, 0.5, 0.5, 1)
    rgb = nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (0.4, 0.8, 1.0, 1)
    links.new(rgb.outputs[0], mix.inputs[7])
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    links.new(mix.outputs[2], bsdf.inputs["Base Color"])
    links.new(bsdf.outputs[0], out.inputs["Surface"])
    job = prepare(make_plane("P", material=mat))
    assert np.allclose(job.albedo, (0.2, 0.4, 0.5), atol=1e-6) and not job.warnings


def emission_mixed(name, color, strength, other, other_inputs, factor_node, factor_output):
    """A material mixing an Emission (first) with an ``other`` shader (second, its inputs set
    from ``other_inputs``) by ``factor_output`` of a ``factor_node``; returns the material,
    the factor node and the Mix Shader."""
    mat, nodes, links, out = new_material(name)
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (*color, 1)
    emission.inputs["Strength"].default_value = strength
    second = nodes.new(other)
    for key, value in other_inputs.items():
        second.inputs[key].default_value = value
    factor = nodes.new(factor_node)
    mix = nodes.new("ShaderNodeMixShader")
    links.new(factor.outputs[factor_output], mix.inputs["Fac"])
    links.new(emission.outputs[0], mix.inputs[1])
    links.new(second.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], out.inputs["Surface"])
    return mat, factor, mix


def test_backfacing_mix_is_one_sided_emission_of_the_front_shader():
    """Geometry ▸ Backfacing into a Mix Shader (emission first, black second): what users build
    for a one-sided light. Surfels are front faces: the emission, no warning."""
    black = {"Color": (0.0, 0.0, 0.0, 1)}
    mat, _, _ = emission_mixed("OneSided", (1.0, 0.5, 0.25), 8.0, "ShaderNodeBsdfDiffuse", black,
                               "ShaderNodeNewGeometry", "Backfacing")
    job = prepare(make_plane("P", material=mat))
    assert np.allclose(job.emission, (8.0, 4.0, 2.0), atol=1e-6)
    assert np.all(job.albedo == 0) and not job.warnings


def test_is_camera_ray_mix_hides_an_emitter_but_keeps_its_light():
    """Light Path ▸ Is Camera Ray into a Mix Shader (emission first, a transparent BSDF
    second): the camera sees through the emitter, every other ray sees the emission, as in
    Cycles. Illumap's light is never a camera ray: the emission, no warning."""
    mat, path, mix = emission_mixed("Hidden", (0.5, 1.0, 1.0), 4.0, "ShaderNodeBsdfTransparent",
                                    {}, "ShaderNodeLightPath", "Is Camera Ray")
    job = prepare(make_plane("P", material=mat))
    assert np.allclose(job.emission, (2.0, 4.0, 4.0), atol=1e-6) and not job.warnings
    # Another Light Path output is not understood: said, not guessed.
    mat.node_tree.links.new(path.outputs["Is Shadow Ray"], mix.inputs["Fac"])
    assert prepare(make_plane("Q", material=mat)).warnings


def test_same_seed_same_surfels():
    obj = make_plane("P", material=diffuse_material("D", (0.5,) * 3))
    a, b = prepare(obj), prepare(obj)
    c = prepare(obj, seed=1)
    assert np.array_equal(a.positions, b.positions)
    assert not np.array_equal(a.positions, c.positions)
