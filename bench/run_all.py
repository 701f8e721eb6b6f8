#!/usr/bin/env python3
"""Run every benchmark the README and docs quote, then redraw every chart, with one command.

    .venv/bin/python bench/run_all.py --quick     # the default: quick sizes, quick Cycles sweep
    .venv/bin/python bench/run_all.py --full      # larger references, sizes and sample counts
    .venv/bin/python bench/run_all.py --charts-only
    .venv/bin/python bench/run_all.py --dry-run   # print the steps and their commands

Runs, in order and each in its own process (with a time limit): bench/calibration/accuracy_speed.py (the
sweep), bench/calibration/leaf_size.py (leaves of 16 and 64 against 32, paired),
bench/calibration/sampling_spread.py (one setting on six further samplings), with --full
bench/calibration/grid_steps.py --all-settings (the Cornell grid at every cell count up to 4128 surfels,
against the full reference), bench/calibration/calibrate.py --write (the automatic mode's models, fitted
on them all),
scripts/setup_env.sh (reinstalls the package with them), bench/calibration/accuracy_speed.py --auto-only
(the automatic mode), bench/reference/cycles_bake.py, bench/micro/scaling.py (results in bench/results/*.json),
bench/reference/run.py (Illumap against Cycles bakes on meshes as users build them, the
table of docs/results.md: bench/results/reference.json; --quick passed through, --reference-scenes to
its --scenes), bench/reference/preview_vs_cycles.py (docs/images/cornell_vs_cycles.png),
then bench/charts.py (docs/images/*.png and docs/benchmarks.md) and bench/reference/chart.py
(docs/images/reference_<scene>.png). A step that fails is reported and the others still run;
the exit status is non-zero if any failed. bench/micro/ and bench/experiments/ are not steps:
run them by hand (bench/README.md).
"""
import argparse
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
STEPS = ("accuracy", "leaf", "sampling", "grid", "calibrate", "install", "auto", "cycles",
         "scaling", "reference", "preview", "charts", "reference-charts")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true")
    mode.add_argument("--full", action="store_true")
    mode.add_argument("--charts-only", action="store_true")
    ap.add_argument("--skip", nargs="*", default=[], choices=STEPS)
    ap.add_argument("--timeout", type=int, default=None,
                    help="seconds per step (default 3600 quick, 7200 full)")
    ap.add_argument("--reference-scenes", nargs="+", default=None, metavar="SCENE",
                    help="bench/reference/run.py --scenes (default: every scene)")
    ap.add_argument("--dry-run", action="store_true", help="print the steps, run nothing")
    args = ap.parse_args(argv)
    flag = "--full" if args.full else "--quick"
    timeout = args.timeout or (7200 if args.full else 3600)
    results = os.path.join(HERE, "results")
    calibration = os.path.join(HERE, "calibration")
    acc = os.path.join(results, "accuracy_speed.json")
    leaf = os.path.join(results, "leaf_size.json")
    spread = os.path.join(results, "sampling_spread.json")
    # the grid steps are solved against the full sweep's reference: a quick run leaves them out
    grid = os.path.join(results, "grid_steps.json") if args.full else ""
    py = [sys.executable]
    reference = os.path.join(HERE, "reference")
    reference_options = (["--quick"] if not args.full else []) + (
        ["--scenes", *args.reference_scenes] if args.reference_scenes else [])
    steps = [] if args.charts_only else [
        ("accuracy", py + [os.path.join(calibration, "accuracy_speed.py"), flag, "--out", acc]),
        ("leaf", py + [os.path.join(calibration, "leaf_size.py"), flag, "--out", leaf]),
        ("sampling", py + [os.path.join(calibration, "sampling_spread.py"), flag, "--out", spread]),
        *([("grid", py + [os.path.join(calibration, "grid_steps.py"), "--all-settings", "--cells",
                            "9", "26", "--sweep", acc, "--out", grid])] if grid else []),
        ("calibrate", py + [os.path.join(calibration, "calibrate.py"), "--results", acc,
                            "--leaf-results", leaf, "--sampling-results", spread,
                            "--grid-steps-results", grid, "--write"]),
        ("install", [os.path.join(ROOT, "scripts", "setup_env.sh")]),
        ("auto", py + [os.path.join(calibration, "accuracy_speed.py"), flag, "--auto-only", "--out",
                       acc]),
        ("cycles", py + [os.path.join(reference, "cycles_bake.py"), flag, "--out",
                         os.path.join(results, "cycles_bake.json")]),
        ("scaling", py + [os.path.join(HERE, "micro", "scaling.py"), flag, "--out",
                          os.path.join(results, "scaling.json")]),
        ("reference", py + [os.path.join(reference, "run.py"), *reference_options]),
        ("preview", py + [os.path.join(reference, "preview_vs_cycles.py")]),
    ]
    steps.append(("charts", py + [os.path.join(HERE, "charts.py")]))
    steps.append(("reference-charts", py + [os.path.join(reference, "chart.py")]))
    failed = []
    for name, cmd in steps:
        if name in args.skip:
            continue
        t = time.perf_counter()
        print(f"== {name}: {' '.join(cmd)}", flush=True)
        if args.dry_run:
            continue
        try:
            rc = subprocess.call(cmd, cwd=ROOT, timeout=timeout)
        except subprocess.TimeoutExpired:
            rc = f"timed out after {timeout}s"
        print(f"== {name}: exit {rc} after {time.perf_counter() - t:.0f}s", flush=True)
        if rc != 0:
            failed.append(name)
    if failed:
        print(f"failed: {', '.join(failed)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
