"""The scripts that read stats.csv by column name use the names of the column table
(kStatsColumns, solvers/include/ccfr/solvers/frame_stats.hpp): a misspelt column would read as
missing (a blank panel, a skipped table) rather than fail, so every string key the scripts look up
must be a stats.csv column or one of the other files' keys listed here. The column names come from
docs/output.md's generated table, which tests/io/test_stats_csv.cpp ties to kStatsColumns."""
import ast
import os
import pathlib
import re

import pytest

ROOT = pathlib.Path(os.environ.get("CCFR_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))

# Keys of the other files these scripts read: run.json (scene, solver, offset, vertices, config.time),
# ablation.csv (scripts/results_md.py's ablation tables), the environment, the command line, and
# text searched in `ccfr audit`'s verdict line.
OTHER_KEYS = {
    "scene", "solver", "offset", "vertices", "config", "time", "substeps", "iterations",
    "frames", "avg_frame_s", "max_frame_s", "max_violations_remaining", "min_distance_over_offset", "audit",
    "audit_violations", "CCFR_BUILD_DIR", "--regenerate", "min distance",
}


def stats_columns():
    doc = (ROOT / "docs" / "output.md").read_text(encoding="utf-8")
    table = doc.split("(ccfr help-markdown --stats-columns) -->\n", 1)[1].split("<!-- end: stats.csv columns -->", 1)[0]
    return re.findall(r"^\| `([a-z_]+)` \|", table, flags=re.M)


def looked_up_keys(source):
    """String keys the code looks up: x["k"], x.get("k"), "k" in x, f("k") / mean("k") (the
    scripts' column helpers), and the first element of ("k", label, ...) tuples in a list or tuple
    literal (the plotted columns)."""
    keys = set()
    for n in ast.walk(ast.parse(source)):
        if isinstance(n, ast.Subscript) and isinstance(n.slice, ast.Constant) and isinstance(n.slice.value, str):
            keys.add(n.slice.value)
        elif isinstance(n, ast.Call) and n.args and isinstance(n.args[0], ast.Constant) and \
                isinstance(n.args[0].value, str):
            fn = n.func
            if (isinstance(fn, ast.Attribute) and fn.attr == "get") or (isinstance(fn, ast.Name) and
                                                                       fn.id in ("f", "mean")):
                keys.add(n.args[0].value)
        elif isinstance(n, ast.Compare) and isinstance(n.left, ast.Constant) and isinstance(n.left.value, str) and \
                all(isinstance(o, (ast.In, ast.NotIn)) for o in n.ops):
            keys.add(n.left.value)
        elif isinstance(n, (ast.List, ast.Tuple)):
            for e in n.elts:
                if isinstance(e, ast.Tuple) and len(e.elts) >= 2 and isinstance(e.elts[0], ast.Constant) and \
                        isinstance(e.elts[0].value, str):
                    keys.add(e.elts[0].value)
    return keys


def embedded_python(shell_script):
    """The Python of a shell script's `python3 - ... <<'PY'` blocks."""
    return re.findall(r"<<'PY'\n(.*?)\nPY\n", shell_script, flags=re.S)


def test_the_column_list_is_the_generated_one():
    cols = stats_columns()
    assert cols[:3] == ["frame", "sim_time", "wall_s"] and "lag_max" in cols and len(cols) == len(set(cols))


@pytest.mark.parametrize("script", ["plot_stats.py", "ccfr_plot_common.py", "results_md.py", "reproduce-results"])
def test_scripts_look_up_stats_columns_by_their_names(script):
    text = (ROOT / "scripts" / script).read_text(encoding="utf-8")
    sources = embedded_python(text) if not script.endswith(".py") else [text]
    keys = set().union(*(looked_up_keys(s) for s in sources))
    columns = set(stats_columns())
    assert keys & columns, "no stats.csv column found: the scan no longer sees how the script reads them"
    assert keys - columns - OTHER_KEYS == set()


def test_a_misspelt_column_is_caught():
    keys = looked_up_keys('rows = []\nf = lambda k: [r[k] for r in rows]\nx = mean("wal_s") + f("cpu_s")\n'
                          'ok = "halted_vertice" in rows[0]\nfor c, label in [("violations_detectd", "d")]: pass\n')
    assert keys - set(stats_columns()) == {"wal_s", "halted_vertice", "violations_detectd"}
