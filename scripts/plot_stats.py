#!/usr/bin/python3
"""Plots a run's stats.csv: per-frame timing breakdown, contact violations, halted vertices.

A fourth panel shows min_distance (with the offset xi from run.json) when the column holds values.

Usage: plot_stats.py RUN_DIR_OR_STATS_CSV [--out PNG] [--title TEXT]

Writes RUN_DIR/stats.png by default (next to stats.csv). Works on every stats.csv ccfr writes,
including runs cut short: a header without rows, a single row, a truncated last line, empty
fields (min_distance is empty when no pair was in range) and missing optional columns.
Uses Debian's python3-matplotlib only (no pip). Exit codes: 0 written, 2 bad input.
"""
import argparse
import csv
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")  # files only, no display needed
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ccfr_plot_common import TIMING, parse_float  # noqa: E402





def read_stats(path):
    """Returns (header, columns) with columns[name] = list of floats (NaN where missing)."""
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r and any(c.strip() for c in r)]
    if not rows:
        return [], {}
    header = [h.strip() for h in rows[0]]
    columns = {h: [] for h in header}
    for r in rows[1:]:
        # A row cut short by a crash is padded; extra fields are ignored.
        r = list(r) + [""] * (len(header) - len(r))
        for h, cell in zip(header, r):
            columns[h].append(parse_float(cell.strip()))
    return header, columns


def frame_axis(columns):
    n = max((len(v) for v in columns.values()), default=0)
    frames = columns.get("frame")
    if frames and not all(math.isnan(x) for x in frames):
        return [x if not math.isnan(x) else i for i, x in enumerate(frames)]
    return list(range(n))


def note(ax, text):
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", color="0.4")


def nan_to_zero(values):
    return [0.0 if math.isnan(v) else v for v in values]


def plot_timing(ax, frames, columns):
    present = [(c, label, color) for c, label, color in TIMING if c in columns]
    ax.set_ylabel("time per frame [ms]")
    ax.set_title("Timing breakdown")
    if not frames:
        note(ax, "no frames recorded")
        return
    if not present:
        note(ax, "no timing columns (xpbd_s, broad_s, narrow_s, resolution_s)")
        return
    bottom = [0.0] * len(frames)
    few = len(frames) <= 120
    for c, label, color in present:
        ms = [1000.0 * v for v in nan_to_zero(columns[c])]
        if few:
            ax.bar(frames, ms, bottom=bottom, color=color, label=label, width=0.85, linewidth=0)
        else:
            top = [b + v for b, v in zip(bottom, ms)]
            ax.fill_between(frames, bottom, top, color=color, label=label, linewidth=0, step="mid")
        bottom = [b + v for b, v in zip(bottom, ms)]
    top = max(bottom, default=0.0)
    if "wall_s" in columns:
        # What the stages do not account for (I/O, audit, bookkeeping) shows as the gap to the wall time.
        wall = [1000.0 * v for v in columns["wall_s"]]
        if any(not math.isnan(v) for v in wall):
            ax.plot(frames, wall, color="0.2", linewidth=1.0, marker="." if few else None, label="wall clock")
            top = max([top] + [v for v in wall if not math.isnan(v)])
    ax.legend(loc="upper left", fontsize=8, ncol=5)
    # Head room for the legend above the data.
    ax.set_ylim(0, 1.3 * top if top > 0 else 1.0)


def plot_violations(ax, frames, columns):
    ax.set_title("Contact violations per frame")
    ax.set_ylabel("vertices")
    if not frames:
        note(ax, "no frames recorded")
        return
    drew = False
    for c, label, color, style in [
        ("violations_detected", "detected (left their region)", "#dd8452", "-"),
        ("violations_remaining", "remaining after the solver", "#c44e52", "--"),
    ]:
        if c in columns:
            ax.plot(frames, columns[c], style, color=color, label=label, marker="." if len(frames) <= 120 else None)
            drew = True
    if not drew:
        note(ax, "no violations_detected / violations_remaining columns")
        return
    ax.legend(loc="upper left", fontsize=8, ncol=2)
    values = [v for c in ("violations_detected", "violations_remaining") for v in columns.get(c, []) if not math.isnan(v)]
    top = max(values, default=0.0)
    ax.set_ylim(0, 1.3 * top if top > 0 else 1.0)


def plot_halted(ax, frames, columns):
    ax.set_title("Halted vertices (projection fallbacks) per frame")
    ax.set_ylabel("vertices")
    if not frames:
        note(ax, "no frames recorded")
        return
    if "halted_vertices" not in columns:
        note(ax, "no halted_vertices column")
        return
    ax.bar(frames, nan_to_zero(columns["halted_vertices"]), color="#8172b3", width=0.85, linewidth=0)
    ax.set_ylim(bottom=0)


def run_offset(csv_path):
    """The contact offset xi from run.json next to stats.csv, or None."""
    try:
        with open(os.path.join(os.path.dirname(os.path.abspath(csv_path)), "run.json")) as f:
            v = float(json.load(f).get("offset", "nan"))
        return v if math.isfinite(v) and v > 0 else None
    except (OSError, ValueError, TypeError, AttributeError):
        return None


def plot_min_distance(ax, frames, columns, offset):
    ax.set_title("Minimum distance between primitives")
    ax.set_ylabel("distance")
    ax.plot(frames, columns["min_distance"], color="#4c72b0", marker="." if len(frames) <= 120 else None,
            label="min distance (empty cells: no pair in range)")
    if offset is not None:
        ax.axhline(offset, color="#c44e52", linestyle="--", linewidth=1, label=f"offset ξ = {offset:g}")
    ax.legend(loc="upper left", fontsize=8, ncol=2)
    top = max([v for v in columns["min_distance"] if not math.isnan(v)] + [offset or 0.0])
    ax.set_ylim(0, 1.4 * top if top > 0 else 1.0)


def run_scene(csv_path):
    """The scene name and solver from run.json next to stats.csv ("twisting_cloth, solver ccfr"), or None."""
    try:
        with open(os.path.join(os.path.dirname(os.path.abspath(csv_path)), "run.json")) as f:
            meta = json.load(f)
        scene, solver = meta.get("scene"), meta.get("solver")
    except (OSError, ValueError, AttributeError):
        return None
    if not scene:
        return None
    return f"{scene}, solver {solver}" if solver else str(scene)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("path", help="run directory holding stats.csv, or the CSV file itself")
    p.add_argument("--out", help="output PNG (default: stats.png next to stats.csv)")
    p.add_argument("--title", help="figure title (default: the scene and solver from run.json, else the run directory's name)")
    a = p.parse_args(argv)

    csv_path = os.path.join(a.path, "stats.csv") if os.path.isdir(a.path) else a.path
    if not os.path.isfile(csv_path):
        print(f"error: '{csv_path}' does not exist", file=sys.stderr)
        return 2
    try:
        header, columns = read_stats(csv_path)
    except (OSError, csv.Error, UnicodeDecodeError) as e:
        print(f"error: cannot read '{csv_path}': {e}", file=sys.stderr)
        return 2
    frames = frame_axis(columns)
    out = a.out or os.path.join(os.path.dirname(os.path.abspath(csv_path)), "stats.png")
    title = a.title or run_scene(csv_path) or os.path.basename(os.path.dirname(os.path.abspath(csv_path)))

    # A fourth panel when distances were measured: the guarantee is min distance >= xi.
    has_distance = any(not math.isnan(v) for v in columns.get("min_distance", []))
    panels = 4 if has_distance else 3
    fig, axes = plt.subplots(panels, 1, figsize=(10, 3 * panels), sharex=True, constrained_layout=True)
    plot_timing(axes[0], frames, columns)
    plot_violations(axes[1], frames, columns)
    plot_halted(axes[2], frames, columns)
    if has_distance:
        plot_min_distance(axes[3], frames, columns, run_offset(csv_path))
    axes[-1].set_xlabel("frame")
    if not header:
        note(axes[0], "empty stats.csv")
    fig.suptitle(f"{title}: {len(frames)} frame{'s' if len(frames) != 1 else ''}")
    try:
        fig.savefig(out, dpi=110)
    except OSError as e:
        print(f"error: cannot write '{out}': {e}", file=sys.stderr)
        return 2
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
