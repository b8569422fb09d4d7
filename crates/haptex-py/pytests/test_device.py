"""device= (a display's device file, `haptex calibrate`) on voltage, check,
play and map_voltage against `--device FILE` of the command line: the
same files byte for byte, the same refusals in the keywords' words.

The device files are calibrated here, by the command line, from the
shipped synthetic measurements (data/examples/calibration-measurements.csv,
seven carriers: the circuit model) and from their 1 kHz rows alone (one
carrier: the eq3 model, which the FE check accepts).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import haptex
from conftest import EXAMPLES, assert_identical, in_keywords, read_csv

BUMP = EXAMPLES / "bump_friction.csv"
MEASUREMENTS = EXAMPLES / "calibration-measurements.csv"


@pytest.fixture(scope="module")
def files(cli, tmp_path_factory):
    """{"circuit": path, "eq3": path, "eq3_low": path, "bare": path}: device
    files made by `haptex calibrate`; eq3_low states U_max 80 V; bare has
    no ultrasonic plate (no amplitude was measured)."""
    d = tmp_path_factory.mktemp("device")
    lines = MEASUREMENTS.read_text().splitlines()
    header = next(i for i, l in enumerate(lines) if not l.startswith("#"))
    columns = lines[header].split(",")
    carrier, hz, v = (columns.index(c) for c in ("carrier", "carrier_hz", "voltage_v"))
    rows = [l.split(",") for l in lines[header + 1:]]
    one_carrier = [",".join(r) for r in rows if r[carrier] == "sine" and r[hz] == "1000"]
    # The plate's rows: at 0 V, each amplitude and the plate at rest.
    plate = [",".join(r) for r in rows if float(r[v]) == 0 and not (r[carrier] == "sine" and r[hz] == "1000")]
    assert len(one_carrier) >= 30 and len(plate) >= 30
    eq3_measurements, bare_measurements = d / "eq3-measurements.csv", d / "bare-measurements.csv"
    eq3_measurements.write_text("\n".join(lines[: header + 1] + one_carrier + plate) + "\n")
    bare_measurements.write_text("\n".join(lines[: header + 1] + one_carrier) + "\n")
    out = {"circuit": d / "circuit.toml", "eq3": d / "eq3.toml", "eq3_low": d / "eq3-low.toml",
           "bare": d / "bare.toml"}
    cli.run("calibrate", "--measurements", MEASUREMENTS, "-o", out["circuit"])
    cli.run("calibrate", "--measurements", eq3_measurements, "-o", out["eq3"])
    cli.run("calibrate", "--measurements", eq3_measurements, "--u-max", "80", "-o", out["eq3_low"])
    cli.run("calibrate", "--measurements", bare_measurements, "-o", out["bare"])
    assert "circuit" in out["circuit"].read_text() and "circuit" not in out["eq3"].read_text().split("[electro")[1]
    return out


# (file, command-line flags, keyword arguments): one design both ways.
VOLTAGE_CASES = [
    ("circuit", [], {}),
    ("circuit", ["--carrier-hz", "300", "--u-max", "70"], {"carrier_hz": 300.0, "u_max": 70.0}),
    ("circuit", ["--carrier", "square", "--carrier-hz", "200", "--relative"],
     {"carrier": "square", "carrier_hz": 200.0, "relative": True}),
    ("eq3", [], {}),
    ("eq3", ["--method", "normalized"], {"method": "normalized"}),
    ("eq3", ["--display", "combined", "--strategy", "bias"], {"display": "combined", "strategy": "bias"}),
    ("circuit", ["--display", "ultrasonic", "--a-max-um", "1"], {"display": "ultrasonic", "a_max_um": 1.0}),
]


@pytest.mark.parametrize("which,flags,kwargs", VOLTAGE_CASES,
                         ids=[f"{w} " + (" ".join(f) or "defaults") for w, f, _ in VOLTAGE_CASES])
def test_voltage_with_a_device_file_is_the_command_lines(cli, tmp_path, files, which, flags, kwargs):
    device = files[which]
    out, js = tmp_path / "u.csv", tmp_path / "u.json"
    cli.run("voltage", "--profile", BUMP, "--device", device, *flags, "-q", "-o", out)
    cli.run("voltage", "--profile", BUMP, "--device", device, *flags, "-q", "-o", js)
    design = haptex.voltage(BUMP, device=device, **kwargs)
    assert design.to_csv() == out.read_text()
    mine = tmp_path / "mine.csv"
    design.write_csv(mine)
    assert mine.read_bytes() == out.read_bytes()
    assert design.to_dict() == json.loads(js.read_text())
    # The notes name the file by its SHA-256, as `haptex play` reads it.
    expected = read_csv(out)
    assert design.notes == expected["#"][: len(design.notes)]
    assert any("device file sha256 " in n for n in design.notes)
    if design.voltage_v is not None:
        assert design.voltage_v.max() <= min(kwargs.get("u_max", 100.0), 100.0)
        assert_identical(design.voltage_v, expected["voltage_v"], "voltage_v")


def test_the_file_sets_what_it_states(files):
    by_file = haptex.voltage(BUMP, device=files["eq3_low"])
    assert by_file.summary.u_max_v == 80.0
    lower = haptex.voltage(BUMP, device=files["eq3_low"], u_max=60.0)
    assert lower.summary.u_max_v == 60.0 and lower.voltage_v.max() <= 60.0


# (file, flags, keyword arguments) each refused with the flag's message.
REFUSALS = [
    ("eq3_low", ["--u-max", "90"], {"u_max": 90.0}),
    ("eq3", ["--carrier-hz", "300"], {"carrier_hz": 300.0}),
    ("eq3", ["--display", "ultrasonic", "--a-max-um", "9"], {"display": "ultrasonic", "a_max_um": 9.0}),
    ("bare", ["--display", "combined"], {"display": "combined"}),
]


@pytest.mark.parametrize("which,flags,kwargs", REFUSALS, ids=[" ".join(f) for _, f, _ in REFUSALS])
def test_refusals_are_the_command_lines_in_keyword_words(cli, files, which, flags, kwargs):
    message = cli.error("voltage", "--profile", BUMP, "--device", files[which], *flags, "-q", "-o", "u.csv")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.voltage(BUMP, device=files[which], **kwargs)
    assert str(caught.value) == in_keywords(message)


@pytest.mark.parametrize("keyword", ["mu_hd", "k_mm2_per_n", "eps_sc", "area_exponent", "gap_um"])
def test_what_the_file_sets_is_refused_beside_it(files, keyword):
    with pytest.raises(haptex.InvalidInputError, match=f"^{keyword} cannot be given with device="):
        haptex.voltage(BUMP, device=files["eq3"], **{keyword: 1.0})
    with pytest.raises(haptex.InvalidInputError, match="^force_model cannot be given with device="):
        haptex.voltage(BUMP, device=files["eq3"], force_model="circuit")


def test_a_missing_or_corrupt_file(cli, tmp_path):
    with pytest.raises(haptex.HaptexOSError):
        haptex.voltage(BUMP, device=tmp_path / "absent.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("haptex-device 1\nnot toml at all = = =\n")
    message = cli.error("voltage", "--profile", BUMP, "--device", bad, "-q", "-o", tmp_path / "u.csv")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.voltage(BUMP, device=bad)
    assert str(caught.value) == message
    assert str(bad) in message


def test_check_with_a_device_file(cli, tmp_path, files):
    out, u = tmp_path / "c.csv", tmp_path / "u.csv"
    flags = ["--step", "0.2", "--carrier-hz", "1000", "--u-max", "90"]
    cli.run("check", "--profile", BUMP, "--device", files["eq3"], *flags, "-q", "-o", out, "--voltage-out", u)
    result = haptex.check(BUMP, device=files["eq3"], step=0.2, carrier_hz=1000.0, u_max=90.0, progress=False)
    assert result.to_csv() == out.read_text()
    assert result.design.to_csv() == u.read_text()
    assert result.lines[0].startswith("designed with device file ")
    # The circuit model's file is refused: the FE display has no gain.
    message = cli.error("check", "--profile", BUMP, "--device", files["circuit"], "-q")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.check(BUMP, device=files["circuit"], progress=False)
    assert str(caught.value) == in_keywords(message)
    with pytest.raises(haptex.InvalidInputError, match="^fe_k cannot be given with device="):
        haptex.check(BUMP, device=files["eq3"], fe_k=True, progress=False)
    with pytest.raises(haptex.InvalidInputError, match="give device= with them"):
        haptex.check(BUMP, carrier_hz=300.0, progress=False)


def test_play_on_a_device_files_display(cli, tmp_path, files):
    design = tmp_path / "u.csv"
    cli.run("voltage", "--profile", BUMP, "--device", files["circuit"], "--carrier-hz", "300", "-q", "-o", design)
    flags = ["--velocity", "50", "--carrier-hz", "300"]
    for suffix in ("csv", "wav"):
        out = tmp_path / f"s.{suffix}"
        cli.run("play", "--profile", design, "--device", files["circuit"], *flags, "-q", "-o", out)
        signal = haptex.play(design, device=files["circuit"], velocity=50.0, carrier_hz=300.0)
        mine = tmp_path / f"mine.{suffix}"
        if suffix == "csv":
            signal.write_csv(mine)
            assert mine.read_bytes() == out.read_bytes()
            assert "played on the display of designed with device file" in out.read_text().splitlines()[0]
        else:
            signal.write_wav(mine)
            sidecar = json.loads(Path(f"{mine}.json").read_text())
            theirs = json.loads(Path(f"{out}.json").read_text())
            assert sidecar["source"]["device_file"] == theirs["source"]["device_file"]
            assert haptex.read_wav(mine)["scale"] == haptex.read_wav(out)["scale"]
    # Played with another device file than the one it was designed with.
    message = cli.error("play", "--profile", design, "--device", files["eq3"], "--velocity", "50", "-q",
                        "-o", tmp_path / "x.csv")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.play(str(design), device=files["eq3"], velocity=50.0)
    assert str(caught.value) == message
    # A design for 300 Hz is not played on another carrier.
    message = cli.error("play", "--profile", design, "--carrier-hz", "500", "--velocity", "50", "-q",
                        "-o", tmp_path / "x.csv")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.play(design, velocity=50.0, carrier_hz=500.0)
    assert str(caught.value) == in_keywords(message)
    assert 'play it with carrier="sine", carrier_hz=300 (or design it again for carrier="sine", carrier_hz=500)' in (
        str(caught.value))
    # The file's U_max bounds the drive: a higher u_max is refused.
    with pytest.raises(haptex.InvalidInputError, match="^u_max 120 is above the U_max = 100 V RMS"):
        haptex.play(design, device=files["circuit"], velocity=50.0, carrier_hz=300.0, u_max=120.0)


def test_map_voltage_with_a_device_file(cli, tmp_path, files):
    friction = tmp_path / "f.csv"
    cli.run("map", "from-profile", "--profile", BUMP, "--dx-mm", "0.5", "--dy-mm", "0.5", "--ny", "4", "-o", friction)
    flags = ["--carrier-hz", "300"]
    for suffix in ("csv", "npy"):
        out = tmp_path / f"u.{suffix}"
        cli.run("map", "voltage", "--map", friction, "--device", files["circuit"], *flags, "-o", out)
        u = haptex.map_voltage(friction, device=files["circuit"], carrier_hz=300.0)
        mine = tmp_path / f"mine.{suffix}"
        u.write(mine)
        assert mine.read_bytes() == out.read_bytes()
        if suffix == "npy":
            assert Path(f"{mine}.json").read_bytes() == Path(f"{out}.json").read_bytes()
    assert len(u.notes) == 2 and "device file sha256 " in u.notes[0]
    assert u.notes[1].startswith("designed for the carrier: sine 300 Hz")
    assert np.nanmax(u.voltage_v) <= 100.0
