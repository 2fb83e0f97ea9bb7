# Type stub of the ccfr package (the pybind11 extension ccfr._core and python/ccfr/__init__.py).
from os import PathLike
from types import TracebackType
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]
_Overrides = Union[Mapping[str, Any], Sequence[str], None]
_Vec3 = npt.ArrayLike

__version__: str

class Error(RuntimeError):
    """A ccfr error that is the user's to fix; str() is the message `ccfr` prints."""

class ConfigError(Error):
    """A configuration error located in a file (or in the arrays of Scene.from_arrays)."""
    file: str
    key_path: str
    line: int  # 1-based; 0 when unknown (an override)
    detail: str

class MissingFileError(Error, FileNotFoundError):
    """A scene file or run directory that does not exist (errno ENOENT, filename the path)."""

class MissingMeshError(ConfigError, MissingFileError):
    """A mesh file named by a scene that does not exist (a ConfigError and a MissingFileError)."""

class NumericalError(Error):
    """A position became non-finite."""
    frame: int
    vertex: int
    stage: str

class GuaranteeError(Error):
    """The run cannot keep its separation promise (stopped before the frame is written)."""
    frame: int

class Scene:
    """A validated scene: objects, state and parameters."""
    @property
    def name(self) -> str: ...
    @property
    def num_vertices(self) -> int: ...
    @property
    def source(self) -> str: ...
    @property
    def overrides(self) -> list[str]: ...
    @property
    def config_json(self) -> str: ...
    @property
    def objects(self) -> list[dict[str, Any]]:
        """One dict per object: name, kind, vertex_begin, vertex_end."""
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """Initial positions, an (n, 3) copy."""
    @property
    def faces(self) -> npt.NDArray[np.int32]:
        """Surface triangles, global vertex indices, (#F, 3)."""
    def with_overrides(self, overrides: _Overrides) -> Scene:
        """The same scene loaded again with more overrides (validated like --set)."""
    @staticmethod
    def from_arrays(objects: Sequence[Mapping[str, Any]], config: Optional[Mapping[str, Any]] = None,
                    overrides: _Overrides = None, name: str = "arrays") -> Scene:
        """Builds a Scene from NumPy arrays (ccfr.scene_from_arrays)."""

def load_scene(path: _Path, overrides: _Overrides = None) -> Scene:
    """Loads a YAML scene file; overrides like `ccfr run --set` ({"contact.offset": 0.02})."""

def load_scene_text(yaml: str, label: str = "<text>", base_dir: _Path = ".", overrides: _Overrides = None) -> Scene:
    """Loads a scene from YAML text; `label` names it in errors, mesh paths are relative to `base_dir`."""

def scene_from_arrays(objects: Sequence[Mapping[str, Any]], config: Optional[Mapping[str, Any]] = None,
                      overrides: _Overrides = None, name: str = "arrays") -> Scene:
    """Builds a Scene from NumPy arrays (vertices, faces, edges, tets per object), validated like YAML."""

class Simulation:
    """Steps a scene frame by frame (contact solver `solver`, `threads` process-wide workers)."""
    def __init__(self, scene: Scene, solver: Optional[str] = None, threads: Optional[int] = None) -> None:
        """A simulation of `scene`; `solver` overrides contact.solver like `ccfr run --solver`."""
    def step(self, frames: int = 1) -> dict[str, Any]:
        """Advances `frames` frames with the GIL released; returns the last frame's stats row."""
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """Read-only (n, 3) zero-copy view; follows every step."""
    @property
    def velocities(self) -> npt.NDArray[np.float64]:
        """Read-only (n, 3) zero-copy view; follows every step."""
    def set_positions(self, positions: npt.ArrayLike) -> None:
        """Overwrites every position ((n, 3), finite) between frames."""
    def set_velocities(self, velocities: npt.ArrayLike) -> None:
        """Overwrites every velocity ((n, 3), finite) between frames."""
    def set_kinematic_targets(self, indices: npt.ArrayLike, targets: npt.ArrayLike) -> None:
        """Pinned/obstacle vertices move linearly to `targets` over the next frame, then hold."""
    @property
    def stats(self) -> Optional[dict[str, Any]]:
        """The last frame's stats.csv row as a dict (None before the first step)."""
    @property
    def frame(self) -> int: ...
    @property
    def time(self) -> float: ...
    @property
    def num_vertices(self) -> int: ...
    @property
    def solver(self) -> str: ...
    @property
    def frames(self) -> int:
        """time.frames of the scene."""
    @property
    def masses(self) -> npt.NDArray[np.float64]:
        """Each vertex's mass in kg as the integrator weighs it, an (n,) copy; obstacles' are 0."""
    @property
    def kinematic_vertices(self) -> npt.NDArray[np.int32]: ...

class Run:
    """`with Run(sim, dir) as run: run.step()` writes the run directory of `ccfr run`."""
    def __init__(self, sim: Simulation, dir: _Path, force: bool = False, last_frame: Optional[int] = None,
                 argv: Optional[Sequence[str]] = None) -> None:
        """A run of `sim` into `dir`; `force` replaces an earlier run, `argv` is what run.json records."""
    def __enter__(self) -> Run:
        """Writes run.json (status running) and frame 0."""
    def __exit__(self, type: Optional[type[BaseException]], value: Optional[BaseException],
                 traceback: Optional[TracebackType]) -> bool:
        """Records run.json's status: 'completed', or 'failed: <exception>'."""
    def step(self, frames: int = 1) -> dict[str, Any]:
        """Steps the simulation and writes what belongs to each frame; returns the last stats."""
    @property
    def dir(self) -> str: ...
    @property
    def frames_written(self) -> int: ...

class FrameAudit:
    """One audited frame."""
    frame: int
    file: str
    triangle_intersections: int
    segment_crossings: int
    close_pairs: int
    min_distance: float
    examples: list[str]
    @property
    def clean(self) -> bool: ...

class AuditResult:
    """The exact penetration audit of a run directory (`ccfr audit`)."""
    verdict: str  # "pass", "fail" or "incomplete"
    @property
    def clean(self) -> bool: ...
    @property
    def offset(self) -> float: ...
    @property
    def offset_source(self) -> str: ...
    @property
    def status(self) -> str: ...
    @property
    def frames_checked(self) -> int: ...
    @property
    def frames_total(self) -> int: ...
    @property
    def bad_frames(self) -> int: ...
    @property
    def violations(self) -> int: ...
    @property
    def first_bad_frame(self) -> int: ...
    @property
    def first_example(self) -> str: ...
    @property
    def min_distance(self) -> float: ...
    @property
    def rows(self) -> list[FrameAudit]: ...
    def __bool__(self) -> bool:
        """True when the verdict is pass."""

def audit(run_dir: _Path, offset: Optional[float] = None, tolerance: float = 1e-6, stride: int = 1,
          partial: bool = False, write_report: bool = False) -> AuditResult:
    """The exact penetration audit of a run directory (`ccfr audit`)."""

class Projection:
    """The result of ccfr.project."""
    @property
    def x(self) -> npt.NDArray[np.float64]: ...
    @property
    def status(self) -> str: ...
    iterations: int
    active: int
    fell_back: bool

def projector_names() -> list[str]:
    """The projector methods ccfr.project accepts."""
def project(anchor: _Vec3, candidate: _Vec3, planes: npt.ArrayLike, method: str = "plesnik", epsilon: float = 1e-6,
            max_iterations: int = 4, sweeps: int = 10) -> Projection:
    """Projects `candidate` into {x : (x - anchor).n_k + d_k >= 0}; planes rows (nx, ny, nz, d)."""
def point_edge(p: _Vec3, a: _Vec3, b: _Vec3) -> dict[str, Any]:
    """Closest point of segment ab to p: dict closest, t, distance, feature."""
def point_triangle(p: _Vec3, a: _Vec3, b: _Vec3, c: _Vec3) -> dict[str, Any]:
    """Closest point of triangle abc to p: dict closest, bary, distance, feature."""
def edge_edge(a0: _Vec3, a1: _Vec3, b0: _Vec3, b1: _Vec3) -> dict[str, Any]:
    """Closest points of segments a0a1 and b0b1: dict pa, pb, s, t, distance, parallel."""
def set_log_level(level: str) -> None:
    """Sets the level of ccfr's log on stderr (trace, debug, info, warn, error, off)."""
def version() -> str:
    """The library version (CMakeLists.txt's project version; also __version__)."""
