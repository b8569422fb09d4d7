"""Properties of haptex.voltage over random profiles and devices
(Hypothesis, derandomized so that a run never fails on a case nobody
changed): no voltage outside [0, U_max], no amplitude outside [0, a_max],
whatever the display and strategy; non-finite input is an error, never a
NaN in the output."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import haptex

SETTINGS = settings(derandomize=True, max_examples=150, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@st.composite
def profiles(draw):
    n = draw(st.integers(2, 60))
    steps = draw(st.lists(st.floats(1e-3, 5.0), min_size=n - 1, max_size=n - 1))
    x0 = draw(st.floats(-100.0, 100.0))
    x = x0 + np.concatenate([[0.0], np.cumsum(steps)])
    mu = np.array(draw(st.lists(st.floats(-2.0, 8.0), min_size=n, max_size=n)))
    return x, mu


devices = st.fixed_dictionaries({
    "mu_hd": st.floats(0.01, 5.0),
    "u_max": st.floats(0.01, 5000.0),
    "k_mm2_per_n": st.floats(1.0, 1e4),
    "eps_sc": st.floats(1.0, 1e4),
    "d_i_mm": st.floats(1e-4, 1.0),
})

displays = st.one_of(
    st.just({"display": "electrovibration"}),
    st.just({"display": "electrovibration", "method": "normalized"}),
    st.builds(lambda a: {"display": "ultrasonic", "a_max_um": a}, st.floats(0.01, 2.3)),
    st.builds(lambda s: {"display": "combined", "strategy": s}, st.sampled_from(["split", "bias"])),
    st.builds(lambda w: {"display": "combined", "strategy": "weighted", "weight": w}, st.floats(0.0, 100.0)),
)


@SETTINGS
@given(profiles(), devices, displays, st.booleans())
def test_no_drive_beyond_its_limit(profile, device, display, relative):
    kwargs = {**device, **display}
    if relative:
        kwargs["relative"] = True
        kwargs["flat_mu"] = 0.5
    try:
        design = haptex.voltage(profile, **kwargs)
    except haptex.InvalidInputError as e:
        # Refused (a profile eq. 9 cannot scale, a relative profile out of
        # range): an error with a message, never a NaN.
        assert str(e)
        return
    s = design.summary
    if design.voltage_v is not None:
        u = design.voltage_v
        assert np.isfinite(u).all()
        assert u.min() >= 0.0
        assert u.max() <= s.u_max_v
        assert s.u_max_v == kwargs["u_max"]
    if design.amplitude_um is not None:
        a = design.amplitude_um
        assert np.isfinite(a).all()
        assert a.min() >= 0.0
        assert a.max() <= s.a_max_um
        assert s.a_max_um <= kwargs.get("a_max_um", 2.3)
    assert 0.0 <= s.above_band.fraction <= 1.0
    assert 0.0 <= s.below_band.fraction <= 1.0


@SETTINGS
@given(profiles(), st.integers(0, 59), st.sampled_from([math.nan, math.inf, -math.inf]),
       st.sampled_from(["x_mm", "mu"]), displays)
def test_non_finite_input_is_an_error(profile, index, bad, where, display):
    x, mu = (a.copy() for a in profile)
    target = x if where == "x_mm" else mu
    target[index % len(target)] = bad
    with pytest.raises(haptex.InvalidInputError):
        haptex.voltage((x, mu), **display)


@SETTINGS
@given(st.sampled_from(["mu_hd", "u_max", "k_mm2_per_n", "eps_sc", "eps_i", "d_sc_mm", "d_i_mm", "flat_mu",
                        "fn_n", "area_exponent"]),
       st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0, 1e300]))
def test_non_finite_or_out_of_range_constants_are_errors(name, value):
    kwargs = {name: value}
    if name == "flat_mu":
        kwargs["relative"] = True
    with pytest.raises(haptex.InvalidInputError, match=name.split("_max")[0]):
        haptex.voltage((np.linspace(0, 1, 5), np.full(5, 1.1)), **kwargs)
