"""The add-on's quality presets: preset name → pipeline Settings values. Pure data (no bpy, no
native core), shared by the pipeline, the scene properties and the batch script."""

#: Surfels over all meshes when neither a density nor a budget is given: a count, not a
#: density, so a scene modelled in centimetres gets as many as one modelled in metres.
DEFAULT_BUDGET = 10_000

#: Preset name → Settings values (surfel budget, FMM order, opening angle, visibility,
#: tolerance, final-gather and shadow rays per receiver). Every preset casts shadows: speed
#: never comes from leaving out what the scene needs.
QUALITY_PRESETS: dict[str, dict] = {
    "DRAFT": dict(budget=2_500, order=3, theta=0.6, visibility="exact", tol=1e-3,
                  gather_rays=128, receiver_shadow_samples=32),
    "MEDIUM": dict(budget=DEFAULT_BUDGET, order=4, theta=0.5, visibility="exact", tol=1e-4,
                   gather_rays=512, receiver_shadow_samples=128),
    # The light at the meshes is limited by the gather and the surfel count, not by the
    # expansions: order 4 at 30k surfels reached 0.94% on the Cornell box in 4.5 s where
    # order 6, theta 0.4 at 40k took 11 s for 0.93% (bench/reference, 8192-sample reference).
    "HIGH": dict(budget=30_000, order=4, theta=0.5, visibility="exact", tol=1e-4,
                 gather_rays=2048, receiver_shadow_samples=512),
}
