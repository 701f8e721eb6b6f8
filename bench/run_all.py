#!/usr/bin/env python3
"""Regenerate every benchmark result, chart and docs/benchmarks.md with one command.

    .venv/bin/python bench/run_all.py --quick     # a few minutes (default)
    .venv/bin/python bench/run_all.py --full      # larger references, sizes and sample counts
    .venv/bin/python bench/run_all.py --charts-only

Runs, in order and each in its own process: bench/accuracy_speed.py --auto,
bench/cycles_bake.py, bench/scaling.py (results in bench/results/*.json), then bench/charts.py
(docs/images/*.png and docs/benchmarks.md). A step that fails is reported and the others still
run; the exit status is non-zero if any failed.
"""
import argparse
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true")
    mode.add_argument("--full", action="store_true")
    mode.add_argument("--charts-only", action="store_true")
    ap.add_argument("--skip", nargs="*", default=[], choices=["accuracy", "cycles", "scaling"])
    args = ap.parse_args(argv)
    flag = "--full" if args.full else "--quick"
    results = os.path.join(HERE, "results")
    steps = [] if args.charts_only else [
        ("accuracy", ["accuracy_speed.py", flag, "--auto", "--out",
                      os.path.join(results, "accuracy_speed.json")]),
        ("cycles", ["cycles_bake.py", flag, "--out", os.path.join(results, "cycles_bake.json")]),
        ("scaling", ["scaling.py", flag, "--out", os.path.join(results, "scaling.json")]),
    ]
    steps.append(("charts", ["charts.py"]))
    failed = []
    for name, cmd in steps:
        if name in args.skip:
            continue
        t = time.perf_counter()
        print(f"== {name}: {' '.join(cmd)}", flush=True)
        rc = subprocess.call([sys.executable, os.path.join(HERE, cmd[0]), *cmd[1:]], cwd=ROOT)
        print(f"== {name}: exit {rc} after {time.perf_counter() - t:.0f}s", flush=True)
        if rc != 0:
            failed.append(name)
    if failed:
        print(f"failed: {', '.join(failed)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
