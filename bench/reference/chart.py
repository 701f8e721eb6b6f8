#!/usr/bin/env python3
"""Error against time, Illumap against Cycles, per scene of bench/reference (one chart each).

Reads ``bench/results/reference.json`` (written by ``run.py``) and draws, for every scene,
the relative RMS error over all scored vertices against the wall-clock seconds of each
Illumap setting and of Cycles' bakes at each sample count, both measured in that one run,
with the reference's own estimated noise as a floor. Writes
``docs/images/reference_<scene>.png`` and prints the ratios the README and docs/results.md
quote: for each Illumap run, the Cycles time at equal error (interpolated log-log between the
sweep's bakes) divided by Illumap's.

    .venv/bin/python bench/reference/chart.py [--json bench/results/reference.json]
"""

from __future__ import annotations

import argparse
import json
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_ROOT = os.path.dirname(os.path.dirname(HERE))
DEFAULT_JSON = os.path.join(REPO_ROOT, "bench", "results", "reference.json")
IMAGES = os.path.join(REPO_ROOT, "docs", "images")


def cycles_time_at(error: float, cycles: list[dict]) -> float | None:
    """Seconds Cycles needs for ``error`` (relative RMS), interpolated log-log between the
    sweep's bakes (error falls about as 1/sqrt(samples)); extrapolated beyond the last bake
    along the last segment. None without two bakes."""
    pts = sorted((r["relative_rms"], r["seconds"]) for r in cycles)
    if len(pts) < 2:
        return None
    e = np.log([p[0] for p in pts])
    t = np.log([p[1] for p in pts])
    x = np.log(error)
    # pts sorted by error ascending: the most samples first
    if x <= e[0]:
        i = 0
    elif x >= e[-1]:
        i = len(e) - 2
    else:
        i = int(np.searchsorted(e, x)) - 1
    slope = (t[i + 1] - t[i]) / (e[i + 1] - e[i])
    return float(np.exp(t[i] + slope * (x - e[i])))


def ratios(data: dict) -> list[dict]:
    """Per Illumap run: its error, time and Cycles' time at that error (the speed ratio)."""
    out = []
    for scene in data["references"]:
        rows = [r for r in data["rows"] if r.get("scene") == scene and "error" not in r]
        cycles = [r for r in rows if r["tool"] == "cycles"]
        for r in rows:
            if r["tool"] != "illumap":
                continue
            t_cycles = cycles_time_at(r["relative_rms"], cycles)
            out.append(dict(scene=scene, label=r["label"], error=r["relative_rms"],
                            seconds=r["seconds"], cycles_seconds=t_cycles,
                            speedup=None if t_cycles is None else t_cycles / r["seconds"]))
    return out


def draw(data: dict) -> list[str]:
    """One chart per scene into docs/images; returns the paths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = []
    for scene, ref in data["references"].items():
        rows = [r for r in data["rows"] if r.get("scene") == scene and "error" not in r]
        cycles = sorted((r for r in rows if r["tool"] == "cycles"), key=lambda r: r["seconds"])
        ours = [r for r in rows if r["tool"] == "illumap"]
        fig, ax = plt.subplots(figsize=(5.2, 3.8), dpi=110)
        ax.plot([r["seconds"] for r in cycles], [100 * r["relative_rms"] for r in cycles],
                "o-", color="#888888", label="Cycles bake (16–1024 spp)")
        for r in cycles:
            ax.annotate(f"{r['samples']}", (r["seconds"], 100 * r["relative_rms"]),
                        textcoords="offset points", xytext=(4, 4), fontsize=7, color="#666666")
        ax.plot([r["seconds"] for r in ours], [100 * r["relative_rms"] for r in ours], "s",
                color="#c0392b", label="Illumap")
        for r in ours:
            ax.annotate(r["label"], (r["seconds"], 100 * r["relative_rms"]),
                        textcoords="offset points", xytext=(4, -9), fontsize=7, color="#c0392b")
        if ref.get("noise"):
            ax.axhline(100 * ref["noise"], color="#888888", ls=":", lw=1,
                       label="reference's own noise")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("seconds (2 cores)")
        ax.set_ylabel("relative RMS error, all vertices (%)")
        ax.set_title(f"{scene}: {ref['vertices']} vertices, {ref['samples']}-sample reference",
                     fontsize=9)
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=7, loc="upper right")
        fig.tight_layout()
        os.makedirs(IMAGES, exist_ok=True)
        path = os.path.join(IMAGES, f"reference_{scene}.png")
        fig.savefig(path)
        plt.close(fig)
        paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> int:
    """Command line: see the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", default=DEFAULT_JSON)
    args = ap.parse_args(argv)
    with open(args.json) as f:
        data = json.load(f)
    for path in draw(data):
        print(f"wrote {path}")
    print(f"\n{'scene':8s} {'run':12s} {'error':>7s} {'seconds':>8s} {'Cycles s':>9s} {'ratio':>7s}")
    for r in ratios(data):
        cyc = "-" if r["cycles_seconds"] is None else f"{r['cycles_seconds']:.2f}"
        sp = "-" if r["speedup"] is None else f"{r['speedup']:.1f}x"
        print(f"{r['scene']:8s} {r['label']:12s} {100 * r['error']:6.2f}% {r['seconds']:8.2f} "
              f"{cyc:>9s} {sp:>7s}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
