#!/usr/bin/python3
"""Plots DIR/ablation.csv (one row per contact solver) as DIR/ablation.png.

Usage: plot_ablation.py DIR [--out PNG] [--title TEXT]

The title names the scene (from the solver runs' run.json); count panels switch to a log scale
when the counts span more than two decades, each bar carries its count, legends sit outside.

Panels: mean time per frame split into XPBD / broad / narrow / resolution (with the maximum
frame time as a marker), violations detected vs remaining, halted vertices, and the minimum
distance over the offset xi (below 1 means a pair ended closer than xi) with the audit verdict.
Missing columns and empty cells are tolerated. Uses Debian's python3-matplotlib only.
Exit codes: 0 written, 2 bad input.
"""
import argparse
import csv
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ccfr_plot_common import TIMING, parse_float  # noqa: E402

num = parse_float





def read_rows(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        rows = [{(k or "").strip(): (v or "").strip() for k, v in r.items()} for r in reader]
        header = [h.strip() for h in (reader.fieldnames or [])]
    return header, [r for r in rows if any(r.values())]


def labels_for(rows):
    """Solver names, prefixed with the scene when several scenes share the table."""
    scenes = {r.get("scene", "") for r in rows}
    out = []
    for i, r in enumerate(rows):
        name = r.get("solver") or f"row {i + 1}"
        if len(scenes) > 1:
            name = f"{r.get('scene', '')}\n{name}"
        out.append(name)
    return out


def audit_verdict(text):
    """(label, colour) of an audit cell: 'pass'/'clean'/'ok'/0 penetrations is green."""
    t = (text or "").strip().lower()
    if not t:
        return "", "0.6"
    v = num(t)
    if not math.isnan(v):
        return ("clean", "#55a868") if v == 0 else (f"{t} penetrating", "#c44e52")
    if t in ("pass", "passed", "clean", "ok", "true", "yes"):
        return t, "#55a868"
    if t in ("fail", "failed", "penetration", "penetrations", "false", "no"):
        return t, "#c44e52"
    return t, "0.5"


def scene_name(directory, rows):
    """The scene of the ablation: the `scene` of a solver run's run.json (ccfr ablate writes one
    sub-directory per solver), else the `scene` column, else the directory's name."""
    for r in rows:
        run_json = os.path.join(directory, r.get("solver", ""), "run.json")
        try:
            with open(run_json) as f:
                scene = json.load(f).get("scene")
            if scene:
                return str(scene)
        except (OSError, ValueError, AttributeError):
            pass
    scenes = sorted({r.get("scene", "") for r in rows} - {""})
    return ", ".join(scenes) if scenes else os.path.basename(directory)


def count_axis(ax, bars_values):
    """Counts spanning more than two decades (ccfr's 7 halts beside toi_clamp's 36,375) go on a
    symmetric log axis, so that small nonzero counts stay visible next to zeros."""
    positive = [v for v in bars_values if v > 0]
    if positive and max(positive) / min(positive) >= 100:
        ax.set_yscale("symlog", linthresh=1)
        ax.set_ylim(0, 3 * max(positive))
        ax.set_ylabel(ax.get_ylabel() + " (log scale)")


def label_bars(ax, bars):
    """Each bar's count as an integer above it (a zero is a label, not an invisible bar)."""
    ax.bar_label(bars, labels=[f"{int(round(b.get_height())):,}" for b in bars], fontsize=7, padding=2)


def legend_outside(ax):
    """The legend to the right of the axes, never over the bars."""
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


def note(ax, text):
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", color="0.4")


def col(rows, name):
    return [num(r.get(name, "")) for r in rows]


def z(values):
    return [0.0 if math.isnan(v) else v for v in values]


def plot_per_frame(ax_r, ax_a, rows):
    """Per frame and solver: violations left at the end of substeps, and what the audit found."""
    solvers = []
    for r in rows:
        if r.get("solver") not in solvers:
            solvers.append(r.get("solver"))
    for ax, column, title in ((ax_r, "violations_remaining", "Violations remaining per frame (solver's recount)"),
                              (ax_a, "audit_penetrations", "Audit penetrations per frame (exact)")):
        ax.set_title(title)
        ax.set_xlabel("frame")
        drawn = False
        for name in solvers:
            pts = [(num(r.get("frame", "")), num(r.get(column, ""))) for r in rows if r.get("solver") == name]
            pts = [(f, v) for f, v in pts if not math.isnan(f) and not math.isnan(v)]
            if pts:
                ax.plot([f for f, _ in pts], [v for _, v in pts], label=name, linewidth=1.2)
                drawn = drawn or any(v > 0 for _, v in pts)
        if drawn:
            ax.set_yscale("symlog", linthresh=1)
        else:
            note(ax, "none in any frame")
        legend_outside(ax)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("dir", help="ablation output directory holding ablation.csv (or the CSV itself)")
    p.add_argument("--out", help="output PNG (default: DIR/ablation.png)")
    p.add_argument("--title", help="figure title")
    a = p.parse_args(argv)

    path = os.path.join(a.dir, "ablation.csv") if os.path.isdir(a.dir) else a.dir
    if not os.path.isfile(path):
        print(f"error: '{path}' does not exist", file=sys.stderr)
        return 2
    try:
        header, rows = read_rows(path)
    except (OSError, csv.Error, UnicodeDecodeError) as e:
        print(f"error: cannot read '{path}': {e}", file=sys.stderr)
        return 2
    out = a.out or os.path.join(os.path.dirname(os.path.abspath(path)), "ablation.png")
    labels = labels_for(rows)
    x = list(range(len(rows)))

    frames_path = os.path.join(os.path.dirname(os.path.abspath(path)), "ablation_frames.csv")
    per_frame = read_rows(frames_path)[1] if os.path.isfile(frames_path) else []
    fig, axes = plt.subplots(3 if per_frame else 2, 2, figsize=(12, 12 if per_frame else 8), constrained_layout=True)
    ax_t, ax_v, ax_h, ax_d = axes[0][0], axes[0][1], axes[1][0], axes[1][1]
    if per_frame:
        plot_per_frame(axes[2][0], axes[2][1], per_frame)

    ax_t.set_title("Mean time per frame")
    ax_t.set_ylabel("ms")
    present = [(c, lab, colr) for c, lab, colr in TIMING if c in header]
    if not rows:
        note(ax_t, "no solvers in ablation.csv")
    elif present:
        bottom = [0.0] * len(rows)
        for c, lab, colr in present:
            ms = [1000.0 * v for v in z(col(rows, c))]
            ax_t.bar(x, ms, bottom=bottom, color=colr, label=lab, width=0.6)
            bottom = [b + v for b, v in zip(bottom, ms)]
        if "avg_frame_s" in header:
            ax_t.scatter(x, [1000.0 * v for v in col(rows, "avg_frame_s")], color="0.15", marker="_", s=400,
                         label="mean frame (wall)", zorder=3)
        if "max_frame_s" in header:
            ax_t.scatter(x, [1000.0 * v for v in col(rows, "max_frame_s")], color="0.15", marker="v", s=30,
                         label="slowest frame", zorder=3)
        legend_outside(ax_t)
    elif "avg_frame_s" in header:
        ax_t.bar(x, [1000.0 * v for v in z(col(rows, "avg_frame_s"))], color="0.5", width=0.6)
    else:
        note(ax_t, "no timing columns")

    ax_v.set_title("Violations (summed over frames)")
    ax_v.set_ylabel("vertices")
    have = [c for c in ("violations_detected", "violations_remaining") if c in header]
    if rows and have:
        w = 0.8 / len(have)
        for k, (c, colr) in enumerate(zip(have, ["#dd8452", "#c44e52"])):
            bars = ax_v.bar([i + (k - (len(have) - 1) / 2) * w for i in x], z(col(rows, c)), width=w, color=colr,
                            label=c.replace("violations_", ""))
            label_bars(ax_v, bars)
        legend_outside(ax_v)
        count_axis(ax_v, [v for c in have for v in z(col(rows, c))])
    else:
        note(ax_v, "no violation columns" if rows else "no solvers")

    ax_h.set_title("Halted vertices (projection fallbacks)")
    ax_h.set_ylabel("vertices")
    if rows and "halted_vertices" in header:
        halted = z(col(rows, "halted_vertices"))
        label_bars(ax_h, ax_h.bar(x, halted, color="#8172b3", width=0.6))
        count_axis(ax_h, halted)
    else:
        note(ax_h, "no halted_vertices column" if rows else "no solvers")

    ax_d.set_title("Minimum distance / offset ξ, audit verdict")
    if rows and "min_distance_over_offset" in header:
        ratio = col(rows, "min_distance_over_offset")
        colors = ["#55a868" if (not math.isnan(v) and v >= 1.0 - 1e-6) else "#c44e52" for v in ratio]
        ax_d.bar(x, z(ratio), color=colors, width=0.6)
        ax_d.axhline(1.0, color="0.2", linestyle="--", linewidth=1)
        top = max([v for v in ratio if not math.isnan(v)] + [1.0])
        ax_d.set_ylim(0, 1.25 * top)
        for i, r in enumerate(rows):
            label, colr = audit_verdict(r.get("audit", ""))
            if label:
                ax_d.text(i, 1.1 * top, label, ha="center", va="bottom", fontsize=8, color=colr)
    else:
        note(ax_d, "no min_distance_over_offset column" if rows else "no solvers")

    for ax in (ax_t, ax_v, ax_h, ax_d):
        ax.set_xticks(x)
        ax.set_xticklabels(labels, rotation=20 if len(rows) > 4 else 0, fontsize=8)
    directory = os.path.dirname(os.path.abspath(path))
    fig.suptitle(a.title or f"Ablation of scene '{scene_name(directory, rows)}': {len(rows)} contact solvers")
    try:
        fig.savefig(out, dpi=110)
    except OSError as e:
        print(f"error: cannot write '{out}': {e}", file=sys.stderr)
        return 2
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
