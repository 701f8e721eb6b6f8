"""Surfels from point-cloud objects and from meshes that have vertices only.

* Positions: the points (world space, m).
* Area: π r² from a ``radius`` attribute (scaled by the object's transform). Without one, the
  spacing is estimated from the k = 8 nearest neighbours: for points spread with density ρ over
  a surface, E[d_j²] = j/(πρ), so 1/ρ ≈ 2π·mean_j(d_j²)/(k+1). A warning says so. A stray
  point far from the rest would get a disc as wide as that distance: it gets the typical
  point's area instead (``bound_stray_areas``), and a warning gives the count.
* Normals: a ``normal`` or ``N`` FLOAT_VECTOR attribute. Without one, PCA over the k nearest
  neighbours (smallest eigenvector of the local covariance), oriented consistently along a
  minimum spanning tree of the neighbour graph (``illumap.pointcloud``). No rule can tell the
  inside of a scanned room from the outside of a scanned statue, so such points are two-sided
  (``two_sided``): the pipeline adds a surfel facing the other way at every point, and each
  point shows its brighter side. A warning says so.
* Albedo: the colour attribute renders use (a mesh's default colour attribute; a point
  cloud's active one where Blender has one), or one named ``Col``/``Cd``/``color``, else the
  first material as for meshes (without UVs). Emission: from that material.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from illumap.neighbours import knn

from . import materials
from ..errors import IllumapError

K_NEIGHBOURS = 8
#: Columns of the one search of a scan's own points (the point and its nearest): the splats'
#: outlines read the most (``illumap.splats.DEFAULT_NEIGHBOURS``); the spacing, the normals
#: and the splats' planes read its first K_NEIGHBOURS + 1 (knn keeps ties to the lower index,
#: so those are what a search of K_NEIGHBOURS would find).
SHARED_NEIGHBOURS = 20
#: A point whose estimated spacing exceeds the cloud's median by this factor is stray
#: (``bound_stray_areas``): 10 lets a scan's density vary a hundredfold in area...
STRAY_SPACING = 10.0
#: ... and, in a cloud whose density varies more, by this many robust deviations of the log
#: spacing as well (a normal distribution leaves 1 in 30,000 beyond 4; a scan's range from
#: 0.2 to 6 m, spacing 1 to 40 cm, sets the bound at 180 times the median).
STRAY_MADS = 4.0
_COLOR_NAMES = ("Col", "Cd", "color", "Color")


@dataclass
class PointSamples:
    """Surfels read from one point object (numpy only)."""

    name: str
    positions: np.ndarray
    normals: np.ndarray | None    # None until ``with_normals`` estimates them
    areas: np.ndarray
    albedo: np.ndarray
    emission: np.ndarray
    colors: dict[str, np.ndarray] = field(default_factory=dict)
    two_sided: bool = False   # normals estimated: their orientation is unknown, both sides lit
    # Estimated normals: the directions each point is lit from as a receiver
    # (``illumap.pointcloud.receiver_normals``); None: ``normals``.
    receiver_normals: np.ndarray | None = None
    # ``own_neighbours`` indices (N, SHARED_NEIGHBOURS + 1) when the areas were estimated and
    # the normals will be: the search is made once, for the spacing, the normals and the
    # splats.
    neighbours: np.ndarray | None = None


class _Attributes:
    """Duck-types MeshSamples.uv/.color for the material evaluator."""

    def __init__(self, colors: dict[str, np.ndarray], active: str | None) -> None:
        self.colors, self.active = colors, active

    def uv(self, name=None):
        return None

    def color(self, name=None):
        return self.colors.get(name or self.active)


def _read_attr(attributes, name: str, count: int, width: int) -> np.ndarray | None:
    attr = attributes.get(name)
    if attr is None:
        return None
    prop = {"FLOAT_COLOR": "color", "BYTE_COLOR": "color", "FLOAT_VECTOR": "vector",
            "FLOAT": "value"}.get(attr.data_type)
    if prop is None or attr.domain != "POINT":
        return None
    w = {"color": 4, "vector": 3, "value": 1}[prop]
    if w != width:
        return None
    out = np.empty(count * w, dtype=np.float64)
    attr.data.foreach_get(prop, out)
    return out.reshape(count, w) if w > 1 else out


def estimate_areas(positions: np.ndarray, k: int = K_NEIGHBOURS) -> np.ndarray:
    """Area per point (m²) from neighbour spacing (see the module docstring)."""
    return areas_from_distances(own_neighbours(positions, k)[1])


def own_neighbours(positions: np.ndarray, k: int = K_NEIGHBOURS) -> tuple[np.ndarray, np.ndarray]:
    """Each point's ``k`` nearest other points and itself: indices (N, k + 1) int64, the
    point first where it has no duplicate, and distances (N, k + 1), m. The one search of a
    scan's own points (with k = ``SHARED_NEIGHBOURS``) that its spacing
    (``areas_from_distances``, the first K_NEIGHBOURS + 1 columns), its normals, its splats'
    planes (``illumap.pointcloud.nearest``, ``settled_normals``) and their outlines
    (``illumap.splats.splat_radii``) all read."""
    return knn(positions, positions, k + 1)


def areas_from_distances(distances: np.ndarray) -> np.ndarray:
    """Area per point (m²) from ``own_neighbours``' distances (N, k + 1), m (module
    docstring: 1/ρ ≈ 2π·mean_j(d_j²)/(k+1) over the k other points)."""
    d2 = distances[:, 1:] ** 2
    return 2 * np.pi * d2.mean(axis=1) / (d2.shape[1] + 1)


def bound_stray_areas(areas: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``areas`` (estimated from the spacing) with stray points' bounded: (areas, stray mask,
    the area given to them, m²).

    A stray point (a scanner's spurious return, a point dragged away by mistake) lies far from
    its neighbours, so its area, estimated from their distances, is the square of that
    distance: a disc kilometres wide for a point 1 km from a 1 m scan, which would occlude
    and reflect as a surface that is not there (and stalled the native build). A point is
    stray where its spacing (√area) exceeds the cloud's median spacing by more than
    ``STRAY_SPACING`` times and by more than ``STRAY_MADS`` median absolute deviations of the
    log spacing (a terrestrial scan's far walls are legitimately sparse). It gets the
    typical (median) point's area: it stands for one sample, and so changes the light of
    the rest no more than any one point does.
    """
    areas = np.asarray(areas, dtype=np.float64)
    positive = areas > 0
    if positive.sum() < 2:
        return areas, np.zeros(len(areas), dtype=bool), float("nan")
    log_spacing = 0.5 * np.log(areas[positive])
    median = float(np.median(log_spacing))
    mad = 1.4826 * float(np.median(np.abs(log_spacing - median)))
    limit = median + max(np.log(STRAY_SPACING), STRAY_MADS * mad)
    stray = areas > np.exp(2.0 * limit)
    typical = float(np.exp(2.0 * median))
    return np.where(stray, typical, areas), stray, typical


def estimate_normals(positions: np.ndarray, k: int = K_NEIGHBOURS,
                     neighbours: np.ndarray | None = None) -> np.ndarray:
    """Unit normals (N, 3) by PCA over k neighbours, oriented consistently (module docstring);
    ``neighbours``: ``illumap.pointcloud.nearest`` of the same points, when at hand."""
    from illumap import pointcloud as core_pointcloud  # noqa: PLC0415 - native, loaded on use
    return core_pointcloud.estimate_normals(positions, k, neighbours=neighbours)


def read_points(obj, depsgraph, warnings: list[str]) -> PointSamples:
    """Surfels from a PointCloud object or a vertex-only mesh (evaluated, world space)."""
    obj_eval = obj.evaluated_get(depsgraph)
    data = obj_eval.data
    name = obj.name
    if obj.type == "POINTCLOUD":
        count = len(data.points)
        pos = _read_attr(data.attributes, "position", count, 3)
        attributes = data.attributes
        # PointCloud.color_attributes has no active_color in bpy 5.0.
        ac = getattr(data.color_attributes, "active_color", None)
        active = ac.name if ac is not None else None
        mats = list(obj.material_slots)
    else:
        mesh = obj_eval.to_mesh()
        try:
            count = len(mesh.vertices)
            pos = np.empty(count * 3)
            mesh.vertices.foreach_get("co", pos)
            pos = pos.reshape(count, 3)
            attributes = mesh.attributes
            # The render colour attribute, as for meshes with faces (sampling.TriangleMesh).
            active = mesh.color_attributes.default_color_name or None
            extra = _point_attrs(attributes, count)
        finally:
            obj_eval.to_mesh_clear()
        mats = list(obj.material_slots)
        return _finish(obj, obj_eval, name, pos, extra, active, mats, warnings)
    extra = _point_attrs(attributes, count)
    return _finish(obj, obj_eval, name, pos, extra, active, mats, warnings)


def _check_spacing(name: str, pos: np.ndarray, areas: np.ndarray, k: int) -> None:
    """Raise an IllumapError naming the point cloud when points coincide with all their
    nearest neighbours: no spacing, so no area, can be estimated for them."""
    bad = ~(areas > 0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        where = ", ".join(f"{c:.6g}" for c in pos[i])
        raise IllumapError(
            f"Point cloud '{name}': {int(bad.sum())} points coincide with their {k} nearest "
            f"neighbours (e.g. point {i} at ({where})), so their spacing and area cannot be "
            "estimated: remove the duplicates (Merge by Distance) or add a 'radius' attribute")


def _stray_warning(name: str, pos: np.ndarray, stray: np.ndarray, typical: float) -> str:
    count = int(stray.sum())
    i = int(np.flatnonzero(stray)[0])
    where = ", ".join(f"{c:.6g}" for c in pos[i])
    points = "1 point lies far from its" if count == 1 else f"{count} points lie far from their"
    return (f"Point cloud '{name}': {points} neighbours (more than {STRAY_SPACING:g} times the "
            f"typical spacing; e.g. point {i} at ({where})): stray points, given the typical "
            f"point's area ({typical:.3g} m²) instead of a disc as wide as that gap. Delete "
            "them, or give the cloud a 'radius' attribute")


def _point_attrs(attributes, count: int) -> dict:
    out = {"radius": _read_attr(attributes, "radius", count, 1), "normal": None, "colors": {}}
    for nm in ("normal", "N"):
        v = _read_attr(attributes, nm, count, 3)
        if v is not None:
            out["normal"] = v
            break
    for attr in attributes:
        if attr.data_type in ("FLOAT_COLOR", "BYTE_COLOR") and attr.domain == "POINT":
            out["colors"][attr.name] = _read_attr(attributes, attr.name, count, 4)
    return out


def _finish(obj, obj_eval, name, pos, extra, active, mats, warnings) -> PointSamples:
    count = len(pos)
    if count == 0:
        raise IllumapError(f"Object '{name}' has no points")
    if not np.all(np.isfinite(pos)):
        raise IllumapError(f"Object '{name}' has points with NaN or infinite coordinates")
    from .sampling import check_coordinates, check_transform
    m = check_transform(name, obj_eval.matrix_world)
    lin = m[:3, :3]
    with np.errstate(over="ignore", invalid="ignore"):
        pos = pos @ lin.T + m[:3, 3]
    check_coordinates(name, pos, "point")
    radius, normal = extra["radius"], extra["normal"]
    if (radius is None or normal is None) and count < 4:
        missing = "radius" if radius is None else "normal"
        raise IllumapError(
            f"Point cloud '{name}' has no '{missing}' attribute and only {count} points: too few to "
            f"estimate it from neighbours (needs at least 4). Add a '{missing}' attribute.")
    k = min(K_NEIGHBOURS, count - 1)
    table = None
    if radius is not None:
        # Areas scale with the transform's area factor |det|^(2/3).
        areas = np.pi * radius.astype(np.float64) ** 2 * abs(np.linalg.det(lin)) ** (2.0 / 3.0)
        if not np.all(np.isfinite(areas)) or (areas <= 0).any():
            raise IllumapError(f"Point cloud '{name}': radius attribute has zero, negative or NaN values")
    else:
        # As wide as the splats read where the normals, and so the splats' planes, are
        # estimated from it too; else the spacing's own.
        wide = min(SHARED_NEIGHBOURS, count - 1) if normal is None else k
        table, dist = own_neighbours(pos, wide)
        areas = areas_from_distances(dist[:, :k + 1])
        del dist
        _check_spacing(name, pos, areas, k)
        warnings.append(f"Point cloud '{name}': no 'radius' attribute; areas estimated from the "
                        f"spacing of {k} nearest neighbours")
        areas, stray, typical = bound_stray_areas(areas)
        if stray.any():
            warnings.append(_stray_warning(name, pos, stray, typical))
    if normal is not None:
        normal = normal @ np.linalg.inv(lin)
        length = np.linalg.norm(normal, axis=1)
        if (length < 1e-12).any() or not np.all(np.isfinite(length)):
            raise IllumapError(f"Point cloud '{name}': normal attribute has zero or NaN vectors")
        normal = normal / length[:, None]
    else:   # estimated by ``with_normals``, off the main thread in an interactive run
        warnings.append(f"Point cloud '{name}': no 'normal' attribute; normals estimated from the "
                        f"plane most of {k} neighbours lie on, and as their orientation is unknown "
                        f"both sides of every point are lit (each point shows its brighter side: "
                        f"the inside of a scanned room, the outside of a scanned object)")
    colors = extra["colors"]
    key = active if active in colors else next((c for c in _COLOR_NAMES if c in colors), None)
    material = mats[0].material if mats else None
    rows = np.arange(count)
    albedo, emission = materials.material_values(material, _Attributes(colors, key), rows, warnings,
                                                 owner=name)
    if key is not None:
        albedo = colors[key][:, :3].copy()
        bad = materials.not_finite(albedo).any(axis=1)
        if bad.any():
            raise IllumapError(f"Point cloud '{name}': colour attribute '{key}' is "
                               f"{materials.describe_not_finite(albedo[bad])} at {int(bad.sum())} "
                               "points; give it finite colours")
    if (albedo > materials.MAX_ALBEDO).any():
        warnings.append(f"Point cloud '{name}': albedo above {materials.MAX_ALBEDO} clamped")
    albedo = np.clip(np.nan_to_num(albedo), 0.0, materials.MAX_ALBEDO)
    return PointSamples(name=name, positions=pos, normals=normal, areas=areas, albedo=albedo,
                        emission=np.maximum(np.nan_to_num(emission), 0.0), colors=colors,
                        two_sided=extra["normal"] is None,
                        neighbours=table if normal is None else None)


def with_normals(samples: PointSamples) -> PointSamples:
    """``samples`` with normals: as read, or where the cloud had none, estimated from the
    plane most of each point's neighbours lie on, and lit about
    ``illumap.pointcloud.receiver_normals`` (the spread of all of them, but for the points
    beside a crease). numpy and the core only."""
    if samples.normals is not None:
        return samples
    pos = samples.positions
    k = min(K_NEIGHBOURS, len(pos) - 1)
    from illumap import pointcloud as core_pointcloud  # noqa: PLC0415 - native, loaded on use
    # One search for the spacing, both fits and the splats' planes and outlines: its first
    # k + 1 columns are what ``nearest`` would find (k ≥ 2 here, as it clamps).
    table = samples.neighbours
    if table is None:
        table = core_pointcloud.nearest(pos, min(SHARED_NEIGHBOURS, len(pos) - 1))
    around = np.ascontiguousarray(table[:, :k + 1])
    normal = estimate_normals(pos, k, neighbours=around)
    receiver = core_pointcloud.receiver_normals(pos, normal, around)
    del around
    return replace(samples, normals=normal, receiver_normals=receiver, neighbours=table)
