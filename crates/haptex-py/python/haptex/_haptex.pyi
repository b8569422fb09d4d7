"""Type stubs of the extension module haptex._haptex."""

from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy
import numpy.typing

# --- playback and library ---

_Floats = numpy.typing.ArrayLike
_Path = Union[str, os.PathLike[str]]
_F64 = numpy.typing.NDArray[numpy.float64]

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
    design: Union["Design", _Path, Tuple[_Floats, _Floats], Tuple[_Floats, _Floats, _Floats]],
    *,
    trajectory: Union[_Path, Tuple[_Floats, _Floats], None] = None,
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
) -> DriveSignal: ...

def read_wav(path: _Path) -> Dict[str, Any]: ...

class Library:
    """A texture library (haptex library): materials, strokes, profiles."""

    def __init__(self, path: Optional[_Path] = None) -> None: ...
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
        profile: Union["Profile", _Path, Tuple[_Floats, _Floats]],
        *,
        material: str,
        synthetic: bool,
        description: str = "",
        source: Optional[str] = None,
        licence: str = "unspecified",
    ) -> Dict[str, int]: ...

from ._types import LibrarySample
