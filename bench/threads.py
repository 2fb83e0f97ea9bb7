#!/usr/bin/env python3
"""Every paper scene under `ccfr bench` at several thread counts; prints a Markdown table of the
median seconds per frame (whole frame and the paper's four stages) and the speed-up over the
first thread count (docs/performance.md, "Threads").

Usage: /usr/bin/python3 bench/threads.py [--threads 1,2] [--frames 12] [--warmup 2]
                                         [--ccfr build/apps/ccfr] [CONFIG ...]
Without CONFIGs it runs the paper's scenes of configs/. Each (scene, threads) is one `ccfr bench`
process, run one after another so that they do not share the cores; `--frames` counts from the
scene's first frame, the first `--warmup` of them excluded from the medians."""
import argparse
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES = ["twisting_cloth", "soft_wires", "hair", "particles", "codimensional", "three_cubes",
          "card_stack_xi0_01", "card_stack_xi0_001", "physically_active", "large_triangle"]
STAGES = ["frame", "xpbd", "broad phase", "narrow phase", "resolution"]


def parse_bench(text, path):
    """The median column of every stage row of `ccfr bench`'s table, and the vertex count."""
    medians = {}
    for stage in STAGES:
        m = re.search(r"^" + re.escape(stage) + r"\s+([0-9.eE+-]+)\s", text, re.M)
        if not m:
            raise SystemExit(f"threads.py: no '{stage}' row in the output of ccfr bench {path}:\n{text}")
        medians[stage] = float(m.group(1))
    v = re.search(r", (\d+) vertices,", text)
    medians["vertices"] = int(v.group(1)) if v else 0
    return medians


def bench(exe, config, threads, frames, warmup):
    cmd = [exe, "bench", config, "--frames", str(frames), "--warmup", str(warmup), "--threads", str(threads),
           "--quiet"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"threads.py: {' '.join(cmd)} exited {p.returncode}:\n{p.stderr}")
    return parse_bench(p.stdout, config)


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--warmup", type=int, default=2)
    ap.add_argument("--ccfr", default=os.path.join(ROOT, "build", "apps", "ccfr"))
    ap.add_argument("configs", nargs="*")
    a = ap.parse_args(argv)
    counts = [int(t) for t in a.threads.split(",")]
    if not counts or min(counts) < 1:
        raise SystemExit("threads.py: --threads takes a comma-separated list of positive integers")
    if a.warmup >= a.frames:
        raise SystemExit("threads.py: --warmup must be smaller than --frames")
    configs = a.configs or [os.path.join(ROOT, "configs", s + ".yaml") for s in SCENES]
    head = ["scene", "vertices"] + [f"{t} thr: frame (xpbd / broad / narrow / resolution)" for t in counts]
    head += [f"speed-up {t} thr" for t in counts[1:]]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for config in configs:
        runs = [bench(a.ccfr, config, t, a.frames, a.warmup) for t in counts]
        cells = [os.path.splitext(os.path.basename(config))[0], f"{runs[0]['vertices']:,}"]
        for r in runs:
            cells.append(f"{r['frame']:.4g} ({r['xpbd']:.3g} / {r['broad phase']:.3g} / "
                         f"{r['narrow phase']:.3g} / {r['resolution']:.3g})")
        for r in runs[1:]:
            cells.append(f"{runs[0]['frame'] / r['frame']:.2f}x" if r["frame"] > 0 else "n/a")
        print("| " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
