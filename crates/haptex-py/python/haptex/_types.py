"""The records haptex returns besides arrays: plain dataclasses."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple

__all__ = ["CheckMetrics", "LibrarySample", "MapSummary", "Regions", "Summary"]


@dataclass(frozen=True)
class Regions:
    """Part of a profile's length where a condition holds.

    length_mm: total length in mm; fraction: that length over the profile's
    span (0..1); ranges_mm: the intervals (start, end) in mm, in order.
    """

    length_mm: float
    fraction: float
    ranges_mm: List[Tuple[float, float]]


@dataclass(frozen=True)
class Summary:
    """What a design did, and where the display could not follow.

    display: "electrovibration", "ultrasonic" or "combined".
    method: "physical (eq. 8)" or "normalized (eq. 9)".
    n_points, x_range_mm (mm), mu_range: the profile mapped (relative
      values when the design was made relative).
    band_mu: the renderable band of felt friction (low, high): for
      electrovibration (mu_HD, the mu at U_max); None for eq. (9).
    above_band: where the target is above the band. Electrovibration: U is
      clipped to U_max there. Ultrasonic: mu > mu_HD, a = 0.
    below_band: where the target is below the band. Electrovibration:
      mu < mu_HD, not renderable, U = 0 V. Ultrasonic: a = a_max.
    u_max_v: U_max in V RMS (None without electrovibration); a_max_um: the
      plate's a_max in um (None without an ultrasonic plate).
    warnings: the warnings `haptex voltage` prints.
    text: the summary `haptex voltage` prints on stderr.
    details: the summary as `haptex voltage --format json` writes it.
    """

    display: str
    method: str
    n_points: int
    x_range_mm: Tuple[float, float]
    mu_range: Tuple[float, float]
    band_mu: Optional[Tuple[float, float]]
    above_band: Regions
    below_band: Regions
    u_max_v: Optional[float]
    a_max_um: Optional[float]
    warnings: List[str]
    text: str = field(repr=False)
    details: Dict[str, Any] = field(repr=False)

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True)
class LibrarySample:
    """A stroke of the texture library and its friction profile.

    profile: a haptex.Profile (x_mm in mm, mu, fn_n in N when known).
    stroke: the stroke's record as `haptex library list --material NAME
      --format json` gives it (id, material, provenance, n_points, span_mm,
      mean_mu, mean_fn_n).
    seed: the seed that picked it (Library.sample), None for
      Library.stroke.
    comments: the provenance lines an exported profile CSV starts with.
    """

    profile: Any
    stroke: Dict[str, Any]
    seed: Optional[int]
    comments: List[str] = field(repr=False)


@dataclass(frozen=True)
class CheckMetrics:
    """How well the friction the FE finger feels follows a target
    (haptex.check; `haptex check`'s report).

    rms_error, max_error: RMS and largest |felt - target| over the
      renderable region (mu_HD <= mu <= mu at U_max; the combined
      display's band), in units of mu.
    not_renderable_fraction: fraction of the target's length below the
      band (mu < mu_HD on the electrovibration display); clipped_fraction:
      above it (0..1).
    lag_mm: the shift in mm (> 0: the felt profile comes later), within
      +-0.1 mm, that best aligns felt and target.
    target_detail_rms: RMS of the target's detail finer than the contact;
      detail_retained: the fraction of it felt (None without such detail).
    k_fe_mm2_per_n: the FE finger's contact length per normal force, mm^2/N
      (eq. 8's k per mm of finger width); contact_mm: the mean contact
      length in mm.
    """

    rms_error: float
    max_error: float
    not_renderable_fraction: float
    clipped_fraction: float
    lag_mm: float
    target_detail_rms: float
    detail_retained: Optional[float]
    k_fe_mm2_per_n: float
    contact_mm: float


@dataclass(frozen=True)
class MapSummary:
    """What a voltage map (haptex.map_voltage) did, and where the display
    could not follow, as fractions of the map's area.

    display: "electrovibration", "ultrasonic" or "combined".
    method: "physical (eq. 8)" or "normalized (eq. 9)".
    shape: (ny, nx) cells.
    voltage_range_v: lowest and highest voltage, V RMS (None without
      electrovibration); amplitude_range_um: lowest and highest plate
      amplitude, um peak (None without an ultrasonic plate).
    u_max_v: U_max in V RMS (None without electrovibration); a_max_um: the
      plate's a_max in um peak (None without a plate).
    band_mu: the renderable band of felt friction (low, high) of an
      ultrasonic or combined display (None for electrovibration alone).
    below_band_fraction: fraction of the cells below what the display
      renders (electrovibration: mu < mu_HD, 0 V; a plate: at a_max);
      above_band_fraction: fraction above it (clipped at U_max). None for
      eq. (9), which has neither.
    text: what `haptex map voltage` prints about the map.
    """

    display: str
    method: str
    shape: Tuple[int, int]
    voltage_range_v: Optional[Tuple[float, float]]
    amplitude_range_um: Optional[Tuple[float, float]]
    u_max_v: Optional[float]
    a_max_um: Optional[float]
    band_mu: Optional[Tuple[float, float]]
    below_band_fraction: Optional[float]
    above_band_fraction: Optional[float]
    text: str = field(repr=False)

    def __str__(self) -> str:
        return self.text
