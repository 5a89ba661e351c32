"""leech from Python: exact statics of LEeCH-type soft climbing robots.

The physics is the Rust library ``leech``; this package converts arguments
and results. Reports carry the names of the command line's JSON
(``leech shape --json`` and so on, units in the names: ``endpoint_m``,
``force_n``); lists of numbers come as NumPy arrays.

>>> import numpy as np, leech
>>> robot = leech.Robot.builtin()
>>> shape = robot.shape(0.30, 0.28)
>>> shape.status, shape.endpoint_m.shape
('converged', (2,))
>>> batch = robot.shapes(np.linspace(0.1, 0.3, 50), np.full(50, 0.2))
>>> bool(batch.converged.all())
True

Errors: bad input raises :class:`InputError` (a ``ValueError`` with
``field``, ``value`` and ``allowed``); a solve that fails raises
:class:`SolveError` (a ``RuntimeError`` with ``status``, ``iterations`` and
``residual``); a fit that cannot be made raises :class:`CalibrationError`.
In a batch, bad entries do not raise: each has its own status.
"""

from __future__ import annotations

import csv
import io
import json
import os
from typing import Any, Iterable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _leech
from ._leech import CHUNK, STATUS_NAMES, WARM_STEP_M, CalibrationError, InputError, SolveError

__all__ = [
    "write_csv",
    "WORKSPACE_COLUMNS",
    "Robot",
    "Reacher",
    "Result",
    "Shapes",
    "Workspace",
    "InputError",
    "SolveError",
    "CalibrationError",
    "CHUNK",
    "WARM_STEP_M",
    "STATUS_NAMES",
    "CONVERGED",
    "NOT_CONVERGED",
    "INVALID",
    "scenes",
    "scenarios",
]

#: Batch status codes (``Shapes.status``), indices into :data:`STATUS_NAMES`.
CONVERGED, NOT_CONVERGED, INVALID = 0, 1, 2

PathLike = Union[str, "os.PathLike[str]"]


def _numeric(value: Any) -> bool:
    """A number (``null`` is a NaN in the JSON), or a non-empty list of them."""
    if value is None or (isinstance(value, (int, float)) and not isinstance(value, bool)):
        return True
    return isinstance(value, list) and bool(value) and all(_numeric(v) for v in value)


def _convert(value: Any) -> Any:
    """A JSON value as a result attribute: numbers' lists as float arrays
    (``null`` as ``nan``), objects as :class:`Result`, other lists as lists."""
    if isinstance(value, dict):
        return Result(value)
    if isinstance(value, list):
        if _numeric(value):
            try:
                return np.array(value, dtype=float)
            except ValueError:  # ragged: each part its own array
                pass
        return [_convert(v) for v in value]
    return value


class Result:
    """A report: its JSON keys as attributes (``result.endpoint_m``), numeric
    lists as NumPy arrays, nested objects as results; ``to_dict()`` gives the
    JSON itself."""

    __slots__ = ("_data",)

    def __init__(self, data: Mapping[str, Any]):
        self._data = dict(data)

    def __getattr__(self, name: str) -> Any:
        try:
            return _convert(self._data[name])
        except KeyError:
            raise AttributeError(f"no {name!r} in this report; it has {', '.join(self._data)}") from None

    def __getitem__(self, name: str) -> Any:
        return _convert(self._data[name])

    def __contains__(self, name: object) -> bool:
        return name in self._data

    def __dir__(self) -> Iterable[str]:
        return list(self._data)

    def keys(self) -> Iterable[str]:
        return self._data.keys()

    def to_dict(self) -> dict:
        """The report as the command line's JSON (a plain dict)."""
        return self._data

    def __repr__(self) -> str:
        return f"Result({', '.join(self._data)})"


def _floats(values: Any) -> np.ndarray:
    """Values as the one-dimensional, contiguous, aligned float64 array the
    native half reads in place (arrays unpickled by Dask may be misaligned)."""
    return np.require(np.asarray(values, dtype=np.float64).reshape(-1), requirements=["C", "A"])


def _result(text: str) -> Result:
    return Result(json.loads(text))


class Shapes:
    """The outcome of :meth:`Robot.shapes`, one entry per input, as arrays:
    ``endpoint_m`` (N x 2, m), ``endpoint_angle_rad``, ``min_bend_radius_m``
    (NaN where an entry did not converge), ``status`` (codes, see
    :data:`STATUS_NAMES`), ``stable``, ``warm`` (warm-started from the
    previous entry), ``snapped``. Each entry that did not converge has a
    reason: ``failure_index`` (entries, ascending) and ``failure_reason``
    (indices into ``reasons``, each distinct reason once), or :meth:`reason`."""

    def __init__(self, columns: dict):
        self.endpoint_m: np.ndarray = columns["endpoint_m"]
        self.endpoint_angle_rad: np.ndarray = columns["endpoint_angle_rad"]
        self.min_bend_radius_m: np.ndarray = columns["min_bend_radius_m"]
        self.status: np.ndarray = columns["status"]
        self.stable: np.ndarray = columns["stable"]
        self.warm: np.ndarray = columns["warm"]
        self.snapped: np.ndarray = columns["snapped"]
        self.failure_index: np.ndarray = columns["failure_index"]
        self.failure_reason: np.ndarray = columns["failure_reason"]
        self.reasons: list = columns["reasons"]

    def reason(self, i: int) -> Optional[str]:
        """Why entry `i` did not converge (None when it did)."""
        k = int(np.searchsorted(self.failure_index, i))
        if k < len(self.failure_index) and self.failure_index[k] == i:
            return self.reasons[self.failure_reason[k]]
        return None

    @property
    def failures(self) -> list:
        """``(index, status name, reason)`` of every entry that did not converge."""
        return [
            (int(i), STATUS_NAMES[self.status[i]], self.reasons[r])
            for i, r in zip(self.failure_index, self.failure_reason)
        ]

    def __len__(self) -> int:
        return len(self.status)

    @property
    def converged(self) -> np.ndarray:
        """Which entries converged (a boolean mask)."""
        return self.status == CONVERGED

    def status_names(self) -> np.ndarray:
        """The statuses as names (``converged``, ``not_converged``, ``invalid``)."""
        return np.asarray(STATUS_NAMES)[self.status]

    def __repr__(self) -> str:
        return f"Shapes({len(self)} entries, {int(self.converged.sum())} converged)"


#: The sweep table's columns, in order, as ``leech workspace --out`` writes them.
WORKSPACE_COLUMNS = (
    "model",
    "shape_parameter",
    "la_m",
    "lb_m",
    "status",
    "stable",
    "snapped",
    "feasible",
    "min_bend_radius_m",
    "endpoint_x_m",
    "endpoint_y_m",
    "endpoint_angle_rad",
    "fresh_difference_m",
)


class Workspace:
    """A workspace sweep (``leech workspace``): ``columns``, the table as a
    dict of arrays named as the CSV's columns (:data:`WORKSPACE_COLUMNS`), and
    ``summaries``, the metrics per model and shape parameter."""

    def __init__(self, columns: dict):
        summaries = columns.pop("summaries_json")
        self.columns = {
            name: (np.asarray(v) if not isinstance(v, np.ndarray) else v) for name, v in columns.items()
        }
        self.summaries = [Result(s) for s in json.loads(summaries)]

    def __len__(self) -> int:
        return len(self.columns["la_m"])

    def __getattr__(self, name: str) -> np.ndarray:
        columns = self.__dict__.get("columns", {})
        if name in columns:
            return columns[name]
        raise AttributeError(name)

    def to_csv(self, path: PathLike) -> None:
        """Writes the table (header with units, one row per point)."""
        write_csv(path, self.columns, WORKSPACE_COLUMNS)


def write_csv(path: PathLike, columns: Mapping[str, np.ndarray], names: Sequence[str]) -> None:
    """Writes `columns` (equal lengths) in the order of `names`; floats as
    Python prints them (the shortest text that reads back to the number)."""
    n = len(columns[names[0]]) if names else 0
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        cols = [np.asarray(columns[c]).tolist() for c in names]
        for i in range(n):
            w.writerow([c[i] for c in cols])


class Reacher:
    """Inverse statics over a map of lengths built once (see :meth:`Robot.reacher`)."""

    def __init__(self, native: "_leech.Reacher"):
        self._native = native

    def reach(self, x: float, y: float, angle_deg: Optional[float] = None) -> Result:
        """``leech reach --json``: tube lengths putting the endpoint on
        ``(x, y)`` (m), the plate at ``angle_deg`` when given."""
        return _result(self._native.reach_json(float(x), float(y), angle_deg))


def _csv_text(data: Any, what: str) -> str:
    """Measurements as CSV text: a path, CSV text, or a mapping of columns."""
    if isinstance(data, Mapping):
        names = list(data)
        columns = [np.atleast_1d(np.asarray(data[n])) for n in names]
        out = io.StringIO()
        w = csv.writer(out, lineterminator="\n")
        w.writerow(names)
        for row in zip(*columns):
            w.writerow([v.item() if hasattr(v, "item") else v for v in row])
        return out.getvalue()
    if isinstance(data, os.PathLike) or (isinstance(data, str) and "\n" not in data and os.path.exists(data)):
        with open(data) as f:
            return f.read(16 << 20)
    if isinstance(data, str):
        return data
    raise InputError(f"{what}: expected a path, CSV text or a mapping of columns")


class Robot:
    """A robot: the built-in LEeCH (:meth:`builtin`), a robot file
    (:meth:`from_file`), a dict of its file's tables (:meth:`from_dict`), or
    one derived from another (``with_...``). Immutable; picklable (as its
    file), so it travels to distributed workers."""

    __slots__ = ("_native",)

    def __init__(self, native: "_leech.Robot"):
        self._native = native

    # Construction and conversion.

    @staticmethod
    def builtin() -> "Robot":
        """The built-in robot (estimated LEeCH parameters)."""
        return Robot(_leech.Robot.builtin())

    @staticmethod
    def from_file(path: PathLike) -> "Robot":
        """A robot file (TOML)."""
        return Robot(_leech.Robot.from_file(os.fspath(path)))

    @staticmethod
    def from_toml(text: str) -> "Robot":
        """A robot file's text (TOML)."""
        return Robot(_leech.Robot.from_toml(text))

    @staticmethod
    def from_dict(tables: Mapping[str, Any]) -> "Robot":
        """A robot from its file's tables (as :meth:`to_dict` gives them)."""
        return Robot(_leech.Robot.from_json(json.dumps(tables)))

    def to_dict(self) -> dict:
        """The robot's tables (``leech robot --json``)."""
        return json.loads(self._native.to_json())

    def to_toml(self) -> str:
        """The robot's file (TOML)."""
        return self._native.to_toml()

    def __reduce__(self):
        return (Robot.from_toml, (self.to_toml(),))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Robot) and self.to_toml() == other.to_toml()

    def __hash__(self) -> int:
        return hash(self.to_toml())

    def __repr__(self) -> str:
        return repr(self._native)

    @property
    def name(self) -> str:
        """The robot's name."""
        return self._native.name

    @property
    def shape_parameter(self) -> float:
        """Shape parameter ``Pi = k/(m g l)`` of one tube."""
        return self._native.shape_parameter

    @property
    def base_angle_deg(self) -> float:
        """The driving unit's base angle (deg): 0 along a floor, 90 up a wall."""
        return self._native.base_angle_deg

    def with_shape_parameter(self, pi: float) -> "Robot":
        """This robot with the joint stiffness giving shape parameter `pi`."""
        return Robot(self._native.with_shape_parameter(float(pi)))

    def with_base_angle(self, degrees: float) -> "Robot":
        """This robot with the driving unit at `degrees`."""
        return Robot(self._native.with_base_angle(float(degrees)))

    def with_gravity(self, g: float) -> "Robot":
        """This robot under gravity `g` (m/s^2)."""
        return Robot(self._native.with_gravity(float(g)))

    def with_tube(self, stiffness_nm_per_rad: float, element_mass_kg: float) -> "Robot":
        """This robot with another joint stiffness (N m/rad) and element mass (kg)."""
        return Robot(self._native.with_tube(float(stiffness_nm_per_rad), float(element_mass_kg)))

    def scaled(self, factor: float) -> "Robot":
        """This robot with every length scaled by `factor`."""
        return Robot(self._native.scaled(float(factor)))

    def with_name(self, name: str) -> "Robot":
        """This robot named `name`."""
        return Robot(self._native.with_name(name))

    # Solves.

    def shape(
        self,
        la: float,
        lb: float,
        scene: Optional[PathLike] = None,
        hold: str = "rear",
        rear: Optional[Tuple[float, float, float]] = None,
        front: Optional[Tuple[float, float, float]] = None,
        free_cups: str = "pass-through",
    ) -> Result:
        """``leech shape --json``: the two-chain body at tube lengths `la`,
        `lb` (m), held by its rear cup (``hold="rear"``), its front cup or both
        (``front=(x, y, deg)``), optionally among a scene's solids (a built-in
        name or a scene file). Raises :class:`SolveError` when it fails."""
        scene = None if scene is None else os.fspath(scene)
        return _result(self._native.shape_json(float(la), float(lb), scene, hold, rear, front, free_cups))

    def constant_curvature(self, la: float, lb: float, samples: int = 60) -> Result:
        """``leech shape --model constant-curvature --json``: the kinematic model."""
        return _result(self._native.constant_curvature_json(float(la), float(lb), int(samples)))

    def shapes(
        self,
        la: Any,
        lb: Any,
        base_angle_deg: Any = None,
        warm_step_m: float = WARM_STEP_M,
    ) -> Shapes:
        """The clamped body at many lengths at once (arrays of LA and LB in m,
        optionally base angles in deg), on all cores with the interpreter's
        lock released. Consecutive entries within `warm_step_m` in both
        lengths are warm-started from each other (an actuation path, as the
        workspace sweep); 0 solves every entry cold, as :meth:`shape` does.
        Bad entries (NaN, out of range) and failed solves are reported per
        entry, never raised."""
        la, lb = _floats(la), _floats(lb)
        if base_angle_deg is not None:
            base_angle_deg = _floats(base_angle_deg)
        return Shapes(self._native.shapes(la, lb, base_angle_deg, float(warm_step_m)))

    def workspace(
        self,
        lengths: Tuple[float, float, float] = (0.05, 0.30, 0.005),
        shape_parameters: Sequence[float] = (),
        models: Sequence[str] = ("two-chain",),
        left_longer: bool = False,
    ) -> Workspace:
        """``leech workspace``: the endpoint over a grid of lengths
        ``(min, max, step)`` in m, along the actuation path, for each shape
        parameter (the robot's own when none) and model."""
        lo, hi, step = (float(x) for x in lengths)
        native = self._native.workspace(lo, hi, step, [float(p) for p in shape_parameters], list(models), bool(left_longer))
        return Workspace(native)

    def reacher(self, grid: Tuple[float, float, float] = (0.05, 0.30, 0.01)) -> Reacher:
        """A map for inverse statics over lengths ``(min, max, step)`` (m), built once."""
        lo, hi, step = (float(x) for x in grid)
        return Reacher(self._native.reacher(lo, hi, step))

    def reach(
        self,
        x: float,
        y: float,
        angle_deg: Optional[float] = None,
        grid: Tuple[float, float, float] = (0.05, 0.30, 0.01),
    ) -> Result:
        """``leech reach --json``: tube lengths that put the endpoint on ``(x, y)`` (m)."""
        return self.reacher(grid).reach(x, y, angle_deg)

    def calibrate(self, sag: Any, shapes: Any = None, fit: str = "stiffness") -> Result:
        """``leech calibrate --json``: fits the tube's stiffness (and with
        ``fit="stiffness-and-mass"`` its element mass) to measurements: a CSV
        file's path, CSV text, or a mapping of columns (sag:
        ``tube_length_m, base_angle_deg, x_m, y_m`` and optionally
        ``tip_mass_kg``; shapes: ``shape, la_m, lb_m, base_angle_deg, chain,
        x_m, y_m``). The result's ``robot`` is the fitted robot."""
        sag_text = _csv_text(sag, "sag")
        shapes_text = None if shapes is None else _csv_text(shapes, "shapes")
        text, fitted = self._native.calibrate(sag_text, shapes_text, fit)
        return _FittedResult(json.loads(text), Robot(fitted))

    def climb(self, scenario: PathLike, time_limit_s: float = 120.0) -> Result:
        """``leech climb --json``: a plan of strides for a scenario (a built-in
        name or a scenario file). An impossible climb is a result with
        ``status`` ``impossible`` and its ``reason``, not an exception."""
        return _result(self._native.climb_json(os.fspath(scenario), float(time_limit_s)))


class _FittedResult(Result):
    """A calibration's report; ``fitted`` is the fitted robot."""

    __slots__ = ("fitted",)

    def __init__(self, data: Mapping[str, Any], fitted: Robot):
        super().__init__(data)
        self.fitted = fitted


def scenes() -> list:
    """The built-in scenes: ``(name, description)`` pairs."""
    return _leech.builtin_names("scenes")


def scenarios() -> list:
    """The built-in climb scenarios: ``(name, description)`` pairs."""
    return _leech.builtin_names("scenarios")
