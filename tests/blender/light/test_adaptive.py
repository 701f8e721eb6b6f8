"""Surfel density from a target error, and adaptive density (two passes).

These are the surfel solve's own automatic mode and adaptive passes, so the runs leave the
meshes alone (``transfer=False``): with the light evaluated at the meshes the surfels are held
to a multiple of the target (``pipeline.surfel_target``).

Scene for the adaptive comparison: a 2 × 2 m floor and a 2 × 2 m back wall (albedo 0.7) under
a spot lamp with a hard cone edge (50°, blend 0) at (0, −0.2, 1.5) pointing down: a sharp
boundary of direct light on the floor, smooth light elsewhere. Lamp shadows are off here (the
scene has nothing to shadow), so only the sampling differs.

Error measure: the illumination map as the preview shows it (each point takes its nearest
surfel's value), at the 48,000 surfels of a reference run at 6000 surfels/m², relative RMS
against the reference's own values. Measured (seed 0, bpy 5.0.1): at 600 surfels uniform
0.238, adaptive 0.227; at 1200 uniform 0.229, adaptive 0.183; at 2400 uniform 0.175, adaptive
0.148. Surfel density after refinement: 729/m² along the cone's edge, 198/m² in its centre. Asserted: adaptive ≤
0.9 × uniform at 1200 surfels, with exactly the same surfel count.
"""

import math

import bpy
import numpy as np
import pytest

from illumap import lights
from illumap_bpy_testing import diffuse_material, link, make_plane, requires_core

from addon import pipeline
from illumap.gather import rays as gather_rays
from illumap.neighbours import knn
from illumap.stages import light as light_stage

pytestmark = requires_core
SPOT = (0.0, -0.2, 1.5)
EDGE_RADIUS = 1.5 * math.tan(math.radians(25))


def spot_scene():
    mat = diffuse_material("W", (0.7,) * 3)
    floor = make_plane("Floor", size=2.0, material=mat)
    wall = make_plane("Wall", size=2.0, location=(0, 1, 1), material=mat)
    wall.rotation_euler = (math.radians(90), 0, 0)
    light = bpy.data.lights.new("Spot", "SPOT")
    light.energy, light.spot_size, light.spot_blend = 60.0, math.radians(50), 0.0
    light.shadow_soft_size = 0.0
    link(bpy.data.objects.new("Spot", light)).location = SPOT
    bpy.context.view_layer.update()
    return [floor, wall]


def solve(objects, **kw):
    """prepare → run (→ next_pass → run): the job and result that would be written."""
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects,
                           pipeline.Settings(**{"lamp_shadows": False, "transfer": False, **kw}))
    result = pipeline.run(job)
    second = pipeline.next_pass(job, result)
    if second is not None:
        job, result = second, pipeline.run(second)
    return job, result


def test_target_error_chooses_the_density():
    from illumap import accuracy
    objects = spot_scene()
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects,
                           pipeline.Settings(transfer=False, target_error=0.1, adaptive=False,
                                             lamp_shadows=False))
    # the model of the "mesh" kind: stratified triangle samples, as the add-on draws them
    chosen = accuracy.choose_mesh_settings(dict(n=accuracy.NO_SURFEL_LIMIT, total_area=8.0), 0.1,
                                           adaptive=False)
    info = job.stats["density"]
    assert info["kind"] == "mesh" and info["surfels"] == chosen["n"]
    assert info["discretization_scale"] == 1.0 and job.accuracy["label"] == chosen["label"]
    assert info["density"] == pytest.approx(chosen["n"] / 8.0)
    assert abs(job.count - chosen["n"]) <= 2        # rounding per object
    assert 0 < info["predicted_discretization"] <= 0.1
    # A tighter target asks for more surfels; the budget caps the count.
    tighter = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects,
                               pipeline.Settings(transfer=False, target_error=0.07,
                                                 adaptive=False, lamp_shadows=False))
    assert tighter.count > 1.2 * job.count
    capped = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects,
                              pipeline.Settings(transfer=False, target_error=0.07, budget=900,
                                                adaptive=False,
                                                lamp_shadows=False))
    assert capped.count == 900 < job.count
    assert capped.stats["density"]["predicted_discretization"] > info["predicted_discretization"]
    # The stats carry it to the result and the UI.
    result = pipeline.run(capped)
    assert result.stats["density"]["surfels"] == 900
    from addon.ui import operators
    stats = bpy.context.scene.illumap.stats
    operators.record_stats(stats, result, 1.0)
    assert stats.density == pytest.approx(900 / 8.0, rel=1e-5)
    assert stats.predicted_error == pytest.approx(capped.stats["density"]["predicted_discretization"],
                                                  rel=1e-5)


def test_target_error_outside_range_is_an_error():
    objects = spot_scene()
    with pytest.raises(pipeline.IllumapError,
                       match=r"Invalid setting target_error: expected a number in \(0, 1\)"):
        pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects,
                         pipeline.Settings(transfer=False, target_error=1.5))


def test_adaptive_pass_is_denser_at_the_light_edge_and_keeps_areas():
    objects = spot_scene()
    job, result = solve(objects, target_error=0.07, budget=2400)   # the budget caps the count
    info = result.stats["adaptive"]
    assert info["pass1"]["surfels"] == 1200 and info["pass2_surfels"] == job.count == 2400
    assert info["max_multiplier"] <= 4.0 + 1e-12 and info["regions"] > 100
    assert any(k.startswith("pass 1: ") for k in result.timings)
    assert "adaptive refinement" in result.timings
    for src in job.sources:     # every object's surfels still cover exactly its area
        assert job.areas[src.start:src.stop].sum() == pytest.approx(src.area, rel=1e-12)
    floor = next(s for s in job.sources if s.name == "Floor")
    p = job.positions[floor.start:floor.stop]
    r = np.hypot(p[:, 0] - SPOT[0], p[:, 1] - SPOT[1])
    edge = np.abs(r - EDGE_RADIUS) < 0.1
    centre = r < 0.3
    # Surfels per m²: annulus of width 0.2 m around the cone's edge, disc of radius 0.3 m.
    d_edge = edge.sum() / (2 * math.pi * EDGE_RADIUS * 0.2)
    d_centre = centre.sum() / (math.pi * 0.3 ** 2)
    print(f"\ndensity at the light's edge {d_edge:.0f}/m², in its smooth centre {d_centre:.0f}/m²")
    assert d_edge > 1.5 * d_centre


def test_adaptive_beats_uniform_with_the_same_count():
    objects = spot_scene()
    ref_job, ref = solve(objects, density=6000.0, tol=1e-6)

    def error(job, result):
        idx, _ = knn(job.positions, ref_job.positions, 1)
        diff = result.radiosity[idx[:, 0]] - ref.radiosity
        return float(np.sqrt(np.mean(diff ** 2) / np.mean(ref.radiosity ** 2)))

    uniform_job, uniform = solve(objects, target_error=0.1, budget=1200, adaptive=False)
    adaptive_job, adaptive = solve(objects, target_error=0.1, budget=1200, adaptive=True)
    e_uniform, e_adaptive = error(uniform_job, uniform), error(adaptive_job, adaptive)
    print(f"\nagainst {ref_job.count} reference surfels: uniform {e_uniform:.4f}, "
          f"adaptive {e_adaptive:.4f} ({adaptive_job.count} surfels each)")
    assert uniform_job.count == adaptive_job.count == 1200
    assert e_adaptive <= 0.9 * e_uniform


def test_compute_runs_both_passes_and_reports_them():
    objects = spot_scene()
    result = pipeline.compute(bpy.context, objects, pipeline.Settings(transfer=False,
        target_error=0.1, budget=800, lamp_shadows=False))
    assert result.count == 800 and result.stats["adaptive"]["pass1"]["surfels"] == 400
    obj = bpy.data.objects["Illumap Surfels"]
    assert len(obj.data.attributes["illumination"].data) == 800
    from addon.ui import operators
    stats = bpy.context.scene.illumap.stats
    operators.record_stats(stats, result, 1.0)
    assert stats.first_pass_surfels == 400 and "adaptive" in stats.summary


def test_adaptive_pass_is_denser_at_a_shadow_edge(monkeypatch):
    """A point lamp (radius 0.05 m) 3 m above a 4 × 4 m floor, a 1 × 1 m plate at 1 m between:
    the shadow's edge on the floor is at max(|x|, |y|) ≈ 0.75 m. After refinement the floor
    is denser along that edge than in the umbra's middle or in the open, lit floor."""
    import illumap
    from illumap_bpy_testing import disc_segment_query
    if not hasattr(illumap, "Occluders"):
        monkeypatch.setattr(light_stage, "make_segment_query",
                            lambda p, n, a, progress=None, shape="disc":
                            disc_segment_query(p, n, a, pipeline.SURFEL_COVERAGE))
    mat = diffuse_material("D", (0.5,) * 3)
    floor = make_plane("Floor", size=4.0, material=mat)
    plate = make_plane("Plate", size=1.0, location=(0, 0, 1), material=mat)
    light = bpy.data.lights.new("P", "POINT")
    light.energy, light.shadow_soft_size = 200.0, 0.05
    link(bpy.data.objects.new("P", light)).location = (0, 0, 3)
    bpy.context.view_layer.update()
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [floor, plate],
                           pipeline.Settings(transfer=False, target_error=0.1, budget=2000))
    result = pipeline.run(job)
    job = pipeline.next_pass(job, result)
    src = next(s for s in job.sources if s.name == "Floor")
    p = job.positions[src.start:src.stop]
    r = np.abs(p[:, :2]).max(axis=1)

    def density(lo, hi):   # surfels per m² in the square ring lo ≤ max(|x|,|y|) < hi
        return ((r >= lo) & (r < hi)).sum() / (4 * (hi * hi - lo * lo))

    edge, umbra, open_floor = density(0.65, 0.85), density(0.0, 0.45), density(1.3, 1.9)
    print(f"\nfloor surfels/m²: shadow edge {edge:.0f}, umbra {umbra:.0f}, lit floor {open_floor:.0f}")
    assert edge > 1.5 * umbra and edge > 1.5 * open_floor


def test_adaptive_pass_one_solves_with_the_final_counts_settings():
    """Pass 1 holds half the surfels only to find where the light varies: it solves with the
    settings chosen for the final count (chosen for its own count, the model would pick the
    costliest setting to meet the whole target there) and skips the error estimate. Pass 2
    chooses for its surfels with the job's kind ("mesh", not the "grid" that equal areas
    suggest) and reports the settings and the estimate in the stats and the UI."""
    objects = spot_scene()
    # a budget below what one uniform pass needs at 10%: two passes lower the error there
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects,
                           pipeline.Settings(transfer=False, target_error=0.1, budget=3000,
                                             lamp_shadows=False))
    chosen = job.accuracy
    assert chosen["adaptive"] and job.refine is not None
    assert chosen["kind"] == "mesh" and job.count < chosen["n"]
    first = pipeline.run(job)
    info = first.stats["accuracy"]
    assert info["settings"] is chosen and "estimate" not in info
    second = pipeline.next_pass(job, first)
    assert second.accuracy is chosen and second.refine is None
    final = pipeline.run(second)
    info = final.stats["accuracy"]
    assert info["settings"]["kind"] == "mesh"
    assert info["settings"]["discretization_scale"] == chosen["discretization_scale"]
    assert info["estimate"]["total"] > 0
    from addon.ui import operators
    stats = bpy.context.scene.illumap.stats
    operators.record_stats(stats, final, 1.0)
    assert stats.chosen_settings.startswith(info["settings"]["label"])
    assert stats.chosen_settings.endswith(
        f"or solver error ≤ {info['settings']['error_tol']:.1%}")
    assert stats.estimated_error == pytest.approx(info["estimate"]["total"], rel=1e-5)
    assert stats.estimated_error_at_objects == 0.0          # without Transfer: no receivers


def test_the_estimate_at_the_objects_is_what_the_panel_shows_first():
    """With Transfer, the light on the objects has its own estimate (the surfels' error by
    the share of the light gathered from them, with the gather's noise), recorded for the
    panel beside the surfels'."""
    objects = spot_scene()
    result = pipeline.compute(bpy.context, objects, pipeline.Settings(target_error=0.1))
    from addon.ui import operators
    stats = bpy.context.scene.illumap.stats
    operators.record_stats(stats, result, 1.0)
    surfels = result.stats["accuracy"]["estimate"]["total"]
    at_objects = result.stats["receivers"]["estimate"]
    share = result.stats["receivers"]["surfel_share"]
    assert share == pytest.approx(result.stats["receivers"]["indirect_share"], rel=1e-9)  # no sky
    noise = result.stats["receivers"]["gather_noise"]
    assert 0 < at_objects == pytest.approx(np.hypot(noise, share * surfels), rel=1e-9)
    assert stats.estimated_error == pytest.approx(surfels, rel=1e-5)
    assert stats.estimated_error_at_objects == pytest.approx(at_objects, rel=1e-5)


def test_one_uniform_pass_where_the_models_predict_it_faster():
    """With the adaptive passes the error ratio was measured with, the add-on runs them only
    where the models predict two passes faster than one uniform pass (or the budget caps the
    count); otherwise one pass of the uniform choice, and the stats say why."""
    from illumap import accuracy
    summary = dict(n=accuracy.NO_SURFEL_LIMIT, total_area=8.0)
    target = next((t for t in (0.2, 0.18, 0.15)
                   if not accuracy.choose_mesh_settings(summary, t)["adaptive"]), None)
    assert target is not None, "two passes are predicted faster at every target from 20% to 15%"
    objects = spot_scene()
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects,
                           pipeline.Settings(transfer=False, target_error=target, lamp_shadows=False))
    assert job.refine is None and not job.accuracy["adaptive"]
    assert abs(job.count - job.accuracy["n"]) <= 2
    assert any(n.startswith("adaptive: one uniform pass")
               for n in job.stats["density"]["notes"])
    result = pipeline.run(job)
    assert pipeline.next_pass(job, result) is None and "adaptive" not in result.stats
    # settings whose passes differ from the measured ones keep the user's two passes
    custom = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects,
                              pipeline.Settings(transfer=False, target_error=target, lamp_shadows=False,
                                                adaptive_first_pass=0.4))
    assert custom.refine is not None


def test_the_target_sets_the_rays_per_receiver():
    """With a target error the gather's rays follow from it (its noise model held to half the
    target), the shadow samples ∝ 1/target²: fewer for a looser target, never below the
    least counts, powers of two, and what the statistics report is what was cast."""
    targets = (0.3, 0.1, 0.05, 0.03, 0.02, 0.01, 0.005, 0.003)
    rays = [gather_rays.receiver_rays(pipeline.Settings(target_error=t)) for t in targets]
    gathers, shadows = [g for g, _ in rays], [s for _, s in rays]
    for counts, low, high in ((gathers, gather_rays.MIN_TARGET_RAYS, gather_rays.MAX_TARGET_RAYS),
                              (shadows, gather_rays.MIN_TARGET_SHADOW_SAMPLES,
                               gather_rays.MAX_TARGET_SHADOW_SAMPLES)):
        assert counts == sorted(counts) and min(counts) == low and max(counts) == high
        assert all(c & (c - 1) == 0 for c in counts)
    for t, g in zip(targets, gathers):
        def noise(rays):
            return gather_rays.NOISE_AT_512_RAYS * (512 / rays) ** gather_rays.NOISE_EXPONENT
        share = gather_rays.GATHER_NOISE_SHARE * t
        assert g == gather_rays.MAX_TARGET_RAYS or noise(g) <= share * (1 + 1e-9)
        assert g == gather_rays.MIN_TARGET_RAYS or noise(g // 2) > share    # the fewest
    assert gather_rays.receiver_rays(pipeline.Settings()) == (512, 128)   # no target: the settings'
    objects = spot_scene()
    for target in (0.1, 0.02):
        settings = pipeline.Settings(target_error=target)
        result = pipeline.compute(bpy.context, objects, settings)
        got = result.stats["receivers"]
        planned = gather_rays.receiver_rays(settings)
        first = got.get("first_gather")      # this scene's gather is noisy: cast again
        assert first is not None and first["rays"] == planned[0]
        assert (got["gather_rays"], got["shadow_samples"]) == (
            gather_rays.more_rays(settings, first["gather_noise"], planned[0]), planned[1])


def test_the_target_sets_the_shadow_rays_per_surfel(monkeypatch):
    """The surfels' shadow rays per sized lamp (and the sky's) are at least what a receiver
    casts for the surfels' own target (five times the target when the light is evaluated at
    the meshes), at most the sky's cap; the settings' count when it is larger, or without a
    target; and the direct light at the surfels is cast with them."""
    count = pipeline.surfel_shadow_samples
    assert count(pipeline.Settings()) == pipeline.Settings().shadow_samples == 16
    assert count(pipeline.Settings(shadow_samples=40)) == 40
    assert [count(pipeline.Settings(target_error=t)) for t in (0.1, 0.03, 0.02)] == [16] * 3
    one = pipeline.Settings(target_error=0.01)
    assert count(one) == gather_rays.target_shadow_samples(pipeline.surfel_target(one)) == 32
    assert count(pipeline.Settings(target_error=0.01, shadow_samples=128)) == 128
    # the surfels are the result without Transfer: the target's own count, capped
    assert count(pipeline.Settings(target_error=0.01, transfer=False)) == lights.WORLD_SAMPLES
    cast = []
    shadows = light_stage._shadows
    monkeypatch.setattr(light_stage, "_shadows",
                        lambda scene, nrm, samples, progress, warnings: cast.append(samples)
                        or shadows(scene, nrm, samples, progress, warnings))
    objects = spot_scene()
    for target in (0.03, 0.01):
        job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects,
                               pipeline.Settings(target_error=target))
        pipeline.light(job)
    assert cast == [16, 32]


def test_the_target_never_skips_visibility(monkeypatch):
    """The error model may find that skipping visibility would stay within the surfels' share
    of the target; that does not prove the scene needs none, so the add-on solves with exact
    visibility and never asks (even where the probe would report an unoccluded scene)."""
    from illumap.accuracy import choice
    asked = []

    def unoccluded(*args, **kwargs):
        asked.append(True)
        return dict(error_none=0.0, surfels=200, seconds=0.0)
    monkeypatch.setattr(choice, "occlusion_probe", unoccluded)
    monkeypatch.setattr(choice, "PROBE_WORTH", 0.0)
    objects = spot_scene()
    box = bpy.data.objects.new("Box", bpy.data.meshes.new("Box"))
    link(box)
    import bmesh
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=0.4)
    bm.to_mesh(box.data)
    bm.free()
    box.location = (0.3, 0.0, 0.2)
    box.data.materials.append(diffuse_material("B", (0.5,) * 3))
    bpy.context.view_layer.update()
    for adaptive in (False, True):
        result = pipeline.compute(bpy.context, objects + [box],
                                  pipeline.Settings(target_error=0.1, adaptive=adaptive))
        assert result.stats["accuracy"]["settings"]["visibility"] == "exact"
        assert result.stats["accuracy"]["settings"]["probe"] is None
    assert not asked


def test_the_estimate_scores_the_lamp_lit_surfels_too(monkeypatch):
    """The solve takes the spot's light at the surfels as emission; the estimate still scores
    every surfel that is not a light, lit or dark, so its parts are relative to the light a
    receiver sees, not to the unlit surfels' alone."""
    from illumap.accuracy import automatic
    seen = {}
    real = automatic.estimate_error

    def spy(sol, surfels, **kw):
        seen.update(kw, emission=np.asarray(surfels.emission))
        seen["unscored"] = real(sol, surfels, **{**kw, "scored": None})
        return real(sol, surfels, **kw)
    monkeypatch.setattr(automatic, "estimate_error", spy)
    objects = spot_scene()
    result = pipeline.compute(bpy.context, objects, pipeline.Settings(target_error=0.1))
    scored = seen["scored"]
    assert scored.all() and len(scored) == result.count    # no emissive mesh in this scene
    lit = seen["emission"].max(axis=1) > 0                   # the spot's light, as emission
    assert lit.any() and not lit.all()
    got = result.stats["accuracy"]["estimate"]
    # Relative to the lit and dark surfels, not the dark ones alone: smaller.
    assert 0 < got["solver"] < seen["unscored"]["solver"]


def test_a_target_the_count_cannot_reach_says_so():
    """A budget that caps the surfels below what the error model needs for the target is said
    in the run's warnings, with the budget and the predicted error (one pass or two), and the
    gather's own noise above a target is too; a target within reach warns of neither."""
    objects = spot_scene()
    result = pipeline.compute(bpy.context, objects, pipeline.Settings(target_error=0.1))
    assert result.stats["density"]["reached"]
    assert not any("may not be met" in w for w in result.warnings), result.warnings
    # This scene's corners see the spot's light only through the gather, and little of it.
    noisy = result.stats["receivers"]["gather_noise"] > 0.1
    assert noisy == any("not met at the objects" in w for w in result.warnings)
    for adaptive in (False, True):
        result = pipeline.compute(bpy.context, objects, pipeline.Settings(
            target_error=0.01, budget=300, adaptive=adaptive))
        density = result.stats["density"]
        assert not density["reached"] and density["cap"] == 300
        capped = [w for w in result.warnings if "may not be met" in w]
        assert len(capped) == 1, result.warnings
        assert "Target error 1.00%" in capped[0] and "surfel budget of 300 caps" in capped[0]
        assert f"{density['predicted']:.1%}" in capped[0] and "5.0%" in capped[0]
    result = pipeline.compute(bpy.context, objects, pipeline.Settings(
        target_error=0.0005, budget=300))
    got = result.stats["receivers"]
    assert got["gather_rays"] == gather_rays.MAX_TARGET_RAYS and got["gather_noise"] > 0.0005
    noisy = [w for w in result.warnings if "not met at the objects" in w]
    assert len(noisy) == 1 and f"{got['gather_noise']:.2%}" in noisy[0], result.warnings
    assert "the most a target casts" in noisy[0]


def test_a_gather_noisier_than_its_share_of_the_target_is_cast_again_with_more_rays():
    """This scene's corners see the spot's light only through the gather, in a small bright
    patch: 64 rays leave far more noise than the half of a 10% target the model expects, so
    the receivers gather again, once, with the rays the noise found asks for; what both
    gathers cast is counted, and the first is reported."""
    objects = spot_scene()
    settings = pipeline.Settings(target_error=0.1)
    result = pipeline.compute(bpy.context, objects, settings)
    got = result.stats["receivers"]
    first = got["first_gather"]
    assert first["rays"] == gather_rays.receiver_rays(settings)[0] == gather_rays.MIN_TARGET_RAYS
    assert first["gather_noise"] > gather_rays.GATHER_NOISE_SHARE * 0.1
    assert got["gather_rays"] == gather_rays.more_rays(settings, first["gather_noise"], first["rays"])
    assert got["gather_noise"] < first["gather_noise"]
    corners = got["corners"]
    assert got["rays"] >= corners * (first["rays"] + got["gather_rays"])
    import io
    from addon import batch
    printed = io.StringIO()
    batch._report(1, result, printed)
    assert f"first gather's noise at 64 rays, {first['gather_noise']:.2%}" in printed.getvalue()
    # Without a target the settings' rays are cast once, whatever the noise.
    plain = pipeline.compute(bpy.context, objects, pipeline.Settings(gather_rays=64))
    assert "first_gather" not in plain.stats["receivers"]
    assert plain.stats["receivers"]["gather_rays"] == 64


def test_more_rays_follow_the_noise_found():
    s = pipeline.Settings(target_error=0.02)
    share = gather_rays.GATHER_NOISE_SHARE * 0.02
    assert gather_rays.more_rays(s, 0.99 * share, 256) is None
    assert gather_rays.more_rays(s, float("nan"), 256) is None
    assert gather_rays.more_rays(s, 10.0, gather_rays.MAX_TARGET_RAYS) is None
    assert gather_rays.more_rays(pipeline.Settings(), 10.0, 64) is None
    counts = [gather_rays.more_rays(s, noise, 128) for noise in (1.01 * share, 2 * share, 4 * share, 100.0)]
    assert counts == sorted(counts) and counts[0] == 256 and counts[-1] == gather_rays.MAX_TARGET_RAYS
    assert all(c & (c - 1) == 0 for c in counts)
    # enough by the model's slope: the noise found, scaled to the count, within the share
    for noise, c in zip((1.01 * share, 2 * share, 4 * share), counts):
        assert c == gather_rays.MAX_TARGET_RAYS or \
            noise * (128 / c) ** gather_rays.NOISE_EXPONENT <= share * (1 + 1e-9)


def test_the_gather_noise_warning_names_what_was_cast():
    """The noise verdict fires only above the target, says whether the rays were the most a
    target casts, and never fires without a target."""
    s = pipeline.Settings(target_error=0.03)
    assert gather_rays.gather_noise_warning(s, 0.029, 256) is None
    assert gather_rays.gather_noise_warning(s, float("nan"), 256) is None
    few = gather_rays.gather_noise_warning(s, 0.04, 256)
    assert "4.00%" in few and "256 rays" in few and "the most" not in few
    assert gather_rays.gather_noise_warning(pipeline.Settings(), 0.5, 512) is None
