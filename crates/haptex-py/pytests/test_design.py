"""haptex.voltage against `haptex voltage`: the same numbers, bit for bit,
on the shipped examples and each display; the same refusals."""

from __future__ import annotations

import numpy as np
import pytest

import haptex
from conftest import EXAMPLES, assert_identical, read_csv

BUMP = EXAMPLES / "bump_friction.csv"
PLATE = EXAMPLES / "ultrasonic_calibration.csv"

# (command-line flags, keyword arguments): the same design both ways.
CASES = [
    ([], {}),
    (["--method", "normalized"], {"method": "normalized"}),
    (["--relative", "--flat-mu", "1.1", "--mu-hd", "0.5"], {"relative": True, "flat_mu": 1.1, "mu_hd": 0.5}),
    (["--relative"], {"relative": True}),
    (["--mu-hd", "0.9", "--u-max", "150", "--k-mm2-per-n", "230", "--eps-sc", "1000", "--d-i-mm", "0.002"],
     {"mu_hd": 0.9, "u_max": 150.0, "k_mm2_per_n": 230.0, "eps_sc": 1000.0, "d_i_mm": 0.002}),
    (["--area-exponent", "0.8", "--fn-n", "0.5"], {"area_exponent": 0.8, "fn_n": 0.5}),
    (["--force-model", "circuit", "--rho-sc-ohm-m", "1e5", "--gap-um", "2", "--carrier-hz", "300"],
     {"force_model": "circuit", "rho_sc_ohm_m": 1e5, "gap_um": 2.0, "carrier_hz": 300.0}),
    (["--display", "ultrasonic"], {"display": "ultrasonic"}),
    (["--display", "ultrasonic", "--ultrasonic-calibration", str(PLATE), "--a-max-um", "1.5"],
     {"display": "ultrasonic", "ultrasonic_calibration": PLATE, "a_max_um": 1.5}),
    (["--display", "combined"], {"display": "combined"}),
    (["--display", "combined", "--strategy", "bias", "--mu-hd", "1.1"],
     {"display": "combined", "strategy": "bias", "mu_hd": 1.1}),
    (["--display", "combined", "--strategy", "weighted", "--weight", "0.3", "--relative"],
     {"display": "combined", "strategy": "weighted", "weight": 0.3, "relative": True}),
]


@pytest.mark.parametrize("flags,kwargs", CASES, ids=[" ".join(f) or "defaults" for f, _ in CASES])
def test_voltage_matches_the_command_line(cli, tmp_path, flags, kwargs):
    out = tmp_path / "u.csv"
    cli.run("voltage", "--profile", BUMP, *flags, "-q", "-o", out)
    expected = read_csv(out)
    design = haptex.voltage(BUMP, **kwargs)
    assert_identical(design.x_mm, expected["x_mm"], "x_mm")
    assert_identical(design.mu, expected["mu"], "mu")
    for column in ("voltage_v", "amplitude_um"):
        got = getattr(design, column)
        if column in expected:
            assert_identical(got, expected[column], column)
        else:
            assert got is None, f"{column} is not a channel of this design"
    # The file the design writes is the command line's, byte for byte.
    mine = tmp_path / "mine.csv"
    design.write_csv(mine)
    assert mine.read_bytes() == out.read_bytes()
    assert design.to_csv() == out.read_text()


def test_summary_is_the_command_lines(cli, tmp_path):
    result = cli.run("voltage", "--profile", BUMP, "-o", tmp_path / "u.csv")
    summary = haptex.voltage(BUMP).summary
    assert result.stderr.startswith(summary.text)
    assert summary.display == "electrovibration"
    assert summary.band_mu[0] == 1.0
    assert summary.above_band.fraction == pytest.approx(0.0459, abs=5e-5)
    assert summary.below_band.fraction == pytest.approx(0.0448, abs=5e-5)
    assert len(summary.warnings) == 2
    json_out = tmp_path / "u.json"
    cli.run("voltage", "--profile", BUMP, "-q", "-o", json_out)
    import json

    assert summary.details == json.loads(json_out.read_text())["summary"]


def test_inputs_arrays_lists_and_profiles_agree():
    table = np.loadtxt(BUMP, delimiter=",", comments="#", skiprows=2)
    x, mu = table[:, 0], table[:, 1]
    from_file = haptex.voltage(BUMP).voltage_v
    for profile in [(x, mu), (list(x), list(mu)), haptex.Profile(x, mu), (x[::-1][::-1], mu)]:
        assert_identical(haptex.voltage(profile).voltage_v, from_file, repr(type(profile)))


@pytest.mark.parametrize(
    "flags,kwargs",
    [
        (["--mu-hd", "50"], {"mu_hd": 50.0}),
        (["--u-max", "0"], {"u_max": 0.0}),
        (["--display", "combined", "--weight", "2"], {"display": "combined", "weight": 2.0}),
        (["--strategy", "bias"], {"strategy": "bias"}),
        (["--display", "ultrasonic", "--method", "normalized"], {"display": "ultrasonic", "method": "normalized"}),
    ],
)
def test_refusals_are_value_errors(cli, flags, kwargs):
    cli.error("voltage", "--profile", BUMP, *flags)
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.voltage(BUMP, **kwargs)
    assert isinstance(caught.value, ValueError)
    assert isinstance(caught.value, haptex.HaptexError)


def test_a_bad_file_names_its_line_as_the_command_line_does(cli, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("x_mm,mu\n0,1\n1,oops\n")
    message = cli.error("voltage", "--profile", bad)
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.voltage(bad)
    assert str(caught.value) == message
    assert "line 3" in message


def test_a_missing_file_is_an_os_error(tmp_path):
    with pytest.raises(haptex.HaptexOSError) as caught:
        haptex.voltage(tmp_path / "nope.csv")
    assert isinstance(caught.value, OSError)
    assert "nope.csv" in str(caught.value)


def test_non_finite_input_is_refused_not_nan():
    x = np.linspace(0.0, 1.0, 11)
    for bad in (np.nan, np.inf, -np.inf):
        mu = np.full(11, 1.1)
        mu[4] = bad
        with pytest.raises(haptex.InvalidInputError):
            haptex.voltage((x, mu))
