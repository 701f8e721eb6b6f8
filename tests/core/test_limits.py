"""One table of limits (``illumap.limits``): the Python API refuses just outside each bound
with a message that names the keyword and its range, and accepts at the bound; the native
core's own limits are the table's; docs/limits.md is the table's text."""

import math
import os
import re

import numpy as np
import pytest

import illumap
from illumap import _core, limits, sampling
from illumap.limits import limit
from illumap.operator import MAX_ORDER, validate_keywords

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _surfels(n=8, **replace):
    """A few surfels with no emission: ``solve`` checks its keywords and returns at once."""
    rng = np.random.default_rng(3)
    a = dict(positions=rng.random((n, 3)), normals=np.tile([0.0, 0.0, 1.0], (n, 1)),
             areas=np.full(n, 0.1), albedo=np.full((n, 3), 0.5), emission=np.zeros((n, 3)))
    a.update(replace)
    return illumap.Surfels(a["positions"], a["normals"], a["areas"], a["albedo"], a["emission"])


def _with(name, index, value):
    """Surfels whose array ``name`` holds ``value`` at ``index``."""
    base = _surfels()
    array = np.array(getattr(base, name), dtype=np.float64)
    array[index] = value
    return _surfels(**{name: array})


def outside(lim):
    """Values just outside each finite bound of ``lim``."""
    out = []
    for bound, is_open, away in ((lim.low, lim.low_open, -math.inf),
                                 (lim.high, lim.high_open, math.inf)):
        if bound is None:
            continue
        if lim.kind is int:
            out.append(bound - 1 if away < 0 else bound + 1)
        else:
            out.append(bound if is_open else math.nextafter(bound, away))
    if lim.kind is float:
        out += [math.nan, math.inf]
    return out


def at_bounds(lim):
    """Each finite bound of ``lim``, or the nearest value inside an open one."""
    out = []
    for bound, is_open, inward in ((lim.low, lim.low_open, math.inf),
                                   (lim.high, lim.high_open, -math.inf)):
        if bound is None:
            continue
        out.append(math.nextafter(bound, inward) if is_open else bound)
    return out


def _operator(name):
    return lambda value: validate_keywords(**{name: value})


def _solve(name):
    return lambda value: illumap.solve(_surfels(), method="direct", solver="cg",
                                       **{name: value})


#: The Python API's entry point for each limit it enforces: value -> call that checks it.
API = {name: _operator(name) for name in
       ("order", "theta", "leaf_size", "threads", "visibility_samples", "coverage",
        "endpoint_offset", "seed_delta", "seed_k", "seed_t1", "seed_t2", "seed_t3",
        "seed_leaf_points")}
API.update({name: _solve(name) for name in ("tol", "max_iterations", "error_tol", "restart")})
API.update({
    "target_error": lambda value: illumap.accuracy.inputs.check_target(value),
    "coordinate": lambda value: _with("positions", (0, 0), value),
    "area": lambda value: _with("areas", 0, value),
    "albedo": lambda value: _with("albedo", (0, 1), value),
    "density": lambda value: sampling.allocate(np.ones(2), density=value),
})


def test_every_api_limit_has_an_entry_point():
    assert sorted(API) == sorted(lim.name for lim in limits.LIMITS
                                 if "Python API" in lim.enforced)


@pytest.mark.parametrize("name", sorted(API))
def test_the_api_refuses_just_outside_each_bound(name):
    lim = limit(name)
    for value in outside(lim):
        with pytest.raises(illumap.InputError) as info:
            API[name](value)
        message = str(info.value)
        assert lim.name in message or name.replace("coordinate", "positions").replace(
            "area", "areas") in message, message
        assert "Traceback" not in message and "incompatible function" not in message


@pytest.mark.parametrize("name", sorted(API))
def test_the_api_accepts_at_each_bound(name):
    for value in at_bounds(limit(name)):
        API[name](value)


def test_messages_name_the_keyword_and_its_range():
    with pytest.raises(illumap.InputError, match=r"^order: expected an integer >= 0 and <= 10, "
                                                 r"got 11$"):
        validate_keywords(order=11)
    with pytest.raises(illumap.InputError, match=r"^theta: expected a number in \(0, 1\), "
                                                 r"got 1\.0$"):
        validate_keywords(theta=1.0)
    with pytest.raises(illumap.InputError, match=r"^tol: expected a number in \(0, 1\), got 0$"):
        illumap.solve(_surfels(), tol=0)
    with pytest.raises(illumap.InputError, match=r"leaf_size: expected an integer >= 1 and <= "
                                                 r"2147483647, got 2147483648"):
        validate_keywords(leaf_size=2 ** 31)


def test_integers_must_be_integers_and_numbers_finite():
    assert not limit("order").contains(4.5) and not limit("order").contains(True)
    assert not limit("tol").contains("abc") and not limit("tol").contains(math.nan)
    assert limit("order").contains(np.int64(3)) and limit("tol").contains(np.float32(0.5))


# --- the native core ----------------------------------------------------------------------

def test_the_native_limits_are_the_table():
    assert dict(_core.LIMITS) == limits.native_limits()
    assert MAX_ORDER == limit("order").high == _core.LIMITS["order"][1]


def test_a_native_module_with_other_limits_is_refused():
    other = dict(_core.LIMITS, order=(0, 12))
    with pytest.raises(ImportError, match="rebuild the native core"):
        limits.check_native(other)


@pytest.mark.parametrize("name", ["order", "theta", "visibility_samples", "leaf_size",
                                  "seed_k", "seed_leaf_points", "threads"])
def test_the_native_core_refuses_what_the_table_refuses(name):
    """The native module's own checks stop exactly where the table does (so the Python
    checks hide nothing it would accept)."""
    s = _surfels()
    lim = limit(name)
    keywords = dict(visibility="seed") if name.startswith("seed") else {}
    for value in outside(lim):
        if lim.kind is int and not -2 ** 31 <= value < 2 ** 31:
            continue   # beyond a C int: nanobind's type check, which the Python API precedes
        if isinstance(value, float) and not math.isfinite(value):
            continue
        with pytest.raises(ValueError, match=name):
            _core.Operator(s.positions, s.normals, s.areas, **keywords, **{name: value})
    for value in at_bounds(lim):
        if name in ("threads", "leaf_size", "seed_k", "seed_leaf_points") and value > 64:
            continue   # a valid but absurd count: checked above by the table, not built here
        op = _core.Operator(s.positions, s.normals, s.areas, **keywords, **{name: value})
        assert np.isfinite(op.apply(np.ones((s.n, 3)))).all()


def test_the_native_order_message():
    s = _surfels()
    with pytest.raises(ValueError, match=r"order must be in 0\.\.10"):
        _core.Operator(s.positions, s.normals, s.areas, order=MAX_ORDER + 1)
    with pytest.raises(ValueError, match=r"order must be in 0\.\.10"):
        _core._kernel_derivatives(np.array([1.0, 0, 0]), MAX_ORDER + 1)


# --- the UI's bounds ----------------------------------------------------------------------

@pytest.mark.parametrize("lim", limits.LIMITS, ids=lambda lim: lim.name)
def test_ui_bounds_lie_inside_the_limit(lim):
    """A field's bounds are values the limit accepts, in single precision (what Blender
    stores): a field can never hold a value the core refuses."""
    ui = lim.ui()
    for key in ("min", "max"):
        if key in ui:
            assert lim.contains(ui[key]), (key, ui[key])
            if lim.kind is float:
                assert float(np.float32(ui[key])) == ui[key]
    if lim.ui_low is None and lim.low is not None and not lim.low_open and lim.kind is int:
        assert ui["min"] == lim.low


# --- docs/limits.md -----------------------------------------------------------------------

def test_the_limits_page_is_generated_from_the_table():
    with open(os.path.join(ROOT, "docs", "limits.md"), encoding="utf-8") as f:
        page = f.read()
    from illumap import settings
    assert page == settings.page(), ("docs/limits.md is out of date: run "
                                     ".venv/bin/python scripts/limits_page.py")
    for lim in limits.LIMITS:
        assert f"| `{lim.name}` | {lim.interval()} |" in page


def test_the_stability_page_takes_its_limits_from_the_limits_page():
    with open(os.path.join(ROOT, "docs", "stability.md"), encoding="utf-8") as f:
        page = f.read()
    assert "limits.md" in page
    # An order range quoted there would be a second copy of the table's.
    assert not re.search(r"\b0\s*(…|\.\.)\s*\d+", page)


def test_numpy_scalars_are_named_as_plain_numbers():
    with pytest.raises(illumap.InputError, match=r"got 11$"):
        validate_keywords(order=np.int64(11))
