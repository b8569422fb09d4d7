"""Type stubs of the extension module haptex._haptex."""

from __future__ import annotations

import os
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy
import numpy.typing

# --- FE finger (simulate, check, compensate) ---

from ._types import CheckMetrics

_Floats = numpy.typing.NDArray[numpy.float64]
_ArrayLike = numpy.typing.ArrayLike
_Path = Union[str, os.PathLike]
# True: a tqdm bar (when tqdm is installed); False: nothing; a callable
# progress(done, total) in FE steps, returning False to cancel.
_Progress = Union[bool, None, Callable[[int, int], Any]]

class Simulation:
    description: str
    x_mm: Optional[_Floats]
    mu: Optional[_Floats]
    ft_n: Optional[_Floats]
    fn_n: Optional[_Floats]
    profile: Optional["Profile"]
    history: Dict[str, _Floats]
    statistics: Dict[str, Any]
    def write_csv(self, path: _Path) -> None: ...
    def to_csv(self) -> str: ...
    def write_history(self, path: _Path) -> None: ...
    def write_png(self, path: _Path) -> None: ...

class CheckResult:
    header: str
    lines: List[str]
    x_mm: _Floats
    target_mu: _Floats
    voltage_v: _Floats
    amplitude_um: Optional[_Floats]
    felt_mu: _Floats
    k_fe_mm2_per_n: Optional[_Floats]
    metrics: CheckMetrics
    trials: List[CheckMetrics]
    best: int
    fe_k: Optional[float]
    design: "Design"
    def write_csv(self, path: _Path) -> None: ...
    def to_csv(self) -> str: ...

def simulate(
    surface: Union[str, _Path, Tuple[_ArrayLike, _ArrayLike]],
    *,
    voltage: Union["Design", _Path, Tuple[_ArrayLike, _ArrayLike], None] = None,
    constant_voltage: Optional[float] = None,
    mu_display: Optional[float] = None,
    eps_sc: Optional[float] = None,
    eps_i: Optional[float] = None,
    d_sc_mm: Optional[float] = None,
    d_i_mm: Optional[float] = None,
    x0: float = 5.0,
    width: float = 1.5,
    height: float = 0.3,
    velocity: float = 20.0,
    indent: Optional[float] = None,
    load: Optional[float] = None,
    slide: float = 10.0,
    step: Optional[float] = None,
    press_time: float = 0.1,
    mu_skin: Optional[float] = None,
    material: str = "viscoelastic",
    kinematics: str = "small",
    mesh: str = "default",
    finger: Optional[_Path] = None,
    penalty: float = 200.0,
    progress: _Progress = True,
) -> Simulation: ...
def check(
    profile: Union["Profile", _Path, Tuple[_ArrayLike, _ArrayLike]],
    *,
    mu_hd: Optional[float] = None,
    u_max: Optional[float] = None,
    k_mm2_per_n: Optional[float] = None,
    fe_k: bool = False,
    eps_sc: Optional[float] = None,
    eps_i: Optional[float] = None,
    d_sc_mm: Optional[float] = None,
    d_i_mm: Optional[float] = None,
    load: Optional[float] = None,
    indent: Optional[float] = None,
    velocity: float = 20.0,
    step: float = 0.05,
    run_up: float = 1.0,
    material: str = "viscoelastic",
    mesh: str = "default",
    finger: Optional[_Path] = None,
    compensate: bool = False,
    max_runs: int = 8,
    tolerance: float = 1e-4,
    display: str = "electrovibration",
    strategy: Optional[str] = None,
    weight: Optional[float] = None,
    ultrasonic_calibration: Union[_Path, Tuple[_ArrayLike, _ArrayLike], None] = None,
    a_max_um: Optional[float] = None,
    progress: _Progress = True,
) -> CheckResult: ...
def compensate(
    profile: Union["Profile", _Path, Tuple[_ArrayLike, _ArrayLike]],
    *,
    relative: bool = False,
    flat_mu: Optional[float] = None,
    mu_hd: Optional[float] = None,
    eps_sc: Optional[float] = None,
    eps_i: Optional[float] = None,
    d_sc_mm: Optional[float] = None,
    d_i_mm: Optional[float] = None,
    k_mm2_per_n: Optional[float] = None,
    area_exponent: Optional[float] = None,
    fn_n: Optional[float] = None,
    u_max: Optional[float] = None,
    load: Optional[float] = None,
    max_runs: int = 8,
    progress: _Progress = True,
) -> "Design": ...
