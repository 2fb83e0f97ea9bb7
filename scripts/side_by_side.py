#!/usr/bin/python3
"""Two renders of the same frame side by side, each titled with its run's audit verdict.

Usage: side_by_side.py --run DIR_A IMAGE_A --run DIR_B IMAGE_B --frame N --out PNG [--title TEXT]

Each DIR holds run.json (the solver's name) and audit.json (written by `ccfr audit`); the panel
title gives the solver, the verdict over the whole run, and what the audit found in frame N.
Uses Debian's python3-matplotlib only. Exit codes: 0 written, 2 bad input.
"""
import argparse
import json
import os
import sys
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402


def load(path):
    with open(path) as f:
        return json.load(f)


def wrap_caption(text, width_px, fontsize=10, dpi=100):
    """TEXT with each line wrapped to a panel WIDTH_PX wide, so neighbouring titles do not overlap
    (a character of DejaVu Sans is about 0.6 em wide on average)."""
    chars = max(20, int(width_px / (0.6 * fontsize * dpi / 72)))
    return "\n".join(textwrap.fill(line, chars) for line in text.split("\n"))


def why_partial(status):
    """Why a run holds fewer frames than its scene asks for, from run.json's status (ccfr's wording)."""
    status = str(status or "")
    if status.startswith("failed"):
        return "run stopped by its error"
    if status.startswith("stopped at its time limit"):
        return "run stopped at its time limit"
    if status.startswith(("interrupted", "terminated", "killed")):
        return "run interrupted"
    return "run not finished"  # still running, or a status this script does not know


def caption(run_dir, frame):
    """(title, colour) of one panel from run.json and audit.json."""
    run = load(os.path.join(run_dir, "run.json"))
    audit = load(os.path.join(run_dir, "audit.json"))
    solver = run.get("solver", os.path.basename(run_dir))
    verdict = str(audit.get("verdict", "?")).upper()
    checked = audit.get("frames_checked", "?")
    if verdict == "PASS" and audit.get("min_distance") is None:
        whole = f"audit PASS: {checked} frames, no pair within range"  # nothing came near (free fall)
    elif verdict == "PASS":
        whole = f"audit PASS: {checked} frames, min distance {audit['min_distance'] / audit['offset']:.3f} ξ"
    elif verdict == "INCOMPLETE" and audit.get("violations") == 0:
        # a partial run: every frame it wrote is clean, but the run is not whole; say why it is partial
        whole = f"audit INCOMPLETE ({why_partial(run.get('status'))}): {checked} frames clean"
        if audit.get("min_distance") is not None and audit.get("offset"):
            whole += f", min {audit['min_distance'] / audit['offset']:.3f} ξ"
    else:
        whole = (f"audit {verdict}: {audit.get('violations', '?'):,} violations in {audit.get('bad_frames', '?')} of "
                 f"{checked} frames (first: frame {audit.get('first_bad_frame')})")
    row = next((r for r in audit.get("frames", []) if r.get("frame") == frame), None)
    if row is None:
        here = f"frame {frame} not audited"
    else:
        found = [(row.get("triangle_intersections", 0), "triangle intersections"),
                 (row.get("segment_crossings", 0), "segment crossings"),
                 (row.get("close_pairs", 0), "pairs closer than ξ")]
        bad = [f"{n:,} {what}" for n, what in found if n]
        here = f"frame {frame}: " + (", ".join(bad) if bad else "clean")
        if row.get("min_distance") is not None and audit.get("offset"):
            here += f"\nclosest pair {row['min_distance'] / audit['offset']:.5f} ξ"
    colour = {"PASS": "#2e7d32", "INCOMPLETE": "#b26a00" if audit.get("violations") == 0 else "#c62828"}
    return f"{solver}\n{whole}\n{here}", colour.get(verdict, "#c62828")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--run", nargs=2, action="append", metavar=("DIR", "IMAGE"), required=True)
    p.add_argument("--frame", type=int, required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--title")
    a = p.parse_args(argv)
    try:
        panels = [(mpimg.imread(image), *caption(run_dir, a.frame)) for run_dir, image in a.run]
        w = panels[0][0].shape[1]
        panels = [(img, wrap_caption(text, w), colour) for img, text, colour in panels]
    except (OSError, ValueError, KeyError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    h, w = panels[0][0].shape[:2]
    lines = max(text.count("\n") + 1 for _, text, _ in panels) + (1 if a.title else 0)
    # Room above the images for every title line (about 0.2 inch each at 10 pt).
    fig, axes = plt.subplots(1, len(panels), figsize=(len(panels) * w / 100, h / 100 + 0.25 * lines + 0.2), dpi=100,
                             constrained_layout=True)
    for ax, (img, text, colour) in zip(axes, panels):
        ax.imshow(img)
        ax.set_axis_off()
        ax.set_title(text, fontsize=10, color=colour)
    if a.title:
        fig.suptitle(a.title, fontsize=11)
    try:
        fig.savefig(a.out)
    except OSError as e:
        print(f"error: cannot write '{a.out}': {e}", file=sys.stderr)
        return 2
    print(a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
