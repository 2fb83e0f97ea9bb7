"""A Python run writes what `ccfr run` writes, byte for byte (frames, stats without timings)."""
import csv
import io
import json
import subprocess

import ccfr
import pytest

# Timing columns of stats.csv (wall and CPU clocks): the only ones allowed to differ between two runs.
TIMING = {"wall_s", "cpu_s", "xpbd_s", "broad_s", "narrow_s", "resolution_s", "audit_s", "check_s", "serial_s",
          "xpbd_serial_s", "broad_serial_s", "narrow_serial_s", "resolution_serial_s", "check_serial_s"}


def stats_without_timing(path):
    rows = list(csv.reader(io.StringIO(path.read_text())))
    keep = [i for i, name in enumerate(rows[0]) if name not in TIMING]
    assert len(keep) == len(rows[0]) - len(TIMING)
    return [[r[i] for i in keep] for r in rows]


def cli_run(exe, config, out, *args):
    subprocess.run([exe, "run", str(config), "--out", str(out), "--threads", "2", *args], check=True,
                   capture_output=True)


@pytest.mark.parametrize("solver", ["ccfr", "toi_clamp"])
def test_python_run_is_bitwise_identical_to_ccfr_run(tmp_path, ccfr_exe, data, solver):
    config = data / "small_drop.yaml"
    cli_run(ccfr_exe, config, tmp_path / "cli", "--solver", solver, "--set", "output.every=2", "--frames", "5")

    scene = ccfr.load_scene(config, overrides={"output.every": 2, "time.frames": 5})
    sim = ccfr.Simulation(scene, solver=solver, threads=2)
    with ccfr.Run(sim, tmp_path / "py") as run:
        for _ in range(sim.frames):
            run.step()

    cli_frames = sorted((tmp_path / "cli" / "frames").iterdir())
    py_frames = sorted((tmp_path / "py" / "frames").iterdir())
    # Frame 0, every 2nd, and the last (5): the output.every rule of `ccfr run`.
    assert [p.name for p in cli_frames] == ["frame_00000.obj", "frame_00002.obj", "frame_00004.obj",
                                            "frame_00005.obj"]
    assert [p.name for p in py_frames] == [p.name for p in cli_frames]
    for a, b in zip(cli_frames, py_frames):
        assert a.read_bytes() == b.read_bytes(), a.name
    cli_stats = stats_without_timing(tmp_path / "cli" / "stats.csv")
    assert len(cli_stats) == 6
    assert stats_without_timing(tmp_path / "py" / "stats.csv") == cli_stats
    # The contact actually happened (the comparison is not between two free falls).
    assert max(int(r[cli_stats[0].index("constraints")]) for r in cli_stats[1:]) > 0

    cli_json = json.loads((tmp_path / "cli" / "run.json").read_text())
    py_json = json.loads((tmp_path / "py" / "run.json").read_text())
    for key in ("scene", "solver", "radius", "offset", "fps", "status", "frames_written", "vertices", "config"):
        assert py_json.get(key) == cli_json.get(key), key
    assert py_json["status"] == "completed"


def test_stats_dict_matches_stats_csv(tmp_path, data):
    sim = ccfr.Simulation(ccfr.load_scene(data / "small_drop.yaml", overrides={"time.frames": 2}), threads=2)
    assert sim.stats is None
    with ccfr.Run(sim, tmp_path / "r") as run:
        run.step(2)
    rows = list(csv.DictReader(io.StringIO((tmp_path / "r" / "stats.csv").read_text())))
    last = sim.stats
    assert set(last) == set(rows[-1])
    for key, text in rows[-1].items():
        if key in TIMING:
            continue
        value = last[key]
        if text == "":
            assert value is None or value == float("inf"), key
        elif isinstance(value, int):
            assert value == int(text), key
        else:
            assert f"{value:.9g}" == text, key


# The columns stats.csv writes as floats (%.6f, %.9g); every other column is an integer.
REAL = TIMING | {"sim_time", "min_distance", "lag_mean", "lag_max"}
# What the dict holds where the CSV cell is empty (unknown): None for penetrations (audit off),
# the markers themselves for the others, as before the column table.
UNKNOWN = {"penetrations": None, "min_distance": float("inf"), "halted_vertices_distinct": -1,
           "contact_vertices_distinct": -1}


@pytest.mark.parametrize("solver", ["ccfr", "toi_clamp"])
def test_stats_dict_has_the_csv_columns_in_order_with_their_types(tmp_path, data, solver):
    sim = ccfr.Simulation(ccfr.load_scene(data / "small_drop.yaml", overrides={"time.frames": 1}), solver=solver,
                          threads=2)
    with ccfr.Run(sim, tmp_path / "r") as run:
        run.step()
    header, row = list(csv.reader(io.StringIO((tmp_path / "r" / "stats.csv").read_text())))
    stats = sim.stats
    assert list(stats) == header
    empty = set()
    for key, text in zip(header, row):
        value = stats[key]
        if text == "":
            empty.add(key)
            assert key in UNKNOWN and value == UNKNOWN[key] and type(value) is type(UNKNOWN[key]), key
        elif key in REAL:
            assert type(value) is float and f"{value:{'.6f' if key in TIMING else '.9g'}}" == text, key
        else:
            assert type(value) is int and value == int(text), key
    assert "penetrations" in empty  # debug.audit is off
    # toi_clamp does not track the distinct counts: their cells are empty, the dict holds -1.
    assert ({"halted_vertices_distinct", "contact_vertices_distinct"} <= empty) == (solver == "toi_clamp")


def test_failed_run_records_the_error(tmp_path, data):
    sim = ccfr.Simulation(ccfr.load_scene(data / "small_drop.yaml"), threads=2)
    with pytest.raises(RuntimeError, match="stop here"):
        with ccfr.Run(sim, tmp_path / "r") as run:
            run.step()
            raise RuntimeError("stop here")
    info = json.loads((tmp_path / "r" / "run.json").read_text())
    assert info["status"] == "failed: stop here"
    assert info["frames_written"] == 2  # frames 0 and 1, both whole
