#!/usr/bin/python3
"""Writes docs/results.md's comparison of contact methods from a collected sweep of
configs/sweeps/methods.yaml: one table per scene with a row per solver, and with --pictures one
image per scene of every solver's last frame side by side (each panel titled with its audit).

Usage: /usr/bin/python3 scripts/methods_md.py SWEEP_DIR [--pictures IMAGE_DIR] [--ccfr EXE] > methods.md
  SWEEP_DIR  run by `ccfr sweep configs/sweeps/methods.yaml --out SWEEP_DIR`; its sweep.csv is
             written by `ccfr sweep collect SWEEP_DIR` (run here when missing, with --ccfr).
  --pictures renders the last frame of every cell (`ccfr render`, one camera per scene, fitted to
             the first solver's last frame) and writes IMAGE_DIR/methods_<scene>.png.
Uses Debian's python3 only (matplotlib for --pictures). Exit codes: 0 written, 2 bad input.
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
# side_by_side.py needs Debian's matplotlib, which another python3 first on PATH may lack.
PYTHON = "/usr/bin/python3" if os.path.isfile("/usr/bin/python3") else sys.executable


def read_rows(sweep_dir):
    with open(os.path.join(sweep_dir, "sweep.csv")) as f:
        return list(csv.DictReader(f))


def number(text):
    try:
        v = float(text)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def fmt(v, spec, scale=1.0):
    return "" if v is None else format(v * scale, spec)


def audit_cell(row):
    verdict = row.get("audit", "")
    if verdict == "fail":
        return f"**FAIL** ({int(float(row.get('audit_violations') or 0)):,})"
    return {"pass": "PASS", "": "not audited"}.get(verdict, verdict)


def scene_table(rows):
    """Markdown rows of one scene: a solver per row, in the sweep's order."""
    out = ["| solver | status | frames | audit (violations) | min distance / ξ | s/frame | CPU s/frame | "
           "outer iterations / frame | lag mean (mm/substep) | lag max (mm) | halted (%) |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append("| `{}` | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |".format(
            r["solver"], r["status"].replace("|", "/"), r["frames"], audit_cell(r),
            fmt(number(r.get("min_distance_over_offset")), ".4f"), fmt(number(r.get("avg_frame_s")), ".3f"),
            fmt(number(r.get("cpu_frame_s")), ".3f"), fmt(number(r.get("outer_iterations")), ".1f"),
            fmt(number(r.get("lag_mean")), ".4f", 1e3), fmt(number(r.get("lag_max")), ".2f", 1e3),
            fmt(number(r.get("halting_percent")), ".2f")))
    return out


def obj_bounds(path, skip=()):
    """Bounds of the vertices of an OBJ frame, leaving out the objects (`o NAME`) in skip."""
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    keep = True
    with open(path) as f:
        for line in f:
            if line.startswith("o "):
                keep = line[2:].strip() not in skip
            elif keep and line.startswith("v "):
                p = [float(t) for t in line.split()[1:4]]
                lo = [min(a, b) for a, b in zip(lo, p)]
                hi = [max(a, b) for a, b in zip(hi, p)]
    return lo, hi


def camera_for(lo, hi, fov_deg=40.0):
    """A camera that sees the box [lo, hi] whole, looking at its centre from the front, above and
    to the right: 'eye_x,eye_y,eye_z,target_x,target_y,target_z,fov' for `ccfr render --camera`."""
    centre = [(a + b) / 2 for a, b in zip(lo, hi)]
    radius = max(1e-6, 0.5 * math.dist(lo, hi))
    dist = 1.1 * radius / math.sin(math.radians(fov_deg) / 2)
    d = [0.5, 0.45, 1.0]
    n = math.sqrt(sum(x * x for x in d))
    eye = [c + dist * x / n for c, x in zip(centre, d)]
    return ",".join(f"{v:.6g}" for v in eye + centre + [fov_deg])


def last_frame(cell_dir):
    frames = sorted(f for f in os.listdir(os.path.join(cell_dir, "frames")) if f.endswith(".obj"))
    return int(frames[-1][len("frame_"):-len(".obj")]) if frames else None


def moving_bounds(cell_dir, frame):
    """Bounds of what moves in a frame: obstacles (a 4 m floor, a cylinder) would set the camera."""
    config = json.load(open(os.path.join(cell_dir, "run.json"))).get("config", {})
    still = {o.get("name") for o in config.get("objects", []) if o.get("kind") == "obstacle"}
    return obj_bounds(os.path.join(cell_dir, "frames", f"frame_{frame:05d}.obj"), still)


def pictures(sweep_dir, scenes, image_dir, exe):
    """IMAGE_DIR/methods_<scene>.png for every scene; returns {scene: path}."""
    made = {}
    os.makedirs(image_dir, exist_ok=True)
    for scene, rows in scenes.items():
        cells = [(r, os.path.join(sweep_dir, r["cell"])) for r in rows]
        cells = [(r, d) for r, d in cells if os.path.isdir(os.path.join(d, "frames"))]
        if len(cells) < 2:
            continue
        frame = min(last_frame(d) for _, d in cells)
        cam = camera_for(*moving_bounds(cells[0][1], frame))
        with tempfile.TemporaryDirectory() as tmp:
            args = []
            for r, d in cells:
                out = os.path.join(tmp, r["solver"])
                subprocess.run([exe, "render", d, "--out", out, "--camera", cam, "--width", "480", "--height", "360",
                                "--every", str(max(frame, 1)), "--samples", "4"], check=True,
                               stdout=subprocess.DEVNULL)
                args += ["--run", d, os.path.join(out, f"frame_{frame:05d}.png")]
            target = os.path.join(image_dir, f"methods_{scene}.png")
            subprocess.run([PYTHON, os.path.join(HERE, "side_by_side.py"), *args, "--frame", str(frame),
                            "--out", target, "--title", f"{scene}, frame {frame}"], check=True,
                           stdout=subprocess.DEVNULL)
        made[scene] = target
    return made


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("sweep_dir")
    p.add_argument("--pictures", metavar="IMAGE_DIR")
    p.add_argument("--ccfr", default=os.path.join(HERE, "..", "build", "apps", "ccfr"))
    a = p.parse_args(argv)
    if not os.path.isfile(os.path.join(a.sweep_dir, "sweep.json")):
        print(f"error: '{a.sweep_dir}' is not a sweep directory (no sweep.json)", file=sys.stderr)
        return 2
    if not os.path.isfile(os.path.join(a.sweep_dir, "sweep.csv")):
        if not os.path.isfile(a.ccfr):
            print(f"error: no sweep.csv in '{a.sweep_dir}' and no ccfr at '{a.ccfr}' to collect it", file=sys.stderr)
            return 2
        subprocess.run([a.ccfr, "sweep", "collect", a.sweep_dir, "--no-plot"], check=True, stdout=subprocess.DEVNULL)
    rows = read_rows(a.sweep_dir)
    scenes = {}
    for r in rows:
        scenes.setdefault(r["scene"], []).append(r)
    made = pictures(a.sweep_dir, scenes, a.pictures, a.ccfr) if a.pictures else {}
    spec = json.load(open(os.path.join(a.sweep_dir, "sweep.json")))
    stride = spec.get("audit_stride", 1)
    print(f"{len(rows)} cells of `{os.path.basename(os.path.normpath(a.sweep_dir))}`; every run audited by "
          f"`ccfr audit` (stride {stride}). s/frame is the mean wall time, CPU s/frame the mean of stats.csv "
          "`cpu_s`; every solver runs one detection pass per outer iteration. The lag is how far the contact "
          "handling kept vertices from their unconstrained (material) step: the mean over movable vertices "
          "and substeps, and the worst vertex of the run (docs/output.md).")
    for scene, srows in scenes.items():
        print(f"\n#### {scene}\n")
        print("\n".join(scene_table(srows)))
        if scene in made:
            rel = os.path.relpath(made[scene], os.path.join(HERE, "..", "docs"))
            print(f"\n![{scene}: the last frame under every solver]({rel})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
