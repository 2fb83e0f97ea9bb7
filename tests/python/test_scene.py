"""Scenes from files, text and NumPy arrays; every error class maps to a Python exception."""
import subprocess

import ccfr
import numpy as np
import pytest

CONFIG = {"time": {"fps": 60, "frames": 3, "substeps": 4, "iterations": 2, "xpbd_sweeps": 6},
          "contact": {"solver": "ccfr", "radius": 0.01, "offset": 0.01},
          "materials": {"cotton": {"density": 0.2, "stretch_compliance": 1.0e-7}}}


def grid(n, size):
    """A regular (n+1)^2 grid in the xz plane, two triangles per cell, built independently of ccfr."""
    t = np.linspace(-size / 2, size / 2, n + 1)
    xs, zs = np.meshgrid(t, t, indexing="ij")
    v = np.stack([xs.ravel(), np.zeros(xs.size), zs.ravel()], axis=1)
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return v, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def test_load_scene_overrides_dict_and_list(data):
    a = ccfr.load_scene(data / "small_drop.yaml", overrides={"contact.offset": 0.02, "time.frames": 3})
    b = ccfr.load_scene(data / "small_drop.yaml", overrides=["contact.offset=0.02", "time.frames=3"])
    assert '"offset": 0.02' in a.config_json and a.config_json == b.config_json
    assert a.num_vertices == 15 * 15 + b.num_vertices - 15 * 15
    assert a.objects[0] == {"name": "cloth", "kind": "cloth", "vertex_begin": 0, "vertex_end": 225}


def test_arrays_scene_equals_the_yaml_scene_it_copies(data):
    # The arrays of a YAML scene fed back through Scene.from_arrays simulate bitwise identically.
    yaml_scene = ccfr.load_scene(data / "small_drop.yaml", overrides={"time.frames": 3})
    x, faces = yaml_scene.positions, yaml_scene.faces
    cloth, ball = yaml_scene.objects
    cf = faces[(faces < cloth["vertex_end"]).all(axis=1)]
    bf = faces[(faces >= ball["vertex_begin"]).all(axis=1)] - ball["vertex_begin"]
    config = {"time": {"fps": 60, "frames": 3, "substeps": 4, "iterations": 2, "xpbd_sweeps": 6},
              "contact": {"solver": "ccfr", "radius": 0.01, "offset": 0.01, "analytic_obstacles": False},
              "materials": {"cotton": {"density": 0.2, "stretch_compliance": 1.0e-7}}}
    arrays_scene = ccfr.Scene.from_arrays(
        [dict(name="cloth", kind="cloth", material="cotton", vertices=x[:225], faces=cf, velocity=[0, -1.5, 0]),
         dict(name="ball", kind="obstacle", vertices=x[225:], faces=bf)], config=config, name="small_drop")
    ref = ccfr.load_scene(data / "small_drop.yaml", overrides={"time.frames": 3, "contact.analytic_obstacles": False})
    s1, s2 = ccfr.Simulation(arrays_scene, threads=2), ccfr.Simulation(ref, threads=2)
    s1.step(3), s2.step(3)
    assert np.array_equal(s1.positions, s2.positions)
    assert s1.stats["constraints"] > 0


def test_arrays_of_every_kind():
    v, f = grid(4, 0.4)
    strand = np.array([[0, 0.3, 0], [0.02, 0.3, 0], [0.04, 0.3, 0], [0.2, 0.3, 0], [0.22, 0.3, 0]])
    tet = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]) + [0.3, 0.5, 0.3]
    scene = ccfr.Scene.from_arrays([
        dict(name="sheet", kind="cloth", vertices=v + [0, 0.2, 0], faces=f, pins=[[0, 4]]),
        dict(name="hair", kind="strand", vertices=strand, edges=[[0, 1], [1, 2], [3, 4]]),
        dict(name="jelly", kind="tet_solid", vertices=tet, tets=[[0, 1, 2, 3]]),
        dict(name="dust", kind="particles", vertices=[[0.5, 0.5, 0.5]]),
    ], config=CONFIG)
    assert [o["kind"] for o in scene.objects] == ["cloth", "strand", "tet_solid", "particles"]
    sim = ccfr.Simulation(scene, threads=2)
    assert list(sim.kinematic_vertices) == [0, 4]
    sim.step()
    assert np.isfinite(sim.positions).all()


@pytest.mark.parametrize("obj,key_path,message", [
    (dict(name="c", kind="cloth", vertices=np.zeros((3, 3)) + np.eye(3), faces=[[0, 1, 3]]), "objects[0].faces",
     "vertex index 3 out of range"),
    (dict(name="c", kind="cloth", vertices=np.eye(3), faces=[[0, 1, 1]]), "objects[0].faces", "repeats vertex"),
    (dict(name="c", kind="cloth", vertices=[[0, 0, 0], [1, 0, 0], [2, 0, 0]], faces=[[0, 1, 2]]), "objects[0].faces",
     "zero area"),
    (dict(name="c", kind="cloth", vertices=np.eye(3), faces=[[0, 1, 2], [2, 1, 0]]), "objects[0].faces",
     "repeats face 1"),
    (dict(name="c", kind="cloth", vertices=np.eye(3)), "objects[0].faces", "needs faces"),
    (dict(name="c", kind="cloth", vertices=np.zeros((0, 3)), faces=np.zeros((0, 3), int)), "objects[0].vertices",
     "no vertices"),
    (dict(name="c", kind="cloth", vertices=[[0, 0, np.nan], [1, 0, 0], [0, 1, 0]], faces=[[0, 1, 2]]),
     "objects[0].vertices", "vertex 0 is not finite"),
    (dict(name="r", kind="rigid", vertices=np.eye(3), faces=[[0, 1, 2]]), "objects[0].faces", "closed surface"),
    (dict(name="t", kind="tet_solid", vertices=[[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1]], tets=[[0, 1, 2, 3]]),
     "objects[0].tets", "negative volume"),
    (dict(name="s", kind="strand", vertices=np.eye(3), faces=[[0, 1, 2]]), "objects[0].kind", "takes edges"),
    (dict(name="s", kind="strand", vertices=np.eye(3), edges=[[1, 1]]), "objects[0].edges", "repeats vertex"),
    (dict(name="c", kind="cloth", vertices=np.eye(3), faces=[[0, 1, 2]], material="silk"), "objects[0].material",
     "unknown material 'silk'"),
    (dict(name="c", kind="cloth", vertices=np.eye(3), faces=[[0, 1, 2]], pins=[[7]]), "objects[0].pins[0].indices[0]",
     "out of range"),
    (dict(name="c", kind="sponge", vertices=np.eye(3), faces=[[0, 1, 2]]), "objects[0].kind", "sponge"),
])
def test_array_errors_are_config_errors_with_the_key_path(obj, key_path, message):
    with pytest.raises(ccfr.ConfigError) as info:
        ccfr.Scene.from_arrays([obj], config=CONFIG)
    e = info.value
    assert e.key_path == key_path and message in str(e) and message in e.detail
    assert e.file == "<arrays:arrays>" and e.line == 0  # the generated document's lines mean nothing
    assert isinstance(e, ccfr.Error) and isinstance(e, RuntimeError)


def test_yaml_errors_carry_file_key_path_and_line(tmp_path, data, ccfr_exe):
    bad = tmp_path / "bad.yaml"
    bad.write_text((data / "small_drop.yaml").read_text().replace("radius: 0.01", "radius: -0.01"))
    with pytest.raises(ccfr.ConfigError) as info:
        ccfr.load_scene(bad)
    e = info.value
    line = next(i for i, l in enumerate(bad.read_text().splitlines(), 1) if "radius: -0.01" in l)
    assert (e.file, e.key_path, e.line) == (str(bad), "contact.radius", line)
    assert str(e).startswith(f"{bad}:{line}: 'contact.radius': ")
    # The message `ccfr run` prints for the same file.
    cli = subprocess.run([ccfr_exe, "run", str(bad), "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert cli.returncode != 0 and str(e) in cli.stderr
    with pytest.raises(ccfr.ConfigError) as info:
        ccfr.load_scene_text("time: {fps: 60}\nsurprise: 1\n", label="inline.yaml")
    assert (info.value.file, info.value.key_path, info.value.line) == ("inline.yaml", "surprise", 2)
    with pytest.raises(ccfr.ConfigError, match="contact.solver"):
        ccfr.Simulation(ccfr.load_scene(data / "small_drop.yaml"), solver="magic")


def test_other_errors_map_to_their_classes(tmp_path, data):
    with pytest.raises(ccfr.Error, match="does not exist") as info:
        ccfr.load_scene(tmp_path / "missing.yaml")
    assert type(info.value) is ccfr.MissingFileError
    sim = ccfr.Simulation(ccfr.load_scene(data / "handle.yaml"), threads=2)
    x = sim.positions.copy()
    x[1], x[2] = [1.7e308, 0, 0], [-1.7e308, 0, 0]  # finite, but their edge's length overflows
    sim.set_positions(x)
    with pytest.raises(ccfr.NumericalError) as info:
        sim.step()
    assert (info.value.frame, info.value.vertex, info.value.stage) == (1, 1, "xpbd")
    with pytest.raises(ccfr.Error, match="is not a directory"):
        ccfr.audit(tmp_path / "no_run")
    (tmp_path / "file").write_text("x")
    with pytest.raises(ccfr.Error):
        with ccfr.Run(ccfr.Simulation(ccfr.load_scene(data / "handle.yaml")), tmp_path / "file"):
            pass
    with pytest.raises(ccfr.Error, match="unknown"):
        ccfr.project([0, 0, 0], [0, 0, 0], np.zeros((0, 4)), method="newton")
