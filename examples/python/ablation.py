#!/usr/bin/env python3
"""An ablation over contact solvers and offsets ξ, plotted with matplotlib.

Runs configs/drape.yaml (a cloth dropped on a ball; coarser cloth with --quick) for each solver and
offset, writes each run directory, audits it, and plots the closest distance seen per frame
relative to ξ, with the audit's verdict in the legend.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/ablation.py --frames 30 --out out/ablation_py
"""
import argparse
import pathlib

import ccfr
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "drape.yaml"))
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--solvers", nargs="+", default=["ccfr", "toi_clamp", "post_process"])
    ap.add_argument("--offsets", nargs="+", type=float, default=[0.005, 0.01])
    ap.add_argument("--quick", action="store_true", help="a 16 x 16 cloth instead of 40 x 40")
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--out", default="out/ablation_py")
    args = ap.parse_args()

    out = pathlib.Path(args.out)
    overrides = {"time.frames": args.frames, "contact.on_violation": "warn"}
    if args.quick:
        overrides["objects[0].shape.resolution"] = [16, 16]
    fig, ax = plt.subplots(figsize=(7, 4))
    rows = []
    for offset in args.offsets:
        scene = ccfr.load_scene(args.config, overrides={**overrides, "contact.offset": offset})
        for solver in args.solvers:
            sim = ccfr.Simulation(scene, solver=solver, threads=args.threads)
            run_dir = out / f"{solver}_xi{offset:g}"
            frames, ratio = [], []
            with ccfr.Run(sim, run_dir, force=True) as run:
                for _ in range(args.frames):
                    s = run.step()
                    frames.append(s["frame"])
                    ratio.append(s["min_distance"] / offset)
            verdict = ccfr.audit(run_dir).verdict
            rows.append((solver, offset, min(ratio), verdict))
            ax.plot(frames, ratio, label=f"{solver}, ξ = {offset:g} m: {verdict}")
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.set_xlabel("frame")
    ax.set_ylabel("closest pair seen / ξ")
    ax.legend(fontsize=7)
    fig.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "ablation.png", dpi=120)
    print(f"{'solver':>14} {'xi':>7} {'min/xi':>8} audit")
    for solver, offset, r, verdict in rows:
        print(f"{solver:>14} {offset:7g} {r:8.3f} {verdict}")
    print(f"plot: {out / 'ablation.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
