"""Friction maps from Python against `haptex map`: the same cells, bit for
bit, and the same files, byte for byte (from-image, from-profile, voltage,
sample-path); the same refusals; and, for random maps and devices, no
voltage above U_max and no amplitude above a_max in any cell."""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import haptex
from conftest import EXAMPLES, REPO, assert_identical, read_csv

BUMP = EXAMPLES / "bump_friction.csv"
PLATE = EXAMPLES / "ultrasonic_calibration.csv"


def write_gray_png(path: Path, levels: np.ndarray) -> None:
    """A plain grayscale PNG of `levels` (uint8 or uint16, row 0 the top)."""
    height, width = levels.shape
    bits = 8 if levels.dtype == np.uint8 else 16
    rows = levels.astype(">u2" if bits == 16 else np.uint8)
    raw = b"".join(b"\x00" + rows[r].tobytes() for r in range(height))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, bits, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def levels_image(dtype, shape=(7, 11)) -> np.ndarray:
    """A deterministic gray image with black, full white and levels between."""
    full = np.iinfo(dtype).max
    ny, nx = shape
    j, i = np.mgrid[0:ny, 0:nx]
    levels = ((i * 37 + j * 101) * 2654435761) % (full + 1)
    levels[0, 0], levels[-1, -1] = 0, full
    return levels.astype(dtype)


def grid_of(table: dict) -> tuple:
    """(ny, nx) of a long-format map CSV's columns."""
    y = table["y_mm"]
    nx = int(np.argmax(y != y[0])) if (y != y[0]).any() else len(y)
    return len(y) // nx, nx


def assert_same_files(mine: Path, theirs: Path) -> None:
    assert mine.read_bytes() == theirs.read_bytes(), f"{mine} differs from the command line's {theirs}"
    if mine.suffix == ".npy":
        sidecar = Path(str(mine) + ".json")
        assert sidecar.read_bytes() == Path(str(theirs) + ".json").read_bytes()


# --- from-image --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16], ids=["8-bit", "16-bit"])
@pytest.mark.parametrize(
    "flags,kwargs",
    [
        (["--mu-black", "0.4", "--mu-white", "1.2", "--pixel-mm", "0.1"], {"mu_black": 0.4, "mu_white": 1.2, "pixel_mm": 0.1}),
        (
            ["--mu-black", "1.5", "--mu-white", "0.3", "--gamma", "2.2", "--pixel-mm", "0.05", "--pixel-mm-y", "0.2",
             "--x0-mm", "-3", "--y0-mm", "7.5"],
            {"mu_black": 1.5, "mu_white": 0.3, "gamma": 2.2, "pixel_mm": 0.05, "pixel_mm_y": 0.2, "x0_mm": -3.0,
             "y0_mm": 7.5},
        ),
    ],
    ids=["linear", "gamma-origin"],
)
def test_from_image_matches_the_command_line(cli, tmp_path, dtype, flags, kwargs):
    levels = levels_image(dtype)
    png = tmp_path / "image.png"
    write_gray_png(png, levels)
    cli.run("map", "from-image", png, *flags, "-o", tmp_path / "cli.csv")
    cli.run("map", "from-image", png, *flags, "-o", tmp_path / "cli.npy")
    expected = read_csv(tmp_path / "cli.csv")
    ny, nx = grid_of(expected)
    assert (ny, nx) == levels.shape
    for image in (png, str(png), levels, np.asfortranarray(levels), levels[::-1][::-1]):
        friction = haptex.map_from_image(image, **kwargs)
        assert friction.shape == (ny, nx)
        assert_identical(friction.mu.ravel(), expected["mu"], f"mu of {type(image).__name__}")
        assert_identical(np.repeat(friction.y_mm, nx), expected["y_mm"], "y_mm")
        assert_identical(np.tile(friction.x_mm, ny), expected["x_mm"], "x_mm")
    # The image's top row is the map's last row (largest y).
    assert friction.mu[-1, 0] == kwargs["mu_black"]
    assert friction.mu[0, -1] == pytest.approx(kwargs["mu_white"], rel=1e-15)
    friction.write(tmp_path / "mine.csv")
    friction.write(tmp_path / "mine.npy")
    assert_same_files(tmp_path / "mine.csv", tmp_path / "cli.csv")
    assert_same_files(tmp_path / "mine.npy", tmp_path / "cli.npy")
    assert friction.to_csv() == (tmp_path / "cli.csv").read_text()
    # Read back, either format, the same map.
    for path in (tmp_path / "cli.csv", tmp_path / "cli.npy"):
        assert_identical(haptex.FrictionMap.read(path).mu, friction.mu, f"read {path.suffix}")


def test_from_image_summary_is_the_command_lines(cli, tmp_path):
    png = tmp_path / "image.png"
    write_gray_png(png, levels_image(np.uint8))
    result = cli.run("map", "from-image", png, "--mu-black", "0.4", "--mu-white", "1.2", "--pixel-mm", "0.1", "-o",
                     tmp_path / "m.csv")
    friction = haptex.map_from_image(png, mu_black=0.4, mu_white=1.2, pixel_mm=0.1)
    assert result.stderr.splitlines()[0] == friction.summary


@pytest.mark.parametrize(
    "flags,kwargs",
    [
        (["--mu-black", "0.4", "--mu-white", "0.4"], {"mu_black": 0.4, "mu_white": 0.4}),
        (["--mu-black", "0.4", "--mu-white", "1", "--gamma", "50"], {"mu_black": 0.4, "mu_white": 1.0, "gamma": 50.0}),
    ],
)
def test_from_image_refusals_have_the_command_lines_message(cli, tmp_path, flags, kwargs):
    png = tmp_path / "image.png"
    write_gray_png(png, levels_image(np.uint8))
    message = cli.error("map", "from-image", png, *flags, "--pixel-mm", "0.1", "-o", tmp_path / "m.csv")
    for image in (png, levels_image(np.uint8)):
        with pytest.raises(haptex.InvalidInputError) as caught:
            haptex.map_from_image(image, pixel_mm=0.1, **kwargs)
        if isinstance(image, Path):
            assert str(caught.value) == message


@pytest.mark.parametrize(
    "image,words",
    [
        (np.zeros((4, 4)), "uint8 or uint16"),
        (np.zeros((4, 4), dtype=np.int16), "uint8 or uint16"),
        (np.zeros(16, dtype=np.uint8), "2-D"),
        (np.zeros((4, 4, 3), dtype=np.uint8), "2-D"),
        (np.zeros((1, 4), dtype=np.uint8), "at least 2 x 2"),
        ([[0, 1], [2, 3]], "path to a grayscale PNG"),
    ],
    ids=["float64", "int16", "1-D", "RGB", "one row", "list"],
)
def test_from_image_refuses_what_is_not_a_gray_image(image, words):
    with pytest.raises(haptex.InvalidInputError, match=words):
        haptex.map_from_image(image, mu_black=0.4, mu_white=1.2, pixel_mm=0.1)


def test_from_image_missing_file_is_an_os_error(tmp_path):
    with pytest.raises(haptex.HaptexOSError):
        haptex.map_from_image(tmp_path / "nope.png", mu_black=0.4, mu_white=1.2, pixel_mm=0.1)


# --- from-profile ------------------------------------------------------------------------------------------------


def test_from_profile_matches_the_command_line(cli, tmp_path):
    flags = ["--dx-mm", "0.07", "--dy-mm", "0.25", "--ny", "4", "--y0-mm", "-1"]
    cli.run("map", "from-profile", "--profile", BUMP, *flags, "-o", tmp_path / "cli.csv")
    cli.run("map", "from-profile", "--profile", BUMP, *flags, "-o", tmp_path / "cli.npy")
    expected = read_csv(tmp_path / "cli.csv")
    table = np.loadtxt(BUMP, delimiter=",", comments="#", skiprows=2)
    for profile in (BUMP, haptex.Profile.read_csv(BUMP), (table[:, 0], table[:, 1])):
        friction = haptex.map_from_profile(profile, dx_mm=0.07, dy_mm=0.25, ny=4, y0_mm=-1.0)
        assert_identical(friction.mu.ravel(), expected["mu"], "mu")
    assert friction.y0_mm == -1.0 and friction.shape[0] == 4
    # Every row is the profile.
    assert (friction.mu == friction.mu[0]).all()
    friction.write(tmp_path / "mine.csv")
    friction.write(tmp_path / "mine.npy")
    assert_same_files(tmp_path / "mine.csv", tmp_path / "cli.csv")
    assert_same_files(tmp_path / "mine.npy", tmp_path / "cli.npy")


@pytest.mark.parametrize("kwargs,words", [
    ({"dx_mm": 0.0}, "dx_mm must be a positive"),
    ({"dx_mm": float("nan")}, "dx_mm must be a positive"),
    ({"dy_mm": float("inf")}, "dy_mm must be a positive"),
    ({"ny": 1}, "ny must be from 2"),
    ({"dx_mm": 1e-9}, "too many"),
])
def test_from_profile_refusals(kwargs, words):
    args = {"dx_mm": 0.1, "dy_mm": 0.1, "ny": 3, **kwargs}
    with pytest.raises(haptex.InvalidInputError, match=words):
        haptex.map_from_profile(BUMP, **args)


# --- FrictionMap from arrays -------------------------------------------------------------------------------------


def test_a_map_from_an_array_is_the_array():
    mu = np.arange(12, dtype=np.float64).reshape(3, 4) / 10 + 0.5
    friction = haptex.FrictionMap(mu, dx_mm=0.5, dy_mm=0.25, x0_mm=1.0, y0_mm=-2.0)
    assert_identical(friction.mu, mu, "mu")
    assert friction.shape == (3, 4)
    assert_identical(friction.x_mm, [1.0, 1.5, 2.0, 2.5], "x_mm")
    assert_identical(friction.y_mm, [-2.0, -1.75, -1.5], "y_mm")
    # Ints, lists, strided and Fortran-ordered arrays hold the same values.
    for same in (mu.tolist(), np.asfortranarray(mu), mu[:, ::-1][:, ::-1]):
        assert_identical(haptex.FrictionMap(same, dx_mm=0.5, dy_mm=0.25, x0_mm=1.0, y0_mm=-2.0).mu, mu, "mu")
    ints = haptex.FrictionMap(np.ones((2, 2), dtype=np.int32), dx_mm=1.0, dy_mm=1.0)
    assert_identical(ints.mu, np.ones((2, 2)), "int mu")
    # The returned array is the caller's to change: the map keeps its own.
    friction.mu[0, 0] = 99.0
    assert friction.mu[0, 0] == 0.5


@pytest.mark.parametrize(
    "mu,words",
    [
        (np.ones(4), "2-D array"),
        (np.ones((2, 2, 2)), "2-D array"),
        (np.ones((2, 2), dtype=complex), "real numbers"),
        (np.array([["a", "b"], ["c", "d"]]), "real numbers"),
        (np.ones((2, 2), dtype=bool), "real numbers"),
        ([[1.0, 2.0], [3.0]], "2-D array"),
        (np.ones((1, 5)), "at least 2 x 2"),
    ],
    ids=["1-D", "3-D", "complex", "str", "bool", "ragged", "one row"],
)
def test_a_map_refuses_what_is_not_a_2d_real_array(mu, words):
    with pytest.raises(haptex.InvalidInputError, match=words):
        haptex.FrictionMap(mu, dx_mm=1.0, dy_mm=1.0)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_input_is_refused_not_nan(bad):
    mu = np.full((3, 3), 1.1)
    mu[1, 2] = bad
    with pytest.raises(haptex.InvalidInputError, match="x = 2 mm, y = 1 mm"):
        haptex.FrictionMap(mu, dx_mm=1.0, dy_mm=1.0)
    good = haptex.FrictionMap(np.full((3, 3), 1.1), dx_mm=1.0, dy_mm=1.0)
    for kwargs in ({"dx_mm": bad}, {"x0_mm": bad}):
        with pytest.raises(haptex.InvalidInputError):
            haptex.FrictionMap(np.full((3, 3), 1.1), **{"dx_mm": 1.0, "dy_mm": 1.0, **kwargs})
    for kwargs in ({"u_max": bad}, {"mu_hd": bad}, {"k_mm2_per_n": bad}):
        with pytest.raises(haptex.InvalidInputError):
            haptex.map_voltage(good, **kwargs)
    u = haptex.map_voltage(good)
    with pytest.raises(haptex.InvalidInputError):
        u.sample([0.0, bad], [0.0, 0.0])
    with pytest.raises(haptex.InvalidInputError):
        haptex.map_sample_path(u, ([0.0, 1.0], [0.0, bad], [0.0, 0.0]))
    with pytest.raises(haptex.InvalidInputError):
        haptex.map_from_image(levels_image(np.uint8), mu_black=bad, mu_white=1.0, pixel_mm=0.1)


# --- voltage -----------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def friction_csv(tmp_path_factory, cli) -> Path:
    """A friction map with cells below mu_HD, in the band and above it."""
    where = tmp_path_factory.mktemp("friction")
    png = where / "image.png"
    write_gray_png(png, levels_image(np.uint16, (9, 13)))
    out = where / "friction.csv"
    cli.run("map", "from-image", png, "--mu-black", "0.6", "--mu-white", "2.4", "--pixel-mm", "0.2", "-o", out)
    return out


VOLTAGE_CASES = [
    ([], {}),
    (["--method", "normalized"], {"method": "normalized"}),
    (["--mu-hd", "0.9", "--u-max", "150", "--k-mm2-per-n", "230", "--eps-sc", "1000", "--d-i-mm", "0.002"],
     {"mu_hd": 0.9, "u_max": 150.0, "k_mm2_per_n": 230.0, "eps_sc": 1000.0, "d_i_mm": 0.002}),
    (["--display", "ultrasonic"], {"display": "ultrasonic"}),
    (["--display", "ultrasonic", "--ultrasonic-calibration", str(PLATE), "--a-max-um", "1.5"],
     {"display": "ultrasonic", "ultrasonic_calibration": PLATE, "a_max_um": 1.5}),
    (["--display", "combined"], {"display": "combined"}),
    (["--display", "combined", "--strategy", "bias", "--mu-hd", "1.1"],
     {"display": "combined", "strategy": "bias", "mu_hd": 1.1}),
    (["--display", "combined", "--strategy", "weighted", "--weight", "0.3", "--u-max", "60"],
     {"display": "combined", "strategy": "weighted", "weight": 0.3, "u_max": 60.0}),
]


@pytest.mark.parametrize("flags,kwargs", VOLTAGE_CASES, ids=[" ".join(f) or "defaults" for f, _ in VOLTAGE_CASES])
def test_voltage_matches_the_command_line(cli, tmp_path, friction_csv, flags, kwargs):
    out = tmp_path / "u.csv"
    result = cli.run("map", "voltage", "--map", friction_csv, *flags, "-o", out)
    expected = read_csv(out)
    ny, nx = grid_of(expected)
    for source in (friction_csv, haptex.FrictionMap.read(friction_csv)):
        u = haptex.map_voltage(source, **kwargs)
        assert u.shape == (ny, nx)
        for column in ("voltage_v", "amplitude_um"):
            got = getattr(u, column)
            if column in expected:
                assert got.shape == (ny, nx)
                assert_identical(got.ravel(), expected[column], column)
            else:
                assert got is None, f"{column} is not a channel of this display"
    mine = tmp_path / "mine.csv"
    u.write(mine)
    assert_same_files(mine, out)
    assert u.to_csv() == out.read_text()
    # What the command line prints, up to the file it wrote.
    printed = [l for l in result.stderr.splitlines() if not l.startswith("wrote ")]
    assert u.summary.text.splitlines() == printed
    s = u.summary
    assert s.shape == (ny, nx)
    if u.voltage_v is not None:
        assert s.voltage_range_v == (u.voltage_v.min(), u.voltage_v.max())
        assert u.voltage_v.max() <= s.u_max_v
    if u.amplitude_um is not None:
        assert u.amplitude_um.max() <= s.a_max_um
    if kwargs.get("display", "electrovibration") == "electrovibration":
        # The NPY the command line writes, byte for byte, and its sidecar.
        cli.run("map", "voltage", "--map", friction_csv, *flags, "-o", tmp_path / "u.npy")
        u.write(tmp_path / "mine.npy")
        assert_same_files(tmp_path / "mine.npy", tmp_path / "u.npy")
        assert json.loads((tmp_path / "mine.npy.json").read_text())["u_max_v"] == s.u_max_v
    else:
        message = cli.error("map", "voltage", "--map", friction_csv, *flags, "-o", tmp_path / "u.npy")
        with pytest.raises(haptex.InvalidInputError) as caught:
            u.write(tmp_path / "u.npy")
        assert str(caught.value) == message


def test_voltage_limits_are_reported_as_areas(friction_csv):
    friction = haptex.FrictionMap.read(friction_csv)
    u = haptex.map_voltage(friction, mu_hd=1.0, u_max=100.0)
    mu = friction.mu
    assert u.summary.below_band_fraction == np.mean(mu < 1.0) > 0
    assert 0 < u.summary.above_band_fraction == np.mean(u.voltage_v == 100.0)
    assert (u.voltage_v[mu < 1.0] == 0.0).all()
    assert haptex.map_voltage(friction, method="normalized").summary.below_band_fraction is None


@pytest.mark.parametrize(
    "flags,kwargs",
    [
        (["--u-max", "0"], {"u_max": 0.0}),
        (["--mu-hd", "50"], {"mu_hd": 50.0}),
        (["--display", "ultrasonic", "--method", "normalized"], {"display": "ultrasonic", "method": "normalized"}),
        (["--strategy", "bias"], {"strategy": "bias"}),
        (["--display", "combined", "--weight", "2"], {"display": "combined", "weight": 2.0}),
        (["--a-max-um", "2"], {"a_max_um": 2.0}),
    ],
)
def test_voltage_refusals_are_value_errors(cli, tmp_path, friction_csv, flags, kwargs):
    cli.error("map", "voltage", "--map", friction_csv, *flags, "-o", tmp_path / "u.csv")
    with pytest.raises(haptex.InvalidInputError):
        haptex.map_voltage(friction_csv, **kwargs)


def test_a_bad_map_file_has_the_command_lines_message(cli, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("x_mm,y_mm,mu\n0,0,1\n1,0,1\n0,1,1\n1,1,oops\n")
    message = cli.error("map", "voltage", "--map", bad, "-o", tmp_path / "u.csv")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.map_voltage(bad)
    assert str(caught.value) == message
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.FrictionMap.read(bad)
    assert str(caught.value) == message
    wrong = tmp_path / "map.txt"
    wrong.write_text("")
    message = cli.error("map", "voltage", "--map", wrong, "-o", tmp_path / "u.csv")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.FrictionMap.read(wrong)
    assert str(caught.value) == message
    with pytest.raises(haptex.HaptexOSError):
        haptex.map_voltage(tmp_path / "nope.csv")
    with pytest.raises(haptex.InvalidInputError, match="FrictionMap or a path"):
        haptex.map_voltage(np.ones((3, 3)))


# --- sample-path -------------------------------------------------------------------------------------------------


def test_sample_path_matches_the_command_line(cli, tmp_path, friction_csv):
    u_csv = tmp_path / "u.csv"
    u_npy = tmp_path / "u.npy"
    cli.run("map", "voltage", "--map", friction_csv, "-o", u_csv)
    cli.run("map", "voltage", "--map", friction_csv, "-o", u_npy)
    t = np.linspace(0.0, 0.5, 41)
    # Across the map, on and off grid lines, and beyond its edges.
    x, y = -0.3 + 3.1 * t / 0.5, 0.8 + 0.9 * np.sin(9.0 * t)
    x[5], y[5] = 0.2 * 2, 0.2 * 4  # the grid point (2, 4): x0 + i dx, y0 + j dy
    trajectory = tmp_path / "path.csv"
    trajectory.write_text("t_s,x_mm,y_mm\n" + "".join(f"{float(a)!r},{float(b)!r},{float(c)!r}\n" for a, b, c in zip(t, x, y)))
    for voltage_map in (u_csv, u_npy):
        out = tmp_path / f"cli-{voltage_map.suffix[1:]}.csv"
        result = cli.run("map", "sample-path", "--voltage-map", voltage_map, "--trajectory", trajectory, "-o", out)
        expected = read_csv(out)
        for source in (voltage_map, haptex.VoltageMap.read(voltage_map)):
            samples = haptex.map_sample_path(source, trajectory)
            assert_identical(samples.voltage_v, expected["voltage_v"], "voltage_v")
            assert_identical(samples.t_s, t, "t_s")
            mine = tmp_path / "mine.csv"
            samples.write_csv(mine)
            assert_same_files(mine, out)
            assert samples.summary == result.stderr.splitlines()[0]
        # Arrays in: the same voltages, from the map in memory too.
        from_arrays = haptex.map_sample_path(haptex.map_voltage(friction_csv), (t, x, y))
        assert_identical(from_arrays.voltage_v, expected["voltage_v"], "voltage_v from arrays")
        assert_identical(haptex.VoltageMap.read(voltage_map).sample(x, y), expected["voltage_v"], "sample")
    assert len(from_arrays) == len(t)
    # On a grid point the map's own value, beyond the edge the edge's.
    u = haptex.map_voltage(friction_csv)
    assert from_arrays.voltage_v[5] == u.voltage_v[4, 2]
    assert from_arrays.voltage_v[0] == u.sample([0.0], [y[0]])[0]


def test_sample_path_refusals(cli, tmp_path, friction_csv):
    combined = haptex.map_voltage(friction_csv, display="combined")
    with pytest.raises(haptex.InvalidInputError, match="combined or ultrasonic display"):
        haptex.map_sample_path(combined, ([0.0, 1.0], [0.0, 0.0], [0.0, 0.0]))
    u = haptex.map_voltage(friction_csv)
    with pytest.raises(haptex.InvalidInputError, match="t_s"):
        haptex.map_sample_path(u, ([1.0, 0.0], [0.0, 0.0], [0.0, 0.0]))
    bad = tmp_path / "path.csv"
    bad.write_text("t_s,x_mm,y_mm\n0,0,0\n0,1,1\n")
    u_csv = tmp_path / "u.csv"
    u.write(u_csv)
    message = cli.error("map", "sample-path", "--voltage-map", u_csv, "--trajectory", bad)
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.map_sample_path(u_csv, bad)
    assert str(caught.value) == message
    with pytest.raises(haptex.InvalidInputError, match="tuple"):
        haptex.map_sample_path(u, 3)


# --- grating -----------------------------------------------------------------------------------------------------

DB = REPO / "data" / "db"
GRATING = ["--period-mm", "1.5", "--amplitude-mm", "0.2", "--angle-deg", "30", "--nx", "6", "--ny", "3", "--dx-mm",
           "0.3", "--dy-mm", "0.4", "--y0-mm", "-0.5"]
GRATING_KW = {"period_mm": 1.5, "amplitude_mm": 0.2, "angle_deg": 30.0, "nx": 6, "ny": 3, "dx_mm": 0.3, "dy_mm": 0.4,
              "y0_mm": -0.5}


@pytest.mark.parametrize("source", ["cae", "fe"])
def test_grating_matches_the_command_line(cli, tmp_path, source):
    # One small case each: the FE source runs the FE model once (about a second).
    cli.run("map", "grating", *GRATING, "--source", source, "--db", DB, "-o", tmp_path / "cli.csv")
    friction = haptex.map_grating(**GRATING_KW, source=source, db=DB)
    expected = read_csv(tmp_path / "cli.csv")
    assert friction.shape == (3, 6)
    assert_identical(friction.mu.ravel(), expected["mu"], "mu")
    friction.write(tmp_path / "mine.csv")
    assert_same_files(tmp_path / "mine.csv", tmp_path / "cli.csv")
    # The rows differ (each line a shifted sine), unlike an extruded profile.
    assert not (friction.mu[0] == friction.mu[1]).all()


def test_grating_refusals(cli, tmp_path):
    outside = [*GRATING[:1], "9", *GRATING[2:], "--source", "cae", "--db", DB]
    message = cli.error("map", "grating", *outside, "-o", tmp_path / "g.csv")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.map_grating(**{**GRATING_KW, "period_mm": 9.0}, source="cae", db=DB)
    assert str(caught.value) == message.replace("--source fe", 'source="fe"')
    for kwargs in ({"angle_deg": 120.0}, {"period_mm": float("nan")}, {"nx": 1}, {"dx_mm": -1.0}):
        with pytest.raises(haptex.InvalidInputError):
            haptex.map_grating(**{**GRATING_KW, **kwargs}, source="cae", db=DB)
    # Ridges along the sliding direction: every line flat, the flat friction.
    flat = haptex.map_grating(**{**GRATING_KW, "angle_deg": 90.0}, source="cae", db=DB)
    assert (flat.mu == flat.mu[0, 0]).all()


# --- compose -----------------------------------------------------------------------------------------------------


def label_image() -> np.ndarray:
    labels = np.zeros((12, 20), dtype=np.uint8)
    labels[2:8, 3:15] = 128
    labels[9:, 10:] = 255
    return labels


def test_compose_matches_the_command_line(cli, tmp_path):
    png = tmp_path / "labels.png"
    labels = label_image()
    write_gray_png(png, labels)
    polygon = "0.2,0.1;1.5,0.3;0.9,1.0"
    flags = ["--region", "0=0.5", "--region", f"128=profile:{BUMP}", "--region", "255=1.2",
             "--polygon", f"{polygon}=0.9", "--pixel-mm", "0.1", "--pixel-mm-y", "0.08", "--x0-mm", "-0.5"]
    cli.run("map", "compose", png, *flags, "-o", tmp_path / "cli.csv")
    vertices = [(0.2, 0.1), (1.5, 0.3), (0.9, 1.0)]
    expected = read_csv(tmp_path / "cli.csv")
    for image in (png, labels):
        for bump in (BUMP, haptex.Profile.read_csv(BUMP)):
            friction = haptex.map_compose(
                image, regions={0: 0.5, 128: bump, 255: 1.2}, polygons=[(vertices, 0.9)], pixel_mm=0.1,
                pixel_mm_y=0.08, x0_mm=-0.5,
            )
            assert_identical(friction.mu.ravel(), expected["mu"], "mu")
    assert (friction.mu == 0.9).any() and (friction.mu == 1.2).any() and (friction.mu == 0.5).any()
    friction.write(tmp_path / "mine.csv")
    assert_same_files(tmp_path / "mine.csv", tmp_path / "cli.csv")
    # Without labels: a base over a rectangle, then the polygon.
    cli.run("map", "compose", "--base", "0.7", "--size-mm", "2,1.5", "--polygon", f"{polygon}=profile:{BUMP}",
            "--pixel-mm", "0.1", "-o", tmp_path / "cli-base.csv")
    based = haptex.map_compose(base=0.7, size_mm=(2.0, 1.5), polygons=[(vertices, BUMP)], pixel_mm=0.1)
    assert_identical(based.mu.ravel(), read_csv(tmp_path / "cli-base.csv")["mu"], "mu on a base")


def test_compose_refusals(cli, tmp_path):
    png = tmp_path / "labels.png"
    write_gray_png(png, label_image())
    message = cli.error("map", "compose", png, "--region", "0=0.5", "--pixel-mm", "0.1", "-o", tmp_path / "m.csv")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.map_compose(png, regions={0: 0.5}, pixel_mm=0.1)
    assert str(caught.value) == message  # level 128 has no fill
    for kwargs, words in [
        ({"regions": {0: 5000.0, 128: 1, 255: 1}}, "mu"),
        ({"regions": {300: 1.0}}, "gray level"),
        ({"regions": {0: "material:sponge"}}, "material"),
        ({"regions": {0: np.nan, 128: 1, 255: 1}}, "mu"),
        ({}, "needs regions"),
    ]:
        with pytest.raises(haptex.InvalidInputError, match=words):
            haptex.map_compose(png, pixel_mm=0.1, **kwargs)
    with pytest.raises(haptex.InvalidInputError, match="2-D uint8"):
        haptex.map_compose(label_image().astype(np.uint16), regions={0: 1.0}, pixel_mm=0.1)
    with pytest.raises(haptex.InvalidInputError, match="or base"):
        haptex.map_compose(pixel_mm=0.1)
    with pytest.raises(haptex.InvalidInputError, match="vertices"):
        haptex.map_compose(base=0.7, size_mm=(1.0, 1.0), polygons=[([(0.0, 0.0), (1.0, 1.0)], 0.5)], pixel_mm=0.1)


# --- the limits, for any map and device --------------------------------------------------------------------------

cells = st.floats(min_value=-5.0, max_value=20.0, allow_nan=False)
maps = st.tuples(st.integers(2, 6), st.integers(2, 6)).flatmap(
    lambda shape: st.lists(cells, min_size=shape[0] * shape[1], max_size=shape[0] * shape[1]).map(
        lambda values: np.array(values).reshape(shape)
    )
)
devices = st.fixed_dictionaries(
    {
        "mu_hd": st.floats(0.01, 5.0),
        "u_max": st.floats(0.01, 5000.0),
        "k_mm2_per_n": st.floats(10.0, 1000.0),
        "eps_sc": st.floats(1.0, 1e5),
        "eps_i": st.floats(1.0, 1e3),
        "d_sc_mm": st.floats(1e-3, 1.0),
        "d_i_mm": st.floats(1e-4, 0.1),
    }
)
# a_max up to the literature placeholder's 2.3 um (it does not extrapolate).
displays = st.one_of(
    st.fixed_dictionaries({"method": st.sampled_from(["physical", "normalized"])}),
    st.fixed_dictionaries({"display": st.just("ultrasonic"), "a_max_um": st.floats(0.01, 2.3)}),
    st.fixed_dictionaries(
        {
            "display": st.just("combined"),
            "strategy": st.sampled_from(["split", "bias"]),
            "a_max_um": st.one_of(st.none(), st.floats(0.01, 2.3)),
        }
    ),
    st.fixed_dictionaries(
        {"display": st.just("combined"), "strategy": st.just("weighted"), "weight": st.floats(0.0, 100.0)}
    ),
)


@settings(derandomize=True, max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mu=maps, device=devices, display=displays)
def test_no_voltage_beyond_u_max_and_no_amplitude_beyond_a_max(mu, device, display):
    friction = haptex.FrictionMap(mu, dx_mm=0.1, dy_mm=0.1)
    u = haptex.map_voltage(friction, **device, **display)
    assert u.voltage_v is not None or u.amplitude_um is not None
    if u.voltage_v is not None:
        assert np.isfinite(u.voltage_v).all()
        assert (u.voltage_v >= 0.0).all() and (u.voltage_v <= device["u_max"]).all()
        assert u.summary.u_max_v == device["u_max"]
    if u.amplitude_um is not None:
        a_max = u.summary.a_max_um
        assert np.isfinite(u.amplitude_um).all()
        assert (u.amplitude_um >= 0.0).all() and (u.amplitude_um <= a_max).all()
        if display.get("a_max_um") is not None:
            assert a_max <= display["a_max_um"]
    # Sampled anywhere (bilinear between cells), still within U_max.
    if u.voltage_v is not None and display.get("display") is None:
        x = np.linspace(-1.0, 1.0, 23)
        assert (u.sample(x, x[::-1]) <= device["u_max"]).all()
