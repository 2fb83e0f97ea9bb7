"""scripts/compare-sweeps.py on small tables written here: equal apart from the timing columns,
a difference in a count, a verdict or a status, a missing row, other columns, ablation.csv's
solver key, and a table with no rows."""
import os
import pathlib
import subprocess
import sys

import pytest

SCRIPT = pathlib.Path(os.environ.get("CCFR_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2])) / "scripts" / \
    "compare-sweeps.py"
HEAD = "cell,scene,solver,frames,status,avg_frame_s,max_frame_s,violations_remaining,audit,min_distance_over_offset\n"
ROWS = ["a__ccfr,a,ccfr,3,completed,0.100000,0.200000,0,pass,1.000000000\n",
        "a__none,a,none,3,completed,0.050000,0.060000,12,fail,0.000000000\n"]


def run(tmp_path, a, b, *extra):
    pa, pb = tmp_path / "a.csv", tmp_path / "b.csv"
    pa.write_text(a)
    pb.write_text(b)
    r = subprocess.run([sys.executable, str(SCRIPT), str(pa), str(pb), *extra], capture_output=True, text=True)
    return r.returncode, r.stdout + r.stderr


def test_equal_apart_from_timing(tmp_path):
    other = [ROWS[0].replace("0.100000,0.200000", "0.310000,0.900000"), ROWS[1].replace("0.050000", "0.070000")]
    code, out = run(tmp_path, HEAD + "".join(ROWS), HEAD + "".join(reversed(other)))  # row order does not matter
    assert code == 0, out
    assert "2 rows identical in 8 columns (2 timing columns left out)" in out


@pytest.mark.parametrize("old,new,column", [("12,fail", "11,fail", "violations_remaining"),
                                            ("pass", "fail", "audit"),
                                            ("3,completed,0.05", "2,terminated,0.05", "status"),
                                            ("1.000000000", "0.999999999", "min_distance_over_offset")])
def test_a_difference_is_named_and_fails(tmp_path, old, new, column):
    b = HEAD + "".join(r.replace(old, new) for r in ROWS)
    code, out = run(tmp_path, HEAD + "".join(ROWS), b)
    assert code == 1, out
    assert f": {column}: " in out and "difference(s)" in out


def test_missing_rows_and_other_columns(tmp_path):
    code, out = run(tmp_path, HEAD + "".join(ROWS), HEAD + ROWS[0])
    assert code == 1 and "a__none: only in" in out
    code, out = run(tmp_path, HEAD + "".join(ROWS), HEAD.replace(",audit", ",verdict") + "".join(ROWS))
    assert code == 2 and "the columns differ" in out
    # --ignore leaves a further column out
    code, out = run(tmp_path, HEAD + "".join(ROWS), HEAD + "".join(r.replace("pass", "fail") for r in ROWS),
                    "--ignore", "audit")
    assert code == 0, out


def test_ablation_tables_key_on_the_solver_and_empty_tables_agree(tmp_path):
    head = "solver,frames,avg_frame_s,audit\n"
    code, out = run(tmp_path, head + "ccfr,3,0.1,pass\nnone,3,0.2,fail\n", head + "none,3,0.4,fail\nccfr,3,0.3,pass\n")
    assert code == 0, out
    code, out = run(tmp_path, head + "ccfr,3,0.1,pass\n", head + "ccfr,4,0.1,pass\n")
    assert code == 1 and "ccfr: frames: '3' != '4'" in out
    code, out = run(tmp_path, head, head)
    assert code == 0 and "0 rows identical" in out
    code, out = run(tmp_path, "frames,audit\n3,pass\n", "frames,audit\n3,pass\n")
    assert code == 2 and "neither a 'cell' nor a 'solver' column" in out


def test_an_unreadable_file_is_named(tmp_path):
    r = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "missing.csv"), str(tmp_path / "x.csv")],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "missing.csv" in r.stderr
