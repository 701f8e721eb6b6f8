"""Surfels from mesh objects: area-weighted, stratified sampling of evaluated meshes.

This module reads Blender data (evaluated meshes, instances) with ``foreach_get``; the sampling
itself is ``illumap.sampling`` (numpy only, shared with the benchmarks).

Units: positions in metres (world space), areas in m², density in surfels per m².

Sampling is done per object in two stages, so that no surfel clumps:

1. *Allocation.* The triangles are laid end to end along their cumulative area and ``n`` sample
   positions are placed systematically on that line (one random offset, then equal steps of
   ``A/n``). A triangle receives ``floor`` or ``ceil`` of its expected count, never a cluster.
2. *Placement.* Inside a triangle the k-th of its ``m`` samples is the k-th point of the R2
   (Kronecker) low-discrepancy sequence with a random per-triangle shift, mapped onto
   the triangle by Heitz's area-preserving, low-distortion square-to-triangle map.

Each surfel stands for the same share ``A/n`` of its object's surface, so the areas sum to the
mesh area exactly (up to rounding) whatever the triangle sizes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from illumap import sampling as core_sampling
from illumap.identities import canonical_triangles, corner_ids
from illumap import surfels as core_surfels
# The corners are the core's receivers (``illumap.Receivers``), a hair inside their faces.
from illumap.stages.scene import RECEIVER_INSET, Receivers  # noqa: F401

from ..errors import IllumapError
from ..kinds import MESH_TYPES


@dataclass
class TriangleMesh:
    """One evaluated mesh object as world-space triangles (numpy only, no bpy references)."""

    name: str
    corners: np.ndarray            # (T, 3, 3) triangle vertex positions, m
    area: np.ndarray               # (T,) triangle areas, m²
    normal: np.ndarray             # (T, 3) geometric unit normals
    corner_normals: np.ndarray     # (T, 3, 3) split (shading) normals, unit, world space
    material_index: np.ndarray     # (T,) int64 slot index
    uv: dict[str, np.ndarray] = field(default_factory=dict)       # name → (T, 3, 2)
    colors: dict[str, np.ndarray] = field(default_factory=dict)   # name → (T, 3, 4), linear
    active_uv: str | None = None
    #: The default (render) colour attribute: what an empty-name Color Attribute node reads in
    #: a render. Not the active one, which only Solid shading shows (Solid Preview makes
    #: ``illumination`` active; reading it would feed the light back in as albedo).
    render_color: str | None = None
    materials: list = field(default_factory=list)  # bpy.types.Material | None per slot
    skipped_triangles: int = 0
    instancer: str = ""            # name of the instancing object, for instances
    loops: np.ndarray | None = None     # (T, 3) int64 corner (loop) index of each triangle corner
    vertices: np.ndarray | None = None  # (T, 3) int64 vertex index of each triangle corner
    two_sided: bool = False        # an open surface (boundary edges): both faces reflect

    @property
    def total_area(self) -> float:
        """Sum of the triangle areas in m²."""
        return float(self.area.sum())


@dataclass
class MeshSamples:
    """Surfels sampled from one mesh, with what is needed to look up its material."""

    mesh: TriangleMesh
    positions: np.ndarray      # (N, 3) m
    normals: np.ndarray        # (N, 3) unit
    areas: np.ndarray          # (N,) m², sums to mesh.total_area
    triangle: np.ndarray       # (N,) int64 index into mesh triangles
    bary: np.ndarray           # (N, 3) barycentric coordinates
    material_index: np.ndarray  # (N,) int64

    def uv(self, name: str | None = None) -> np.ndarray | None:
        """UV coordinates (N, 2) of the named (or active) UV map, None if the mesh has none."""
        key = name or self.mesh.active_uv
        if key not in self.mesh.uv:
            return None
        return np.einsum("nk,nkc->nc", self.bary, self.mesh.uv[key][self.triangle])

    def color(self, name: str | None = None) -> np.ndarray | None:
        """Colour attribute (N, 4), linear, interpolated at the surfels; None if absent. No
        name: the default (render) colour attribute, as Cycles reads it."""
        key = name or self.mesh.render_color
        if key not in self.mesh.colors:
            return None
        return np.einsum("nk,nkc->nc", self.bary, self.mesh.colors[key][self.triangle])


#: Farther than this from the origin (m, world space), a coordinate is taken for an infinite or
#: absurd value (Blender stores an infinite coordinate as ±3.4e38): the core's own limit
#: (``illumap.surfels.MAX_COORDINATE``, 1e12 m; georeferenced scans sit within 1e7 m).
MAX_COORDINATE = core_surfels.MAX_COORDINATE


def check_transform(name: str, matrix, kind: str = "Object") -> np.ndarray:
    """``matrix`` (4×4 world matrix) as float64, or an IllumapError naming ``name`` when it
    holds NaN or infinite values (a NaN location, rotation or scale, here or on a parent or
    through a constraint or driver)."""
    m = np.array(matrix, dtype=np.float64)
    if not np.all(np.isfinite(m)):
        raise IllumapError(f"{kind} '{name}' has a non-finite transform (NaN or infinite "
                           "location, rotation or scale, on it or on a parent, constraint or "
                           "driver)")
    return m


def check_coordinates(name: str, world: np.ndarray, what: str = "vertex") -> None:
    """Raise an IllumapError naming ``name`` and the first ``what`` (vertex, point) whose world
    coordinates (N, 3) are not finite or lie beyond ``MAX_COORDINATE``."""
    bad = ~np.isfinite(world).all(axis=1)
    with np.errstate(invalid="ignore", over="ignore"):
        bad |= (np.abs(world) > MAX_COORDINATE).any(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        where = ", ".join(f"{c:.3g}" for c in world[i])
        more = f" (and {int(bad.sum()) - 1} more)" if bad.sum() > 1 else ""
        raise IllumapError(f"Object '{name}': {what} {i} lies at ({where}) m in world space"
                           f"{more}, beyond ±{MAX_COORDINATE:.0e} m: an infinite or absurd "
                           "coordinate or scale; fix the geometry or the object's transform")


def _get(collection, attr: str, count: int, width: int, dtype) -> np.ndarray:
    """foreach_get into a fresh numpy array of shape (count, width)."""
    out = np.empty(count * width, dtype=dtype)
    collection.foreach_get(attr, out)
    return out.reshape(count, width) if width > 1 else out


def read_mesh(obj, depsgraph, allow_empty: bool = False) -> TriangleMesh | None:
    """Read ``obj``'s evaluated mesh (modifiers applied) as world-space triangles.

    With ``allow_empty`` (an object that instances other geometry, e.g. Geometry Nodes that
    output only instances) an empty mesh gives None instead of an error. Raises IllumapError
    for non-finite vertices or when every face has zero area. Zero-area triangles are dropped
    and counted in ``skipped_triangles`` (the caller warns).
    """
    obj_eval = obj.evaluated_get(depsgraph)
    mesh = obj_eval.to_mesh()
    try:
        if allow_empty and (mesh is None or len(mesh.polygons) == 0):
            return None
        return _read_mesh_data(obj.name, obj_eval, mesh, obj_eval.matrix_world, obj.material_slots)
    finally:
        obj_eval.to_mesh_clear()


def read_instances(depsgraph, instancer_names: set[str]) -> list[TriangleMesh]:
    """World-space triangles of every instance (collection instances, Geometry Nodes
    instances, particle/vertex/face instancing) whose instancer is one of ``instancer_names``.

    One loop over the depsgraph's instances (not over vertices): each instance's geometry is
    read while the iterator holds it. Names are ``instancer/object#k``.
    """
    out: list[TriangleMesh] = []
    counter = 0
    for inst in depsgraph.object_instances:
        if not inst.is_instance or inst.parent is None:
            continue
        if inst.parent.original.name not in instancer_names:
            continue
        ob = inst.object
        if ob.type not in MESH_TYPES:
            continue
        mesh = ob.to_mesh()
        try:
            if mesh is None or len(mesh.polygons) == 0:
                continue
            counter += 1
            name = f"{inst.parent.original.name}/{ob.original.name}#{counter}"
            tm = _read_mesh_data(name, ob, mesh, inst.matrix_world.copy(), ob.material_slots)
            tm.instancer = inst.parent.original.name
            out.append(tm)
        finally:
            ob.to_mesh_clear()
    return out


def _polygon_keys(mesh) -> np.ndarray:
    """Each polygon's vertices sorted (F, K), padded with -1 to the largest polygon's size:
    the same rows whatever order the polygons and their loops are kept in."""
    nf, nl = len(mesh.polygons), len(mesh.loops)
    start = _get(mesh.polygons, "loop_start", nf, 1, np.int32).astype(np.int64)
    total = _get(mesh.polygons, "loop_total", nf, 1, np.int32).astype(np.int64)
    vertex = _get(mesh.loops, "vertex_index", nl, 1, np.int32).astype(np.int64)
    width = int(total.max(initial=1))
    k = np.arange(width)
    big = np.iinfo(np.int64).max
    keys = np.where(k[None, :] < total[:, None],
                    vertex[np.minimum(start[:, None] + k[None, :], max(nl - 1, 0))], big)
    keys = np.sort(keys, axis=1)
    return np.where(keys == big, -1, keys)


#: A polygon of four or more corners is cut into a fan from its lowest vertex where every fan
#: triangle faces the polygon's way within this cosine (it is flat and the fan stays inside it).
FAN_FLAT_COS = 1.0 - 1e-9


def _fanned(mesh, world: np.ndarray, mirrored: bool = False) -> tuple[np.ndarray, ...]:
    """The mesh's triangles: vertices (T, 3), loops (T, 3), material index (T,), polygon (T,).

    Blender cuts a polygon starting from its first loop, which a mirror applied (it reverses
    the loops) or an edit moves: a flat, convex polygon is the same surface whichever way it
    is cut, so it is cut here into a fan from its lowest vertex, and its samples do not depend
    on where its loops start. Its triangles follow its winding, as Blender's do (the same way
    round on every polygon, which the stratified layout keeps even); ``mirrored`` (a transform
    that mirrors) takes them the other way round, as the mirror applied would. Other polygons
    keep Blender's triangles (a bent quad's diagonal is the surface Blender renders)."""
    nt, nl, nf = len(mesh.loop_triangles), len(mesh.loops), len(mesh.polygons)
    tri_v = _get(mesh.loop_triangles, "vertices", nt, 3, np.int32).astype(np.int64)
    tri_l = _get(mesh.loop_triangles, "loops", nt, 3, np.int32).astype(np.int64)
    mat_idx = _get(mesh.loop_triangles, "material_index", nt, 1, np.int32).astype(np.int64)
    total = _get(mesh.polygons, "loop_total", nf, 1, np.int32).astype(np.int64)
    tri_face = _get(mesh.loop_triangles, "polygon_index", nt, 1, np.int32).astype(np.int64)
    if not (total > 3).any():
        return tri_v, tri_l, mat_idx, tri_face
    start = _get(mesh.polygons, "loop_start", nf, 1, np.int32).astype(np.int64)
    face_material = _get(mesh.polygons, "material_index", nf, 1, np.int32).astype(np.int64)
    loop_vertex = _get(mesh.loops, "vertex_index", nl, 1, np.int32).astype(np.int64)
    fanned = np.zeros(nf, dtype=bool)
    fans_v, fans_l, fans_m, fans_f = [], [], [], []
    for n in np.unique(total[total > 3]):
        faces = np.flatnonzero(total == n)
        loops = start[faces][:, None] + np.arange(n)
        apex = loop_vertex[loops].argmin(axis=1)
        loops = np.take_along_axis(loops, (apex[:, None] + np.arange(n)) % n, axis=1)
        k = np.arange(1, n - 1)
        fan = np.stack([np.repeat(loops[:, :1], n - 2, axis=1), loops[:, k], loops[:, k + 1]],
                       axis=2)                                            # (F, n-2, 3) loops
        if mirrored:   # the fan the same polygon with its loops reversed gives, in order
            fan = fan[:, ::-1]
        p = world[loop_vertex[fan]]
        cross = np.cross(p[..., 1, :] - p[..., 0, :], p[..., 2, :] - p[..., 0, :])
        whole = cross.sum(axis=1)
        size = np.linalg.norm(cross, axis=2)
        facing = np.einsum("fkc,fc->fk", cross, whole)
        flat = (facing >= FAN_FLAT_COS * size * np.linalg.norm(whole, axis=1)[:, None]) \
            & (size > 0)
        good = flat.all(axis=1)
        fanned[faces[good]] = True
        fans_l.append(fan[good].reshape(-1, 3))
        fans_v.append(loop_vertex[fans_l[-1]])
        fans_m.append(np.repeat(face_material[faces[good]], n - 2))
        fans_f.append(np.repeat(faces[good], n - 2))
    keep = ~fanned[tri_face]
    return (np.concatenate([tri_v[keep]] + fans_v), np.concatenate([tri_l[keep]] + fans_l),
            np.concatenate([mat_idx[keep]] + fans_m), np.concatenate([tri_face[keep]] + fans_f))


def _read_mesh_data(name: str, obj_eval, mesh, matrix_world, material_slots) -> TriangleMesh:
    mesh.calc_loop_triangles()
    nv, nt, nl = len(mesh.vertices), len(mesh.loop_triangles), len(mesh.loops)
    if nt == 0:
        raise IllumapError(f"Object '{name}' has no faces to sample")
    co = _get(mesh.vertices, "co", nv, 3, np.float64)
    if not np.all(np.isfinite(co)):
        bad = int((~np.isfinite(co)).any(axis=1).sum())
        raise IllumapError(f"Object '{name}' has {bad} vertices with NaN or infinite coordinates")
    m = check_transform(name, matrix_world)
    lin, trans = m[:3, :3], m[:3, 3]
    with np.errstate(over="ignore", invalid="ignore"):
        world = co @ lin.T + trans
    check_coordinates(name, world)
    mirrored = bool(np.linalg.det(m[:3, :3]) < 0)
    tri_v, tri_l, mat_idx, tri_face = _fanned(mesh, world, mirrored)
    order, turn = canonical_triangles(tri_v, _polygon_keys(mesh)[tri_face])
    if mirrored:
        # A mirroring transform turns the winding inside out: Blender flips it back, so that
        # the front faces stay the ones the normals point out of.
        turn = turn[:, [0, 2, 1]]
    tri_v = np.take_along_axis(tri_v, turn, axis=1)[order]
    tri_l = np.take_along_axis(tri_l, turn, axis=1)[order]
    mat_idx = mat_idx[order]
    corners = world[tri_v]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    area = 0.5 * double_area
    # Normals transform with the inverse transpose; row vectors: n @ inv(M).
    try:
        inv = np.linalg.inv(lin)
    except np.linalg.LinAlgError:
        raise IllumapError(f"Object '{name}' has a degenerate (zero-scale) transform") from None
    cn = _get(mesh.corner_normals, "vector", nl, 3, np.float64) @ inv
    cn /= np.maximum(np.linalg.norm(cn, axis=1, keepdims=True), 1e-300)
    # Zero area relative to each triangle's own size (not the object's: one far vertex would
    # make every ordinary face look degenerate).
    edges = corners - np.roll(corners, 1, axis=1)
    longest = np.sqrt(np.einsum("tkc,tkc->tk", edges, edges).max(axis=1))
    keep = np.isfinite(area) & (area > 1e-12 * np.maximum(longest, 1e-30) ** 2)
    skipped = int(nt - keep.sum())
    if not keep.any():
        raise IllumapError(f"Object '{name}': all {nt} faces have zero area; nothing to sample")
    normal = cross[keep] / double_area[keep, None]
    uv = {}
    for layer in mesh.uv_layers:
        vec = _get(layer.uv, "vector", nl, 2, np.float64)
        uv[layer.name] = vec[tri_l[keep]]
    colors = {}
    for attr in mesh.color_attributes:
        if attr.domain == "POINT":
            count, index = nv, tri_v[keep]
        elif attr.domain == "CORNER":
            count, index = nl, tri_l[keep]
        else:
            continue
        # 'color' is scene-linear for both FLOAT_COLOR and BYTE_COLOR ('color_srgb' is not).
        col = _get(attr.data, "color", count, 4, np.float64)
        colors[attr.name] = col[index]
    render_color = mesh.color_attributes.default_color_name or None
    active_uv = mesh.uv_layers.active.name if mesh.uv_layers.active else None
    materials = [slot.material for slot in material_slots]
    # Open surfaces (an edge with one face) reflect on both faces, as in Cycles; the back of a
    # closed surface is inside it and never lit.
    edge_faces = np.bincount(_get(mesh.loops, "edge_index", nl, 1, np.int32),
                             minlength=len(mesh.edges))
    return TriangleMesh(two_sided=bool((edge_faces == 1).any()),
        name=name, corners=corners[keep], area=area[keep], normal=normal,
        corner_normals=cn[tri_l[keep]], material_index=mat_idx[keep], uv=uv, colors=colors,
        active_uv=active_uv, render_color=render_color, materials=materials,
        skipped_triangles=skipped, loops=tri_l[keep].astype(np.int64),
        vertices=tri_v[keep].astype(np.int64),
    )


#: Modifiers that move, smooth or subdivide a mesh but keep its vertices as the first of the
#: result's, in their order (Subdivision Surface and Multires put the limit points of the
#: original vertices first): the light at each of the mesh's corners is then evaluated where
#: its vertex ends up, inside the part of its face that touches that vertex.
VERTEX_KEEPING_MODIFIERS = frozenset({
    "SUBSURF", "MULTIRES", "ARMATURE", "CAST", "CURVE", "DISPLACE", "HOOK", "LAPLACIANDEFORM",
    "LATTICE", "MESH_DEFORM", "SHRINKWRAP", "SIMPLE_DEFORM", "SMOOTH", "CORRECTIVE_SMOOTH",
    "LAPLACIANSMOOTH", "SURFACE_DEFORM", "WARP", "WAVE", "WEIGHTED_NORMAL", "NORMAL_EDIT",
    "MESH_CACHE", "MESH_SEQUENCE_CACHE", "UV_PROJECT", "UV_WARP", "VERTEX_WEIGHT_EDIT",
    "VERTEX_WEIGHT_MIX", "VERTEX_WEIGHT_PROXIMITY", "DATA_TRANSFER"})


def _polygon_loops(mesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each loop's face (L,), and the next and the previous loop around that face (L,)."""
    nl, nf = len(mesh.loops), len(mesh.polygons)
    start = _get(mesh.polygons, "loop_start", nf, 1, np.int32).astype(np.int64)
    total = _get(mesh.polygons, "loop_total", nf, 1, np.int32).astype(np.int64)
    face = np.zeros(nl, dtype=np.int64)
    face[start] = 1
    face = np.cumsum(face) - 1
    following = np.arange(1, nl + 1, dtype=np.int64)
    following[start + total - 1] = start
    preceding = np.arange(-1, nl - 1, dtype=np.int64)
    preceding[start] = start + total - 1
    return np.argsort(start, kind="stable")[face], following, preceding


def _face_centroids(mesh, positions: np.ndarray, vertex: np.ndarray, face: np.ndarray) -> np.ndarray:
    """Each face's centroid (F, 3) of ``positions`` at its loops' ``vertex``."""
    count = np.bincount(face, minlength=len(mesh.polygons)).astype(np.float64)
    out = np.zeros((len(mesh.polygons), 3))
    np.add.at(out, face, positions[vertex])
    return out / np.maximum(count, 1.0)[:, None]


def _evaluated_corners(obj, mesh, evaluated) -> np.ndarray | str:
    """For each corner of ``obj``'s own ``mesh``, the loop of its ``evaluated`` mesh where its
    light is to be evaluated (L,); or why there is none (a message). The same topology maps
    corner to corner (shape keys, deforming modifiers, mirroring by scale); subdivision maps
    each corner to the evaluated corner at its vertex that lies toward its own face."""
    nl = len(mesh.loops)
    vertex = _get(mesh.loops, "vertex_index", nl, 1, np.int32).astype(np.int64)
    ne = len(evaluated.loops)
    ev_vertex = _get(evaluated.loops, "vertex_index", ne, 1, np.int32).astype(np.int64)
    if ne == nl and len(evaluated.polygons) == len(mesh.polygons) and np.array_equal(vertex, ev_vertex):
        return np.arange(nl, dtype=np.int64)
    from ..write.output import OWN_MODIFIERS, repeat_problem
    repeated = repeat_problem(obj)
    if repeated is not None:
        return repeated
    changing = [mod for mod in obj.modifiers if (mod.show_viewport or mod.show_render)
                and mod.name not in OWN_MODIFIERS and mod.type not in VERTEX_KEEPING_MODIFIERS]
    if changing or len(evaluated.vertices) < len(mesh.vertices):
        culprit = (f"its {changing[0].type.replace('_', ' ').title()} modifier "
                   f"'{changing[0].name}'" if changing else "its modifiers")
        return (f"Object '{obj.name}': {culprit} changes the mesh's faces, so its corners have no "
                "place on the surface Blender shows: no illumination written to it. The surfel "
                "object holds its light; apply the modifier to transfer onto the mesh")
    nv = len(evaluated.vertices)
    co = _get(evaluated.vertices, "co", nv, 3, np.float64)
    face, _, _ = _polygon_loops(mesh)
    ev_face, _, _ = _polygon_loops(evaluated)
    toward = _face_centroids(mesh, co, vertex, face)[face] - co[vertex]
    ev_toward = _face_centroids(evaluated, co, ev_vertex, ev_face)[ev_face] - co[ev_vertex]
    toward /= np.maximum(np.linalg.norm(toward, axis=1, keepdims=True), 1e-300)
    ev_toward /= np.maximum(np.linalg.norm(ev_toward, axis=1, keepdims=True), 1e-300)
    # The evaluated corners at each original vertex, as a padded table (vertices × valence).
    at = np.flatnonzero(ev_vertex < len(mesh.vertices))
    at = at[np.argsort(ev_vertex[at], kind="stable")]
    count = np.bincount(ev_vertex[at], minlength=len(mesh.vertices))
    begin = np.concatenate([[0], np.cumsum(count)[:-1]])
    width = max(int(count.max(initial=0)), 1)
    k = np.arange(width)
    valid = k[None, :] < count[vertex][:, None]
    candidate = np.where(valid, at[np.minimum(begin[vertex][:, None] + k[None, :], len(at) - 1)], 0)
    score = np.where(valid, np.einsum("lc,lkc->lk", toward, ev_toward[candidate]), -np.inf)
    best = candidate[np.arange(nl), score.argmax(axis=1)]
    if not valid.any(axis=1).all():
        return (f"Object '{obj.name}': its modifiers drop some of its vertices, so their corners "
                "have no place on the surface Blender shows: no illumination written to it")
    return best


#: A triangle whose corner normals differ by less than this (per component) is flat-shaded.
FLAT_CORNERS = 1e-6


def read_receivers(obj, warnings: list[str], depsgraph=None,
                   material_warnings: list[str] | None = None) -> Receivers | None:
    """The receivers of ``obj``'s mesh corners in world space, on the surface Blender shows
    (its evaluated mesh with ``depsgraph``: shape keys, modifiers, a mirroring scale), with
    materials evaluated at every corner (``materials.surfel_materials``); None without faces,
    or (with a warning) where a modifier changes the faces so that the corners have no place
    on the evaluated surface (``_evaluated_corners``). Material warnings go to
    ``material_warnings`` when given (the surfels' reading gave them already)."""
    from .materials import surfel_materials
    mesh = obj.data
    if mesh is None or len(mesh.polygons) == 0:
        return None
    obj_eval = obj.evaluated_get(depsgraph) if depsgraph is not None else obj
    evaluated = obj_eval.to_mesh() if depsgraph is not None else mesh
    try:
        if evaluated is None or len(evaluated.polygons) == 0:
            return None
        at = _evaluated_corners(obj, mesh, evaluated)
        if isinstance(at, str):
            warnings.append(at)
            return None
        tm = _read_mesh_data(obj.name, obj_eval, evaluated, obj_eval.matrix_world,
                             obj.material_slots)
        ne, nve = len(evaluated.loops), len(evaluated.vertices)
        ev_vertex = _get(evaluated.loops, "vertex_index", ne, 1, np.int32).astype(np.int64)
    finally:
        if depsgraph is not None:
            obj_eval.to_mesh_clear()
    nl, nv = len(mesh.loops), len(mesh.vertices)
    corner_vertex = _get(mesh.loops, "vertex_index", nl, 1, np.int32).astype(np.int64)
    _, following, preceding = _polygon_loops(mesh)
    flat = tm.loops.ravel()
    loops, first = np.unique(flat, return_index=True)
    # Corners of zero-area faces only: evaluated at a neighbouring triangle corner of the
    # same vertex where there is one (the light at a point does not depend on the face).
    owner = np.full(ne, -1, dtype=np.int64)
    owner[loops] = first
    orphan = np.flatnonzero(owner < 0)
    if orphan.size:
        by_vertex = np.full(nve, -1, dtype=np.int64)
        by_vertex[tm.vertices.ravel()[::-1]] = np.arange(flat.size)[::-1]
        owner[orphan] = by_vertex[ev_vertex[orphan]]
    owner = owner[at]
    missing = owner < 0
    if missing.any():
        warnings.append(f"Object '{obj.name}': {int(missing.sum())} corner(s) of degenerate "
                        "faces get no illumination")
        owner[missing] = 0
    tri, slot = owner // 3, owner % 3
    bary = np.zeros((nl, 3))
    bary[np.arange(nl), slot] = 1.0
    # Each corner is evaluated a hair inside its triangle (RECEIVER_INSET of the way to the
    # centroid), as a bake does: at a box's edge the point then lies on the inner side of the
    # adjacent wall, whose light its rays must meet rather than pass behind.
    corner = tm.corners[tri, slot]
    inward = tm.corners[tri].mean(axis=1) - corner
    positions = corner + RECEIVER_INSET * inward
    normals = tm.corner_normals[tri, slot]
    # The face below which a corner's gather drops its rays (a renderer drops the directions
    # of a smooth normal's hemisphere below the triangle). A flat face (its three corners of
    # one normal) drops none: a renderer shades it with the triangle's own normal.
    flat = np.ptp(tm.corner_normals[tri], axis=1).max(axis=1) < FLAT_CORNERS
    faces = np.where(flat[:, None], normals, tm.normal[tri])
    samples = MeshSamples(mesh=tm, positions=positions, normals=normals, areas=np.ones(nl),
                          triangle=tri, bary=bary, material_index=tm.material_index[tri])
    albedo, emission = surfel_materials(samples, warnings if material_warnings is None
                                        else material_warnings)
    # Every corner is its own receiver: the corners of one vertex lie inside different faces,
    # which a wall standing on that vertex separates (a floor vertex under a box's side is
    # half in its shadow, as a bake finds averaging the corners).
    return Receivers(name=obj.name, corner_vertex=corner_vertex,
                     points=np.ascontiguousarray(positions),
                     normals=np.ascontiguousarray(normals), albedo=albedo,
                     emission=emission, vertex_count=nv, inward=np.ascontiguousarray(inward),
                     faces=np.ascontiguousarray(faces),
                     corner_id=corner_ids(corner_vertex, corner_vertex[following],
                                          corner_vertex[preceding]))


def allocate(areas: np.ndarray, *, density: float | None = None,
             budget: int | None = None) -> np.ndarray:
    """Surfel counts per object from a density (surfels/m²) or a total budget.

    Every object gets at least one surfel (so small emitters are never lost); a budget is
    shared in proportion to area by largest remainder (``illumap.sampling.allocate``).
    """
    try:
        return core_sampling.allocate(areas, density=density, budget=budget)
    except core_sampling.InputError as exc:
        raise IllumapError(str(exc)) from None


def sample_mesh(mesh: TriangleMesh, count: int, rng: np.random.Generator,
                regions: "core_sampling.Regions | None" = None,
                weights: np.ndarray | None = None) -> MeshSamples:
    """Place ``count`` stratified surfels on ``mesh`` (see the module docstring).

    With ``regions`` (the mesh's triangles split by ``illumap.sampling.Regions.build``) and
    ``weights`` (a density multiplier per region), the surfels follow the weights; triangle
    and barycentric coordinates still refer to the mesh's own triangles.
    """
    if regions is None:
        s = core_sampling.sample_triangles(mesh.corners, int(count), rng,
                                           corner_normals=mesh.corner_normals, areas=mesh.area)
        tri, bary = s.triangle, s.bary
    else:
        s = core_sampling.sample_triangles(regions.corners, int(count), rng,
                                           corner_normals=regions.interpolate(mesh.corner_normals),
                                           weights=weights, areas=regions.area)
        tri, bary = regions.to_parent(s.triangle, s.bary)
    return MeshSamples(mesh=mesh, positions=s.positions, normals=s.normals, areas=s.areas,
                       triangle=tri, bary=bary, material_index=mesh.material_index[tri])
