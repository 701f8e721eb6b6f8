#!/usr/bin/env python3
"""Fit the error and time models of ``illumap.accuracy`` on the benchmark sweep.

Reads bench/results/accuracy_speed.json (bench/calibration/accuracy_speed.py) and, for each scene (its
kind: cornell -> "grid", interior -> "random", bunny -> "point_cloud") and each hand-picked
setting, fits

* error(N): the measured errors as a non-increasing upper envelope (interpolated log-log by
  illumap.accuracy), with a fitted slope a (error ~ N^-a) for extrapolation beyond the largest N;
  errors below the reference's half-density check are raised to it (not resolved);
* time(N): the measured wall times as a non-decreasing lower envelope (interpolated log-log),
  with the least-squares slope of its last sizes (TIME_SLOPE_SIZES) for extrapolation.

and, from bench/results/leaf_size.json (bench/calibration/leaf_size.py) where it exists, the error
curves of the settings it ran also over its other sampling (the worst of both), and each
setting's leaf variants (leaves of 16 and 64 surfels against the 32 of the sweep, on the same surfels):
an error factor (the largest paired error ratio) and time ratios against N (see
``fit_leaf_variants``),

and, from bench/results/sampling_spread.json (bench/calibration/sampling_spread.py) where it exists, each
sampled kind's sampling factor against N (``fit_sampling``),

and, from bench/results/grid_steps.json (bench/calibration/grid_steps.py) where it exists, the grid
scene's solves at every cell count between the sweep's sizes, as more points of the same
curves (the grid's error is a step curve: its model can only choose a measured size),

and how well the time models extrapolate (``time_holdout``: each setting's largest size
predicted from the smaller ones; its rms sets ``ADAPTIVE_TIME_MARGIN``), and writes them
to core/python/illumap/data/calibration.json (loaded as ``illumap.accuracy.calibration.CALIBRATION``),
with the run's date and core commit.

    .venv/bin/python bench/calibration/calibrate.py --results bench/results/accuracy_speed.json --write
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys

import numpy as np

#: bench/, where the scenes and the results are (this script is in bench/calibration).
HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenes import surfels as S  # noqa: E402
from illumap import accuracy  # noqa: E402
from illumap.accuracy import models  # noqa: E402

CALIBRATION_JSON = os.path.join(os.path.dirname(HERE), "core", "python", "illumap", "data",
                                "calibration.json")
# leaf_size: a swept setting may fix its own (the automatic mode passes it on)
MODEL_KEYS = (("method", "order", "theta", "leaf_size", "visibility")
              + accuracy.SETTING_VISIBILITY_KEYS)


def _sig(x, digits=4):
    return float(f"{x:.{digits}g}")


def fit_error(points, floor):
    """Measured errors as a non-increasing upper envelope against N (each value the largest
    error measured at that N or above), plus the log-log slope a for extrapolation beyond the
    largest N (least squares, clamped to [0.05, 1.2]; 0.3 with fewer than two points). Errors
    below the reference check are raised to it (not resolved)."""
    by_n = {}
    for p in points:
        by_n[p["n"]] = max(by_n.get(p["n"], 0.0), max(p["error"], floor))
    ns = sorted(by_n)
    env, run = [], 0.0
    for n in reversed(ns):
        run = max(run, by_n[n])
        env.append([int(n), _sig(run)])
    env.reverse()
    resolved = [(n, e) for n, e in by_n.items() if e > floor]
    if len(resolved) >= 2 and np.ptp(np.log([n for n, _ in resolved])) > 0.3:
        a = -float(np.polyfit(np.log([n for n, _ in resolved]),
                              np.log([e for _, e in resolved]), 1)[0])
        a = min(max(a, 0.05), 1.2)
    else:
        a = 0.3
    return dict(points=env, slope=_sig(a))


#: Sizes at the top of a time curve whose least-squares log-log slope extrapolates it: each
#: setting's largest swept size predicted from the smaller ones (``time_holdout``, 100
#: settings) is off by 0.42 rms in log time with the last two sizes' slope, 0.37 with three,
#: 0.35 with four, 0.33 with five. Two stay: with four the triangles' 5% target moves to
#: 34.7k surfels with leaves of 16 (both extrapolated from 15.4k), beyond what the 48k
#: reference resolves, so that choice could not be measured.
TIME_SLOPE_SIZES = 2


def fit_time(points):
    """Measured times against N (the least per N) as a non-decreasing lower envelope (each
    value the least time measured at that N or above: on a shared machine noise only ever
    adds time, so a small size timed slower than a larger one was disturbed), and for
    extrapolation the least-squares log-log slope of its last TIME_SLOPE_SIZES sizes (clamped
    to [1, 2.5])."""
    by_n = {}
    for p in points:
        by_n[p["n"]] = min(by_n.get(p["n"], math.inf), p["time"])
    ns = sorted(by_n)
    fitted = np.minimum.accumulate([by_n[n] for n in reversed(ns)])[::-1]
    pts = [[int(n), _sig(t)] for n, t in zip(ns, fitted)]
    top = slice(-min(TIME_SLOPE_SIZES, len(ns)), None)
    if len(ns) >= 2 and fitted[-1] > fitted[0]:
        beta = float(np.polyfit(np.log(ns[top]), np.log(fitted[top]), 1)[0])
    else:
        beta = 1.0
    return dict(points=pts, slope=_sig(min(max(beta, 1.0), 2.5)))


def fit_leaf_variants(rows, floor, base_leaf=32):
    """Each leaf size's variant of one setting from paired rows (bench/calibration/leaf_size.py: the same
    surfels solved at every leaf size, one after the other): ``error_factor``, the largest
    ratio error(leaf) / error(base) over sizes and samplings (errors below ``floor``, what the
    reference resolves, raised to it; rows without visibility, measured against the direct
    solution, are not limited by the reference), with the sizes it was measured at
    (``n_range``), and ``time_ratio``, the median time ratio per swept size against N."""
    if rows and rows[0].get("error_against", "reference") != "reference":
        floor = 1e-6
    out = {}
    leaves = sorted({int(k) for r in rows for k in r["leaves"]} - {base_leaf})
    for leaf in leaves:
        pairs = [(r, r["leaves"][str(leaf)], r["leaves"][str(base_leaf)]) for r in rows
                 if str(leaf) in r["leaves"] and str(base_leaf) in r["leaves"]]
        if not pairs:
            continue
        factor = max(max(v["error"], floor) / max(b["error"], floor) for _, v, b in pairs)
        by_size = {}
        for r, v, b in pairs:
            by_size.setdefault(r["size"], []).append((r["n"], v["time"] / b["time"]))
        ratios = sorted([float(np.mean([n for n, _ in g])), float(np.median([t for _, t in g]))]
                        for g in by_size.values())
        out[str(leaf)] = dict(error_factor=_sig(factor, 3),
                              n_range=[min(r["n"] for r, _, _ in pairs),
                                       max(r["n"] for r, _, _ in pairs)],
                              time_ratio=[[int(n), _sig(t, 3)] for n, t in ratios])
    return out


def other_samplings(leaf_results, scene, label, sweep_seed=0):
    """bench/calibration/leaf_size.py's solves of setting ``label`` at its base leaf size on samplings
    other than the sweep's, as sweep points (n, error, time)."""
    base = str(leaf_results.get("base_leaf", 32))
    data = leaf_results["scenes"].get(scene, {})
    return [dict(n=r["n"], error=r["leaves"][base]["error"], time=r["leaves"][base]["time"])
            for r in data.get("rows", []) if r["label"] == label and r["seed"] != sweep_seed
            and r["error_against"] == "reference" and base in r["leaves"]]


def _retimed(results) -> dict:
    """Where bench/calibration/retime.py re-timed a results file: its last run's date and core commit."""
    runs = results.get("retimed")
    if not runs:
        return {}
    last = runs[-1] if isinstance(runs, list) else runs
    return dict(retimed=last.get("date"),
                retimed_core_commit=(last.get("core") or {}).get("core_src_commit"))


def add_leaf_variants(calibration, leaf_results, floors):
    """Attach bench/calibration/leaf_size.py's variants to the calibrated settings of each scene kind."""
    base = int(leaf_results.get("base_leaf", 32))
    for scene, data in leaf_results["scenes"].items():
        table = calibration["kinds"].get(S.KIND[scene])
        if table is None or table["scene"] != scene:
            continue
        for label, entry in table["settings"].items():
            rows = [r for r in data["rows"] if r["label"] == label]
            if rows:
                entry["leaf_variants"] = fit_leaf_variants(rows, floors[scene], base)
    calibration["leaf_source"] = dict(date=leaf_results.get("date"),
                                      core_commit=leaf_results.get("core", {}).get("commit"),
                                      **_retimed(leaf_results))
    return calibration


def sampling_ratios(rows, table):
    """bench/calibration/sampling_spread.py's rows grouped by size: {size: [(n, error / model), …]}, the
    model being the setting's curve in ``table`` without a sampling factor."""
    by_size = {}
    for r in rows:
        entry = table["settings"].get(r["label"])
        if entry is None:
            continue
        model = models.predicted_error(entry, table, r["n"], None, sampling=False)
        by_size.setdefault(r["size"], []).append((r["n"], r["error"] / model))
    return by_size


def fit_sampling(rows, table, z=accuracy.SAMPLING_Z):
    """A kind's sampling factor from bench/calibration/sampling_spread.py's rows (one setting solved on
    several samplings per size): per size, exp(mean + z·sd) of log(error / model), with the
    model the freshly fitted curve of that setting (``table``) and sd pooled over the sizes
    (six samplings give a poor sd each); never below 1 nor below the largest ratio seen."""
    groups = [[(n, math.log(r)) for n, r in g] for g in sampling_ratios(rows, table).values()
              if len(g) >= 2]
    if not groups:
        return None
    sd = math.sqrt(float(np.mean([np.var([x for _, x in g], ddof=1) for g in groups])))
    points = []
    for g in sorted(groups, key=lambda g: np.mean([n for n, _ in g])):
        logs = [x for _, x in g]
        f = max(1.0, math.exp(float(np.mean(logs)) + z * sd), math.exp(max(logs)))
        points.append([int(round(float(np.mean([n for n, _ in g])))), _sig(f, 3)])
    return dict(points=points, z=z, log_sd=_sig(sd, 3), samplings=len(groups[0]),
                setting=rows[0]["label"])


def add_sampling(calibration, sampling_results):
    """Attach bench/calibration/sampling_spread.py's factors to the kinds whose scene it ran."""
    for scene, data in sampling_results["scenes"].items():
        table = calibration["kinds"].get(S.KIND[scene])
        if table is None or table["scene"] != scene:
            continue
        fit = fit_sampling(data["rows"], table)
        if fit:
            table["sampling"] = fit
    calibration["sampling_source"] = dict(
        date=sampling_results.get("date"),
        core_commit=sampling_results.get("core", {}).get("commit"))
    return calibration


def time_holdout(results, min_sizes=5):
    """How well the time models extrapolate: for every swept setting with at least
    ``min_sizes`` sizes, ``fit_time`` on all but the largest size predicts the largest
    (``illumap.accuracy``'s own extrapolation). Returns the log(predicted / measured) of each,
    which ``ADAPTIVE_TIME_MARGIN`` is set against."""
    out = []
    for data in results["scenes"].values():
        by_label = {}
        for p in data["points"]:
            if p["family"] not in ("auto", None) and p.get("time"):
                by_label.setdefault(p["label"], []).append(p)
        for pts in by_label.values():
            sizes = sorted({p["n"] for p in pts})
            if len(sizes) < min_sizes:
                continue
            model = fit_time([p for p in pts if p["n"] < sizes[-1]])
            measured = min(p["time"] for p in pts if p["n"] == sizes[-1])
            out.append(math.log(models.loglog(model, sizes[-1], error=False) / measured))
    return out


def grid_step_points(grid_results, scene, label):
    """bench/calibration/grid_steps.py's solves of setting ``label`` on ``scene`` (its reference's scene),
    as sweep points (n, error, time): the grid at cell counts between the sweep's sizes."""
    if grid_results is None or grid_results.get("reference", {}).get("scene") != scene:
        return []
    return [dict(n=r["n"], error=r["error"], time=r["time"]) for r in grid_results["rows"]
            if r["label"] == label]


def calibrate(results, leaf_results=None, sampling_results=None, grid_results=None):
    """The calibration of every scene kind from the sweep; with ``leaf_results``
    (bench/calibration/leaf_size.py), each setting's error curve also takes in its solves on the leaf
    benchmark's other samplings (the envelope is then the worst of the samplings: at equal N
    two samplings differ by a median 8–10%, up to 51%), and each setting gets its leaf
    variants (``add_leaf_variants``); with ``grid_results`` (bench/calibration/grid_steps.py), the grid
    scene's settings also take in its solves at the cell counts between the sweep's sizes,
    errors and times alike (``grid_step_points``)."""
    kinds = {}
    for scene, data in results["scenes"].items():
        kind = S.KIND[scene]
        floor = data["reference"]["check"]
        hand = [p for p in data["points"] if p["family"] not in ("auto", "solver")
                and p.get("time") is not None]
        table = dict(scene=scene, n_min=int(min(p["n"] for p in hand)),
                     reference_check=_sig(floor), discretization="direct vis=exact",
                     settings={})
        labels = []
        for p in data["points"]:
            if p["family"] in ("auto", "solver") or p.get("time") is None:
                continue
            if p["label"] not in labels:
                labels.append(p["label"])
        for label in labels:
            pts = [p for p in data["points"] if p["label"] == label and p.get("time")]
            kw = {k: pts[0]["settings"][k] for k in MODEL_KEYS if k in pts[0]["settings"]}
            kw.setdefault("visibility", "none")
            more = other_samplings(leaf_results, scene, label) if leaf_results else []
            steps = grid_step_points(grid_results, scene, label)
            table["settings"][label] = dict(keywords=kw,
                                            error=fit_error(pts + more + steps, floor),
                                            cost=fit_time(pts + steps),
                                            n_range=[min(p["n"] for p in pts + steps),
                                                     max(p["n"] for p in pts + steps)])
            if more:
                table["settings"][label]["samplings"] = 2
        kinds[kind] = table
    runs = results.get("scene_runs", {})
    for kind, table in kinds.items():   # a file merged from runs (--merge): each kind's own
        run = runs.get(table["scene"])
        if run:
            table["sweep"] = dict(date=run.get("date"),
                                  core_commit=(run.get("core") or {}).get("commit"))
    core = results.get("core", {})
    held = np.array(time_holdout(results))
    calibration = dict(source="bench/results/accuracy_speed.json", date=results.get("date"),
                       mode=results.get("mode"), core_commit=core.get("commit"),
                       **_retimed(results),
                       solve_tol=results.get("solve_tol"), kinds=kinds)
    if held.size:
        calibration["time_holdout"] = dict(settings=int(held.size), mean=_sig(held.mean(), 3),
                                           rms=_sig(np.sqrt((held ** 2).mean()), 3))
    if leaf_results:
        add_leaf_variants(calibration, leaf_results,
                          {k: v["reference"]["check"] for k, v in results["scenes"].items()})
    if sampling_results:
        add_sampling(calibration, sampling_results)
    if grid_results:
        calibration["grid_steps_source"] = dict(
            date=grid_results.get("date"), core_commit=grid_results.get("core", {}).get("commit"),
            cells=grid_results.get("cells"))
    return calibration


def write(calibration, path=CALIBRATION_JSON):
    """Write ``calibration`` as JSON, one calibrated setting per line (readable diffs)."""
    def dump(value):
        return json.dumps(value, ensure_ascii=False)
    lines = ["{"]
    for key, value in calibration.items():
        if key != "kinds":
            lines.append(f"    {dump(key)}: {dump(value)},")
    lines.append('    "kinds": {')
    for k, (kind, table) in enumerate(calibration["kinds"].items()):
        lines.append(f"        {dump(kind)}: {{")
        for key, value in table.items():
            if key != "settings":
                lines.append(f"            {dump(key)}: {dump(value)},")
        lines.append('            "settings": {')
        entries = [f"                {dump(label)}: {dump(entry)}"
                   for label, entry in table["settings"].items()]
        lines.append(",\n".join(entries))
        lines += ["            }", "        }" + ("," if k < len(calibration["kinds"]) - 1 else "")]
    lines += ["    }", "}"]
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", default=os.path.join(HERE, "results", "accuracy_speed.json"))
    ap.add_argument("--leaf-results", default=os.path.join(HERE, "results", "leaf_size.json"),
                    help="bench/calibration/leaf_size.py's pairs (leaf variants; skipped when absent)")
    ap.add_argument("--sampling-results",
                    default=os.path.join(HERE, "results", "sampling_spread.json"),
                    help="bench/calibration/sampling_spread.py's samplings (sampling factors; skipped "
                         "when absent)")
    ap.add_argument("--grid-steps-results",
                    default=os.path.join(HERE, "results", "grid_steps.json"),
                    help="bench/calibration/grid_steps.py's grid solves between the sweep's sizes (skipped "
                         "when absent)")
    ap.add_argument("--write", action="store_true", help="write the calibration to core/python/illumap/data/calibration.json")
    args = ap.parse_args(argv)
    with open(args.results) as f:
        results = json.load(f)

    def optional(path):
        if path and os.path.exists(path):
            with open(path) as f:
                return json.load(f)
        return None
    cal = calibrate(results, optional(args.leaf_results), optional(args.sampling_results),
                    optional(args.grid_steps_results))
    for kind, t in cal["kinds"].items():
        print(f"{kind} ({t['scene']}): n_min {t['n_min']}, reference check {t['reference_check']}")
        if "sampling" in t:
            print("  sampling factor " + " ".join(f"{n}:{f}" for n, f in t["sampling"]["points"])
                  + f" (log sd {t['sampling']['log_sd']})")
        for label, e in t["settings"].items():
            err = " ".join(f"{n}:{v:.3f}" for n, v in e["error"]["points"])
            tim = " ".join(f"{v:.3f}" for _, v in e["cost"]["points"])
            print(f"  {label:30s} err {err} (a={e['error']['slope']})  time {tim}")
            for size, v in e.get("leaf_variants", {}).items():
                tr = " ".join(f"{n}:{r:.2f}" for n, r in v["time_ratio"])
                print(f"    leaf {size}: error x{v['error_factor']}  time x {tr}")
    held = cal.get("time_holdout")
    if held:
        print(f"time models, largest size predicted from the smaller ones ({held['settings']} "
              f"settings): log(predicted/measured) mean {held['mean']:.3f}, "
              f"rms {held['rms']:.3f}")
    if args.write:
        write(cal)
        print(f"wrote the calibration to {CALIBRATION_JSON}")


if __name__ == "__main__":
    main()
