"""The automatic accuracy mode (illumap.accuracy): the requested error is met on every benchmark
scene, with the chosen settings in the stats, and the a-posteriori estimate bounds the error.

Scenes are those of bench/scenes.py (the Cornell box, the Stanford bunny scan as a point cloud,
the room with occluders) at small N. The numerical error (FMM + solver) is measured against the
direct O(N²) solution on the same surfels; the discretization part (density) is checked on the
Cornell box against a direct solve at 4× the density.
"""

import os
import sys

import numpy as np
import pytest

import illumap
from illumap import accuracy, scenes

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "bench"))
import scenes as S  # noqa: E402  (bench/scenes.py)

TARGETS = (0.1, 0.03, 0.01)
KIND = {"cornell": None, "bunny": "point_cloud", "interior": None}


def _scene(name, n=1500):
    if name == "bunny" and not os.path.exists(S.BUNNY_PLY):
        pytest.skip(f"the Stanford bunny scan is not at {S.BUNNY_PLY} (set ILLUMAP_BUNNY); "
                    "this scene is NOT tested here")
    return S.build(name, n)


@pytest.fixture(scope="module")
def cases():
    cache = {}

    def get(name):
        if name not in cache:
            q = _scene(name)
            ref = illumap.solve(q, method="direct", tol=1e-11)
            cache[name] = (q, ref)
        return cache[name]
    return get


@pytest.mark.parametrize("allow_direct", [True, False], ids=["any", "fmm-only"])
@pytest.mark.parametrize("name", S.SCENES)
def test_requested_numerical_error_is_met(cases, name, allow_direct):
    q, ref = cases(name)
    for target in TARGETS:
        sol = accuracy.solve(q, target, kind=KIND[name], allow_direct=allow_direct)
        info = sol.stats["accuracy"]
        chosen = info["settings"]
        # the chosen settings are shown in the stats
        for key in ("density", "n", "method", "order", "theta", "leaf_size", "visibility",
                    "tol", "budget", "predicted"):
            assert key in chosen, key
        assert info["solve_keywords"]["tol"] == chosen["tol"]
        if not allow_direct:
            assert chosen["method"] == "fmm"
            assert sol.stats["order"] == chosen["order"]
        assert sol.converged
        err = S.relative_rms(sol.radiosity, ref.radiosity, q.emission)
        numerical_budget = chosen["budget"]["fmm"] + chosen["budget"]["solver"]
        assert err <= numerical_budget, (name, target, chosen, err)
        # the a-posteriori estimate is an upper bound, and not a useless one
        est = info["estimate"]["numerical"]
        assert err <= est <= max(30 * err, 0.3 * target), (name, target, err, est)


def test_settings_tighten_as_the_target_shrinks():
    q = S.build("cornell", 3000)
    previous = None
    for target in (0.1, 0.03, 0.01, 0.003):
        c = accuracy.choose_settings(q, target, allow_direct=False)
        if previous is not None:
            assert c["tol"] < previous["tol"]
            assert c["n"] >= previous["n"]
            assert accuracy.FMM_ERROR[c["theta"]][c["order"]] <= \
                accuracy.FMM_ERROR[previous["theta"]][previous["order"]]
            assert c["predicted"]["total"] < previous["predicted"]["total"]
        assert c["predicted"]["total"] <= target * 1.0001
        previous = c


def test_presets_and_bad_targets():
    q = S.build("cornell", 500)
    assert accuracy.choose_settings(q, "medium")["target_error"] == accuracy.PRESETS["medium"]
    for bad in (0, -0.1, 1.5, float("nan"), "ultra", None):
        with pytest.raises(illumap.InputError):
            accuracy.choose_settings(q, bad)


def test_point_cloud_density_is_capped_by_its_points():
    q = S.build("bunny", 1000) if os.path.exists(S.BUNNY_PLY) else S.build("interior", 1000)
    c = accuracy.choose_settings(q, 0.003, kind="point_cloud")
    assert c["n"] == q.n
    assert any("point cloud" in note for note in c["notes"])


@pytest.mark.parametrize("target", [0.1, 0.03])
def test_cornell_density_meets_the_target_against_a_finer_reference(target):
    """Discretization included: the Cornell box sampled at the chosen density, solved with the
    chosen settings, against a direct solve at 6000 surfels gathered at its points."""
    summary = accuracy.scene_summary(S.build("cornell", 500))
    summary["n"] = 10 ** 9
    chosen = accuracy.choose_settings(summary, target)
    q = S.build("cornell", chosen["n"])
    chosen = accuracy.choose_settings(q, target)
    sol = illumap.solve(q, **accuracy.solve_keywords(chosen))
    ref = S.build("cornell", 6000)
    ref_sol = illumap.solve(ref, method="direct", tol=1e-9)
    err = S.relative_rms(sol.radiosity, S.reference_at(ref, ref_sol.radiosity, q), q.emission)
    assert err <= target, (chosen, err)


@pytest.mark.parametrize("name,low,high", [("interior", 0.5, 3.0), ("bunny", 0.5, 3.0),
                                           ("cornell", 1.0, 25.0)])
def test_discretization_estimate_tracks_the_error(name, low, high):
    """The coarse-density estimate (a spatially even half of the surfels) against the error
    measured with a 3× denser reference: within 0.5×–3× on randomly sampled scenes and scans;
    on regular grids halving breaks the midpoint rule, so there it is only an upper bound
    (measured 9–15× too high on the Cornell box; docs/stability.md)."""
    q = _scene(name, 2000)
    sol = illumap.solve(q, method="direct", tol=1e-9)
    est = accuracy.estimate_error(sol, q, coarse=True)
    ref = S.build(name, 6000, seed=99)
    ref_sol = illumap.solve(ref, method="direct", tol=1e-9)
    err = S.relative_rms(sol.radiosity, S.reference_at(ref, ref_sol.radiosity, q), q.emission)
    assert est["discretization"] is not None
    assert low * err <= est["discretization"] <= high * err, (err, est)


def test_solve_with_target_error_chooses_and_reports_settings():
    q = scenes.closed_box(6, albedo=0.7, emission=0.0).replace(
        emission=np.where(np.arange(216)[:, None] < 36, 1.0, 0.0) * np.ones((216, 3)))
    sol = illumap.solve(q, target_error=0.03)
    info = sol.stats["accuracy"]
    assert info["settings"]["target_error"] == 0.03
    assert info["solve_keywords"]["tol"] == info["settings"]["tol"]
    assert sol.converged and "estimate" in info
    # an explicit keyword overrides the chosen one
    jac = illumap.solve(q, target_error=0.03, solver="jacobi")
    assert jac.stats["solver"] == "jacobi" and jac.stats["accuracy"]["solve_keywords"]["solver"] == "jacobi"
    ref = illumap.solve(q, method="direct", tol=1e-10)
    assert np.sqrt(np.mean((sol.radiosity - ref.radiosity) ** 2)) / np.sqrt(np.mean(ref.radiosity ** 2)) < 0.03
