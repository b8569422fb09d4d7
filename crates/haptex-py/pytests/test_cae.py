"""haptex.Cae, haptex.cae_loo, haptex.predict and haptex.Database against
`haptex cae predict`, `haptex cae loo`, `haptex predict` and `haptex db
loo`: the same numbers, bit for bit; NumPy's own estimate as a second
reference for eq. (10)-(11)."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import haptex
from conftest import DATA, EXAMPLES, assert_identical, read_csv

MODEL = EXAMPLES / "cae_bump_model.csv"
INPUTS = ["r_w_mm", "r_h_mm"]


def model_arrays():
    table = read_csv(MODEL)
    names = [k for k in table if k != "#"]
    b = np.column_stack([table[n] for n in INPUTS])
    outs = [n for n in names if n not in INPUTS]
    c = np.column_stack([table[n] for n in outs])
    return b, c, outs


@pytest.mark.parametrize("widths", [{"width": 0.13}, {"widths": (0.08, 0.3)}, {}])
def test_one_query_and_a_batch_match_cae_predict(cli, tmp_path, widths):
    queries = np.array([[1.2, 0.3], [0.55, 0.12], [2.4, 0.45], [1.0, 0.3]])
    flags = []
    if "width" in widths:
        flags = ["--width", str(widths["width"])]
    elif "widths" in widths:
        flags = ["--widths", ",".join(map(str, widths["widths"]))]
    at_file = tmp_path / "q.csv"
    at_file.write_text("r_w_mm,r_h_mm\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in queries))
    out = tmp_path / "p.csv"
    cli.run("cae", "predict", "--model", MODEL, "--inputs", "r_w_mm,r_h_mm", "--at-file", at_file, *flags, "-q", "-o", out)
    expected = read_csv(out)
    cae = haptex.Cae.read_csv(MODEL, INPUTS, **widths)
    batch = cae.predict_batch(queries)
    assert batch.shape == (len(queries), cae.shape[2])
    for k, name in enumerate(cae.outputs):
        assert_identical(batch[:, k], expected[name], name)
    # One query at a time: `--at` with one query, the same bits; a batch of
    # one is computed the same way.
    for i, q in enumerate(queries[:2]):
        one = tmp_path / f"one{i}.csv"
        at = f"r_w_mm={float(q[0])!r},r_h_mm={float(q[1])!r}"
        cli.run("cae", "predict", "--model", MODEL, "--inputs", "r_w_mm,r_h_mm", "--at", at, *flags, "-q", "-o", one)
        expected_one = read_csv(one)
        single = cae.predict(q)
        assert_identical(single, np.array([expected_one[name][0] for name in cae.outputs]), f"query {i}")
        assert_identical(cae.predict_batch(q[None, :])[0], single, f"batch of one, query {i}")
        np.testing.assert_allclose(single, batch[i], rtol=1e-13, atol=0)
    # The width the command line found (printed on stderr) is the same.
    if not widths:
        result = cli.run("cae", "predict", "--model", MODEL, "--inputs", "r_w_mm,r_h_mm", "--at", "r_w_mm=1,r_h_mm=0.2")
        assert f"width: {cae.widths[0]!r}"[:14] in result.stderr


def test_cae_from_arrays_is_the_csvs_and_numpy_agrees():
    b, c, outs = model_arrays()
    from_csv = haptex.Cae.read_csv(MODEL, INPUTS, width=0.13)
    from_arrays = haptex.Cae(b, c, width=0.13, input_names=INPUTS, output_names=outs)
    q = np.array([1.3, 0.27])
    assert_identical(from_arrays.predict(q), from_csv.predict(q), "arrays vs CSV")
    # Eq. (10)-(12) with constant widths written in NumPy: inputs normalized
    # to [0, 1] by their range, Gaussian weights, weighted mean. Rounding
    # differs (other summation order), so 1e-12 relative.
    lo, span = b.min(axis=0), b.max(axis=0) - b.min(axis=0)
    x = (b - lo) / span
    qn = (q - lo) / span
    a = np.exp(-0.5 * (((x - qn) / 0.13) ** 2).sum(axis=1))
    reference = (a[:, None] * c).sum(axis=0) / a.sum()
    np.testing.assert_allclose(from_arrays.predict(q), reference, rtol=1e-12, atol=0)


def test_inputs_are_read_in_place_and_strided_views_work():
    b, c, outs = model_arrays()
    cae = haptex.Cae(b, c, width=0.2)
    wide = np.zeros((3, 4))
    wide[:, 0] = [1.2, 0.9, 2.0]
    wide[:, 2] = [0.3, 0.2, 0.4]
    strided = wide[:, ::2]
    assert not strided.flags["C_CONTIGUOUS"]
    assert_identical(cae.predict_batch(strided), cae.predict_batch(np.ascontiguousarray(strided)), "strided")
    assert_identical(cae.predict(strided[1]), cae.predict(np.array([0.9, 0.2])), "strided row")
    assert_identical(cae.predict([1, 0.25]), cae.predict(np.array([1.0, 0.25])), "list of ints")


def test_refusals():
    b, c, _ = model_arrays()
    with pytest.raises(haptex.InvalidInputError, match="rows"):
        haptex.Cae(b, c[:-1], width=0.1)
    bad = b.copy()
    bad[3, 1] = np.nan
    with pytest.raises(haptex.InvalidInputError, match=r"inputs\[3, 1\]"):
        haptex.Cae(bad, c, width=0.1)
    cae = haptex.Cae(b, c, width=0.1)
    with pytest.raises(haptex.InvalidInputError):
        cae.predict([1.0, np.inf])
    with pytest.raises(haptex.InvalidInputError):
        cae.predict([1.0, 0.2, 3.0])
    with pytest.raises(haptex.InvalidInputError, match="columns"):
        cae.predict_batch(np.ones((2, 3)))
    with pytest.raises(haptex.InvalidInputError):
        haptex.Cae(b, c, width=-1.0)
    with pytest.raises(haptex.InvalidInputError, match="not both"):
        haptex.Cae(b, c, width=0.1, widths=(0.1, 0.2))


def test_an_extrapolation_warns():
    cae = haptex.Cae.read_csv(MODEL, INPUTS, width=0.05)
    with pytest.warns(haptex.ExtrapolationWarning):
        cae.predict([9.0, 3.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cae.predict([1.25, 0.3])


@pytest.mark.parametrize("flags,kwargs", [([], {}), (["--constant"], {"constant": True}), (["--width", "0.2"], {"width": 0.2})])
def test_cae_loo_is_the_command_lines_json(cli, tmp_path, flags, kwargs):
    out = tmp_path / "loo.json"
    cli.run("cae", "loo", "--model", MODEL, "--inputs", "r_w_mm,r_h_mm", *flags, "-o", out)
    assert haptex.cae_loo(MODEL, INPUTS, **kwargs) == json.loads(out.read_text())


CASES = [("bump", 5.0, 1.5, 0.3, 20.0), ("edge", 5.0, 1.5, 0.3, 20.0), ("sine", 5.0, 1.5, 0.3, 20.0),
         ("bump", 5.0, 0.5, 0.2, 20.0), ("sine", 5.0, 2.5, 0.5, 20.0), ("bump", 3.0, 1.3, 0.27, 35.0),
         ("edge", -2.5, 0.8, 0.45, 20.0)]


@pytest.mark.parametrize("surface,x0,width,height,velocity", CASES)
def test_predict_matches_haptex_predict(cli, tmp_path, surface, x0, width, height, velocity):
    out = tmp_path / "p.csv"
    cli.run("predict", "--surface", surface, "--x0", x0, "--width", width, "--height", height,
            "--velocity", velocity, "-q", "-o", out)
    expected = read_csv(out)
    p = haptex.predict(surface, x0, width, height, velocity)
    assert_identical(p.x_mm, expected["x_mm"], "x_mm")
    assert_identical(p.mu, expected["mu"], "mu")
    mine = tmp_path / "mine.csv"
    p.write_csv(mine)
    assert mine.read_bytes() == out.read_bytes()
    assert p.flat_mu == 0.5
    assert (p.fe_row is not None) == p.source.startswith("FE result")


def test_database_keeps_its_models_and_reports_loo(cli, tmp_path):
    db = haptex.Database()
    a = db.predict("bump", 5.0, 1.3, 0.27)
    b = haptex.predict("bump", 5.0, 1.3, 0.27, db=DATA / "db")
    assert_identical(a.mu, b.mu, "Database vs predict")
    result = cli.run("db", "loo", "--json", "--surface", "bump", "--width", "1.5", "--height", "0.3", "-q",
                     "-o", tmp_path / "case.csv")
    assert db.loo_summary() == json.loads(result.stderr)
    case = db.loo("bump", 1.5, 0.3)
    expected = read_csv(tmp_path / "case.csv")
    for name in ("xi_mm", "h_mm", "mu_fe", "mu_cae_loo", "mu_cae_full"):
        assert_identical(getattr(case, name), expected[name], name)
    assert case.row is not None
    assert 0 < case.rms_full < case.rms_loo
    mine = tmp_path / "mine.csv"
    case.write_csv(mine)
    assert mine.read_bytes() == (tmp_path / "case.csv").read_bytes()


def test_prediction_feeds_voltage():
    p = haptex.predict("bump", 5.0, 1.3, 0.27)
    design = haptex.voltage(p.profile(), relative=True, flat_mu=p.flat_mu)
    assert design.voltage_v.max() <= 100.0
    assert design.summary.display == "electrovibration"


def test_database_refusals(tmp_path):
    with pytest.raises(haptex.HaptexOSError, match="no FE database"):
        haptex.Database(tmp_path / "missing")
    with pytest.raises(haptex.InvalidInputError, match="no FE database"):
        haptex.Database(tmp_path)
    with pytest.raises(haptex.InvalidInputError, match="surface must be one of"):
        haptex.predict("ramp", 5.0, 1.0, 0.2)
    with pytest.raises(haptex.InvalidInputError, match="width"):
        haptex.predict("bump", 5.0, float("nan"), 0.2)
    with pytest.raises(haptex.InvalidInputError):
        haptex.predict("bump", float("inf"), 1.0, 0.2)
