"""The settings' one declaration (illumap.settings): what the add-on, the batch command and the
check are generated from."""

import dataclasses
import math
import os
import subprocess
import sys

import pytest

from illumap import settings
from illumap.limits import LIMITS
from illumap.settings import Settings, SettingsError, check, from_preset, spec, specs


def test_every_setting_is_declared_with_what_the_front_ends_need():
    names = [f.name for f in dataclasses.fields(Settings)]
    assert [s.name for s in specs()] == names
    for s in specs():
        assert s.label and s.description and s.group in settings.GROUPS, s.name
        if s.kind in (int, float) and not s.choices:
            assert s.limit is not None, f"{s.name} has no range"
        if s.choices:
            assert s.canonical(s.default) == s.default, s.name
            assert any(c.offered for c in s.choices), s.name
        if s.ui and not s.optional and not s.choices:
            assert isinstance(s.property_default, s.kind), s.name


def test_the_defaults_pass_the_check_and_each_preset_too():
    check(Settings())
    for name in settings.QUALITY_PRESETS:
        check(from_preset(name))


@pytest.mark.parametrize("name, value, words", [
    ("order", 11, "order: expected an integer"),
    ("tol", math.nan, "tol:"),
    ("gather_rays", 2 ** 31, "gather_rays: expected an integer >= 1"),
    ("solver", "newton", "solver: expected one of auto, cg, gmres, jacobi, got 'newton'"),
    ("transfer_domain", "FACE", "transfer_domain: expected one of point, corner"),
    ("target_error", 1.0, "target_error: expected a number in (0, 1), got 1.0"),
    ("budget", True, "budget"),
])
def test_the_check_refuses_what_a_run_cannot_take_and_names_it(name, value, words):
    with pytest.raises(SettingsError, match="Invalid setting") as caught:
        check(dataclasses.replace(Settings(), **{name: value}))
    assert words in str(caught.value)


def test_choices_match_in_any_case_and_come_back_as_a_run_spells_them():
    assert spec("solver").canonical("CG") == "cg"
    assert spec("transfer_domain").canonical("point") == "POINT"
    check(Settings(solver="GMRES", transfer_domain="point"))
    with pytest.raises(ValueError):
        spec("visibility").canonical("rays")


def test_presets_and_overrides():
    s = from_preset("draft", gather_rays=7, tol=None)
    assert (s.budget, s.gather_rays, s.tol) == (2_500, 7, 1e-3)
    assert from_preset("HIGH").budget == 30_000
    dense = from_preset("medium", density=50.0)
    assert dense.density == 50.0 and dense.budget is None     # a density replaces the count
    with pytest.raises(SettingsError, match="Unknown quality preset 'ultra'"):
        from_preset("ultra")
    with pytest.raises(SettingsError, match="Unknown setting gather"):
        from_preset("draft", gather=3)


def test_options_follow_the_declaration():
    assert spec("gather_rays").option == "--gather-rays"
    assert spec("lamps").option == "--no-lamps"
    assert spec("world_ambient").option == "--world"
    assert spec("preview_splats").option is None
    options = [s.option for s in specs() if s.option]
    assert len(options) == len(set(options))


def test_the_page_lists_every_setting_and_limit():
    page = settings.page()
    for s in specs():
        assert f"| `{s.name}` |" in page
    for lim in LIMITS:
        assert f"| `{lim.name}` |" in page


def test_the_settings_import_without_the_native_module():
    """The reduced UI declares its fields from here where the native module cannot load."""
    code = ("import sys; sys.modules['illumap._core'] = None\n"
            "import illumap, illumap.settings\n"
            "assert illumap.settings.check(illumap.settings.Settings()) is None\n"
            "print(illumap.native_available())\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=dict(os.environ), timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"
