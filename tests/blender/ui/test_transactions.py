"""One transaction per run, and transfer that respects Blender's data model (issue 35).

* A failed run leaves the file's data as it was: ``fingerprint`` (every object, mesh, point
  cloud, material, node group, image and collection, with each attribute's type, domain and
  values, the active and render colour attribute, modifiers, custom properties) is the same
  in memory after the failure, and in the saved file before and after (``save_and_compare``).
  Failures: an export path under a file (refused before the solve), an export that fails while
  written (after the solve), an object removed between prepare and write, a mesh in Edit Mode
  (before the solve and at the write), and a failure in the middle of the swap of a second run
  (the first run's result is put back).
* Transfer: a mesh shared by two objects, a library-linked mesh and an existing
  ``illumination`` of another type are refused with a message that says what to do; an Array
  modifier skips that mesh with a warning; the active and render colour attributes never
  change; a user's own object named "Illumap Surfels" is never replaced.
"""

import hashlib
import os

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import add_lamp, diffuse_material, make_plane, requires_core, select_only

from addon.write import exports, output
from addon import pipeline
from addon.errors import IllumapError, OutputError

pytestmark = requires_core

_KEYS = {"FLOAT_COLOR": ("color", 4), "BYTE_COLOR": ("color", 4), "FLOAT_VECTOR": ("vector", 3),
         "FLOAT": ("value", 1), "INT": ("value", 1), "BOOLEAN": ("value", 1),
         "INT32_2D": ("value", 2), "FLOAT2": ("vector", 2)}


def _attr_digest(attr):
    key, width = _KEYS.get(attr.data_type, (None, 0))
    if key is None:
        return None
    values = np.zeros(len(attr.data) * width, dtype=np.float64 if attr.data_type not in
                      ("INT", "BOOLEAN", "INT32_2D") else np.int64)
    if attr.data_type == "BOOLEAN":
        values = np.zeros(len(attr.data), dtype=bool)
    attr.data.foreach_get(key, values)
    return hashlib.sha1(np.ascontiguousarray(values).tobytes()).hexdigest()


def _geometry(data):
    ca = getattr(data, "color_attributes", None)
    colours = (ca.active_color_name or "", ca.default_color_name or "") \
        if ca is not None and hasattr(ca, "active_color_name") else None
    return (data.name, data.users,
            tuple(sorted((a.name, a.data_type, a.domain, _attr_digest(a))
                         for a in data.attributes)),
            colours, tuple(m.name if m else "" for m in data.materials))


def _props(idb):
    return tuple(sorted((k, str(idb[k])) for k in idb.keys()))


def fingerprint():
    """The file's data as a comparable value (what a failed run must leave as it was)."""
    bpy.context.view_layer.update()      # matrices as evaluated
    return {
        "objects": sorted((o.name, o.type, o.data.name if o.data else "", _props(o),
                           tuple((m.name, m.type) for m in o.modifiers),
                           tuple(round(v, 6) for row in o.matrix_world for v in row),
                           tuple(sorted(c.name for c in o.users_collection)))
                          for o in bpy.data.objects),
        "meshes": sorted(_geometry(m) for m in bpy.data.meshes),
        "pointclouds": sorted(_geometry(p) for p in bpy.data.pointclouds),
        "materials": sorted(m.name for m in bpy.data.materials),
        "node_groups": sorted(g.name for g in bpy.data.node_groups),
        "images": sorted(i.name for i in bpy.data.images),
        "collections": sorted(c.name for c in bpy.data.collections),
    }


def _saved_fingerprint(path):
    bpy.ops.wm.open_mainfile(filepath=str(path))
    return fingerprint()


def save_and_compare(tmp_path, failing, *, expect=IllumapError, match=None):
    """Save the file, run ``failing()`` (which must raise ``expect`` matching ``match``),
    and prove the data is unchanged: in memory, and in the file saved before against the file
    saved after (both read back)."""
    before, after = tmp_path / "before.blend", tmp_path / "after.blend"
    in_memory = fingerprint()
    bpy.ops.wm.save_as_mainfile(filepath=str(before), copy=True)
    with pytest.raises(expect, match=match) as info:
        failing()
    assert fingerprint() == in_memory
    bpy.ops.wm.save_as_mainfile(filepath=str(after), copy=True)
    assert _saved_fingerprint(after) == _saved_fingerprint(before)
    return info.value


def lit_scene(name="Floor"):
    floor = make_plane(name, size=2.0, material=diffuse_material("Grey", (0.5,) * 3))
    add_lamp("POINT", location=(0, 0, 2), energy=100.0)
    return floor


def draft(**kw):
    kw.setdefault("budget", 300)
    kw.setdefault("gather_rays", 16)
    kw.setdefault("receiver_shadow_samples", 4)
    return pipeline.settings_from_preset("draft", **kw)


def colour(data, name="illumination"):
    attr = data.attributes[name]
    out = np.empty(len(attr.data) * 4)
    attr.data.foreach_get("color", out)
    return out.reshape(-1, 4)[:, :3]


# --- one transaction per run ---------------------------------------------------------------

def test_export_path_under_a_file_is_refused_before_the_solve(tmp_path, monkeypatch):
    floor = lit_scene()
    pipeline.compute(bpy.context, [floor], draft())     # a first result the failure must keep
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    import illumap

    def no_solve(*args, **kwargs):
        raise AssertionError("solved although the export cannot be written")
    monkeypatch.setattr(illumap, "solve", no_solve)
    error = save_and_compare(tmp_path, lambda: pipeline.compute(
        bpy.context, [floor], draft(export_exr=str(blocker / "out.exr"))),
        expect=OutputError, match=r"Export EXR path .*a_file.* is a file, not a folder")
    assert error.exit_code == 5


def test_export_failing_while_written_leaves_file_and_folder_as_they_were(tmp_path, monkeypatch):
    floor = lit_scene()
    pipeline.compute(bpy.context, [floor], draft())
    out = tmp_path / "out"
    out.mkdir()

    def disk_full(path, *args, **kwargs):
        with open(path, "wb") as f:
            f.write(b"half")
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(exports, "export_exr", disk_full)
    save_and_compare(tmp_path, lambda: pipeline.compute(
        bpy.context, [floor], draft(export_npz=str(out / "s.npz"), export_exr=str(out / "i.exr"))),
        expect=OutputError, match=r"Writing '.*i\.exr' failed: No space left on device")
    assert os.listdir(out) == []          # neither the npz written first nor a temporary file


def test_exports_are_written_whole(tmp_path):
    floor = lit_scene()
    out = tmp_path / "out"
    pipeline.compute(bpy.context, [floor], draft(export_npz=str(out / "s"),
                                                 export_exr=str(out / "i.exr")))
    assert sorted(os.listdir(out)) == ["i.exr", "s.npz"]


def test_object_removed_between_prepare_and_write(tmp_path):
    floor = lit_scene()
    other = make_plane("Other", size=1.0, location=(3, 0, 0),
                       material=diffuse_material("G2", (0.5,) * 3))
    settings = draft()
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [floor, other], settings)
    result = pipeline.run(job)
    mesh = other.data
    bpy.data.objects.remove(other)
    bpy.data.meshes.remove(mesh)
    save_and_compare(tmp_path, lambda: pipeline.write(bpy.context, job, result),
                     match=r"Object 'Other' was removed or renamed while Illumap computed.*"
                           r"Nothing was written")


def _edit_mode(obj):
    select_only(obj)
    bpy.ops.object.mode_set(mode="EDIT")
    assert obj.mode == "EDIT"


def test_mesh_in_edit_mode_is_refused_before_the_solve(tmp_path):
    floor = lit_scene()
    other = make_plane("Wall", size=1.0, location=(0, 1, 1),
                       material=diffuse_material("G2", (0.5,) * 3))
    _edit_mode(other)
    save_and_compare(tmp_path, lambda: pipeline.compute(bpy.context, [floor, other], draft()),
                     match=r"Object 'Wall' is in Edit Mode.*Leave Edit Mode \(Tab\)")


def test_mesh_entering_edit_mode_during_the_run_is_refused_at_the_write(tmp_path):
    floor = lit_scene()
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [floor], draft())
    result = pipeline.run(job)
    _edit_mode(floor)
    save_and_compare(tmp_path, lambda: pipeline.write(bpy.context, job, result),
                     match=r"Object 'Floor' is in Edit Mode.*Nothing was written")


def test_operator_edit_mode_reports_and_writes_nothing():
    floor = lit_scene()
    _edit_mode(floor)
    before = fingerprint()
    with pytest.raises(RuntimeError, match=r"Illumap failed: Transfer cannot write the "
                                           r"illumination: Object 'Floor' is in Edit Mode"):
        bpy.ops.illumap.compute_illumination_map()
    assert fingerprint() == before


def test_failure_in_the_swap_puts_the_first_result_back(tmp_path, monkeypatch):
    """A second run that fails after the meshes' attributes were swapped (while the surfel
    object is replaced) leaves the first run's attributes, colour settings and surfels."""
    floor = lit_scene()
    col = floor.data.color_attributes.new("Col", "BYTE_COLOR", "CORNER")
    floor.data.color_attributes.active_color_name = "Col"
    floor.data.color_attributes.default_color_name = "Col"
    pipeline.compute(bpy.context, [floor], draft(transfer_domain="POINT"))
    first = colour(floor.data).copy()
    assert col.name == "Col"

    def broken(self):
        raise RuntimeError("simulated failure while swapping the surfel object")
    monkeypatch.setattr(output.Transaction, "_swap_surfels", broken)
    save_and_compare(tmp_path, lambda: pipeline.compute(
        bpy.context, [floor], draft(budget=500, seed=3, transfer_domain="CORNER")),
        expect=RuntimeError, match="simulated failure")
    floor = bpy.data.objects["Floor"]
    attr = floor.data.attributes["illumination"]
    assert (attr.domain, attr.data_type) == ("POINT", "FLOAT_COLOR")
    assert np.array_equal(colour(floor.data), first)
    assert output.STAGING_ATTRIBUTE not in floor.data.attributes


def test_failure_while_staging_removes_what_was_staged(tmp_path, monkeypatch):
    """A failure after the surfel datablock and one mesh's attribute were staged."""
    a = lit_scene("A")
    b = make_plane("B", size=1.0, location=(0, 0, 1), material=diffuse_material("G2", (0.5,) * 3))
    calls = []
    real = output.Transaction.stage_colors

    def second_fails(self, data, domain, values):
        calls.append(data.name)
        if len(calls) == 2:
            raise RuntimeError("simulated failure while staging")
        return real(self, data, domain, values)
    monkeypatch.setattr(output.Transaction, "stage_colors", second_fails)
    save_and_compare(tmp_path, lambda: pipeline.compute(bpy.context, [a, b], draft()),
                     expect=RuntimeError, match="simulated failure while staging")
    assert len(calls) == 2


# --- transfer that respects Blender's data model ---------------------------------------------

def test_shared_mesh_is_refused_with_what_to_do(tmp_path):
    floor = lit_scene()
    twin = bpy.data.objects.new("Twin", floor.data)
    bpy.context.scene.collection.objects.link(twin)
    twin.location = (0, 0, 1.5)
    save_and_compare(tmp_path, lambda: pipeline.compute(bpy.context, [floor, twin], draft()),
                     match=r"Object 'Floor': its mesh 'Floor' is shared by 2 objects \('Floor', "
                           r"'Twin'\).*Make Single User.*or turn off Transfer to Meshes")
    # Without Transfer the same scene computes (the surfels hold each object's light).
    floor, twin = bpy.data.objects["Floor"], bpy.data.objects["Twin"]
    pipeline.compute(bpy.context, [floor, twin], draft(transfer=False))
    assert "illumination" not in floor.data.attributes


def test_shared_with_an_object_outside_the_run_is_refused_too():
    floor = lit_scene()
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("Copy", floor.data))
    with pytest.raises(IllumapError, match=r"shared by 2 objects"):
        pipeline.compute(bpy.context, [floor], draft())


def test_array_modifier_skips_the_mesh_with_a_warning():
    floor = lit_scene()
    wall = make_plane("Tiles", size=0.5, location=(0, 0, 0.5),
                      material=diffuse_material("G2", (0.5,) * 3))
    mod = wall.modifiers.new("Array", "ARRAY")
    mod.count = 3
    result = pipeline.compute(bpy.context, [floor, wall], draft())
    assert any(w.startswith("Object 'Tiles': its Array modifier 'Array' repeats the mesh")
               and "apply the modifier" in w for w in result.warnings), result.warnings
    assert "illumination" not in wall.data.attributes
    assert "illumination" in floor.data.attributes
    assert bpy.data.objects["Illumap Surfels"][output.MARKER]


def test_library_mesh_is_refused(tmp_path):
    lib_path = tmp_path / "library.blend"
    make_plane("LibPlane", size=1.0)
    bpy.data.meshes["LibPlane"].use_fake_user = True
    bpy.ops.wm.save_as_mainfile(filepath=str(lib_path))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    floor = lit_scene()
    with bpy.data.libraries.load(str(lib_path), link=True) as (src, dst):
        dst.meshes = ["LibPlane"]
    mesh = dst.meshes[0]
    assert mesh.library is not None
    obj = bpy.data.objects.new("Linked", mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = (0, 0, 1)
    before = fingerprint()
    with pytest.raises(IllumapError, match=r"Object 'Linked': its data is linked from the "
                                           r"library '.*library\.blend'.*Make Local"):
        pipeline.compute(bpy.context, [floor, obj], draft())
    assert fingerprint() == before


def test_active_and_render_colour_are_kept():
    floor = lit_scene()
    bare = make_plane("Bare", size=1.0, location=(1.5, 0, 1), flip=True,
                      material=diffuse_material("G2", (0.5,) * 3))
    ca = floor.data.color_attributes
    ca.new("Paint", "BYTE_COLOR", "CORNER")
    ca.new("Dirt", "FLOAT_COLOR", "POINT")
    ca.active_color_name, ca.default_color_name = "Paint", "Dirt"
    for domain in ("CORNER", "POINT", "CORNER"):   # re-runs, also across domains
        pipeline.compute(bpy.context, [floor, bare], draft(transfer_domain=domain))
        assert (ca.active_color_name, ca.default_color_name) == ("Paint", "Dirt")
        assert floor.data.attributes["illumination"].domain == domain
        # A mesh without colour attributes does not get 'illumination' as its active or
        # render colour (a Color Attribute node would read the light back as albedo).
        assert (bare.data.color_attributes.active_color_name or "",
                bare.data.color_attributes.default_color_name or "") == ("", "")


def test_existing_attribute_of_another_type_is_refused(tmp_path):
    floor = lit_scene()
    attr = floor.data.attributes.new("illumination", "FLOAT", "FACE")
    attr.data.foreach_set("value", [0.25])
    save_and_compare(tmp_path, lambda: pipeline.compute(bpy.context, [floor], draft()),
                     match=r"Object 'Floor': it already has an attribute 'illumination' of type "
                           r"FLOAT on the FACE domain, which Illumap did not write.*rename or "
                           r"remove")


def test_users_object_named_illumap_surfels_is_kept():
    floor = lit_scene()
    mine = make_plane("Illumap Surfels", size=0.1, location=(5, 5, 5))
    mine_data = mine.data.name
    result = pipeline.compute(bpy.context, [floor], draft())
    assert bpy.data.objects["Illumap Surfels"].data.name == mine_data
    assert not output.is_illumap_object(bpy.data.objects["Illumap Surfels"])
    assert result.object_name == "Illumap Surfels.001"
    assert any("that Illumap did not make" in w and "'Illumap Surfels.001'" in w
               for w in result.warnings), result.warnings
    # A re-run replaces Illumap's own object, not the user's, and makes no third one.
    pipeline.compute(bpy.context, [floor], draft())
    assert sorted(o.name for o in bpy.data.objects if o.name.startswith("Illumap")) == \
        ["Illumap Surfels", "Illumap Surfels.001"]
    assert bpy.data.objects["Illumap Surfels"].data.name == mine_data
    # Clear Results removes Illumap's object only.
    bpy.ops.illumap.clear_results()
    assert [o.name for o in bpy.data.objects if o.name.startswith("Illumap")] == ["Illumap Surfels"]


def test_surfel_object_is_marked_and_rerun_reuses_it():
    floor = lit_scene()
    pipeline.compute(bpy.context, [floor], draft())
    obj = bpy.data.objects["Illumap Surfels"]
    assert obj[output.MARKER]
    pipeline.compute(bpy.context, [floor, obj], draft())   # never an input of its own
    assert bpy.data.objects["Illumap Surfels"] == obj
    assert len(bpy.data.pointclouds) == 1


def test_interactive_finish_writes_nothing_when_a_target_went_away():
    """The modal path: the worker finished, then the user deleted a target before the write."""
    from addon.ui import operators
    floor = lit_scene()
    other = make_plane("Other", size=1.0, location=(3, 0, 0),
                       material=diffuse_material("G2", (0.5,) * 3))
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [floor, other], draft())
    task = operators.ComputeTask(job, pipeline.run, run_id=operators.begin_run()).start()
    task.wait(60)
    assert task.state == "DONE"
    mesh = other.data
    bpy.data.objects.remove(other)
    bpy.data.meshes.remove(mesh)
    before = fingerprint()
    reports = []
    assert operators.finish_task(bpy.context, task, lambda kind, text: reports.append(
        (kind, text))) == {"CANCELLED"}
    assert any(kind == {"ERROR"} and "Object 'Other' was removed or renamed" in text
               and "Nothing was written" in text for kind, text in reports), reports
    assert fingerprint() == before


def test_mesh_preview_leaves_a_users_material_of_that_name_alone():
    from addon.preview import mesh_preview
    floor = lit_scene()
    mine = diffuse_material(mesh_preview.MATERIAL_NAME, (0.1, 0.2, 0.3))
    nodes = sorted(n.bl_idname for n in mine.node_tree.nodes)
    pipeline.compute(bpy.context, [floor], draft())
    assert mesh_preview.build_mesh_preview([floor]) == ["Floor"]
    assert sorted(n.bl_idname for n in mine.node_tree.nodes) == nodes
    assert not mine.get(mesh_preview.MARKER)
    ng = floor.modifiers[mesh_preview.MODIFIER_NAME].node_group
    used = [n for n in ng.nodes if n.bl_idname == "GeometryNodeSetMaterial"][0]
    assert used.inputs["Material"].default_value != mine
    # Built again: the same (Illumap's) material and node group, no third one.
    mesh_preview.build_mesh_preview([floor])
    assert len([m for m in bpy.data.materials
                if m.name.startswith(mesh_preview.MATERIAL_NAME)]) == 2


def test_failure_renaming_an_export_rolls_the_datablocks_back(tmp_path, monkeypatch):
    """Exports are renamed into place last: a failure there still puts the datablocks back."""
    floor = lit_scene()
    pipeline.compute(bpy.context, [floor], draft())
    first = colour(floor.data).copy()
    out = tmp_path / "out"
    out.mkdir()

    def no_rename(src, dst):
        raise OSError(30, "Read-only file system")
    monkeypatch.setattr(output.os, "replace", no_rename)
    save_and_compare(tmp_path, lambda: pipeline.compute(
        bpy.context, [floor], draft(seed=5, export_exr=str(out / "i.exr"))),
        expect=OutputError, match=r"i\.exr' could not be put in place: Read-only file system")
    monkeypatch.undo()
    assert os.listdir(out) == []
    assert np.array_equal(colour(bpy.data.objects["Floor"].data), first)
