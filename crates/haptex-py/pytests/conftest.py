"""Shared fixtures of the haptex Python tests.

The parity tests run the ``haptex`` command line next to the Python
function and compare the files it writes value for value. The binary is
$HAPTEX_BIN, else target/ci/haptex or target/release/haptex of this
checkout (scripts/test.sh builds target/ci/haptex before running pytest).
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path
from typing import List

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[3]
DATA = REPO / "data"
EXAMPLES = DATA / "examples"


def cli_binary() -> Path:
    given = os.environ.get("HAPTEX_BIN")
    if given:
        return Path(given)
    for profile in ("ci", "release", "debug"):
        candidate = REPO / "target" / profile / "haptex"
        if candidate.exists():
            return candidate
    pytest.fail("no haptex binary: build it (cargo build --profile ci) or set HAPTEX_BIN")


class Cli:
    """Runs `haptex ARGS...` in a directory and reads what it writes."""

    def __init__(self, binary: Path, cwd: Path):
        self.binary = binary
        self.cwd = cwd

    def run(self, *args: str, check: bool = True) -> subprocess.CompletedProcess:
        result = subprocess.run(
            [str(self.binary), *map(str, args)],
            cwd=self.cwd,
            capture_output=True,
            text=True,
            stdin=subprocess.DEVNULL,
        )
        if check and result.returncode != 0:
            raise AssertionError(f"haptex {' '.join(map(str, args))} failed:\n{result.stderr}")
        return result

    def error(self, *args: str) -> str:
        """The message after `error: ` of a command that must fail."""
        result = self.run(*args, check=False)
        assert result.returncode != 0, f"haptex {' '.join(map(str, args))} did not fail"
        lines = [l for l in result.stderr.splitlines() if l.startswith("error: ")]
        assert lines, result.stderr
        return lines[-1][len("error: "):]


@pytest.fixture(scope="session")
def cli(tmp_path_factory) -> Cli:
    return Cli(cli_binary(), tmp_path_factory.mktemp("cli"))


def read_csv(path: Path) -> dict:
    """A haptex CSV file's columns by name, as float64 arrays (full
    precision: Rust's shortest round-trip text reads back to the same
    double), and its comment lines."""
    comments: List[str] = []
    rows: List[List[float]] = []
    header = None
    for line in Path(path).read_text().splitlines():
        if line.startswith("#"):
            comments.append(line[1:].strip())
        elif line.strip():
            if header is None:
                header = [h.strip() for h in line.split(",")]
            else:
                rows.append([float(v) for v in line.split(",")])
    assert header is not None, f"{path}: no header"
    table = np.array(rows, dtype=np.float64).reshape(len(rows), len(header))
    out = {name: table[:, i].copy() for i, name in enumerate(header)}
    out["#"] = comments
    return out


def assert_identical(actual, expected, what: str) -> None:
    """Bit-identical float arrays (NaN never allowed)."""
    actual = np.asarray(actual, dtype=np.float64)
    expected = np.asarray(expected, dtype=np.float64)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} vs {expected.shape}"
    assert not np.isnan(actual).any(), f"{what}: NaN"
    differ = np.flatnonzero(actual.view(np.uint64) != expected.view(np.uint64))
    assert differ.size == 0, (
        f"{what}: {differ.size} values differ, first at {differ[0]}: {actual[differ[0]]!r} vs {expected[differ[0]]!r}"
    )


# What the package's messages say where the command line's name a flag
# (haptex_core::arg_names::ArgNames::PYTHON against ::CLI).
KEYWORDS = {
    "--a-max-um": "a_max_um",
    "--u-max": "u_max",
    "--display electrovibration": "display='electrovibration'",
    "`haptex voltage --device`": "haptex.voltage(..., device=...)",
}


def in_keywords(message: str) -> str:
    """A command-line message in the words of the Python keywords."""
    message = re.sub(r"--carrier (\w+) --carrier-hz (\S+?)(?=[ )]|$)", r'carrier="\1", carrier_hz=\2', message)
    for flag, keyword in KEYWORDS.items():
        message = message.replace(flag, keyword)
    return message
