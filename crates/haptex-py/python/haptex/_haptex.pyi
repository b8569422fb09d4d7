"""Type stubs of the extension module haptex._haptex (one section per part)."""

from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._types import MapSummary

# --- friction maps ---

_Path = Union[str, "os.PathLike[str]"]
_Floats1 = Union[npt.NDArray[np.float64], Sequence[float]]
_Calibration = Union[_Path, Tuple[_Floats1, _Floats1]]

class FrictionMap:
    """mu over a regular grid: mu[j, i] at x = x0_mm + i dx_mm, y = y0_mm + j dy_mm (mm)."""

    def __init__(
        self,
        mu: npt.ArrayLike,
        *,
        dx_mm: float,
        dy_mm: float,
        x0_mm: float = 0.0,
        y0_mm: float = 0.0,
    ) -> None: ...
    @staticmethod
    def read(path: _Path) -> FrictionMap: ...
    def write(self, path: _Path) -> None: ...
    def to_csv(self) -> str: ...
    @property
    def mu(self) -> npt.NDArray[np.float64]: ...
    @property
    def x_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def y_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def shape(self) -> Tuple[int, int]: ...
    @property
    def dx_mm(self) -> float: ...
    @property
    def dy_mm(self) -> float: ...
    @property
    def x0_mm(self) -> float: ...
    @property
    def y0_mm(self) -> float: ...
    @property
    def summary(self) -> str: ...

class VoltageMap:
    """A display's drive over a map's grid: voltage_v (V RMS), amplitude_um (um peak), (ny, nx)."""

    voltage_v: Optional[npt.NDArray[np.float64]]
    amplitude_um: Optional[npt.NDArray[np.float64]]
    summary: Optional[MapSummary]
    @staticmethod
    def read(path: _Path) -> VoltageMap: ...
    def write(self, path: _Path) -> None: ...
    def to_csv(self) -> str: ...
    def sample(self, x_mm: _Floats1, y_mm: _Floats1) -> npt.NDArray[np.float64]: ...
    @property
    def x_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def y_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def shape(self) -> Tuple[int, int]: ...

class PathSamples:
    """The voltage (V RMS) along a finger path: 1-D arrays t_s, x_mm, y_mm, voltage_v."""

    t_s: npt.NDArray[np.float64]
    x_mm: npt.NDArray[np.float64]
    y_mm: npt.NDArray[np.float64]
    voltage_v: npt.NDArray[np.float64]
    summary: str
    def write_csv(self, path: _Path) -> None: ...
    def to_csv(self) -> str: ...
    def __len__(self) -> int: ...

def map_from_image(
    image: Union[_Path, npt.NDArray[np.uint8], npt.NDArray[np.uint16]],
    *,
    mu_black: float,
    mu_white: float,
    gamma: float = 1.0,
    pixel_mm: float,
    pixel_mm_y: Optional[float] = None,
    x0_mm: float = 0.0,
    y0_mm: float = 0.0,
) -> FrictionMap: ...
def map_from_profile(
    profile: object,
    *,
    dx_mm: float,
    dy_mm: float,
    ny: int,
    y0_mm: float = 0.0,
) -> FrictionMap: ...
def map_voltage(
    friction_map: Union[FrictionMap, _Path],
    *,
    method: str = "physical",
    mu_hd: Optional[float] = None,
    eps_sc: Optional[float] = None,
    eps_i: Optional[float] = None,
    d_sc_mm: Optional[float] = None,
    d_i_mm: Optional[float] = None,
    k_mm2_per_n: Optional[float] = None,
    u_max: Optional[float] = None,
    display: str = "electrovibration",
    strategy: Optional[str] = None,
    weight: Optional[float] = None,
    ultrasonic_calibration: Optional[_Calibration] = None,
    a_max_um: Optional[float] = None,
) -> VoltageMap: ...
def map_sample_path(
    voltage_map: Union[VoltageMap, _Path],
    trajectory: Union[_Path, Tuple[_Floats1, _Floats1, _Floats1]],
) -> PathSamples: ...
def map_grating(
    *,
    period_mm: float,
    amplitude_mm: float,
    angle_deg: float,
    velocity: float = 20.0,
    nx: int,
    ny: int,
    dx_mm: float,
    dy_mm: float,
    x0_mm: float = 0.0,
    y0_mm: float = 0.0,
    source: str = "fe",
    db: Optional[_Path] = None,
) -> FrictionMap: ...
_Fill = Union[float, Any]  # a number (mu) or a friction profile (Profile, CSV path, (x_mm, mu))

def map_compose(
    labels: Optional[Union[_Path, npt.NDArray[np.uint8]]] = None,
    *,
    regions: Optional[Dict[int, _Fill]] = None,
    base: Optional[_Fill] = None,
    size_mm: Optional[Tuple[float, float]] = None,
    polygons: Optional[List[Tuple[Sequence[Tuple[float, float]], _Fill]]] = None,
    pixel_mm: float,
    pixel_mm_y: Optional[float] = None,
    x0_mm: float = 0.0,
    y0_mm: float = 0.0,
) -> FrictionMap: ...
