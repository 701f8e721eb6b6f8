"""The add-on takes its limits from the one table (``illumap.limits``): every numeric field's
hard and soft range is the table's, the extreme values a field can hold pass the settings
check, the settings check and the batch command refuse just outside each bound and accept at
it, and the batch help states the ranges."""

import math
import re

import bpy
import pytest

from illumap import limits
from illumap.limits import limit

from addon import batch, checks, pipeline
from addon.ui import properties
from addon.errors import IllumapError


def _settings_rna():
    return bpy.types.Scene.bl_rna.properties["illumap"].fixed_type


#: Numeric fields and their limit (the same name except where stated).
FIELD_LIMITS = {"disc_scale": "disc_scale"}


def _numeric_fields(rna):
    return [p for p in rna.properties if p.type in ("INT", "FLOAT") and p.identifier != "rna_type"
            and not p.is_hidden and p.array_length == 0]


def _expected(prop, lim):
    ui = lim.ui()
    want = {"hard_min": ui.get("min"), "hard_max": ui.get("max"),
            "soft_min": ui.get("soft_min", ui.get("min")),
            "soft_max": ui.get("soft_max", ui.get("max"))}
    return want


def _check_field(prop, lim):
    want = _expected(prop, lim)
    for key, value in want.items():
        if value is None:   # no bound in the table: Blender's own type limit
            continue
        assert getattr(prop, key) == value, (prop.identifier, key, getattr(prop, key), value)


def test_every_numeric_setting_takes_its_range_from_the_table(registered_addon):
    fields = _numeric_fields(_settings_rna())
    assert {p.identifier for p in fields} >= {"order", "theta", "tol", "budget", "target_error"}
    for prop in fields:
        _check_field(prop, limit(FIELD_LIMITS.get(prop.identifier, prop.identifier)))


def test_the_preferences_disc_scale_takes_its_range_from_the_table(registered_addon):
    from addon.ui import preferences
    rna = preferences.IllumapPreferences.bl_rna.properties["default_disc_scale"]
    _check_field(rna, limit("disc_scale"))


def test_the_fmm_order_field_stops_at_the_native_limit(registered_addon):
    from illumap import _core
    prop = _settings_rna().properties["order"]
    assert prop.hard_max == limit("order").high == _core.LIMITS["order"][1]


@pytest.mark.parametrize("end", ["hard_min", "hard_max"])
def test_a_field_at_its_end_passes_the_settings_check(registered_addon, end):
    """Whatever a field can hold, the core accepts: each field set to its end (as Blender
    stores it, in single precision for floats) passes ``check_settings``."""
    scene = bpy.context.scene
    s = scene.illumap
    for prop in _numeric_fields(_settings_rna()):
        if prop.identifier == "disc_scale":
            continue
        saved = getattr(s, prop.identifier)
        setattr(s, prop.identifier, getattr(prop, end))
        s.use_target_error = prop.identifier == "target_error"
        s.sampling = "DENSITY" if prop.identifier == "density" else "BUDGET"
        settings = properties.make_settings(s, pipeline.Settings)
        checks.check_settings(settings)
        setattr(s, prop.identifier, saved)


#: The settings check: pipeline.Settings field -> limit name.
CHECKED = ("density", "budget", "order", "theta", "leaf_size", "tol", "max_iterations",
           "target_error", "adaptive_first_pass", "adaptive_max_ratio", "shadow_samples",
           "gather_rays", "gather_cache", "receiver_shadow_samples", "seed", "memory_limit", "lightmap_size")


def test_the_settings_check_covers_its_limits():
    assert sorted(CHECKED) == sorted(lim.name for lim in limits.LIMITS
                                     if "add-on settings check" in lim.enforced)


def _outside(lim):
    out = []
    for bound, is_open, away in ((lim.low, lim.low_open, -math.inf),
                                 (lim.high, lim.high_open, math.inf)):
        if bound is not None:
            if lim.kind is int:
                out.append(bound - 1 if away < 0 else bound + 1)
            else:
                out.append(bound if is_open else math.nextafter(bound, away))
    return out + ([math.nan] if lim.kind is float else [])


def _at(lim):
    return [math.nextafter(b, inward) if is_open else b
            for b, is_open, inward in ((lim.low, lim.low_open, math.inf),
                                       (lim.high, lim.high_open, -math.inf)) if b is not None]


@pytest.mark.parametrize("name", CHECKED)
def test_the_settings_check_refuses_just_outside_and_accepts_at_each_bound(name):
    lim = limit(name)
    for value in _outside(lim):
        settings = pipeline.settings_from_preset("draft")
        setattr(settings, name, value)
        with pytest.raises(IllumapError) as info:
            checks.check_settings(settings)
        message = str(info.value)
        assert name.replace("_", " ").lower() in message.replace("_", " ").lower(), message
        assert lim.expected() in message or lim.interval() in message, message
    for value in _at(lim):
        settings = pipeline.settings_from_preset("draft")
        setattr(settings, name, value)
        checks.check_settings(settings)


@pytest.mark.parametrize("option", sorted(batch.NUMBER_OPTIONS))
def test_the_batch_command_refuses_just_outside_and_accepts_at_each_bound(option):
    lim = limit(batch.NUMBER_OPTIONS[option])
    parser = batch.build_parser()
    # option=value: a negative float in exponent form would read as an option name.
    for value in _outside(lim):
        args = parser.parse_args([f"{option}={value!r}" if lim.kind is float else f"{option}={value}"])
        with pytest.raises(batch.UsageError,
                           match=re.escape(f"{option} must lie in {lim.interval()}")):
            batch.make_settings(args)
    for value in _at(lim):
        args = parser.parse_args([f"{option}={value!r}" if lim.kind is float else f"{option}={value}"])
        batch.make_settings(args)


def test_the_batch_help_states_the_ranges(capsys):
    """Every numeric option's help states its range as a user reads it: the limit's interval,
    "at least 1" where the bound is past anything sensible (2³¹ rays), and for the budget
    what this machine's memory allows; no 19-digit bound is printed."""
    text = " ".join(batch.build_parser().format_help().split())
    for option, name in batch.NUMBER_OPTIONS.items():
        lim = limit(name)
        if option == "--budget":
            assert "1 to about" in text and "surfels on this machine" in text
        elif isinstance(lim.high, int) and lim.high >= 2 ** 31 - 1:
            assert f"{lim.low} or more" in text, option
        elif lim.high is None or lim.high == float("inf"):
            assert f"more than {lim.low:g}" in text, option
        else:
            assert lim.interval() in text, option
    assert str(2 ** 62) not in text and str(2 ** 31 - 1) not in text and str(2 ** 63 - 1) not in text
    assert "inf" not in text.replace("information", "")
    # Defaults are stated too.
    assert "(default: medium)" in text and "(default: 16)" in text and "(default: 256)" in text


def test_the_presets_lie_inside_the_fields():
    """A preset outside a field's range would be clamped silently when chosen."""
    from illumap.settings import QUALITY_PRESETS
    for preset, values in QUALITY_PRESETS.items():
        for name, value in values.items():
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                lim = limit(name)
                ui = lim.ui()
                assert lim.contains(value), (preset, name, value)
                assert ui.get("min", value) <= value <= ui.get("max", value), (preset, name)
