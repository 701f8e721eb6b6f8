"""The bench's layout (bench/README.md): the front door (bench/run_all.py, bench/charts.py), the
scene library (bench/scenes/), the evidence against Cycles (bench/reference/), the calibration
that writes what the extension ships (bench/calibration/), timings (bench/micro/) and
experiments (bench/experiments/), and nothing else. The tests and the front door's own code use
only modules the front door owns; nothing of theirs imports a micro-benchmark or an experiment,
which may change or go without a test noticing."""
import ast
import os

import pytest

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
BENCH = os.path.join(ROOT, "bench")
SIDE = ("micro", "experiments")
#: What bench/ holds: its folders and its loose scripts (the front door). scaling_scans.py
#: joins bench/micro/ once issue-58, which reworks it, is merged.
FOLDERS = {"calibration", "experiments", "micro", "reference", "results", "scenes"}
FRONT_DOOR = {"run_all.py", "charts.py", "scaling_scans.py"}


def python_files(folder, recursive=True):
    for base, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if d not in ("__pycache__",)) if recursive else []
        yield from (os.path.join(base, f) for f in sorted(files) if f.endswith(".py"))


def side_modules():
    """Module names of the scripts under bench/micro and bench/experiments."""
    return {os.path.splitext(os.path.basename(p))[0]
            for side in SIDE for p in python_files(os.path.join(BENCH, side))}


def imports_and_paths(path):
    """The modules a file imports and the string constants of its sys.path calls."""
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read(), path)
    modules, strings = set(), set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            modules.add(node.module)
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and ast.unparse(node.func.value) == "sys.path"):
            strings.update(n.value for n in ast.walk(node)
                           if isinstance(n, ast.Constant) and isinstance(n.value, str))
    return modules, strings


def users():
    """The tests and the front door's own code."""
    yield from python_files(os.path.join(ROOT, "tests"))
    yield from python_files(BENCH, recursive=False)
    yield from python_files(os.path.join(BENCH, "scenes"))
    yield from python_files(os.path.join(BENCH, "reference"))
    yield from python_files(os.path.join(BENCH, "calibration"))


def test_bench_holds_its_kinds_and_nothing_else():
    entries = [e for e in os.listdir(BENCH) if e != "__pycache__"]
    folders = {e for e in entries if os.path.isdir(os.path.join(BENCH, e))}
    scripts = {e for e in entries if e.endswith(".py")}
    assert folders == FOLDERS, f"bench/ folders: {sorted(folders ^ FOLDERS)} differ"
    assert scripts == FRONT_DOOR, f"loose scripts in bench/: {sorted(scripts - FRONT_DOOR)}"


def test_one_scene_library():
    """Scenes are built in bench/scenes/ only: no other scenes module under bench/."""
    others = [p for p in python_files(BENCH) if os.path.basename(p) in ("scenes.py",
                                                                      "preview_scenes.py")]
    assert not others, f"scene modules outside bench/scenes/: {others}"


def test_bench_has_its_micro_and_experiment_folders():
    assert side_modules(), "bench/micro and bench/experiments hold no scripts"


@pytest.mark.parametrize("path", list(users()), ids=lambda p: os.path.relpath(p, ROOT))
def test_no_test_or_front_door_step_imports_a_micro_benchmark_or_experiment(path):
    side = side_modules()
    modules, strings = imports_and_paths(path)
    for name in modules:
        parts = name.split(".")
        assert not any(s in parts for s in SIDE), f"{path} imports {name}"
        assert parts[-1] not in side, f"{path} imports {name} (a bench/micro or experiments script)"
    for s in strings:
        assert not any(part in SIDE for part in s.replace("\\", "/").split("/")), (
            f"{path} puts {s} on sys.path")
