"""scripts/methods_md.py on a sweep folder written here: one table per scene in the sweep's order,
the lag in millimetres, failed audits with their count; the fitted camera sees the whole box; the
obstacles are left out of the camera's bounds; a folder that is not a sweep exits 2."""
import importlib.util
import itertools
import json
import math
import os
import pathlib
import subprocess
import sys

SCRIPT = pathlib.Path(os.environ.get("CCFR_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2])) / "scripts" / \
    "methods_md.py"

HEAD = ("cell,scene,solver,halting_percent,frames,status,avg_frame_s,max_frame_s,median_frame_s,xpbd_s,broad_s,"
        "narrow_s,resolution_s,violations_detected,violations_remaining,max_violations_remaining,halted_vertices,"
        "audit,audit_violations,min_distance_over_offset,lag_mean,lag_max,cpu_frame_s,outer_iterations\n")


def load_script():
    spec = importlib.util.spec_from_file_location("methods_md", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def sweep(tmp_path):
    d = tmp_path / "sweep"
    d.mkdir()
    (d / "sweep.json").write_text(json.dumps({"audit_stride": 1}))
    (d / "sweep.csv").write_text(
        HEAD +
        "twist__ccfr,twist,ccfr,0.0000,480,completed,1.5,2,1.4,0.1,0.2,0.3,0.4,10,0,0,0,pass,0,1.000000000,"
        "0.00035,0.0123,1.25,17.5\n"
        "twist__post_process,twist,post_process,,480,completed,1.1,2,1,0.1,0.2,0.3,0.4,10,5,2,0,fail,1234,"
        "0.010330000,0.0004,0.05,0.95,16\n"
        "cubes__ogc,cubes,ogc,nan,120,completed,0.01,0.02,0.01,0,0,0,0,0,0,0,0,pass,0,1.000000000,"
        "0.000645,0.002,0.012,8\n")
    return d


def test_one_table_per_scene_in_the_sweeps_order(tmp_path):
    r = subprocess.run([sys.executable, str(SCRIPT), str(sweep(tmp_path))], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert out.index("#### twist") < out.index("#### cubes")
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in out.splitlines() if line.startswith("| `")]
    assert rows[0] == ["`ccfr`", "completed", "480", "PASS", "1.0000", "1.500", "1.250", "17.5", "0.3500", "12.30",
                       "0.00"]
    assert rows[1][3] == "**FAIL** (1,234)"
    assert rows[1][4] == "0.0103"
    assert rows[1][10] == ""  # no contact vertices: no halting share
    assert rows[2][0] == "`ogc`" and rows[2][8] == "0.6450" and rows[2][10] == ""


def test_the_camera_sees_the_whole_box():
    mod = load_script()
    lo, hi = [-0.5, 0.2, -1.0], [1.5, 0.9, 0.4]
    cam = [float(v) for v in mod.camera_for(lo, hi, 40.0).split(",")]
    eye, target, fov = cam[:3], cam[3:6], cam[6]
    assert fov == 40.0
    axis = [t - e for t, e in zip(target, eye)]
    for corner in itertools.product(*zip(lo, hi)):
        ray = [c - e for c, e in zip(corner, eye)]
        cos = sum(a * b for a, b in zip(axis, ray)) / (math.hypot(*axis) * math.hypot(*ray))
        assert math.degrees(math.acos(min(1.0, cos))) < fov / 2


def test_obstacles_are_left_out_of_the_bounds(tmp_path):
    mod = load_script()
    obj = tmp_path / "f.obj"
    obj.write_text("o floor\nv -10 0 -10\nv 10 0 10\nf 1 2 1\no sheet\nv 0 1 0\nv 1 2 3\n")
    assert mod.obj_bounds(str(obj), {"floor"}) == ([0.0, 1.0, 0.0], [1.0, 2.0, 3.0])
    assert mod.obj_bounds(str(obj)) == ([-10.0, 0.0, -10.0], [10.0, 2.0, 10.0])


def test_a_folder_that_is_not_a_sweep_exits_2(tmp_path):
    r = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 2
    assert "not a sweep directory" in r.stderr


def test_a_store_keeps_the_cells_of_earlier_parts_of_the_sweep(tmp_path):
    """A sweep run in parts (each machine runs some cells): the store keeps every cell that ran,
    a later part's queued row does not replace it, and a cell that ran further does."""
    store = tmp_path / "store"
    first = sweep(tmp_path)
    r = subprocess.run([sys.executable, str(SCRIPT), str(first), "--store", str(store)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    second = tmp_path / "second"
    second.mkdir()
    (second / "sweep.json").write_text(json.dumps({"audit_stride": 1}))
    # A part with fewer cells, in another order: the tables keep the store's order.
    (second / "sweep.csv").write_text(
        HEAD +
        "cubes__dat,cubes,dat,,0,not run,,,,,,,,,,,,,,,,,,\n"
        "twist__ccfr,twist,ccfr,,0,not run,,,,,,,,,,,,,,,,,,\n"
        "twist__post_process,twist,post_process,,480,completed,1.1,2,1,0.1,0.2,0.3,0.4,10,5,2,0,fail,99,"
        "0.5,0.0004,0.05,0.95,16\n"
        "cubes__ogc,cubes,ogc,nan,60,interrupted after frame 60,0.01,0.02,0.01,0,0,0,0,0,0,0,0,pass,0,1.0,"
        "0.000645,0.002,0.012,8\n")
    r = subprocess.run([sys.executable, str(SCRIPT), str(second), "--store", str(store)], capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.index("#### twist") < r.stdout.index("#### cubes")
    order = [line.split("|")[1].strip() for line in r.stdout.splitlines() if line.startswith("| `")]
    assert order == ["`ccfr`", "`post_process`", "`ogc`", "`dat`"]
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.strip("|").split("|")]
            for line in r.stdout.splitlines() if line.startswith("| `")}
    assert rows["`ccfr`"][1:3] == ["completed", "480"]  # kept from the first part
    assert rows["`post_process`"][3] == "**FAIL** (99)"  # the rerun, as far as the first: replaces it
    assert rows["`ogc`"][1:3] == ["completed", "120"]  # ran further in the first part
    assert rows["`dat`"][1:3] == ["not run", "0"]
    assert r.stdout.startswith("3 of 4 cells run")
    stored = (store / "sweep.csv").read_text().splitlines()
    assert len(stored) == 5 and stored[0].startswith("cell,scene,solver")


def test_panels_compose_into_one_picture_per_scene(tmp_path):
    mod = load_script()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    (tmp_path / "methods").mkdir()
    meta = {"cameras": {}, "captions": {}}
    for i, cell in enumerate(["s__a", "s__b"]):
        plt.imsave(str(tmp_path / "methods" / f"{cell}.png"), [[[0.1 * i, 0.5, 0.5]] * 48] * 36)
        meta["captions"][cell] = [f"{cell}\naudit PASS", "#2e7d32"]
    rows = [{"cell": "s__a", "frames": "9"}, {"cell": "s__b", "frames": "9"}, {"cell": "s__c", "frames": "0"}]
    target = mod.compose("s", rows, str(tmp_path), meta)  # s__c never ran: it needs no panel
    assert target == str(tmp_path / "methods_s.png")
    img = plt.imread(target)
    assert img.shape[1] >= 2 * 48 and img.shape[0] > 36
    # A cell that ran without a panel (on a machine that kept none) leaves the picture as it is.
    assert mod.compose("s", rows + [{"cell": "s__d", "frames": "5"}], str(tmp_path), meta) is None
    assert mod.compose("t", rows[:1], str(tmp_path), meta) is None
