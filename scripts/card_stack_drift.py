#!/usr/bin/env python3
"""Static-equilibrium check of a card-stack run: how far card vertices moved between frame 0 and
the last frame (max and mean displacement, and the largest vertical drop), in units of xi.
Usage: /usr/bin/python3 scripts/card_stack_drift.py RUN_DIR"""
import json, math, os, sys


def read_vertices(path):
    objs, cur = {}, None
    with open(path) as f:
        for line in f:
            if line.startswith("o "):
                cur = line[2:].strip()
                objs[cur] = []
            elif line.startswith("v ") and cur is not None:
                objs[cur].append(tuple(float(t) for t in line.split()[1:4]))
    return objs


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    d = sys.argv[1]
    frames = sorted(f for f in os.listdir(os.path.join(d, "frames")) if f.endswith(".obj"))
    xi = json.load(open(os.path.join(d, "run.json")))["offset"]
    a = read_vertices(os.path.join(d, "frames", frames[0]))
    b = read_vertices(os.path.join(d, "frames", frames[-1]))
    disp, drop = [], 0.0
    for name, va in a.items():
        if not name.startswith("card"):
            continue
        for p, q in zip(va, b[name]):
            disp.append(math.dist(p, q))
            drop = max(drop, p[1] - q[1])
    print(f"{os.path.basename(d.rstrip('/'))}: {len(disp)} card vertices over {len(frames) - 1} frames; "
          f"max displacement {max(disp) / xi:.4f} xi, mean {sum(disp) / len(disp) / xi:.4f} xi, largest drop {drop / xi:.4f} xi")
    return 0


if __name__ == "__main__":
    sys.exit(main())
