"""Visibility benchmark: precomputation time, peak memory, node-pair classes and accuracy of
``visibility="exact"`` and ``"seed"`` (and ``"none"`` for contrast) in the FMM operator.

Scene: ``illumap.scenes.box_room(N)`` — a closed 4 × 3 × 2.5 m room holding a box on the
floor, a sphere and a floating two-sided panel, randomly sampled by area (occluders between
most surface pairs). Each configuration is built in its own subprocess (peak RSS from
``resource.getrusage``), with a timeout.

Accuracy: on R random receivers, ``y = F·V·x`` from each FMM operator's ``apply`` against the
exact operator's ``apply_rows`` (a direct sum with the exact per-pair V, one ray per facing
pair), for x = the emission (a ceiling light: direct shadows) and x = 1 everywhere; relative
RMS over the receivers. "none" and "seed" are compared with the same exact reference.

Usage::

    .venv/bin/python bench/micro/bench_visibility.py                       # N = 100k and 1M
    .venv/bin/python bench/micro/bench_visibility.py --sizes 100000 --rows 1000
    .venv/bin/python bench/micro/bench_visibility.py --methods exact none --shape quad

Writes bench/results/visibility.json and prints a markdown table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # bench/
RESULTS = os.path.join(HERE, "results", "visibility.json")


def _vector(surfels):
    """One source vector x holding both cases, so each operator applies (and the exact one casts
    its reference rays) once: channel 0 = the emission's red channel (a ceiling light: direct
    shadows), channel 1 = 1 everywhere, channel 2 = the emission's green channel."""
    e = surfels.emission
    return np.ascontiguousarray(np.column_stack([e[:, 0], np.ones(surfels.n), e[:, 1]]))


CHANNELS = {"emission": [0, 2], "ones": [1]}


def worker(args) -> None:
    """One configuration: build, apply at the receivers, (exact) the reference rows."""
    import illumap
    import illumap.scenes

    surfels = illumap.scenes.box_room(args.n, seed=args.seed)
    rows = np.sort(np.random.default_rng(args.seed + 1).choice(surfels.n, args.rows[0],
                                                                replace=False))
    keywords = {}
    if args.method != "none":
        keywords.update(visibility_samples=args.samples)
    if args.method == "exact":
        keywords.update(visibility_shape=args.shape)
    cpu0 = time.process_time()
    t0 = time.perf_counter()
    op = illumap.TransportOperator(surfels, visibility=args.method, threads=args.threads,
                                   **keywords)
    build = time.perf_counter() - t0
    build_cpu = time.process_time() - cpu0
    rss_build = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    stats = op.stats
    out = {"n": surfels.n, "method": args.method, "build_seconds": build,
           "build_cpu_seconds": build_cpu, "peak_rss_bytes_build": rss_build,
           "stats": {k: v for k, v in stats.items() if isinstance(v, (int, float, str, list))}}
    x = _vector(surfels)
    t0 = time.perf_counter()
    y = op.apply(x)[rows]
    out["apply_seconds"] = time.perf_counter() - t0
    arrays = {"rows": rows, "y": y}
    if args.reference:
        t0 = time.perf_counter()
        arrays["ref"] = op.apply_rows(x, rows)
        out["reference_seconds"] = time.perf_counter() - t0
    out["peak_rss_bytes"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    np.savez(args.out + ".npz", **arrays)
    with open(args.out + ".json", "w") as f:
        json.dump(out, f)


def relative_rms(y, ref) -> float:
    return float(np.sqrt(np.mean((y - ref) ** 2)) / np.sqrt(np.mean(ref ** 2)))


def errors(arrays, ref):
    return {name: relative_rms(arrays["y"][:, c], ref["ref"][:, c])
            for name, c in CHANNELS.items()}


def run_config(n, rows, method, args, tmp, reference):
    base = os.path.join(tmp, f"{method}_{n}")
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--n", str(n), "--method",
           method, "--rows", str(rows), "--seed", str(args.seed), "--samples",
           str(args.samples), "--shape", args.shape, "--threads", str(args.threads),
           "--out", base] + (["--reference"] if reference else [])
    timeout = args.timeout_seed if method == "seed" else args.timeout
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, timeout=timeout, capture_output=True, text=True)
    except subprocess.TimeoutExpired:
        return {"n": n, "method": method, "error": f"timed out after {timeout} s"}, None
    if proc.returncode != 0:
        return {"n": n, "method": method,
                "error": f"exit {proc.returncode}: {proc.stderr.strip()[-800:]}"}, None
    with open(base + ".json") as f:
        result = json.load(f)
    result["subprocess_seconds"] = time.perf_counter() - t0
    return result, dict(np.load(base + ".npz"))


def per_level(stats, name):
    return stats.get(f"visibility_{name}_per_level", [])


def markdown(results) -> str:
    lines = ["| N | visibility | build (s) | build CPU (s) | lists (s) | near field (s) | "
             "peak RSS (MB) | rays | valid / invalid / partial (node pairs) | "
             "near blocks | M2L weighted | receivers | rel. RMS (emission) | rel. RMS (ones) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        if "error" in r:
            lines.append(f"| {r['n']} | {r['method']} | {r['error']} |" + " |" * 11)
            continue
        st = r["stats"]
        cls = " / ".join(str(sum(per_level(st, c))) for c in ("valid", "invalid", "partial")) \
            if r["method"] != "none" else "–"
        err = r.get("errors", {})
        lines.append(
            f"| {r['n']} | {r['method']} | {r['build_seconds']:.1f} | "
            f"{r['build_cpu_seconds']:.1f} | {st.get('time_build_lists', 0):.1f} | "
            f"{st.get('time_build_near', 0):.1f} | {r['peak_rss_bytes_build'] / 2**20:.0f} | "
            f"{st.get('visibility_queries', 0) / 1e6:.1f} M | {cls} | "
            f"{st.get('visibility_p2p_blocks', 0)} | {st.get('visibility_m2l_weighted', 0)} | "
            f"{r.get('rows', '')} | {err.get('emission', float('nan')):.2e} | {err.get('ones', float('nan')):.2e} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[100000, 1000000])
    p.add_argument("--methods", nargs="+", default=["exact", "seed", "none"],
                   choices=["exact", "seed", "none"])
    p.add_argument("--rows", type=int, nargs="+", default=[500, 100],
                   help="receivers for the error, one per size (the last repeats; default "
                        "500 at 100k, 100 at 1M: the reference casts one ray per facing pair, "
                        "~0.4 M long rays per receiver at 1M)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--samples", type=int, default=8, help="visibility_samples")
    p.add_argument("--shape", default="disc", choices=["disc", "quad", "octagon"],
                   help="exact: occluder shape")
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--timeout", type=float, default=1800, help="seconds per configuration")
    p.add_argument("--timeout-seed", type=float, default=1200,
                   help="seconds for a seed configuration")
    p.add_argument("--output", default=RESULTS)
    # internal: one configuration in this process
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--n", type=int, help=argparse.SUPPRESS)
    p.add_argument("--method", help=argparse.SUPPRESS)
    p.add_argument("--reference", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--out", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        worker(args)
        return 0

    results = []
    with tempfile.TemporaryDirectory(prefix="illumap_bench_vis_") as tmp:
        for k, n in enumerate(args.sizes):
            rows = args.rows[min(k, len(args.rows) - 1)]
            # The exact operator also yields the reference rows (its apply_rows).
            order = ["exact"] + [m for m in args.methods if m != "exact"]
            ref = None
            for method in order:
                result, arrays = run_config(n, rows, method, args, tmp,
                                            reference=method == "exact")
                result["rows"] = rows
                if method == "exact" and arrays is not None:
                    ref = arrays
                if arrays is not None and ref is not None:
                    result["errors"] = errors(arrays, ref)
                if method in args.methods:
                    results.append(result)
                    print(f"[bench_visibility] N={n} {method}: "
                          + (result.get("error") or
                             f"build {result['build_seconds']:.1f} s, errors "
                             f"{result.get('errors')}"), file=sys.stderr, flush=True)
    table = markdown(results)
    doc = {"scene": "illumap.scenes.box_room", "seed": args.seed,
           "samples": args.samples, "exact_shape": args.shape,
           "command": " ".join([os.path.relpath(sys.argv[0])] + sys.argv[1:]),
           "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                       "load_average": os.getloadavg()},
           "results": results, "table": table}
    os.makedirs(os.path.dirname(os.path.abspath(args.output)), exist_ok=True)
    with open(args.output, "w") as f:
        json.dump(doc, f, indent=1)
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
