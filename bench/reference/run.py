#!/usr/bin/env python3
"""Illumap against Cycles on meshes as users build them: the front door of bench/reference.

For each scene of ``scenes.SCENES``: build it, load its cached Cycles reference
(``bench/results/reference/<scene>.npz``; baked and cached when missing, stale or made with
fewer samples than asked), run Illumap through the add-on (``addon.pipeline.compute`` with
``transfer=True, transfer_domain="POINT"``) with each of ``ILLUMAP_SETTINGS``, read every scored
mesh's ``illumination`` POINT attribute, and score it over all scored vertices against the
reference (relative RMS, ``score.relative_rms``). In the same run Cycles bakes the scene at
``CYCLES_SAMPLES`` with another seed than the reference's, timed (the bake call alone) and scored
the same way. Writes ``bench/results/reference.json`` and prints a table.

    .venv/bin/python bench/reference/run.py                     # every scene, 2048-sample references
    .venv/bin/python bench/reference/run.py --quick --scenes cornell
    .venv/bin/python -m bench.reference --scenes cornell room --out /tmp/reference.json

Illumap's time is the whole ``compute`` call (sampling, materials, lamps, solve, transfer).
A scene's objects are rebuilt before each Illumap run, so every run starts from the same file.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_ROOT = os.path.dirname(os.path.dirname(HERE))
if REPO_ROOT not in sys.path:          # ``import addon``, as tests/blender/conftest.py does
    sys.path.insert(0, REPO_ROOT)

import bpy  # noqa: E402

if __package__ in (None, ""):          # run as a script: bench/ on the path
    sys.path.insert(0, os.path.dirname(HERE))
    from reference import bake, score  # noqa: E402
    from scenes import blender as scenes  # noqa: E402
else:
    from . import bake, score  # noqa: E402
    if __package__.startswith("bench."):
        from bench.scenes import blender as scenes  # noqa: E402
    else:                              # ``reference.…`` with bench/ on the path
        from scenes import blender as scenes  # noqa: E402

#: Illumap settings to score: (label, keywords). ``preset`` picks
#: ``pipeline.settings_from_preset``; other keys are ``pipeline.Settings`` fields.
ILLUMAP_SETTINGS: list[tuple[str, dict]] = [
    ("default", {}),                      # = MEDIUM
    ("DRAFT", dict(preset="DRAFT")),
    ("HIGH", dict(preset="HIGH")),
    ("target 0.1", dict(target_error=0.1)),
    ("target 0.05", dict(target_error=0.05)),
    ("target 0.03", dict(target_error=0.03)),
    ("target 0.02", dict(target_error=0.02)),
    ("target 0.01", dict(target_error=0.01)),
]
CYCLES_SAMPLES = (16, 64, 256, 1024)
QUICK_CYCLES_SAMPLES = (16, 64, 256)
REFERENCE_SAMPLES = 2048
#: Reference bakes when --quick finds no cache (written, and replaced by a full run later).
QUICK_REFERENCE_SAMPLES = 512
REFERENCE_SEED = 7919                  # the sweep uses seeds 0, 1, 2, …: uncorrelated
CACHE_DIR = os.path.join(REPO_ROOT, "bench", "results", "reference")
DEFAULT_OUT = os.path.join(REPO_ROOT, "bench", "results", "reference.json")


def register_addon():
    """Register the add-on from this checkout once (classes survive factory resets)."""
    import addon
    if not hasattr(bpy.types.Scene, "illumap"):
        addon.register()
    from addon import pipeline
    return pipeline


def make_settings(pipeline, spec: dict):
    """``pipeline.Settings`` for a spec of ILLUMAP_SETTINGS, writing POINT-domain results onto
    the meshes."""
    spec = dict(spec, transfer=True, transfer_domain="POINT")
    preset = spec.pop("preset", None)
    if preset is not None:
        return pipeline.settings_from_preset(preset, **spec)
    return pipeline.Settings(**spec)


def read_illumination(obj) -> np.ndarray:
    """The ``illumination`` POINT attribute of a mesh object as (V, 3) float64."""
    attr = obj.data.color_attributes.get("illumination")
    if attr is None or attr.domain != "POINT":
        raise RuntimeError(f"'{obj.name}' has no POINT-domain 'illumination' attribute")
    rgba = np.empty(len(obj.data.vertices) * 4, dtype=np.float32)
    attr.data.foreach_get("color", rgba)
    return rgba.reshape(-1, 4)[:, :3].astype(np.float64)


# --- the cached reference -------------------------------------------------------------------

def scan_objects(scene: "scenes.ReferenceScene") -> tuple[list, dict]:
    """What Illumap is given for ``scene``: one vertex-only point object holding the vertices
    of the meshes named in ``scene.scan`` (albedo in "Col", no normals, no radii) in place of
    those meshes, and how to read it back ({mesh name: (first point, count)})."""
    if not scene.scan:
        return scene.objects, {}
    meshes = [o for o in scene.scored if o.name in scene.scan]
    points = np.concatenate([bake.vertex_positions(o) for o in meshes])
    albedo = np.concatenate([scene.albedo[o.name] for o in meshes])
    data = bpy.data.meshes.new("Scan")
    data.vertices.add(len(points))
    data.vertices.foreach_set("co", points.ravel())
    colour = data.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
    rgba = np.ones((len(points), 4), dtype=np.float32)
    rgba[:, :3] = albedo
    colour.data.foreach_set("color", rgba.ravel())
    data.color_attributes.active_color = colour
    scan = bpy.data.objects.new("Scan", data)
    bpy.context.scene.collection.objects.link(scan)
    spans, start = {}, 0
    for o in meshes:
        spans[o.name] = (start, len(o.data.vertices))
        start += len(o.data.vertices)
    rest = [o for o in scene.objects if o.name not in scene.scan]
    return [scan] + rest, spans


def read_scan(spans: dict) -> dict[str, np.ndarray]:
    """The scan object's ``illumination`` point attribute, split back into its meshes."""
    attr = bpy.data.objects["Scan"].data.attributes["illumination"]
    rgba = np.empty(len(attr.data) * 4, dtype=np.float32)
    attr.data.foreach_get("color", rgba)
    values = rgba.reshape(-1, 4)[:, :3].astype(np.float64)
    return {name: values[start:start + count] for name, (start, count) in spans.items()}


def _cache_path(name: str) -> str:
    return os.path.join(CACHE_DIR, f"{name}.npz")


def load_reference(scene: "scenes.ReferenceScene", min_samples: int) -> dict | None:
    """The cached reference of ``scene`` if it matches the built vertices and has at least
    ``min_samples`` samples, else None."""
    path = _cache_path(scene.reference_name)
    if not os.path.exists(path):
        return None
    data = np.load(path, allow_pickle=False)
    names = [o.name for o in scene.scored]
    counts = [len(o.data.vertices) for o in scene.scored]
    if list(data["names"]) != names or list(data["counts"]) != counts:
        print(f"  cached reference {path} is for other meshes: re-baking")
        return None
    positions = np.concatenate([bake.vertex_positions(o) for o in scene.scored])
    if np.abs(data["positions"] - positions).max() > 1e-4:
        print(f"  cached reference {path} has other vertex positions: re-baking")
        return None
    if int(data["samples"]) < min_samples:
        print(f"  cached reference has {int(data['samples'])} samples < {min_samples}: re-baking")
        return None
    split = np.cumsum(counts)[:-1]
    outgoing = dict(zip(names, np.split(data["outgoing"].astype(np.float64), split)))
    return dict(outgoing=outgoing, samples=int(data["samples"]), seconds=float(data["seconds"]),
                blender=str(data["blender"]), seed=int(data["seed"]), date=str(data["date"]),
                cached=True)


def make_reference(scene: "scenes.ReferenceScene", samples: int) -> dict:
    """Bake the reference of ``scene`` with ``samples`` samples and cache it (float32, compressed)."""
    outgoing, seconds = bake.bake_outgoing(scene, samples, seed=REFERENCE_SEED)
    names = [o.name for o in scene.scored]
    os.makedirs(CACHE_DIR, exist_ok=True)
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    np.savez_compressed(
        _cache_path(scene.reference_name), names=np.array(names),
        counts=np.array([len(o.data.vertices) for o in scene.scored]),
        positions=np.concatenate([bake.vertex_positions(o) for o in scene.scored]).astype(np.float32),
        outgoing=score.stacked(outgoing, names).astype(np.float32), samples=samples,
        seconds=seconds, seed=REFERENCE_SEED, blender=bpy.app.version_string, date=date)
    return dict(outgoing=outgoing, samples=samples, seconds=seconds,
                blender=bpy.app.version_string, seed=REFERENCE_SEED, date=date, cached=False)


# --- runs -----------------------------------------------------------------------------------

def _scored_row(scene, label, tool, values, reference, seconds, **extra) -> dict:
    """Scores over the vertices the reference has a value for (``bake.baked_vertices``)."""
    names = [o.name for o in scene.scored]
    keep = {o.name: bake.baked_vertices(o) for o in scene.scored}
    values = {n: np.asarray(v)[keep[n]] for n, v in values.items() if n in keep}
    reference = {n: np.asarray(v)[keep[n]] for n, v in reference.items() if n in keep}
    positions = {o.name: bake.vertex_positions(o)[keep[o.name]] for o in scene.scored}
    row = dict(scene=scene.name, tool=tool, label=label, seconds=round(seconds, 4),
               relative_rms=score.relative_rms(score.stacked(values, names),
                                               score.stacked(reference, names)),
               **extra)
    row["groups"] = {g: score.relative_rms(score.stacked(values, members),
                                           score.stacked(reference, members))
                     for g, members in scene.groups.items()}
    row["objects"] = score.per_object(values, reference, positions)
    return row


def run_scene(name: str, pipeline, settings: list[tuple[str, dict]], sample_counts,
              reference_samples: int) -> tuple[dict, list[dict]]:
    """Reference, Cycles sweep and Illumap runs on one scene: (reference info, result rows)."""
    scene = scenes.build(name)
    print(f"{name}: {scene.vertex_count()} scored vertices in {len(scene.scored)} meshes, "
          f"{len(scene.emitters)} emitters, {len(scene.lamps)} lamps", flush=True)
    if scene.reference_samples:
        reference_samples = min(reference_samples, scene.reference_samples)
    ref = load_reference(scene, reference_samples)
    if ref is None:
        print(f"  baking the reference at {reference_samples} samples …", flush=True)
        ref = make_reference(scene, reference_samples)
    print(f"  reference: {ref['samples']} samples, bake {ref['seconds']:.1f} s "
          f"({'cached' if ref['cached'] else 'new'}, Blender {ref['blender']})", flush=True)
    rows = []
    if scene.cycles_samples:
        sample_counts = [c for c in sample_counts if c in scene.cycles_samples] or \
            list(scene.cycles_samples)
    if scene.only_settings:
        settings = [s for s in settings if s[0] in scene.only_settings]
    for seed, samples in enumerate(sample_counts):
        values, seconds = bake.bake_outgoing(scene, samples, seed=seed)
        rows.append(_scored_row(scene, f"Cycles {samples} spp", "cycles", values,
                                ref["outgoing"], seconds, samples=samples))
        print(f"  Cycles {samples:5d} spp {seconds:8.2f} s  rel. RMS {rows[-1]['relative_rms']:.4f}",
              flush=True)
    noise = reference_noise(rows, ref["samples"])
    if noise is not None:
        print(f"  reference noise (estimated from the {rows[-1]['samples']}-sample bake): "
              f"rel. RMS {noise:.4f}", flush=True)
    for label, spec in settings:
        scene = scenes.build(name)        # a fresh file for every run
        objects, spans = scan_objects(scene)
        settings_obj = make_settings(pipeline, spec)
        start = time.perf_counter()
        try:
            result = pipeline.compute(bpy.context, objects, settings_obj)
        except Exception as exc:          # noqa: BLE001 - a failing setting is a result too
            print(f"  Illumap {label}: failed: {type(exc).__name__}: {exc}", flush=True)
            rows.append(dict(scene=name, tool="illumap", label=label, error=str(exc)))
            continue
        seconds = time.perf_counter() - start
        values = {o.name: read_illumination(o) for o in scene.scored if o.name not in spans}
        values.update(read_scan(spans) if spans else {})
        rows.append(_scored_row(scene, label, "illumap", values, ref["outgoing"], seconds,
                                surfels=int(result.count), settings=spec,
                                receivers=result.stats.get("receivers"),
                                timings={k: round(float(v), 4) for k, v in result.timings.items()},
                                warnings=list(result.warnings)))
        print(f"  Illumap {label:12s} {result.count:7d} surfels {seconds:8.2f} s  "
              f"rel. RMS {rows[-1]['relative_rms']:.4f}", flush=True)
    info = dict(samples=ref["samples"], seconds=ref["seconds"], seed=ref["seed"], noise=noise,
                blender=ref["blender"], date=ref["date"], vertices=scene.vertex_count(),
                notes=scene.notes)
    return info, rows


def reference_noise(cycles_rows: list[dict], reference_samples: int) -> float | None:
    """The reference's own noise (relative RMS) estimated from the sweep's largest bake: with
    independent seeds and noise variance ∝ 1/samples, a bake of N samples differs from a
    reference of R samples by e = σ·sqrt(1/N + 1/R), so the reference's share is
    e·sqrt(N/(N + R)). None without a sweep."""
    if not cycles_rows:
        return None
    row = max(cycles_rows, key=lambda r: r["samples"])
    n = row["samples"]
    return float(row["relative_rms"] * np.sqrt(n / (n + reference_samples)))


def print_table(rows: list[dict], detail: bool = False) -> None:
    """The results as a fixed-width table; with ``detail``, each Illumap run's objects and
    groups below it (relative RMS, mean ratio to the reference)."""
    print(f"\n{'scene':8s} {'run':16s} {'surfels/spp':>11s} {'seconds':>9s} {'rel. RMS':>9s}")
    for r in rows:
        if "error" in r:
            print(f"{r['scene']:8s} {r['label']:16s} {'failed':>11s}")
            continue
        size = r.get("surfels", r.get("samples"))
        print(f"{r['scene']:8s} {r['label']:16s} {size:11d} {r['seconds']:9.2f} "
              f"{r['relative_rms']:9.4f}")
        if detail and r["tool"] == "illumap":
            for name, o in r["objects"].items():
                print(f"{'':12s}{name:22s} rel. RMS {o['relative_rms']:7.4f}  "
                      f"mean ratio {o['mean_ratio']:6.3f}")
            for group, value in r["groups"].items():
                print(f"{'':12s}{group:22s} rel. RMS {value:7.4f}")


def _commit() -> str:
    """HEAD's short hash, with "+changes" when tracked files differ from it."""
    def git(*args):
        return subprocess.run(["git", "-C", REPO_ROOT, *args], capture_output=True, text=True,
                              check=True).stdout.strip()
    try:
        head = git("rev-parse", "--short", "HEAD")
        return head + ("+changes" if git("status", "--porcelain", "--untracked-files=no") else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv: list[str] | None = None) -> int:
    """Command line: see the module docstring and ``--help``."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="+", choices=sorted(scenes.SCENES),
                    default=list(scenes.SCENES))
    ap.add_argument("--quick", action="store_true",
                    help=f"Cycles sweep {QUICK_CYCLES_SAMPLES}; a missing reference is baked at "
                         f"{QUICK_REFERENCE_SAMPLES} samples (a cached one of any count is used)")
    ap.add_argument("--reference-samples", type=int, default=None,
                    help=f"reference samples (default {REFERENCE_SAMPLES})")
    ap.add_argument("--settings", nargs="+", default=None, metavar="LABEL",
                    help="only these labels of ILLUMAP_SETTINGS")
    ap.add_argument("--out", default=DEFAULT_OUT)
    ap.add_argument("--detail", action="store_true",
                    help="print each Illumap run's objects and groups under it")
    ap.add_argument("--table", metavar="JSON", default=None,
                    help="only print the table of an earlier run's JSON")
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)
    if args.table:
        with open(args.table) as f:
            print_table(json.load(f)["rows"], args.detail)
        return 0
    if args.reference_samples is not None:
        reference_samples = args.reference_samples
    else:
        reference_samples = QUICK_REFERENCE_SAMPLES if args.quick else REFERENCE_SAMPLES
    sample_counts = QUICK_CYCLES_SAMPLES if args.quick else CYCLES_SAMPLES
    settings = [s for s in ILLUMAP_SETTINGS if args.settings is None or s[0] in args.settings]
    pipeline = register_addon()
    start = time.perf_counter()
    references, rows = {}, []
    for name in args.scenes:
        references[name], scene_rows = run_scene(name, pipeline, settings, sample_counts,
                                                 reference_samples)
        rows += scene_rows
    import illumap
    results = dict(
        mode="quick" if args.quick else "full", commit=_commit(),
        blender=bpy.app.version_string, illumap_core=getattr(illumap, "__file__", ""),
        machine=dict(platform=platform.platform(), cpus=os.cpu_count()),
        date=datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        references=references, rows=rows, wall_seconds=time.perf_counter() - start)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(results, f, indent=1)
    print_table(rows, args.detail)
    print(f"wrote {args.out} ({results['wall_seconds']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
