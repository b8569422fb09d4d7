"""haptex.play against `haptex play`: the same samples bit for bit, the
same WAV bytes and sidecar, the same refusals; and, for random designs and
trajectories, no sample beyond the limits the signal states."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import haptex
from conftest import EXAMPLES, assert_identical, in_keywords, read_csv

BUMP = EXAMPLES / "bump_friction.csv"


@pytest.fixture(scope="module")
def designs(cli, tmp_path_factory):
    """The bump's electrovibration and combined designs, written by the
    command line."""
    d = tmp_path_factory.mktemp("designs")
    cli.run("voltage", "--profile", BUMP, "-q", "-o", d / "u.csv")
    cli.run("voltage", "--profile", BUMP, "--display", "combined", "-q", "-o", d / "ua.csv")
    trajectory = d / "finger.csv"
    t = np.linspace(0.0, 0.4, 81)
    x = 10.0 + 30.0 * np.sin(np.pi * t / 0.4) ** 2
    trajectory.write_text("t_s,x_mm\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, x)))
    return {"u": d / "u.csv", "ua": d / "ua.csv", "finger": trajectory}


# (design key, command-line flags, keyword arguments): the same play both ways.
CASES = [
    ("u", ["--velocity", "50"], {"velocity": 50.0}),
    ("u", ["--velocity", "80", "--strokes", "2", "--slew-v-per-s", "20000", "--sample-rate", "8000"],
     {"velocity": 80.0, "strokes": 2, "slew_v_per_s": 20000.0, "sample_rate": 8000}),
    ("u", ["--trajectory", "finger", "--carrier", "square", "--carrier-hz", "400", "--u-max", "60"],
     {"trajectory": "finger", "carrier": "square", "carrier_hz": 400.0, "u_max": 60.0}),
    ("u", ["--velocity", "40", "--from-mm", "-5", "--to-mm", "70", "--outside", "zero", "--carrier", "none",
           "--volts-per-full-scale", "150"],
     {"velocity": 40.0, "from_mm": -5.0, "to_mm": 70.0, "outside": "zero", "carrier": "none",
      "volts_per_full_scale": 150.0}),
    ("ua", ["--velocity", "40"], {"velocity": 40.0}),
    ("ua", ["--velocity", "60", "--a-max-um", "1", "--outside", "repeat", "--from-mm", "0", "--to-mm", "90"],
     {"velocity": 60.0, "a_max_um": 1.0, "outside": "repeat", "from_mm": 0.0, "to_mm": 90.0}),
    ("ua", ["--velocity", "100", "--sample-rate", "96000", "--plate-resonance-hz", "30000"],
     {"velocity": 100.0, "sample_rate": 96000, "plate_resonance_hz": 30000.0}),
]


def _flags(flags, designs):
    return [str(designs[f]) if f in designs else f for f in flags]


def _kwargs(kwargs, designs):
    return {k: (designs[v] if isinstance(v, str) and v in designs else v) for k, v in kwargs.items()}


@pytest.mark.parametrize("key,flags,kwargs", CASES, ids=[f"{k} {' '.join(f)}" for k, f, _ in CASES])
def test_play_matches_the_command_line(cli, tmp_path, designs, key, flags, kwargs):
    profile = designs[key]
    cli.run("play", "--profile", profile, *_flags(flags, designs), "-q", "-o", tmp_path / "cli.csv")
    expected = read_csv(tmp_path / "cli.csv")
    signal = haptex.play(profile, **_kwargs(kwargs, designs))
    for column in ("t_s", "x_mm", "envelope_v", "signal_v"):
        assert_identical(getattr(signal, column), expected[column], column)
    for column in ("amplitude_um", "displacement_um"):
        if column in expected:
            assert_identical(getattr(signal, column), expected[column], column)
        else:
            assert getattr(signal, column) is None, column
    assert signal.channels == (2 if key == "ua" else 1)
    # The CSV file, byte for byte.
    signal.write_csv(tmp_path / "py.csv")
    assert (tmp_path / "py.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    assert signal.to_csv() == (tmp_path / "cli.csv").read_text()


@pytest.mark.parametrize("wav_format", ["pcm16", "pcm24", "float32"])
@pytest.mark.parametrize("key", ["u", "ua"])
def test_wav_and_sidecar_are_the_command_lines(cli, tmp_path, designs, key, wav_format):
    profile = designs[key]
    cli_wav = tmp_path / "cli.wav"
    cli.run("play", "--profile", profile, "--velocity", "60", "--wav-format", wav_format, "-q", "-o", cli_wav)
    signal = haptex.play(profile, velocity=60.0)
    py_wav = tmp_path / "py.wav"
    sidecar = signal.write_wav(py_wav, wav_format=wav_format)
    assert py_wav.read_bytes() == cli_wav.read_bytes()
    assert signal.wav_bytes(wav_format=wav_format) == cli_wav.read_bytes()
    cli_sidecar = json.loads((tmp_path / "cli.wav.json").read_text())
    py_sidecar = json.loads((tmp_path / "py.wav.json").read_text())
    assert py_sidecar == sidecar
    # Everything but the command that made it: scale, hashes, report, source.
    assert py_sidecar["source"].pop("command") == "haptex.play (Python)"
    cli_sidecar["source"].pop("command")
    assert py_sidecar["wav_file"] == "py.wav" and cli_sidecar["wav_file"] == "cli.wav"
    py_sidecar["wav_file"] = cli_sidecar["wav_file"]
    assert py_sidecar == cli_sidecar
    assert sidecar["volts_per_full_scale"] == signal.volts_per_full_scale == 100.0 * np.sqrt(2.0)
    assert sidecar["channels"] == signal.channels
    if key == "ua":
        assert sidecar["channel_2"]["um_per_full_scale"] == signal.um_per_full_scale
    # The WAV passes the command line's own check.
    cli.run("play", "--check", py_wav)


def test_read_wav_checks_as_the_command_line_does(cli, tmp_path, designs):
    signal = haptex.play(designs["ua"], velocity=60.0)
    wav = tmp_path / "p.wav"
    signal.write_wav(wav, wav_format="pcm24")
    back = haptex.read_wav(wav)
    assert back["scale"]["volts_per_full_scale"] == signal.volts_per_full_scale
    assert back["sidecar"]["samples_sha256"] == back["scale"]["samples_sha256"]
    # Within half a code of the rendered samples, never beyond full scale.
    step_v = signal.volts_per_full_scale / 8388607
    assert np.abs(back["volts"] - signal.signal_v).max() <= 0.5 * step_v * (1 + 1e-9)
    assert np.abs(back["volts"]).max() <= signal.volts_per_full_scale
    step_um = signal.um_per_full_scale / 8388607
    assert np.abs(back["amplitude_um"] - signal.amplitude_um).max() <= 0.5 * step_um * (1 + 1e-9)
    # A sample changed after writing: refused, with the command line's message.
    data = bytearray(wav.read_bytes())
    at = data.index(b"data") + 8 + 3 * 1000
    data[at] ^= 0x01
    wav.write_bytes(bytes(data))
    message = cli.error("play", "--check", wav)
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.read_wav(wav)
    assert str(caught.value) == message
    with pytest.raises(haptex.HaptexOSError):
        haptex.read_wav(tmp_path / "nope.wav")


def test_a_design_object_plays_as_its_file(cli, tmp_path, designs):
    for key, kwargs in (("u", {}), ("ua", {"display": "combined"})):
        from_file = haptex.play(designs[key], velocity=50.0)
        from_design = haptex.play(haptex.voltage(BUMP, **kwargs), velocity=50.0)
        for column in ("signal_v", "envelope_v", "amplitude_um"):
            if getattr(from_file, column) is not None:
                assert_identical(getattr(from_design, column), getattr(from_file, column), column)
        assert from_design.wav_bytes() == from_file.wav_bytes()


def test_arrays_play_as_a_file(designs):
    table = read_csv(designs["u"])
    from_arrays = haptex.play((table["x_mm"], table["voltage_v"]), velocity=50.0)
    assert_identical(from_arrays.signal_v, haptex.play(designs["u"], velocity=50.0).signal_v, "signal_v")
    finger = read_csv(designs["finger"])
    by_arrays = haptex.play(designs["u"], trajectory=(finger["t_s"], finger["x_mm"]))
    by_file = haptex.play(designs["u"], trajectory=designs["finger"])
    assert_identical(by_arrays.signal_v, by_file.signal_v, "signal_v")


@pytest.mark.parametrize(
    "flags,kwargs",
    [
        (["--velocity", "50", "--amp-range-v", "100"], {"velocity": 50.0, "amp_range_v": 100.0}),
        (["--velocity", "50", "--volts-per-full-scale", "100"], {"velocity": 50.0, "volts_per_full_scale": 100.0}),
        (["--velocity", "50", "--carrier-hz", "30000"], {"velocity": 50.0, "carrier_hz": 30000.0}),
        (["--velocity", "50", "--a-max-um", "1"], {"velocity": 50.0, "a_max_um": 1.0}),
        (["--velocity", "1e-6"], {"velocity": 1e-6}),
    ],
)
def test_refusals_are_the_command_lines(cli, tmp_path, designs, flags, kwargs):
    message = cli.error("play", "--profile", designs["u"], *flags, "-o", tmp_path / "x.wav")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.play(designs["u"], **kwargs)
    assert str(caught.value) == in_keywords(message)
    assert not (tmp_path / "x.wav").exists()


def test_channel_2_above_the_stated_a_max_is_refused(cli, tmp_path, designs):
    message = cli.error("play", "--profile", designs["ua"], "--velocity", "50", "--a-max-um", "50",
                        "-o", tmp_path / "x.wav")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.play(designs["ua"], velocity=50.0, a_max_um=50.0)
    assert str(caught.value) == in_keywords(message)
    assert str(caught.value).startswith("a_max_um 50 is above the a_max")


def test_argument_refusals():
    x = np.linspace(0.0, 10.0, 11)
    u = np.full(11, 50.0)
    for kwargs in ({}, {"velocity": 10.0, "trajectory": ([0.0, 1.0], [0.0, 1.0])}, {"strokes": 2},
                   {"velocity": -1.0}, {"velocity": 10.0, "outside": "wrap"}, {"velocity": 10.0, "sample_rate": 10},
                   {"velocity": 10.0, "carrier": "triangle"}, {"velocity": 10.0, "u_max": 0.0}):
        with pytest.raises(haptex.InvalidInputError):
            haptex.play((x, u), **kwargs)
    with pytest.raises(haptex.InvalidInputError):
        haptex.play((x, u), velocity=10.0).write_wav("never.wav", wav_format="pcm8")


def test_a_missing_file_is_an_os_error(tmp_path, designs):
    with pytest.raises(haptex.HaptexOSError):
        haptex.play(tmp_path / "nope.csv", velocity=10.0)
    with pytest.raises(haptex.HaptexOSError):
        haptex.play(designs["u"], trajectory=tmp_path / "nope.csv")


# --- properties: random designs and trajectories -------------------------

finite = dict(allow_nan=False, allow_infinity=False)


@st.composite
def plays(draw):
    n = draw(st.integers(2, 12))
    steps = draw(st.lists(st.floats(0.1, 20.0, **finite), min_size=n - 1, max_size=n - 1))
    x = np.concatenate([[draw(st.floats(-50.0, 50.0, **finite))], np.zeros(n - 1)])
    x[1:] = x[0] + np.cumsum(steps)
    u = np.array(draw(st.lists(st.floats(0.0, 400.0, **finite), min_size=n, max_size=n)))
    m = draw(st.integers(2, 8))
    dt = draw(st.lists(st.floats(1e-3, 0.02, **finite), min_size=m - 1, max_size=m - 1))
    t = np.concatenate([[0.0], np.cumsum(dt)])
    xt = np.array(draw(st.lists(st.floats(-100.0, 150.0, **finite), min_size=m, max_size=m)))
    kwargs = {
        "carrier": draw(st.sampled_from(["sine", "square", "none"])),
        "u_max": draw(st.floats(1.0, 300.0, **finite)),
        "outside": draw(st.sampled_from(["hold", "zero", "repeat"])),
        "sample_rate": draw(st.sampled_from([4000, 8000, 48000])),
    }
    if draw(st.booleans()):
        kwargs["slew_v_per_s"] = draw(st.floats(10.0, 1e6, **finite))
    amplitude = None
    if draw(st.booleans()):
        amplitude = np.array(draw(st.lists(st.floats(0.0, 5.0, **finite), min_size=n, max_size=n)))
        kwargs["a_max_um"] = draw(st.floats(0.01, 4.0, **finite))
    return x, u, amplitude, (t, xt), kwargs


@settings(derandomize=True, max_examples=60, deadline=None)
@given(plays())
def test_no_sample_beyond_the_stated_limits(case):
    x, u, amplitude, trajectory, kwargs = case
    design = (x, u) if amplitude is None else (x, u, amplitude)
    signal = haptex.play(design, trajectory=trajectory, **kwargs)
    u_max = kwargs["u_max"]
    envelope = signal.envelope_v
    assert np.isfinite(signal.signal_v).all() and np.isfinite(envelope).all()
    assert envelope.min() >= 0.0 and envelope.max() <= u_max
    peak_per_rms = {"sine": np.sqrt(2.0), "square": 1.0, "none": 1.0}[kwargs["carrier"]]
    assert np.abs(signal.signal_v).max() <= signal.peak_v <= signal.volts_per_full_scale
    assert signal.peak_v <= peak_per_rms * u_max * (1 + 1e-12)
    assert signal.volts_per_full_scale == np.sqrt(2.0) * u_max
    assert signal.report["limits"]["u_max_v"] == u_max
    if amplitude is not None:
        a_max = kwargs["a_max_um"]
        assert signal.um_per_full_scale == a_max
        assert signal.amplitude_um.min() >= 0.0 and signal.amplitude_um.max() <= a_max
    # Every WAV sample within full scale, decoded from the bytes written.
    wav = signal.wav_bytes(wav_format="float32")
    data = wav.index(b"data")
    size = int.from_bytes(wav[data + 4:data + 8], "little")
    samples = np.frombuffer(wav[data + 8:data + 8 + size], dtype="<f4").reshape(-1, signal.channels)
    assert np.abs(samples).max() <= 1.0
    assert samples.shape[0] == len(signal)


@settings(derandomize=True, max_examples=30, deadline=None)
@given(plays(), st.sampled_from([np.nan, np.inf, -np.inf]), st.integers(0, 3), st.integers(0, 100))
def test_non_finite_input_is_refused_not_nan(case, bad, where, at):
    x, u, amplitude, (t, xt), kwargs = case
    arrays = [x.copy(), u.copy(), t.copy(), xt.copy()]
    arrays[where][at % len(arrays[where])] = bad
    x, u, t, xt = arrays
    design = (x, u) if amplitude is None else (x, u, amplitude)
    with pytest.raises(haptex.InvalidInputError):
        haptex.play(design, trajectory=(t, xt), **kwargs)


@settings(derandomize=True, max_examples=20, deadline=None)
@given(st.sampled_from([np.nan, np.inf, -np.inf]),
       st.sampled_from(["u_max", "slew_v_per_s", "amp_range_v", "volts_per_full_scale", "carrier_hz", "velocity",
                        "a_max_um", "from_mm"]))
def test_non_finite_arguments_are_refused(bad, name):
    x = np.linspace(0.0, 10.0, 11)
    kwargs = {"velocity": 10.0, name: bad}
    with pytest.raises(haptex.InvalidInputError):
        haptex.play((x, np.full(11, 50.0), np.full(11, 1.0)), **kwargs)
