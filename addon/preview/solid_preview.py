"""Solid Preview: the illumination in Solid shading with Color ▸ Attribute, switched on and off
by the user.

Blender's Solid shading with Color ▸ Attribute (``View3DShading.color_type == 'VERTEX'``) shows
each mesh's *active* colour attribute (``color_attributes.active_color_name``); renders and an
empty-name Color Attribute node use the *default* (render) one (``default_color_name``). A run
never changes either (``output.Transaction`` keeps both), so Solid mode shows the user's own
colours until they ask for Illumap's:

* ``enable(objects, screen)``: each lit mesh (faces, and Illumap's FLOAT_COLOR ``illumination``
  on its corners or points) records its active colour attribute in the custom property
  ``RECORD`` on its mesh data (``""`` for none; saved with the file and undone with it) and
  makes ``illumination`` active. The default/render colour attribute is never changed, so
  renders, bakes and Illumap's own material reader (``sampling``: an empty-name Color Attribute
  node reads the render one) see what they saw before. Every 3D viewport of ``screen`` records
  its Solid colour type in the screen's custom property ``SCREEN_RECORD`` (area index → type)
  and shows Attribute.
* ``disable(blend_data)``: every recorded mesh gets its recorded active colour attribute back
  (none when that attribute was deleted meanwhile), and every recorded viewport that still
  shows Attribute gets its recorded colour type back (one the user changed since is left as
  they set it). The records are removed.

A run while Solid Preview is on keeps it on (``after_run``): Transfer writes the new
``illumination`` under the same name and keeps the active name, so lit meshes show the new
result, and meshes the run lit for the first time join. Removing the attribute with Illumap's
Clear (``forget``) gives the mesh its recorded active colour attribute back.

Point clouds are left out: Solid mode does not colour them by attribute (their
``color_attributes`` has no active colour in Blender 5.0–5.2); the Object Preview shows them.
"""

from __future__ import annotations

from ..write.output import ATTRIBUTE, is_illumap_object

#: Custom property on a mesh (its data): the active colour attribute before Solid Preview.
RECORD = "illumap_solid_active"
#: Custom property on a screen: {area index: Solid colour type before Solid Preview}.
SCREEN_RECORD = "illumap_solid_shading"
#: Solid shading's "Attribute" colour type.
ATTRIBUTE_COLOR = "VERTEX"


def lit_mesh(obj) -> bool:
    """Whether ``obj`` is a mesh with faces that Solid Preview can show: local data, not in
    Edit Mode, with a FLOAT_COLOR ``illumination`` colour attribute on its corners or points."""
    if obj is None or obj.type != "MESH" or is_illumap_object(obj):
        return False
    mesh = obj.data
    if mesh is None or mesh.library is not None or getattr(mesh, "is_editmode", False) or \
            len(mesh.polygons) == 0:
        return False
    attr = mesh.color_attributes.get(ATTRIBUTE)
    return attr is not None and attr.data_type == "FLOAT_COLOR" and \
        attr.domain in ("CORNER", "POINT")


def _show(mesh) -> None:
    ca = mesh.color_attributes
    default = ca.default_color_name or ""
    if RECORD not in mesh:
        mesh[RECORD] = ca.active_color_name or ""
    if (ca.active_color_name or "") != ATTRIBUTE:
        ca.active_color_name = ATTRIBUTE
    if (ca.default_color_name or "") != default:   # never the render one
        ca.default_color_name = default
    mesh.update_tag()


def _restore(mesh) -> None:
    """Give ``mesh`` its recorded active colour attribute back and drop the record."""
    if RECORD not in mesh:
        return
    recorded = str(mesh[RECORD])
    del mesh[RECORD]
    if mesh.library is not None:
        return
    ca = mesh.color_attributes
    default = ca.default_color_name or ""
    wanted = recorded if recorded and ca.get(recorded) is not None else ""
    if (ca.active_color_name or "") != wanted:
        ca.active_color_name = wanted
    if (ca.default_color_name or "") != default:
        ca.default_color_name = default
    mesh.update_tag()


def _viewports(screen):
    """(area index, View3DShading) of every 3D viewport of ``screen``."""
    if screen is None:
        return []
    return [(i, area.spaces.active.shading) for i, area in enumerate(screen.areas)
            if area.type == "VIEW_3D" and area.spaces.active is not None]


def show_viewports(screen) -> int:
    """Solid colour type Attribute in every 3D viewport of ``screen``, each one's previous type
    recorded (a type recorded already is kept: the one before Solid Preview). Returns how
    many viewports there are."""
    views = _viewports(screen)
    if not views:
        return 0
    record = {str(k): str(v) for k, v in dict(screen.get(SCREEN_RECORD, {})).items()}
    for index, shading in views:
        record.setdefault(str(index), shading.color_type)
        shading.color_type = ATTRIBUTE_COLOR
    screen[SCREEN_RECORD] = record
    return len(views)


def restore_viewports(screen) -> int:
    """Every recorded viewport of ``screen`` that still shows Attribute gets its recorded
    colour type back; the record is removed. Returns how many were restored."""
    if screen is None or SCREEN_RECORD not in screen:
        return 0
    record = dict(screen[SCREEN_RECORD])
    del screen[SCREEN_RECORD]
    restored = 0
    for index, shading in _viewports(screen):
        previous = record.get(str(index))
        if previous is not None and shading.color_type == ATTRIBUTE_COLOR:
            shading.color_type = str(previous)
            restored += 1
    return restored


def enable(objects, screen=None) -> list[str]:
    """Solid Preview on for the lit meshes among ``objects`` (``lit_mesh``) and the 3D
    viewports of ``screen``; returns the names of the objects shown."""
    shown, done = [], set()
    for obj in objects:
        if not lit_mesh(obj):
            continue
        if obj.data.as_pointer() not in done:
            done.add(obj.data.as_pointer())
            _show(obj.data)
        shown.append(obj.name)
    if shown:
        show_viewports(screen)
    return shown


def recorded_meshes(blend_data) -> list:
    """The meshes of the file that Solid Preview shows (they carry ``RECORD``)."""
    return [m for m in blend_data.meshes if RECORD in m]


def is_on(blend_data) -> bool:
    """Whether Solid Preview is on anywhere in the file: a mesh or a screen carries a record."""
    # Drawn with the panel on every redraw: the few screens first, and no list of meshes.
    return (any(SCREEN_RECORD in s for s in blend_data.screens)
            or any(RECORD in m for m in blend_data.meshes))


def disable(blend_data) -> int:
    """Solid Preview off everywhere in the file: every recorded mesh and viewport gets what was
    recorded back. Returns how many meshes were restored."""
    meshes = recorded_meshes(blend_data)
    for mesh in meshes:
        _restore(mesh)
    for screen in blend_data.screens:
        restore_viewports(screen)
    return len(meshes)


def forget(mesh) -> None:
    """After Illumap removed ``illumination`` from ``mesh``: its recorded active colour
    attribute back (nothing happens to a mesh that Solid Preview does not show)."""
    _restore(mesh)


def after_run(context, names) -> list[str]:
    """After a run wrote its result: while Solid Preview is on, the lit meshes among the
    objects named ``names`` show the new ``illumination`` (those already shown keep it
    active; those lit for the first time join). Returns the names shown; nothing while it is
    off."""
    data = context.blend_data
    if not recorded_meshes(data):
        return []
    objects = [data.objects.get(name) for name in names]
    return enable([o for o in objects if o is not None], None)
