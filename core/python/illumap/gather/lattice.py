"""The gather's table of the surfels' light at its lattice points (no bpy): the lamps' and the
sky's light cast at the points where it changes sharply (``exact_direct``), and beside
contacts under a sky the light between the surfaces gathered afresh
(``gathered_at_contacts``)."""

from __future__ import annotations

import numpy as np

from .. import lights
from ..stages.scene import Scene
from .ids import lattice_ids


#: Shadow rays per lattice point and sized lamp: a hit interpolates three lattice points and
#: a receiver averages hundreds of hits, so the lattice's own noise averages out.
LATTICE_SHADOW_SAMPLES = 4
#: Rays per lattice point that find how much of the sky it sees: the receivers' shadow
#: samples, within [MIN_LATTICE_WORLD_SAMPLES, lights.WORLD_SAMPLES] (the surfels' own count).
#: The sky is most of the light outdoors, so fewer would show.
MIN_LATTICE_WORLD_SAMPLES = 16


def exact_direct(scene: Scene, direct: np.ndarray | None, direct_lamps: np.ndarray | None, occ,
                 sent: np.ndarray, front: np.ndarray, field_, owners, sides,
                 shadow_samples: int) -> tuple:
    """The gather's ``ExactPart`` for the front field (None without lamp or sky light) and
    the number of lattice points shadow rays were cast from: the reflected direct light of
    the lamps, the emitters and the world at the points where the gather tabulates the
    surfels' light, beside the surfels' light less their own direct part. A hit then sees a
    lamp's shadow edge, or the sky hidden under an object resting on a floor, as sharp as
    that lattice, not blurred over the surfels' spacing: what lights a receiver beside a
    contact or a shadow. Shadow rays are cast only where the surfels' direct light changes
    sharply (``sharpness``, blended in by it); elsewhere their average is as good. The sky
    takes ``shadow_samples`` rays per point (the receivers'; MIN_LATTICE_WORLD_SAMPLES to
    ``lights.WORLD_SAMPLES``), the lamps LATTICE_SHADOW_SAMPLES. ``direct`` and
    ``direct_lamps``: the surfels' reflected direct light, all of it and the lamps' part
    (``Lit``). Under a sky the surfels' indirect light at those points is rescaled to the
    share of the hemisphere the sky cast there leaves (``rest_for_sky_seen``); the third
    value returned is what that added to each lattice point's value (L, 3)."""
    from .. import receivers as rc
    sky = scene.world is not None and direct is not None
    lit = direct if sky else direct_lamps
    if lit is None or not np.any(lit[front]):
        return None, 0, None
    s = scene.settings
    all_lamps = list(scene.lamps) + list(scene.emitters)
    (points, normals, owner), _ = rc.gather_lattices(occ, field_, two_sided=sides, owners=owners,
                                                     triangles=True)
    if not len(points):
        return None, 0, None
    pos, nrm, direct = scene.positions[front], scene.normals[front], lit[front]
    weight = rc.sharpness(pos, direct, points)
    values = rc.SurfelField(pos, nrm, direct).at(points, normals, occ)
    rest = rc.SurfelField(pos, nrm, (sent - lit)[front])
    correction = np.zeros_like(values)
    sharp = np.flatnonzero(weight > 0)
    if sharp.size:
        p_, n_ = points[sharp], normals[sharp]
        ids = lattice_ids(scene, owner)[sharp]   # not their place in the list
        albedo = rc.SurfelField(pos, nrm, scene.albedo[front]).at(p_, n_, occ)
        query = occ.segment_query(n_)
        shadows = (lights.Shadows(query, samples=LATTICE_SHADOW_SAMPLES, seed=s.seed,
                                 extent=occ.extent, ids=ids)
                   if all_lamps and s.lamp_shadows else None)
        exact = albedo * lights.incident_radiance(all_lamps, p_, n_, shadows=shadows)
        if sky:
            rays = min(max(int(shadow_samples), MIN_LATTICE_WORLD_SAMPLES), lights.WORLD_SAMPLES)
            sky_shadows = (lights.Shadows(query, samples=rays, seed=s.seed, extent=occ.extent,
                                         ids=ids) if s.lamp_shadows else None)
            seen = lights.incident_radiance([scene.world], p_, n_, shadows=sky_shadows)
            exact += albedo * seen
            sky_part = lit if direct_lamps is None else lit - direct_lamps
            from_sky = rc.SurfelField(pos, nrm, sky_part[front]).at(p_, n_, occ)
            correction[sharp] = weight[sharp, None] * rest_for_sky_seen(
                scene.world.color, seen, from_sky, albedo, rest.at(p_, n_, occ))
        values[sharp] += weight[sharp, None] * (exact - values[sharp]) + correction[sharp]
    return rc.ExactPart(rest=rest, values=values), int(sharp.size), correction


#: The surfels' share of hemisphere that does not see the sky is taken as at least this when
#: their indirect light is rescaled to a lattice point's (``rest_for_sky_seen``): where the
#: surfels see almost only sky their indirect light is small and its share noisy.
MIN_HIDDEN_SHARE = 0.05
#: The indirect light is only ever lowered (scaled at most this): where a point sees less sky
#: than its surfels, raising it by their hidden shares' ratio amplified the solve's own noise
#: (the resting sphere's lowest ring in the white furnace read up to 1.009, with 1.5 as with
#: no bound; 1.002 before the rescale, 0.9998 with this bound).
MAX_REST_SCALE = 1.0


def rest_for_sky_seen(color, seen: np.ndarray, from_sky: np.ndarray, albedo: np.ndarray,
                      rest: np.ndarray) -> np.ndarray:
    """What to add (L, 3) to the lattice points' values so that the surfels' indirect light
    there (``rest``, interpolated, (L, 3)) comes from the share of the hemisphere that the
    sky cast at the point (``seen``: incident sky radiance, (L, 3)) leaves, not the surfels'
    own share (``from_sky``: their reflected sky light, interpolated; ``albedo`` there). Each
    direction then counts once, the sky's or a surface's: where a point sees more sky than the
    surfels round it (a rim beside a contact), the sky cast afresh on top of their indirect
    light read above 1 in a white furnace. Never raised (``MAX_REST_SCALE``): where the
    point sees less sky than its surfels it keeps their indirect light."""
    c = np.asarray(color, dtype=np.float64).reshape(1, 3)
    lit = c > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        v_point = np.where(lit, seen / np.where(lit, c, 1.0), 0.0)
        reflected = albedo * c
        v_surfels = np.where(reflected > 0, from_sky / np.where(reflected > 0, reflected, 1.0),
                             0.0)
    v_point = np.clip(v_point, 0.0, 1.0)
    v_surfels = np.clip(v_surfels, 0.0, 1.0)
    hidden = np.maximum(1.0 - v_surfels, MIN_HIDDEN_SHARE)
    return rest * (np.minimum((1.0 - v_point) / hidden, MAX_REST_SCALE) - 1.0)


#: A lattice point is beside a contact where a surfel of a surface facing it lies within this
#: many of that surfel's radii (and it faces that surfel within about 72°, as the surfel faces
#: it): a sphere resting on a floor, a box's foot, a corner.
CONTACT_REACH = 2.0
CONTACT_FACING = 0.3
#: Gather rays per lattice point beside a contact (fewer when the receivers cast fewer): on
#: the sky bench scene 128 and 512 gave the same error.
CONTACT_RAYS = 128


def beside_contacts(points: np.ndarray, normals: np.ndarray, pos: np.ndarray,
                     nrm: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """Rows of ``points`` (L, 3, facing unit ``normals``) with a surfel (``pos``, ``nrm``,
    ``areas``: m, unit, m²) of another surface facing them within CONTACT_REACH of its
    radii (see there)."""
    from ..neighbours import knn
    if not len(points) or not len(pos):
        return np.zeros(0, dtype=np.int64)
    near, dist = knn(pos, points, 8)
    row, col = np.nonzero(dist < CONTACT_REACH * np.sqrt(areas / np.pi)[near])
    q = near[row, col]
    to = pos[q] - points[row]
    d = dist[row, col]
    facing = ((np.einsum("ic,ic->i", normals[row], to) > CONTACT_FACING * d)
              & (np.einsum("ic,ic->i", nrm[q], -to) > CONTACT_FACING * d))
    return np.unique(row[facing])


def gathered_at_contacts(scene: Scene, occ, exact, front: np.ndarray, field_, back_field,
                          owners, back_owners, sides, rays: int,
                          correction: np.ndarray | None = None) -> tuple:
    """Under a sky (the exact part has it), the lattice points of the ``front`` surfels' field
    beside a contact (``beside_contacts``) take the light between the surfaces gathered
    afresh (``rays`` rays each, the sky's part left to the exact part) in place of the
    surfels' own: where a sphere rests on a floor, both the sky hidden under it and the light
    bounced between them change over less than a surfel's spacing. Returns the exact part and
    how many points gathered. Without a sky the receivers that face such a gap take the light
    at their rays' hits instead (``across_gaps``): on the lamp-lit bench scenes this gather
    had changed no error by 0.1% and cost a third of the receivers' time."""
    from .. import receivers as rc
    if exact is None or scene.world is None:
        return exact, 0
    (points, normals, owner), _ = rc.gather_lattices(occ, field_, two_sided=sides, owners=owners,
                                                     triangles=True)
    beside = beside_contacts(points, normals, scene.positions[front], scene.normals[front],
                              scene.areas[front])
    if not beside.size:
        return exact, 0
    if correction is None:
        correction = np.zeros_like(exact.values)
    p_, n_ = points[beside], normals[beside]
    gathered = rc.gather(occ, field_, p_, n_, rays=rays, seed=scene.settings.seed,
                         ids=lattice_ids(scene, owner)[beside], back_field=back_field,
                         two_sided=sides,
                         owners=owners, back_owners=back_owners, exact=exact,
                         tabulate=False)
    albedo = rc.SurfelField(scene.positions[front], scene.normals[front],
                            scene.albedo[front]).at(p_, n_, occ)
    values = np.array(exact.values, dtype=np.float64, copy=True)
    # The gather replaces the surfels' indirect light there, rescaled or not.
    values[beside] += (albedo * gathered.radiance - exact.rest.at(p_, n_, occ)
                       - correction[beside])
    return rc.ExactPart(rest=exact.rest, values=values), int(beside.size)
