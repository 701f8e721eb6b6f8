"""The splats of a scan's points in the Object Preview, on the Blender side (no bpy here
either): a cache of the frames a run computed on its worker (``prepare_frames``), by
``fingerprint``, until the preview takes them (``ready_frames``).

The frames themselves (the ellipse of each point in its tangent plane, clipped at creases and
rims; its rules and constants) are ``illumap.splats.splat_frames`` (native, both threads);
mesh_preview.py writes them into hidden point attributes that its point node group reads.
Everything is in the object's own coordinates: the object's transform maps each tangent plane
to the world's, as it does the points.
"""

from __future__ import annotations

import numpy as np

#: Changes whenever the splats' attributes change meaning (2: the scale's third component is
#: the cone's height, where it was 1).
SPLATS_VERSION = 2
#: Splats a run computed on its worker for the scans it lights (``prepare_frames``), by
#: ``fingerprint``, until the preview takes them (``ready_frames``): the preview that follows
#: a run then costs the main thread only the attributes' writing.
_READY: dict[str, dict] = {}
_READY_MAX = 8
#: Each scan's splat neighbours (the frames' search: its order and neighbours, int32), by
#: ``fingerprint``: the shading that every preview after a run writes (the light changed,
#: the splats did not) fits each splat to them without a search of its own. The latest few
#: scans only.
_NEIGHBOURS: dict[str, tuple] = {}
_NEIGHBOURS_MAX = 4
#: The points of each scan whose splats ``prepare_frames`` computed, by ``fingerprint``, until
#: the run's worker shades them (``prepare_shading``).
_PENDING: dict[str, np.ndarray] = {}
#: Each scan's splat shading the run's worker computed (``prepare_shading``), by
#: ``fingerprint``: the values it was computed from (float32 (n, 3)) and the shading, until
#: the preview takes it (``taken_shading``) for a scan whose ``illumination`` is those values.
_SHADED: dict[str, tuple] = {}


def fingerprint(positions, normals=None, radius=None) -> str:
    """What a scan's splats depend on, in a few numbers: the splats' version (splats an
    earlier version wrote are written again), its points (float32, object space), its given
    normals and radii."""
    pos = np.asarray(positions, dtype=np.float32)
    parts = [SPLATS_VERSION, len(pos), float(pos.sum(dtype=np.float64)),
             float(np.square(pos, dtype=np.float64).sum())]
    for extra in (normals, radius):
        parts.append(None if extra is None else float(np.asarray(extra).sum(dtype=np.float64)))
    return repr(parts)


def prepare_frames(positions, normals=None, radius=None, *, progress=None) -> None:
    """Compute the splats of one scan ahead of its preview (numpy and the core only: safe on
    a worker thread). ``progress(fraction, phase)`` returning False cancels (the core's
    ``Cancelled``)."""
    key = fingerprint(positions, normals, radius)
    frames = splat_frames(np.asarray(positions, dtype=np.float32), normals, radius,
                          progress=progress, key=key)
    while len(_READY) >= _READY_MAX:
        _READY.pop(next(iter(_READY)))
    _READY[key] = frames
    while len(_PENDING) >= _READY_MAX:
        _PENDING.pop(next(iter(_PENDING)))
    _PENDING[key] = np.asarray(positions, dtype=np.float32)


def ready_frames(key: str) -> dict | None:
    """The splats ``prepare_frames`` computed for ``key`` (taken out), or None."""
    return _READY.pop(key, None)


def splat_frames(positions, normals=None, radius=None, *, threads: int = 0,
                 progress=None, key: str | None = None) -> dict:
    """Each point's splat: ``illumap.splats.splat_frames`` (float32 ``normal``, ``axis``,
    ``scale``, ``offset`` (N, 3) and bool ``clipped`` (N,), in the positions' unit). With
    ``key`` (the scan's ``fingerprint``) its neighbours are kept for ``splat_shading``."""
    from illumap.splats import splat_frames as frames  # noqa: PLC0415 - native, loaded on use
    out = frames(positions, normals, radius, threads=threads, progress=progress,
                 with_neighbours=key is not None)
    if key is not None:
        order, neighbours = out.pop("order"), out.pop("neighbours")
        if neighbours is not None:
            while len(_NEIGHBOURS) >= _NEIGHBOURS_MAX:
                _NEIGHBOURS.pop(next(iter(_NEIGHBOURS)))
            _NEIGHBOURS[key] = (order.astype(np.int32), neighbours.astype(np.int32))
    return out


def splat_shading(positions, frames: dict, values, key: str | None = None) -> dict:
    """Each splat's linear shading from the points' light ``values`` (n, 3 or 4):
    ``illumap.splat_shading.splat_shading`` (float32 ``base``, ``dx``, ``dy`` (n, 3)), with
    the neighbours the frames of ``key`` found where they are still kept."""
    from illumap.splat_shading import splat_shading as shading  # noqa: PLC0415 - loaded on use
    order, neighbours = _NEIGHBOURS.get(key, (None, None)) if key is not None else (None, None)
    if neighbours is not None and len(neighbours) != len(positions):
        order = neighbours = None
    return shading(positions, frames, values, order=order, neighbours=neighbours)


def pending_shading() -> bool:
    """Whether a scan's splats wait for their shading (``prepare_shading``)."""
    return bool(_PENDING)


def prepare_shading(values_by_cloud: dict, *, progress=None) -> int:
    """Shade the splats ``prepare_frames`` computed, on the run's worker (numpy and the core
    only), from the run's values per point cloud (name → (n, 3) radiance, each in its cloud's
    own order, as written to its ``illumination``): the preview that follows the run then
    writes the shading without computing it on the main thread. A scan is matched to the one
    cloud of its point count (none or several: it is left to the preview); the preview uses the
    result only where the scan's ``illumination`` is the values it was computed from
    (``taken_shading``). Returns the number of scans shaded. ``progress`` may cancel (the
    core's ``Cancelled``)."""
    done = 0
    for key in list(_PENDING):
        positions = _PENDING.pop(key)
        frames = _READY.get(key)
        match = [v for v in values_by_cloud.values() if len(v) == len(positions)]
        if frames is None or len(match) != 1:
            continue
        values = np.asarray(match[0], dtype=np.float64)[:, :3].astype(np.float32)
        from illumap.splat_shading import splat_shading as shading  # noqa: PLC0415
        order, neighbours = _NEIGHBOURS.get(key, (None, None))
        if neighbours is not None and len(neighbours) != len(positions):
            order = neighbours = None
        while len(_SHADED) >= _READY_MAX:
            _SHADED.pop(next(iter(_SHADED)))
        _SHADED[key] = (values, shading(positions, frames, values, order=order,
                                        neighbours=neighbours, progress=progress))
        done += 1
    return done


def taken_shading(key: str, values: np.ndarray) -> dict | None:
    """The shading ``prepare_shading`` computed for the scan ``key`` (taken out), when its
    light ``values`` (n, 3 or 4; float32, as read from its ``illumination``) are the ones it
    was computed from; else None."""
    entry = _SHADED.pop(key, None)
    if entry is None:
        return None
    shaded, shading = entry
    light = np.asarray(values)[:, :3]
    return shading if light.shape == shaded.shape and np.array_equal(light, shaded) else None
