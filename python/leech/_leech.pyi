"""Type stubs of the native half of leech (the Rust extension)."""

from typing import Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

CHUNK: int
WARM_STEP_M: float
STATUS_NAMES: list[str]

class InputError(ValueError):
    """Bad input: the field, the value given and what is allowed."""

    field: str
    value: str
    allowed: str

class SolveError(RuntimeError):
    """A solve that failed."""

    status: str
    iterations: Optional[int]
    residual: float

class CalibrationError(RuntimeError):
    """A fit that could not be made."""

class Reacher:
    def reach_json(self, x: float, y: float, angle_deg: Optional[float] = None) -> str: ...

class Robot:
    @staticmethod
    def builtin() -> Robot: ...
    @staticmethod
    def from_toml(text: str) -> Robot: ...
    @staticmethod
    def from_file(path: str) -> Robot: ...
    @staticmethod
    def from_json(text: str) -> Robot: ...
    def to_toml(self) -> str: ...
    def to_json(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def shape_parameter(self) -> float: ...
    @property
    def base_angle_deg(self) -> float: ...
    def with_shape_parameter(self, pi: float) -> Robot: ...
    def with_base_angle(self, degrees: float) -> Robot: ...
    def with_gravity(self, g: float) -> Robot: ...
    def with_tube(self, stiffness: float, element_mass: float) -> Robot: ...
    def scaled(self, factor: float) -> Robot: ...
    def with_name(self, name: str) -> Robot: ...
    def shape_json(
        self,
        la: float,
        lb: float,
        scene: Optional[str] = None,
        hold: str = "rear",
        rear: Optional[Tuple[float, float, float]] = None,
        front: Optional[Tuple[float, float, float]] = None,
        free_cups: str = "pass-through",
    ) -> str: ...
    def constant_curvature_json(self, la: float, lb: float, samples: int = 60) -> str: ...
    def shapes(
        self,
        la: npt.NDArray[np.float64],
        lb: npt.NDArray[np.float64],
        base_angle_deg: Optional[npt.NDArray[np.float64]] = None,
        warm_step_m: float = ...,
    ) -> dict: ...
    def workspace(
        self,
        min_m: float,
        max_m: float,
        step_m: float,
        shape_parameters: Sequence[float] = ...,
        models: Sequence[str] = ...,
        left_longer: bool = False,
    ) -> dict: ...
    def calibrate(self, sag: str, shapes: Optional[str] = None, fit: str = "stiffness") -> Tuple[str, Robot]: ...
    def climb_json(self, scenario: str, time_limit_s: float = 120.0) -> str: ...
    def reacher(self, min_m: float, max_m: float, step_m: float) -> Reacher: ...

def builtin_names(kind: str) -> list[Tuple[str, str]]: ...
