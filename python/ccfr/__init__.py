"""ccfr from Python: scenes, stepping, run directories, the audit, projectors and closest points.

A session (run from the source tree; configs/drape.yaml is a cloth draped over a ball):

>>> import ccfr
>>> scene = ccfr.load_scene("configs/drape.yaml", overrides={"time.frames": 3})
>>> sim = ccfr.Simulation(scene, solver="ccfr", threads=2)
>>> with ccfr.Run(sim, "out/drape") as run:
...     for _ in range(sim.frames):
...         stats = run.step()
>>> sim.positions.shape, stats["frame"], ccfr.audit("out/drape").verdict
((2323, 3), 3, 'pass')

The state arrays are read-only NumPy views of the C++ buffers (no copy). Errors are ccfr.Error
(ConfigError, NumericalError, GuaranteeError); a missing file is also a FileNotFoundError.
docs/python.md has the whole API.
"""
from __future__ import annotations

import os
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np

from ._core import (  # noqa: F401  (re-exported)
    AuditResult,
    ConfigError,
    Error,
    FrameAudit,
    GuaranteeError,
    MissingFileError,
    MissingMeshError,
    NumericalError,
    Projection,
    Run,
    Scene,
    Simulation,
)
from . import _core

__all__ = [
    "AuditResult", "ConfigError", "Error", "FrameAudit", "GuaranteeError", "MissingFileError", "MissingMeshError",
    "NumericalError", "Projection", "Run", "Scene", "Simulation", "audit", "edge_edge", "load_scene",
    "load_scene_text", "point_edge", "point_triangle", "project", "projector_names", "scene_from_arrays",
    "set_log_level", "version",
]

#: The project version of CMakeLists.txt, compiled into the library (run.json records it too).
__version__: str = _core.version()

_Path = Union[str, "os.PathLike[str]"]
_Overrides = Union[Mapping[str, Any], Sequence[str], None]

# help(), repr() and doctest name the classes where users find them: ccfr, not ccfr._core.
for _cls in (AuditResult, FrameAudit, Projection, Run, Scene, Simulation):
    _cls.__module__ = __name__

# The scene summary and per-frame lines of `ccfr run` are info; a Python session sees warnings.
_core.set_log_level("warn")


def set_log_level(level: str) -> None:
    """Sets the level of ccfr's log on stderr: trace, debug, info, warn (the default here), error or off.

    >>> ccfr.set_log_level("error")
    >>> ccfr.set_log_level("warn")
    """
    _core.set_log_level(level)


def version() -> str:
    """The library version, the project version of CMakeLists.txt (also ccfr.__version__).

    >>> ccfr.version() == ccfr.__version__
    True
    """
    return _core.version()


def load_scene(path: _Path, overrides: _Overrides = None) -> Scene:
    """Loads and validates a YAML scene file.

    overrides: a dict {"contact.offset": 0.02} (values, NumPy scalars and arrays included, written as
    JSON, which YAML reads) or a list ["contact.offset=0.02"], applied before validation like
    `ccfr run --set`. Errors: ccfr.MissingFileError (a FileNotFoundError) when `path` does not
    exist, ccfr.MissingMeshError for a mesh file it names that does not, ccfr.ConfigError naming
    file, key path and line, or "overrides (key=value)" for a bad override.

    >>> scene = ccfr.load_scene("configs/drape.yaml", overrides={"time.frames": np.int64(3)})
    >>> scene.name, scene.num_vertices, [o["name"] for o in scene.objects]
    ('drape', 2323, ['cloth', 'ball'])
    >>> ccfr.load_scene("configs/drape.yaml", overrides={"time.frames": "three"})
    Traceback (most recent call last):
    ...
    ccfr.ConfigError: overrides (time.frames=three): 'time.frames': expected an integer, got 'three'
    >>> ccfr.load_scene("no_such_scene.yaml")
    Traceback (most recent call last):
    ...
    ccfr.MissingFileError: scene file 'no_such_scene.yaml' does not exist
    """
    return _core.load_scene(path, overrides)


def load_scene_text(yaml: str, label: str = "<text>", base_dir: _Path = ".", overrides: _Overrides = None) -> Scene:
    """Loads a scene from YAML text; `label` names it in errors, mesh paths are relative to `base_dir`.

    >>> scene = ccfr.load_scene_text('''
    ... time: {fps: 60, frames: 1}
    ... objects:
    ...   - {name: sheet, kind: cloth, shape: {type: grid, size: [1, 1], resolution: [2, 2]}}
    ... ''', label="sheet.yaml")
    >>> scene.num_vertices, scene.faces.shape
    (9, (8, 3))
    >>> ccfr.load_scene_text("time: {fps: 60}\\nsurprise: 1\\n", label="inline.yaml")
    Traceback (most recent call last):
    ...
    ccfr.ConfigError: inline.yaml:2: 'surprise': unknown key 'surprise'...
    """
    return _core.load_scene_text(yaml, label, base_dir, overrides)


# Keys of an object given as arrays that are not passed to the scene document as they are.
_ARRAY_KEYS = ("vertices", "faces", "edges", "tets")


def _plain(value: Any) -> Any:
    """NumPy scalars and arrays as JSON-compatible Python values (JSON is YAML)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def scene_from_arrays(objects: Sequence[Mapping[str, Any]], config: Optional[Mapping[str, Any]] = None,
                      overrides: _Overrides = None, name: str = "arrays") -> Scene:
    """Builds a Scene from NumPy arrays, validated exactly like a YAML scene file (also Scene.from_arrays).

    objects: one mapping per object with `name`, `kind` (cloth, shell, tet_solid, strand, particles,
    obstacle, rigid), `vertices` ((n, 3) floats) and, by kind, `faces` ((m, 3) ints), `edges` ((m, 2),
    strands; consecutive edges (a, b), (b, c) chain into one strand) or `tets` ((m, 4), positively
    oriented); any other object key of the scene file (`material`, `pins`, `velocity`, `motion`,
    `transform`) as in YAML. Pins: a list of index arrays, or of mappings as in YAML.
    config: the other top-level keys of a scene file (time, contact, materials, ...).
    Errors are ccfr.ConfigError with file <arrays:NAME> and the key path of the offending entry,
    e.g. objects[0].faces or time.fps (no line: the document is generated); wrong array shapes
    are ValueError naming the entry.

    >>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1]], dtype=np.float32)
    >>> scene = ccfr.Scene.from_arrays([dict(name="tri", kind="cloth", vertices=V, faces=[[0, 1, 2]])],
    ...                                config={"time": {"frames": np.int64(2)}})
    >>> scene.num_vertices, scene.faces.tolist()
    (3, [[0, 1, 2]])
    >>> ccfr.Scene.from_arrays([dict(name="tri", kind="cloth", vertices=V, faces=[[0, 1, 3]])])
    Traceback (most recent call last):
    ...
    ccfr.ConfigError: <arrays:arrays>: 'objects[0].faces': faces row 0: vertex index 3 out of range (the object has 3 vertices)
    """
    import json

    doc = dict(_plain(config or {}))
    if "objects" in doc:
        raise ValueError("give the objects as the `objects` argument, not inside `config`")
    doc.setdefault("scene", name)
    arrays = {}
    objs = []
    for i, spec in enumerate(objects):
        if "vertices" not in spec:
            raise ValueError(f"objects[{i}]: needs `vertices`, an (n, 3) array")
        key = f"@arrays/{i}"
        arrays[key] = tuple(None if spec.get(k) is None else np.asarray(spec[k]) for k in _ARRAY_KEYS) + (
            f"objects[{i}]",)
        obj = {k: _plain(v) for k, v in spec.items() if k not in _ARRAY_KEYS}
        if "pins" in obj:
            obj["pins"] = [p if isinstance(p, Mapping) else {"indices": p} for p in obj["pins"]]
        obj["shape"] = {"type": "mesh", "path": key}
        objs.append(obj)
    doc["objects"] = objs
    return _core._load_scene_arrays(json.dumps(doc), f"<arrays:{name}>", arrays, overrides)


Scene.from_arrays = staticmethod(scene_from_arrays)  # type: ignore[attr-defined]


def audit(run_dir: _Path, offset: Optional[float] = None, tolerance: float = 1e-6, stride: int = 1,
          partial: bool = False, write_report: bool = False) -> AuditResult:
    """The exact penetration audit of a run directory, frame by frame (`ccfr audit`).

    offset: ξ (default: run.json's); tolerance: how far below ξ a pair may be; stride: audit every
    stride-th frame; partial: an unfinished run passes when its frames are clean; write_report:
    also write RUN_DIR/audit.json as `ccfr audit` does. A missing directory is ccfr.MissingFileError.

    >>> sim = ccfr.Simulation(ccfr.load_scene("configs/drape.yaml", overrides={"time.frames": 1}), threads=2)
    >>> with ccfr.Run(sim, "out/audit_doc") as run:
    ...     _ = run.step()
    >>> result = ccfr.audit("out/audit_doc")
    >>> result.verdict, result.frames_checked, result.violations, bool(result)
    ('pass', 2, 0, True)
    >>> ccfr.audit("out/no_such_run")
    Traceback (most recent call last):
    ...
    ccfr.MissingFileError: 'out/no_such_run' is not a directory
    """
    return _core.audit(run_dir, offset, tolerance, stride, partial, write_report)


def projector_names() -> list[str]:
    """The projector methods ccfr.project accepts.

    >>> ccfr.projector_names()
    ['plesnik', 'successive_projection', 'exact']
    """
    return _core.projector_names()


def project(anchor: Any, candidate: Any, planes: Any, method: str = "plesnik", epsilon: float = 1e-6,
            max_iterations: int = 4, sweeps: int = 10) -> Projection:
    """Projects `candidate` into {x : (x - anchor).n_k + d_k >= 0}, planes rows (nx, ny, nz, d), unit n.

    method: one of ccfr.projector_names(); epsilon, max_iterations (Plesník) and sweeps
    (successive projection) as in the scene's `projector` keys.

    >>> p = ccfr.project([0, 0, 0], [1, -1, 0], [[0, 1, 0, 0]], method="exact")
    >>> np.round(p.x, 4).tolist(), p.status, p.active
    ([1.0, 0.0, 0.0], 'projected', 1)
    """
    return _core.project(anchor, candidate, planes, method, epsilon, max_iterations, sweeps)


def point_edge(p: Any, a: Any, b: Any) -> dict[str, Any]:
    """Closest point of segment ab to p: dict closest, t (closest = a + t (b - a)), distance, feature.

    >>> r = ccfr.point_edge([0.5, 1, 0], [0, 0, 0], [1, 0, 0])
    >>> r["closest"].tolist(), r["t"], r["distance"], r["feature"]
    ([0.5, 0.0, 0.0], 0.5, 1.0, 'interior')
    """
    return _core.point_edge(p, a, b)


def point_triangle(p: Any, a: Any, b: Any, c: Any) -> dict[str, Any]:
    """Closest point of triangle abc to p: dict closest, bary (barycentrics), distance, feature.

    >>> r = ccfr.point_triangle([2, 2, 1], [0, 0, 0], [1, 0, 0], [0, 1, 0])
    >>> r["closest"].tolist(), r["feature"]
    ([0.5, 0.5, 0.0], 'e12')
    """
    return _core.point_triangle(p, a, b, c)


def edge_edge(a0: Any, a1: Any, b0: Any, b1: Any) -> dict[str, Any]:
    """Closest points of segments a0a1 and b0b1: dict pa, pb, s, t, distance, parallel.

    >>> r = ccfr.edge_edge([-1, 0, 0], [1, 0, 0], [0, -1, 2], [0, 1, 2])
    >>> r["pa"].tolist(), r["pb"].tolist(), r["distance"], r["parallel"]
    ([0.0, 0.0, 0.0], [0.0, 0.0, 2.0], 2.0, False)
    """
    return _core.edge_edge(a0, a1, b0, b1)
