"""ccfr from Python: scenes, stepping, run directories, the audit, projectors and closest points.

    import ccfr
    scene = ccfr.load_scene("configs/paper/cloth_drop.yaml", overrides={"time.frames": 10})
    sim = ccfr.Simulation(scene, solver="ccfr", threads=2)
    with ccfr.Run(sim, "out/cloth") as run:
        for _ in range(sim.frames):
            run.step()
    print(sim.positions[:3], ccfr.audit("out/cloth").verdict)

The state arrays are read-only NumPy views of the C++ buffers (no copy); docs/python.md.
"""
from __future__ import annotations

import json
from typing import Any, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from ._core import (  # noqa: F401  (re-exported)
    AuditResult,
    ConfigError,
    Error,
    FrameAudit,
    GuaranteeError,
    NumericalError,
    Projection,
    Run,
    Scene,
    Simulation,
    audit,
    edge_edge,
    load_scene,
    load_scene_text,
    point_edge,
    point_triangle,
    project,
    projector_names,
    set_log_level,
    version,
)
from . import _core

__all__ = [
    "AuditResult", "ConfigError", "Error", "FrameAudit", "GuaranteeError", "NumericalError", "Projection", "Run",
    "Scene", "Simulation", "audit", "edge_edge", "load_scene", "load_scene_text", "point_edge", "point_triangle",
    "project", "projector_names", "scene_from_arrays", "set_log_level", "version",
]

# The scene summary and per-frame lines of `ccfr run` are info; a Python session sees warnings.
set_log_level("warn")

# Keys of an object given as arrays that are not passed to the scene file as they are.
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
                      overrides: Union[Mapping[str, Any], Sequence[str], None] = None,
                      name: str = "arrays") -> Scene:
    """Builds a Scene from NumPy arrays, validated exactly like a YAML scene file.

    objects: one mapping per object with `name`, `kind` (cloth, shell, tet_solid, strand, particles,
    obstacle, rigid), `vertices` ((n, 3) floats) and, by kind, `faces` ((m, 3) ints), `edges` ((m, 2),
    strands; consecutive edges (a, b), (b, c) chain into one strand) or `tets` ((m, 4), positively
    oriented); any other object key of the scene file (`material`, `pins`, `velocity`, `motion`,
    `transform`) as in YAML. Pins: a list of index arrays, or of mappings as in YAML.
    config: the other top-level keys of a scene file (time, contact, materials, ...).
    Errors are ccfr.ConfigError with the key path of the offending entry, e.g. objects[0].faces.
    """
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
        arrays[key] = tuple(None if spec.get(k) is None else np.asarray(spec[k]) for k in _ARRAY_KEYS)
        obj = {k: _plain(v) for k, v in spec.items() if k not in _ARRAY_KEYS}
        if "pins" in obj:
            obj["pins"] = [p if isinstance(p, Mapping) else {"indices": p} for p in obj["pins"]]
        obj["shape"] = {"type": "mesh", "path": key}
        objs.append(obj)
    doc["objects"] = objs
    # One key per line, so that the line in a ConfigError points at something readable.
    text = json.dumps(doc, indent=1)
    return _core._load_scene_arrays(text, f"<arrays:{name}>", arrays, overrides)


Scene.from_arrays = staticmethod(scene_from_arrays)  # type: ignore[attr-defined]
