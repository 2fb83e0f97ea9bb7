"""The module behaves like Python: built-in exception types, NumPy values anywhere, __version__,
signatures and docstrings (checked against the stub), doctests that run, and the README's session."""
import ast
import doctest
import errno
import inspect
import os
import re
import subprocess
import sys

import ccfr
import numpy as np
import pytest


@pytest.fixture()
def in_tree_copy(tmp_path, source_dir, monkeypatch):
    """A scratch working directory where configs/ is the source tree's (examples write into out/)."""
    (tmp_path / "configs").symlink_to(source_dir / "configs")
    monkeypatch.chdir(tmp_path)
    return tmp_path


# ---- 1. exceptions

def test_missing_files_are_file_not_found_errors(tmp_path, data, ccfr_exe):
    missing = tmp_path / "missing.yaml"
    with pytest.raises(FileNotFoundError) as info:
        ccfr.load_scene(missing)
    e = info.value
    assert isinstance(e, ccfr.Error) and isinstance(e, ccfr.MissingFileError) and not isinstance(e, ccfr.ConfigError)
    assert (e.errno, e.filename) == (errno.ENOENT, str(missing))
    cli = subprocess.run([ccfr_exe, "run", str(missing), "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert str(e) == f"scene file '{missing}' does not exist" and str(e) in cli.stderr
    # A mesh named by the scene: a ConfigError (file, key path, line) and a FileNotFoundError.
    scene = tmp_path / "mesh.yaml"
    scene.write_text("scene: m\nobjects:\n  - name: m\n    kind: obstacle\n    shape: {type: mesh, path: gone.obj}\n")
    with pytest.raises(FileNotFoundError) as info:
        ccfr.load_scene(scene)
    e = info.value
    assert isinstance(e, ccfr.MissingMeshError) and isinstance(e, ccfr.ConfigError)
    assert (e.file, e.key_path, e.line) == (str(scene), "objects[0].shape.path", 5)
    assert (e.errno, e.filename) == (errno.ENOENT, str(tmp_path / "gone.obj"))
    with pytest.raises(ccfr.MissingMeshError):
        ccfr.load_scene_text("objects:\n  - {name: m, kind: obstacle, shape: {type: mesh, path: gone.obj}}\n",
                             base_dir=tmp_path)
    # A run directory.
    with pytest.raises(FileNotFoundError) as info:
        ccfr.audit(tmp_path / "no_run")
    assert isinstance(info.value, ccfr.Error) and info.value.filename == str(tmp_path / "no_run")
    # Paths that exist but are wrong are not FileNotFoundError.
    for call in (lambda: ccfr.load_scene(tmp_path), lambda: ccfr.audit(scene)):
        with pytest.raises(ccfr.Error) as info:
            call()
        assert not isinstance(info.value, FileNotFoundError), str(info.value)
    (tmp_path / "empty.obj").write_text("")
    scene.write_text(scene.read_text().replace("gone.obj", "empty.obj"))
    with pytest.raises(ccfr.ConfigError) as info:
        ccfr.load_scene(scene)
    assert not isinstance(info.value, FileNotFoundError)


@pytest.mark.parametrize("overrides,key_path,detail", [
    ({"time.frames": "abc"}, "time.frames", "expected an integer, got 'abc'"),
    (["time.frames=abc"], "time.frames", "expected an integer, got 'abc'"),
    ({"time.framez": 3}, "time.framez", "unknown key 'framez'"),
    ({"objects.0.kind": "sponge"}, "objects[0].kind", "unknown value 'sponge'"),
    (["time.frames"], "time.frames", "expected key.path=value"),
    ({"contact.offset": -1}, "contact.offset", "out of range"),
])
def test_override_errors_say_overrides_and_name_the_key(data, overrides, key_path, detail):
    for call in (lambda: ccfr.load_scene(data / "small_drop.yaml", overrides=overrides),
                 lambda: ccfr.load_scene(data / "small_drop.yaml").with_overrides(overrides),
                 lambda: ccfr.load_scene_text((data / "small_drop.yaml").read_text(), overrides=overrides)):
        with pytest.raises(ccfr.ConfigError) as info:
            call()
        e = info.value
        item = overrides[0] if isinstance(overrides, list) else "".join(f"{k}={v}" for k, v in overrides.items())
        assert e.file == f"overrides ({item})" and (e.key_path, e.line) == (key_path, 0)
        assert str(e) == f"overrides ({item}): '{key_path}': {e.detail}" and detail in e.detail
        assert "command line" not in str(e) and "--set" not in str(e)
    with pytest.raises(ccfr.ConfigError) as info:
        ccfr.Simulation(ccfr.load_scene(data / "small_drop.yaml"), solver="magic")
    assert str(info.value).startswith("Simulation(solver=magic): 'contact.solver': unknown value 'magic'")


def test_override_values_of_other_types_are_type_errors(data):
    with pytest.raises(TypeError, match="override value"):
        ccfr.load_scene(data / "small_drop.yaml", overrides={"time.frames": object()})
    with pytest.raises(TypeError, match="not a string"):
        ccfr.load_scene(data / "small_drop.yaml", overrides="time.frames=3")


def test_from_arrays_errors_name_the_argument_not_a_generated_line():
    v = np.eye(3)
    with pytest.raises(ccfr.ConfigError) as info:
        ccfr.Scene.from_arrays([dict(name="c", kind="cloth", vertices=v, faces=[[0, 1, 2]])],
                               config={"time": {"fps": -1}})
    e = info.value
    assert (e.file, e.key_path, e.line) == ("<arrays:arrays>", "time.fps", 0)
    assert str(e) == "<arrays:arrays>: 'time.fps': " + e.detail
    with pytest.raises(ccfr.ConfigError) as info:
        ccfr.Scene.from_arrays([dict(name="c", kind="cloth", vertices=v, faces=[[0, 1, 2]])],
                               overrides={"time.fps": -1})
    assert info.value.file == "overrides (time.fps=-1)"
    for key, bad, shape_text in (("vertices", np.zeros((3, 2)), "(n, 3)"), ("faces", [[0, 1]], "(n, 3)"),
                                 ("faces", [[0.0, 1.0, 2.0]], "integers")):
        obj = dict(name="c", kind="cloth", vertices=v, faces=[[0, 1, 2]])
        obj[key] = bad
        with pytest.raises(ValueError) as info:
            ccfr.Scene.from_arrays([dict(name="p", kind="particles", vertices=[[0, 0, 0]]), obj])
        assert str(info.value).startswith(f"objects[1].{key} must") and shape_text in str(info.value)


def test_nested_override_dicts_merge_key_by_key_like_set(data, ccfr_exe, tmp_path):
    """{"time": {"frames": 3}} sets time.frames alone, as `--set time.frames=3` does; the other
    keys of `time` keep the file's values (it once replaced the section: iterations 2 -> 4)."""
    import json
    plain = json.loads(ccfr.load_scene(data / "small_drop.yaml").config_json)["time"]
    merged = ccfr.load_scene(data / "small_drop.yaml", overrides={"time": {"frames": 3}, "contact": {"offset": 0.02}})
    assert merged.overrides == ["time.frames=3", "contact.offset=0.02"]
    cfg = json.loads(merged.config_json)
    assert cfg["time"] == dict(plain, frames=3) and (cfg["time"]["iterations"], cfg["time"]["xpbd_sweeps"]) == (2, 6)
    subprocess.run([ccfr_exe, "run", str(data / "small_drop.yaml"), "--out", str(tmp_path / "cli"), "-q",
                    "--set", "time.frames=3", "--set", "contact.offset=0.02"], check=True)
    assert json.loads((tmp_path / "cli" / "run.json").read_text())["config"]["time"] == cfg["time"]


def test_python_refuses_what_the_cli_refuses(data, ccfr_exe, tmp_path):
    """threads, the audit's options and the projector's inputs have the CLI's and the scene's
    bounds; wrong shapes, dtypes and non-finite values are ValueError naming the argument."""
    cli = subprocess.run([ccfr_exe, "run", str(data / "small_drop.yaml"), "--threads", "100000", "--out",
                          str(tmp_path / "t")], capture_output=True, text=True)
    assert cli.returncode == 2 and "is too many worker threads: at most 1024" in cli.stderr
    for bad in (100000, -1):
        with pytest.raises(ValueError, match="threads"):
            ccfr.Simulation(ccfr.load_scene(data / "small_drop.yaml"), threads=bad)
    sim = ccfr.Simulation(ccfr.load_scene(data / "small_drop.yaml"), threads=2)
    n = sim.num_vertices
    for bad, text in ((np.zeros((n + 1, 3)), f"{n + 1} rows given"), (np.zeros((n, 3), complex), "complex128"),
                      (np.full((n, 3), "1"), "real numbers"), (np.full((n, 3), np.inf), "row 0 is not finite")):
        with pytest.raises(ValueError, match=re.escape(text)):
            sim.set_positions(bad)
        with pytest.raises(ValueError):
            sim.set_velocities(bad)
    run = tmp_path / "run"
    with ccfr.Run(sim, run) as r:
        r.step()
    for kwargs, option in ((dict(stride=0), ["--stride", "0"]), (dict(tolerance=1.0), ["--tol", "1"]),
                           (dict(offset=float("nan")), ["--offset", "nan"]), (dict(offset=-1.0), ["--offset", "-1"])):
        with pytest.raises(ValueError, match=next(iter(kwargs))):
            ccfr.audit(run, **kwargs)
        assert subprocess.run([ccfr_exe, "audit", str(run), *option], capture_output=True).returncode == 2
    assert ccfr.audit(run, stride=1)
    a, c, planes = [0, 0, 0], [0, -1, 0], [[0, 1, 0, 0.1]]
    assert ccfr.project(a, c, planes, epsilon=0.0).status == "projected"
    for kwargs in (dict(anchor=[np.nan, 0, 0]), dict(candidate=[0, 2e6, 0]), dict(candidate=np.zeros(3, complex)),
                   dict(planes=[[0, 2, 0, 0.1]]), dict(planes=[[0, 1, 0, np.inf]]), dict(epsilon=-1.0),
                   dict(epsilon=np.nan), dict(max_iterations=0), dict(sweeps=0)):
        args = dict(anchor=a, candidate=c, planes=planes)
        args.update(kwargs)
        with pytest.raises(ValueError):
            ccfr.project(**args)
    with pytest.raises(ValueError, match="real numbers"):
        ccfr.Scene.from_arrays([dict(name="c", kind="cloth", vertices=np.eye(3, dtype=complex), faces=[[0, 1, 2]])])
    with pytest.raises(ValueError, match="index 9223372036854775808 does not fit 32 bits"):
        ccfr.Scene.from_arrays([dict(name="c", kind="cloth", vertices=np.eye(3),
                                     faces=np.array([[0, 1, 2**63]], dtype=np.uint64))])


def test_late_component_checks_name_the_file_key_and_line(data, tmp_path):
    """contact.dat.query_radius is checked when the simulation starts: the error names the scene
    file and line, or the override, as the schema's errors do (it named neither)."""
    scene = tmp_path / "q.yaml"
    scene.write_text((data / "small_drop.yaml").read_text().replace(
        "  solver: ccfr\n", "  solver: dat\n  dat: {query_radius: 1.0e300}\n"))
    line = scene.read_text().splitlines().index("  dat: {query_radius: 1.0e300}") + 1
    with pytest.raises(ccfr.ConfigError) as info:
        ccfr.Simulation(ccfr.load_scene(scene))
    assert (info.value.file, info.value.key_path, info.value.line) == (str(scene), "contact.dat.query_radius", line)
    with pytest.raises(ccfr.ConfigError) as info:
        ccfr.Simulation(ccfr.load_scene(data / "small_drop.yaml", overrides={"contact": {
            "solver": "dat", "dat": {"query_radius": 1e-300}}}))
    assert (info.value.file, info.value.key_path) == ("overrides (contact.dat.query_radius=1e-300)",
                                                      "contact.dat.query_radius")


# ---- 2. NumPy scalars and arrays

def test_numpy_values_are_accepted_like_python_ones(data, tmp_path):
    plain = {"time.frames": 2, "contact.offset": 0.02, "time.gravity": [0.0, -5.0, 0.0],
             "contact.analytic_obstacles": False}
    numpy = {"time.frames": np.int64(2), "contact.offset": np.float64(0.02),
             "time.gravity": np.array([0.0, -5.0, 0.0]), "contact.analytic_obstacles": np.bool_(False)}
    a = ccfr.load_scene(data / "small_drop.yaml", overrides=plain)
    b = ccfr.load_scene(data / "small_drop.yaml", overrides=numpy)
    assert a.config_json == b.config_json and '"frames": 2' in b.config_json
    assert ccfr.load_scene(data / "small_drop.yaml").with_overrides(numpy).config_json == a.config_json
    # from_arrays: NumPy in config, object keys, pins, and an overrides dict.
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [1, 0, 1]], dtype=np.float32)
    f = np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int64)
    s1 = ccfr.Scene.from_arrays([dict(name="c", kind="cloth", vertices=v.tolist(), faces=f.tolist(), pins=[[0]],
                                      velocity=[0, 1, 0])], config={"time": {"frames": 3}},
                                overrides={"contact.offset": 0.01})
    s2 = ccfr.Scene.from_arrays([dict(name="c", kind="cloth", vertices=v, faces=f.astype(np.uint16),
                                      pins=[np.array([0])], velocity=np.array([0, 1, 0], np.int32))],
                                config={"time": {"frames": np.int32(3)}}, overrides={"contact.offset": np.float64(0.01)})
    assert s1.config_json == s2.config_json and np.array_equal(s1.positions, s2.positions)
    # State setters, stepping, thread counts, the audit and the kernels.
    sims = [ccfr.Simulation(a, threads=2), ccfr.Simulation(b, threads=np.int64(2))]
    x = (sims[0].positions + [0.0, 0.01, 0.0]).astype(np.float32)
    sims[0].set_positions(x.astype(np.float64).tolist()), sims[1].set_positions(x)
    sims[0].set_velocities(np.zeros((a.num_vertices, 3)).tolist()), sims[1].set_velocities(np.zeros_like(x))
    sims[0].step(2), sims[1].step(np.int64(2))
    assert np.array_equal(sims[0].positions, sims[1].positions) and sims[1].frame == 2
    with ccfr.Run(ccfr.Simulation(b, threads=2), tmp_path / "run") as run:
        run.step(np.int32(2))
    r1 = ccfr.audit(tmp_path / "run", offset=0.02, stride=1, tolerance=1e-6)
    r2 = ccfr.audit(tmp_path / "run", offset=np.float64(0.02), stride=np.int64(1), tolerance=np.float32(1e-6))
    assert (r1.verdict, r1.min_distance, r1.offset) == (r2.verdict, r2.min_distance, r2.offset) == (
        r1.verdict, r1.min_distance, 0.02)
    p1 = ccfr.project([0, 0, 0], [1, -1, 0], [[0, 1, 0, 0]], epsilon=1e-6, max_iterations=4)
    p2 = ccfr.project(np.zeros(3, np.float32), np.array([1, -1, 0]), np.array([[0, 1, 0, 0]], np.int8),
                      epsilon=np.float64(1e-6), max_iterations=np.int64(4))
    assert np.array_equal(p1.x, p2.x)
    q = ccfr.point_edge(np.float32([0.5, 1, 0]), np.zeros(3, int), [1, 0, 0])
    assert (q["t"], q["distance"]) == (0.5, 1.0)


# ---- 3. version

def test_version_comes_from_cmake_once(source_dir):
    cmake = re.search(r"project\(ccfr\s+VERSION\s+([0-9.]+)", (source_dir / "CMakeLists.txt").read_text()).group(1)
    assert ccfr.__version__ == ccfr.version() == cmake
    pyproject = (source_dir / "pyproject.toml").read_text()
    assert not re.search(r"^version\s*=", pyproject, re.M) and 'dynamic = ["version"]' in pyproject
    out = subprocess.run([sys.executable, str(source_dir / "setup.py"), "--version"], capture_output=True, text=True,
                         cwd=source_dir)
    assert out.stdout.strip().splitlines()[-1] == cmake, out.stderr


# ---- 4. signatures and docstrings, module and stub

def _public_members(cls):
    """Public attributes a class defines (not those of object, Exception or OSError)."""
    base = set(dir(FileNotFoundError)) | set(dir(RuntimeError))
    return {a for a in dir(cls) if not a.startswith("_") and a not in base}


def _stub(source_dir):
    tree = ast.parse((source_dir / "python" / "ccfr" / "__init__.pyi").read_text())
    top = {n.name: n for n in tree.body if isinstance(n, (ast.ClassDef, ast.FunctionDef))}
    variables = {n.target.id for n in tree.body if isinstance(n, ast.AnnAssign)}
    return top, variables


def _members(node):
    names = {}
    for n in node.body:
        if isinstance(n, ast.FunctionDef):
            names[n.name] = n
        elif isinstance(n, ast.AnnAssign):
            names[n.target.id] = n
    return names


def test_module_and_stub_list_the_same_names(source_dir):
    top, variables = _stub(source_dir)
    public_stub = {k for k in top if not k.startswith("_")}
    assert public_stub == set(ccfr.__all__), (public_stub ^ set(ccfr.__all__))
    assert "__version__" in variables
    public_module = {k for k, v in vars(ccfr).items() if not k.startswith("_") and not inspect.ismodule(v)
                     and k not in {"annotations", "Any", "Mapping", "Optional", "Sequence", "Union", "np"}}
    assert public_module == set(ccfr.__all__), public_module ^ set(ccfr.__all__)
    for name in ccfr.__all__:
        obj = getattr(ccfr, name)
        if not inspect.isclass(obj):
            continue
        stubbed = {k for k in _members(top[name]) if not k.startswith("_")}
        if issubclass(obj, BaseException):
            # The stub declares the attributes set on an instance; the class itself has none.
            assert not _public_members(obj), (name, _public_members(obj))
            continue
        assert stubbed == _public_members(obj), (name, stubbed ^ _public_members(obj))


def test_every_public_function_and_method_has_a_signature_and_a_docstring(source_dir):
    top, _ = _stub(source_dir)
    for name in ccfr.__all__:
        obj = getattr(ccfr, name)
        assert inspect.getdoc(obj), name
        assert ast.get_docstring(top[name]), f"stub: {name}"
        if not inspect.isclass(obj):
            stub_params = [a.arg for a in top[name].args.args]
            assert list(inspect.signature(obj).parameters) == stub_params, name
            continue
        stub_init = _members(top[name]).get("__init__")
        if stub_init:  # Simulation and Run; the other classes come out of functions
            assert list(inspect.signature(obj).parameters) == [a.arg for a in stub_init.args.args][1:], name
        stub_members = _members(top[name]) if name in top else {}
        for attr in _public_members(obj) | ({"__init__", "__enter__", "__exit__"} & set(stub_members)):
            member = inspect.getattr_static(obj, attr)
            assert inspect.getdoc(getattr(obj, attr)), f"{name}.{attr}"
            if isinstance(member, property) or not callable(getattr(obj, attr)):
                continue
            params = list(inspect.signature(getattr(obj, attr)).parameters)
            stub = stub_members[attr]
            assert ast.get_docstring(stub), f"stub: {name}.{attr}"
            assert params == [a.arg for a in stub.args.args], (name, attr, params)


# ---- 5. doctests, and the paths they cite

def test_docstring_examples_run(in_tree_copy):
    # The classes say __module__ == "ccfr", so the finder walks into them from the module.
    tests = [t for t in doctest.DocTestFinder().find(ccfr, "ccfr") if t.examples]
    with_examples = {t.docstring for t in tests}
    # Every public function has an example, and the classes one makes directly.
    needed = [ccfr, ccfr.Simulation, ccfr.Run] + [getattr(ccfr, n) for n in ccfr.__all__
                                                   if not inspect.isclass(getattr(ccfr, n))]
    missing = [getattr(o, "__name__", o) for o in needed if o.__doc__ not in with_examples]
    assert not missing, missing
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    for t in tests:
        t.globs.update({"ccfr": ccfr, "np": np})
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0 and result.attempted > 30, result


def test_paths_cited_in_docstrings_exist(source_dir):
    docs = [ccfr.__doc__]
    for name in ccfr.__all__:
        obj = getattr(ccfr, name)
        docs.append(inspect.getdoc(obj))
        if inspect.isclass(obj):
            docs += [inspect.getdoc(getattr(obj, a)) for a in _public_members(obj)]
    cited = set()
    for d in filter(None, docs):
        cited |= set(re.findall(r"\b((?:configs|tests|examples|docs|scripts)/[\w./-]*\w)", d))
    assert "configs/drape.yaml" in cited
    missing = sorted(p for p in cited if not (source_dir / p).exists())
    assert not missing, missing


# ---- 6. the README's session

def test_readme_python_session_prints_what_it_says(in_tree_copy, source_dir):
    readme = (source_dir / "README.md").read_text()
    section = readme[readme.index("## From Python"):]
    section = section[:section.index("\n## ", 1)]
    assert "PYTHONPATH=build/python /usr/bin/python3 session.py" in section
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    expected = re.search(r"```text\n(.*?)```", section, re.S).group(1)
    (in_tree_copy / "session.py").write_text(code)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    out = subprocess.run([sys.executable, "session.py"], capture_output=True, text=True, env=env, timeout=240)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == expected.splitlines()
