"""The native core's default worker count follows what the process may use: its CPU affinity
(a farm slot's mask) and cgroup quota, or ILLUMAP_THREADS (Blender's -t, passed on by the
add-on)."""

import os
import subprocess
import sys

import pytest

PROBE = "from illumap import _core; print(_core.hardware_threads())"


def threads_in_child(threads=None, cpus=None) -> int:
    """The core's default worker count in a fresh process with ILLUMAP_THREADS=``threads``
    (None: unset) and the CPU affinity ``cpus`` (None: this process's)."""
    code = PROBE if cpus is None else f"import os; os.sched_setaffinity(0, {set(cpus)!r}); " + PROBE
    env = {k: v for k, v in os.environ.items() if k != "ILLUMAP_THREADS"}
    if threads is not None:
        env["ILLUMAP_THREADS"] = threads
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    return int(done.stdout.strip())


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="no CPU affinity on this OS")
def test_the_affinity_mask_bounds_the_workers():
    assert threads_in_child(cpus=[0]) == 1
    assert 1 <= threads_in_child() <= len(os.sched_getaffinity(0))


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="no CPU affinity on this OS")
def test_illumap_threads_sets_the_count():
    assert threads_in_child("3") == 3
    assert threads_in_child("3", cpus=[0]) == 3
    for bad in ("0", "-2", "two", "4x", ""):    # not a positive integer: ignored
        assert threads_in_child(bad, cpus=[0]) == 1
