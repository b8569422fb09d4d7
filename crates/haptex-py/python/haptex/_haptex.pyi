"""Type stubs of the extension module haptex._haptex (re-exported by
haptex): what editors and type checkers see. Units are in the names."""

from __future__ import annotations

import os
from typing import Any, Callable, Dict, List, Literal, Optional, Sequence, Tuple, Union, final

import numpy
import numpy as np
import numpy.typing
import numpy.typing as npt

from ._types import CheckMetrics, MapSummary, Summary

# Anything NumPy converts to a float64 array (read in place when it is one).
_ArrayLike = numpy.typing.ArrayLike
# A float64 array haptex returns (Python owns it).
_F64 = numpy.typing.NDArray[numpy.float64]
_Path = Union[str, os.PathLike[str]]
# True: a tqdm bar (when tqdm is installed); False: nothing; a callable
# progress(done, total) in FE steps, returning False to cancel.
_Progress = Union[bool, None, Callable[[int, int], Any]]
# A friction profile argument: a Profile, a profile CSV, (x_mm, mu), or an
# object with x_mm and mu arrays (a Prediction, a Design, a Simulation).
_ProfileArg = Union["Profile", _Path, Tuple[_ArrayLike, _ArrayLike], Any]

__version__: str
__all__ = ["Cae", "CheckResult", "Database", "Design", "DriveSignal", "FrictionMap", "Library", "LooCase", "PathSamples", "Prediction", "Profile", "Simulation", "VoltageMap", "__version__", "_bench_rust_predict", "_bench_rust_predict_batch", "cae_loo", "check", "compensate", "map_compose", "map_from_image", "map_from_profile", "map_grating", "map_sample_path", "map_voltage", "play", "predict", "read_wav", "simulate", "voltage"]

# --- friction profiles and design (haptex voltage) ---

@final
class Profile:
    """A friction profile: x in mm (strictly increasing), mu = Ft/Fn, and
    optionally the normal force Fn in N."""

    def __new__(cls, x_mm: _ArrayLike, mu: _ArrayLike) -> Profile: ...
    @staticmethod
    def from_forces(x_mm: _ArrayLike, ft_n: _ArrayLike, fn_n: _ArrayLike) -> Profile: ...
    @staticmethod
    def read_csv(path: _Path) -> Profile: ...
    def write_csv(self, path: _Path) -> None: ...
    @property
    def x_mm(self) -> _F64: ...
    @property
    def mu(self) -> _F64: ...
    @property
    def fn_n(self) -> Optional[_F64]: ...
    def __len__(self) -> int: ...

@final
class Design:
    """A display's drive for a friction profile (haptex.voltage)."""

    @property
    def x_mm(self) -> _F64: ...
    @property
    def mu(self) -> _F64: ...
    @property
    def voltage_v(self) -> Optional[_F64]:
        """Electrovibration voltage, V RMS (None without electrovibration)."""
    @property
    def amplitude_um(self) -> Optional[_F64]:
        """Ultrasonic vibration amplitude, um peak (None without a plate)."""
    @property
    def summary(self) -> Summary: ...
    @property
    def notes(self) -> List[str]: ...
    def write_csv(self, path: _Path) -> None: ...
    def to_csv(self) -> str: ...
    def to_dict(self) -> Dict[str, Any]: ...

def voltage(
    profile: _ProfileArg,
    *,
    method: str = "physical",
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
    display: str = "electrovibration",
    strategy: Optional[str] = None,
    weight: Optional[float] = None,
    ultrasonic_calibration: Union[_Path, Tuple[_ArrayLike, _ArrayLike], None] = None,
    a_max_um: Optional[float] = None,
    force_model: str = "eq3",
    rho_sc_ohm_m: Optional[float] = None,
    gap_um: Optional[float] = None,
    carrier: Optional[str] = None,
    carrier_hz: Optional[float] = None,
    device: Optional[_Path] = None,
) -> Design: ...

# --- the conditional average estimator and the FE database ---

@final
class Cae:
    """The conditional average estimator (paper eqs. 10-12) over a model
    matrix: inputs (N x D), outputs (N x M)."""

    def __new__(
        cls,
        inputs: _ArrayLike,
        outputs: _ArrayLike,
        *,
        width: Optional[float] = None,
        widths: Optional[Tuple[float, float]] = None,
        input_names: Optional[Sequence[str]] = None,
        output_names: Optional[Sequence[str]] = None,
        memory_budget_mib: int = 2048,
    ) -> Cae: ...
    @staticmethod
    def read_csv(
        path: _Path,
        inputs: Sequence[str],
        *,
        width: Optional[float] = None,
        widths: Optional[Tuple[float, float]] = None,
        memory_budget_mib: int = 2048,
    ) -> Cae: ...
    def predict(self, query: _ArrayLike) -> _F64:
        """M outputs at one query of D inputs."""
    def predict_batch(self, queries: _ArrayLike) -> _F64:
        """K x M outputs at K x D queries."""
    def diagnose(self, query: _ArrayLike) -> Dict[str, Any]: ...
    @property
    def widths(self) -> Tuple[float, float]: ...
    @property
    def inputs(self) -> List[str]: ...
    @property
    def outputs(self) -> List[str]: ...
    @property
    def shape(self) -> Tuple[int, int, int]: ...

def cae_loo(
    model: _Path,
    inputs: Sequence[str],
    *,
    constant: bool = False,
    width: Optional[float] = None,
    widths: Optional[Tuple[float, float]] = None,
    range: Tuple[float, float] = ...,  # (0.005, 2.0)
    memory_budget_mib: int = 2048,
) -> Dict[str, Any]: ...

@final
class Prediction:
    """A friction profile predicted from the FE database (haptex predict)."""

    @property
    def x_mm(self) -> _F64: ...
    @property
    def mu(self) -> _F64: ...
    @property
    def fe_row(self) -> Optional[int]: ...
    @property
    def source(self) -> str: ...
    @property
    def warning(self) -> Optional[str]: ...
    @property
    def flat_mu(self) -> float: ...
    def write_csv(self, path: _Path) -> None: ...
    def to_csv(self) -> str: ...
    def profile(self) -> Profile: ...

@final
class LooCase:
    """One database case against the CAE (haptex db loo --surface)."""

    @property
    def xi_mm(self) -> _F64: ...
    @property
    def h_mm(self) -> _F64: ...
    @property
    def mu_fe(self) -> _F64: ...
    @property
    def mu_cae_loo(self) -> _F64: ...
    @property
    def mu_cae_full(self) -> _F64: ...
    @property
    def row(self) -> Optional[int]: ...
    @property
    def source(self) -> str: ...
    @property
    def rms_loo(self) -> float: ...
    @property
    def rms_full(self) -> float: ...
    def write_csv(self, path: _Path) -> None: ...

@final
class Database:
    """The FE database of the bump, edge and sine templates."""

    def __new__(cls, db: Optional[_Path] = None) -> Database: ...
    def predict(
        self,
        surface: str,
        x0: float,
        width: float,
        height: float,
        velocity: float = 20.0,
        estimator: Optional[Literal["grid", "cae"]] = None,
    ) -> Prediction: ...
    def loo_summary(self) -> Dict[str, Any]: ...
    def loo(self, surface: str, width: float, height: float, velocity: float = 20.0) -> LooCase: ...
    @property
    def dir(self) -> os.PathLike[str]: ...
    @property
    def flat_mu(self) -> float: ...

def _bench_rust_predict(cae: Cae, query: _ArrayLike, repeats: int) -> float: ...
def _bench_rust_predict_batch(cae: Cae, queries: _ArrayLike, repeats: int) -> float: ...
def predict(
    surface: str,
    x0: float,
    width: float,
    height: float,
    velocity: float = 20.0,
    db: Optional[_Path] = None,
    estimator: Optional[Literal["grid", "cae"]] = None,
) -> Prediction: ...

# --- playback and library ---


@final
class DriveSignal:
    """A rendered drive signal (haptex.play) with the scale its WAV carries."""

    @property
    def t_s(self) -> _F64: ...
    @property
    def x_mm(self) -> _F64: ...
    @property
    def envelope_v(self) -> _F64: ...
    @property
    def signal_v(self) -> _F64: ...
    @property
    def amplitude_um(self) -> Optional[_F64]: ...
    @property
    def displacement_um(self) -> Optional[_F64]: ...
    @property
    def report(self) -> Dict[str, Any]: ...
    @property
    def volts_per_full_scale(self) -> float: ...
    @property
    def um_per_full_scale(self) -> Optional[float]: ...
    @property
    def u_max_v(self) -> float: ...
    @property
    def peak_v(self) -> float: ...
    @property
    def sample_rate_hz(self) -> int: ...
    @property
    def channels(self) -> int: ...
    @property
    def text(self) -> str: ...
    def write_wav(self, path: _Path, *, wav_format: str = "pcm16") -> Dict[str, Any]: ...
    def wav_bytes(self, *, wav_format: str = "pcm16") -> bytes: ...
    def write_csv(self, path: _Path) -> None: ...
    def to_csv(self) -> str: ...
    def __len__(self) -> int: ...

def play(
    design: Union["Design", _Path, Tuple[_ArrayLike, _ArrayLike], Tuple[_ArrayLike, _ArrayLike, _ArrayLike]],
    *,
    trajectory: Union[_Path, Tuple[_ArrayLike, _ArrayLike], None] = None,
    velocity: Optional[float] = None,
    strokes: Optional[int] = None,
    from_mm: Optional[float] = None,
    to_mm: Optional[float] = None,
    carrier: str = "sine",
    carrier_hz: Optional[float] = None,
    a_max_um: Optional[float] = None,
    u_max: Optional[float] = None,
    slew_v_per_s: Optional[float] = None,
    amp_range_v: Optional[float] = None,
    volts_per_full_scale: Optional[float] = None,
    outside: str = "hold",
    plate_resonance_hz: Optional[float] = None,
    sample_rate: int = 48000,
    device: Optional[_Path] = None,
) -> DriveSignal: ...

def read_wav(path: _Path) -> Dict[str, Any]: ...

@final
class Library:
    """A texture library (haptex library): materials, strokes, profiles."""

    def __new__(cls, path: Optional[_Path] = None) -> Library: ...
    @property
    def path(self) -> os.PathLike[str]: ...
    def materials(self) -> List[Dict[str, Any]]: ...
    def strokes(self, material: str) -> List[Dict[str, Any]]: ...
    def sample(self, material: str, *, seed: Optional[int] = None) -> "LibrarySample": ...
    def stroke(self, stroke_id: int) -> "LibrarySample": ...
    def check(self) -> List[str]: ...
    def import_recordings(
        self,
        inputs: Union[_Path, Sequence[_Path]],
        *,
        dx_mm: Optional[float] = None,
        min_speed_mm_s: Optional[float] = None,
        min_fn_n: Optional[float] = None,
        fn_tolerance: Optional[float] = None,
        max_gap_mm: Optional[float] = None,
        direction: str = "both",
        trim_s: Optional[float] = None,
        min_duration_s: Optional[float] = None,
        min_length_mm: Optional[float] = None,
        speed_window_s: Optional[float] = None,
        passband_fraction: Optional[float] = None,
        stopband_fraction: Optional[float] = None,
        attenuation_db: Optional[float] = None,
    ) -> Dict[str, List[int]]: ...
    def import_profile(
        self,
        profile: Union["Profile", _Path, Tuple[_ArrayLike, _ArrayLike]],
        *,
        material: str,
        synthetic: bool,
        description: str = "",
        source: Optional[str] = None,
        licence: str = "unspecified",
    ) -> Dict[str, int]: ...

from ._types import LibrarySample

# --- FE finger (simulate, check, compensate) ---



@final
class Simulation:
    description: str
    x_mm: Optional[_F64]
    mu: Optional[_F64]
    ft_n: Optional[_F64]
    fn_n: Optional[_F64]
    profile: Optional["Profile"]
    history: Dict[str, _F64]
    statistics: Dict[str, Any]
    def write_csv(self, path: _Path) -> None: ...
    def to_csv(self) -> str: ...
    def write_history(self, path: _Path) -> None: ...
    def write_png(self, path: _Path) -> None: ...

@final
class CheckResult:
    header: str
    lines: List[str]
    x_mm: _F64
    target_mu: _F64
    voltage_v: _F64
    amplitude_um: Optional[_F64]
    felt_mu: _F64
    k_fe_mm2_per_n: Optional[_F64]
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
    device: Optional[_Path] = None,
    carrier: Optional[str] = None,
    carrier_hz: Optional[float] = None,
    progress: _Progress = True,
    model: str = "2d",
    direction_deg: Optional[float] = None,
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

# --- friction maps ---

_Floats1 = Union[npt.NDArray[np.float64], Sequence[float]]
_Calibration = Union[_Path, Tuple[_Floats1, _Floats1]]

@final
class FrictionMap:
    """mu over a regular grid: mu[j, i] at x = x0_mm + i dx_mm, y = y0_mm + j dy_mm (mm)."""

    def __new__(
        cls,
        mu: npt.ArrayLike,
        *,
        dx_mm: float,
        dy_mm: float,
        x0_mm: float = 0.0,
        y0_mm: float = 0.0,
    ) -> FrictionMap: ...
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

@final
class VoltageMap:
    """A display's drive over a map's grid: voltage_v (V RMS), amplitude_um (um peak), (ny, nx)."""

    voltage_v: Optional[npt.NDArray[np.float64]]
    amplitude_um: Optional[npt.NDArray[np.float64]]
    summary: Optional[MapSummary]
    notes: List[str]
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

@final
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
    device: Optional[_Path] = None,
    carrier: Optional[str] = None,
    carrier_hz: Optional[float] = None,
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
