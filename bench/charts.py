#!/usr/bin/env python3
"""Regenerate every benchmark chart and docs/benchmarks.md from the JSON results.

    .venv/bin/python bench/charts.py [--results bench/results] [--images docs/images]
                                     [--doc docs/benchmarks.md]

Reads accuracy_speed.json, cycles_bake.json and scaling.json (whichever exist) and writes
docs/images/accuracy_<scene>.png, docs/images/cornell_vs_cycles.png, docs/images/scaling.png
and docs/benchmarks.md (the charts, with a table under each: the Pareto-best setting at 10%,
3%, 1% and 0.3% error and its speed ratio against Cycles at equal error).
"""
from __future__ import annotations

import argparse
import json
import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

THRESHOLDS = (0.10, 0.03, 0.01, 0.003)
SCENE_TITLES = {"cornell": "Cornell box (empty, 0.556 m)",
                "bunny": "Stanford bunny scan as a point cloud (no mesh, no normals)",
                "interior": "Room with occluders (box, sphere, panel)"}


def load(path):
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


def pareto_best(points, threshold):
    ok = [p for p in points if p.get("error") is not None and p["error"] <= threshold
          and p.get("time") is not None]
    return min(ok, key=lambda p: p["time"]) if ok else None


def fmt_time(t):
    return "–" if t is None else (f"{t * 1000:.1f} ms" if t < 1 else f"{t:.2f} s")


def fmt_pct(e):
    return "–" if e is None else f"{100 * e:.2f}%"


def describe(p):
    if p is None:
        return "not reached"
    return f"{p['label']}, N={p['n']}"


# ------------------------------------------------------------------------------------------------

STYLE = {"direct": dict(color="black", marker="o", ls="-")}


def curve_style(label, i):
    if label == "direct":
        return dict(color="black", marker="o", ls="-", lw=1.5)
    if label.startswith("FMM"):
        cmap = plt.get_cmap("viridis")
        p = int(label.split("p=")[1].split()[0])
        ls = {"none": "-", "seed": "--", "exact": ":"}.get(label.split("vis=")[1], "-")
        return dict(color=cmap(p / 9.0), marker=".", ls=ls, lw=1.2)
    if "(FMM" in label:
        return dict(color={"jacobi": "tab:orange", "cg": "tab:blue", "gmres": "tab:purple"}
                    [label.split()[0]], marker="x", ls="-.", lw=1.0)
    return dict(marker="s", ls="-", lw=1)


def accuracy_chart(scene, data, cycles, out_png):
    pts = [p for p in data["points"] if p.get("time")]
    fig, ax = plt.subplots(figsize=(8.5, 5.6))
    labels = []
    for p in pts:
        if p["family"] != "auto" and p["label"] not in labels:
            labels.append(p["label"])
    for i, label in enumerate(labels):
        c = sorted((p for p in pts if p["label"] == label), key=lambda p: p["n"])
        ax.plot([p["time"] for p in c], [p["error"] for p in c], label=label,
                **curve_style(label, i))
    auto = [p for p in pts if p["family"] == "auto"]
    if auto:
        ax.scatter([p["time"] for p in auto], [p["error"] for p in auto], marker="*", s=160,
                   color="gold", edgecolor="black", zorder=5, label="automatic mode")
        for p in auto:
            ax.annotate(f"target {p['target']:g}", (p["time"], p["error"]), fontsize=7,
                        xytext=(4, 4), textcoords="offset points")
    if cycles and scene == "cornell":
        grids = sorted({p["grid"] for p in cycles["points"]})
        for g in grids:
            c = sorted((p for p in cycles["points"] if p["tool"] == "cycles" and p["grid"] == g),
                       key=lambda p: p["samples"])
            ax.plot([p["time"] for p in c], [p["error"] for p in c], color="tab:red",
                    marker="s", ls="-", alpha=0.5 + 0.5 * g / max(grids),
                    label=f"Cycles bake, N={c[0]['n']} (4…{c[-1]['samples']} spp)")
            for p in c:
                ax.annotate(str(p["samples"]), (p["time"], p["error"]), fontsize=6,
                            color="tab:red", xytext=(3, -8), textcoords="offset points")
    floor = data["reference"]["floor"]
    ax.axhline(floor, color="gray", ls=":", lw=1)
    ax.text(ax.get_xlim()[0] if False else min(p["time"] for p in pts), floor * 1.05,
            f"reference floor {100 * floor:.2f}%", fontsize=7, color="gray")
    for t in THRESHOLDS:
        ax.axhline(t, color="lightgray", lw=0.6, zorder=0)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time of the solve (s, this machine)")
    ax.set_ylabel("relative RMS error per surfel")
    ax.set_title(SCENE_TITLES.get(scene, scene) + "\npoints along a curve: surfel density",
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.2)
    ax.legend(fontsize=6.5, ncol=2, loc="upper right")
    fig.tight_layout()
    fig.savefig(out_png, dpi=110)
    plt.close(fig)


def cycles_chart(cycles, out_png):
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for g in sorted({p["grid"] for p in cycles["points"]}):
        cy = sorted((p for p in cycles["points"] if p["tool"] == "cycles" and p["grid"] == g),
                    key=lambda p: p["samples"])
        il = [p for p in cycles["points"] if p["tool"] == "illumap" and p["grid"] == g]
        line, = ax.plot([p["time"] for p in cy], [p["error"] for p in cy], marker="s",
                        label=f"Cycles bake, N={cy[0]['n']} vertices")
        for p in cy:
            ax.annotate(f"{p['samples']} spp", (p["time"], p["error"]), fontsize=6,
                        xytext=(3, 3), textcoords="offset points")
        ax.scatter([p["time"] for p in il], [p["error"] for p in il], marker="o",
                   color=line.get_color(), edgecolor="black", zorder=5,
                   label=f"Illumap, same {il[0]['n']} vertices")
        for p in il:
            ax.annotate(p["label"], (p["time"], p["error"]), fontsize=6, xytext=(3, -8),
                        textcoords="offset points")
    ax.axhline(0.03, color="gray", ls="--", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time (s): Cycles bake call / Illumap solve")
    ax.set_ylabel("relative RMS error per vertex")
    ax.set_title("Cornell box: Illumap against Cycles 'Bake to Color Attribute', same vertices",
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.2)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out_png, dpi=110)
    plt.close(fig)


def scaling_chart(scaling, out_png):
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.3))
    for method, color in (("fmm", "tab:blue"), ("direct", "black")):
        pts = sorted((p for p in scaling["points"] if p["method"] == method and "error" not in p),
                     key=lambda p: p["n"])
        if not pts:
            continue
        s = scaling["slopes"][method]
        name = f"FMM p={scaling['order']}" if method == "fmm" else "direct O(N²)"
        axes[0].plot([p["n"] for p in pts], [p["total"] for p in pts], marker="o", color=color,
                     label=f"{name}: slope {s['time']:.2f}" if s["time"] else name)
        axes[1].plot([p["n"] for p in pts], [p["peak_rss"] / 2 ** 20 for p in pts], marker="o",
                     color=color,
                     label=f"{name}: slope {s['memory']:.2f}" if s["memory"] else name)
    for ax, ylabel in zip(axes, ("wall time of build + solve (s)", "peak RSS (MiB)")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("surfels N")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.2)
        ax.legend(fontsize=8)
    fig.suptitle("Scaling on the room scene (each size in its own process; slopes fitted "
                 "for N ≥ 30k where two sizes ran)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out_png, dpi=110)
    plt.close(fig)


# ------------------------------------------------------------------------------------------------

def pareto_table(points, cycles_points):
    rows = ["| error ≤ | Pareto-best Illumap setting | its error | its time | Cycles at equal "
            "error | speed ratio vs Cycles |", "|---|---|---|---|---|---|"]
    for t in THRESHOLDS:
        best = pareto_best(points, t)
        if cycles_points is None:
            cy_txt, ratio = "no Cycles bake for this scene", "–"
        else:
            cy = pareto_best(cycles_points, t)
            cy_txt = "not reached" if cy is None else \
                f"{cy['label']} (N={cy['n']}): {fmt_time(cy['time'])}"
            ratio = f"{cy['time'] / best['time']:.0f}×" if (cy and best) else "–"
        rows.append(f"| {100 * t:g}% | {describe(best)} | "
                    f"{fmt_pct(best['error']) if best else '–'} | "
                    f"{fmt_time(best['time']) if best else '–'} | {cy_txt} | {ratio} |")
    return "\n".join(rows)


def auto_table(scene, points):
    auto = [p for p in points if p["family"] == "auto"]
    if not auto:
        return ""
    hand = [p for p in points if p["family"] != "auto"]
    rows = ["| target | chosen (N, method, p, θ, tol) | error | met? | time | best hand-picked "
            "at that error | time ratio |", "|---|---|---|---|---|---|---|"]
    for p in auto:
        kw = p["settings"]
        desc = f"N={p['n']}, {kw['method']}" + (f", p={kw['order']}, θ={kw['theta']}"
                                                 if kw["method"] == "fmm" else "") \
            + f", tol={kw['tol']:.1e}"
        if p.get("time") is None:
            rows.append(f"| {100 * p['target']:g}% | {desc} | not run: {p.get('skipped')} "
                        f"| – | – | – | – |")
            continue
        best = pareto_best(hand, p["target"])   # the best hand-picked setting for that error
        met = "yes" if p["error"] <= p["target"] else "**no**"
        ratio = f"{p['time'] / best['time']:.2f}" if best else "–"
        rows.append(f"| {100 * p['target']:g}% | {desc} | {fmt_pct(p['error'])} "
                    f"(estimate {fmt_pct(p['estimate']['total'])}) | {met} | "
                    f"{fmt_time(p['time'])} | {describe(best)}: "
                    f"{fmt_time(best['time']) if best else '–'} | {ratio} |")
    return "\n".join(rows)


def main(argv=None):
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(here)
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", default=os.path.join(here, "results"))
    ap.add_argument("--images", default=os.path.join(root, "docs", "images"))
    ap.add_argument("--doc", default=os.path.join(root, "docs", "benchmarks.md"))
    args = ap.parse_args(argv)
    os.makedirs(args.images, exist_ok=True)
    acc = load(os.path.join(args.results, "accuracy_speed.json"))
    cyc = load(os.path.join(args.results, "cycles_bake.json"))
    sca = load(os.path.join(args.results, "scaling.json"))
    rel = os.path.relpath(args.images, os.path.dirname(os.path.abspath(args.doc)))
    md = ["# Benchmarks: speed against accuracy",
          "",
          "Generated by `bench/charts.py` from `bench/results/*.json` (regenerate everything with "
          "`.venv/bin/python bench/run_all.py --quick|--full`; see bench/README.md). All times "
          "are wall times on this machine (2 cores shared with other jobs, so noisy); ratios are "
          "measured within one run. Error = relative RMS per surfel over non-emitting surfels, "
          "against a converged direct O(N²) reference at high density evaluated at each "
          "setting's own surfels by one exact gather; errors below the reference's own floor "
          "(dotted line) are not resolved.",
          ""]
    note = os.path.join(args.results, "NOTE.md")
    if os.path.exists(note):
        with open(note) as f:
            md += [f.read().strip(), ""]
    if acc:
        md += [f"Run: `{acc['mode']}` mode, {acc['date']}, solve tolerance "
               f"{acc['solve_tol']:g}. Visibility modes measured: "
               f"{', '.join(acc['visibilities'])}. Not available in this build: "
               + (", ".join(f"`{m}` ({why})" for m, why in acc["unavailable"].items()) or "none")
               + ". The reference uses visibility `" + next(iter(acc["scenes"].values()))
               ["reference"]["visibility"] + "`.", ""]
        for scene, data in acc["scenes"].items():
            png = f"accuracy_{scene}.png"
            accuracy_chart(scene, data, cyc, os.path.join(args.images, png))
            ref = data["reference"]
            md += [f"## {SCENE_TITLES.get(scene, scene)}", "",
                   f"![error against time, {scene}]({rel}/{png})", "",
                   f"Reference: direct, N={ref['n']}, {ref['iterations']} CG iterations, "
                   f"{ref['time']:.1f} s; its floor (gather at its own surfels) "
                   f"{100 * ref['floor']:.2f}%.", ""]
            hand = [p for p in data["points"] if p["family"] != "auto"]
            cy_pts = None
            if scene == "cornell" and cyc:
                cy_pts = [p for p in cyc["points"] if p["tool"] == "cycles"]
            md += [pareto_table(hand, cy_pts), ""]
            if scene == "cornell" and cyc:
                md += ["Cycles times come from `bench/cycles_bake.py` (bake call only); the "
                       "Illumap times in this table from `bench/accuracy_speed.py`, a separate "
                       "run: see the same-run comparison below for the target ratio.", ""]
            at = auto_table(scene, data["points"])
            if at:
                md += ["Automatic mode (`illumap.accuracy`):", "", at, ""]
    if cyc:
        cycles_chart(cyc, os.path.join(args.images, "cornell_vs_cycles.png"))
        il = [p for p in cyc["points"] if p["tool"] == "illumap"]
        cy = [p for p in cyc["points"] if p["tool"] == "cycles"]
        md += ["## Cornell box: Illumap against Cycles on the same vertices (one run)", "",
               f"![Cornell box against Cycles]({rel}/cornell_vs_cycles.png)", "",
               f"Blender {cyc['blender']}, Cycles CPU, 64 diffuse bounces, no clamping; "
               "`bpy.ops.object.bake(type='DIFFUSE', pass_filter={'DIRECT','INDIRECT'}, "
               "target='VERTEX_COLORS')`, outgoing = albedo × baked. Illumap and Cycles are "
               f"timed in the same process, on the same vertices ({cyc['date']}).", "",
               pareto_table(il, cy), "",
               "| N | setting | time | error |", "|---|---|---|---|"]
        md += [f"| {p['n']} | {p['label']} | {fmt_time(p['time'])} | {fmt_pct(p['error'])} |"
               for p in sorted(cyc["points"], key=lambda p: (p["n"], p["tool"], p["time"]))]
        md += [""]
    if sca:
        scaling_chart(sca, os.path.join(args.images, "scaling.png"))
        md += ["## Scaling", "", f"![scaling]({rel}/scaling.png)", "",
               f"FMM p={sca['order']}, θ={sca['theta']}, CG to {sca['tol']:g}; fitted log–log "
               f"slopes (sizes ≥ 30k where two ran, else all): time {sca['slopes']['fmm']['time']:.2f}, peak memory "
               f"{sca['slopes']['fmm']['memory']:.2f}; direct: time "
               + (f"{sca['slopes']['direct']['time']:.2f}" if sca['slopes']['direct']['time']
                  else "–") + f". {sca['date']}.", "",
               "| method | N | build | total | iterations | peak RSS |",
               "|---|---|---|---|---|---|"]
        for p in sca["points"]:
            if "error" in p:
                md.append(f"| {p['method']} | {p['n']} | – | {p['error']} | – | – |")
            else:
                md.append(f"| {p['method']} | {p['n']} | {fmt_time(p['build'])} | "
                          f"{fmt_time(p['total'])} | {p['iterations']} | "
                          f"{p['peak_rss'] / 2 ** 20:.0f} MiB |")
        md += [""]
    md += ["## Data", "",
           "The Stanford Bunny: Stanford 3D Scanning Repository, Stanford University Computer "
           "Graphics Laboratory (Greg Turk and Marc Levoy, 1994); used here only as benchmark "
           "data, kept outside the extension.", ""]
    with open(args.doc, "w") as f:
        f.write("\n".join(md))
    print(f"wrote {args.doc} and charts in {args.images}")


if __name__ == "__main__":
    main()
