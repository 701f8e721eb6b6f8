"""The light stage (no bpy): ``Scene`` → ``Lit``. The direct light of the lamps, the emissive
meshes' lamps and the world at every surfel, shadows cast against the scene (its triangles,
or the surfels as occluders where there are none); where triangles occlude, what each
surfel's hemisphere meets (``illumap.conservation``), which bounds its transport row and
brings the world's light."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .. import lights
from ..gather.ids import gather_sides, surfel_ids
from .choices import SURFEL_COVERAGE, occluder_shape, surfel_shadow_samples
from ..settings import SettingsError
from .errors import NoLight, RunError
from .scene import Progress, Scene, with_occluders


@dataclass(frozen=True)
class Lit:
    """A scene with the direct light at its surfels."""

    scene: Scene                   # with its occluders built
    direct: np.ndarray             # (N, 3) albedo × incident lamp, emitter and world radiance
    direct_lamps: np.ndarray       # (N, 3) the part of ``direct`` from lamps and emitters
    hemisphere: object = None      # conservation.Hemisphere, or None (no triangles)
    timings: dict = field(default_factory=dict)   # the scene's, and this stage's, s
    stats: dict = field(default_factory=dict)
    warnings: tuple = ()


#: Scale each surfel's transport row to its measured hemisphere share
#: (``illumap.conservation``) and take the world's light at the surfels from the same rays.
#: White furnace against Cycles (bench/reference/furnace.py --conserve on/off): Suzanne
#: 0.83 -> 0.23 RMS (max 2.93 -> 1.01, the solve converges), bunny scan 2.18 -> 0.037 (max
#: 8.1 -> 1.10), room scan 0.195 -> 0.0005; bench monkey 4.56% -> 2.5%. False restores the
#: kernel's own rows (to compare; light is then created where parts overlap).
CONSERVE_LIGHT = True


def make_segment_query(positions, normals, areas, progress=None, shape="disc"):
    """The segment query lamp shadows are cast with, ``visible(origins, targets, skip,
    progress=None)``: the core's ``illumap.Occluders`` built once on the surfels (``shape``s
    of the area of discs of SURFEL_COVERAGE), or None when the installed core has none.
    ``progress`` hears the build."""
    import illumap
    occluders = getattr(illumap, "Occluders", None)
    if occluders is None:
        return None
    n = len(areas)
    surfels = illumap.Surfels(positions, normals, areas, np.zeros((n, 3)), np.zeros((n, 3)))
    build = None if progress is None else (lambda f, _phase="": progress(0.0, lights.PHASE))
    occ = occluders(surfels, coverage=SURFEL_COVERAGE, shape=shape, progress=build)

    def visible(origins, targets, skip, progress=None):
        return occ.visible(origins, targets, skip=skip, progress=progress)
    return visible


def shadow_query(scene: Scene, normals: np.ndarray, progress: Progress | None = None):
    """The segment query lamp shadows are cast with from points with ``normals`` (surfels or
    receivers), ``visible(origins, targets, rows, progress=None)``: against the scene's
    triangles where it has them (``MeshOccluders.segment_query``; ``scene`` with its
    occluders built), else against the surfels as occluders (``make_segment_query``). None
    when the core has neither."""
    if scene.triangles_occlude:
        return scene.occluders.segment_query(normals)
    return make_segment_query(scene.positions, scene.normals, scene.areas, progress,
                              shape=occluder_shape(scene.settings))


def hemisphere_hits(scene: Scene, progress: Progress | None = None):
    """What each surfel's hemisphere meets (``illumap.conservation.Hemisphere``: the share
    whose first hit is a lit face, and the share open to the world), against the scene's
    triangles and splats (``scene`` with its occluders built); None without triangles. Back faces are lit where the gather has a
    back field (open meshes that kept back surfels) and on every splat. No bpy."""
    occ = scene.occluders
    if occ is None:
        return None
    from ..conservation import hemisphere_hits as hits
    sides = gather_sides(scene)
    lit_backs = (np.ones(len(scene.triangles), dtype=bool) if sides is None
                 else np.asarray(sides, dtype=bool).copy())
    if scene.splat_point is not None:
        lit_backs |= scene.splat_point >= 0
    # The rays belong to the direct light's phase (light() casts them first): its fraction
    # stays where it starts, so the phases keep their order.
    report = None if progress is None else (lambda f, _p="": progress(0.0, lights.PHASE))
    clouds = {cloud.name for cloud in scene.clouds}
    points = np.zeros(scene.count, dtype=bool)
    # A surfel's rays follow from its object and its row there (both sides of a point alike),
    # so that adding, removing or turning another object changes none of its rays.
    ids = surfel_ids(scene)
    for src in scene.sources:
        if src.name in clouds:
            points[src.start:src.stop] = True
    return hits(occ, scene.positions, scene.normals, lit_backs=lit_backs, inset=points, ids=ids,
                seed=scene.settings.seed, links=True, progress=report, faces=surfel_faces(scene),
                triangles=surfel_triangles(scene))


def surfel_triangles(scene: Scene) -> np.ndarray | None:
    """(N,) int64 the row in ``scene.triangles`` of each mesh surfel's triangle (a back
    surfel's too), -1 for a scan's points; None without mesh triangles."""
    if scene.triangles is None or scene.mesh_triangle_start is None or scene.triangle is None:
        return None
    out = np.full(scene.count, -1, dtype=np.int64)
    meshes = [src.name for src in scene.sources if src.kind == "MESH"]
    for src in scene.sources:
        if src.name in meshes and src.kind in ("MESH", "BACK"):
            rows = np.arange(src.start, src.stop)
            local = np.asarray(scene.triangle[rows], dtype=np.int64)
            start = int(scene.mesh_triangle_start[meshes.index(src.name)])
            out[rows] = np.where(local >= 0, start + local, -1)
    return out


def surfel_faces(scene: Scene) -> np.ndarray | None:
    """(N, 3) the unit geometric normal of each front mesh surfel's triangle, turned to its
    side; 0 for a mesh's back surfels and a scan's points; None without mesh triangles.
    Below it a smooth normal's hemisphere sends nothing, as in a renderer (the final
    gather's corners drop the same directions)."""
    triangle = surfel_triangles(scene)
    if triangle is None:
        return None
    front = np.zeros(scene.count, dtype=bool)
    for src in scene.sources:
        if src.kind == "MESH":
            front[src.start:src.stop] = True
    rows = np.flatnonzero(front & (triangle >= 0))
    tri = scene.triangles[triangle[rows]]
    f = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    f /= np.maximum(np.linalg.norm(f, axis=1, keepdims=True), 1e-300)
    f *= np.where(np.einsum("ij,ij->i", f, scene.normals[rows]) < 0.0, -1.0, 1.0)[:, None]
    faces = np.zeros((scene.count, 3))
    faces[rows] = f
    return faces


def light(scene: Scene, progress: Progress | None = None) -> Lit:
    """Direct light of the scene's lamps, its emissive meshes' lamps (``emitters``) and its
    world at the surfels, shadows cast against the scene; the "direct light", "hemisphere"
    and "shadow rays" timings and ``stats["shadow_rays"]``. Raises the core's Cancelled when
    ``progress`` returns False, RunError when a ray query fails."""
    t0 = time.perf_counter()
    s = scene.settings
    timings, stats, warnings = dict(scene.timings), dict(scene.stats), list(scene.warnings)
    scene = with_occluders(scene, progress)
    pos, nrm = scene.positions, scene.normals
    shadows, hemisphere = None, None
    try:
        # The world's light comes through the rays that bound each surfel's transport row:
        # its sky and its surfaces then share one hemisphere, and a white furnace reads 1.
        if CONSERVE_LIGHT and scene.triangles_occlude:
            hemisphere = hemisphere_hits(scene, progress)
            timings["hemisphere"] = time.perf_counter() - t0
        world_by_rays = scene.world is not None and hemisphere is not None
        all_lamps = (scene.all_lamps
                     + ([scene.world] if scene.world and not world_by_rays else []))
        if progress is not None and progress(0.0, lights.PHASE if all_lamps and s.lamp_shadows
                                             else "direct light") is False:
            from .._progress import Cancelled
            raise Cancelled("Cancelled")
        if all_lamps and s.lamp_shadows:
            shadows = _shadows(scene, nrm, surfel_shadow_samples(s), progress, warnings)
        incident, from_world = lights.incident_radiance(all_lamps, pos, nrm, shadows=shadows,
                                                        world_apart=True)
        if world_by_rays:
            from_world = hemisphere.open[:, None] * np.asarray(scene.world.color)[None, :]
    except Exception as exc:  # noqa: BLE001 - a failing ray query is reported, not raised raw
        if _cancelled(exc) or isinstance(exc, (RunError, SettingsError)):
            raise
        raise RunError(f"Lamp shadows failed: {type(exc).__name__}: {exc}", "solver") from exc
    if shadows is not None:
        timings["shadow rays"] = shadows.seconds
        stats["shadow_rays"] = int(shadows.rays)
        stats["shadow_occluders"] = ("triangles" if scene.triangles_occlude
                                     else f"{occluder_shape(s)}s")
    direct_lamps = np.ascontiguousarray(scene.albedo * incident)
    direct = np.ascontiguousarray(direct_lamps + scene.albedo * from_world)
    timings["direct light"] = time.perf_counter() - t0
    return Lit(scene=scene, direct=direct, direct_lamps=direct_lamps, hemisphere=hemisphere,
               timings=timings, stats=stats, warnings=tuple(warnings))


def _cancelled(exc: BaseException) -> bool:
    from .._progress import Cancelled
    return isinstance(exc, Cancelled)


def _shadows(scene: Scene, normals: np.ndarray, samples: int, progress: Progress | None,
             warnings: list[str]):
    """``lights.Shadows`` for points with ``normals`` (``shadow_query``), or None with a
    warning when the core has no ray query."""
    query = shadow_query(scene, normals, progress)
    if query is None:
        warnings.append("Lamp shadows need the core's occluder query, which this "
                        "build lacks: lamp light is unshadowed")
        return None
    extent = float(np.ptp(scene.positions, axis=0).max()) if len(scene.positions) else 1.0
    return lights.Shadows(query, samples=samples, seed=scene.settings.seed, extent=extent,
                          progress=progress)


def check_light(lit: Lit) -> None:
    """Refuse a lit scene whose surfels receive no light and emit none: its map would be
    black. Says whether the scene has no light at all (no lamps, no emissive materials, no
    world light) or has lamps that light no surface (every surface faces away, lies in
    shadow or outside a spot's cone). Raises NoLight; the run skips the solve."""
    scene = lit.scene
    if (np.asarray(scene.emission) > 0).any() or (np.asarray(lit.direct) > 0).any():
        return
    s = scene.settings
    lamps = [lamp.name for lamp in scene.all_lamps]
    lamp_notes = [w for w in lit.warnings if w.startswith("Lamp '")]
    end = ("so the map would be black: solve skipped, nothing written.")
    if lamps:
        one = len(lamps) == 1
        raise NoLight(
            f"The lamp{'' if one else 's'} {_names(lamps)} light{'s' if one else ''} none of "
            f"the surfaces (every surface of the {scene.count} surfels faces away from "
            f"{'it' if one else 'them'}, lies in shadow or outside the cone), {end} Turn the "
            "lamp towards the objects, or check the objects' normals.")
    hints = []
    if not s.lamps:
        hints.append("the lamps are switched off (Lamps setting, batch --no-lamps)")
    if not s.world_ambient:
        hints.append("World Light is off (batch: without --no-world it is on)")
    elif scene.world is None:
        hints.append("the world is black or absent")
    else:
        hints.append("the world's light reaches none of the surfaces")
    hints += lamp_notes
    raise NoLight(
        "No light in the scene: no lamps, no emissive materials and no world light reach the "
        f"{scene.count} surfels, {end} Add a lamp or an Emission material"
        + ("; " + "; ".join(hints) if hints else "") + ".")


def _names(items, limit: int = 3) -> str:
    names = [f"'{n}'" for n in items]
    return ", ".join(names[:limit]) + (f" and {len(names) - limit} more" if len(names) > limit
                                       else "")
