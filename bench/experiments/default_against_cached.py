#!/usr/bin/env python3
"""Illumap at its default settings against the cached Cycles references of bench scenes, with no
Cycles sweep (a diagnostic; ``bench/reference/run.py`` gives the published figures).

Prints each scene's relative RMS over its vertices, per object, with the run's wall and
process CPU seconds. ``--rounds N`` runs each scene N times; ``--without-corner-split`` adds,
alternating in the same process, runs where a vertex's smooth corners share one evaluation
across face planes (the drop of rays below each corner's face kept), to measure what the
per-face split costs and buys; ``--separate-face-gathers`` runs where each face plane's
corners cast rays of their own instead of taking their vertex's (``merged_corners``' casters).
``--seeds`` runs each scene at these seeds (surfels and rays placed afresh: the noise);
``--cpu-phases`` prints the receivers' phases in process CPU seconds after each run.
``--settings`` scores other labels of ``bench/reference/run.py``'s ``ILLUMAP_SETTINGS``
(``DRAFT``, ``HIGH``, ``"target 0.01"``, …) in place of the default, with the surfels they
placed.

    .venv/bin/python bench/experiments/default_against_cached.py monkey cornell
    .venv/bin/python bench/experiments/default_against_cached.py --rounds 2 --without-corner-split monkey
    .venv/bin/python bench/experiments/default_against_cached.py --settings default DRAFT HIGH \
        "target 0.1" "target 0.05" "target 0.03" "target 0.02" "target 0.01" -- monkey
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import os
import resource
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))

from reference import run  # noqa: E402


def _cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _variants(without_split: bool, separate: bool) -> list[tuple[str, object]]:
    receive = importlib.import_module("illumap.gather.receive")
    corners = importlib.import_module("illumap.gather.corners")
    split = corners.merged_corners

    def unsplit(occ, rec, *args, **kwargs):
        return split(occ, dataclasses.replace(rec, faces=None), *args, **kwargs)

    def apart(occ, rec, *args, **kwargs):
        rows, index, _ = split(occ, rec, *args, **kwargs)
        return rows, index, np.arange(len(rows))

    chosen = [("default", split)] + ([("no corner split", unsplit)] if without_split else []) \
        + ([("separate face gathers", apart)] if separate else [])
    return [(label, (receive, fn)) for label, fn in chosen]


def _print_cpu_phases() -> None:
    """Time the receivers' phases with the process's CPU clock (all threads), not the wall
    clock, and print them after each run: on a shared machine the wall clock measures the
    neighbours."""
    import types
    evaluation = importlib.import_module("illumap.gather.evaluation")
    receive = importlib.import_module("illumap.gather.receive")
    cpu_clock = types.SimpleNamespace(perf_counter=time.process_time)
    evaluation.time = receive.time = cpu_clock
    once = receive._receive_once

    def printing(*args, **kwargs):
        light = once(*args, **kwargs)
        print("  receivers, CPU s: " + " ".join(
            f"{k.replace('receivers: ', '')} {v:.2f}" for k, v in light.timings.items())
            + f" ({light.stats['points']} evaluations, {light.stats['rays']} rays)", flush=True)
        return light

    receive._receive_once = printing


def score(pipeline, name: str, seed: int = 0,
          setting: str = "default") -> tuple[dict, float, float, int]:
    """One run of scene ``name`` at ``setting`` (a label of ``run.ILLUMAP_SETTINGS``): its
    scored row, wall s, process CPU s and the surfels placed."""
    import bpy
    scene = run.scenes.build(name)
    reference = run.load_reference(scene, 1)
    objects, spans = run.scan_objects(scene)
    spec = dict(dict(run.ILLUMAP_SETTINGS)[setting], seed=seed)
    cpu, wall = _cpu_seconds(), time.perf_counter()
    result = pipeline.compute(bpy.context, objects, run.make_settings(pipeline, spec))
    cpu, wall = _cpu_seconds() - cpu, time.perf_counter() - wall
    values = {o.name: run.read_illumination(o) for o in scene.scored if o.name not in spans}
    values.update(run.read_scan(spans) if spans else {})
    row = run._scored_row(scene, setting, "illumap", values, reference["outgoing"], wall)
    return row, wall, cpu, int(getattr(result, "count", 0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="+")
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--without-corner-split", action="store_true")
    parser.add_argument("--separate-face-gathers", action="store_true")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--cpu-phases", action="store_true")
    parser.add_argument("--settings", nargs="+", default=["default"],
                        choices=[label for label, _ in run.ILLUMAP_SETTINGS])
    args = parser.parse_args()
    pipeline = run.register_addon()
    if args.cpu_phases:
        _print_cpu_phases()
    variants = _variants(args.without_corner_split, args.separate_face_gathers)
    for _ in range(args.rounds):
        for name, seed, setting in [(n, s, t) for n in args.scenes for s in args.seeds
                                    for t in args.settings]:
            for label, (module, fn) in variants:
                module.merged_corners = fn
                row, wall, cpu, surfels = score(pipeline, name, seed, setting)
                objects = row.get("objects") or {}
                parts = " ".join(f"{k} {v.get('relative_rms', float('nan')):.4f}"
                                 for k, v in objects.items()) if isinstance(objects, dict) else ""
                at = "" if setting == "default" else f" {setting}"
                print(f"{name} seed {seed}{at} [{label}]: relative RMS {row['relative_rms']:.6f}, "
                      f"{wall:.2f} s wall, {cpu:.2f} s CPU, {surfels} surfels  {parts}",
                      flush=True)


if __name__ == "__main__":
    main()
