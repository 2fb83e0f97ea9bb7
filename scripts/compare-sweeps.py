#!/usr/bin/env python3
"""Compares two collected sweep tables (sweep.csv of `ccfr sweep collect`, or ablation.csv of
`ccfr ablate`) column by column, timing columns excluded: runs are deterministic, so the same sweep
run here and on a cluster must agree in everything else (docs/cluster.md).

    scripts/compare-sweeps.py A.csv B.csv [--ignore COLUMN ...]

Rows are matched by their `cell` column (`solver` for ablation.csv). Prints every difference and
exits 1 when there is one, 2 when a file cannot be read or the tables have different columns.
"""
import argparse
import csv
import sys

# Clock measurements (wall and CPU time): they differ between any two runs.
TIMING = {"avg_frame_s", "max_frame_s", "median_frame_s", "xpbd_s", "broad_s", "narrow_s", "resolution_s",
          "wall_s", "cpu_s", "cpu_frame_s", "audit_s", "check_s"}


def read(path):
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            rows = list(reader)
            return list(reader.fieldnames or []), rows
    except OSError as e:
        sys.exit(f"compare-sweeps: cannot read {path}: {e.strerror}")


def key_column(columns, path):
    for k in ("cell", "solver"):
        if k in columns:
            return k
    print(f"compare-sweeps: {path} has neither a 'cell' nor a 'solver' column", file=sys.stderr)
    sys.exit(2)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--ignore", action="append", default=[], help="another column to leave out")
    args = ap.parse_args(argv)
    ca, ra = read(args.a)
    cb, rb = read(args.b)
    if ca != cb:
        print(f"compare-sweeps: the columns differ:\n  {args.a}: {','.join(ca)}\n  {args.b}: {','.join(cb)}",
              file=sys.stderr)
        return 2
    key = key_column(ca, args.a)
    skip = TIMING | set(args.ignore)
    compared = [c for c in ca if c not in skip]
    ia = {r[key]: r for r in ra}
    ib = {r[key]: r for r in rb}
    diffs = []
    for k in ia.keys() - ib.keys():
        diffs.append(f"{k}: only in {args.a}")
    for k in ib.keys() - ia.keys():
        diffs.append(f"{k}: only in {args.b}")
    if len(ia) != len(ra) or len(ib) != len(rb):
        diffs.append(f"a '{key}' value repeats")
    for k in [r[key] for r in ra]:
        if k not in ib:
            continue
        for c in compared:
            if ia[k][c] != ib[k][c]:
                diffs.append(f"{k}: {c}: {ia[k][c]!r} != {ib[k][c]!r}")
    for d in sorted(set(diffs)):
        print(d)
    if diffs:
        print(f"compare-sweeps: {len(set(diffs))} difference(s) in {len(ra)} / {len(rb)} rows", file=sys.stderr)
        return 1
    print(f"compare-sweeps: {len(ra)} rows identical in {len(compared)} columns "
          f"({len(ca) - len(compared)} timing columns left out)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
