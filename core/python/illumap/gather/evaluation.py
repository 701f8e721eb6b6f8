"""One evaluation of the light at a batch of receivers (no bpy): the lamps' direct light with
shadow rays from each receiver, plus the final gather of the surfels' solved light
(``illumap.receivers``), shared through an irradiance cache where the receivers are a point
cloud's points, corrected across gaps, zero where another surface covers the receiver.
``Evaluation`` holds what every batch of one gather shares (the prepared ``Gatherer``, its
exact part, the seconds of each phase); ``prepare`` builds it."""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from .. import lights
from ..stages.scene import Progress, Scene
from .covered import covered_receivers
from .gaps import across_gaps
from .ids import (back_field_normals, back_field_rows, gather_sides, splat_owners,
                  with_splat_backs)
from .lattice import CONTACT_RAYS, exact_direct, gathered_at_contacts
from .straddling import regather_straddling


@dataclass
class Evaluation:
    """What the batches of one gather share, and what they found so far."""

    scene: Scene
    occ: object                    # receivers.MeshOccluders of the scene
    back: np.ndarray               # (N,) bool: back-face surfels (a field of their own)
    field_: object                 # receivers.SurfelField of the front surfels' light
    exact: object                  # receivers.ExactPart, or None
    gatherer: object               # receivers.Gatherer, tabulated once
    gather_rays: int
    shadow_samples: int
    report: object                 # the gather's progress, or None
    radiosity: np.ndarray          # the surfels' outgoing radiance, straddling ones evaluated
    straddling: int
    lattice_lit: int
    contact_points: int
    gap_receivers: int = 0
    phases: dict = field(default_factory=dict)    # seconds of each part
    mark: float = field(default_factory=time.perf_counter)

    def lap(self, name: str) -> None:
        """Add the seconds since the last lap to phase ``name``."""
        now = time.perf_counter()
        self.phases[name] = self.phases.get(name, 0.0) + now - self.mark
        self.mark = now

    @property
    def all_lamps(self) -> list:
        return list(self.scene.lamps) + list(self.scene.emitters)

    def gather_at(self, points, normals, ids, rays, faces=None, casters=None):
        """The prepared gather at receivers (``Gatherer.gather``; ``faces``: their faces'
        geometric normals, or None; ``casters`` (M,) int: the row whose rays each row takes
        in its own face (itself: it casts them; ``merged_corners``), or None: each casts)."""
        seed = self.scene.settings.seed
        if faces is None or casters is None or (casters == np.arange(len(casters))).all():
            return self.gatherer.gather(points, normals, rays=rays, seed=seed, ids=ids,
                                        faces=faces, progress=self.report)
        casts = np.flatnonzero(casters == np.arange(len(casters)))
        of_cast = np.full(len(casters), -1, dtype=np.int64)
        of_cast[casts] = np.arange(len(casts))
        takers = np.flatnonzero(casters != np.arange(len(casters)))
        takers = takers[np.argsort(of_cast[casters[takers]], kind="stable")]
        start = np.r_[0, np.cumsum(np.bincount(of_cast[casters[takers]],
                                               minlength=len(casts)))]
        g = self.gatherer.gather(points[casts], normals[casts],
                                 rays=rays if np.ndim(rays) == 0 else np.asarray(rays)[casts],
                                 seed=seed, ids=ids[casts], faces=faces[casts],
                                 shares=(start, points[takers], faces[takers]),
                                 progress=self.report)
        order = np.concatenate([casts, takers])

        def rows(a):
            if a is None:
                return None
            out = np.empty_like(a)
            out[order] = a
            return out

        return replace(g, radiance=rows(g.radiance), stderr=rows(g.stderr), reach=rows(g.reach),
                       open=rows(g.open), halves=rows(g.halves))

    def incident_at(self, points, normals, ids, meshes=None, rays=None, shared=None,
                    samples=None, gaps=False, timed=False, faces=None, casters=None):
        """Incident radiance (M, 3) at receivers, the gather's result, the rays cast and the
        receivers found covered (inside or under another surface: no light). ``shared`` (M,)
        int: receivers of one group (≥ 0) share the gather through an irradiance cache
        (``illumap.irradiance_cache``); -1 or None: each gathers itself. ``gaps``: correct
        the receivers that face a gap (``across_gaps``; the main batch's). ``timed``: its
        parts go into ``phases``. ``rays``, ``samples``: the gather's and the shadows' (None:
        the evaluation's). ``faces`` (M, 3): the geometric normals of the receivers' faces,
        below which their rays take nothing (None: no face). ``casters`` (M,) int: the row
        whose rays and direct light each row takes (itself: its own; ``merged_corners``'
        corners of one vertex in other face planes), or None: each row its own."""
        s = self.scene.settings
        rays = self.gather_rays if rays is None else rays
        samples = self.shadow_samples if samples is None else samples
        occ, all_lamps = self.occ, self.all_lamps
        if timed:
            self.lap("corners and side probe")
        shadows = None
        # Each row's own shadow rays, casters or not: a vertex's corners in other face planes
        # sample its lamps afresh (taken from the caster, Suzanne read 1.12% where its own
        # shadow rays give 1.07%, for 0.03 s).
        if all_lamps and s.lamp_shadows:
            # A point cloud's points (``shared``) share the lamps' probes as their gathers.
            groups = shared if shared is not None and s.gather_cache > 0 else None
            shadows = lights.Shadows(occ.segment_query(normals), samples=samples,
                                     seed=s.seed, extent=occ.extent, ids=ids,
                                     progress=self.report,   # a cancel between lamps, rays
                                     groups=groups)
        direct = lights.incident_radiance(all_lamps, points, normals, shadows=shadows)
        if timed:
            self.lap("direct")
        gap_cast = 0
        if shared is not None and s.gather_cache > 0 and (shared >= 0).any():
            from ..irradiance_cache import MIN_REACH_SHARE, cached_gather

            def full_gather(rows, rays_=None):
                """The cache's gathers; those in full (not its probes) corrected across gaps
                here, so that the receivers between records take the corrected light."""
                nonlocal gap_cast
                g = self.gather_at(points[rows], normals[rows], ids[rows],
                                   rays if rays_ is None else rays_,
                                   None if faces is None else faces[rows],
                                   None if casters is None else _within(casters, rows))
                if gaps and rays_ is None:
                    fixed, cast_ = across_gaps(self.scene, occ, self.exact, self.gatherer,
                                               ~self.back, points[rows], normals[rows],
                                               ids[rows], rays, g.radiance)
                    self.gap_receivers += fixed
                    gap_cast += cast_
                return g

            gathered = cached_gather(
                lambda rows, rays=None: full_gather(rows, rays),
                points, normals, groups=shared, accuracy=s.gather_cache, max_reach=occ.extent,
                min_reach=MIN_REACH_SHARE * self.field_.reach, progress=self.report)
            if timed:
                self.lap("gather")
        else:
            gathered = self.gather_at(points, normals, ids, rays, faces, casters)
            if timed:
                self.lap("gather")
            if gaps:
                self.gap_receivers, gap_cast = across_gaps(
                    self.scene, occ, self.exact, self.gatherer, ~self.back, points, normals,
                    ids, rays, gathered.radiance)
        if timed:
            self.lap("gaps")
        incident = direct + gathered.radiance
        hidden = covered_receivers(self.scene, points, normals, 2.0 * occ.offset, meshes)
        incident[hidden] = 0.0
        if timed:
            self.lap("covered")
        cast = gathered.rays + gap_cast + (shadows.rays if shadows is not None else 0)
        return incident, gathered, cast, int(hidden.sum())


def _within(casters: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``casters`` of ``rows`` among ``rows``: a row whose caster is not among them casts."""
    local = np.full(len(casters), -1, dtype=np.int64)
    local[rows] = np.arange(len(rows))
    own = local[casters[rows]]
    return np.where(own < 0, np.arange(len(rows)), own)


def prepare(scene: Scene, occ, direct: np.ndarray | None, direct_lamps: np.ndarray | None,
            radiosity: np.ndarray, gather_rays: int, shadow_samples: int,
            progress: Progress | None = None, enclosed: np.ndarray | None = None) -> Evaluation:
    """The gather's shared parts for surfels whose solved outgoing radiance is ``radiosity``
    (N, 3) and whose reflected direct light is ``direct`` (the lamps' part
    ``direct_lamps``): the straddling surfels evaluated afresh, the surfels' fields (front and
    back faces), the exact part of the lattice (lamp and sky light cast there, contacts
    gathered afresh) and the ``Gatherer`` that tabulates them once. ``enclosed`` (N,) bool:
    the surfels whose solved rows came from their first hits (the back ones keep their solved
    values, ``regather_straddling``), or None."""
    from .. import receivers as rc
    mark = time.perf_counter()
    # What the surfels send on: their solved radiance (with the emission left to them); the
    # open surfaces' and two-sided points' back faces are a field of their own.
    sent = radiosity - scene.emission + scene.solve_emission
    back = scene.back_rows()
    back_rows = back_field_rows(scene, back)
    owners, back_owners = splat_owners(scene, back, back_rows)
    background = None if scene.world is None else scene.world.color
    sides = with_splat_backs(scene, gather_sides(scene))
    straddling, radiosity = regather_straddling(scene, direct_lamps, radiosity, occ, sent, back,
                                                owners, back_owners, gather_rays, background,
                                                sides, back_rows, enclosed)
    # The back field is a field of light: a point that no surfel near it sees (walled off by
    # triangles) is dark, not lit by a surfel behind a wall. The front field is not: its
    # lifted segments read the lamps bench's awning 1.47% -> 2.19% (the scene 0.77-0.84% ->
    # 1.00-1.38% over seeds 0-2) for Suzanne's white furnace 2.29% -> 1.90%.
    field_ = rc.SurfelField(scene.positions[~back], scene.normals[~back], sent[~back])
    back_field = (rc.SurfelField(scene.positions[back_rows],
                                 back_field_normals(scene, back, back_rows), sent[back_rows],
                                 light_field=True)
                  if len(back_rows) else None)
    phases = {"straddling": time.perf_counter() - mark}
    mark = time.perf_counter()
    exact, lattice_lit, correction = exact_direct(scene, direct, direct_lamps, occ, sent, ~back,
                                                  field_, owners, sides, shadow_samples)
    exact, contact_points = gathered_at_contacts(scene, occ, exact, ~back, field_, back_field,
                                                 owners, back_owners, sides,
                                                 min(gather_rays, CONTACT_RAYS), correction)
    report = None if progress is None else (lambda f, _p="": progress(f, "gather"))
    ev = Evaluation(scene=scene, occ=occ, back=back, field_=field_, exact=exact, gatherer=None,
                    gather_rays=gather_rays, shadow_samples=shadow_samples, report=report,
                    radiosity=radiosity, straddling=straddling, lattice_lit=lattice_lit,
                    contact_points=contact_points, phases=phases, mark=mark)
    # One prepared gather for every batch: the field is tabulated once.
    ev.gatherer = rc.Gatherer(occ, field_, background=background, back_field=back_field,
                              two_sided=sides, owners=owners, back_owners=back_owners,
                              exact=exact, progress=report)
    ev.lap("tables")
    return ev
