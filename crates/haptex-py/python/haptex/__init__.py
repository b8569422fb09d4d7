"""haptex from Python: surface haptic drive signals with NumPy arrays.

The functions are the ``haptex`` command line's commands, their keyword
arguments its flags, their numbers its numbers (the same library computes
both). Units are in every name: positions in mm, forces in N, voltages in
V RMS, amplitudes in um peak, velocities in mm/s.

>>> import haptex
>>> bump = haptex.Profile.read_csv("data/examples/bump_friction.csv")
>>> design = haptex.voltage(bump)
>>> design.voltage_v.max()  # V RMS
100.0

Errors are haptex.HaptexError, and a ValueError (bad input) or an OSError
(a file) as well, with the command line's message. See docs/python.md.
"""

from ._errors import (
    CancelledError,
    ComputationError,
    ExtrapolationWarning,
    HaptexError,
    HaptexOSError,
    InvalidInputError,
)
from ._types import CheckMetrics, LibrarySample, MapSummary, Regions, Summary
from ._haptex import (
    Cae,
    CheckResult,
    Database,
    Design,
    DriveSignal,
    FrictionMap,
    Library,
    LooCase,
    PathSamples,
    Prediction,
    Profile,
    Simulation,
    VoltageMap,
    __version__,
    cae_loo,
    check,
    compensate,
    map_compose,
    map_from_image,
    map_from_profile,
    map_grating,
    map_sample_path,
    map_voltage,
    play,
    predict,
    read_wav,
    simulate,
    voltage,
)

__all__ = sorted(name for name in dir() if not name.startswith("_")) + ["__version__"]
