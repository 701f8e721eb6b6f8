"""Writing results into Blender: the surfel object, transfer onto meshes, file exports.

The surfel object ``Illumap Surfels`` is a PointCloud with point attributes ``illumination``
(FLOAT_COLOR, outgoing radiance), ``normal`` (FLOAT_VECTOR), ``radius`` (FLOAT, disc radius
sqrt(A/π) in m), ``albedo`` and ``emission`` (FLOAT_COLOR). bpy 5.0.1 cannot resize a
PointCloud, so the points are built as a vertex-only mesh and converted (should the conversion
operator be unavailable in some context, the vertex-only mesh with the same point attributes is
kept, as docs/architecture.md allows). A re-run swaps the new
data into the existing object (keeping its modifiers — e.g. the preview — and materials) and
deletes the old data. Illumap's objects carry the custom property ``illumap_generated``; an
object of that name that Illumap did not make is never replaced (``surfel_target``).

One run is one transaction (``Transaction``): every target is checked first
(``transfer_problem``, ``check_targets``), the exports go to temporary files, the new
attributes are written under a temporary name and the new surfel data is built beside the old;
only then are they swapped in (``commit``). Any failure before or during the swap removes what
was made and puts back what was replaced (``rollback``), so the file's data is as it was.
"""

from __future__ import annotations

import os

import numpy as np

from .exports import exr_problem, lightmap_pattern
from ..kinds import ATTRIBUTE, RESULT_TYPES

SURFEL_OBJECT = "Illumap Surfels"
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


#: Custom property that marks the objects Illumap made (only those are ever replaced).
MARKER = "illumap_generated"
#: The name new attribute values are written under until the whole run is committed.
STAGING_ATTRIBUTE = "illumination_illumap_new"
#: Modifiers that repeat (or mirror) the mesh: one value per original corner cannot hold the
#: light of each copy.
REPEATING_MODIFIERS = {"ARRAY": "Array", "MIRROR": "Mirror", "SCREW": "Screw",
                       "PARTICLE_INSTANCE": "Particle Instance"}
#: The modifiers Illumap itself adds to meshes and point clouds (they change no point or corner).
OWN_MODIFIERS = ("Illumap Mesh Preview", "Illumap Point Preview")


def is_illumap_object(obj) -> bool:
    """An object Illumap made: marked ``illumap_generated`` (or ``illumap_surfels``), or, for
    files from before the marker, named ``Illumap Surfels[.NNN]`` with the surfel attributes
    ``illumination``, ``normal`` and ``radius``."""
    if obj is None:
        return False
    if obj.get(MARKER) or obj.get("illumap_surfels"):
        return True
    if obj.name != SURFEL_OBJECT and not obj.name.startswith(SURFEL_OBJECT + "."):
        return False
    data = obj.data
    attrs = getattr(data, "attributes", None)
    return attrs is not None and all(n in attrs for n in (ATTRIBUTE, "normal", "radius"))


def surfel_target(blend_data):
    """(the Illumap surfel object to replace or None, "taken" or None). The object named
    ``Illumap Surfels`` when Illumap made it, else another object Illumap made with that name
    and a suffix. "taken": a user's own object holds the name; it is never touched (the
    caller warns where the surfels went instead)."""
    own = blend_data.objects.get(SURFEL_OBJECT)
    if own is not None and is_illumap_object(own):
        return own, None
    others = sorted((o for o in blend_data.objects
                     if o.name.startswith(SURFEL_OBJECT + ".") and is_illumap_object(o)),
                    key=lambda o: o.name)
    found = others[0] if others else None
    return found, (None if own is None else "taken")


def _linked(obj) -> str | None:
    data = obj.data
    for thing, what in ((obj, "object"), (data, "data")):
        lib = getattr(thing, "library", None)
        if lib is not None:
            return (f"its {what} is linked from the library '{lib.filepath}', where an attribute "
                    "written here would be lost on reload")
    for thing, what in ((obj, "object"), (data, "data")):
        if getattr(thing, "override_library", None) is not None:
            return (f"its {what} is a library override, whose geometry (and attributes) "
                    "is re-read from the library on reload")
    return None


def _existing_conflict(obj, domains) -> str | None:
    attr = obj.data.attributes.get(ATTRIBUTE)
    if attr is None or (attr.data_type == "FLOAT_COLOR" and attr.domain in domains):
        return None
    return (f"it already has an attribute '{ATTRIBUTE}' of type {attr.data_type} on the "
            f"{attr.domain} domain, which Illumap did not write (Illumap writes FLOAT_COLOR on "
            f"{' or '.join(domains)}) and will not replace; rename or remove that attribute")


def object_users(blend_data) -> dict:
    """Data pointer → names of the objects that use it (one pass over the objects)."""
    users: dict = {}
    for o in blend_data.objects:
        if o.data is not None:
            users.setdefault(o.data.as_pointer(), []).append(o.name)
    return users


def _names(names, limit=3):
    shown = ", ".join(f"'{n}'" for n in names[:limit])
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")


def transfer_problem(obj, users: dict | None = None) -> str | None:
    """Why Transfer cannot write ``illumination`` onto ``obj`` (a mesh or point cloud) so that
    it is right and kept, with what to do; None when it can. The run is refused for these
    (``check_targets``)."""
    data = obj.data
    kind = "point cloud" if is_pointcloud(data) else "mesh"
    problem = _linked(obj)
    if problem is not None:
        return (f"Object '{obj.name}': {problem}. Make it local (Object > Relations > Make "
                "Local > Selected Objects and Data), or turn off Transfer to Meshes")
    if getattr(obj, "mode", "OBJECT") == "EDIT" or getattr(data, "is_editmode", False):
        return (f"Object '{obj.name}' is in Edit Mode, where its {kind} data is not up to date "
                "and an attribute written now would be lost on leaving Edit Mode. Leave Edit "
                "Mode (Tab) and run again")
    users = users if users is not None else object_users(bpy_data())
    sharing = users.get(data.as_pointer(), [obj.name])
    if len(sharing) > 1:
        return (f"Object '{obj.name}': its {kind} '{data.name}' is shared by {len(sharing)} "
                f"objects ({_names(sharing)}), which are lit differently, and one attribute on "
                "shared data cannot hold the light of each. Make the data single-user (Object > "
                "Relations > Make Single User > Object & Data), or turn off Transfer to Meshes")
    point_like = is_pointcloud(data) or len(data.polygons) == 0
    problem = _existing_conflict(obj, ("POINT",) if point_like else ("CORNER", "POINT"))
    if problem is not None:
        return f"Object '{obj.name}': {problem}"
    return None


def repeat_problem(obj, depsgraph=None) -> str | None:
    """Why one value per corner of ``obj``'s own mesh cannot be right after its modifiers
    (they repeat the mesh, so every copy would show the first copy's light); None otherwise.
    Transfer skips such objects with this warning."""
    if obj.type != "MESH":
        return None
    culprit = None
    for mod in obj.modifiers:
        if not (mod.show_viewport or mod.show_render) or mod.name in OWN_MODIFIERS:
            continue
        if mod.type in REPEATING_MODIFIERS:
            culprit = f"its {REPEATING_MODIFIERS[mod.type]} modifier '{mod.name}' repeats the mesh"
            break
        if mod.type == "NODES" and depsgraph is not None:
            ev = obj.evaluated_get(depsgraph).data
            if ev is not None and (len(ev.loops) != len(obj.data.loops)
                                   or len(ev.polygons) != len(obj.data.polygons)):
                culprit = f"its Geometry Nodes modifier '{mod.name}' changes the geometry"
                break
    if culprit is None:
        return None
    existing = (" (its existing 'illumination' attribute is left as it was)"
                if ATTRIBUTE in obj.data.attributes else "")
    return (f"Object '{obj.name}': {culprit}, so one attribute on the mesh would give every "
            f"copy the light of the original: no illumination written to it{existing}. The "
            "surfel object holds each copy's light; apply the modifier to transfer onto the "
            "mesh")


def transfer_targets(objects) -> list:
    """The objects of a run that Transfer writes onto: meshes and point clouds that Illumap
    did not make."""
    return [o for o in objects if o is not None and o.type in RESULT_TYPES
            and not is_illumap_object(o)]


def check_targets(objects, settings) -> None:
    """Refuse a run, before anything is read or solved, whose transfer could not be right or
    kept (``transfer_problem``), or whose export paths cannot be written
    (``check_export_paths``). Raises IllumapError naming every object and the cause."""
    from ..errors import IllumapError
    if getattr(settings, "transfer", False):
        users = object_users(bpy_data())
        problems = [p for p in (transfer_problem(o, users) for o in transfer_targets(objects))
                    if p is not None]
        if problems:
            more = f" (and {len(problems) - 3} more)" if len(problems) > 3 else ""
            raise IllumapError("Transfer cannot write the illumination: "
                               + "; ".join(problems[:3]) + more + ". Nothing was written.")
    check_export_paths(settings)


def npz_path(path: str) -> str:
    """The file numpy writes for ``path`` (it adds ``.npz`` when the name lacks it)."""
    return path if path.endswith(".npz") else path + ".npz"


def folder_problem(path: str) -> tuple[str, str | None]:
    """(the nearest existing folder above ``path``, why nothing can be written under it or
    None): it is a file, or a temporary file cannot be made in it (which, unlike a permission
    check, holds for root and read-only mounts too; the probe is removed)."""
    import tempfile
    ancestor = os.path.dirname(os.path.abspath(path)) or os.sep
    while not os.path.lexists(ancestor):
        parent = os.path.dirname(ancestor)
        if parent == ancestor:
            break
        ancestor = parent
    if not os.path.isdir(ancestor):
        return ancestor, f"'{ancestor}' is a file, not a folder, so nothing can be written under it"
    try:
        fd, probe = tempfile.mkstemp(prefix=".illumap-probe-", dir=ancestor)
        os.close(fd)
        os.remove(probe)
    except OSError as exc:
        return ancestor, (f"the folder '{ancestor}' is not writable "
                          f"({exc.strerror or type(exc).__name__})")
    return ancestor, None


def check_export_paths(settings) -> None:
    """Refuse export paths (npz, EXR, lightmaps) that cannot be written: a folder, a path
    under a file, a folder that is not writable. Raises OutputError."""
    from ..errors import OutputError
    paths = [("Export NPZ", npz_path(settings.export_npz) if settings.export_npz else ""),
             ("Export EXR", settings.export_exr),
             ("Export Lightmaps", lightmap_pattern(settings.export_lightmaps).replace(
                 "{object}", "object") if settings.export_lightmaps else "")]
    for label, path in paths:
        if not path:
            continue
        if label != "Export NPZ" and exr_problem():
            raise OutputError(f"{label} path '{path}' cannot be written: {exr_problem()}. "
                              "Nothing was written.")
        problem = ("it is a folder: give a file name" if os.path.isdir(path)
                   else folder_problem(path)[1])
        if problem:
            raise OutputError(f"{label} path '{path}' cannot be written: {problem}. Nothing "
                              "was written.")


def _colour_names(data):
    ca = getattr(data, "color_attributes", None)
    if ca is None or not hasattr(ca, "active_color_name"):
        return None
    return ca.active_color_name or "", ca.default_color_name or ""


def _restore_colour_names(data, names) -> None:
    if names is None:
        return
    ca = data.color_attributes
    active, default = names
    if (ca.active_color_name or "") != active:
        ca.active_color_name = active
    if (ca.default_color_name or "") != default:
        ca.default_color_name = default


def _attribute_copy(attr):
    """(type, domain, values) of an attribute, to put it back."""
    key = _VALUE_KEY.get(attr.data_type)
    if key is None:
        return None
    width = _VALUE_WIDTH[attr.data_type]
    values = np.empty(len(attr.data) * width, dtype=np.float32)
    attr.data.foreach_get(key, values)
    return attr.data_type, attr.domain, values


_VALUE_KEY = {"FLOAT_COLOR": "color", "BYTE_COLOR": "color", "FLOAT_VECTOR": "vector",
              "FLOAT": "value"}
_VALUE_WIDTH = {"FLOAT_COLOR": 4, "BYTE_COLOR": 4, "FLOAT_VECTOR": 3, "FLOAT": 1}


def _tag(data) -> None:
    if is_pointcloud(data):
        data.update_tag()
    else:
        data.update()


class Transaction:
    """All datablock changes and exports of one run, applied together or not at all.

    ``stage_*`` make the new things beside the old ones (temporary files, attributes under
    ``STAGING_ATTRIBUTE``, a new surfel datablock); ``commit`` swaps them in, and ``rollback``
    (called by ``commit`` itself on a failure, or by the caller before ``commit``) removes what
    was made and restores what was replaced. Use as a context manager: leaving the block with
    an exception rolls back."""

    def __init__(self, context) -> None:
        self.context = context
        self.files: list[tuple[str, str]] = []          # (temporary, final)
        self.attributes: list[tuple] = []               # (data, domain, colour names)
        self.surfels = None                             # the new surfel datablock
        self.surfel_object = None
        self.warnings: list[str] = []
        self._undo: list = []                           # callables, newest last
        self._old_data: list = []                       # datablocks to delete on success
        self.committed = False

    # --- staging (nothing the user sees changes) -----------------------------------------

    def stage_file(self, final: str, write) -> None:
        """Write a file with ``write(temporary_path)`` into a temporary file beside ``final``
        (same extension); it is renamed onto ``final`` by ``commit``."""
        import tempfile
        from ..errors import OutputError
        folder = os.path.dirname(os.path.abspath(final))
        root, ext = os.path.splitext(os.path.basename(final))
        try:
            os.makedirs(folder, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{root}.", suffix=".partial" + ext, dir=folder)
            os.close(fd)
        except OSError as exc:
            raise OutputError(f"'{final}' cannot be written: {exc.strerror or exc}. Nothing "
                              "was written.") from None
        self.files.append((tmp, final))
        try:
            write(tmp)
        except OSError as exc:
            raise OutputError(f"Writing '{final}' failed: {exc.strerror or exc}. Nothing was "
                              "written.") from None

    def stage_surfels(self, positions, normals, areas, illumination, albedo, emission) -> None:
        """Build the new surfel datablock (not yet on any object)."""
        radius = np.sqrt(np.asarray(areas, dtype=np.float64) / np.pi)
        self.surfels = _build_pointcloud(self.context, positions, normals, radius, {
            ATTRIBUTE: illumination, "albedo": albedo, "emission": emission})

    def stage_colors(self, data, domain: str, values: np.ndarray) -> None:
        """Write ``values`` (n, 3) as FLOAT_COLOR in ``domain`` under ``STAGING_ATTRIBUTE``;
        the active and render colour attributes are kept."""
        names = _colour_names(data)
        old = data.attributes.get(STAGING_ATTRIBUTE)
        if old is not None:          # left over from an interrupted run of Illumap's own
            data.attributes.remove(old)
        if is_pointcloud(data):
            attr = data.attributes.new(STAGING_ATTRIBUTE, "FLOAT_COLOR", domain)
        else:
            attr = data.color_attributes.new(STAGING_ATTRIBUTE, "FLOAT_COLOR", domain)
        self.attributes.append((data, domain, names))
        _restore_colour_names(data, names)
        attr.data.foreach_set("color", _rgba(np.asarray(values, dtype=np.float64)))

    # --- the swap --------------------------------------------------------------------------

    def commit(self):
        """Swap everything staged in; returns the surfel object (or None). On any failure the
        file is put back as it was and the error raised."""
        try:
            for data, domain, names in self.attributes:
                self._swap_attribute(data, names)
            if self.surfels is not None:
                self._swap_surfels()
            # Files last: each rename is atomic, and a datablock swap can still be undone.
            while self.files:
                tmp, final = self.files[0]
                try:
                    os.replace(tmp, final)
                except OSError as exc:
                    from ..errors import OutputError
                    raise OutputError(f"'{final}' could not be put in place: "
                                      f"{exc.strerror or exc}. The file's data was left as "
                                      "it was.") from None
                self.files.pop(0)
        except BaseException:
            self.rollback()
            raise
        for old in self._old_data:
            if old is not None and old.users == 0:
                _remove_data(old)
        self._old_data.clear()
        if self.surfel_object is not None:
            self.surfel_object.data.name = SURFEL_OBJECT
        self.committed = True
        self._undo.clear()
        return self.surfel_object

    def _swap_attribute(self, data, names) -> None:
        old = data.attributes.get(ATTRIBUTE)
        saved = _attribute_copy(old) if old is not None else None
        if old is not None:
            data.attributes.remove(old)

        def undo(data=data, saved=saved, names=names):
            new = data.attributes.get(ATTRIBUTE)
            if new is not None:
                data.attributes.remove(new)
            if saved is not None:
                kind, domain, values = saved
                coll = data.attributes if is_pointcloud(data) or kind not in (
                    "FLOAT_COLOR", "BYTE_COLOR") else data.color_attributes
                back = coll.new(ATTRIBUTE, kind, domain)
                back.data.foreach_set(_VALUE_KEY[kind], values)
            _restore_colour_names(data, names)
        self._undo.append(undo)
        data.attributes[STAGING_ATTRIBUTE].name = ATTRIBUTE
        _restore_colour_names(data, names)
        _tag(data)

    def _swap_surfels(self) -> None:
        data = bpy_data()
        scene = self.context.scene
        cloud = self.surfels
        obj, warning = surfel_target(data)
        kind = "POINTCLOUD" if is_pointcloud(cloud) else "MESH"
        if obj is not None and obj.type != kind:
            # Illumap's own object of another type: replaced by a new one (its name kept).
            name = obj.name
            self._old_data.append(obj.data)
            unlinked = [c for c in obj.users_collection]
            data.objects.remove(obj)
            obj = data.objects.new(name, cloud)
            for coll in unlinked:
                coll.objects.link(obj)
            self._undo.append(lambda: None)   # the stale object is not restored
        if obj is None:
            obj = data.objects.new(SURFEL_OBJECT, cloud)
            scene.collection.objects.link(obj)
            self._undo.append(lambda o=obj: data.objects.remove(o))
        else:
            old = obj.data
            matrix = obj.matrix_world.copy()
            if old is not None and old != cloud:
                for mat in old.materials:
                    cloud.materials.append(mat)
                obj.data = cloud
                self._old_data.append(old)

                def undo(o=obj, old=old, matrix=matrix):
                    o.data = old
                    o.matrix_world = matrix
                self._undo.append(undo)
            obj.matrix_world.identity()
        obj[MARKER] = True
        if obj.name not in scene.objects:
            scene.collection.objects.link(obj)
        self.surfel_object = obj
        if warning:
            self.warnings.append(
                f"An object named '{SURFEL_OBJECT}' that Illumap did not make is in the file: "
                f"it was left as it is, and the surfels were written to '{obj.name}'")

    def rollback(self) -> None:
        """Undo the swap so far (newest first), then remove everything staged."""
        for undo in reversed(self._undo):
            try:
                undo()
            except Exception:   # noqa: BLE001 - put back as much as can be
                pass
        self._undo.clear()
        for data, _, names in self.attributes:
            try:
                attr = data.attributes.get(STAGING_ATTRIBUTE)
                if attr is not None:
                    data.attributes.remove(attr)
                _restore_colour_names(data, names)
            except Exception:   # noqa: BLE001
                pass
        self.attributes.clear()
        if self.surfels is not None:
            try:
                if self.surfels.users == 0:
                    _remove_data(self.surfels)
            except Exception:   # noqa: BLE001
                pass
        self.surfels = None
        self.surfel_object = None
        for tmp, _ in self.files:
            try:
                os.remove(tmp)
            except OSError:
                pass
        self.files.clear()
        self._old_data.clear()

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb) -> None:
        if kind is not None and not self.committed:
            self.rollback()


def write_surfels(context, positions: np.ndarray, normals: np.ndarray, areas: np.ndarray,
                  illumination: np.ndarray, albedo: np.ndarray, emission: np.ndarray,
                  warnings: list | None = None):
    """Create or replace the ``Illumap Surfels`` object (one transaction); returns it.

    Positions in m (world space; the object keeps an identity transform), areas in m²,
    colours as linear RGB radiance / reflectance.
    """
    with Transaction(context) as tx:
        tx.stage_surfels(positions, normals, areas, illumination, albedo, emission)
        obj = tx.commit()
    if warnings is not None:
        warnings.extend(tx.warnings)
    return obj


def _remove_data(datablock) -> None:
    for coll in (bpy_data().meshes, bpy_data().pointclouds):
        if datablock.name in coll and coll[datablock.name] == datablock:
            coll.remove(datablock)
            return


def write_mesh_values(obj, receivers, corner_values: np.ndarray, domain: str = "CORNER") -> None:
    """Write radiance evaluated at ``obj``'s own corners (``sampling.Receivers``; (L, 3)) as
    the FLOAT_COLOR attribute ``illumination`` in ``domain`` ('CORNER', or 'POINT': the mean
    of each vertex's corners). One transaction of its own; ``pipeline.write`` stages it with
    the rest instead (``stage_mesh_values``)."""
    import bpy
    with Transaction(bpy.context) as tx:
        stage_mesh_values(tx, obj, receivers, corner_values, domain)
        tx.commit()


def mesh_values(receivers, corner_values: np.ndarray, domain: str) -> np.ndarray:
    """The values to write for ``domain`` from the values at the corners."""
    values = np.asarray(corner_values, dtype=np.float64)
    return receivers.per_vertex(values) if domain == "POINT" else values


def stage_mesh_values(tx: Transaction, obj, receivers, corner_values, domain="CORNER") -> None:
    """Stage ``write_mesh_values`` in ``tx``."""
    tx.stage_colors(obj.data, domain, mesh_values(receivers, corner_values, domain))


def write_point_values(obj, values: np.ndarray) -> None:
    """Write radiance per point (n, 3) of a point-cloud object, or of a mesh that has vertices
    only, as its FLOAT_COLOR point attribute ``illumination`` (one transaction)."""
    import bpy
    with Transaction(bpy.context) as tx:
        tx.stage_colors(obj.data, "POINT", np.asarray(values, dtype=np.float64))
        tx.commit()


def point_count(obj) -> int:
    """Points of a point-cloud object, or vertices of a mesh."""
    data = obj.data
    return len(data.points) if is_pointcloud(data) else len(data.vertices)
