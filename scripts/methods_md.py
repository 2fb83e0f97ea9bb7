#!/usr/bin/python3
"""Writes docs/results.md's comparison of contact methods from a collected sweep of
configs/sweeps/methods.yaml: one table per scene with a row per solver, and with --pictures one
image per scene of every solver's last frame side by side (each panel titled with its audit).

Usage: /usr/bin/python3 scripts/methods_md.py SWEEP_DIR [--store DIR] [--pictures IMAGE_DIR] [--ccfr EXE] > methods.md
  SWEEP_DIR  run by `ccfr sweep configs/sweeps/methods.yaml --out SWEEP_DIR`; its sweep.csv is
             written by `ccfr sweep collect SWEEP_DIR` (run here when missing, with --ccfr).
  --store    a folder that keeps every cell collected so far (docs/data/methods: cells.csv, the
             panels' cameras and captions), so that a sweep too long for one machine's lifetime can
             be run in parts: the cells this sweep ran replace the stored ones that ran less far,
             and the tables and pictures show every stored cell.
  --pictures renders the last frame of every cell that has frames (`ccfr render`, one camera per
             scene, fitted to the first of its cells that ran) into IMAGE_DIR/methods/<cell>.png,
             and writes IMAGE_DIR/methods_<scene>.png: the panels of the scene's cells side by side.
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


def ran(row):
    """Whether a sweep.csv row is a cell that ran (a row of a queued cell has no frames)."""
    return (number(row.get("frames")) or 0) > 0


def merge(store_rows, rows):
    """The stored cells in their order, each replaced by the sweep's row of the same scene and
    solver unless the stored one ran further; cells new to the store follow, in the sweep's order."""
    fresh = {(r["scene"], r["solver"]): r for r in rows}
    out = []
    for old in store_rows:
        r = fresh.pop((old["scene"], old["solver"]), None)
        keep = r is None or (ran(old) and (number(old["frames"]) or 0) > (number(r["frames"]) or 0))
        out.append(old if keep else r)
    return out + [r for r in rows if (r["scene"], r["solver"]) in fresh]


def load_store(store):
    rows = read_rows(store) if os.path.isfile(os.path.join(store, "sweep.csv")) else []
    meta_path = os.path.join(store, "panels.json")
    meta = json.load(open(meta_path)) if os.path.isfile(meta_path) else {"cameras": {}, "captions": {}}
    return rows, meta


def save_store(store, rows, meta):
    os.makedirs(store, exist_ok=True)
    fields = []
    for r in rows:
        fields += [k for k in r if k not in fields]
    with open(os.path.join(store, "sweep.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    with open(os.path.join(store, "panels.json"), "w") as f:
        json.dump(meta, f, indent=1, sort_keys=True)
        f.write("\n")


def render_panels(sweep_dir, rows, image_dir, exe, meta):
    """IMAGE_DIR/methods/<cell>.png: the last frame of every cell of this sweep that has frames,
    seen by its scene's camera (kept in meta so that later parts of the sweep use the same one);
    meta["captions"][cell] = [text, colour] from its run.json and audit.json."""
    sys.path.insert(0, HERE)
    from side_by_side import caption  # the same panel titles as the other side-by-side pictures
    os.makedirs(os.path.join(image_dir, "methods"), exist_ok=True)
    for r in rows:
        d = os.path.join(sweep_dir, r["cell"])
        frame = last_frame(d) if os.path.isdir(os.path.join(d, "frames")) else None
        if frame is None or not os.path.isfile(os.path.join(d, "audit.json")):
            continue
        cam = meta["cameras"].setdefault(r["scene"], camera_for(*moving_bounds(d, frame)))
        with tempfile.TemporaryDirectory() as tmp:
            subprocess.run([exe, "render", d, "--out", tmp, "--camera", cam, "--width", "480", "--height", "360",
                            "--every", str(max(frame, 1)), "--samples", "4"], check=True, stdout=subprocess.DEVNULL)
            os.replace(os.path.join(tmp, f"frame_{frame:05d}.png"), os.path.join(image_dir, "methods", f"{r['cell']}.png"))
        meta["captions"][r["cell"]] = list(caption(d, frame))


def compose(scene, rows, image_dir, meta):
    """IMAGE_DIR/methods_<scene>.png from the panels of the scene's cells that ran. None (the
    picture is left as it is) while a cell that ran has no panel (its frames were on a machine that
    kept no panel) or fewer than two cells have one."""
    panels = [(os.path.join(image_dir, "methods", f"{r['cell']}.png"), r["cell"]) for r in rows if ran(r)]
    if len(panels) < 2 or not all(os.path.isfile(p) and c in meta["captions"] for p, c in panels):
        return None
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt
    images = [mpimg.imread(p) for p, _ in panels]
    h, w = images[0].shape[:2]
    sys.path.insert(0, HERE)
    from side_by_side import wrap_caption  # the panels' titles fit their width as in side_by_side's pictures
    titles = {c: wrap_caption(meta["captions"][c][0], w) for _, c in panels}
    lines = max(t.count("\n") + 1 for t in titles.values()) + 1
    fig, axes = plt.subplots(1, len(panels), figsize=(len(panels) * w / 100, h / 100 + 0.25 * lines + 0.2), dpi=100,
                             constrained_layout=True)
    for ax, img, (_, c) in zip(axes, images, panels):
        ax.imshow(img)
        ax.set_axis_off()
        ax.set_title(titles[c], fontsize=10, color=meta["captions"][c][1])
    fig.suptitle(f"{scene}: the last frame of every cell", fontsize=11)
    target = os.path.join(image_dir, f"methods_{scene}.png")
    fig.savefig(target)
    plt.close(fig)
    return target


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("sweep_dir")
    p.add_argument("--store", metavar="DIR")
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
    for r in rows:  # which part of the sweep a stored cell came from
        r["part"] = os.path.basename(os.path.normpath(a.sweep_dir))
    store_rows, meta = load_store(a.store) if a.store else ([], {"cameras": {}, "captions": {}})
    if a.pictures:
        render_panels(a.sweep_dir, [r for r in rows if ran(r)], a.pictures, a.ccfr, meta)
    rows = merge(store_rows, rows)
    if a.store:
        save_store(a.store, rows, meta)
    scenes = {}
    for r in rows:
        scenes.setdefault(r["scene"], []).append(r)
    made = {}
    if a.pictures:
        for scene, srows in scenes.items():
            target = compose(scene, srows, a.pictures, meta) or os.path.join(a.pictures, f"methods_{scene}.png")
            if os.path.isfile(target):
                made[scene] = target
    spec = json.load(open(os.path.join(a.sweep_dir, "sweep.json")))
    stride = spec.get("audit_stride", 1)
    done = sum(1 for r in rows if ran(r))
    print(f"{done} of {len(rows)} cells run; every run audited by "
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
