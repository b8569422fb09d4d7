"""docs/python.md runs: each ```python block of it is executed from the
repository root (each in a fresh namespace, Matplotlib without a display),
and what it says it prints or writes is checked."""

from __future__ import annotations

import contextlib
import io
import os
import re

import pytest

from conftest import REPO

DOC = REPO / "docs" / "python.md"


def blocks():
    return re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)


def test_the_doc_has_its_examples():
    assert len(blocks()) >= 3


@pytest.mark.parametrize("index", range(len(blocks())))
def test_each_example_runs(cli, tmp_path, monkeypatch, index):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    code = blocks()[index]
    # Paths in the examples are relative to the repository root; outputs go
    # to a scratch copy of the paths they name.
    monkeypatch.chdir(REPO)
    code = code.replace('"fig2.png"', repr(str(tmp_path / "fig2.png")))
    code = code.replace('"voltage.csv"', repr(str(tmp_path / "voltage.csv")))
    if '"my-display.toml"' in code:
        # The example's device file: calibrated from the shipped synthetic
        # measurements, as docs/calibration.md does.
        device = tmp_path / "my-display.toml"
        cli.run("calibrate", "--measurements", REPO / "data/examples/calibration-measurements.csv", "-o", device)
        code = code.replace('"my-display.toml"', repr(str(device)))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, f"{DOC}:block{index + 1}", "exec"), {"__name__": f"doc_block_{index}"})
    # Each `print(x)  # text` states what it prints: the printed line starts
    # with the comment's text before its first "...", ":" or " (".
    printed = out.getvalue().splitlines()
    stated = re.findall(r"print\(.*\)\s+#\s*(.*)", code)
    assert len(printed) == len(stated)
    for line, comment in zip(printed, stated):
        expected = re.split(r"\.\.\.|: | \(", comment)[0].strip()
        assert line.startswith(expected), f"printed {line!r}, the doc says {comment!r}"
    if "fig2.png" in code:
        assert (tmp_path / "fig2.png").stat().st_size > 10_000
    if "voltage.csv" in code:
        lines = (tmp_path / "voltage.csv").read_text().splitlines()
        header = next(line for line in lines if not line.startswith("#"))
        assert header == "x_mm,mu,voltage_v"
