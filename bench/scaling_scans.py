#!/usr/bin/env python3
"""How the light at a scan's own points scales with the scan's size: the Cornell box's walls
and blocks as grids of ``cell`` m, their vertices given to Illumap as one point cloud without
normals (the light kept as a mesh), at default settings, from about 100k points up.

Each size runs in a process of its own (its peak memory is that process's), which reports
the time of each phase (preparing the job: reading the points, their normals, thinning,
splats, the ray-casting scene; the solve; the receivers, with their parts), the rays the
receivers cast, the records of the gather cache and the peak resident memory. The parent
fits the slope of log time against log points (1.0: linear) and, at ``--error-cell``
(0.007 m: 990k points), scores the points against the Cycles bake of the Cornell box
(``bench/results/reference/cornell.npz``, 0.1 m grids): each reference vertex takes the
value of the nearest scan point of its own wall or block (at most half a cell away, where
the light changes little but for shadow edges).

    .venv/bin/python bench/scaling_scans.py                       # 0.02 0.01 0.007 m
    .venv/bin/python bench/scaling_scans.py --cells 0.02 0.014 0.01 0.007 0.005

Writes bench/results/scaling_scans.json (``--out``) and docs/images/scaling_scans.png.
The machine is shared: wall-clock seconds move with its load; ``cpu_s`` (the process's CPU
seconds, all threads) moves less.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

BENCH = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(BENCH)
OUT = os.path.join(REPO, "bench", "results", "scaling_scans.json")
CHART = os.path.join(REPO, "docs", "images", "scaling_scans.png")
REFERENCE = os.path.join(REPO, "bench", "results", "reference", "cornell.npz")


class PhaseMemory:
    """Peak resident memory per phase: a thread samples the process's RSS every ``every``
    seconds and charges it to the phase the run's progress last named."""

    def __init__(self, every: float = 0.1):
        import threading
        self.phase, self.peaks, self._every = "prepare", {}, every
        self.step, self.step_peaks = "prepare", {}
        self._page = os.sysconf("SC_PAGE_SIZE")
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        while not self._stop.wait(self._every):
            with open("/proc/self/statm") as f:
                rss = int(f.read().split()[1]) * self._page / 1e9
            self.peaks[self.phase] = max(self.peaks.get(self.phase, 0.0), rss)
            self.step_peaks[self.step] = max(self.step_peaks.get(self.step, 0.0), rss)

    def progress(self, fraction: float, phase: str = "") -> bool:
        """The run's progress callback: notes the phase, never cancels."""
        self.phase = phase.split(":")[0] or self.phase
        self.step = phase or self.step
        return True

    def stop(self) -> tuple[dict, dict]:
        """The peaks (GB) per phase and per step (the progress's full phase names)."""
        self._stop.set()
        self._thread.join()
        return ({k: round(v, 3) for k, v in self.peaks.items()},
                {k: round(v, 3) for k, v in self.step_peaks.items()})


def one_size(cell: float, score: bool) -> dict:
    """Run the scan at ``cell`` in this process; the row of results (see the module doc)."""
    sys.path.insert(0, REPO)
    sys.path.insert(0, BENCH)
    import bpy  # noqa: F401
    from reference import run
    from scenes import blender as scenes
    pipeline = run.register_addon()
    t0 = time.perf_counter()
    objects, spans = run.scan_objects(scenes.cornell_scan(cell))
    build_scene = time.perf_counter() - t0
    points = sum(count for _, count in spans.values())
    depsgraph = bpy.context.evaluated_depsgraph_get()
    settings = run.make_settings(pipeline, {})
    memory = PhaseMemory()
    c0, t0 = time.process_time(), time.perf_counter()
    job = pipeline.prepare(depsgraph, objects, settings)
    prepare = time.perf_counter() - t0
    memory.phase = memory.step = "job built"
    t1 = time.perf_counter()
    result = pipeline.run(job, memory.progress)
    run_s = time.perf_counter() - t1
    cpu = time.process_time() - c0
    phase_peaks, step_peaks = memory.stop()
    rec = result.stats.get("receivers", {})
    row = dict(cell=cell, points=int(points), surfels=int(result.count),
               triangles=int(0 if job.triangles is None else len(job.triangles)),
               scene_s=round(build_scene, 2), prepare_s=round(prepare, 2),
               run_s=round(run_s, 2), total_s=round(prepare + run_s, 2), cpu_s=round(cpu, 2),
               phases={k: round(float(v), 3) for k, v in result.timings.items()},
               rays=int(rec.get("rays", 0)), records=rec.get("cache_records"),
               peak_rss_gb=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6, 3),
               peak_rss_by_phase_gb=phase_peaks, peak_rss_by_step_gb=step_peaks)
    if score:
        values = next(iter(result.point_receiver_values.values()))
        row["cycles"] = score_against_cycles(values, spans)
    return row


def score_against_cycles(values: np.ndarray, spans: dict) -> dict:
    """Relative RMS of the scan's values at the Cycles reference's vertices (the nearest scan
    point of the same object each), over all of them and per object."""
    from illumap import _core
    sys.path.insert(0, BENCH)
    from reference import score
    data = np.load(REFERENCE, allow_pickle=False)
    names = [str(n) for n in data["names"]]
    split = np.cumsum(data["counts"])[:-1]
    ref = dict(zip(names, np.split(data["outgoing"].astype(np.float64), split)))
    where = dict(zip(names, np.split(data["positions"].astype(np.float64), split)))
    got = {}
    import bpy
    scan = bpy.data.objects["Scan"].data
    pos = np.empty(len(scan.vertices) * 3)
    scan.vertices.foreach_get("co", pos)
    pos = pos.reshape(-1, 3)
    far = 0.0
    for name in names:
        start, count = spans[name]
        mine = np.ascontiguousarray(pos[start:start + count])
        idx, dist = _core.knn(mine, np.ascontiguousarray(where[name]), 1)
        got[name] = values[start:start + count][np.asarray(idx)[:, 0]]
        far = max(far, float(np.asarray(dist).max()))
    return dict(relative_rms=score.relative_rms(score.stacked(got, names),
                                                score.stacked(ref, names)),
                objects={n: score.relative_rms(got[n], ref[n]) for n in names},
                reference_samples=int(data["samples"]), vertices=int(sum(data["counts"])),
                farthest_m=far)


#: The bench scans (bench/scenes/meshes.py) whose error the cache must keep within 10% of
#: the full gather's.
BENCH_SCANS = ("scan_room", "scan_object")


def bench_scans_accuracy() -> list[dict]:
    """Each bench scan at default settings and with every point gathering in full
    (``gather_cache=0``), scored against its cached Cycles reference as bench/reference
    scores it."""
    sys.path.insert(0, REPO)
    sys.path.insert(0, BENCH)
    import bpy
    from reference import run
    from scenes import blender as scenes
    pipeline = run.register_addon()
    rows = []
    for name in BENCH_SCANS:
        for label, spec in (("cache", {}), ("full gather", dict(gather_cache=0.0))):
            scene = scenes.build(name)
            ref = run.load_reference(scene, 1)
            if ref is None:
                raise SystemExit(f"no cached Cycles reference for {name}: run bench/reference first")
            objects, spans = run.scan_objects(scene)
            t0 = time.perf_counter()
            result = pipeline.compute(bpy.context, objects, run.make_settings(pipeline, spec))
            seconds = time.perf_counter() - t0
            values = {o.name: run.read_illumination(o) for o in scene.scored if o.name not in spans}
            values.update(run.read_scan(spans) if spans else {})
            row = run._scored_row(scene, label, "illumap", values, ref["outgoing"], seconds)
            rec = result.stats.get("receivers", {})
            rows.append(dict(scene=name, label=label, relative_rms=row["relative_rms"],
                             seconds=round(seconds, 2), rays=int(rec.get("rays", 0)),
                             records=rec.get("cache_records"),
                             scan_points=int(rec.get("scan_points", 0))))
    return rows


def slope(rows: list[dict], key: str) -> float | None:
    """Least-squares slope of log(row[key]) against log(points)."""
    xs = [np.log(r["points"]) for r in rows if r.get(key)]
    ys = [np.log(r[key]) for r in rows if r.get(key)]
    return float(np.polyfit(xs, ys, 1)[0]) if len(xs) >= 2 else None


def chart(rows: list[dict], out_png: str) -> None:
    """Seconds per phase and peak memory against points, log-log."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = np.array([r["points"] for r in rows], dtype=float)
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for label, get in (("total", lambda r: r["total_s"]), ("prepare", lambda r: r["prepare_s"]),
                       ("solve", lambda r: r["phases"].get("solve", 0)),
                       ("receivers", lambda r: r["phases"].get("receivers", 0)),
                       ("CPU (both cores)", lambda r: r["cpu_s"])):
        a.loglog(n, [get(r) for r in rows], "o-", label=label)
    a.loglog(n, rows[0]["total_s"] * n / n[0], "k:", label="∝ points")
    a.set_xlabel("scan points")
    a.set_ylabel("seconds")
    a.legend(fontsize=8)
    a.grid(True, which="both", alpha=0.3)
    b.loglog(n, [r["peak_rss_gb"] for r in rows], "o-", label="peak memory")
    b.loglog(n, rows[0]["peak_rss_gb"] * n / n[0], "k:", label="∝ points")
    b.set_xlabel("scan points")
    b.set_ylabel("GB")
    b.legend(fontsize=8)
    b.grid(True, which="both", alpha=0.3)
    fig.suptitle("Light at a scan's points (Cornell box scan, default settings, 2 cores)")
    fig.tight_layout()
    os.makedirs(os.path.dirname(out_png), exist_ok=True)
    fig.savefig(out_png, dpi=100)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cells", type=float, nargs="+", default=[0.02, 0.01, 0.007])
    ap.add_argument("--error-cell", type=float, default=0.007)
    ap.add_argument("--out", default=OUT)
    ap.add_argument("--chart", default=CHART)
    ap.add_argument("--no-accuracy", action="store_true",
                    help="skip the bench scans' error with and without the cache")
    ap.add_argument("--accuracy-only", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--one", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--score", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one is not None:
        print("ROW " + json.dumps(one_size(args.one, args.score)), flush=True)
        return 0
    if args.accuracy_only:
        print("ROW " + json.dumps(bench_scans_accuracy()), flush=True)
        return 0
    accuracy = None
    if not args.no_accuracy:
        done = subprocess.run([sys.executable, os.path.abspath(__file__), "--accuracy-only"],
                              capture_output=True, text=True)
        line = [x for x in done.stdout.splitlines() if x.startswith("ROW ")]
        if done.returncode != 0 or not line:
            print(f"bench scans: failed (exit {done.returncode})\n{done.stderr[-3000:]}", flush=True)
        else:
            accuracy = json.loads(line[0][4:])
            for r in accuracy:
                print(f"{r['scene']:12s} {r['label']:12s} {100 * r['relative_rms']:.2f}% from "
                      f"Cycles, {r['rays'] / 1e6:.1f}M rays, {r['seconds']:.1f} s", flush=True)
    rows = []
    for cell in args.cells:
        cmd = [sys.executable, os.path.abspath(__file__), "--one", str(cell)]
        if abs(cell - args.error_cell) < 1e-12:
            cmd.append("--score")
        done = subprocess.run(cmd, capture_output=True, text=True)
        line = [x for x in done.stdout.splitlines() if x.startswith("ROW ")]
        if done.returncode != 0 or not line:
            print(f"cell {cell}: failed (exit {done.returncode})\n{done.stderr[-3000:]}", flush=True)
            break
        row = json.loads(line[0][4:])
        rows.append(row)
        err = row.get("cycles", {}).get("relative_rms")
        print(f"{row['points']:9d} points: prepare {row['prepare_s']:7.1f} s, solve "
              f"{row['phases'].get('solve', 0):6.1f} s, receivers {row['phases'].get('receivers', 0):7.1f} s, "
              f"total {row['total_s']:7.1f} s (CPU {row['cpu_s']:7.1f} s), "
              f"{row['rays'] / 1e6:6.1f}M rays, peak {row['peak_rss_gb']:.2f} GB"
              + ("" if err is None else f", {100 * err:.2f}% from Cycles"), flush=True)
    commit = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    fits = {key: slope(rows, key) for key in ("total_s", "cpu_s", "rays", "peak_rss_gb")}
    print("slopes (log-log against points): " +
          ", ".join(f"{k} {v:.2f}" for k, v in fits.items() if v is not None))
    import bpy  # noqa: F401  (for the version only)
    with open(args.out, "w") as f:
        json.dump(dict(blender=bpy.app.version_string, commit=commit, cpus=os.cpu_count(),
                       date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                       slopes=fits, rows=rows, bench_scans=accuracy), f, indent=1)
    if len(rows) >= 2:
        chart(rows, args.chart)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
