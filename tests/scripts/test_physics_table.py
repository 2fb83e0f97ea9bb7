"""scripts/physics-table on a stand-in test binary written here: the table from its physics lines
(errors signed, relative to the closed form), a failing test's exit passed on, no binary, a
binary that printed no measurement, the pairings' matrices and --compare's table."""
import os
import pathlib
import stat
import subprocess
import sys

SCRIPT = pathlib.Path(os.environ.get("CCFR_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2])) / "scripts" / \
    "physics-table"


def fake_build(tmp_path, lines, code=0, prelude=""):
    exe = tmp_path / "tests" / "test_solvers"
    exe.parent.mkdir(parents=True)
    body = "".join(f"echo '{line}'\n" for line in lines)
    exe.write_text(f"#!/bin/sh\n{prelude}{body}exit {code}\n")
    exe.chmod(exe.stat().st_mode | stat.S_IEXEC)
    return tmp_path


def run(build, *options):
    r = subprocess.run([sys.executable, str(SCRIPT), *options, str(build)], capture_output=True, text=True)
    return r.returncode, r.stdout, r.stderr


def test_table_from_the_measurements(tmp_path):
    build = fake_build(tmp_path, ["[ RUN      ] A.b", "physics|A.b|ball: acceleration|2.5|2.4|m/s²",
                                  "physics|A.c|box: distance|2|2.1|m", "[       OK ] A.b"])
    code, out, err = run(build)
    assert code == 0, err
    rows = out.strip().splitlines()
    assert rows[0] == "| test | quantity | closed form | measured | error |"
    assert rows[2] == "| `A.b` | ball: acceleration | 2.5 m/s² | 2.4 m/s² | -4.00 % |"
    assert rows[3] == "| `A.c` | box: distance | 2 m | 2.1 m | +5.00 % |"


def test_a_failing_test_fails_the_table(tmp_path):
    build = fake_build(tmp_path, ["physics|A.b|x|1|3|m", "[  FAILED  ] A.b"], code=1)
    code, out, err = run(build)
    assert code == 1
    assert "+200.00 %" in out
    assert "1 failing" in err


def test_no_binary_and_no_measurement(tmp_path):
    code, _, err = run(tmp_path)
    assert code == 2 and "not found" in err
    code, _, err = run(fake_build(tmp_path / "b", ["nothing"]))
    assert code == 2 and "no measurement" in err


def test_pairings_as_a_matrix_per_solver_and_setting(tmp_path):
    dev = "momentum'\"'\"'s largest deviation"  # an apostrophe inside the stand-in's echo '...'
    build = fake_build(tmp_path, [
        f"physics|P.x/a|rigid into cloth, ccfr (defaults): {dev} in 10 frames|2|2.02|kg m/s",
        "physics|P.x/a|rigid into cloth, ccfr (defaults): angular momentum after 10 frames|0.1|0.099|kg m²/s",
        f"physics|P.x/b|cloth into rigid, ccfr (defaults): {dev} in 10 frames|1|1|kg m/s",
        f"physics|P.x/c|cloth into rigid, ccfr (contact.momentum): {dev} in 10 frames|1|1.5|kg m/s",
        "physics|A.b|box: distance|2|2.1|m"])
    code, out, err = run(build)
    assert code == 0, err
    assert "| `A.b` | box: distance | 2 m | 2.1 m | +5.00 % |" in out
    assert "rigid into cloth" not in out
    defaults, momentum = out.split("Every pairing under `ccfr` with the defaults")[1].split(
        "Every pairing under `ccfr` with `contact.momentum: true`")
    assert "| shot \\ hit | rigid | cloth |" in defaults
    assert "| rigid | — | +1.00 % / -1.00 % |" in defaults
    assert "| cloth | +0.00 % / — | — |" in defaults
    assert "| cloth | +50.00 % / — | — |" in momentum


def test_compare_runs_the_tests_under_more_solvers_and_tabulates_them(tmp_path):
    # The stand-in fails unless the script asked for ogc through CCFR_PHYSICS_COMPARE.
    build = fake_build(tmp_path, [
        "physics|A.b|ball: acceleration, ccfr|2|2|m/s²",
        "physics|A.b|ball: acceleration, exact_projection|2|2.2|m/s²",
        "physics|A.b|ball: acceleration, ogc|2|1|m/s²",
        "physics|A.c|belt: ratio, μ = 0, ogc, sliding off|1|1.5|",
        "physics|A.d|box: distance|2|2.1|m"], prelude='[ "$CCFR_PHYSICS_COMPARE" = ogc ] || exit 3\n')
    code, out, err = run(build, "--compare", "ogc")
    assert code == 0, err
    main, compared = out.split("The same tests under other solvers")
    assert "| `A.b` | ball: acceleration, ccfr | 2 m/s² | 2 m/s² | +0.00 % |" in main
    assert ", ogc" not in main
    assert "| quantity | closed form | `ccfr` | `exact_projection` | `ogc` |" in compared
    assert "| ball: acceleration | 2 m/s² | 2 m/s² (+0.00 %) | 2.2 m/s² (+10.00 %) | 1 m/s² (-50.00 %) |" in compared
    assert "| belt: ratio, μ = 0, sliding off | 1 | — | — | 1.5 (+50.00 %) |" in compared
    assert "box: distance" not in compared
    code, _, err = run(build)  # without --compare the variable is empty: the stand-in prints nothing
    assert code == 2 and "no measurement" in err
