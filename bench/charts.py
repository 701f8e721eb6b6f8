#!/usr/bin/env python3
"""Regenerate every benchmark chart and docs/benchmarks.md from the JSON results.

    .venv/bin/python bench/charts.py [--results bench/results] [--images docs/images]
                                     [--doc docs/benchmarks.md]

Reads accuracy_speed.json, cycles_bake.json and scaling.json (whichever exist) and writes
docs/images/accuracy_<scene>.png, docs/images/cycles_bake.png, docs/images/scaling.png
and docs/benchmarks.md (the charts, with a table under each: the Pareto-best setting at 10%,
3%, 1% and 0.3% error and its speed ratio against Cycles at equal error).
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from illumap import accuracy  # noqa: E402
from illumap.accuracy import calibration  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "calibration"))
import calibrate  # noqa: E402  (bench/calibration/calibrate.py: the leaf variants' and sampling fits)
from scenes import surfels as S  # noqa: E402

THRESHOLDS = (0.10, 0.03, 0.01, 0.003)
SCENE_TITLES = {"cornell": "Cornell box with its two blocks (0.556 m, grid surfels)",
                "cornell_mesh": "Cornell box as triangles (stratified surfels, as the add-on "
                                "samples meshes)",
                "bunny": "Stanford bunny scan as a point cloud (no mesh, no normals)",
                "interior": "Room with occluders (box, sphere, panel; random surfels)"}
VIS_STYLE = {"none": "-", "seed": "--", "exact": ":"}


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
    return "not reached" if p is None else f"{p['label']}, N={p['n']}"


def core_line(core):
    if not core:
        return "core: not recorded"
    mod = " (core/src modified, uncommitted)" if core.get("core_src_modified") else ""
    src = core.get("core_src_commit")
    return (f"commit `{core.get('commit')}`" + (f" (core/src at `{src}`)" if src else "")
            + f"{mod}; native module built {core.get('core_module_built')}")


def auto_runs_line(results):
    """Scenes whose automatic-mode rows come from an earlier ``--auto-only`` run than the
    file's last one (each scene's ``auto_run``)."""
    last = results.get("auto_date")
    older = [(scene, data["auto_run"]) for scene, data in results["scenes"].items()
             if data.get("auto_run") and data["auto_run"]["date"] != last]
    return "".join(f" Automatic mode on {scene}: {run['date']}, {core_line(run.get('core'))}."
                   for scene, run in older)


def runs_line(results):
    """Where a results file merges runs (``--merge``): which scenes came from a run other
    than the file's latest, with that run's date and core; "" when it holds one run."""
    runs = results.get("scene_runs") or {}
    older = [(scene, run) for scene, run in runs.items() if run.get("date") != results.get("date")]
    if not older:
        return ""
    newer = [scene for scene, run in runs.items() if run.get("date") == results.get("date")]
    return (f" Merged runs: {', '.join(newer)} from this run; "
            + "; ".join(f"{scene} from {run.get('date')}, {core_line(run.get('core'))}"
                        for scene, run in older) + ".")


# ------------------------------------------------------------------------------------------------

def _vis(label):
    return label.split("vis=")[1].split()[0].rstrip(",)") if "vis=" in label else "none"


def curve_style(label):
    vis = _vis(label)
    if label.startswith("direct"):
        return dict(color="black", marker="o", ls=VIS_STYLE.get(vis, "-"), lw=1.4)
    if label.startswith("FMM"):
        p = int(label.split("p=")[1].split()[0])
        if "all-pairs" in label:
            theta = label.split("θ=")[1]
            return dict(color={"0.5": "tab:green", "0.3": "tab:cyan"}.get(theta, "tab:olive"),
                        marker="D", ls="-" if " s=32" in label else "--", lw=1.2,
                        alpha=0.5 + 0.15 * p)
        if "θ=" in label:
            theta = label.split("θ=")[1]
            return dict(color={"0.3": "tab:brown", "0.2": "tab:pink"}[theta], marker="^",
                        ls="-", lw=1.0, alpha=0.4 + 0.15 * p)
        return dict(color=plt.get_cmap("viridis")(p / 9.0), marker=".",
                    ls=VIS_STYLE.get(vis, "-"), lw=1.1)
    if label.split()[0] in ("jacobi", "cg", "gmres"):
        return dict(color={"jacobi": "tab:orange", "cg": "tab:blue", "gmres": "tab:purple"}
                    [label.split()[0]], marker="x", ls="-.", lw=1.0)
    return dict(marker="s", ls="-", lw=1)


def _plot_curves(ax, pts, labels):
    for label in labels:
        c = sorted((p for p in pts if p["label"] == label), key=lambda p: p["n"])
        if c:
            ax.plot([p["time"] for p in c], [p["error"] for p in c], label=label,
                    **curve_style(label))


def accuracy_chart(scene, data, cycles, out_png):
    pts = [p for p in data["points"] if p.get("time") and p.get("error") is not None]
    hand = [p for p in pts if p["family"] != "auto"]
    labels = []
    for p in hand:
        if p["label"] not in labels:
            labels.append(p["label"])
    left = [lab for lab in labels if "θ=" not in lab and lab.split()[0] not in
            ("jacobi", "cg", "gmres")]
    right = [lab for lab in labels if lab not in left]
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.6), sharey=True)
    _plot_curves(axes[0], hand, left)
    axes[0].set_title("FMM p ∈ {0,2,3,4,6,8} (colour) × visibility none — / seed -- / "
                      "exact ··· (θ=0.5); direct (black)", fontsize=8.5)
    _plot_curves(axes[1], hand, right)
    axes[1].set_title("exact visibility at smaller θ; all-pairs: per-pair V in every partial "
                      "leaf pair (s samples)\nJacobi vs CG vs GMRES; Cycles; automatic mode",
                      fontsize=8)
    best = [lab for lab in left if lab.startswith("direct") and "exact" in lab]
    _plot_curves(axes[1], hand, best)
    if cycles and scene == "cornell":
        for g in sorted({p["grid"] for p in cycles["points"]}):
            c = sorted((p for p in cycles["points"] if p["tool"] == "cycles" and p["grid"] == g),
                       key=lambda p: p["samples"])
            axes[1].plot([p["time"] for p in c], [p["error"] for p in c], color="tab:red",
                         marker="s", ls="-", alpha=0.7,
                         label=f"Cycles bake, N={c[0]['n']} ({c[0]['samples']}…"
                               f"{c[-1]['samples']} spp)")
            for p in c:
                axes[1].annotate(str(p["samples"]), (p["time"], p["error"]), fontsize=6,
                                 color="tab:red", xytext=(3, -8), textcoords="offset points")
    auto = [p for p in pts if p["family"] == "auto"]
    if auto:
        axes[1].scatter([p["time"] for p in auto], [p["error"] for p in auto], marker="*",
                        s=170, color="gold", edgecolor="black", zorder=5, label="automatic mode")
        for p in auto:
            axes[1].annotate(f"target {100 * p['target']:g}%", (p["time"], p["error"]),
                             fontsize=7, xytext=(4, 4), textcoords="offset points")
    check = data["reference"]["check"]
    for ax in axes:
        ax.axhline(check, color="gray", ls=":", lw=1)
        ax.text(0.01, check * 1.05, f"reference check {100 * check:.2f}%", fontsize=7,
                color="gray", transform=ax.get_yaxis_transform())
        for t in THRESHOLDS:
            ax.axhline(t, color="lightgray", lw=0.6, zorder=0)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time of the solve (s, this machine)")
        ax.grid(True, which="both", alpha=0.2)
        ax.legend(fontsize=6, ncol=2, loc="lower left")
    axes[0].set_ylabel("relative RMS error per surfel")
    fig.suptitle(SCENE_TITLES.get(scene, scene) + " — points along a curve: surfel density",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(out_png, dpi=100)
    plt.close(fig)


def cycles_chart(cycles, out_png):
    fig, ax = plt.subplots(figsize=(8.5, 5.5))
    cmap = plt.get_cmap("tab10")
    for k, g in enumerate(sorted({p["grid"] for p in cycles["points"]})):
        cy = sorted((p for p in cycles["points"] if p["tool"] == "cycles" and p["grid"] == g),
                    key=lambda p: p["samples"])
        il = [p for p in cycles["points"] if p["tool"] == "illumap" and p["grid"] == g]
        color = cmap(k)
        ax.plot([p["time"] for p in cy], [p["error"] for p in cy], marker="s", color=color,
                label=f"Cycles bake, N={cy[0]['n']} vertices")
        for p in cy:
            ax.annotate(f"{p['samples']}", (p["time"], p["error"]), fontsize=6, color=color,
                        xytext=(3, 3), textcoords="offset points")
        ax.scatter([p["time"] for p in il], [p["error"] for p in il], marker="o",
                   color=color, edgecolor="black", zorder=5,
                   label=f"Illumap, same {il[0]['n']} vertices")
        for p in il:
            ax.annotate(p["label"], (p["time"], p["error"]), fontsize=5.5, xytext=(3, -7),
                        textcoords="offset points")
    ax.axhline(0.03, color="gray", ls="--", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time (s): Cycles bake call / Illumap solve")
    ax.set_ylabel("relative RMS error per vertex")
    ax.set_title("Cornell box with blocks: Illumap against Cycles 'Bake to Color Attribute', "
                 "same vertices, one run", fontsize=9.5)
    ax.grid(True, which="both", alpha=0.2)
    ax.legend(fontsize=6.5)
    fig.tight_layout()
    fig.savefig(out_png, dpi=100)
    plt.close(fig)


#: How the scaling cases' visibility reads in the chart's legend.
VIS_LABELS = {"none": "", "exact": ", exact vis., occluder discs",
              "exact-mesh": ", exact vis., the box's mesh"}


def scaling_chart(scaling, out_png):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    colors = ["tab:blue", "tab:green", "tab:orange", "black", "tab:red"]
    for key, color in zip(scaling["slopes"], colors):
        scene, method, vis = key.split("/")
        pts = sorted((p for p in scaling["points"] if "error" not in p and p["scene"] == scene
                      and p["method"] == method and p["visibility"] == vis),
                     key=lambda p: p["n"])
        s = scaling["slopes"][key]
        name = (f"{scene}, FMM p={scaling['order']}" if method == "fmm"
                else f"{scene}, direct O(N²)") + VIS_LABELS.get(vis, f", vis={vis}")
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
        ax.legend(fontsize=7)
    fig.suptitle(f"Scaling (each size in its own process; slopes fitted for "
                 f"N ≥ {scaling.get('fit_min_n', 100000) // 1000}k)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out_png, dpi=100)
    plt.close(fig)


# ------------------------------------------------------------------------------------------------

def pareto_table(points, cycles_points, check=None, cycles_header="Cycles at equal error"):
    rows = ["| error ≤ | Pareto-best Illumap setting | its error | its time | "
            f"{cycles_header} | speed ratio vs Cycles |", "|---|---|---|---|---|---|"]
    for t in THRESHOLDS:
        if check is not None and t < check:
            rows.append(f"| {100 * t:g}% | below what the reference resolves "
                        f"({fmt_pct(check)}) | – | – | – | – |")
            continue
        best = pareto_best(points, t)
        if cycles_points is None:
            cy_txt, ratio = "no Cycles bake for this scene", "–"
        else:
            cy = pareto_best(cycles_points, t)
            cy_txt = "not reached" if cy is None else \
                f"{cy['label']} (N={cy['n']}): {fmt_time(cy['time'])}"
            ratio = f"{cy['time'] / best['time']:.1f}×" if (cy and best) else "–"
        rows.append(f"| {100 * t:g}% | {describe(best)} | "
                    f"{fmt_pct(best['error']) if best else '–'} | "
                    f"{fmt_time(best['time']) if best else '–'} | {cy_txt} | {ratio} |")
    return "\n".join(rows)


def same_vertices_table(il, cy):
    """Per grid and threshold: the fastest Illumap setting and the fastest Cycles sample count
    within it on the same vertices, and their time ratio."""
    rows = ["| vertices N | error ≤ | Illumap (fastest within it) | Cycles (fastest within it) "
            "| speed ratio vs Cycles |", "|---|---|---|---|---|"]
    for n in sorted({p["n"] for p in il}):
        for t in THRESHOLDS:
            bi = pareto_best([p for p in il if p["n"] == n], t)
            bc = pareto_best([p for p in cy if p["n"] == n], t)
            if bi is None and bc is None:
                continue
            ti = f"{bi['label']}: {fmt_pct(bi['error'])}, {fmt_time(bi['time'])}" if bi \
                else "not reached"
            tc = f"{bc['label']}: {fmt_pct(bc['error'])}, {fmt_time(bc['time'])}" if bc \
                else "not reached (up to " + str(max((p["samples"] for p in cy if p["n"] == n),
                                                      default=0)) + " spp)"
            ratio = f"**{bc['time'] / bi['time']:.1f}×**" if (bi and bc) else "–"
            rows.append(f"| {n} | {100 * t:g}% | {ti} | {tc} | {ratio} |")
    return "\n".join(rows)


def describe_settings(kw, n):
    s = f"N={n}, {kw['method']}"
    if kw["method"] == "fmm":
        s += f" p={kw['order']} θ={kw['theta']}"
        if kw.get("leaf_size", 32) != 32:
            s += f" leaf={kw['leaf_size']}"
    s += f", vis={kw.get('visibility', 'none')}"
    if kw.get("visibility_leaf_mode") == "per_pair_all":
        s += f" all-pairs s={kw.get('visibility_samples', 8)}"
    s += f", tol={kw['tol']:.0e}"
    if kw.get("error_tol"):
        s += f" or solver error ≤ {100 * kw['error_tol']:g}%"
    return s


def paired_time(best):
    """A best's time, with the automatic mode's from the same alternating rounds."""
    txt = fmt_time(best["time"])
    return txt + (f" (auto {fmt_time(best['auto_time'])})" if "auto_time" in best else "")


def auto_table(points):
    auto = [p for p in points if p["family"] == "auto"]
    if not auto:
        return ""
    hand = [p for p in points if p["family"] != "auto"]
    rows = ["| target | chosen settings | error (worst of the samplings) | met? | a-posteriori estimate | time | best "
            "hand-picked at that error | time ratio | best steady setting | ratio | best on "
            "the automatic mode's samplings too | ratio | the same within its aim "
            f"({accuracy.SAFETY:g} × target) | ratio |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for p in auto:
        variant = " adaptive" if p.get("adaptive") else (" uniform" if "uniform" in p["label"]
                                                         else "")
        if p.get("time") is None:
            rows.append(f"| {100 * p['target']:g}%{variant} | not run: {p.get('skipped')} "
                        "| – | – | – | – | – | – | – | – | – | – | – | – |")
            continue
        worst = p.get("worst_error", p["error"])
        met = "yes" if worst <= p["target"] else "**no**"
        others = p.get("other_samplings") or []
        err_txt = fmt_pct(p["error"]) + (f" ({fmt_pct(worst)} of {1 + len(others)})"
                                         if others else "")
        bh = p.get("best_hand")
        if bh:   # re-timed in the same process, right after the automatic mode
            best_txt = f"{bh['label']}, N={bh['n']} ({fmt_pct(bh['error'])}): {paired_time(bh)}"
            ratio = f"{bh['ratio']:.2f}"
        else:
            best = pareto_best(hand, p["target"])
            best_txt = f"{describe(best)}: {fmt_time(best['time']) if best else '–'} (sweep)"
            ratio = f"{p['time'] / best['time']:.2f}" if best else "–"
        st = p.get("best_steady")
        steady_txt = (f"{st['label']}, N={st['n']} ({fmt_pct(st['error'])}): "
                      f"{paired_time(st)} | {st['ratio']:.2f}") if st else "– | –"
        rb = p.get("best_robust")
        if rb and "errors_auto_samplings" in rb:
            rb_err = fmt_pct(max(rb["errors_auto_samplings"]))
        elif rb:
            rb_err = fmt_pct(rb["error_second_sampling"])
        search = p.get("robust_search")
        if rb:
            robust_txt = (f"{rb['label']}, N={rb['n']} ({fmt_pct(rb['error'])}, {rb_err}): "
                          f"{paired_time(rb)} | {rb['ratio']:.2f}")
        elif search:   # none passes up to the horizon: every passing setting is slower
            robust_txt = (f"none of the {search['tried']} swept points within the target up "
                          f"to {search['horizon']:g}× this time "
                          f"({fmt_time(search['horizon_time'])}) | < {1 / search['horizon']:.2f}")
        else:
            robust_txt = "– | –"
        ra = p.get("best_robust_aim")
        if ra:
            aim_txt = (f"{ra['label']}, N={ra['n']} ({fmt_pct(ra['error'])}, "
                       f"{fmt_pct(max(ra['errors_auto_samplings']))}): {paired_time(ra)} | "
                       f"{ra['ratio']:.2f}")
        elif p.get("robust_aim_search"):
            aim_txt = (f"none up to {p['robust_aim_search'].get('horizon', 2):g}× this time "
                       "| –")
        else:
            aim_txt = "– | –"
        rows.append(f"| {100 * p['target']:g}%{variant} | "
                    f"{describe_settings(p['settings'], p['n'])} | "
                    f"{err_txt} | {met} | {fmt_pct(p['estimate']['total'])} | "
                    f"{fmt_time(p['time'])} | {best_txt} | {ratio} | {steady_txt} | "
                    f"{robust_txt} | {aim_txt} |")
    return "\n".join(rows)


def leaf_section(leaf):
    """docs/benchmarks.md's leaf-size section from bench/calibration/leaf_size.py's paired solves."""
    base = str(leaf.get("base_leaf", 32))
    others = [str(x) for x in leaf["leaf_sizes"] if str(x) != base]
    md = ["## Leaf size (paired against 32)", "",
          f"`bench/calibration/leaf_size.py`, `{leaf['mode']}` mode, {leaf['date']}, "
          f"{core_line(leaf.get('core'))}: each FMM setting the automatic mode can choose, "
          f"solved with leaves of {', '.join(str(x) for x in leaf['leaf_sizes'])} surfels one "
          f"after the other on the same surfels, at the sweep's sizes, on samplings "
          f"{leaf['seeds']} (the grid has one).{runs_line(leaf)} Error ratio: the worst over "
          "sizes and samplings "
          "of error(leaf) / error(32) (against the reference; without visibility, the FMM's "
          "error against the direct solution), what `bench/calibration/calibrate.py` keeps as the "
          "variant's error factor; time ratio: the median at the smallest and the largest "
          "size. Smaller leaves move node pairs from the near field, where visibility is per "
          "pair, to the far field, where it is classified per node pair.", "",
          "| scene | setting | sizes | " + " | ".join(
              f"leaf {x}: worst error ratio | time ratio (small → large N)" for x in others)
          + " |", "|---|---|---|" + "---|---|" * len(others)]
    for scene, data in leaf["scenes"].items():
        labels = []
        for r in data["rows"]:
            if r["label"] not in labels:
                labels.append(r["label"])
        for label in labels:
            rows = [r for r in data["rows"] if r["label"] == label]
            fit = calibrate.fit_leaf_variants(rows, data["reference"]["check"], int(base))
            cells = []
            for x in others:
                ratios = fit[x]["time_ratio"]
                cells += [f"{fit[x]['error_factor']:.2f}",
                          f"{ratios[0][1]:.2f} → {ratios[-1][1]:.2f}"]
            n_lo, n_hi = min(r["n"] for r in rows), max(r["n"] for r in rows)
            md.append(f"| {scene} | {label} | {n_lo}–{n_hi} | " + " | ".join(cells) + " |")
    return md + [""]


def sampling_section(spread):
    """docs/benchmarks.md's sampling section from bench/calibration/sampling_spread.py, with the factors
    bench/calibration/calibrate.py fits (against the calibration in use)."""
    md = ["## Sampling spread (the automatic mode's sampling factors)", "",
          f"`bench/calibration/sampling_spread.py`, `{spread['mode']}` mode, {spread['date']}, "
          f"{core_line(spread.get('core'))}: `{spread['setting']}` (its error is the "
          f"discretization's) solved on samplings {spread['seeds']}, kept out of the "
          f"calibration and of the automatic mode's benchmark, at three or four sizes per "
          f"scene.{runs_line(spread)} "
          "Ratio: error over the calibrated model at that N. The factor `bench/calibration/calibrate.py` "
          f"keeps is exp(mean + {accuracy.SAMPLING_Z:g}·sd) of the log ratios, sd pooled over "
          "the sizes, never below 1 nor below the largest ratio seen; the automatic mode "
          "scales its predictions by it.", "",
          "| scene | N | errors (min – median – max) | ratio to the model (min – max) | "
          "factor |", "|---|---|---|---|---|"]
    for scene, data in spread["scenes"].items():
        table = calibration.CALIBRATION["kinds"].get(S.KIND[scene], {})
        fit = calibrate.fit_sampling(data["rows"], table) if table.get("scene") == scene \
            else None
        factors = dict((n, f) for n, f in (fit or {}).get("points", []))
        ratios_by_size = calibrate.sampling_ratios(data["rows"], table) if table else {}
        by_size = {}
        for r in data["rows"]:
            by_size.setdefault(r["size"], []).append(r)
        for size, rows in sorted(by_size.items()):
            errs = sorted(r["error"] for r in rows)
            ratios = [x for _, x in ratios_by_size.get(size, [])] or [float("nan")]
            n = int(round(float(np.mean([r["n"] for r in rows]))))
            f = factors.get(n)
            md.append(f"| {scene} | {n} | {fmt_pct(errs[0])} – "
                      f"{fmt_pct(float(np.median(errs)))} – {fmt_pct(errs[-1])} | "
                      f"{min(ratios):.2f} – {max(ratios):.2f} | "
                      f"{'–' if f is None else f'{f:.2f}'} |")
    return md + [""]



def cpu_slope(points, key):
    """Least-squares log-log slope of points' `key` against N over N >= 100k (None if < 2)."""
    ok = [p for p in points if p.get(key) and p["n"] >= 100_000]
    if len(ok) < 2:
        return None
    return float(np.polyfit(np.log([p["n"] for p in ok]), np.log([p[key] for p in ok]), 1)[0])


def scaling_exact_section(ex):
    """The scaling section's paired before/after runs of one case (scaling_exact_1m.json)."""
    f2 = lambda x: "–" if x is None else f"{x:.2f}"  # noqa: E731
    md = [f"### {ex['case']} from 100k to 1M, paired runs", "", ex["note"], "",
          f"Command: `{ex['command']}`.", "",
          "| run | core | N | build | build CPU | total | total CPU | iterations | peak RSS |",
          "|---|---|---|---|---|---|---|---|---|"]
    for r in ex["runs"]:
        for p in r["points"]:
            md.append(f"| {r['label']} ({r['date']}) | `{r['core_commit']}` | {p['n']} | "
                      f"{fmt_time(p['build'])} | {fmt_time(p['build_cpu'])} | "
                      f"{fmt_time(p['total'])} | {fmt_time(p['total_cpu'])} | "
                      f"{p['iterations']} | {p['peak_rss'] / 2 ** 20:.0f} MiB |")
    md += ["", "| run | time slope | build slope | solve slope | total CPU slope | "
           "build CPU slope |", "|---|---|---|---|---|---|"]
    for r in ex["runs"]:
        s = r["slopes"]
        md.append(f"| {r['label']} ({r['date']}) | {f2(s['time'])} | {f2(s['build'])} | "
                  f"{f2(s['solve'])} | {f2(cpu_slope(r['points'], 'total_cpu'))} | "
                  f"{f2(cpu_slope(r['points'], 'build_cpu'))} |")
    md += [""] + [ex["findings"], ""] if ex.get("findings") else [""]
    return md


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
    md = ["# Benchmarks: speed against accuracy", "",
          "Generated by `bench/charts.py` from `bench/results/*.json` (regenerate everything "
          "with `.venv/bin/python bench/run_all.py --quick|--full`; see bench/README.md). "
          "Times are wall times on this machine (2 cores shared with other jobs, so noisy); "
          "compare ratios measured within one run. Error = relative RMS per surfel over "
          "non-emitting surfels (a random subset of up to 1200 per point; 4000 for the automatic "
          "mode in full mode), against a converged "
          "reference: the direct O(N²) operator with exact visibility at high density, "
          "gathered at each setting's own surfels with exact visibility.", ""]
    note = os.path.join(args.results, "NOTE.md")
    if os.path.exists(note):
        with open(note) as f:
            md += [f.read().strip(), ""]
    if acc:
        md += [f"Accuracy/speed run: `{acc['mode']}` mode, {acc['date']}, "
               f"{core_line(acc.get('core'))}. Solve tolerance {acc['solve_tol']:g}. "
               f"Visibility modes: {', '.join(acc['visibilities'])}"
               + ("; not available: " + ", ".join(acc["unavailable"]) if acc["unavailable"]
                  else "") + f"; exact visibility with `{acc.get('exact_keywords')}`."
               + runs_line(acc)
               + (f" Sweep times re-timed {acc['retimed']['date']} by bench/calibration/retime.py "
                  f"({acc['retimed']['points']} points, {core_line(acc['retimed'].get('core'))};"
                  f" errors from the sweep)." if acc.get("retimed") else "")
               + (f" Automatic mode re-run {acc['auto_date']}, {core_line(acc.get('auto_core'))}."
                  if acc.get("auto_date") else "") + auto_runs_line(acc), ""]
        for scene, data in acc["scenes"].items():
            png = f"accuracy_{scene}.png"
            accuracy_chart(scene, data, cyc, os.path.join(args.images, png))
            ref = data["reference"]
            md += [f"## {SCENE_TITLES.get(scene, scene)}", "",
                   f"![error against time, {scene}]({rel}/{png})", "",
                   f"Reference: direct, exact visibility, N={ref['n']}, {ref['iterations']} CG "
                   f"iterations, {ref['time']:.1f} s. Check: a second reference at half the "
                   f"density (N={ref['half_n']}, another sampling) differs from it by "
                   f"**{fmt_pct(ref['check'])}**; with error ∝ N^-a the reference's own error "
                   f"is that over (2^a − 1): {fmt_pct(ref['check'])} (a = 1) to "
                   f"{fmt_pct(ref['floor'])} (a = ½). Errors below the check are not resolved.",
                   ""]
            hand = [p for p in data["points"] if p["family"] != "auto"]
            cy_pts = None
            if scene == "cornell" and cyc:
                cy_pts = [p for p in cyc["points"] if p["tool"] == "cycles"]
            md += [pareto_table(hand, cy_pts, ref["check"],
                                "Cycles at equal error (any vertex count, other run)"
                                if cy_pts else "Cycles at equal error"), ""]
            if scene == "cornell" and cyc:
                md += ["Cycles here: the fastest bake within the error at any vertex count, from "
                       "`bench/reference/cycles_bake.py`, against Illumap's times from "
                       "`bench/calibration/accuracy_speed.py` (two runs, different vertex sets: Cycles at 371 "
                       "vertices has no discretization error, Illumap's 371 surfels do). The "
                       "comparison the target asks for — same run, same vertices — is the "
                       "Cycles section below.", ""]
            at = auto_table(data["points"])
            auto_ref = data.get("auto_reference")
            if at and auto_ref and auto_ref["n"] != ref["n"]:
                md += [f"The automatic mode's rows below are measured against another "
                       f"reference than the sweep above: N={auto_ref['n']}, whose check "
                       f"against N={auto_ref['half_n']} is **{100 * auto_ref['check']:.2f}%** "
                       f"(the hand-picked points keep the sweep's errors; the best on the "
                       f"automatic mode's samplings is measured against this one).", ""]
            if at:
                if scene == "cornell_mesh":
                    md += ["Automatic mode on the triangles (`illumap.accuracy.solve_triangles`, "
                           "timed whole: sampling, both passes): *adaptive* solves half the "
                           "chosen count, then resamples the full count denser where that "
                           "solution varies and solves again; *uniform* is one pass of the "
                           "chosen count; two passes run only where the models predict them "
                           f"at most {accuracy.ADAPTIVE_TIME_MARGIN:g} of one pass's time "
                           "(`ADAPTIVE_TIME_MARGIN`), or where "
                           "a budget caps the count. The best hand-picked setting is that of "
                           "this sweep (uniform stratified surfels), timed in rounds "
                           "alternating with the automatic mode as below:", "", at, ""]
                else:
                    md += ["Automatic mode (`illumap.accuracy`): the density is chosen for the "
                           "target, the scene sampled at it, then `accuracy.solve` (settings, "
                           "occlusion probe where it can matter, solve) is timed. It runs "
                           "on three other samplings of the scene (seeds 1, 3, 5; the grid "
                           "has one) than those that calibrated it; its error column gives "
                           "seed 1's and the worst, the ratios are timed on seed 1. *Best "
                           "hand-picked* (leaf sizes of bench/calibration/leaf_size.py included): the "
                           "fastest sweep point within the target; *steady*: the fastest whose setting stays within it at "
                           "every larger density swept; *on the automatic mode's samplings too*: "
                           "the fastest that stays within it when the scene is sampled at the "
                           "same size with each of the automatic mode's seeds, its error "
                           "measured on as many points (the sweep's error, then the worst of "
                           "those, shown): the same test the automatic mode is held to. Each "
                           "is re-timed in the same process in rounds alternating with the "
                           "automatic mode (the least of as many rounds as fit in about 6 s, 5 to 15; "
                           "the automatic mode's time from those rounds in brackets), and "
                           "the ratio is of those two times. *Within its aim*: the same "
                           "test at the error the automatic mode aims for "
                           "(`illumap.accuracy.SAFETY` × target), the cheapest setting "
                           "it could pick with its margin and a perfect model:", "", at, ""]
    leaf = load(os.path.join(args.results, "leaf_size.json"))
    if leaf:
        md += leaf_section(leaf)
    spread = load(os.path.join(args.results, "sampling_spread.json"))
    if spread:
        md += sampling_section(spread)
    if cyc:
        cycles_chart(cyc, os.path.join(args.images, "cycles_bake.png"))
        il = [p for p in cyc["points"] if p["tool"] == "illumap"]
        cy = [p for p in cyc["points"] if p["tool"] == "cycles"]
        top = max(cy, key=lambda p: (p["samples"], -p["n"])) if cy else None
        md += ["## Cornell box: Illumap against Cycles on the same vertices (one run)", "",
               f"![Cornell box against Cycles]({rel}/cycles_bake.png)", "",
               f"Blender {cyc['blender']}, Cycles CPU, 64 diffuse bounces, no clamping; "
               "`bpy.ops.object.bake(type='DIFFUSE', pass_filter={'DIRECT','INDIRECT'}, "
               "target='VERTEX_COLORS')`, outgoing = albedo × baked. Illumap and Cycles are "
               f"timed in the same process, on the same vertices ({cyc['date']}, "
               f"{core_line(cyc.get('core'))}). Errors on the same random subset of vertices "
               "against the reference above.", ""]
        if top:
            md += [f"Cross-check of the reference: Cycles at {top['samples']} samples per "
                   f"vertex (N={top['n']}), which integrates the true geometry, differs from it "
                   f"by {fmt_pct(top['error'])}.", ""]
        md += ["On the same vertices (each grid apart: the target's comparison):", "",
               same_vertices_table(il, cy), "",
               "At any vertex count (the fastest of each tool over all grids; Cycles integrates "
               "the true geometry at its vertices, so few vertices cost it nothing in accuracy, "
               "while Illumap's surfels are its discretization):", "",
               pareto_table(il, cy), "", "| N | setting | time | error |", "|---|---|---|---|"]
        md += [f"| {p['n']} | {p['label']} | {fmt_time(p['time'])} | {fmt_pct(p['error'])} |"
               for p in sorted(cyc["points"], key=lambda p: (p["n"], p["tool"], p["time"]))]
        md += [""]
    if sca:
        scaling_chart(sca, os.path.join(args.images, "scaling.png"))
        md += ["## Scaling", "", f"![scaling]({rel}/scaling.png)", "",
               f"FMM p={sca['order']}, θ={sca['theta']}, CG to {sca['tol']:g}; each size in its "
               f"own process (peak RSS is the process's); {sca['date']}, "
               f"{core_line(sca.get('core'))}. Fitted log–log slopes (N ≥ "
               f"{sca.get('fit_min_n', 100000) // 1000}k). Exact visibility: `exact-mesh` "
               "occludes with the box's own mesh (10,368 triangles, `scenes.cornell_surface`), "
               "as the add-on does for a scene of meshes or point clouds (their splats); "
               "`exact` with discs made from the surfels, the core's default when no "
               "triangles are given:", "",
               "| case | time slope | build slope | solve slope | memory slope | largest N |",
               "|---|---|---|---|---|---|"]
        f2 = lambda x: "–" if x is None else f"{x:.2f}"  # noqa: E731
        for key, s in sca["slopes"].items():
            md.append(f"| {key} | {f2(s['time'])} | {f2(s.get('build'))} | "
                      f"{f2(s.get('solve'))} | {f2(s['memory'])} | {s['largest']} |")
        md += ["", "| case | N | build | total | iterations | peak RSS | core commit, run |",
               "|---|---|---|---|---|---|---|"]
        for p in sca["points"]:
            key = f"{p.get('scene')}/{p['method']}/{p.get('visibility')}"
            run = f"`{p['commit']}`, {p.get('date', '')}" if p.get("commit") else "–"
            if "error" in p:
                md.append(f"| {key} | {p['n']} | – | {p['error']} | – | – | {run} |")
            else:
                md.append(f"| {key} | {p['n']} | {fmt_time(p['build'])} | "
                          f"{fmt_time(p['total'])} | {p['iterations']} | "
                          f"{p['peak_rss'] / 2 ** 20:.0f} MiB | {run} |")
        md += [""]
        ex = load(os.path.join(args.results, "scaling_exact_1m.json"))
        if ex:
            md += scaling_exact_section(ex)
    md += ["## Data", "",
           "The Stanford Bunny: Stanford 3D Scanning Repository, Stanford University Computer "
           "Graphics Laboratory (Greg Turk and Marc Levoy, 1994); used here only as benchmark "
           "data, kept outside the extension.", ""]
    with open(args.doc, "w") as f:
        f.write("\n".join(md))
    print(f"wrote {args.doc} and charts in {args.images}")


if __name__ == "__main__":
    main()
