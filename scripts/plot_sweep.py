#!/usr/bin/env python3
"""Plots a metric of DIR/sweep.csv (`ccfr sweep collect`) against a swept parameter, one line per
contact solver and one panel per scene, as DIR/sweep_<metric>.png.

Usage: plot_sweep.py DIR/sweep.csv --metric avg_frame_s --against contact.offset [--out PNG]
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def number(s):
    try:
        return float(s)
    except ValueError:
        return None


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("csv", help="sweep.csv written by ccfr sweep collect")
    p.add_argument("--metric", default="avg_frame_s", help="column to plot (default avg_frame_s)")
    p.add_argument("--against", required=True, help="swept parameter (a column of sweep.csv)")
    p.add_argument("--out", help="output PNG (default: next to the CSV, sweep_<metric>.png)")
    a = p.parse_args()
    with open(a.csv, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit("plot_sweep: %s has no cells" % a.csv)
    for col in (a.metric, a.against):
        if col not in rows[0]:
            sys.exit("plot_sweep: no column '%s' in %s; columns: %s" % (col, a.csv, ", ".join(rows[0])))
    scenes = sorted({r["scene"] for r in rows})
    fig, axes = plt.subplots(1, len(scenes), figsize=(5 * len(scenes), 3.8), squeeze=False)
    for ax, scene in zip(axes[0], scenes):
        lines = {}
        for r in rows:
            if r["scene"] != scene:
                continue
            x, y = number(r[a.against]), number(r[a.metric])
            if x is not None and y is not None:
                lines.setdefault(r["solver"], []).append((x, y))
        for solver, pts in sorted(lines.items()):
            pts.sort()
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=solver)
        ax.set_title(scene)
        ax.set_xlabel(a.against)
        ax.set_ylabel(a.metric)
        ax.grid(alpha=0.3)
        if lines:
            ax.legend(fontsize=8)
    fig.tight_layout()
    out = a.out or os.path.join(os.path.dirname(os.path.abspath(a.csv)), "sweep_%s.png" % a.metric)
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
