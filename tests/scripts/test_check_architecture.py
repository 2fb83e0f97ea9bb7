"""scripts/check-architecture.py on a small link graph and documents written here: a table that
agrees passes; a missing or extra link, a link in the wrong column, a missing target row and a
public header including a privately linked package each fail, named."""
import os
import pathlib
import subprocess
import sys

SCRIPT = pathlib.Path(os.environ.get("CCFR_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2])) / "scripts" / \
    "check-architecture.py"

GRAPH = [
    ("ccfr_core", "all", "Eigen3::Eigen"), ("ccfr_core", "all", "spdlog::spdlog"),
    ("ccfr_core", "public", "Eigen3::Eigen"),
    ("ccfr_io", "all", "ccfr::core"), ("ccfr_io", "all", "yaml-cpp"), ("ccfr_io", "public", "ccfr::core"),
    ("ccfr", "all", "ccfr::io"), ("ccfr", "all", "CLI11::CLI11"),
]
TABLE = """# Architecture

```
core       ──► Eigen   ┄┄► spdlog
io         ──► core (a note)   ┄┄► yaml-cpp
apps/ccfr              ┄┄► io, CLI11
```

| target | links (public) | links (private) |
|---|---|---|
| `ccfr::core` | Eigen | spdlog |
| `ccfr::io` | `ccfr::core` | yaml-cpp |
| `apps/ccfr` | — | `ccfr::io`, CLI11 |

After the table.
"""


def run(tmp_path, table, graph=GRAPH, headers=None):
    src = tmp_path / "src"
    lines = [f"{t}\t{k}\t{d}" for t, k, d in graph]
    for t in ("ccfr_core", "ccfr_io", "ccfr"):
        lines.append(f"{t}\tsource_dir\t{src / t}")
        (src / t / "include" / "ccfr").mkdir(parents=True, exist_ok=True)
    for (t, name), text in (headers or {}).items():
        (src / t / "include" / "ccfr" / name).write_text(text)
    (tmp_path / "graph.tsv").write_text("\n".join(lines) + "\n")
    (tmp_path / "architecture.md").write_text(table)
    r = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "graph.tsv"), str(tmp_path / "architecture.md")],
                       capture_output=True, text=True)
    return r.returncode, r.stdout + r.stderr


def test_agreeing_table_passes(tmp_path):
    code, out = run(tmp_path, TABLE, headers={("ccfr_io", "a.hpp"): "#include <Eigen/Core>\n"})
    assert code == 0, out
    assert "agrees" in out


def test_missing_and_extra_links_fail(tmp_path):
    code, out = run(tmp_path, TABLE.replace("| yaml-cpp |", "| zlib |"))
    assert code == 1, out
    assert "ccfr::io: links yaml-cpp privately; the table does not say so" in out
    assert "ccfr::io: the table says it links zlib privately; CMake does not" in out


def test_public_link_in_the_private_column_fails(tmp_path):
    code, out = run(tmp_path, TABLE.replace("| Eigen | spdlog |", "| — | Eigen, spdlog |"))
    assert code == 1, out
    assert "ccfr::core: links Eigen publicly; the table does not say so" in out


def test_diagram_disagreeing_fails(tmp_path):
    code, out = run(tmp_path, TABLE.replace("┄┄► io, CLI11", "┄┄► io, CLI11, spdlog"))
    assert code == 1, out
    assert "apps/ccfr: the diagram says it links spdlog privately; CMake does not" in out
    code, out = run(tmp_path, TABLE.replace("io         ──► core (a note)   ┄┄► yaml-cpp\n", ""))
    assert code == 1, out
    assert "ccfr::io: a CMake target the diagram does not list" in out


def test_missing_row_fails(tmp_path):
    code, out = run(tmp_path, TABLE.replace("| `apps/ccfr` | — | `ccfr::io`, CLI11 |\n", ""))
    assert code == 1, out
    assert "apps/ccfr: a CMake target the table does not list" in out
    assert "the diagram" not in out


def test_public_header_with_a_private_package_fails(tmp_path):
    code, out = run(tmp_path, TABLE, headers={("ccfr_core", "log.hpp"): "#pragma once\n#include <spdlog/spdlog.h>\n"})
    assert code == 1, out
    assert "log.hpp:2: public header of ccfr::core includes <spdlog/spdlog.h> (spdlog)" in out


def test_no_table_is_an_error(tmp_path):
    code, out = run(tmp_path, "# Architecture\n\nno table\n")
    assert code != 0
    assert "no table with the header" in out
