#!/usr/bin/env python3
"""Checks docs/architecture.md's link table against the CMake targets (ctest architecture_doc).

GRAPH is written by tests/CMakeLists.txt at configure time, one line per fact:
    <target>\tpublic\t<dependency>     (INTERFACE_LINK_LIBRARIES without $<LINK_ONLY:...>)
    <target>\tall\t<dependency>        (LINK_LIBRARIES: every direct dependency)
    <target>\tsource_dir\t<directory>
The table is the one whose header is `| target | links (public) | links (private) |`; the diagram
is every line `target ──► public, ... ┄┄► private, ...` (short names: io, geometry/exact; notes in
parentheses). Fails (exit 1) naming every disagreement of either: a dependency the table lacks or has too many, public against private, a
target missing from either side, and a public header that includes a third-party header its
target does not link publicly (directly or through a public ccfr dependency).

With CONFIG (cmake/ccfrConfig.cmake.in), also checks its per-component package lists
(`set(_ccfr_needs_<component> ...)`, what find_package(ccfr COMPONENTS ...) looks for) against the
same graph: a component needs every target it links, public or private (static libraries).

Usage: check-architecture.py GRAPH ARCHITECTURE_MD [CONFIG]
"""
import pathlib
import re
import sys

# The names the document uses for the CMake targets of third-party packages.
THIRD_PARTY = {
    "Eigen3::Eigen": "Eigen",
    "spdlog::spdlog": "spdlog",
    "TBB::tbb": "oneTBB",
    "fcl": "FCL",
    "CGAL::CGAL": "CGAL",
    "yaml-cpp": "yaml-cpp",
    "nlohmann_json::nlohmann_json": "nlohmann-json",
    "ZLIB::ZLIB": "zlib",
    "embree": "Embree",
    "PkgConfig::STB": "stb",
    "CLI11::CLI11": "CLI11",
}
# Header prefixes of those packages, for the public-header check (fmt comes with spdlog).
INCLUDES = {
    "Eigen": ("Eigen/", "unsupported/Eigen/"),
    "spdlog": ("spdlog/", "fmt/"),
    "oneTBB": ("tbb/", "oneapi/tbb"),
    "FCL": ("fcl/",),
    "CGAL": ("CGAL/",),
    "yaml-cpp": ("yaml-cpp/",),
    "nlohmann-json": ("nlohmann/",),
    "zlib": ("zlib.h",),
    "Embree": ("embree3/", "embree4/"),
    "stb": ("stb_image", "stb/"),
    "CLI11": ("CLI/",),
}
# Those packages as ccfrConfig.cmake.in names them (find_dependency / pkg_check_modules).
CONFIG_NAMES = {"Eigen": "Eigen3", "spdlog": "spdlog", "oneTBB": "TBB", "FCL": "fcl", "CGAL": "CGAL",
                "yaml-cpp": "yaml-cpp", "nlohmann-json": "nlohmann_json", "zlib": "ZLIB", "Embree": "embree",
                "stb": "stb", "CLI11": "CLI11"}
HEADER = re.compile(r"^\|\s*target\s*\|\s*links \(public\)\s*\|\s*links \(private\)\s*\|\s*$")


def doc_name(cmake_name):
    """`ccfr::io` for ccfr_io and ccfr::io, `apps/ccfr` for the executable, else the package name."""
    if cmake_name == "ccfr":
        return "apps/ccfr"
    m = re.fullmatch(r"(?:ccfr_|ccfr::)(\w+)", cmake_name)
    if m:
        return "ccfr::" + m.group(1)
    return THIRD_PARTY.get(cmake_name, cmake_name)


def read_graph(path):
    public, every, dirs = {}, {}, {}
    for line in pathlib.Path(path).read_text().splitlines():
        if not line.strip():
            continue
        target, kind, value = line.split("\t")
        t = doc_name(target)
        public.setdefault(t, set())
        every.setdefault(t, set())
        if kind == "public":
            public[t].add(doc_name(value))
        elif kind == "all":
            every[t].add(doc_name(value))
        elif kind == "source_dir":
            dirs[t] = pathlib.Path(value)
    return public, {t: every[t] - public[t] for t in every}, dirs


def split_cell(cell):
    cell = cell.strip()
    if cell in ("", "—", "-"):
        return set()
    return {c.strip().strip("`") for c in cell.split(",")}


def read_table(path):
    lines = pathlib.Path(path).read_text().splitlines()
    start = next((i for i, l in enumerate(lines) if HEADER.match(l)), None)
    if start is None:
        raise SystemExit(f"{path}: no table with the header | target | links (public) | links (private) |")
    public, private = {}, {}
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        cells = line.strip().strip("|").split("|")
        if len(cells) != 3:
            raise SystemExit(f"{path}: a row of the link table has {len(cells)} cells, not 3: {line}")
        t = cells[0].strip().strip("`")
        public[t], private[t] = split_cell(cells[1]), split_cell(cells[2])
    return public, private


MODULES = {"core", "geometry", "geometry/exact", "feasibility", "collision", "solvers", "formats", "scene", "run", "io",
           "render"}


def diagram_name(name):
    name = re.sub(r"\s*\(.*?\)", "", name).strip()  # "(the audit)" is a note
    return "ccfr::" + name.replace("geometry/exact", "geometry_exact") if name in MODULES else name


def read_diagram(path):
    """The lines `target ──► public, ... ┄┄► private, ...` of the document's code blocks."""
    public, private = {}, {}
    in_code = False
    for line in pathlib.Path(path).read_text().splitlines():
        if line.startswith("```"):
            in_code = not in_code
            continue
        if not in_code or ("──►" not in line and "┄┄►" not in line):
            continue
        m = re.fullmatch(r"\s*(\S+)\s*(?:──►(.*?))?\s*(?:┄┄►(.*))?", line)
        if not m:
            raise SystemExit(f"{path}: cannot read the diagram line: {line}")
        t = diagram_name(m.group(1))
        public[t] = {diagram_name(x) for x in (m.group(2) or "").split(",") if x.strip()}
        private[t] = {diagram_name(x) for x in (m.group(3) or "").split(",") if x.strip()}
    return public, private


def closure(target, public):
    """Everything `target` exposes to its users: its public links and theirs."""
    seen, todo = set(), [target]
    while todo:
        for d in public.get(todo.pop(), ()):
            if d not in seen:
                seen.add(d)
                todo.append(d)
    return seen


def compare(what, g_pub, g_priv, d_pub, d_priv, problems):
    for t in sorted(set(g_pub) | set(d_pub)):
        if t not in d_pub:
            problems.append(f"{t}: a CMake target the {what} does not list")
            continue
        if t not in g_pub:
            problems.append(f"{t}: in the {what}, but no such CMake target")
            continue
        for scope, g, d in (("public", g_pub[t], d_pub[t]), ("private", g_priv[t], d_priv[t])):
            for x in sorted(g - d):
                problems.append(f"{t}: links {x} {scope}ly; the {what} does not say so")
            for x in sorted(d - g):
                problems.append(f"{t}: the {what} says it links {x} {scope}ly; CMake does not")


def check(graph_path, doc_path):
    g_pub, g_priv, dirs = read_graph(graph_path)
    problems = []
    compare("table", g_pub, g_priv, *read_table(doc_path), problems)
    compare("diagram", g_pub, g_priv, *read_diagram(doc_path), problems)
    # Public headers: a third-party header in one must come from a public link.
    for t, src in sorted(dirs.items()):
        inc = src / "include"
        if not inc.is_dir():
            continue
        exposed = closure(t, g_pub)
        for h in sorted(inc.rglob("*.hpp")):
            for n, line in enumerate(h.read_text(errors="replace").splitlines(), 1):
                m = re.match(r"\s*#\s*include\s*<([^>]+)>", line)
                if not m:
                    continue
                for package, prefixes in INCLUDES.items():
                    if m.group(1).startswith(prefixes) and package not in exposed:
                        problems.append(f"{h}:{n}: public header of {t} includes <{m.group(1)}> ({package}), "
                                        f"which {t} does not link publicly")
    return problems


def check_config(graph_path, config_path):
    """The config's `_ccfr_needs_<c>` lists and `_ccfr_all` against the graph's library targets."""
    g_pub, g_priv, _ = read_graph(graph_path)
    text = pathlib.Path(config_path).read_text()
    lists = {m.group(1): set(m.group(2).split())
             for m in re.finditer(r"^set\(_ccfr_(needs_\w+|all)\s+([^)]*)\)", text, re.M)}
    problems = []
    libraries = {t[len("ccfr::"):] for t in g_pub if t.startswith("ccfr::")}
    listed = lists.get("all", set())
    for c in sorted(libraries - listed):
        problems.append(f"{config_path}: _ccfr_all lacks the library {c}")
    for c in sorted(listed - libraries):
        problems.append(f"{config_path}: _ccfr_all lists {c}, which is no library target")
    for c in sorted(libraries):
        t = "ccfr::" + c
        want = {d[len("ccfr::"):] if d.startswith("ccfr::") else CONFIG_NAMES.get(d, d) for d in g_pub[t] | g_priv[t]}
        have = lists.get("needs_" + c)
        if have is None:
            problems.append(f"{config_path}: no _ccfr_needs_{c} for the library {c}")
            continue
        for d in sorted(want - have):
            problems.append(f"{config_path}: {c} links {d}; _ccfr_needs_{c} lacks it")
        for d in sorted(have - want):
            problems.append(f"{config_path}: _ccfr_needs_{c} lists {d}; {c} does not link it")
    return problems


def main(argv):
    if len(argv) not in (3, 4):
        print(__doc__, file=sys.stderr)
        return 2
    problems = check(argv[1], argv[2])
    if len(argv) == 4:
        problems += check_config(argv[1], argv[3])
    for p in problems:
        print(p)
    if problems:
        print(f"{argv[2]}: {len(problems)} disagreement(s) with the CMake targets")
        return 1
    print(f"{argv[2]}: the link table agrees with the CMake targets")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
