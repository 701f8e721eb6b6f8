"""The standalone C++ tests of the visibility components (core/tests_native/run.sh): compiled
against the same headers as the module, so an interface change that breaks them fails here."""

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_visibility_component_tests_pass():
    result = subprocess.run(["bash", str(ROOT / "core" / "tests_native" / "run.sh")], cwd=ROOT,
                            text=True, capture_output=True, timeout=900)
    output = result.stdout + result.stderr
    assert result.returncode == 0, output[-4000:]
    assert "OK (0 failures)" in output, output[-4000:]
