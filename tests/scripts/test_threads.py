"""bench/threads.py: the medians it reads from `ccfr bench`'s table (a table as ccfr prints it),
and a clear error when a stage row is missing or the options do not fit."""
import importlib.util
import os
import pathlib
import subprocess
import sys

import pytest

SCRIPT = pathlib.Path(os.environ.get("CCFR_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2])) / "bench" / \
    "threads.py"

BENCH = """bench configs/three_cubes.yaml: solver ccfr, 379 vertices, 4 substeps x 2 iterations, 2 threads, 10 frames (2 warm-up skipped)
stage (s/frame)            median         mean          max
frame                    0.022160     0.023000     0.030000
xpbd                     0.011300     0.011400     0.012000
broad phase              0.000897     0.000900     0.001000
narrow phase             0.007940     0.008000     0.009000
resolution               0.001150     0.001200     0.002000
count (per frame)          median         mean          max
candidates                   1234       1234.0         1300
status: completed; 12 frames in 0.30 s
"""


def load_script():
    spec = importlib.util.spec_from_file_location("threads", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_reads_the_median_column_and_the_vertex_count():
    got = load_script().parse_bench(BENCH, "x.yaml")
    assert got == {"frame": 0.02216, "xpbd": 0.0113, "broad phase": 0.000897, "narrow phase": 0.00794,
                   "resolution": 0.00115, "vertices": 379}


def test_a_missing_stage_row_is_an_error_naming_it():
    with pytest.raises(SystemExit) as e:
        load_script().parse_bench(BENCH.replace("narrow phase", "narrow"), "x.yaml")
    assert "no 'narrow phase' row" in str(e.value) and "x.yaml" in str(e.value)


@pytest.mark.parametrize("args, message", [(["--frames", "3", "--warmup", "3"], "--warmup must be smaller"),
                                           (["--threads", "0,2"], "positive integers")])
def test_options_that_do_not_fit_are_refused(args, message):
    r = subprocess.run([sys.executable, str(SCRIPT), *args, "none.yaml"], capture_output=True, text=True)
    assert r.returncode != 0 and message in r.stderr
