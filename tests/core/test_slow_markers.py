"""Every test that compares against a Cycles bake or a path-traced render is marked ``slow``
(tests/pytest.ini): a developer can leave them out locally (``-m "not slow"``); CI runs them all
the same (scripts/run_tests.sh selects no marker)."""

import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BLENDER_TESTS = os.path.join(ROOT, "tests", "blender")
#: What a Cycles reference looks like in a test module: the shared bake helpers and the bench's
#: bake and path-traced comparison.
REFERENCE = re.compile(r"\b(cycles_outgoing|bake_reference|preview_vs_cycles)\b")
MODULE_MARK = re.compile(r"^pytestmark\s*=.*\bpytest\.mark\.slow\b", re.M)
TEST = re.compile(r"((?:^@.*\n)*)^def (test_\w+)\(", re.M)


def offenders(text: str) -> list[str]:
    """The tests of a module that use a Cycles reference without the ``slow`` mark (all of
    them when the module uses one and is not marked as a whole)."""
    if not REFERENCE.search(text) or MODULE_MARK.search(text):
        return []
    return [name for decorators, name in TEST.findall(text) if "pytest.mark.slow" not in decorators]


def test_cycles_comparisons_are_marked_slow():
    found = []
    for folder, _dirs, files in os.walk(BLENDER_TESTS):
        for name in sorted(files):
            if name.startswith("test_") and name.endswith(".py"):
                path = os.path.join(folder, name)
                bad = offenders(open(path, encoding="utf-8").read())
                found += [f"{os.path.relpath(path, ROOT)}::{test}" for test in bad]
    assert not found, f"compare against Cycles but are not marked slow: {found}"


def test_the_check_sees_an_unmarked_comparison():
    text = "from reference_helpers import cycles_outgoing\n\ndef test_x():\n    pass\n"
    assert offenders(text) == ["test_x"]
    assert offenders("import pytest\n" + text.replace("def test_x", "@pytest.mark.slow\ndef test_x")) == []
    assert offenders("pytestmark = [requires_core, pytest.mark.slow]\n" + text) == []
